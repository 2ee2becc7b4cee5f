"""The two-phase Particle IK solver: goals in, world poses of the IK sub-tree out.

Hecker et al. 2008, section 4.3. One solve is one numba call over plain arrays:

1. goals -> 3-DOF targets at the goal bodies' joints (4.3.1);
2. spine phase: spine particles at IK branch points, simplified limbs (one chord
   constraint from the spine to each limb goal, allowed to compress to 10%), delegated
   goals (mouths/heads pull their spine body), 5 outer iterations leaves-inward, buckling
   watch and blend toward the root-relative rest pose (4.3.2);
3. the root's spine children nudge the root's rotation (footnote 8; ``root_influence``);
4. spine reconstruction: outward projection, tangents, minimal twist, delegated
   rotations, interior spine bodies by frame transport along quintic splines (4.3.2);
5. limb phase: aim preconditioner, constraint iterations, outward projection,
   orientations by minimal twist or from two constraint axes (4.3.3).

Every solve starts from the root-relative rest pose: no state is carried between solves,
so the pose depends only on the current goals (path independence, objective 4).

Output: ``out_pos (nbody, 3)`` and ``out_rot (nbody, 4)`` get the world pose of every body
in ``plan.ik_bodies`` (including the root: its position and rotation as given, the
rotation nudged by ``root_influence``); rows of ``plan.free_bodies`` are left untouched
for the caller (secondary motion). Goals: ``goal_pos (nbody, 3)`` is the target of the
body's origin, ``goal_rot (nbody, 4)`` its target rotation (w, x, y, z), and
``goal_pos_weight`` / ``goal_rot_weight`` (nbody,) in [0, 1]; weight 0 means no goal. Only
bodies in ``plan.goal_bodies`` are read.

The ground (``IKParams.ground``, on by default): the solve runs in the character's space,
where a creature stands on z = 0 in its rest pose; ``ground`` (4,) ``(nx, ny, nz, d)``, the
plane n . x = d with n pointing up, says where the ground is instead (a zero normal: none).
Every body's box is kept above it, down to its floor (``engine.ik.plan.body_floor``); goals
are still met where they are, on or below it.
"""

from __future__ import annotations

import os

import numpy as np

from engine.ik import _kernels as K
from engine.ik.plan import DEFAULT_PARAMS, IKError, IKParams, IKPlan, plan_for


class IKGoals:
    """Preallocated goal arrays of one character (or a stack of ``n`` characters).

    goal_pos (nbody, 3) float64        target of each body's origin, world, m
    goal_rot (nbody, 4) float64        target rotation, w-first unit quaternion
    goal_pos_weight (nbody,) float64   0 = no position goal, 1 = full
    goal_rot_weight (nbody,) float64   0 = no rotation goal, 1 = full
    With ``n`` given every array gets a leading axis of length n (a crowd).
    """

    def __init__(self, nbody: int, n: int | None = None):
        lead = () if n is None else (int(n),)
        self.goal_pos = np.zeros(lead + (nbody, 3))
        self.goal_rot = np.zeros(lead + (nbody, 4))
        self.goal_rot[..., 0] = 1.0
        self.goal_pos_weight = np.zeros(lead + (nbody,))
        self.goal_rot_weight = np.zeros(lead + (nbody,))

    def clear(self) -> None:
        self.goal_pos_weight[...] = 0.0
        self.goal_rot_weight[...] = 0.0

    def set(self, body: int, pos=None, rot=None, pos_weight: float = 1.0, rot_weight: float = 1.0,
            index: int | None = None) -> None:
        """Set one body's goal (``index`` selects the character in a stack)."""
        sel = (body,) if index is None else (index, body)
        if pos is not None:
            self.goal_pos[sel] = pos
            self.goal_pos_weight[sel] = pos_weight
        if rot is not None:
            self.goal_rot[sel] = rot
            self.goal_rot_weight[sel] = rot_weight


def _check_array(name, a, shape):
    if not _ok(a, shape):
        raise _bad_array(name, a, shape)


def _raise_bad(plan, code, who=""):
    if code == -2:
        raise IKError(f"{who}root pose is not finite or the root rotation is zero",
                      subject=plan.creature.body_names[0], field="root_pos/root_rot")
    raise IKError(f"{who}goal is not usable: weights must be in [0, 1], positions finite and "
                  f"rotations finite and non-zero where their weight is > 0",
                  subject=plan.creature.body_names[code], field="goals")


def _bad_array(name, a, shape):
    got = f"{type(a).__name__}" if not isinstance(a, np.ndarray) else f"{a.dtype} {a.shape}"
    return IKError(f"expected a C-contiguous float64 array of shape {shape}, got {got}", field=name, subject=None)


_F64 = np.dtype(np.float64)
_NO_FASTCALL = bool(os.environ.get("MENAGERIE_NO_FASTCALL"))


def _ok(a, shape):
    """A C-contiguous float64 array of this shape (cheap checks: this runs every solve)."""
    if type(a) is not np.ndarray or a.shape != shape or a.dtype is not _F64:
        return False
    st = a.strides
    return (st[-1] == 8 and (len(st) == 1 or st[-2] == 8 * shape[-1])
            and (len(st) < 3 or st[-3] == 8 * shape[-1] * shape[-2]))


#: The ground of a solve that names none: z = 0 of the character's space (its rest stance).
GROUND_Z0 = np.array([0.0, 0.0, 1.0, 0.0])


def _ground_plane(ground):
    if ground is None:
        return GROUND_Z0
    g = np.ascontiguousarray(ground, dtype=np.float64)
    if g.shape != (4,) or not np.all(np.isfinite(g)):
        raise IKError(f"ground must be 4 finite numbers (nx, ny, nz, d), got {ground!r}", field="ground",
                      subject=None)
    return g


def solve_ik(plan: IKPlan, root_pos, root_rot, goals: IKGoals, out_pos: np.ndarray, out_rot: np.ndarray,
             scratch: np.ndarray, ground=None) -> None:
    """Solve one character: writes the IK sub-tree's world poses into ``out_pos``/``out_rot``.
    ``scratch`` comes from ``plan.make_scratch()``. Allocation-free after compilation.
    ``ground``: the plane (nx, ny, nz, d) under the character (None: z = 0; see above).

    The goal, output and scratch arrays are checked the first time they are used with this
    plan and remembered (the plan holds them, so they cannot be freed and their identity
    reused); the root pose is checked every call. Reshaping a remembered array in place
    (``a.shape = ...``) is not noticed: don't."""
    gp, gr, gpw, grw = goals.goal_pos, goals.goal_rot, goals.goal_pos_weight, goals.goal_rot_weight
    seen = plan._checked
    if not (seen is not None and seen[0] is gp and seen[1] is gr and seen[2] is gpw and seen[3] is grw
            and seen[4] is out_pos and seen[5] is out_rot and seen[6] is scratch):
        n = plan.creature.nbody
        for name, a, shape in (("goal_pos", gp, (n, 3)), ("goal_rot", gr, (n, 4)),
                               ("goal_pos_weight", gpw, (n,)), ("goal_rot_weight", grw, (n,)),
                               ("out_pos", out_pos, (n, 3)), ("out_rot", out_rot, (n, 4)),
                               ("scratch", scratch, plan.scratch_shape)):
            if not _ok(a, shape):
                raise _bad_array(name, a, shape)
        for name, a in (("out_pos", out_pos), ("out_rot", out_rot), ("scratch", scratch)):
            if not a.flags.writeable:
                raise IKError("the solver writes into this array; it is read-only", field=name)
        plan._checked = (gp, gr, gpw, grw, out_pos, out_rot, scratch)
        plan._entry = None
    if not _ok(root_pos, (3,)):
        raise _bad_array("root_pos", root_pos, (3,))
    if not _ok(root_rot, (4,)):
        raise _bad_array("root_rot", root_rot, (4,))
    gd = GROUND_Z0 if ground is None else _ground_plane(ground)
    b = plan.blobs
    entry = plan._entry
    if entry:
        # The compiled overload for these (validated) array types, called directly: skips
        # numba's per-call type resolution (as engine._fastcall does for the runtime).
        code = entry(b[0], b[1], b[2], b[3], root_pos, root_rot, gp, gr, gpw, grw, out_pos, out_rot, scratch, gd)
    else:
        args = (b[0], b[1], b[2], b[3], root_pos, root_rot, gp, gr, gpw, grw, out_pos, out_rot, scratch, gd)
        code = K.solve_packed(*args)
        if entry is None and not _NO_FASTCALL:
            try:
                sig = tuple(K.solve_packed.typeof_pyval(a) for a in args)
                plan._entry = K.solve_packed.overloads[sig].entry_point
            except Exception:  # an unusual numba: keep going through the dispatcher
                plan._entry = False
    if code != -1:
        _raise_bad(plan, code)


def solve_ik_batch(plan: IKPlan, root_pos, root_rot, goals: IKGoals, out_pos, out_rot, scratch,
                   bad: np.ndarray | None = None, ground=None) -> None:
    """Many independent solves sharing ``plan`` in one kernel call: ``root_pos (c, 3)``,
    ``root_rot (c, 4)``, ``goals`` made with ``IKGoals(nbody, c)``, ``out_pos (c, nbody, 3)``,
    ``out_rot (c, nbody, 4)``. ``bad`` (c,) int64, if given, receives a per-character code
    (-1 solved) and nothing is raised; otherwise the first bad character raises.
    ``ground``: one plane (4,) for all, or one per character (c, 4); None: z = 0."""
    n = plan.creature.nbody
    c = root_pos.shape[0] if isinstance(root_pos, np.ndarray) and root_pos.ndim == 2 else -1
    _check_array("root_pos", root_pos, (c, 3))
    _check_array("root_rot", root_rot, (c, 4))
    _check_array("goal_pos", goals.goal_pos, (c, n, 3))
    _check_array("goal_rot", goals.goal_rot, (c, n, 4))
    _check_array("goal_pos_weight", goals.goal_pos_weight, (c, n))
    _check_array("goal_rot_weight", goals.goal_rot_weight, (c, n))
    _check_array("out_pos", out_pos, (c, n, 3))
    _check_array("out_rot", out_rot, (c, n, 4))
    _check_array("scratch", scratch, plan.scratch_shape)
    g = GROUND_Z0 if ground is None else np.asarray(ground, dtype=np.float64)
    if g.shape == (4,):
        g = np.tile(g, (c, 1))
    g = np.ascontiguousarray(g)
    if g.shape != (c, 4) or not np.all(np.isfinite(g)):
        raise IKError(f"ground must be (4,) or ({c}, 4) finite planes (nx, ny, nz, d)", field="ground", subject=None)
    raise_on_bad = bad is None
    if bad is None:
        bad = np.empty(c, np.int64)
    nbad = K.solve_packed_batch(*plan.blobs, root_pos, root_rot, goals.goal_pos, goals.goal_rot,
                                goals.goal_pos_weight, goals.goal_rot_weight, out_pos, out_rot, scratch, bad, g)
    if nbad and raise_on_bad:
        k = int(np.flatnonzero(bad != -1)[0])
        _raise_bad(plan, int(bad[k]), who=f"character {k}: ")


class IKSolver:
    """Convenience owner of one character's plan, goals, scratch and output.

    >>> solver = IKSolver(creature, ["hand_l", "foot_l"])
    >>> solver.goals.set(creature.body("hand_l"), pos=(0.3, 0.2, 1.2))
    >>> solver.solve(root_pos, root_rot)      # -> solver.out_pos, solver.out_rot
    """

    def __init__(self, creature, goal_bodies, params: IKParams = DEFAULT_PARAMS):
        self.plan = plan_for(creature, goal_bodies, params)
        n = creature.nbody
        self.goals = IKGoals(n)
        self.scratch = self.plan.make_scratch()
        self.out_pos = np.zeros((n, 3))
        self.out_rot = np.zeros((n, 4))
        self.out_rot[:, 0] = 1.0

    def solve(self, root_pos, root_rot, ground=None):
        solve_ik(self.plan, np.ascontiguousarray(root_pos, np.float64), np.ascontiguousarray(root_rot, np.float64),
                 self.goals, self.out_pos, self.out_rot, self.scratch, ground)
        return self.out_pos, self.out_rot


def pose_free_rigid(plan: IKPlan, out_pos: np.ndarray, out_rot: np.ndarray) -> None:
    """Place the bodies the solver leaves to the caller (``plan.free_bodies``) rigidly on
    their parents at their local rest transform. For tools, pictures and tests; the
    runtime gives these bodies secondary motion instead."""
    c = plan.creature
    for b in plan.free_bodies:
        p = int(c.body_parent[b])
        rp = tuple(out_rot[p])
        out_rot[b] = K.qnormalize(K.qmul(rp, tuple(c.body_local_rot[b])))
        out_pos[b] = np.asarray(out_pos[p]) + np.array(K.qrot(rp, tuple(c.body_local_pos[b])))


def rest_pose_world(creature, root_pos, root_rot):
    """World pose of every body in the root-relative rest pose carried by the root."""
    n = creature.nbody
    pos = np.empty((n, 3))
    rot = np.empty((n, 4))
    rr = tuple(float(x) for x in root_rot)
    for b in range(n):
        rot[b] = K.qmul(rr, tuple(creature.body_rootrel_rot[b]))
        pos[b] = np.asarray(root_pos) + np.array(K.qrot(rr, tuple(creature.body_rootrel_pos[b])))
    return pos, rot


__all__ = ["IKError", "IKGoals", "IKParams", "IKPlan", "IKSolver", "plan_for", "pose_free_rigid",
           "rest_pose_world", "solve_ik", "solve_ik_batch"]
