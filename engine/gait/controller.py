"""GaitController: the runtime's gait stage for one character (Hecker et al. 2008,
section 4.2).

Per frame (``step``), called by ``Character.tick`` after the animation blend and before
the IK:

1. root motion: the commanded velocity and turn rate, limited to what the style allows
   (no overreach) and reached with the style's acceleration limits (continuity), are
   integrated into the character's placement;
2. cadence: each leg group's cycle rate follows its style's stride at the group's
   relative speed, raised where the stride would make a planted foot overreach
   (``rig.group_sweep``), locked across groups by the harmonized ratios;
3. ``gait_plan`` kernel: stance/flight transitions and touchdown predictions;
4. one call of the terrain height function for all the points the frame needs;
5. placement height and torso slope from the ground under the rest feet;
6. ``gait_pose`` kernel: feet planted, in flight, goals through the new placement, hip
   bob, sway, crouch, lean and slope alignment on the root.

Slope alignment, lean and crouch are low-pass filtered so a sudden command or a ridge in
the terrain never snaps the torso.
"""

from __future__ import annotations

import math

import numpy as np

from engine.errors import MenagerieError
from engine.gait import _kernels as K
from engine.gait import _step_kernels as SK
from engine.gait.rig import GaitRig, analyze
from engine.gait.style import PATH_SAMPLES, GaitStyle, GaitStyleError, load_style
from engine.model.creature import Creature

#: Time constants (s) of the filters on the placement height and the torso tilt.
HEIGHT_TAU = 0.12
TILT_TAU = 0.25
#: Time constant (s) of a flying foot's turn toward the body's ground slope.
FOOT_TILT_TAU = 0.05
#: Time constant (s) of the filter on the hip bob and sway.
BOB_TAU = 0.06
#: Largest constant miss of a foot at the rest stance (share of its leg length) the
#: calibration accepts and compensates (``GaitController.foot_bias``).
BIAS_SHARE = 0.03
#: The calibration picks the least crouch whose half-sweep is at least this share of the
#: best it found at any crouch.
CROUCH_SWEEP_SHARE = 0.7
#: How much (m) the calibration lets a planted foot's IK miss vary from its constant part
#: (the gait follows what is left from the IK's output: ``observe``).
CAL_TOL = 3e-4
# phases of the inch-worm wave a crawler's forward sweep is calibrated at (``_calibrate``)
CRAWL_CAL_PHASES = 12
#: ``observe``: share of the way a foot's bias moves toward the IK's latest miss per frame,
#: in stance and in flight, and how far (m) it may leave the calibrated rest-stance bias: the
#: calibration verified the planted feet's miss varies by at most ``CAL_TOL`` from it, so a
#: larger miss is the IK failing a goal for a frame, not a bias to learn (followed, the one-frame
#: lag put a centipede's foot 0.5 mm under the ground the frame after).
OBSERVE_GAIN = 1.0
OBSERVE_FLIGHT_GAIN = 1.0
OBSERVE_LIMIT = CAL_TOL
#: Smallest calibrated half-sweep (share of leg length) a group steps with; below it the
#: legs stand (``GaitController.immobile``).
MIN_SWEEP_SHARE = 0.01
#: Below these the character counts as standing still (share of leg length per second, rad/s).
IDLE_SPEED = 1e-3
IDLE_TURN = 1e-3


class GaitError(MenagerieError, ValueError):
    """Bad input to the gait controller (a terrain function, a style, a group index)."""


class _Scalar:
    """A scalar of the controller's state, kept in its row of the gait stack (``sv``) so
    the stage kernel reads and writes it (``engine.gait._step_kernels``)."""

    __slots__ = ("col", "kind")

    def __init__(self, col: int, kind=float) -> None:
        self.col = col
        self.kind = kind

    def __get__(self, obj, cls=None):
        if obj is None:
            return self
        return self.kind(obj._sv[self.col])

    def __set__(self, obj, value) -> None:
        obj._sv[self.col] = value


#: Style layers and speed-table rows a gait stack holds per group (more: a larger stack).
STACK_LAYERS = 4
STACK_ROWS = 8

EPOCH = SK.EPOCH

#: The per-frame arrays of a controller, in order, as the stage kernel takes them (each
#: a row of a ``GaitStack`` array; ``_tab`` ... ``_sc_settle`` are its style constants).
ROW_FIELDS = ("_sv", "_cmd_v", "velocity", "_prev_v", "_last_place", "group_phase", "_group_support", "group_rate",
              "group_duty", "group_sweep", "group_park", "group_lift", "group_bob", "group_sway", "_crouch_want",
              "path", "step_trigger", "step_duty_scale", "step_lift_scale", "step_state", "step_progress",
              "step_prev_u", "step_parked", "step_lift_u", "step_done", "foot_world", "foot_lift", "foot_yaw",
              "foot_lift_yaw", "foot_target", "foot_target_yaw", "_query", "_heights", "_place3", "_vel3",
              "foot_slope", "_foot_tilt", "_slope_w", "ground_plane", "_root_dq", "_root_dpos", "_bob", "_row",
              "_tilt", "_lean", "_cal_crouch", "_cal_sweep", "group_stretch", "foot_bias", "_prev_root_pos",
              "_prev_root_rot", "_goal_written", "_tab", "_tab_n", "_tab_w", "_tab_nl", "_sc_cap", "_sc_top",
              "_sc_ptop", "_sc_sa", "_sc_settle")
_STACK_FIELDS = ROW_FIELDS + ("_cal_bias", "_observe_limit")


class GaitStack:
    """The per-frame state of ``n`` gait controllers of one creature in shared arrays
    (leading axis n): each controller's arrays are views of its row, so one kernel call
    steps them all (``engine.gait._step_kernels.gait_rows``)."""

    def __init__(self, controllers: list, *, private: bool = True) -> None:
        first = controllers[0]
        self.controllers = list(controllers)
        self.rig = first.rig
        n = len(controllers)
        nl = max(STACK_LAYERS, max(c._need_layers() for c in controllers))
        nt = max(STACK_ROWS, max(c._need_rows() for c in controllers))
        for name in _STACK_FIELDS:
            a = getattr(first, name)
            shape = a.shape
            if name == "_tab":
                shape = (shape[0], nl, nt, 8)
            elif name in ("_tab_n", "_tab_w"):
                shape = (shape[0], nl)
            setattr(self, name, np.zeros((n,) + shape, a.dtype))
        for row, c in enumerate(controllers):
            for name in _STACK_FIELDS:
                src = getattr(c, name)
                dst = getattr(self, name)[row]
                dst[tuple(slice(0, k) for k in src.shape)] = src
            c._bind(self, row)
        r = self.rig
        self.rig_args = (_MODES[r.mode], float(r.float_height), r.group_length, r.group_radius, r.group_ratio,
                         _group_first(r), r.step_group, r.step_side, r.step_foot_adr, r.step_foot_num, r.foot_body,
                         r.foot_neutral, r.foot_offset, r.foot_rest_rot, r.foot_hip, r.foot_jointrel, r.foot_chain,
                         r.foot_rigid, r.foot_knee, r.foot_contact)
        self.state_args = tuple(getattr(self, name) for name in ROW_FIELDS)
        self.observe_args = (self._sv, self._goal_written, self.step_state, self.foot_bias, self._cal_bias,
                             self._observe_limit, r.foot_body, r.foot_stepper, r.foot_rest_rot, r.foot_contact,
                             OBSERVE_GAIN, OBSERVE_FLIGHT_GAIN)
        if private:
            EPOCH[0] += 1     # a controller left the stack it was in (or is new)


_MODES = {"walk": SK.MODE_WALK, "crawl": SK.MODE_CRAWL, "float": SK.MODE_FLOAT}


def _group_first(r: GaitRig) -> np.ndarray:
    """Per leg group, its front stepper (least rank; the first of equals)."""
    out = np.zeros(max(r.ngroup, 1), np.int64)
    for g in range(r.ngroup):
        steps = [int(k) for k in np.flatnonzero(r.step_group == g)]
        if steps:
            out[g] = min(steps, key=lambda k: r.step_rank[k])
    return out


def gait_stage(dt: float, stack: GaitStack, rows: np.ndarray, crows: np.ndarray, char_args: tuple,
               call=None) -> None:
    """The gait step of the controllers in ``stack`` rows ``rows`` (their characters in
    rows ``crows`` of ``char_args``: place_pos, place_rot, root_pos, root_rot, goal_pos,
    goal_rot, goal_pw, goal_rw, ground, ground_set). ``call``: the same kernel call bound
    once (``engine._fastcall.BoundKernel``, dt in its first slot)."""
    if call is not None:
        nflag = call.call(float(dt))
    else:
        nflag = SK.gait_rows(float(dt), 0, rows, crows, *char_args, *stack.state_args, *stack.rig_args)
    if nflag:
        _finish_rows(dt, stack, rows, crows, char_args)


def _finish_rows(dt: float, stack: GaitStack, rows: np.ndarray, crows: np.ndarray, char_args: tuple) -> None:
    """The rows the kernel left to Python: planting afresh (then the step), and terrain
    given by Python functions (sampled here, then steps 4-6)."""
    sv = stack._sv
    place_pos, place_rot, root_pos, root_rot = char_args[:4]
    for i in np.flatnonzero(sv[rows, SK.FLAG] != 0.0):
        r, c = int(rows[i]), int(crows[i])
        ctrl = stack.controllers[r]
        one, cone = np.array([r], np.int64), np.array([c], np.int64)
        if sv[r, SK.FLAG] == SK.FLAG_START:
            sv[r, SK.FLAG] = 0.0
            yaw_now = 2.0 * math.atan2(float(place_rot[c, 3]), float(place_rot[c, 0]))
            ctrl._start(place_pos[c], yaw_now)
            ctrl._prev_root_pos[:] = root_pos[c]
            ctrl._prev_root_pos[2] -= ctrl._crouch
            ctrl._prev_root_rot[:] = root_rot[c]
            SK.gait_rows(float(dt), 0, one, cone, *char_args, *stack.state_args, *stack.rig_args)
        if sv[r, SK.FLAG] == SK.FLAG_TERRAIN:
            ctrl._terrain(place_pos[c])
            SK.gait_rows(float(dt), 1, one, cone, *char_args, *stack.state_args, *stack.rig_args)


class GaitController:
    """Locomotion for one character (see the module docstring).

    Public state: ``rig`` (the static analysis: ``rig.mode`` is 'walk', 'crawl' or
    'float'), ``version`` and ``goal_bodies`` (the bodies the gait drives),
    ``velocity`` (2,) and ``turn_rate`` (the filtered motion, character frame),
    ``speed_limit`` (m/s the styles allow now), ``group_phase`` (cycle of each group),
    ``step_state`` (0 stance, 1 flight, 3 owned by an animation per stepper).
    """

    # scalar state, in the gait stack's ``sv`` row (see ``_Scalar``)
    _yaw = _Scalar(SK.YAW)                    # unwrapped heading we integrate
    turn_rate = _Scalar(SK.TURN)
    _crouch = _Scalar(SK.CROUCH)
    _time = _Scalar(SK.TIME)
    _idle = _Scalar(SK.IDLE, bool)
    _started = _Scalar(SK.STARTED, bool)
    _written = _Scalar(SK.WRITTEN, bool)
    immobile = _Scalar(SK.IMMOBILE, bool)
    speed_limit = _Scalar(SK.SPEED_LIMIT)
    _cmd_w = _Scalar(SK.CMD_W)
    _L = _Scalar(SK.LEN)
    _replant = _Scalar(SK.REPLANT)
    _radius = _Scalar(SK.RADIUS)
    _slope_e = _Scalar(SK.SLOPE_E)
    min_crouch = _Scalar(SK.MIN_CROUCH)
    max_crouch = _Scalar(SK.MAX_CROUCH)
    bob_scale = _Scalar(SK.BOB_SCALE)

    def __init__(self, creature: Creature, style: str | GaitStyle = "walk") -> None:
        if not isinstance(creature, Creature):
            raise TypeError(f"GaitController needs a Creature, got {type(creature).__name__}")
        self._sv = np.zeros(SK.NSCALAR)
        self._gs = None
        self._gr = 0
        self._calls: dict = {}
        self.creature = creature
        self.rig: GaitRig = analyze(creature)
        r = self.rig
        F, S, G = r.nfoot, r.nstep, max(r.ngroup, 1)
        self.version = 1
        self.goal_bodies = np.array(sorted(set(int(b) for b in r.foot_body)), np.int32)
        # command and filtered motion (character frame)
        self._cmd_v = np.zeros(2)
        self._cmd_w = 0.0
        self.velocity = np.zeros(2)
        self.turn_rate = 0.0
        self.speed_limit = math.inf
        self._last_place = np.zeros(3)
        self._time = 0.0
        # terrain
        self._height = None
        self._normal = None
        self._vectorised = True
        # styles: per group a list of (style, weight) layers
        base = _as_style(style)
        self._layers: list[list[tuple[GaitStyle, float]]] = [[(base, 1.0)] for _ in range(G)]
        # per-frame arrays (kernel inputs), preallocated
        self.group_phase = np.zeros(G)
        self._group_support = np.zeros(G, np.int32)
        self.group_rate = np.zeros(G)
        self.group_duty = np.full(G, 0.6)
        self.group_sweep = np.zeros((G, 2))
        self.group_park = np.zeros(G)
        self.group_lift = np.zeros(G)
        self.group_bob = np.zeros(G)
        self.group_sway = np.zeros(G)
        # static scales read every frame: longest leg group (m), its half-length for the
        # teleport test, widest foot radius (m), half the body's footprint for the slope (m)
        self._L = float(np.max(r.group_length)) if r.ngroup else max(float(creature.size[2]), 0.1)
        self._replant = 0.5 * max(float(np.max(r.group_length)) if r.ngroup else 0.5, 0.05)
        self._radius = float(np.max(r.group_radius)) if r.ngroup else 0.0
        self._slope_e = max(0.5 * float(max(creature.size[0], creature.size[1])), 0.05)
        self._crouch_want = np.zeros(G)
        self.path = np.zeros((G, PATH_SAMPLES, 3))
        self.step_trigger = np.zeros(S)
        self.step_duty_scale = np.ones(S)
        self.step_lift_scale = np.ones(S)
        self.step_state = np.zeros(S, np.int32)
        self.step_progress = np.zeros(S)
        self.step_prev_u = np.zeros(S)
        self.step_parked = np.ones(S, np.int32)
        self.step_lift_u = np.zeros(S)
        self.step_done = np.zeros(S, np.int32)
        self.foot_world = np.zeros((F, 3))
        self.foot_lift = np.zeros((F, 3))
        self.foot_yaw = np.zeros(F)
        self.foot_lift_yaw = np.zeros(F)
        self.foot_target = np.zeros((F, 3))
        self.foot_target_yaw = np.zeros(F)
        self._query = np.zeros((3 * F + 5, 2))
        self._heights = np.zeros(3 * F + 5)
        self._place3 = np.zeros(3)
        self._vel3 = np.zeros(3)
        #: Each foot's ground slope (world dz/dx, dz/dy) and its tilt quaternion in its own
        #: heading frame: frozen while the foot is planted, so a planted foot never turns
        #: (see ``K.gait_pose``)
        self.foot_slope = np.zeros((F, 2))
        self._foot_tilt = np.zeros((F, 4))
        self._foot_tilt[:, 0] = 1.0
        self._slope_w = np.zeros(2)
        #: The ground plane under the character, world (nx, ny, nz, d): n . x = d, updated
        #: each step from the terrain under the root and its slope.
        self.ground_plane = np.array([0.0, 0.0, 1.0, 0.0])
        self._root_dq = np.array([1.0, 0.0, 0.0, 0.0])
        self._root_dpos = np.zeros(3)
        self._bob = np.zeros(7)               # see ``_kernels.gait_pose``
        self._row = np.zeros(8)
        self._tilt = np.zeros(2)             # filtered slope (dz/dx, dz/dy) in the character frame
        self._crouch = 0.0
        self._lean = np.zeros(2)
        self._prev_v = np.zeros(2)
        self._started = False
        #: IK-calibrated half-sweep per group (m) at the crouches ``_cal_crouch`` (m), and
        #: the crouch the creature needs at least (m); see ``_calibrate``.
        self._cal_crouch = np.array([0.0, 0.04, 0.08, 0.12, 0.17, 0.23, 0.3]) * (
            float(np.max(r.group_length)) if r.ngroup else 0.0)
        self._cal_sweep = np.zeros((G, self._cal_crouch.shape[0], 2))
        self.min_crouch = 0.0
        self.max_crouch = math.inf
        #: Hip-to-foot stretch (over chain length) the IK was verified to meet, per group:
        #: a planted foot stretched further takes a rescue step.
        self.group_stretch = np.full(G, 10.0)
        #: Constant IK miss of each foot at the rest stance (F, 3), character space, m: taken
        #: off the foot goals every frame (see ``_calibrate``).
        self.foot_bias = np.zeros((F, 3))
        #: 0 when the calibration found the feet's IK miss changing with the hip bob: the
        #: styles' bob is then left out
        self.bob_scale = 1.0
        #: True while the calibrated sweeps leave the legs no step the IK meets: the
        #: character stands (see ``step``)
        self.immobile = False
        self._prev_root_pos = np.zeros(3)
        self._prev_root_rot = np.array([1.0, 0.0, 0.0, 0.0])
        #: the feet's goals the last ``step`` wrote (character space), for ``observe``
        self._goal_written = np.zeros((F, 7))
        self._written = False
        self._group_steps = [[int(s) for s in np.flatnonzero(r.step_group == g)] for g in range(G)]
        self._idle = True
        self._rebuild_patterns()
        if r.nstep:
            self._calibrate()
        self._cal_bias = self.foot_bias.copy()
        self._observe_limit = np.full(r.nfoot, OBSERVE_LIMIT)
        # style constants the stage kernel reads (``_fill_tables``, ``_style_cache``)
        self._tab = np.zeros((G, self._need_layers(), self._need_rows(), 8))
        self._tab_n = np.zeros((G, self._tab.shape[1]), np.int64)
        self._tab_w = np.zeros((G, self._tab.shape[1]))
        self._tab_nl = np.zeros(G, np.int64)
        self._sc_cap = np.zeros(G)
        self._sc_top = np.zeros(G)
        self._sc_ptop = np.zeros((G, 8))
        self._sc_sa = np.zeros((G, 2))
        self._sc_settle = np.zeros(G)
        # the ground arrays of a standalone ``step`` call (the runtime passes its own)
        self._ground_out = np.zeros((1, 4))
        self._ground_set_out = np.zeros(1, np.bool_)
        GaitStack([self])                    # this controller's own stack of one row
        self._fill_tables()
        self._style_cache()                  # the calibration moved the sweeps and crouches

    # -- the gait stack ------------------------------------------------------------------

    def _need_layers(self) -> int:
        return max(len(layers) for layers in self._layers)

    def _need_rows(self) -> int:
        return max(st.table.shape[0] for layers in self._layers for st, _ in layers)

    def _bind(self, stack: GaitStack, row: int) -> None:
        """Make this controller's arrays views of row ``row`` of ``stack``."""
        for name in _STACK_FIELDS:
            setattr(self, name, getattr(stack, name)[row])
        self._gs, self._gr = stack, row
        self._calls = {}

    def _fill_tables(self) -> None:
        """The style layers' speed tables into the padded arrays the kernel reads (a
        larger stack of its own when they do not fit)."""
        if self._need_layers() > self._tab.shape[1] or self._need_rows() > self._tab.shape[2]:
            GaitStack([self])
        self._tab[:] = 0.0
        self._tab_n[:] = 0
        self._tab_w[:] = 0.0
        for g, layers in enumerate(self._layers):
            self._tab_nl[g] = len(layers)
            for k, (st, w) in enumerate(layers):
                t = st.table
                self._tab[g, k, :t.shape[0]] = t
                self._tab_n[g, k] = t.shape[0]
                self._tab_w[g, k] = w

    def _terrain(self, place_pos) -> None:
        """Step 4 of ``step`` for a terrain given by Python functions: sample the points
        the kernel wrote (``_query``), the mean ground under the feet, the normal."""
        F = self.rig.nfoot
        hts = self._heights
        self._sample(self._query, hts)
        self._sv[SK.GROUND_IN] = float(np.mean(hts[2 * F:3 * F])) if F else float(hts[3 * F])
        if self._normal is not None:
            n = np.asarray(self._normal(place_pos[0], place_pos[1]), dtype=float).reshape(3)
            self._sv[SK.NX], self._sv[SK.NY], self._sv[SK.NZ] = float(n[0]), float(n[1]), float(n[2])

    def observe(self, char_pos, char_rot) -> None:
        """What the IK made of the goals the last ``step`` wrote: ``char_pos`` (nbody, 3)
        character space (the runtime passes its IK output after every solve). Each foot's
        miss at its goal is taken off its next goal (``K.observe_feet``), so a planted foot
        lands and stays on the ground even where the IK's miss changes with the stance
        (uneven ground, a branching leg): no blanket clearance above the terrain is needed."""
        if not self._written or self.rig.nfoot == 0:
            return
        self._written = False
        r = self.rig
        K.observe_feet(char_pos, char_rot, self._goal_written, r.foot_body, r.foot_stepper, self.step_state,
                       r.foot_rest_rot, r.foot_contact, self.foot_bias, self._cal_bias, OBSERVE_GAIN,
                       OBSERVE_FLIGHT_GAIN, self._observe_limit)

    def _calibrate(self, tol: float = CAL_TOL, tries: int = 12) -> None:
        """Measure with the IK itself how far each group's feet may sweep from their rest
        spots (every foot of the group displaced together along +-x and +-y, as the body
        moves over planted feet) at a few crouch depths of the hips, then pick the least
        crouch that gives every group the most sweep relative to its leg length. The
        geometric reach of ``rig`` assumes each leg bends freely; branching legs (whose feet
        keep their relative positions), single-segment legs and spines reach less, and
        crouching helps some legs while it jams others, so the solver decides.

        The criterion is what the eye (and the metrics) see: a planted foot must not
        *move*. The IK may miss a foot by a constant offset (a branching leg whose feet
        cannot all sit exactly at their rest spots misses them by a millimetre or two at
        rest); that offset is measured at the rest stance (``foot_bias``, character space)
        and taken off the foot goals every frame, so the output lands where the gait wants
        it. What must stay small is how much the miss *changes* while the foot sweeps
        under the body, the other feet step and the hips bob: at most ``tol`` (m) from
        the rest stance's miss, so any two frames of one stance differ by at most 2 tol."""
        from engine.ik import IKGoals, plan_for, solve_ik

        c, r = self.creature, self.rig
        if r.mode == "crawl":
            # a crawler's body lies on the ground: it never crouches (see ``step``)
            self._cal_crouch = np.zeros(1)
            self._cal_sweep = np.zeros((self._cal_sweep.shape[0], 1, 2))
        plan = plan_for(c, [int(b) for b in self.goal_bodies])
        scratch = plan.make_scratch()
        goals = IKGoals(c.nbody)
        out_p = np.zeros((c.nbody, 3))
        out_r = np.zeros((c.nbody, 4))
        out_r[:, 0] = 1.0
        fb = r.foot_body
        foot_len = r.group_length[r.step_group[r.foot_stepper]]
        pivots = [f for f in range(r.nfoot) if r.foot_knee[f, 3] > 0.0]

        def miss_of(root_drop: float, bob: float, feet, dx: float, dy: float, alternate: bool = False,
                    lift: float = 0.0):
            """(miss (F, 3) = IK output - goal, counted (F,) bool) for one test stance."""
            goals.clear()
            # lifted compass feet swing on their sphere in the gait: they neither hold the
            # hips nor count as misses here. Other lifted feet count: a swing foot the IK
            # cannot meet pulls on the planted ones (measured: excluding them let the
            # forkstrider's planted feet slide 7 mm)
            skip = [f for f in range(r.nfoot) if alternate and lift > 0 and f in feet and r.foot_rigid[f]
                    and r.step_rank[r.foot_stepper[f]] % 2 == 1]
            for f in range(r.nfoot):
                p = r.foot_neutral[f].copy()
                if f in feet:
                    # alternate: every other stepper (by rank) the other way and lifted, as
                    # stance and flight feet are while walking
                    odd = alternate and r.step_rank[r.foot_stepper[f]] % 2 == 1
                    sign = -1.0 if odd else 1.0
                    p[0] += sign * dx
                    p[1] += sign * dy
                    if odd:
                        p[2] += lift
                goals.set(int(fb[f]), p, r.foot_rest_rot[f], 1.0, 1.0)
            root = c.body_rest_pos[0].copy()
            root[2] -= root_drop - bob                # the hips bob up while feet are planted
            rigid = [f for f in range(r.nfoot) if r.foot_rigid[f] and f not in skip]
            if rigid:
                # compass legs: the hips sit at leg's length above the planted feet
                dz = []
                for f in rigid:
                    j = goals.goal_pos[fb[f]] + r.foot_jointrel[f]
                    h = c.body_rest_pos[0] + r.foot_hip[f]
                    need = math.sqrt(max(r.foot_chain[f] ** 2 - (h[0] - j[0]) ** 2 - (h[1] - j[1]) ** 2, 0.0))
                    dz.append(j[2] + need - h[2])
                root[2] = c.body_rest_pos[0][2] + float(np.mean(dz))
            for f in pivots:
                # pivot feet turn about their contact points, as in the gait (``K.pivot_goal``)
                b = int(fb[f])
                K.pivot_goal(goals.goal_pos[b], goals.goal_rot[b], r.foot_rest_rot[f],
                             root + _rotate(c.body_rest_rot[0], r.foot_hip[f]), r.foot_knee[f], r.foot_contact[f])
            solve_ik(plan, root, c.body_rest_rot[0], goals, out_p, out_r, scratch)
            miss = out_p[fb] - goals.goal_pos[fb]
            counted = np.ones(r.nfoot, bool)
            counted[skip] = False
            # how stretched the bending legs were (hip joint to foot joint over chain)
            for f in feet:
                if not r.foot_rigid[f] and r.foot_chain[f] > 0:
                    h = root + _rotate(c.body_rest_rot[0], r.foot_hip[f])
                    j = goals.goal_pos[fb[f]] + r.foot_jointrel[f]
                    stretch_seen[0] = max(stretch_seen[0], float(np.linalg.norm(j - h)) / r.foot_chain[f])
            return miss, counted

        def deviation(miss, counted, base) -> float:
            d = np.linalg.norm(miss - base, axis=1)
            return float(np.max(d[counted])) if np.any(counted) else 0.0

        def crawl_passes(e: float, lift: float, base) -> bool:
            """A crawler's forward half-sweep ``e`` (m) passes when the stances its inch-worm
            wave really produces are met (section 4.2: pseudo-feet step in a wave along the
            body). The walking test above moves every other pseudo-foot the opposite way, a
            stance the wave never makes: it asks the spine between neighbouring pseudo-feet to
            stretch or shrink by 2e and held crawlers to 1-4% of their spacing per stance. Here
            each pseudo-foot goes from +e to -e (body frame) during its stance and back,
            lifted, during its flight, started at its own trigger; phases across the whole
            cycle, with the body moving forward and backward (a wave read the other way), at
            the shortest and longest duty factor the styles ask for, and all feet displaced
            together (the root ahead of or behind every pseudo-foot)."""
            trig = self.step_trigger[r.foot_stepper]
            dsc = self.step_duty_scale[r.foot_stepper]
            duties = [float(np.min(st.table[:, 2])) for layers in self._layers for st, _ in layers]
            duties += [float(np.max(st.table[:, 2])) for layers in self._layers for st, _ in layers]
            allf = list(range(r.nfoot))
            for sign in (1.0, -1.0):
                if deviation(*miss_of(0.0, 0.0, allf, sign * e, 0.0), base) > tol:
                    return False
            for duty in sorted(set(duties)):
                for sign in (1.0, -1.0):
                    for t in np.arange(CRAWL_CAL_PHASES) / CRAWL_CAL_PHASES:
                        goals_dx = np.zeros(r.nfoot)
                        goals_dz = np.zeros(r.nfoot)
                        for f in range(r.nfoot):
                            du = min(max(duty * float(dsc[f]), 0.05), 0.95)
                            ph = (t - float(trig[f])) % 1.0
                            if ph < du:
                                goals_dx[f] = e * (1.0 - 2.0 * ph / du)
                            else:
                                q = (ph - du) / (1.0 - du)
                                goals_dx[f] = e * (2.0 * q - 1.0)
                                goals_dz[f] = lift * math.sin(math.pi * q)
                        if deviation(*crawl_miss(sign * goals_dx, goals_dz), base) > tol:
                            return False
            return True

        def crawl_miss(dx, dz):
            """(miss, counted) with each pseudo-foot displaced by its own dx (forward) and dz."""
            goals.clear()
            for f in range(r.nfoot):
                p = r.foot_neutral[f].copy()
                p[0] += dx[f]
                p[2] += dz[f]
                goals.set(int(fb[f]), p, r.foot_rest_rot[f], 1.0, 1.0)
            solve_ik(plan, c.body_rest_pos[0], c.body_rest_rot[0], goals, out_p, out_r, scratch)
            return out_p[fb] - goals.goal_pos[fb], np.ones(r.nfoot, bool)

        # the largest hip bob the layered styles ask for (leg lengths of the longest group)
        bob_margin = max(float(np.max(st.table[:, 4])) for layers in self._layers for st, _ in layers) * float(
            np.max(r.group_length)) if r.mode == "walk" else 0.0
        groups_feet = [[f for f in range(r.nfoot) if r.step_group[r.foot_stepper[f]] == g] for g in range(r.ngroup)]
        stretch_seen = [0.0]
        nk = self._cal_crouch.shape[0]
        verified = np.zeros((r.ngroup, nk))
        base_at = np.zeros((nk, r.nfoot, 3))
        usable = np.zeros(nk, bool)
        level_bob = np.zeros(nk)
        for k, drop in enumerate(self._cal_crouch):
            base, _ = miss_of(drop, bob_margin, (), 0.0, 0.0)
            low, _ = miss_of(drop, 0.0, (), 0.0, 0.0)
            # the rest stance must be met up to a small constant offset, the same with the
            # hips bobbed up or not; legs whose miss changes with the bob walk without it
            bob = bob_margin
            if deviation(low, np.ones(r.nfoot, bool), base) > tol:
                base, bob = low, 0.0
            base_at[k] = base
            level_bob[k] = bob
            if np.any(np.linalg.norm(base, axis=1) > BIAS_SHARE * foot_len):
                continue
            usable[k] = True
            for g in range(r.ngroup):
                lift = float(np.max(self.path[g, :, 1])) * float(self._params(g, 0.0)[3]) * r.group_length[g]
                seen = 0.0
                # forward/back (the stride) and sideways (turning, side steps) apart: some legs
                # sweep far along the body and hardly across it
                for axis in range(2):
                    d = 0.5 * r.group_length[g]
                    def passes(d: float, axis=axis, lift=lift, drop=drop, bob=bob, g=g, base=base) -> bool:
                        e = 1.25 * d                       # a margin for bob, lean, tilt and turning
                        stretch_seen[0] = 0.0
                        if r.mode == "crawl" and axis == 0:
                            return crawl_passes(e, lift, base)
                        # same way, alternating with every other stepper lifted, alternating all planted
                        for sign in (1.0, -1.0):
                            dx, dy = (sign * e, 0.0) if axis == 0 else (0.0, sign * e)
                            for alt, h in ((False, 0.0), (True, lift), (True, 0.0)):
                                if deviation(*miss_of(drop, bob, groups_feet[g], dx, dy, alt, h), base) > tol:
                                    return False
                        return True

                    top = 0.5 * r.group_length[g]
                    d = top
                    for _ in range(tries):
                        if passes(d):
                            # (no finer search: the tests sample a few stances, and the 30% steps
                            # leave the margin the stances between them need; refining by 1.2
                            # let a random creature's planted feet slide 7 mm)
                            seen = max(seen, stretch_seen[0])
                            break
                        d *= 0.7
                    else:
                        d = 0.0
                    # a half-sweep under MIN_SWEEP_SHARE of the leg is no step: it only churns the IK
                    self._cal_sweep[g, k, axis] = d if d >= MIN_SWEEP_SHARE * r.group_length[g] else 0.0
                if np.all(self._cal_sweep[g, k] > 0):
                    verified[g, k] = seen
        # the crouch is chosen by the geometric mean of the two half-sweeps
        self.calibrated_sweep = self._cal_sweep.copy()     # (G, crouch levels, 2) before the choice below
        score = np.min(np.sqrt(self._cal_sweep[:, :, 0] * self._cal_sweep[:, :, 1]) / r.group_length[:, None], axis=0)
        best = float(np.max(score))
        # the least crouch that keeps most of the best sweep (a deeper crouch buys a longer
        # stride but looks like a crouch walk; a shorter stride is made up by cadence)
        k = (int(np.flatnonzero(score >= CROUCH_SWEEP_SHARE * best)[0]) if best > 0
             else int(np.argmax(usable)) if usable.any() else 0)
        self.min_crouch = float(self._cal_crouch[k])
        self.foot_bias[:] = base_at[k] if usable[k] else 0.0
        self.bob_scale = 1.0 if level_bob[k] > 0 or bob_margin == 0.0 else 0.0
        for g in range(r.ngroup):
            if verified[g, k] > 0:
                self.group_stretch[g] = verified[g, k]
        # ... and the deepest crouch (a sneak, a heavy gait) that keeps every group able to
        # step with the same constant offset of the feet (the crouch changes under planted feet)
        top = k
        while (top + 1 < len(score) and best > 0 and score[top + 1] >= 0.5 * best
               and np.max(np.linalg.norm(base_at[top + 1] - base_at[k], axis=1)) <= tol):
            top += 1
        self.max_crouch = float(self._cal_crouch[top])
        # no shallower crouch than the chosen one is used, so the table starts there
        self._cal_sweep[:, :k] = self._cal_sweep[:, k:k + 1]

    def _sweep(self, g: int, crouch: float) -> tuple[float, float]:
        """Calibrated half-sweeps (m) of group g at hip crouch ``crouch`` (m): forward/back
        and sideways."""
        cc = self._cal_crouch
        t = self._cal_sweep
        if crouch <= cc[0]:
            return float(t[g, 0, 0]), float(t[g, 0, 1])
        for k in range(cc.shape[0] - 1):
            if crouch <= cc[k + 1]:
                a = (crouch - cc[k]) / (cc[k + 1] - cc[k])
                return (float(t[g, k, 0] * (1 - a) + t[g, k + 1, 0] * a),
                        float(t[g, k, 1] * (1 - a) + t[g, k + 1, 1] * a))
        return float(t[g, -1, 0]), float(t[g, -1, 1])

    # -- control -------------------------------------------------------------------------

    def command(self, velocity, turn_rate: float) -> None:
        """Desired velocity (forward, left) m/s in the heading frame and turn rate rad/s."""
        v = np.asarray(velocity, dtype=float)
        if v.shape != (2,) or not np.all(np.isfinite(v)) or not math.isfinite(float(turn_rate)):
            raise GaitError(f"command: velocity must be 2 finite numbers and turn_rate finite, got {velocity!r}, "
                            f"{turn_rate!r}")
        self._cmd_v[:] = v
        self._cmd_w = float(turn_rate)

    def set_terrain(self, height, normal=None) -> None:
        """``height(x, y) -> z`` (world; arrays in, arrays out is fastest) and optionally
        ``normal(x, y) -> (3,)``; None is the flat plane z = 0."""
        if height is not None and not callable(height):
            raise GaitError(f"set_terrain: height must be a function height(x, y) -> z or None, got "
                            f"{type(height).__name__}")
        if normal is not None and not callable(normal):
            raise GaitError(f"set_terrain: normal must be a function normal(x, y) -> (3,) or None, got "
                            f"{type(normal).__name__}")
        self._height = height
        self._normal = normal
        self._sv[SK.TERRAIN] = 0.0 if height is None and normal is None else 1.0
        self._sv[SK.HAS_NORMAL] = 0.0 if normal is None else 1.0
        self._vectorised = True
        if height is not None:
            try:
                z = np.asarray(height(np.zeros(2), np.zeros(2)), dtype=float)
                self._vectorised = z.shape == (2,)
            except Exception:                                  # noqa: BLE001 - scalar-only functions
                self._vectorised = False
            z0 = self._sample_scalar(0.0, 0.0)
            if not math.isfinite(z0):
                raise GaitError(f"set_terrain: height(0, 0) returned {z0!r}, not a finite number")
        self._started = False                                  # replant on the new ground

    def set_style(self, style, group: int | None = None, weight: float = 1.0, *, layer: bool = False) -> None:
        """Use ``style`` (a name such as 'trot', a path, or a GaitStyle) for leg group
        ``group`` (None: every group). ``layer=True`` puts it on top of the current styles
        with ``weight`` (numbers blend linearly, step triggers along the shorter way round
        the cycle), e.g. a limp over a walk; otherwise it replaces them."""
        st = _as_style(style)
        if not (isinstance(weight, (int, float)) and math.isfinite(weight) and 0.0 <= weight <= 1.0):
            raise GaitError(f"set_style: weight must be in [0, 1], got {weight!r}")
        ng = len(self._layers)
        if group is not None and not (isinstance(group, (int, np.integer)) and 0 <= group < max(self.rig.ngroup, 1)):
            raise GaitError(f"set_style: creature '{self.creature.name}' has {self.rig.ngroup} leg group(s), "
                            f"got group {group!r}")
        groups = range(ng) if group is None else [int(group)]
        for g in groups:
            if layer:
                self._layers[g] = [(s, w) for s, w in self._layers[g] if s is not st] + [(st, float(weight))]
            else:
                self._layers[g] = [(st, 1.0)]
        self._rebuild_patterns()

    def styles(self, group: int = 0) -> list[tuple[str, float]]:
        """(style name, weight) layers of a group, bottom first."""
        return [(s.name, w) for s, w in self._layers[group]]

    # -- static per-style arrays ----------------------------------------------------------

    def _rebuild_patterns(self) -> None:
        self._rebuild_paths()
        if self._gs is not None:             # (made at the end of __init__)
            self._fill_tables()
            self._style_cache()

    def _rebuild_paths(self) -> None:
        r = self.rig
        for g in range(len(self._layers)):
            layers = self._layers[g]
            path = layers[0][0].path.copy()
            for st, w in layers[1:]:
                path += w * (st.path - path)
            self.path[g] = path
            if r.nstep == 0:
                continue
            steps = r.group_steppers(g)
            npair = int(math.ceil(len(steps) / 2))
            side = r.step_side[steps]
            rank = r.step_rank[steps]
            row = rank if len(steps) <= 6 else rank // 2 if np.all(side != 0) else rank
            trig, dsc, lsc = layers[0][0].stepper_pattern(side, row, npair)
            for st, w in layers[1:]:
                t2, d2, l2 = st.stepper_pattern(side, row, npair)
                diff = (t2 - trig + 0.5) % 1.0 - 0.5
                trig = (trig + w * diff) % 1.0
                dsc = dsc + w * (d2 - dsc)
                lsc = lsc + w * (l2 - lsc)
            if r.mode == "crawl":
                # inch-worm: a wave from the front to the back along the body, as tight as
                # it can be while one pseudo-foot always holds the ground: neighbours lift
                # 1/(n-1) of the shortest flight apart, so the last lifts as the first lands.
                # A spine of rigid bodies bends but cannot stretch, so the spacing of two
                # pseudo-feet changes only while one of them flies; the closer in time they
                # lift, the less it changes for the same stride (spreading the wave over
                # 0.55 of the cycle held crawlers to 1-4% of their spacing per stance)
                n = len(steps)
                duty = max(float(np.max(st.table[:, 2])) for st, _ in layers)
                trig = ((1.0 - duty) * rank / max(n - 1, 1)) % 1.0
            elif len(steps) > 2 and np.all(r.foot_rigid[r.step_foot_adr[steps]] == 1):
                # knee-less legs: the hips ride at one leg length over the planted feet, so
                # every planted foot must sit as far from its hip as the others; only two
                # sets stepping in turn (alternate rows, the sides opposed) can do that
                row2 = rank // 2 if np.all(side != 0) else rank
                trig = 0.5 * ((row2 + (side < 0)) % 2)
            self.step_trigger[steps] = trig
            self.step_duty_scale[steps] = dsc
            self.step_lift_scale[steps] = lsc

    def _style_cache(self) -> None:
        """What ``step`` needs of the styles that does not change from frame to frame
        (rebuilt when a style or the calibration changes), into the arrays the kernel
        reads: per group the cadence cap (cycles/s), the top speed entry (leg lengths/s)
        and its row, and the half-sweeps at the top entry's crouch; the style scalars of
        group 0."""
        r = self.rig
        for g in range(r.ngroup):
            Lg = r.group_length[g]
            mc = self._style_scalar(g, "max_cadence") / math.sqrt(max(Lg, 1e-3))
            self._sc_cap[g] = mc * r.group_ratio[g]
            self._sc_settle[g] = 0.5 * mc
            top = self._layers[g][0][0].table[-1, 0]
            self._sc_top[g] = top
            self._sc_ptop[g] = self._params(g, top)
            self._sc_sa[g] = self._sweep(g, min(max(self._sc_ptop[g, 7] * Lg, self.min_crouch), self.max_crouch))
        self._sv[SK.ACCEL] = self._style_scalar(0, "accel")
        self._sv[SK.TURN_ACCEL] = self._style_scalar(0, "turn_accel")
        self._sv[SK.SLOPE_ALIGN] = self._style_scalar(0, "slope_align")

    def _params(self, g: int, rel_speed: float) -> np.ndarray:
        """The blended speed-entry row of group g at ``rel_speed`` (into a reused buffer)."""
        row = self._row
        layers = self._layers[g]
        _interp_into(layers[0][0].table, rel_speed, row)
        for st, w in layers[1:]:
            t = st.table
            # blend each column toward the layer's value
            k = _bracket(t[:, 0], rel_speed)
            for j in range(1, 8):
                v = _lerp_col(t, k, rel_speed, j)
                row[j] += w * (v - row[j])
        return row

    def _style_scalar(self, g: int, name: str) -> float:
        layers = self._layers[g]
        v = getattr(layers[0][0], name)
        for st, w in layers[1:]:
            v += w * (getattr(st, name) - v)
        return v

    # -- terrain ---------------------------------------------------------------------------

    def _sample_scalar(self, x: float, y: float) -> float:
        if self._height is None:
            return 0.0
        return float(np.asarray(self._height(x, y), dtype=float).reshape(()))

    def _sample(self, q: np.ndarray, out: np.ndarray) -> None:
        if self._height is None:
            out[:] = 0.0
            return
        if self._vectorised:
            z = np.asarray(self._height(q[:, 0], q[:, 1]), dtype=float)
            if z.shape != out.shape:
                raise GaitError(f"terrain height returned shape {z.shape} for {out.shape[0]} points")
            out[:] = z
        else:
            for i in range(q.shape[0]):
                out[i] = self._sample_scalar(q[i, 0], q[i, 1])
        if not np.all(np.isfinite(out)):
            i = int(np.flatnonzero(~np.isfinite(out))[0])
            raise GaitError(f"terrain height({q[i, 0]:.3f}, {q[i, 1]:.3f}) is {out[i]!r}, not finite")

    # -- one frame -------------------------------------------------------------------------

    def _start(self, place_pos, yaw) -> None:
        """Plant every foot at its rest spot under the current placement."""
        r = self.rig
        self._yaw = yaw
        c, s = math.cos(yaw), math.sin(yaw)
        F = r.nfoot
        for f in range(F):
            n = r.foot_neutral[f]
            self.foot_world[f, 0] = place_pos[0] + c * n[0] - s * n[1]
            self.foot_world[f, 1] = place_pos[1] + s * n[0] + c * n[1]
        if F:
            self._sample(self.foot_world[:, :2].copy(), self._heights[:F])
            self.foot_world[:, 2] = self._heights[:F] + r.foot_offset
            place_pos[2] = float(np.mean(self._heights[:F]))      # stand on the ground at once
        else:
            place_pos[2] = self._sample_scalar(float(place_pos[0]), float(place_pos[1]))
        self.foot_yaw[:] = yaw
        self.step_state[:] = K.STANCE
        self.step_parked[:] = 1
        self.step_done[:] = 0
        self.step_prev_u[:] = (self.group_phase[r.step_group] - self.step_trigger) % 1.0 if r.nstep else 0.0
        # the torso starts aligned to the ground it stands on (a filter settling in from
        # level would turn the hips under planted feet)
        e = max(0.5 * float(max(self.creature.size[0], self.creature.size[1])), 0.05)
        if self._normal is not None:
            n = np.asarray(self._normal(place_pos[0], place_pos[1]), dtype=float).reshape(3)
            nz = max(float(n[2]), 1e-3)
            gx, gy = -float(n[0]) / nz, -float(n[1]) / nz
            self._tilt[0], self._tilt[1] = c * gx + s * gy, -s * gx + c * gy
        else:
            h4 = [self._sample_scalar(place_pos[0] + a * e, place_pos[1] + b * e)
                  for a, b in ((c, s), (-c, -s), (-s, c), (s, -c))]
            self._tilt[0], self._tilt[1] = (h4[0] - h4[1]) / (2 * e), (h4[2] - h4[3]) / (2 * e)
        self.foot_slope[:, 0] = c * self._tilt[0] - s * self._tilt[1]
        self.foot_slope[:, 1] = s * self._tilt[0] + c * self._tilt[1]
        self._bob[3] = 0.0                    # compass legs: no held hip height yet
        self._bob[6] = 0.0                    # ... and no hip hike to ease out
        # start crouched as the style wants at rest (straight legs must bend to step)
        self._crouch = min(max((max(self._params(g, 0.0)[7] * r.group_length[g], self.min_crouch)
                                for g in range(r.ngroup)), default=0.0), self.max_crouch)
        self._lean[:] = 0.0
        self._last_place[:] = place_pos
        self._started = True

    def step(self, dt, place_pos, place_rot, root_pos, root_rot, goal_pos, goal_rot, goal_pw, goal_rw) -> None:
        """Advance the gait by ``dt`` seconds, writing into the given views (see the
        runtime's contract in the module docstring of ``engine.gait``): steps 1-6 of the
        module docstring, in ``engine.gait._step_kernels.gait_rows`` (the runtime calls
        it for all the walking characters of a stack at once, ``gait_stage``)."""
        args = (place_pos[None], place_rot[None], root_pos[None], root_rot[None], goal_pos[None], goal_rot[None],
                goal_pw[None], goal_rw[None], self._ground_out, self._ground_set_out)
        gait_stage(dt, self._gs, np.array([self._gr], np.int64), np.zeros(1, np.int64), args)


def _as_style(style) -> GaitStyle:
    if isinstance(style, GaitStyle):
        return style
    if isinstance(style, str):
        try:
            return load_style(style)
        except GaitStyleError:
            raise
    raise GaitError(f"a gait style is a name, a path or a GaitStyle, got {type(style).__name__}")


def _bracket(speeds: np.ndarray, x: float) -> int:
    n = speeds.shape[0]
    k = 0
    while k + 1 < n and speeds[k + 1] <= x:
        k += 1
    return k


def _lerp_col(t: np.ndarray, k: int, x: float, j: int) -> float:
    n = t.shape[0]
    if k + 1 >= n or x <= t[0, 0]:
        return float(t[k if x > t[0, 0] else 0, j])
    a = (x - t[k, 0]) / (t[k + 1, 0] - t[k, 0])
    return float(t[k, j] + a * (t[k + 1, j] - t[k, j]))


def _interp_into(t: np.ndarray, x: float, out: np.ndarray) -> None:
    """Row of the speed table ``t`` at speed ``x`` (clamped at both ends), into ``out``."""
    n = t.shape[0]
    k = _bracket(t[:, 0], x)
    if k + 1 >= n or x <= t[0, 0]:
        out[:] = t[k if x > t[0, 0] else 0]
        return
    a = (x - t[k, 0]) / (t[k + 1, 0] - t[k, 0])
    np.subtract(t[k + 1], t[k], out=out)
    out *= a
    out += t[k]


def _rotate(q, v):
    w, x, y, z = q
    u = np.array([x, y, z])
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _pitch_roll_into(pitch: float, roll: float, out: np.ndarray) -> None:
    """Quaternion of a rotation by ``pitch`` about +y after ``roll`` about +x."""
    out[0], out[1], out[2], out[3] = K._pitch_roll(pitch, roll)
