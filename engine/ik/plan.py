"""The IK plan: which particles, constraints, spine splines and aim groups exist for one
creature and one set of goal bodies (Hecker et al. 2008, sections 4.3.1 to 4.3.3).

Built once per (creature, goal bodies, parameters) and cached by ``plan_for``; immutable.
The arrays the kernels read are packed into flat blobs (``plan_i`` int32, ``plan_f``,
``plan_f3``, ``plan_f4`` float64, see ``engine.ik._kernels.INT_FIELDS`` / ``FLOAT_FIELDS``) and are also
readable by name as read-only views: ``plan.arrays.sc_len`` and so on.

Who is solved (section 4.3.1): a body "has IK" when it or a body below it has a goal; the
root always has IK. The solver writes the world pose of every body in ``plan.ik_bodies``
and leaves ``plan.free_bodies`` (the sub-trees without IK) untouched: they belong to the
caller (secondary motion, section 4.4). ``pose_free_rigid`` places them rigidly on their
parents for tools and tests.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import weakref
from dataclasses import asdict, dataclass, fields, replace

import numpy as np

from engine.errors import DataError
from engine.ik import _kernels as K
from engine.ik import selfcollision
from engine.model.caps import FOOT, GRASPER, HEAD, MOUTH


class IKError(DataError):
    """Bad input to the IK solver (goal bodies, arrays of the wrong shape, non-finite goals)."""


@dataclass(frozen=True)
class IKParams:
    """Tuning of the solver; defaults in one place. Angles in radians, ratios of rest length."""

    spine_outer: int = 5          # outer iterations of the spine phase (the paper's 5)
    spine_inner: int = 2          # constraint sweeps per outer iteration
    limb_outer: int = 6           # outer iterations of the limb phase
    limb_inner: int = 2           # sweeps per limb outer iteration (then an outward projection)
    soft_slope: float = 0.5       # share of a small length error removed per sweep
    soft_band: float = 0.01       # relative error below which the constraint is soft
    soft_width: float = 0.04      # width of the C1 blend from soft to full correction
    spine_shrink: float = 0.9     # spine constraints project to [shrink, stretch] (the paper's 10%/120%)
    spine_stretch: float = 1.2
    chord_compress: float = 0.1   # simplified limbs may compress to 10% in the spine phase
    limb_shrink: float = 0.98     # limb constraints project to [shrink, stretch]
    limb_stretch: float = 1.02
    spine_rootward_invmass: float = 0.5  # rootward end of a spine constraint moves half as much
    limb_child_invmass: float = 0.25  # outer end of a limb constraint moves less: inward sweeps drag the
                                      # parents toward the goal (FABRIK-like), long chains settle faster
    buckle_on: float = math.radians(60.0)    # spine fold (over rest) where anti-buckling starts
    buckle_full: float = math.radians(100.0)  # ... and where it is fully on
    anti_buckling: bool = True
    root_influence: float = 0.1   # share of the spine children's swing given to the root rotation
    soft_reach: float = 0.97      # past this fraction of full reach a serial limb's bend is eased and the
                                  # rest met by stretching (no knee pop); 1 = exact up to full reach
    transport_substeps: int = 2   # minimal-twist steps between spline samples
    straight_bend: float = 0.03   # bend hint for straight rest chains, fraction of segment length
    fork_splay: float = 0.15      # splay hint for planar forks (branching legs), fraction of the fork's segment
    spline_regularization: float = 1e-3
    self_collision: bool = False  # limbs pushed out of the creature's other bodies in the limb phase (issue 16)
    self_collision_rounds: int = 2  # push-and-project rounds after the limb iterations (engine/ik/_collide.py)
    self_collision_iterate: bool = False  # contacts also pushed inside the limb iterations with the goals held
                                          # (routes limbs round the body; more flips: engine/ik/NOTES.md)
    goal_aim: int = 1             # a spine body held at a goal swings to point at its outward neighbour as far
                                  # as the goal leaves it free: 1 by position x rotation weight, 0 by position
                                  # weight alone (see ``_aim_at_child``)
    root_pin: bool = True        # a spine body hanging off the root keeps its joint where the root puts it
    spine_pull_cap: float = 0.5   # a goal's pull on a spine particle per sweep eased past this times the particle's
                                  # chord to its rootward neighbour (0: off; see ``_flush_acc``)
    foot_priority: float = 0.0    # where feet and other goals pull one spine particle, the others' share of a
                                  # pull (1: equal shares; below 1 the feet win, so a grasper past its reach does
                                  # not lift the feet it stands on)
    aim_via: bool = True          # a limb's aim turns it through forward (no flip for goals opposite its
                                  # rest direction; the one ill-defined aim is straight behind): ``_aim_via``.
    spine_brace: bool = True      # a spine body held at a goal keeps its origin's rest distance to its child's joint
    ground: bool = False          # every body's box kept above the ground plane passed to the solve (character
                                  # space; z = 0 by default), down to its floor ``body_floor`` (issues 12/16)
    ground_spine: bool = True     # with ``ground`` off, the spine phase alone keeps spine bodies' boxes above the
                                  # ground (a snake lifting its head no longer sinks its neck 0.9 of its height)
    parent_twist: bool = True     # limb bodies below a limb's root are rebuilt from their parent's frame through a
                                  # chord bent 45 degrees into their bend, so their one ill-defined chord is a joint
                                  # bent 135 degrees against its bend, not the rest chord reversed (``_rebuild_refs``)

    def vector(self) -> np.ndarray:
        v = np.zeros(K.NPARAM)
        v[K.P_SPINE_OUTER] = self.spine_outer
        v[K.P_SPINE_INNER] = self.spine_inner
        v[K.P_LIMB_OUTER] = self.limb_outer
        v[K.P_LIMB_INNER] = self.limb_inner
        v[K.P_SOFT_SLOPE] = self.soft_slope
        v[K.P_SOFT_BAND] = self.soft_band
        v[K.P_SOFT_WIDTH] = self.soft_width
        v[K.P_BUCKLE_ON] = self.buckle_on
        v[K.P_BUCKLE_FULL] = self.buckle_full
        v[K.P_ANTI_BUCKLING] = 1.0 if self.anti_buckling else 0.0
        v[K.P_ROOT_INFLUENCE] = self.root_influence
        v[K.P_SUBSTEPS] = self.transport_substeps
        v[K.P_SOFT_REACH] = self.soft_reach
        v[K.P_LIMB_STRETCH] = self.limb_stretch
        v[K.P_GOAL_AIM] = self.goal_aim
        v[K.P_ROOT_PIN] = 1.0 if self.root_pin else 0.0
        v[K.P_GROUND] = 1.0 if self.ground else (0.5 if self.ground_spine else 0.0)
        v[K.P_CONTACT_ITERATE] = 1.0 if self.self_collision_iterate else 0.0
        v[K.P_PULL_CAP] = self.spine_pull_cap
        return v

    def validate(self) -> None:
        for name, value in asdict(self).items():
            if isinstance(value, bool):
                continue
            if not np.isfinite(value) or value < 0:
                raise IKError(f"IK parameter must be a finite number >= 0, got {value!r}", field=name,
                              subject=None)
        for name in ("spine_outer", "spine_inner", "limb_outer", "limb_inner", "transport_substeps",
                     "self_collision_rounds"):
            if int(getattr(self, name)) != getattr(self, name) or getattr(self, name) < 1:
                raise IKError(f"must be a whole number >= 1, got {getattr(self, name)!r}", field=name)
        if not 0.0 < self.soft_slope <= 1.0:
            raise IKError(f"must be in (0, 1], got {self.soft_slope}", field="soft_slope")
        if self.soft_width <= 0.0:
            raise IKError("must be > 0", field="soft_width")
        if not self.spine_shrink <= 1.0 <= self.spine_stretch:
            raise IKError("spine_shrink <= 1 <= spine_stretch is required", field="spine_shrink")
        if not self.limb_shrink <= 1.0 <= self.limb_stretch:
            raise IKError("limb_shrink <= 1 <= limb_stretch is required", field="limb_shrink")
        if not 0.0 < self.soft_reach <= 1.0:
            raise IKError("must be in (0, 1] (1 turns the easing off)", field="soft_reach")
        if not 0.0 <= self.foot_priority <= 1.0:
            raise IKError("must be in [0, 1]", field="foot_priority")
        if not 0.0 < self.chord_compress <= 1.0:
            raise IKError("must be in (0, 1]", field="chord_compress")
        if self.goal_aim not in (0, 1):
            raise IKError(f"must be 0 or 1, got {self.goal_aim!r}", field="goal_aim")
        if self.buckle_full <= self.buckle_on:
            raise IKError("buckle_full must be greater than buckle_on", field="buckle_full")


DEFAULT_PARAMS = IKParams()

_DEFAULTS: contextvars.ContextVar = contextvars.ContextVar("menagerie_ik_params", default=None)


def default_params() -> IKParams:
    """The IKParams a ``Character`` made without ``ik_params`` gets: ``DEFAULT_PARAMS``, or
    what the innermost ``ik_defaults`` block around it set."""
    p = _DEFAULTS.get()
    return DEFAULT_PARAMS if p is None else p


@contextlib.contextmanager
def ik_defaults(params: IKParams):
    """Inside the block, characters made without ``ik_params`` solve with ``params`` (the
    validation grid's ``--ik``: every character a cell makes, the scrubbed ones too)."""
    if not isinstance(params, IKParams):
        raise IKError(f"ik_defaults takes an IKParams, got {type(params).__name__}", field="params")
    token = _DEFAULTS.set(params)
    try:
        yield params
    finally:
        _DEFAULTS.reset(token)


def params_to_strings(params: IKParams, base: IKParams = DEFAULT_PARAMS) -> list[str]:
    """The ``NAME=VALUE`` strings that make ``params`` from ``base`` (``params_from_strings``'s
    inverse): what a grid cell's reproduce command passes as ``--ik``."""
    out = []
    for f in fields(IKParams):
        v = getattr(params, f.name)
        if v != getattr(base, f.name):
            out.append(f"{f.name}={str(v).lower() if isinstance(v, bool) else repr(v)}")
    return out


def params_from_strings(items, base: IKParams = DEFAULT_PARAMS) -> IKParams:
    """``base`` with fields set from ``NAME=VALUE`` strings (``self_collision=true``,
    ``limb_outer=8``), as a command line gives them; an unknown name, a value of the wrong
    kind or one ``IKParams`` refuses is an ``IKError`` naming the item."""
    names = {f.name: f for f in fields(IKParams)}
    changes = {}
    for item in items:
        name, sep, text = str(item).partition("=")
        name, text = name.strip(), text.strip()
        if not sep or name not in names:
            raise IKError(f"'{item}': expected NAME=VALUE with NAME one of {', '.join(sorted(names))}",
                          field=name or str(item))
        cur = getattr(base, name)
        try:
            if isinstance(cur, bool):
                if text.lower() not in ("true", "false", "1", "0", "on", "off", "yes", "no"):
                    raise ValueError(text)
                value = text.lower() in ("true", "1", "on", "yes")
            elif isinstance(cur, int):
                value = int(text)
            else:
                value = float(text)
        except ValueError:
            raise IKError(f"'{item}': {name} takes a {type(cur).__name__}, got '{text}'", field=name) from None
        changes[name] = value
    out = replace(base, **changes)
    out.validate()
    return out


def _aim_via(lp, ag_pivot, ag_goal, goal_lp, goal_lpj, rr_rot) -> np.ndarray:
    """(ngroup, 3) the direction each limb root's aim turns its limb through, in the frame
    of the spine body it hangs from (zero for the groups inside a limb: a fork's branches
    keep the shortest arc).

    The aim (``_limb_phase``) turns a limb so its goal particles point at their goals.
    The shortest arc from the rest direction u to the goal direction v is ill-defined
    where v = -u, and that is where a hanging arm's hand goes to the mouth or over the
    head: the arm turned over between two frames (the humanoid's ``wave``: 2.9 rad). No
    choice is smooth for every v (a rotation taking u to each v, continuous in v, does
    not exist on the whole sphere), so the ill-defined direction is put where goals
    rarely go: the aim is the arc from u to w, then from w to v, with w the creature's
    forward across the limb (its component perpendicular to u; up, across it, for a
    limb that points forward or back at rest: a tail, a snout). It is ill-defined only
    at v = -w: straight behind a hanging limb. For v in the plane of u and w (reaching
    forward, raising the arm in front) it is the shortest arc; elsewhere it differs by a
    twist about v that grows from zero near the rest direction (a foot goal a little to
    the side twists the leg by about as much as it leans)."""
    out = np.zeros((len(ag_pivot), 3))
    for g, (pivot, gl) in enumerate(zip(ag_pivot, ag_goal, strict=True)):
        if lp[pivot]["parent"] >= 0:
            continue
        ends = [lp[goal_lpj[k] if goal_lpj[k] >= 0 else goal_lp[k]]["init"] for k in gl if goal_lp[k] >= 0]
        if not ends:
            continue
        u = np.mean(ends, axis=0) - lp[pivot]["init"]
        if np.linalg.norm(u) < 1e-9:
            continue
        u = u / np.linalg.norm(u)
        qs_inv = _qconj(rr_rot[lp[pivot]["attach"]])
        for axis in ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)):
            a = _qrot(qs_inv, np.array(axis))
            w = a - (a @ u) * u
            if np.linalg.norm(w) >= 0.5:  # u within 60 degrees of perpendicular to it
                out[g] = w / np.linalg.norm(w)
                break
    return out


#: A joint folded further than this at rest (cosine of its bend; 120 degrees) keeps the
#: paper's reference: the IK folds such a joint through its fold line and opens it on the
#: other side (the mantis's raptorial claw, folded 172 degrees at rest, opened straight to
#: strike), sweeping more than half a turn in its bend plane, so any reference direction
#: in that plane is crossed (measured: raptortibia 0.8-2.1 rad in one frame over 9 mantis
#: cells with it).
FOLDED_COS = -0.5


def _rebuild_refs(c, lp, rr_rot, feet, on: bool) -> tuple[np.ndarray, np.ndarray]:
    """(nlp, 3) reference chord directions and (nlp, 4) reference rotations of the limb
    rebuild (``_limb_rebuild``), each in the frame of the particle's parent body.

    The rebuild turns a body from a reference rotation by the shortest arc that takes the
    reference chord to the posed chord. The paper's reference is the rest pose carried by
    the spine, so a body is ill-defined where its chord points opposite its rest chord, and
    that is where a hanging forearm goes when the hand comes to the mouth or over the head:
    the body turned over between two frames (longspine's hand_to_mouth: 1.85 rad). No
    reference is smooth for every chord (a rotation taking d to each p, continuous in p,
    does not exist on the whole sphere), and blending two references is not continuous
    either (near one's singular chord their twists differ by any angle), so each body gets
    one reference direction d, fixed at plan time, whose opposite is a pose limbs do not
    take: a body below its limb's root is carried by its parent (a joint's twist is its
    own, as an elbow or a knee has it), and d is its chord bent 45 degrees from straight
    into the side the joint bends (its rest bend; for a joint straight at rest, the side
    the bend hint bends it). Straight and fully folded are 45 and 135 degrees from d, a
    bend in the plane of d is a turn about the joint's hinge axis with no twist, and the
    singular pose is the joint bent 135 degrees against its own bend.

    The reference rotation is the rest rotation turned by the shortest arc from the rest
    chord to d, so the rest pose is exact. Left to the paper's rule (a zero direction):
    limb roots (their chord is set by the aim, ``_aim_via``, whose own singular direction
    is behind; a root reference through forward was tried and changed nothing there: the
    root flips left in the grid are particles jumping, not the rebuild), joints folded
    past ``FOLDED_COS`` at rest, rigid bodies, the branches of a fork (the fork body's frame
    comes from two of its children's chords and turns fast as a branching leg splays:
    random creature 10162's toe segment turned 0.86 rad in one frame carried by it), and
    leaves held at their origin by a tip
    particle (a hand with a position goal: its chord is the few millimetres from its joint
    to its origin, and where the wrist particle wanders the parent's frame put it on the
    new singular chord: a capture's RightHand turned 2.8 rad in one frame as dance's goal
    faded in)."""
    n = len(lp)
    ref_dir = np.zeros((n, 3))
    ref_rot = np.zeros((n, 4))
    ref_rot[:, 0] = 1.0
    if not on:
        return ref_dir, ref_rot
    for i, P in enumerate(lp):
        if P["mode"] not in (0, 1) or P["c1"] < 0 or lp[P["c1"]].get("tip"):
            continue
        b, s = P["body"], P["attach"]
        qa = rr_rot[s]
        r = _qrot(qa, lp[P["c1"]]["local"] - P["local"])      # rest chord, root-relative
        nr = float(np.linalg.norm(r))
        if nr < 1e-9:
            continue
        r = r / nr
        if P["parent"] < 0 or lp[P["parent"]]["mode"] == 1:
            continue
        ref = lp[P["parent"]]["body"]
        sv = _qrot(qa, P["local"] - lp[P["parent"]]["local"])   # the parent's bone
        ns = float(np.linalg.norm(sv))
        if ns < 1e-9:
            continue
        sh = sv / ns
        if float(r @ sh) < FOLDED_COS:
            continue
        h = r - (r @ sh) * sh
        if float(np.linalg.norm(h)) < 0.05:
            # straight (or folded flat) at rest: the side the bend hint bends it to
            # (the joint moves forward for legs, back otherwise: its child bends the
            # other way)
            leg = bool(np.any(feet[b:int(c.body_subtree_end[b])]))
            hint = np.array([1.0 if leg else -1.0, 0.0, 0.0])
            h = -(hint - (hint @ sh) * sh)
            if float(np.linalg.norm(h)) < 0.3:
                h = np.array([0.0, 0.0, 1.0]) - sh[2] * sh
        h = h / np.linalg.norm(h)
        d = (sh + h) / math.sqrt(2.0)
        qr_inv = _qconj(rr_rot[ref])
        d_ref = _qrot(qr_inv, d)
        r_ref = _qrot(qr_inv, r)
        rel = _qmul(qr_inv, rr_rot[b])
        ref_dir[i] = d_ref / np.linalg.norm(d_ref)
        ref_rot[i] = _qmul(np.array(K.qbetween(tuple(r_ref), tuple(ref_dir[i]))), rel)
    return ref_dir, ref_rot


def _param_vector(prm: IKParams, held_forks: int):
    """The kernel's parameter vector for one plan. A fork whose branches all end on held
    feet or graspers settles more slowly than a serial chain bends: its branch point is dragged by
    two children in turn, and a fork swinging out of its plane turns only through the
    small splay. Plans with such forks get twice the limb iterations: with 6 a held-out
    branching-leg walker's planted toes slid 1.9 mm, with 12 none did; the forkstrider's
    planted feet slid 1.4% of its leg as a crouch bent its straight forked legs (12
    iterations: none; first given only to forks in the plane of their ends, stop 41 to
    every held fork). Plans without forks (most creatures, the benchmark humanoid) keep
    the default cost."""
    v = prm.vector()
    if held_forks:
        v[K.P_LIMB_OUTER] = 2 * prm.limb_outer
    return v


# -- numpy quaternion helpers (plan time only) ------------------------------------------


def _qmul(a, b):
    return np.array(K.qmul(tuple(a), tuple(b)))


def _qconj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _qrot(q, v):
    return np.array(K.qrot(tuple(float(x) for x in q), tuple(float(x) for x in v)))


def fit_quintic(points: np.ndarray, ts: np.ndarray, regularization: float = 1e-3):
    """Least-squares quintic Hermite through ``points`` (m, 3) at parameters ``ts`` with
    its ends pinned to the first and last point (section 4.3.2, "Spine Splines"). The
    unknown end tangents and accelerations are pulled weakly toward a straight segment
    (tangent = chord, acceleration 0) so short chains with fewer than 4 interior points
    still give one answer. Returns (v0, a0, v1, a1)."""
    points = np.asarray(points, float)
    p0, p1 = points[0], points[-1]
    chord = p1 - p0
    H = np.array([K.hermite5_basis(float(t)) for t in ts])
    rhs = points - np.outer(H[:, 0], p0) - np.outer(H[:, 3], p1)
    A = H[:, [1, 2, 4, 5]]
    lam = math.sqrt(regularization)
    A = np.vstack([A, lam * np.eye(4)])
    rhs = np.vstack([rhs, lam * np.array([chord, np.zeros(3), chord, np.zeros(3)])])
    x = np.linalg.lstsq(A, rhs, rcond=None)[0]
    return x[0], x[1], x[2], x[3]


def body_floor(c) -> np.ndarray:
    """(nbody,) the lowest each body's box corner may go relative to the ground, m: 0, or
    lower where the box dips into the ground (z = 0) in the rest pose, so the rest pose
    itself is never moved. The one rule for goals (``engine._runtime_kernels.goals_above_ground``)
    and for the IK's ground constraint."""
    signs = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
    low = np.array([float(c.body_rest_pos[b, 2]) + min(_qrot(c.body_rest_rot[b], s * c.body_extent[b])[2]
                                                        for s in signs) for b in range(c.nbody)])
    return np.minimum(low, 0.0)


# -- the plan ---------------------------------------------------------------------------


class IKPlan:
    """Particles, constraints, spine splines, limb chains and aim groups of one creature
    for one set of goal bodies. Immutable. Fields:

    creature, goal_bodies (tuple, ascending), params (IKParams)
    plan_i, plan_f, plan_f3, plan_f4   the packed blobs the kernels read (``blobs``)
    arrays                the same as a ``PlanArrays`` NamedTuple of read-only views
    has_ik (nbody,) bool  bodies in the IK sub-tree
    ik_bodies (k,) int32  bodies the solver writes (root, IK spine bodies, delegated
                          bodies, IK limb bodies)
    free_bodies (m,) int32 bodies left to the caller
    delegated {body: spine parent}  goals handed to the spine (mouths, heads)
    self_collision_pairs (p, 2) int64  body pairs the limb phase keeps apart (empty with
                          ``params.self_collision`` off; ``engine.ik.selfcollision``)
    scratch_shape         shape of the (rows, 3) float64 scratch a solve needs
    """

    def __init__(self, creature, goal_bodies, params: IKParams = DEFAULT_PARAMS):
        params.validate()
        self.creature = creature
        self.params = params
        goals = _check_goal_bodies(creature, goal_bodies)
        self.goal_bodies = tuple(goals)
        fields, info = _build(creature, goals, params)
        self.has_ik = info["has_ik"]
        self.delegated = info["delegated"]
        self.ik_bodies = np.flatnonzero(self.has_ik).astype(np.int32)
        self.free_bodies = np.flatnonzero(~self.has_ik).astype(np.int32)
        self.spine_branch_bodies = tuple(info["branch_bodies"])
        self.self_collision_pairs = info["cl_pairs"]
        self.plan_i, self.plan_f, self.plan_f3, self.plan_f4, rows = _pack(fields)
        self.scratch_shape = (rows, 3)
        for a in (self.has_ik, self.ik_bodies, self.free_bodies, self.self_collision_pairs, self.plan_i,
                  self.plan_f, self.plan_f3, self.plan_f4):
            a.flags.writeable = False
        self.blobs = (self.plan_i, self.plan_f, self.plan_f3, self.plan_f4)
        self._checked = None  # the arrays solve_ik last validated (see solve_ik)
        self._entry = None    # the compiled solve for their types (None: not looked up yet)
        self.arrays = K.PlanArrays(**{k: _ro(v) for k, v in _views(*self.blobs).items()})

    @property
    def nbody(self) -> int:
        return self.creature.nbody

    def counts(self) -> dict[str, int]:
        a = self.arrays
        return {
            "spine_particles": int(np.sum(a.sp_kind == 1)) + 1,
            "spine_constraints": int(np.sum(a.sc_kind != 3)),
            "spine_splines": int(a.seg_a.shape[0]),
            "limb_particles": int(a.lp_body.shape[0]),
            "limb_constraints": int(a.lc_a.shape[0]),
            "goals": len(self.goal_bodies),
            "ik_bodies": int(self.ik_bodies.shape[0]),
        }

    def make_scratch(self, n: int | None = None) -> np.ndarray:
        """A scratch buffer for ``solve_ik`` (one buffer serves a whole batch too)."""
        return np.zeros(self.scratch_shape)

    def __repr__(self) -> str:
        names = [self.creature.body_names[g] for g in self.goal_bodies]
        return f"IKPlan('{self.creature.name}', goals={names}, {self.counts()})"


def _ro(a):
    a = a.view()
    a.flags.writeable = False
    return a


_cache: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def plan_for(creature, goal_bodies, params: IKParams = DEFAULT_PARAMS) -> IKPlan:
    """The cached plan for (creature, set of goal bodies, params). Goal bodies may be
    indices or names."""
    key = (frozenset(_check_goal_bodies(creature, goal_bodies)), params)
    per = _cache.setdefault(creature, {})
    plan = per.get(key)
    if plan is None:
        plan = IKPlan(creature, key[0], params)
        per[key] = plan
    return plan


def _check_goal_bodies(creature, goal_bodies) -> list[int]:
    out = set()
    for g in goal_bodies:
        if isinstance(g, str):
            try:
                g = creature.body(g)
            except KeyError as e:
                raise IKError(str(e.args[0]), subject=g, field="goal_bodies") from None
        if isinstance(g, bool) or not isinstance(g, (int, np.integer)):
            raise IKError(f"goal body must be a body index or name, got {g!r}", field="goal_bodies")
        g = int(g)
        if not 0 <= g < creature.nbody:
            raise IKError(f"goal body index {g} is outside 0..{creature.nbody - 1} of creature "
                          f"'{creature.name}'", field="goal_bodies")
        if g == 0:
            raise IKError("the root is forward-kinematically controlled and cannot have an IK "
                          "goal; set root_pos/root_rot instead", subject=creature.body_names[0],
                          field="goal_bodies")
        out.add(g)
    return sorted(out)


def _build(c, goals: list[int], prm: IKParams):
    n = c.nbody
    parent = c.body_parent
    is_spine = c.body_is_spine
    caps = c.body_caps
    rr_rot = c.body_rootrel_rot
    rr_pos = c.body_rootrel_pos
    rr_joint = c.body_rootrel_joint
    goal_set = set(goals)
    slot_of = {g: k for k, g in enumerate(goals)}

    # Delegated goals (4.3.1): a mouth or head hanging off a spine body hands its goal to
    # that spine body so the spine bends, unless the spine body is the root (which the
    # solver does not move) or bodies below it have goals of their own.
    delegated: dict[int, int] = {}
    for g in goals:
        p = int(parent[g])
        if (not is_spine[g] and (int(caps[g]) & (MOUTH | HEAD)) and p > 0 and is_spine[p]
                and not any(h in goal_set for h in range(g + 1, int(c.body_subtree_end[g])))):
            delegated[g] = p

    # The IK sub-tree.
    has_ik = np.zeros(n, bool)
    has_ik[0] = True
    for g in goals:
        j = g
        while j >= 0 and not has_ik[j]:
            has_ik[j] = True
            j = int(parent[j])

    # Spine sides, outward from the root, restricted to bodies with IK.
    chain = [int(s) for s in c.spine_chain]
    ri = c.spine_root_index
    sides = [[s for s in chain[ri + 1:] if has_ik[s]], [s for s in reversed(chain[:ri]) if has_ik[s]]]
    nonspine_ik_child = np.zeros(n, bool)
    for b in range(1, n):
        if has_ik[b] and not is_spine[b]:
            nonspine_ik_child[parent[b]] = True

    sp_kind, sp_body, sp_rest = [0], [0], [np.zeros(3)]
    sp_of = {0: 0}
    sc = []  # dicts: a, b, kind, len, lo, hi, plo, phi, inva, invb, depth
    ch = []  # chain slots
    segs = []
    branch_bodies = []
    side_cons = []
    for side in sides:
        # A spine body whose parent is held at a goal is a particle too (when the brace is on):
        # the brace below keeps it where that rigid parent can point at it. So is the root's
        # spine child: a spline from the root starts with the root's frame as given (the
        # game's), and a body inside it (a waist or belly between the root and the first
        # branch) was put where that frame's tangent sends it, up to 0.46 of its bone off its
        # parent's frame when the root leans away from the spine's bend.
        branches = [s for k, s in enumerate(side) if s in goal_set or nonspine_ik_child[s] or k == len(side) - 1
                    or k == 0
                    or (prm.spine_brace and int(parent[s]) in goal_set and int(parent[s]) != 0)]
        cons = []
        prev_body, prev_p, prev_k = 0, 0, -1
        for depth, s in enumerate(branches, start=1):
            p = len(sp_kind)
            sp_kind.append(1)
            sp_body.append(s)
            sp_rest.append(rr_joint[s].copy())
            sp_of[s] = p
            branch_bodies.append(s)
            L = float(np.linalg.norm(rr_joint[s] - sp_rest[prev_p]))
            ci = len(sc)
            sc.append(dict(a=prev_p, b=p, kind=0, len=L, lo=1.0, hi=1.0, plo=prm.spine_shrink,
                           phi=prm.spine_stretch, inva=0.0 if prev_p == 0 else prm.spine_rootward_invmass,
                           invb=1.0, depth=depth))
            cons.append(ci)
            interior = side[side.index(prev_body) + 1 if prev_body != 0 else 0: side.index(s)]
            segs.append(dict(A=prev_body, B=s, a=prev_p, b=p, interior=interior))
            ch.append(dict(particle=p, prev=prev_p, prev_k=prev_k, next=-1, con=ci, seg=len(segs) - 1,
                           depth=depth))
            if prev_k >= 0:
                ch[prev_k]["next"] = p
            prev_body, prev_p, prev_k = s, p, len(ch) - 1
        side_cons.append(cons)

    # Goals in the spine phase: delegated goals (rigid) and simplified limbs (4.3.2).
    goal_sp = np.full(len(goals), -1, np.int32)
    goal_limb_root = np.full(len(goals), -1, np.int32)
    dg = []
    for g in goals:
        k = slot_of[g]
        if is_spine[g]:
            off = float(np.linalg.norm(c.body_joint_offset[g]))
            if off <= 1e-9:
                goal_sp[k] = sp_of[g]
                continue
            # A spine body whose origin is off its joint holds its goal with a particle at
            # its origin, rigidly chorded to its spine particle: delegated to itself. The
            # reconstruction swings the body so the chord points at that particle.
            p = len(sp_kind)
            sp_kind.append(2)
            sp_body.append(g)
            sp_rest.append(rr_pos[g].copy())
            goal_sp[k] = p
            goal_limb_root[k] = -2
            depth = next((x["depth"] for x in ch if x["particle"] == sp_of[g]), 0) + 1
            sc.append(dict(a=sp_of[g], b=p, kind=2, len=off, lo=1.0, hi=1.0, plo=1.0, phi=1.0, inva=1.0,
                           invb=1.0, depth=depth))
            dg.append(dict(body=g, goal=k, particle=p, spine_particle=sp_of[g], chord=c.body_joint_offset[g].copy(),
                           rel_rot=np.array([1.0, 0.0, 0.0, 0.0])))
            # Brace: the body is rigid, so its origin and its outward spine child's joint
            # keep their rest distance too. Without it the spine phase is free to put that
            # joint anywhere on its chord's sphere, and a body held at its goal cannot
            # point at it without taking its origin off the goal (a gap at the child).
            for x in (ch if prm.spine_brace else ()):
                if x["prev"] == sp_of[g] and int(parent[sp_body[x["particle"]]]) == g:
                    y = sp_body[x["particle"]]
                    L = float(np.linalg.norm(rr_joint[y] - rr_pos[g]))
                    if L > 1e-9:
                        sc.append(dict(a=p, b=x["particle"], kind=0, len=L, lo=1.0, hi=1.0, plo=1.0, phi=1.0,
                                       inva=1.0, invb=1.0, depth=depth))
            continue
        limb_root = int(c.limb_root[c.body_limb[g]])
        if g in delegated:
            sp = sp_of[delegated[g]]
            goal_limb_root[k] = 0  # rotation estimate: aimed along the chord from the root
        else:
            goal_limb_root[k] = limb_root
            sp = sp_of[int(c.body_spine_attach[g])]
        L = float(np.linalg.norm(rr_joint[g] - sp_rest[sp]))
        if L < 1e-9:
            continue
        p = len(sp_kind)
        sp_kind.append(2)
        sp_body.append(g)
        sp_rest.append(rr_joint[g].copy())
        goal_sp[k] = p
        depth = next((s["depth"] for s in ch if s["particle"] == sp), 0) + 1
        if g in delegated:
            sc.append(dict(a=sp, b=p, kind=2, len=L, lo=1.0, hi=1.0, plo=1.0, phi=1.0, inva=1.0,
                           invb=1.0, depth=depth))
            s_body = delegated[g]
            dg.append(dict(body=g, goal=k, particle=p, spine_particle=sp,
                           chord=c.body_local_joint[g] + c.body_joint_offset[s_body], rel_rot=c.body_local_rot[g]))
        else:
            reach = float(c.body_limb_length[g]) + float(np.linalg.norm(rr_joint[limb_root] - sp_rest[sp]))
            lo = 1.0 if g == limb_root else prm.chord_compress
            sc.append(dict(a=sp, b=p, kind=1, len=L, lo=lo, hi=max(1.0, reach / L), plo=lo,
                           phi=max(1.0, reach / L), inva=1.0, invb=1.0, depth=depth,
                           foot=bool(int(caps[g]) & FOOT)))

    # Several goals pulling one spine particle: each moves it by its share, so a sweep
    # in any order settles between them instead of at the last one processed. Where feet
    # pull it too, the other goals keep ``foot_priority`` of a share: a grasper whose goal
    # is past its reach (a prehensile tail waving a metre up) bends the spine, but does
    # not lift the body off the feet it stands on (the pelvis rose 19 cm and the hind feet
    # hung 22 cm over their goals with equal shares).
    pulls: dict[int, int] = {}
    feet_at: dict[int, int] = {}
    for x in sc:
        if x["kind"] in (1, 2):
            pulls[x["a"]] = pulls.get(x["a"], 0) + 1
            if x.get("foot"):
                feet_at[x["a"]] = feet_at.get(x["a"], 0) + 1
    for x in sc:
        if x["kind"] not in (1, 2):
            x["stiff"] = 1.0
        elif feet_at.get(x["a"]) and prm.foot_priority < 1.0:
            nf, n = feet_at[x["a"]], pulls[x["a"]]
            x["stiff"] = 1.0 / nf * (1.0 - prm.foot_priority * (n - nf) / n) if x.get("foot") \
                else prm.foot_priority / n
        else:
            x["stiff"] = 1.0 / pulls[x["a"]]

    # Anti-buckling anchors at each spine particle's rest position.
    for s in branch_bodies:
        sp = sp_of[s]
        p = len(sp_kind)
        sp_kind.append(3)
        sp_body.append(s)
        sp_rest.append(sp_rest[sp].copy())
        sc.append(dict(a=sp, b=p, kind=3, len=0.0, lo=1.0, hi=1.0, plo=1.0, phi=1.0, inva=1.0, invb=0.0,
                       depth=-1))

    # Leaves inward (section 4.3.2, footnote 10): deepest first, anchors last.
    order = sorted(range(len(sc)), key=lambda i: (sc[i]["kind"] == 3, -sc[i]["depth"]))
    remap = {old: new for new, old in enumerate(order)}
    sc = [sc[i] for i in order]
    for s in ch:
        s["con"] = remap[s["con"]]
    side_cons = [[remap[x] for x in cons] for cons in side_cons]
    sp_rest_arr = np.array(sp_rest)

    # Buckling watch: neighbouring spine constraints (through the root between sides).
    def rest_dir(ci):
        return sp_rest_arr[sc[ci]["b"]] - sp_rest_arr[sc[ci]["a"]]

    def angle(u, v):
        nu, nv = np.linalg.norm(u), np.linalg.norm(v)
        if nu < 1e-12 or nv < 1e-12:
            return 0.0
        return float(np.arccos(np.clip(u @ v / (nu * nv), -1.0, 1.0)))

    bp = []  # (c1, sign1, c2, rest angle)
    for si, cons in enumerate(side_cons):
        other = side_cons[1 - si]
        for k, ci in enumerate(cons):
            if k > 0:
                bp.append((cons[k - 1], 1.0, ci, angle(rest_dir(cons[k - 1]), rest_dir(ci))))
            elif other:
                if si == 0:
                    bp.append((other[0], -1.0, ci, angle(-rest_dir(other[0]), rest_dir(ci))))
            else:
                bp.append((-1, 1.0, ci, 0.0))

    # Spine splines: quintic least-squares fits between particles, stored in the end
    # bodies' rest frames, plus each interior body's parameter, offset and rotation
    # relative to the frame transported along the rest spline.
    seg_v0, seg_a0, seg_v1, seg_a1, seg_chord, seg_twist = [], [], [], [], [], []
    segbody_body, segbody_t, segbody_off, segbody_rot, seg_adr, seg_num = [], [], [], [], [], []
    for sg in segs:
        A, B = sg["A"], sg["B"]
        pts = np.array([sp_rest_arr[sg["a"]]] + [rr_joint[b] for b in sg["interior"]] + [rr_joint[B]])
        d = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))]
        ts = d / d[-1] if d[-1] > 1e-12 else np.linspace(0.0, 1.0, len(pts))
        v0, a0, v1, a1 = fit_quintic(pts, ts, prm.spline_regularization)
        sg["v0_rootrel"] = v0
        qa, qb = rr_rot[A], rr_rot[B]
        seg_v0.append(_qrot(_qconj(qa), v0))
        seg_a0.append(_qrot(_qconj(qa), a0))
        seg_v1.append(_qrot(_qconj(qb), v1))
        seg_a1.append(_qrot(_qconj(qb), a1))
        seg_chord.append(float(np.linalg.norm(pts[-1] - pts[0])))
        inner_t = np.ascontiguousarray(ts[1:-1], dtype=np.float64)
        frames = np.zeros((len(inner_t), 4))
        points = np.zeros((len(inner_t), 3))
        f_end = K.transport_rest(tuple(pts[0]), tuple(v0), tuple(a0), tuple(pts[-1]), tuple(v1), tuple(a1),
                                 tuple(float(x) for x in qa), inner_t, int(prm.transport_substeps),
                                 frames, points)
        seg_twist.append(_qmul(_qconj(np.array(f_end)), qb))
        seg_adr.append(len(segbody_body))
        seg_num.append(len(inner_t))
        for j, b in enumerate(sg["interior"]):
            fi = _qconj(frames[j])
            segbody_body.append(b)
            segbody_t.append(inner_t[j])
            segbody_off.append(_qrot(fi, rr_joint[b] - points[j]))
            segbody_rot.append(_qmul(fi, rr_rot[b]))

    # Rest tangents at the chain particles, by the same formulas as the solve.
    ch_tan = []
    for s in ch:
        pi_, pp = sp_rest_arr[s["particle"]], sp_rest_arr[s["prev"]]
        if s["next"] >= 0:
            t = 0.5 * (sp_rest_arr[s["next"]] - pp)
        else:
            vprev = ch_tan[s["prev_k"]] if s["prev_k"] >= 0 else segs[s["seg"]]["v0_rootrel"]
            t = 1.5 * (pi_ - pp) - 0.5 * vprev
        ch_tan.append(t)

    # -- limb phase (4.3.3) --------------------------------------------------------------
    lp = []  # dicts
    lp_of: dict[int, int] = {}
    tip_of: dict[int, int] = {}
    brace: dict[int, int] = {}
    lc = []
    ag_pivot, ag_moved, ag_goal = [], [], []
    for li in range(c.nlimb):
        r = int(c.limb_root[li])
        if not has_ik[r] or r in delegated:
            continue
        s = int(c.limb_attach[li])
        qs_inv = _qconj(rr_rot[s])
        bodies = [b for b in range(r, int(c.body_subtree_end[r])) if has_ik[b]]
        for b in bodies:
            kids = [int(k) for k in c.children(b) if has_ik[k]]
            lp_of[b] = len(lp)
            lp.append(dict(body=b, parent=lp_of.get(int(parent[b]), -1) if b != r else -1, con=-1,
                           attach=s, kids=kids, local=_qrot(qs_inv, rr_joint[b] - rr_pos[s]),
                           rot_local=_qmul(qs_inv, rr_rot[b]), goal=slot_of.get(b, -1)))
        for b in bodies:
            kids = lp[lp_of[b]]["kids"]
            for k in kids:
                L = float(np.linalg.norm(rr_joint[k] - rr_joint[b]))
                lp[lp_of[k]]["con"] = len(lc)
                lc.append(dict(a=lp_of[b], b=lp_of[k], len=L, inva=0.0 if b == r else 1.0,
                               invb=prm.limb_child_invmass, depth=int(c.body_depth[k])))
            for x in range(len(kids)):
                for y in range(x + 1, len(kids)):
                    L = float(np.linalg.norm(rr_joint[kids[y]] - rr_joint[kids[x]]))
                    lc.append(dict(a=lp_of[kids[x]], b=lp_of[kids[y]], len=L, inva=1.0, invb=1.0,
                                   depth=int(c.body_depth[kids[x]])))

        # Tips: a leaf goal body whose origin is off its joint gets a particle at its
        # origin, rigidly tied to its joint. The position goal pins the tip; the joint is
        # pinned only as far as a rotation goal fixes where it must be. So a goal is met
        # at the body's origin exactly, with or without a rotation goal.
        for b in bodies:
            off = float(np.linalg.norm(c.body_joint_offset[b]))
            if b not in slot_of or lp[lp_of[b]]["kids"] or off <= 1e-9 + 1e-4 * float(c.body_limb_length[b]):
                continue
            tip_of[b] = len(lp)
            lp.append(dict(body=b, parent=lp_of[b], con=len(lc), attach=s, kids=[], tip=True,
                           local=_qrot(qs_inv, rr_pos[b] - rr_pos[s]), rot_local=_qmul(qs_inv, rr_rot[b]), goal=-1))
            lc.append(dict(a=lp_of[b], b=tip_of[b], len=off, inva=0.0 if b == r else 1.0, invb=1.0,
                           depth=int(c.body_depth[b]) + 1, plo=1.0, phi=1.0))
            u = rr_joint[int(parent[b])] - rr_joint[b]
            v = rr_pos[b] - rr_joint[b]
            sin_rest = float(np.linalg.norm(np.cross(u, v)) / (np.linalg.norm(u) * off + 1e-300))
            if b != r and sin_rest > 0.3:
                # The brace: tip to the parent's joint at rest distance, so the body keeps
                # its rest angle to its parent (softened by the goal's rotation weight).
                # Only where that triangle is well shaped: a nearly straight one could fold
                # to either side and flip the body.
                pp = lp_of[int(parent[b])]
                brace[b] = pp
                lc.append(dict(a=pp, b=tip_of[b], len=float(np.linalg.norm(rr_pos[b] - rr_joint[int(parent[b])])),
                               inva=0.0 if int(parent[b]) == r else 1.0, invb=1.0, depth=int(c.body_depth[b]) + 1,
                               goal=slot_of[b]))

        def goals_below(b):
            end = int(c.body_subtree_end[b])
            return ([slot_of[h] for h in range(b + 1, end) if h in slot_of]
                    + ([slot_of[b]] if b in tip_of else []))

        def moved_below(b):
            end = int(c.body_subtree_end[b])
            return ([lp_of[h] for h in range(b + 1, end) if h in lp_of]
                    + [tip_of[h] for h in range(b, end) if h in tip_of])

        groups = [(r, goals_below(r), moved_below(r))]
        for b in bodies:
            kids = lp[lp_of[b]]["kids"]
            if len(kids) >= 2:
                for k in kids:
                    groups.append((k, goals_below(k), moved_below(k)))
        for pivot, gl, mv in groups:
            if gl and mv:
                ag_pivot.append(lp_of[pivot])
                ag_goal.append(gl)
                ag_moved.append(mv)

    # Bend hint: a chain that is straight at rest has no preferred bend side; start its
    # middle joints slightly off the line (forward for legs ending in a foot, like knees;
    # backward otherwise, like elbows; down when the chain runs along x) so the solver
    # always bends it the same way.
    feet = (caps & np.uint32(FOOT)) != 0
    for P in lp:
        P["init"] = P["local"].copy()
    for P in lp:
        if P["parent"] < 0 or len(P["kids"]) != 1 or P.get("tip"):
            continue
        b = P["body"]
        pp, kk = lp[P["parent"]]["body"], P["kids"][0]
        u, v = rr_joint[pp] - rr_joint[b], rr_joint[kk] - rr_joint[b]
        nu, nv = np.linalg.norm(u), np.linalg.norm(v)
        if nu < 1e-9 or nv < 1e-9:
            continue
        if np.linalg.norm(np.cross(u, v)) / (nu * nv) > 0.05 or u @ v > 0:
            continue
        chord = (v - u) / np.linalg.norm(v - u)
        leg = bool(np.any(feet[b:int(c.body_subtree_end[b])]))
        hint = np.array([1.0 if leg else -1.0, 0.0, 0.0])
        perp = hint - (hint @ chord) * chord
        if np.linalg.norm(perp) < 0.3:
            hint = np.array([0.0, 0.0, -1.0])
            perp = hint - (hint @ chord) * chord
        perp /= np.linalg.norm(perp)
        off = prm.straight_bend * 0.5 * (nu + nv) * perp
        P["init"] = P["local"] + _qrot(_qconj(rr_rot[P["attach"]]), off)

    # Splay hint: a fork (a body with two or more IK children, their branches ending in
    # joints E) keeps its branch point P on the circle of points at the branches' lengths
    # from the ends; when the ends come closer to the fork's joint R than at rest (the
    # hips crouch over planted toes) P must move along that circle, tangent
    # t = spread x (P - mid E). If R lies in the plane of spread and P - mid E, no
    # constraint correction has a component along t and the iterations sit in that plane
    # with every segment compressed. Start the branch joints slightly along t: away from
    # the sagittal plane (forward for a fork on it), like a knee splaying out.
    held_forks = 0
    for P in lp:
        kids = [k for k in P["kids"] if not lp[lp_of[k]].get("tip")]
        if len(kids) < 2:
            continue
        # Only where every branch is held by a goal (a free branch lets P turn freely).
        if not all(any(h in slot_of for h in range(k, int(c.body_subtree_end[k]))) for k in kids):
            continue
        # A fork planted on feet or holding with graspers (a head whose eyes and jaw turn
        # to rotation goals is no such fork) settles slowly: twice the limb iterations.
        if all(any(h in slot_of and int(caps[h]) & (FOOT | GRASPER) for h in range(k, int(c.body_subtree_end[k])))
               for k in kids):
            held_forks += 1
        b = P["body"]
        ends = []
        for k in kids:
            gk = [g for g in lp[lp_of[k]]["kids"] if not lp[lp_of[g]].get("tip")]
            ends.append(rr_joint[gk[0]] if gk else rr_joint[k])
        fork = np.mean([rr_joint[k] for k in kids], axis=0)
        t = np.cross(ends[-1] - ends[0], fork - np.mean(ends, axis=0))
        nt = float(np.linalg.norm(t))
        seg = float(np.linalg.norm(fork - rr_joint[b]))
        if nt < 1e-12 or seg < 1e-9:
            continue
        t /= nt
        if abs(float((rr_joint[b] - fork) @ t)) > 0.05 * seg:
            continue                       # R is off that plane: the corrections already turn P
        side = float(c.body_side[b])
        pref = np.array([0.0, side, 0.0]) if side != 0.0 else np.array([1.0, 0.0, 0.0])
        if float(t @ pref) < 0.0:
            t = -t
        off = prm.fork_splay * seg * t
        for k in kids:
            Q = lp[lp_of[k]]
            Q["init"] = Q["init"] + _qrot(_qconj(rr_rot[Q["attach"]]), off)

    for P in lp:
        kids = P["kids"]
        if P.get("tip"):
            P["mode"], P["c1"], P["c2"] = 3, -1, -1
        elif not kids and P["body"] in tip_of:
            b = P["body"]
            # Carried by the parent and swung at the tip where braced, else the tip alone.
            P["mode"], P["c1"], P["c2"] = (4, tip_of[b], -1) if b in brace else (0, tip_of[b], -1)
        else:
            P["mode"] = 2 if not kids else (0 if len(kids) == 1 else 1)
            P["c1"] = lp_of[kids[0]] if kids else -1
            P["c2"] = lp_of[kids[1]] if len(kids) > 1 else -1

    ref_dir, ref_rot = _rebuild_refs(c, lp, rr_rot, feet, prm.parent_twist)

    lc_order = sorted(range(len(lc)), key=lambda i: -lc[i]["depth"])
    lc_remap = {old: new for new, old in enumerate(lc_order)}
    lc = [lc[i] for i in lc_order]
    for P in lp:
        if P["con"] >= 0:
            P["con"] = lc_remap[P["con"]]

    # Reach of each limb goal particle from its limb root particle: the rest lengths of
    # the chain up to the goal body's joint, plus the tip's brace (or offset).
    goal_lproot = np.full(len(goals), -1, np.int32)
    goal_reach = np.zeros(len(goals))
    goal_reachj = np.zeros(len(goals))
    for k, g in enumerate(goals):
        if g not in lp_of:
            continue
        i = lp_of[g]
        chain_len = 0.0
        while lp[i]["parent"] >= 0:
            chain_len += float(np.linalg.norm(lp[i]["local"] - lp[lp[i]["parent"]]["local"]))
            i = lp[i]["parent"]
        goal_lproot[k] = i
        goal_reachj[k] = chain_len
        goal_reach[k] = chain_len
        if g in tip_of:
            t = tip_of[g]
            if g in brace:
                pp = brace[g]
                up = chain_len - float(np.linalg.norm(lp[lp_of[g]]["local"] - lp[pp]["local"]))
                goal_reach[k] = up + float(np.linalg.norm(lp[t]["local"] - lp[pp]["local"]))
            else:
                goal_reach[k] = chain_len + float(np.linalg.norm(lp[t]["local"] - lp[lp_of[g]]["local"]))
    goal_lp = np.array([tip_of.get(g, lp_of.get(g, -1)) for g in goals], np.int32)
    goal_lpj = np.array([lp_of[g] if g in tip_of else -1 for g in goals], np.int32)
    ag_via = _aim_via(lp, ag_pivot, ag_goal, goal_lp, goal_lpj, rr_rot) if prm.aim_via else np.zeros((len(ag_pivot), 3))
    rg_body = sorted(delegated)

    i32 = lambda x: np.asarray(x, np.int32).reshape(-1)  # noqa: E731
    f64 = lambda x, w: np.asarray(x, np.float64).reshape(-1, w) if w > 1 else np.asarray(x, np.float64).reshape(-1)  # noqa: E731
    nsp, nlp, ngoal, nch = len(sp_kind), len(lp), len(goals), len(ch)
    sizes = [nsp, nsp, nlp, nlp, nlp, ngoal, nch, 1, len(dg), nsp, ngoal, ngoal, len(segbody_body)]  # rows of 3
    layout = np.r_[0, np.cumsum(sizes)[:-1]].astype(np.int32)
    fields = dict(
        b_parent=i32(parent),
        sp_kind=i32(sp_kind), sp_body=i32(sp_body),
        sc_a=i32([x["a"] for x in sc]), sc_b=i32([x["b"] for x in sc]), sc_kind=i32([x["kind"] for x in sc]),
        ch_particle=i32([x["particle"] for x in ch]), ch_prev=i32([x["prev"] for x in ch]),
        ch_prev_k=i32([x["prev_k"] for x in ch]), ch_next=i32([x["next"] for x in ch]),
        ch_con=i32([x["con"] for x in ch]), ch_seg=i32([x["seg"] for x in ch]),
        bp_c1=i32([x[0] for x in bp]), bp_c2=i32([x[2] for x in bp]),
        seg_a=i32([x["a"] for x in segs]), seg_b=i32([x["b"] for x in segs]),
        seg_body_adr=i32(seg_adr), seg_body_num=i32(seg_num), segbody_body=i32(segbody_body),
        dg_body=i32([x["body"] for x in dg]), dg_goal=i32([x["goal"] for x in dg]),
        dg_particle=i32([x["particle"] for x in dg]), dg_spine_particle=i32([x["spine_particle"] for x in dg]),
        rg_body=i32(rg_body),
        lp_body=i32([x["body"] for x in lp]), lp_parent=i32([x["parent"] for x in lp]),
        lp_con=i32([x["con"] for x in lp]), lp_attach=i32([x["attach"] for x in lp]),
        lp_mode=i32([x["mode"] for x in lp]), lp_c1=i32([x["c1"] for x in lp]), lp_c2=i32([x["c2"] for x in lp]),
        lp_goal=i32([x["goal"] for x in lp]),
        lc_a=i32([x["a"] for x in lc]), lc_b=i32([x["b"] for x in lc]), lc_goal=i32([x.get("goal", -1) for x in lc]),
        ag_pivot=i32(ag_pivot),
        ag_moved_adr=i32(np.r_[0, np.cumsum([len(m) for m in ag_moved])[:-1]] if ag_moved else []),
        ag_moved_num=i32([len(m) for m in ag_moved]),
        ag_goal_adr=i32(np.r_[0, np.cumsum([len(m) for m in ag_goal])[:-1]] if ag_goal else []),
        ag_goal_num=i32([len(m) for m in ag_goal]),
        ag_moved=i32([x for m in ag_moved for x in m]), ag_goal=i32([x for m in ag_goal for x in m]),
        goal_body=i32(goals), goal_sp=i32(goal_sp), goal_lp=goal_lp, goal_lpj=goal_lpj, goal_lproot=goal_lproot,
        goal_limb_root=i32(goal_limb_root),
        scratch_layout=layout,
        b_rootrel_rot=f64(rr_rot, 4), b_rootrel_pos=f64(rr_pos, 3), b_rootrel_joint=f64(rr_joint, 3),
        b_joint_offset=f64(c.body_joint_offset, 3), b_local_rot=f64(c.body_local_rot, 4),
        b_local_pos=f64(c.body_local_pos, 3), b_local_joint=f64(c.body_local_joint, 3),
        sp_rest=f64(sp_rest_arr, 3),
        sc_len=f64([x["len"] for x in sc], 1), sc_lo=f64([x["lo"] for x in sc], 1),
        sc_hi=f64([x["hi"] for x in sc], 1), sc_plo=f64([x["plo"] for x in sc], 1),
        sc_phi=f64([x["phi"] for x in sc], 1), sc_inva=f64([x["inva"] for x in sc], 1),
        sc_invb=f64([x["invb"] for x in sc], 1), sc_stiff=f64([x.get("stiff", 1.0) for x in sc], 1),
        bp_sign1=f64([x[1] for x in bp], 1), bp_rest_angle=f64([x[3] for x in bp], 1),
        ch_rest_tangent=f64(ch_tan, 3),
        seg_v0=f64(seg_v0, 3), seg_a0=f64(seg_a0, 3), seg_v1=f64(seg_v1, 3), seg_a1=f64(seg_a1, 3),
        seg_rest_chord=f64(seg_chord, 1), seg_rest_twist=f64(seg_twist, 4),
        segbody_t=f64(segbody_t, 1), segbody_off=f64(segbody_off, 3), segbody_rot=f64(segbody_rot, 4),
        dg_chord=f64([x["chord"] for x in dg], 3), dg_rel_rot=f64([x["rel_rot"] for x in dg], 4),
        lp_local=f64([x["local"] for x in lp], 3), lp_init_local=f64([x["init"] for x in lp], 3),
        lp_rot_local=f64([x["rot_local"] for x in lp], 4),
        lc_len=f64([x["len"] for x in lc], 1), lc_lo=f64([1.0] * len(lc), 1), lc_hi=f64([1.0] * len(lc), 1),
        lc_plo=f64([x.get("plo", prm.limb_shrink) for x in lc], 1),
        lc_phi=f64([x.get("phi", prm.limb_stretch) for x in lc], 1),
        lc_inva=f64([x["inva"] for x in lc], 1), lc_invb=f64([x["invb"] for x in lc], 1),
        goal_reach=goal_reach, goal_reachj=goal_reachj, params=_param_vector(prm, held_forks),
        ag_via=f64(ag_via, 3),
        lp_ref_dir=f64(ref_dir, 3), lp_ref_rot=f64(ref_rot, 4),
        b_extent=f64(c.body_extent, 3), b_floor=f64(body_floor(c), 1),
        b_ground_r=f64(np.linalg.norm(c.body_joint_offset, axis=1) + np.linalg.norm(c.body_extent, axis=1), 1),
    )
    # the rest splines' arc lengths and the interior bodies' shares of them: static, so
    # measured here once by the solve's own kernel rather than in every reconstruction
    fields["seg_rest_arc"] = np.zeros(len(seg_v0))
    fields["segbody_share"] = np.zeros(len(segbody_body))
    K.rest_arc_shares(fields["sp_rest"], fields["b_rootrel_rot"], fields["sp_body"], fields["seg_a"],
                      fields["seg_b"], fields["seg_v0"], fields["seg_a0"], fields["seg_v1"], fields["seg_a1"],
                      fields["seg_body_adr"], fields["seg_body_num"], fields["segbody_t"],
                      int(fields["params"][K.P_SUBSTEPS]), fields["seg_rest_arc"], fields["segbody_share"])
    sp_prev = np.full(len(fields["sp_kind"]), -1, np.int32)
    sp_prev[fields["ch_particle"]] = fields["ch_prev"]
    fields["sp_prev"] = sp_prev
    fields["cl_i"], fields["cl_f"], cl_rows, cl_pairs = selfcollision.build(
        c, has_ik, fields["lp_body"], fields["lp_mode"], fields["lp_c1"], fields["lp_attach"], prm.self_collision,
        prm.self_collision_rounds, int(sum(sizes)), goals, goal_lp)
    fields["_scratch_size"] = int(sum(sizes)) + cl_rows
    info = dict(has_ik=has_ik, delegated=delegated, branch_bodies=branch_bodies, cl_pairs=cl_pairs)
    return fields, info


def _pack(fields):
    """Pack the named arrays into the blobs: ints into ``plan_i`` after a header of
    (offset, rows) per field, floats by width into ``plan_f`` (1-D), ``plan_f3`` (k, 3)
    and ``plan_f4`` (k, 4), so the kernel's views are plain slices."""
    nh = 2 * (len(K.INT_FIELDS) + len(K.FLOAT_FIELDS))
    ints = [np.ascontiguousarray(fields[name], np.int32).reshape(-1) for name in K.INT_FIELDS]
    header = np.zeros(nh, np.int32)
    off = nh
    for k, a in enumerate(ints):
        header[2 * k], header[2 * k + 1] = off, a.size
        off += a.size
    plan_i = np.concatenate([header] + ints).astype(np.int32)
    blobs = {1: [], 3: [], 4: []}
    offs = {1: 0, 3: 0, 4: 0}
    for k, (name, w) in enumerate(K.FLOAT_FIELDS):
        a = np.ascontiguousarray(fields[name], np.float64).reshape(-1, w) if w > 1 else \
            np.ascontiguousarray(fields[name], np.float64).reshape(-1)
        h = 2 * (len(K.INT_FIELDS) + k)
        plan_i[h], plan_i[h + 1] = offs[w], a.shape[0]
        offs[w] += a.shape[0]
        blobs[w].append(a)
    plan_f = np.ascontiguousarray(np.concatenate(blobs[1]))
    plan_f3 = np.ascontiguousarray(np.concatenate(blobs[3]).reshape(-1, 3))
    plan_f4 = np.ascontiguousarray(np.concatenate(blobs[4]).reshape(-1, 4))
    return plan_i, plan_f, plan_f3, plan_f4, fields["_scratch_size"]


def _views(plan_i, plan_f, plan_f3, plan_f4):
    """The fields as numpy views of the blobs, by name (the Python twin of ``unpack``)."""
    out = {}
    for k, name in enumerate(K.INT_FIELDS):
        o, n = int(plan_i[2 * k]), int(plan_i[2 * k + 1])
        out[name] = plan_i[o:o + n]
    blobs = {1: plan_f, 3: plan_f3, 4: plan_f4}
    for k, (name, w) in enumerate(K.FLOAT_FIELDS):
        h = 2 * (len(K.INT_FIELDS) + k)
        o, n = int(plan_i[h]), int(plan_i[h + 1])
        out[name] = blobs[w][o:o + n]
    return out
