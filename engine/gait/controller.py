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


class GaitController:
    """Locomotion for one character (see the module docstring).

    Public state: ``rig`` (the static analysis: ``rig.mode`` is 'walk', 'crawl' or
    'float'), ``version`` and ``goal_bodies`` (the bodies the gait drives),
    ``velocity`` (2,) and ``turn_rate`` (the filtered motion, character frame),
    ``speed_limit`` (m/s the styles allow now), ``group_phase`` (cycle of each group),
    ``step_state`` (0 stance, 1 flight, 3 owned by an animation per stepper).
    """

    def __init__(self, creature: Creature, style: str | GaitStyle = "walk") -> None:
        if not isinstance(creature, Creature):
            raise TypeError(f"GaitController needs a Creature, got {type(creature).__name__}")
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
        self._yaw = None                     # unwrapped heading we integrate
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
        self._cache = None                   # the calibration moved the sweeps and crouches
        self._cal_bias = self.foot_bias.copy()
        self._observe_limit = np.full(r.nfoot, OBSERVE_LIMIT)

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
        r = self.rig
        self._cache = None                   # per-style constants of ``step`` (``_style_cache``)
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

    def _style_cache(self) -> dict:
        """What ``step`` needs of the styles that does not change from frame to frame
        (rebuilt when a style or the calibration changes): per group the cadence cap
        (cycles/s), the top speed entry (leg lengths/s) and its row, and the half-sweeps at
        the top entry's crouch; the style scalars of group 0."""
        r = self.rig
        G = max(r.ngroup, 1)
        c = {"cap": np.zeros(G), "top": np.zeros(G), "p_top": np.zeros((G, 8)), "sa": np.zeros((G, 2)),
             "settle": np.zeros(G)}
        for g in range(r.ngroup):
            Lg = r.group_length[g]
            mc = self._style_scalar(g, "max_cadence") / math.sqrt(max(Lg, 1e-3))
            c["cap"][g] = mc * r.group_ratio[g]
            c["settle"][g] = 0.5 * mc
            top = self._layers[g][0][0].table[-1, 0]
            c["top"][g] = top
            c["p_top"][g] = self._params(g, top)
            c["sa"][g] = self._sweep(g, min(max(c["p_top"][g, 7] * Lg, self.min_crouch), self.max_crouch))
        c["accel"] = self._style_scalar(0, "accel")
        c["turn_accel"] = self._style_scalar(0, "turn_accel")
        c["slope_align"] = self._style_scalar(0, "slope_align")
        self._cache = c
        return c

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
        runtime's contract in the module docstring of ``engine.gait``)."""
        r = self.rig
        yaw_now = 2.0 * math.atan2(float(place_rot[3]), float(place_rot[0]))
        if (not self._started or self._yaw is None
                or math.hypot(place_pos[0] - self._last_place[0], place_pos[1] - self._last_place[1])
                > self._replant
                or abs(math.remainder(yaw_now - self._yaw, 2 * math.pi)) > 1e-6):
            # first frame, or the game moved the character itself: plant afresh
            self._start(place_pos, yaw_now)
            self._prev_root_pos[:] = root_pos
            self._prev_root_pos[2] -= self._crouch
            self._prev_root_rot[:] = root_rot
        self._time += dt
        L = self._L

        # 1. speed limit (no overreach) and acceleration-limited root motion
        sc = self._cache if self._cache is not None else self._style_cache()
        limit = math.inf                   # forward (m/s)
        limit_y = math.inf                 # sideways
        for g in range(r.ngroup):
            Lg = r.group_length[g]
            cap = sc["cap"][g]
            top = sc["top"][g]
            p = sc["p_top"][g]
            sa = sc["sa"][g]
            sb = self._sweep(g, self._crouch)
            duty = max(p[2], 0.05)
            limit = min(limit, cap * min(p[1] * Lg, 1.6 * min(sa[0], sb[0]) / duty), top * Lg * 1.25)
            limit_y = min(limit_y, cap * min(p[1] * Lg, 1.6 * min(sa[1], sb[1]) / duty), top * Lg * 1.25)
        self.speed_limit = limit
        cmd = self._cmd_v
        cmd_speed = math.hypot(cmd[0], cmd[1])
        w_cmd = self._cmd_w
        radius = self._radius
        # the command as a share of what the legs allow (an ellipse of velocities; a turn
        # moves feet either way, so it counts against the smaller limit)
        demand = 0.0
        if limit < math.inf:
            lo = max(min(limit, limit_y), 1e-12)
            demand = math.hypot(cmd[0] / max(limit, 1e-12), cmd[1] / max(limit_y, 1e-12)) + abs(w_cmd) * radius / lo
        if demand > 1.0:
            k = 1.0 / demand
            tx, ty, tw = cmd[0] * k, cmd[1] * k, w_cmd * k
        else:
            tx, ty, tw = cmd[0], cmd[1], w_cmd
        acc = sc["accel"] * L
        tacc = sc["turn_accel"]
        dvx, dvy = tx - self.velocity[0], ty - self.velocity[1]
        dv = math.hypot(dvx, dvy)
        if dv > acc * dt:
            dvx, dvy = dvx * acc * dt / dv, dvy * acc * dt / dv
        self._prev_v[:] = self.velocity
        self.velocity[0] += dvx
        self.velocity[1] += dvy
        dw = tw - self.turn_rate
        self.turn_rate += max(-tacc * dt, min(tacc * dt, dw))
        # integrate the placement: heading, then position in the mid-step heading
        yaw0 = self._yaw
        self._yaw = yaw0 + self.turn_rate * dt
        ym = 0.5 * (yaw0 + self._yaw)
        cm, sm = math.cos(ym), math.sin(ym)
        vx = cm * self.velocity[0] - sm * self.velocity[1]
        vy = sm * self.velocity[0] + cm * self.velocity[1]
        place_pos[0] += vx * dt
        place_pos[1] += vy * dt
        h = 0.5 * self._yaw
        place_rot[0], place_rot[1], place_rot[2], place_rot[3] = math.cos(h), 0.0, 0.0, math.sin(h)
        speed = math.hypot(self.velocity[0], self.velocity[1])
        idle = (cmd_speed < IDLE_SPEED * L and abs(w_cmd) < IDLE_TURN
                and speed < IDLE_SPEED * L and abs(self.turn_rate) < IDLE_TURN)
        # legs the calibration found unable to step at all (no sweep the IK meets along one
        # axis) stand: a step would move the planted feet
        self.immobile = r.nstep > 0 and min(limit, limit_y) <= 0.0
        if self.immobile:
            idle = True
        if self._idle and not idle and all(self.step_parked[s] == 1 for s in range(r.nstep)):
            # setting off from a stand: start each group's cycle just before its front
            # stepper lifts, so the first step comes at once instead of after up to a cycle
            for g in range(r.ngroup):
                steps = self._group_steps[g]
                first = min(steps, key=lambda k: r.step_rank[k])
                duty0 = self._params(g, 0.0)[2] * self.step_duty_scale[first]
                self.group_phase[g] = (self.step_trigger[first] + duty0 - 0.005) % 1.0
                for k in steps:
                    self.step_prev_u[k] = (self.group_phase[g] - self.step_trigger[k]) % 1.0
                    self.step_done[k] = 0
        self._idle = idle

        # 2. cadence per group, locked by the harmonized ratios
        base = 0.0
        for g in range(r.ngroup):
            Lg = r.group_length[g]
            v_eff = speed + abs(self.turn_rate) * r.group_radius[g]
            p = self._params(g, v_eff / Lg)
            sx, sy = self._sweep(g, self._crouch)
            duty = p[2]
            # the sweep along the direction of travel (on the ellipse of the two half-sweeps),
            # the smaller one for the turn
            ux, uy = self.velocity[0] / max(speed, 1e-12), self.velocity[1] / max(speed, 1e-12)
            s_dir = 1.0 / max(math.hypot(ux / max(sx, 1e-12), uy / max(sy, 1e-12)), 1e-12) if speed > 0 else sx
            stride = min(p[1] * Lg, 1.6 * s_dir / duty)
            stride_turn = min(p[1] * Lg, 1.6 * min(sx, sy) / duty)
            f_g = speed / max(stride, 1e-6) + abs(self.turn_rate) * r.group_radius[g] / max(stride_turn, 1e-6)
            settle = sc["settle"][g]
            if not idle:
                f_g = max(f_g, 0.35 * settle)
            elif any(self.step_parked[s] == 0 for s in self._group_steps[g]):
                f_g = settle
            base = max(base, f_g / r.group_ratio[g])
            self.group_duty[g] = duty
            self.group_sweep[g, 0] = 0.97 * sx
            self.group_sweep[g, 1] = 0.97 * sy
            self.group_park[g] = 0.03 * Lg
            self.group_lift[g] = p[3] * Lg
            gain = min(v_eff / Lg, 1.0)
            self.group_bob[g] = p[4] * Lg * gain * self.bob_scale
            self.group_sway[g] = p[5] * Lg * gain
            self._crouch_want[g] = p[7] * Lg
        for g in range(r.ngroup):
            self.group_rate[g] = base * r.group_ratio[g]

        # 3. stance/flight transitions and touchdown predictions
        self._place3[0], self._place3[1], self._place3[2] = place_pos[0], place_pos[1], self._yaw
        self._vel3[0], self._vel3[1], self._vel3[2] = vx, vy, self.turn_rate
        F = r.nfoot
        q = self._query
        if r.nstep:
            K.gait_plan(dt, self._place3, self._vel3, idle, self.group_rate, self.group_phase, self.group_duty,
                        self.group_sweep, self.group_park, self.path, r.step_group, self.step_trigger,
                        self.step_duty_scale, r.step_foot_adr, r.step_foot_num, self.step_state,
                        self.step_progress, self.step_prev_u, self.step_parked, self.step_lift_u, self.step_done,
                        r.foot_body,
                        r.foot_neutral,
                        self.foot_world, self.foot_lift, self.foot_yaw, self.foot_lift_yaw, self.foot_target,
                        self.foot_target_yaw, goal_pw, q, float(place_pos[2]), self._prev_root_pos,
                        self._prev_root_rot, r.foot_hip, r.foot_jointrel, r.foot_chain, r.foot_rigid,
                        self.group_stretch, self._group_support)
        # ground under the centre and four points around it (slope at the body's scale)
        e = self._slope_e
        cy, sy = math.cos(self._yaw), math.sin(self._yaw)
        q[3 * F, 0], q[3 * F, 1] = place_pos[0], place_pos[1]
        q[3 * F + 1, 0], q[3 * F + 1, 1] = place_pos[0] + e * cy, place_pos[1] + e * sy
        q[3 * F + 2, 0], q[3 * F + 2, 1] = place_pos[0] - e * cy, place_pos[1] - e * sy
        q[3 * F + 3, 0], q[3 * F + 3, 1] = place_pos[0] - e * sy, place_pos[1] + e * cy
        q[3 * F + 4, 0], q[3 * F + 4, 1] = place_pos[0] + e * sy, place_pos[1] - e * cy

        # 4. the ground
        hts = self._heights
        self._sample(q, hts)

        # 5. placement height and torso slope
        ground = float(np.mean(hts[2 * F:3 * F])) if F else float(hts[3 * F])
        a_h = 1.0 - math.exp(-dt / HEIGHT_TAU)
        place_pos[2] += a_h * (ground - place_pos[2])
        if self._normal is not None:
            n = np.asarray(self._normal(place_pos[0], place_pos[1]), dtype=float).reshape(3)
            nz = max(float(n[2]), 1e-3)
            gx, gy = -float(n[0]) / nz, -float(n[1]) / nz          # world slope dz/dx, dz/dy
            sx, sl = cy * gx + sy * gy, -sy * gx + cy * gy          # ... in the character frame
        else:
            sx = (hts[3 * F + 1] - hts[3 * F + 2]) / (2 * e)
            sl = (hts[3 * F + 3] - hts[3 * F + 4]) / (2 * e)
        # the ground plane under the character (world), for the passive bodies
        gx, gy = cy * sx - sy * sl, sy * sx + cy * sl
        nrm = math.sqrt(gx * gx + gy * gy + 1.0)
        gp = self.ground_plane
        gp[0], gp[1], gp[2] = -gx / nrm, -gy / nrm, 1.0 / nrm
        gp[3] = gp[0] * place_pos[0] + gp[1] * place_pos[1] + gp[2] * float(hts[3 * F])
        a_t = 1.0 - math.exp(-dt / TILT_TAU)
        self._tilt[0] += a_t * (sx - self._tilt[0])
        self._tilt[1] += a_t * (sl - self._tilt[1])
        # lean: pitch into acceleration, roll into the turn (centripetal acceleration)
        p0 = self._params(0, speed / L) if r.ngroup else self._row
        lean_k = float(p0[6]) if r.ngroup else 0.0
        ax = (self.velocity[0] - self._prev_v[0]) / dt
        ay = speed * self.turn_rate
        self._lean[0] += a_t * (lean_k * ax / L - self._lean[0])
        self._lean[1] += a_t * (-lean_k * ay / L - self._lean[1])   # lean into the turn
        align = sc["slope_align"]
        pitch = -align * math.atan(self._tilt[0]) + self._lean[0]      # nose up on an uphill (-pitch about +y)
        roll = align * math.atan(self._tilt[1]) + self._lean[1]
        _pitch_roll_into(pitch, roll, self._root_dq)
        # the body's slope in the world: feet in flight turn toward it, planted ones keep theirs
        self._slope_w[0] = cy * self._tilt[0] - sy * self._tilt[1]
        self._slope_w[1] = sy * self._tilt[0] + cy * self._tilt[1]
        # crouch: the style's, low-pass filtered
        want = self.min_crouch
        for g in range(r.ngroup):
            want = max(want, self._crouch_want[g])      # the style's crouch at the group's speed (step 2)
        want = min(want, self.max_crouch)
        self._crouch += a_t * (want - self._crouch)
        self._root_dpos[2] = -self._crouch
        if r.mode == "crawl":
            # a crawler's body lies on the ground: no crouch, bob or sway of the root (the
            # arching of the spine between pseudo-feet is the motion)
            self._root_dpos[2] = 0.0
            self.group_bob[:] = 0.0
            self.group_sway[:] = 0.0
        if r.mode == "float":
            # hover with a gentle bob at the rest height over the ground
            self._root_dpos[2] = 0.03 * r.float_height * (1.0 - math.cos(2.0 * math.pi * 0.4 * self._time))

        # 6. feet and root
        K.gait_pose(place_pos, self._yaw, hts, self.path, self.group_lift, self.group_bob, self.group_sway,
                    self.group_duty, r.step_group, r.step_side, self.step_lift_scale, self.step_duty_scale,
                    r.step_foot_adr, r.step_foot_num, self.step_state, self.step_progress, self.step_prev_u,
                    r.foot_body, r.foot_offset, r.foot_rest_rot, r.foot_hip, r.foot_jointrel, r.foot_chain,
                    r.foot_rigid, r.foot_knee, r.foot_contact, self.foot_world, self.foot_lift, self.foot_yaw,
                    self.foot_lift_yaw, self.foot_target,
                    self.foot_target_yaw, self._slope_w, self.foot_slope, 1.0 - math.exp(-dt / FOOT_TILT_TAU),
                    self._foot_tilt, self._root_dq, self._root_dpos, self._bob,
                    1.0 - math.exp(-dt / BOB_TAU), root_pos, root_rot,
                    goal_pos, goal_rot, goal_pw, goal_rw, self.foot_bias, self.step_lift_u, self.step_parked,
                    self.step_done, self._goal_written)
        self._written = True
        self._last_place[:] = place_pos
        self._prev_root_pos[:] = root_pos
        self._prev_root_rot[:] = root_rot


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
