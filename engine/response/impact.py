"""Impact response (Zordan, Majkowska, Chiu, Fast 2005), causal and per frame.

A hit turns the character physical for a short burst, a lookahead simulation finds where
in the creature's motion library to re-enter, PD servos steer the live simulation toward
that clip, and an inertialized blend hands the pose back to animation.

    char.hit("hand_l", impulse=(0, 40, 0))      # N s, world space
    char.reacting, char.response.phase, char.response.clip

Phases (``ImpactResponse.phase``):
    ``burst``       from the impact tick: the runtime's pose and finite-difference
                    velocities became the physics state (``state_from_kinematic``, no
                    pop); the servos hold the interrupted clip (it keeps playing
                    underneath); Simulation 1 (the lookahead) runs ahead in slices.
    ``transition``  after the reaction delay: the search has chosen a clip, time and root
                    alignment; the found clip is faded in on the player (the paper's
                    ease-in/out slerp of theta_d) and the servos track it.
    ``blend``       at the match time: animation again, plus the physics-minus-animation
                    offset of every body decaying as a critically damped spring.
    ``settle``      after the blend, while a stagger plays to its end: then the placement
                    moves by the stagger's displacement and the clip played before resumes.
    ``idle``        nothing running (``reacting`` is False).

Choices where the paper is silent (see ``../shared/research/impact.md`` 1.9):
    * Simulation 1 is *active-holding*, not passive: the servos hold the pose frozen at the
      impact (the lookahead cannot see the future clip). A fully passive ragdoll folds on
      every tap, so every search would find lying frames; holding keeps taps upright and
      still lets heavy hits knock the body over. Friction 1.0 (paper section 5).
    * Simulation 2 runs live at friction 0.5 with the inertia-scaled PD servos of
      ``engine.physics`` (kp = (2 pi f)^2, kv = 2 zeta 2 pi f; one gain pair for all
      creatures, mass-normalized, like the paper's single hand-picked pair).
    * Simulation 1 uses a coarser substep (1/240 s) than Simulation 2 (1/480 s).
    * The paper's final blend interpolates Simulation 2 into the clip and needs Simulation
      2's *end* before its first frame. Here the hand-off is causal: at the match time the
      offset (position, rotation and their velocities) between the physical pose and the
      animated pose is taken once and decays as x(t) = (x0 + (v0 + w x0) t) e^(-w t), so
      the displayed pose and its velocity are continuous at the hand-off and nothing has to
      be simulated ahead of display.
    * Window: 6 frames at 30 Hz (0.2 s); weights in ``engine.response.search``.
    * The servos' stance side is anchored (a loaded foot counts as immovable in a servo's
      inertia) and their frequency rises as 1/sqrt(height) below ``servo_height``: with the
      paper's single gain pair on each joint's outboard inertia, thin legs under heavy bodies
      and small creatures sagged into a fall within the reaction delay, so every tap on them
      was answered with a fall (``servo_hz_of``; ``engine.physics.WorldSettings.servo_anchor``).
    * A creature that hovers in its rest pose (``hovers``: a fish) reacts without gravity.
    * The standing controller (``engine.response.stand``) runs only for creatures whose rest
      pose stands on feet: a snake lying on its belly thrashed under its balance wrench.
    * The found clip is placed on Simulation 2's root at the hand-off, not on Simulation 1's
      at the match (friction 0.5 against 1.0: the live body slides where the lookahead stood).
    * The standing controller's balance wrench holds the centre of mass where it stood over
      the supports at the hit (it goes where the feet go), turns the root back through the
      whole body's inertia tensor and damps its angular momentum, at frequencies capped by
      the frame it is held for; over the transition it fades only into a clip that goes
      down (``MotionLibrary.goes_down``), so a body re-entering a standing clip is held on
      its feet until the clip takes it (s40).
    * The search adds a push term to the paper's distance: a window whose clip still
      carries the root against the hits' impulse costs more (``engine.response.search``):
      the paper's 0.2 s window sees the pose, not where the clip will take the body (s40).
    * A tap (Simulation 1's root stays near where it was) is not searched: the pose blends
      back onto the clip that kept playing (``tap_move``, ``tap_turn``). The search has no
      prior for staying in the interrupted clip, and near a held pose every window is close.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from engine.anim.chain import MAX_CHAIN
from engine.errors import MenagerieError
from engine.model.caps import TAIL
from engine.physics import (
    DEFAULT_FOOT,
    ContactSettings,
    CreatureBodyOptions,
    WorldSettings,
    model_from_creatures,
    servo_targets_from_pose,
    state_from_kinematic,
    step,
)
from engine.physics._kernels import terrain_sample
from engine.physics.world import PhysicsState, rotvec_between
from engine.response.library import RATE, WINDOW, MotionLibrary, library_for
from engine.response.search import SearchResult, search, window_features, yaw_of
from engine.response.stand import Stander, StandParams

PHASES = ("idle", "burst", "transition", "blend", "settle")


class ImpactError(MenagerieError):
    """A hit that cannot be applied (unknown body, bad impulse); nothing is applied."""


@dataclass(frozen=True)
class ImpactParams:
    servo_hz: float = 5.0            # PD stiffness as a frequency (Hz), every joint
    servo_zeta: float = 1.0          # PD damping ratio
    substep: float = 1.0 / 480.0     # Simulation 2 substep, s
    lookahead_substep: float = 1.0 / 240.0   # Simulation 1 substep, s (coarser)
    reaction_delay: float = 0.15     # s before theta_d leaves the interrupted clip (paper: 0.1-0.2)
    match_min: float = 0.1           # earliest match after the impact, s (paper section 5)
    match_max: float = 1.0           # latest match after the impact, s
    contact_push: float = 0.25       # the earliest match waits for contact to end, up to this, s
    blend_omega: float = 12.0        # 1/s of the hand-off's critically damped decay (~0.4 s to 1%)
    blend_time: float = 0.5          # s after the hand-off the offset is dropped (e^-6 of it left)
    sim2_mu: float = 0.5             # foot friction, Simulation 2 (paper section 5)
    sim1_mu: float = 1.0             # foot friction, Simulation 1
    max_speed: float = 60.0          # an impulse giving the whole creature more than this (m/s) is absurd
    # s of the player's crossfade into the found clip at the hand-off. Measured with the IK's
    # proportional weights (27 chain-sized hits on humanoid, dog, random 4; /tmp script in the
    # issue-13 note): the hand-back turn is the same with or without a fade (median 0.08 rad,
    # max 0.29 at 0 and 0.2 s, 0.42 at 0.1 s) but the animation afterwards turns more (median
    # 0.14 -> 0.24 rad, max 0.51 -> 1.21): the fade mixes the interrupted clip into the pose the
    # offset was taken against. So none: the offset decay is the fade.
    handoff_fade: float = 0.0
    contact_dv: float = 4.0          # m/s: an instantaneous hit is spread so the struck body alone gains this per frame
    contact_max: float = 0.1         # s: ... over at most this long (a shove, not a punch, beyond it)
    contact_spin: float = 18.0       # rad/s: ... and no faster than this about a point its own length away
    resume_fade: float = 0.3         # s of the crossfade from a one-shot found clip back to the loop
    # The standing controller (engine.response.stand) in both simulations: gravity
    # compensation always, the balance term while the servos hold the interrupted pose (it
    # fades out over the transition, so a found fall is not held up). None: the servos alone
    # (the first version: unhit, the humanoid's lookahead fell by 1 s, so taps read as falls).
    stand: StandParams | None = StandParams()
    # the controller in Simulation 2 too (False: the lookahead only). Both, since s31: the lookahead
    # predicts with it, so the live simulation must run it to do what was predicted (a humanoid
    # shoved at 1.7 m/s stood in the lookahead, fell 0.9 m in the live simulation without it, and
    # the blend stood it up into 'stretch' in 0.5 s). benchmarks/impact.py, three sets (the first
    # 6 library creatures + random 0-4; the next 8 + random 100-105; random 200-211), 148 single
    # hits, 74 trains of 2, 37 of 5: both 0.946 / 0.946 / 0.946, the lookahead only 0.959 / 0.932 /
    # 0.892. (With the old weight-carrying torques, s24, both were far worse.)
    stand_live: bool = True
    servo_anchor: bool | str = True
    # A tap: Simulation 1's root stays within tap_move of the height of where it was and turns
    # less than tap_turn (rad) over the lookahead. The response then blends back onto the
    # clip that kept playing at the end of the reaction delay, with no search (the search
    # ranked the first frames of a fall above the interrupted idle for a 1 mN s tap on a
    # 15 cm creature: every window is near a held pose). 0 turns it off.
    tap_move: float = 0.05
    tap_turn: float = 0.2
    servo_height: float = 1.75


_MODELS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _models(creature, p: ImpactParams):
    """(Simulation 1 model, Simulation 2 model) of a creature, built once."""
    key = (p.servo_hz, p.servo_zeta, p.sim1_mu, p.sim2_mu, p.servo_anchor, p.servo_height)
    per = _MODELS.setdefault(creature, {})
    hit = per.get(key)
    if hit is None:
        # Leaves lighter than 1% of the creature (eyes, ears, a jaw, fingertips) ride locked
        # on their parents: their tiny inertia lets a hit spin them tens of rad/s, and they
        # carry nothing of the reaction.
        vol = np.prod(np.maximum(np.asarray(creature.body_extent, float), 1e-6), axis=1)
        has_child = np.zeros(creature.nbody, bool)
        has_child[[int(q) for q in creature.body_parent if q >= 0]] = True
        locked = tuple(creature.body_names[b] for b in range(1, creature.nbody)
                       if not has_child[b] and vol[b] < 0.01 * vol.sum())
        opts = CreatureBodyOptions(servo_hz=servo_hz_of(creature, p), servo_zeta=p.servo_zeta, locked=locked)
        # A creature whose rest pose hovers (a fish, a jellyfish, random creatures with no legs
        # that touch the ground) is held up by what the animation does not model (water, its
        # wings): its response runs without gravity (with it, a tap on a fish's fin dropped it
        # 0.2 m in 0.2 s and every hit was answered with a fall to the ground).
        gravity = (0.0, 0.0, 0.0) if hovers(creature) else WorldSettings().gravity
        out = []
        for mu in (p.sim1_mu, p.sim2_mu):
            foot = ContactSettings(hz=DEFAULT_FOOT.hz, zeta=DEFAULT_FOOT.zeta, mu=mu, spin_mu=DEFAULT_FOOT.spin_mu)
            out.append(model_from_creatures(creature, options=opts, settings=WorldSettings(
                foot=foot, servo_anchor=p.servo_anchor, gravity=gravity)))
        hit = per[key] = tuple(out)
    return hit


HOVER = 0.02     # a rest pose whose lowest box corner is this fraction of the height above the ground hovers


def hovers(creature) -> bool:
    """The creature's rest pose stands clear of the ground (its lowest box corner more than
    ``HOVER`` of its height above it): it swims or flies, and its response has no gravity."""
    from engine.channels.modes import ground_height

    low = min(float(creature.body_rest_pos[b, 2]) - ground_height(creature, b) for b in range(creature.nbody))
    return low > HOVER * float(creature.height)


def servo_hz_of(creature, p: ImpactParams) -> float:
    """The servos' frequency for a creature: ``servo_hz`` at ``servo_height`` and above,
    raised as 1/sqrt(height) below it (dynamic similarity: a held limb sags under gravity
    by about g / (omega^2 L), so a creature a tenth of the size needs sqrt(10) times the
    frequency to sag by the same angle; at 5 Hz a 15 cm creature's tail dropped to the
    ground in 0.1 s after a tap)."""
    if p.servo_height <= 0.0:
        return p.servo_hz
    return p.servo_hz * math.sqrt(max(p.servo_height / max(float(creature.height), 1e-6), 1.0))


def chain_bodies(creature, body: int) -> np.ndarray:
    """The bodies a hit on ``body`` moves first: the whole limb that carries it (the sub-tree
    of its limb's first body: a hand's arm, a foot's leg), the tail from its first tail body
    for a tail segment, or every body for a hit on the spine (the trunk carries the whole
    creature)."""
    limb = int(creature.body_limb[body])
    if limb < 0:
        caps = creature.body_caps
        if int(caps[body]) & TAIL:
            # a tail is its own chain, like a limb (sized by the whole creature, a hit on a
            # crawler's 53 g tail tip was 11.7 N s and whipped it 1.2 rad in a frame)
            r = body
            while int(creature.body_parent[r]) >= 0 and int(caps[int(creature.body_parent[r])]) & TAIL:
                r = int(creature.body_parent[r])
            return np.arange(r, int(creature.body_subtree_end[r]))
        return np.arange(creature.nbody)
    r = int(creature.limb_root[limb])
    return np.arange(r, int(creature.body_subtree_end[r]))


def chain_mass(creature, body: int, params: ImpactParams | None = None) -> float:
    """Mass (kg) of ``chain_bodies(creature, body)`` in the response's physics model.

    The rule for sizing a hit: an impulse J on a body sets its chain moving at about
    |J| / chain_mass before the joints share it with the rest. A hit sized by the whole
    creature's mass lands on a 0.3 kg foot as tens of m/s and spins it about the ankle
    (the rigid-body answer, not a reaction); sized by the chain, a tap on a hand moves the
    arm and a knock-down needs a hit on the trunk."""
    m = _models(creature, params or ImpactParams())[1].body_mass
    return float(m[chain_bodies(creature, body)].sum())


def _copy_state(dst: PhysicsState, src: PhysicsState) -> None:
    for a, b in zip(dst.arrays, src.arrays, strict=True):
        np.copyto(a, b)


class ImpactResponse:
    """The impact response of one Character (made by its first ``hit``)."""

    def __init__(self, char, params: ImpactParams | None = None, library: MotionLibrary | None = None) -> None:
        self.char = char
        self.params = p = params or ImpactParams()
        c = char.creature
        self.model1, self.model2 = _models(c, p)
        self.sim2 = PhysicsState(self.model2)
        self.sim1 = PhysicsState(self.model1)
        # Locked leaves (see _models) are shown in the animated pose relative to their parent:
        # the physics holds them at their rest relative rotation, and writing that out snapped
        # the humanoid's hand 1.8 rad in the first physical frame of a punch (its fist turned 80
        # degrees by the clip).
        jl = np.asarray(self.model2.joint_locked)
        self._locked = np.array([int(self.model2.joint_child[j]) for j in range(self.model2.njoint) if jl[j]], int)
        self._locked_parent = np.array([int(self.model2.joint_parent[j]) for j in range(self.model2.njoint)
                                        if jl[j]], int)
        self._phys_pos = np.zeros((c.nbody, 3))
        self._phys_rot = np.zeros((c.nbody, 4))
        # the physics' joints, by depth, for joining an animated pose (see _joined)
        m2 = self.model2
        bj = np.asarray(m2.body_joint, int)
        depth = np.zeros(c.nbody, int)
        for b in range(1, c.nbody):
            depth[b] = depth[int(m2.joint_parent[bj[b]])] + 1
        jpar, jap, jac = (np.asarray(a) for a in (m2.joint_parent, m2.joint_anchor_parent, m2.joint_anchor_child))
        #: per depth below the root: (bodies, their parents, joint point in the parent, in the body)
        self._join_levels = [(bs, jpar[bj[bs]], jap[bj[bs]], jac[bj[bs]])
                             for bs in (np.flatnonzero(depth == d) for d in range(1, int(depth.max()) + 1))]
        self._join_w = np.asarray(m2.body_mass, float) / float(np.sum(m2.body_mass))
        self._entry_res = np.zeros((c.nbody, 3))
        self._entry_t = 0.0
        self.stand1 = self.stand2 = None
        if p.stand is not None:
            self.stand1 = Stander(self.model1, p.stand, height=c.height)
            self.stand2 = Stander(self.model2, p.stand, height=c.height)
            if not self.stand1.on_feet:
                # nothing to keep up: a creature lying on its belly or hovering (stand.Stander.on_feet).
                # benchmarks/impact.py on fish, inchworm, jellyfish, octopus and snake, 6 hits each:
                # single 0.833 -> 0.867, trains of 2 0.933 -> 1.0, of 5 0.6 -> 1.0; the largest
                # turn in a physical tick 3.08 -> 0.98 rad
                self.stand1 = self.stand2 = None
        self._library = library       # built on the first search (a recoil needs none)
        self.phase = "idle"
        self.clip = None              #: the Animation the response re-enters (None before the search)
        self.clip_time = 0.0          #: the matched time in it, s
        self.match = None             #: the SearchResult
        self.entry = None             #: the library entry (clip, variant, speed; or a gait cycle)
        self.hits = 0
        self._push = np.zeros(3)      # the running response's hits' impulse, N s (the search's push)
        self._found_down = True       # the found clip goes down from the matched frame (a fall)
        self.tap = False              #: the running response is a tap (no search, see _is_tap)
        self.time = 0.0               # s since the last hit
        self.since_start = 0.0        # s since the response began
        self._contact = []            # [body, force (3,), point or None, seconds left]
        self._contact_end = 0.0
        n = c.nbody
        self._sim1_frames_pos = np.zeros((0, n, 3))
        self._sim1_frames_rot = np.zeros((0, n, 4))
        self._sim1_done = 0.0
        self._sim1_count = 0
        self._hold_rot = np.zeros((self.model1.njoint, 4))
        self._found_rot = np.zeros((self.model1.njoint, 4))
        self._armed = False
        self._balance = 1.0
        self._settle_at = None
        self._settle_d = np.zeros(3)
        self._plan_time = 0.0
        self._resume = None           # the looping clip playing before the response
        self._prev_anim_pos = np.zeros((n, 3))
        self._prev_anim_rot = np.zeros((n, 4))
        self._off_pos = np.zeros((n, 3))
        self._off_vel = np.zeros((n, 3))
        self._off_rot = np.zeros((n, 3))
        from engine.channels.modes import ground_height

        # each body's origin height when its rest box rests on the ground (the blend's floor)
        self._rest_height = np.array([ground_height(c, b) for b in range(c.nbody)])
        self._clip_z = np.zeros(n)
        self._off_angvel = np.zeros((n, 3))
        self._blend_t = 0.0
        self._handoff = 0.0
        self._place_yaw = 0.0
        rate, window = (RATE, WINDOW) if library is None else (library.rate, library.window)
        self._frame_dt = 1.0 / rate
        self._recoil = 0.0
        # Simulation 1's frames: the search's latest start is match_max (the contact push moves
        # the earliest one, never past match_max), and a window after it; +1 for the rounding
        # of k0. (It was sized by match_max + contact_push: 45 frames, 8 of them never read,
        # a fifth of the lookahead's cost.)
        nrec = int(math.ceil(p.match_max / self._frame_dt)) + window + 1
        self._sim1_pos = np.zeros((nrec, n, 3))
        self._sim1_rot = np.zeros((nrec, n, 4))
        self.root_trace: list = []    # (time since start, phase, root z) per tick, for plots
        self.sim1_trace: list = []

    @property
    def library(self) -> MotionLibrary:
        """The creature's motion library (``library_for``), built on first use."""
        if self._library is None:
            self._library = library_for(self.char.creature)
        return self._library

    @property
    def reacting(self) -> bool:
        return self.phase != "idle"

    def prepare(self) -> float:
        """Build (or load) the motion library and load the response's kernels now, so the
        first hit costs a tick what any later one does; returns the seconds it took. Without
        it the first hit's tick pays both: measured (benchmarks/impact.py, quiet machine) a
        37 ms slice for the kernels' first call in a process, and the library's build (1.4 s
        for the humanoid) inside the first search. State is left as it was."""
        import time

        t0 = time.perf_counter()
        lib = self.library
        c = self.char.creature
        pos = np.asarray(self.char.world_positions, float)
        rot = np.asarray(self.char.world_rotations, float)
        s = state_from_kinematic(self.model1, *self._lock_leaves(pos, rot))
        if self.stand1 is not None:
            ref = self.stand1.ref.copy()
            self.stand1.apply(s, 1.0, self._frame_dt)
            np.copyto(self.stand1.ref, ref)
        step(self.model1, s, self._frame_dt, substeps=1)
        W = lib.window
        feats = window_features(c, np.repeat(pos[None], W + 1, 0), np.repeat(rot[None], W + 1, 0))
        search(lib, feats, 0, 1, allow_gait=False)
        return time.perf_counter() - t0

    # -- the hit -----------------------------------------------------------------------

    def hit(self, body, impulse, point=None, duration: float = 0.0, *, recoil: float = 0.0) -> None:
        """``recoil`` > 0: the hit is the reaction an attacker's strike gets back
        (``engine.response.strike``): the body is physical for ``recoil`` seconds, then blends
        back onto the clip that kept playing underneath, with no search; a running full
        response takes the hit as an ordinary one."""
        c = self.char.creature
        if isinstance(body, str):
            if not c.has_body(body):
                raise ImpactError(f"hit: creature '{c.name}' has no body '{body}'")
            b = c.body(body)
        elif isinstance(body, (int, np.integer)) and not isinstance(body, bool):
            if not 0 <= int(body) < c.nbody:
                raise ImpactError(f"hit: body index {body} out of range (creature '{c.name}' has {c.nbody} bodies)")
            b = int(body)
        else:
            raise ImpactError(f"hit: body must be a name or an index, got {body!r}")
        name = c.body_names[b]
        J = np.asarray(impulse, dtype=float)
        if J.shape != (3,) or not np.all(np.isfinite(J)):
            raise ImpactError(f"hit on '{name}': impulse must be 3 finite numbers (N s), got {impulse!r}")
        total = self.model2.total_mass
        if np.linalg.norm(J) / total > self.params.max_speed:
            raise ImpactError(f"hit on '{name}': impulse {np.linalg.norm(J):.4g} N s is absurd for a "
                              f"{total:.4g} kg creature (more than {self.params.max_speed:g} m/s to all of it)")
        if point is not None:
            point = np.asarray(point, dtype=float)
            if point.shape != (3,) or not np.all(np.isfinite(point)):
                raise ImpactError(f"hit on '{name}': point must be 3 finite numbers, got {point!r}")
        if not (isinstance(duration, (int, float)) and math.isfinite(duration) and 0.0 <= duration <= 5.0):
            raise ImpactError(f"hit on '{name}': duration must be 0..5 s, got {duration!r}")
        if not (isinstance(recoil, (int, float)) and math.isfinite(recoil) and 0.0 <= recoil <= 1.0):
            raise ImpactError(f"hit on '{name}': recoil must be 0..1 s, got {recoil!r}")
        # -- validated; from here the hit is applied ---------------------------------------
        ch = self.char
        p = self.params
        if self.phase in ("idle", "blend", "settle"):
            # the displayed pose and its finite-difference velocity become the physics state
            dt = ch._stack.last_dt
            # joined at the physics' joints first: the animated spine is not rigid (a lying
            # crawler's pelvis joint stood 4.5 cm open) and the first step snapped such gaps shut,
            # 1.2 rad in a frame; the gaps are shown decaying instead (_entry_res)
            pos, rot = self._lock_leaves(ch.world_positions, ch.world_rotations)
            ppos, prot = self._lock_leaves(ch._prev_world_pos, ch._prev_world_rot)
            jpos = self._joined(pos, rot)
            s = state_from_kinematic(self.model2, jpos, rot, self._joined(ppos, prot), prot, dt)
            _copy_state(self.sim2, s)
            np.subtract(pos, jpos, out=self._entry_res)
            if self._locked.size:       # a locked leaf is shown on its parent (_physics_pose): its gap is the parent's
                self._entry_res[self._locked] = self._entry_res[self._locked_parent]
            self._entry_t = 0.0
            self._hold_leaves(ch.world_positions, ch.world_rotations)
            if self.phase == "idle":
                loops = [h.animation for h in ch.player.handles if h is not None and h.animation.loop]
                self._resume = loops[0] if loops else None
                self.since_start = 0.0
                self.root_trace = []
                self.sim1_trace = []
            self._fade_handle = None
        np.copyto(self._prev_anim_pos, ch.world_positions)
        np.copyto(self._prev_anim_rot, ch.world_rotations)
        # the push the search prefers to travel along (search.py): the hits of a physical
        # response add up; a hit on a pose that is animation again starts a new push
        if self.phase in ("burst", "transition"):
            self._push += J
        else:
            self._push = J.copy()
        full = self.phase in ("burst", "transition") and self._recoil == 0.0
        self._recoil = 0.0 if (recoil <= 0.0 or full) else float(recoil)
        self.phase = "burst"
        self._settle_at = None
        self.hits += 1
        self.tap = False              #: the running response is a tap (no search, see _is_tap)
        self.time = 0.0
        self.clip = None
        self.match = None
        self._armed = False
        self._blend_t = 0.0
        # An instantaneous hit is delivered as a force over one frame, so the joint solver
        # shares it through the body (a velocity kick on a 0.4 kg hand spun it 2 rad/frame).
        # A contact lasts at least long enough that the struck body alone would gain no more
        # than ``contact_dv`` per frame (up to ``contact_max``): a hit sized for the trunk on a
        # 1.5 kg neck over one frame turned it 1 rad in that frame (humanoid, 44 N s).
        dt = ch._stack.last_dt
        m_b = float(self.model2.body_mass[b])
        # per frame, the struck body alone gains at most contact_dv, and no more than would
        # spin it at contact_spin about a point its own length away (a 2.5 m/s hit on a 2 cm
        # crab leg segment at 4 m/s a frame turned it 1 rad in the impact tick)
        dv = min(p.contact_dv, p.contact_spin * 2.0 * float(np.max(c.body_extent[b])))
        soft = np.linalg.norm(J) * dt / (max(m_b, 1e-9) * max(dv, 1e-6))
        span = float(duration) if duration > 0.0 else min(max(dt, soft), max(p.contact_max, dt))
        self._contact.append([b, J / span, point, span])
        self._contact_end = span
        # the servos hold the interrupted clip's pose as it was at the impact (Simulation 1)
        servo_targets_from_pose(self.model2, ch.world_rotations, self._hold_rot)
        np.copyto(self.sim2.joint_target_rot, self._hold_rot)
        # Simulation 1 restarts from the live state (a second hit re-plans from here)
        _copy_state(self.sim1, self.sim2)
        self._sim1_contact = [b, J / span, point, span]
        if self.stand1 is not None:
            # both balance references from the live state the hit lands on
            self.stand1.reset()
            self.stand2.reset()
        self._balance = 1.0
        self._sim1_count = 0
        self._sim1_done = 0.0
        self._record_sim1()

    # -- per tick ----------------------------------------------------------------------

    def tick(self, dt: float) -> None:
        """After the character's own stages: advance the response, write the pose."""
        if self.phase == "idle":
            return
        ch = self.char
        p = self.params
        anim_pos, anim_rot = ch.world_positions, ch.world_rotations
        self.time += dt
        self.since_start += dt
        if self.phase in ("burst", "transition"):
            if self._recoil > 0.0:
                pass                                    # a recoil: no lookahead, no search
            elif self.phase == "burst":
                self._advance_sim1(dt)
                if self.time >= p.reaction_delay:
                    self._plan()
            if self.phase == "transition":
                self._transition_targets()
            self._apply_contacts(self.model2, self.sim2, self._contact, dt)
            if self.stand2 is not None and p.stand_live:
                self.stand2.apply(self.sim2, self._balance, dt)
            sub = max(1, int(math.ceil(dt / p.substep)))
            step(self.model2, self.sim2, dt, substeps=sub)
            self._entry_t += dt
            if (self.phase == "transition" and self._armed) or (self._recoil > 0.0 and self.time >= self._recoil):
                self._start_blend(anim_pos, anim_rot, dt)
            else:
                if self.phase == "transition" and self.time + dt >= self._handoff - 1e-9:
                    self._arm(dt)
                np.copyto(self._prev_anim_pos, anim_pos)
                np.copyto(self._prev_anim_rot, anim_rot)
                self._physics_pose(anim_pos, anim_rot)
                np.copyto(anim_pos, self._phys_pos)
                np.copyto(anim_rot, self._phys_rot)
        elif self.phase in ("blend", "settle"):
            if self._settle_at is not None and self.time + dt >= self._settle_at:
                self._settle()
            self._blend_t += dt
            t = self._blend_t
            w = p.blend_omega
            e = math.exp(-w * t)
            kx = (1.0 + w * t) * e
            kv = t * e
            if t >= p.blend_time and self._settle_at is not None:
                self.phase = "settle"                # the offset is gone; a stagger still to end
            elif t >= p.blend_time:
                self.phase = "idle"
                from engine.runtime import _REACTING

                _REACTING.discard(self.char)
            else:
                self._blend_pose(anim_pos, anim_rot, kx, kv)
        self.root_trace.append((self.since_start, self.phase, float(anim_pos[0, 2])))

    def _record_sim1(self) -> None:
        k = self._sim1_count
        if k < self._sim1_pos.shape[0]:
            self._sim1_pos[k] = self.sim1.body_pos
            self._sim1_rot[k] = self.sim1.body_rot
            self._sim1_count = k + 1

    def _advance_sim1(self, dt: float) -> None:
        """Simulation 1 in slices: all of its lookahead done a tick before the end of the
        delay, so the search's tick carries no slice (the humanoid's worst tick of a response
        was that one: a slice of 4 frames plus the search)."""
        p = self.params
        total = self._sim1_pos.shape[0] - 1
        ticks_left = max(1, int(math.ceil((p.reaction_delay - self.time) / dt - 1e-9)))
        want = min(total, self._sim1_count - 1 + int(math.ceil((total - (self._sim1_count - 1)) / ticks_left)))
        sub = max(1, int(math.ceil(self._frame_dt / p.lookahead_substep)))
        while self._sim1_count - 1 < want:
            if self._sim1_contact is not None:
                self._apply_contacts(self.model1, self.sim1, [self._sim1_contact], self._frame_dt)
                if self._sim1_contact[3] <= 0:
                    self._sim1_contact = None
            else:
                self.sim1.body_force[:] = 0.0
                self.sim1.body_torque[:] = 0.0
            if self.stand1 is not None:
                self.stand1.apply(self.sim1, 1.0, self._frame_dt)
            step(self.model1, self.sim1, self._frame_dt, substeps=sub)
            self._record_sim1()
            self.sim1_trace.append((self.since_start - self.time + (self._sim1_count - 1) * self._frame_dt,
                                    float(self.sim1.body_pos[0, 2])))

    @staticmethod
    def _apply_contacts(model, state, contacts, dt) -> None:
        state.body_force[:] = 0.0
        state.body_torque[:] = 0.0
        for entry in contacts:
            b, F, point, left = entry
            if left <= 0:
                continue
            share = min(dt, left) / dt
            f = F * share
            state.body_force[b] += f
            if point is not None:
                state.body_torque[b] += np.cross(point - state.body_pos[b], f)
            entry[3] = left - dt
        contacts[:] = [e for e in contacts if e[3] > 0]

    def _plan(self) -> None:
        """The search (paper section 3) and the start of the transition."""
        p = self.params
        while self._sim1_count < self._sim1_pos.shape[0]:     # a delay shorter than a tick
            self._advance_sim1(1e9)
        lo = min(p.match_min + min(self._contact_end, p.contact_push), p.match_max)
        lo = max(lo, self.time + self._frame_dt)               # never in the past
        k0 = int(math.ceil(lo / self._frame_dt))
        k1 = int(p.match_max / self._frame_dt)
        last = self._sim1_count - self.library.window        # the last start with a whole window
        k1 = min(max(k0, min(k1, last)), last)
        k0 = min(k0, k1)
        if self._is_tap():
            # the hit moved the body too little to leave the clip: back onto it from here (no search)
            self.tap = True
            self._recoil = max(self.time, 1e-9)
            return
        feats = window_features(self.char.creature, self._sim1_pos[: self._sim1_count],
                                self._sim1_rot[: self._sim1_count])
        res: SearchResult = search(self.library, feats, k0, k1, allow_gait=self.locomoting(), push=self._push)
        self.match = res
        self._found_down = self.library.goes_down(res.lib_frame)
        self.entry = self.library.entries[res.clip]
        self.clip = self.entry.animation
        self.clip_time = res.clip_time
        self._handoff = res.sim_frame * self._frame_dt
        self._plan_time = self.time
        self._armed = False
        self.phase = "transition"
        if self.time + self._frame_dt * 0 >= self._handoff - 1e-9:
            self._arm(0.0)

    def locomoting(self) -> bool:
        """The character's gait is moving or turning: only then may the search re-enter a
        gait cycle."""
        g = self.char.gait
        return g is not None and (bool(np.any(np.abs(g._cmd_v) > 1e-6)) or abs(g._cmd_w) > 1e-6)

    def _is_tap(self) -> bool:
        """Simulation 1 keeps the root within ``tap_move`` of the creature's height of where it
        was at the hit and turns it less than ``tap_turn`` over the whole lookahead."""
        p = self.params
        if p.tap_move <= 0.0:
            return False
        n = self._sim1_count
        pos, rot = self._sim1_pos[:n, 0], self._sim1_rot[:n, 0]
        move = float(np.linalg.norm(pos - pos[0], axis=1).max())
        d = np.abs(rot @ rot[0])
        turn = float(2.0 * np.arccos(min(float(d.min()), 1.0)))
        return move < p.tap_move * self.char.creature.height and turn < p.tap_turn

    def _transition_targets(self) -> None:
        """theta_d: the interrupted pose slerped with ease-in/out toward the found clip's
        pose at the time it will have at the hand-off (the library's frames: joint-relative
        rotations do not depend on the placement)."""
        lib = self.library
        s = self.match.lib_frame
        back = int(round((self._handoff - self.time) / self._frame_dt))
        f = s - back
        first = int(np.searchsorted(lib.clip_of, lib.clip_of[s]))
        f = max(f, first)
        span = max(self._handoff - self._plan_time, 1e-6)
        u = min(max((self.time - self._plan_time) / span, 0.0), 1.0)
        u = u * u * (3.0 - 2.0 * u)
        # The balance fades only into a clip that goes down (a fall, lying): one that stands
        # is balanced on its feet when it takes over, so the body is kept so until then.
        # Faded into every clip until s40: a stance that leans on small feet (random 3,
        # 4.3 cm ahead of 1 cm feet) tipped back as it faded, 5 cm in the last 0.25 s before
        # the hand-off, and re-entered a standing clip there, against the push.
        self._balance = 1.0 - u if self._found_down else 1.0
        servo_targets_from_pose(self.model2, lib.rot[f], self._found_rot)
        _slerp_into(self._hold_rot, self._found_rot, u, self.sim2.joint_target_rot)

    def _arm(self, dt: float) -> None:
        """One tick before the hand-off: the found clip starts (no fade, ``handoff_fade``: the
        pose is the library's, the one the search matched), placed so its root at the matched time sits
        on the live simulation's root now (yaw and ground-plane translation)."""
        ch = self.char
        res = self.match
        # The clip is placed on the live simulation's root as it is now (yaw and ground-plane
        # position), not on Simulation 1's at the match: the two differ by what friction 0.5
        # against 1.0 and the servos' new targets did since the hit (a centipede slid 0.36 m
        # along a push in Simulation 2, stood in Simulation 1, and the hand-off's offset then
        # slid it back to where it was hit from).
        lib = self.library
        s = res.lib_frame
        yaw2, xy2 = yaw_of(self.char.creature, self.sim2.body_rot[:1], self.sim2.body_pos[:1])
        self._place_yaw = yaw = float(yaw2[0] - lib.yaw[s])
        c, sn = math.cos(yaw), math.sin(yaw)
        lx, ly = lib.xy[s]
        place = np.array([xy2[0, 0] - (c * lx - sn * ly), xy2[0, 1] - (sn * lx + c * ly), 0.0])
        ch.set_placement(position=place, heading=yaw, teleport=True)
        e = self.entry
        if e.animation is None:          # a gait entry: the character's own locomotion goes on
            self._armed = True
            return
        for q in list(ch.player.queues[0]):     # what an earlier response queued (a fall's lying, ...)
            ch.player.stop(q.handle)
        start = min(max(self.clip_time - dt * e.speed, 0.0), self.clip.length)
        # fade_out: a clip played with fade 0 ends with a fade-out of 0 by default, and the clip
        # queued behind it then fades in from nothing: a frame of near-zero clip weight, the
        # rest pose's goals, a knee flipped 2 rad (measured on the dog after fall_back_low)
        ch.play(self.clip, variant=e.variant, fade=self.params.handoff_fade, start_time=start, speed=e.speed,
                fade_out=self.params.resume_fade)
        name = self.clip.name
        # a fall goes on into the clips that continue it (``follows``: lying, then getting
        # up, animations/reactions), then what played before
        nxt = self.library.followed_by.get(name)
        continued = nxt is not None
        for _ in range(MAX_CHAIN):
            if nxt is None:
                break
            ch.queue(nxt, fade=0.2, fade_out=0.2, loop=False)
            nxt = self.library.followed_by.get(nxt.name)
        self._settle_at = None
        if name.startswith("stagger_"):
            # A stagger ends in the rest pose moved by d (animations/reactions): when it ends the
            # placement moves by d and what played before goes on from there, with no slide back
            # (clips carry no root motion). d from the library's frames of this entry.
            i0 = int(np.searchsorted(lib.clip_of, res.clip))
            i1 = int(np.searchsorted(lib.clip_of, res.clip, side="right")) - 1
            dc = lib.pos[i1, 0, :2] - lib.pos[i0, 0, :2]
            c, sn = math.cos(self._place_yaw), math.sin(self._place_yaw)
            self._settle_d = np.array([c * dc[0] - sn * dc[1], sn * dc[0] + c * dc[1], 0.0])
            self._settle_at = self._handoff + (self.clip.length - self.clip_time) / e.speed - 1.5 * dt
        elif (continued or not self.clip.loop) and self._resume is not None \
                and self._resume is not self.clip:
            # after a one-shot reaction (or the chain that continues it: a lying entered in the
            # middle goes on into getting up): what played before
            ch.queue(self._resume, fade=self.params.resume_fade)
        self._armed = True

    def _settle(self) -> None:
        """The stagger's end: the placement moves by its displacement, what played before
        resumes (same pose: the stagger ends in the rest pose moved by it)."""
        ch = self.char
        ch.set_placement(position=ch.position + self._settle_d, teleport=True)
        if self._resume is not None:
            ch.play(self._resume, fade=0.0)
        else:
            ch.stop(fade=0.0)
        self._settle_at = None

    def _lock_leaves(self, pos, rot):
        """A copy of a pose with the locked leaves at their rest rotation on their parents, as
        the physics holds them (a start the lock does not have to correct: with the fist of a
        punch turned 80 degrees, the correction turned the forearm 0.5 rad in a frame)."""
        if not self._locked.size:
            return pos, rot
        m = self.model2
        pos, rot = pos.copy(), rot.copy()
        j = np.asarray(m.body_joint)[self._locked]
        b, p = self._locked, self._locked_parent
        rot[b] = _qmul(rot[p], np.asarray(m.joint_rest_rot)[j])
        pos[b] = (pos[p] + _qrot(rot[p], np.asarray(m.joint_anchor_parent)[j])
                  - _qrot(rot[b], np.asarray(m.joint_anchor_child)[j]))
        return pos, rot

    def _joined(self, pos, rot) -> np.ndarray:
        """Body positions with every physics joint closed, for the rotations ``rot``: each body
        hung from its parent's joint point, the whole placed where the pose's mass was."""
        out = np.array(pos, dtype=float)
        for bs, ps, ap, ac in self._join_levels:
            out[bs] = out[ps] + _qrot(rot[ps], ap) - _qrot(rot[bs], ac)
        out += self._join_w @ (np.asarray(pos) - out)
        return out

    def _hold_leaves(self, pos, rot) -> None:
        """The locked leaves' transforms relative to their parents in the displayed pose at
        the impact, kept while the response is physical."""
        if self._locked.size:
            b, p = self._locked, self._locked_parent
            self._leaf_rel = _qmul(_qconj(rot[p]), rot[b])
            self._leaf_off = _qrot(_qconj(rot[p]), pos[b] - pos[p])

    def _physics_pose(self, anim_pos, anim_rot) -> None:
        """Simulation 2's pose into ``_phys_pos/_phys_rot``, the locked leaves placed on their
        simulated parents as they sat on them at the impact (following the animation instead
        jumped them when the found clip started; the hand-off's offset decay takes them back)."""
        np.copyto(self._phys_pos, self.sim2.body_pos)
        np.copyto(self._phys_rot, self.sim2.body_rot)
        if self._locked.size:
            b, p = self._locked, self._locked_parent
            qp = self.sim2.body_rot[p]
            self._phys_rot[b] = _qmul(qp, self._leaf_rel)
            self._phys_pos[b] = self.sim2.body_pos[p] + _qrot(qp, self._leaf_off)
        if self._entry_t < self.params.blend_time:
            # the joints' gaps of the pose the physics started from, decaying (see hit)
            w = self.params.blend_omega
            t = self._entry_t
            self._phys_pos += (1.0 + w * t) * math.exp(-w * t) * self._entry_res

    def _start_blend(self, anim_pos, anim_rot, dt: float) -> None:
        """Hand-off: the offset between physics and animation, and its velocity."""
        s = self.sim2
        self._physics_pose(anim_pos, anim_rot)
        np.subtract(self._phys_pos, anim_pos, out=self._off_pos)
        # the found clip's velocity from the library (its first frame has no previous one);
        # a recoil's, from the clip that kept playing (last tick's animated pose)
        if self.match is None:
            anim_vel = (anim_pos - self._prev_anim_pos) / max(dt, 1e-9)
            f = -1
        else:
            lib = self.library
            f = self.match.lib_frame
        if f < 0:
            pass
        elif f > 0 and lib.clip_of[f - 1] == lib.clip_of[f]:
            v = (lib.pos[f] - lib.pos[f - 1]) * lib.rate
            c, sn = math.cos(self._place_yaw), math.sin(self._place_yaw)
            anim_vel = np.stack([c * v[:, 0] - sn * v[:, 1], sn * v[:, 0] + c * v[:, 1], v[:, 2]], axis=1)
        else:
            anim_vel = np.zeros_like(anim_pos)
        np.subtract(s.body_linvel, anim_vel, out=self._off_vel)
        self._off_rot[:] = rotvec_between(anim_rot, self._phys_rot)
        # The angular-velocity offset is not carried: the animated pose's finite-difference
        # angular velocity at the hand-off tick includes the found clip's fade and the
        # jiggles' springs, and carrying it flipped ears 0.6 rad in a frame. Rotations are
        # continuous at the hand-off; their rate is the animation's from then on.
        self.phase = "blend"
        self._blend_t = 0.0
        np.copyto(anim_pos, self._phys_pos)
        np.copyto(anim_rot, self._phys_rot)

    def _blend_pose(self, anim_pos, anim_rot, kx: float, kv: float) -> None:
        """The hand-off's offset, decayed, on the animated pose: each body's position offset
        as (x0 + (v0 + w x0) t) e^(-w t), its rotation offset scaled by kx. Per body, not as a
        chain: turning the bodies about their joints by the decaying rotation offsets (tried,
        s31) swung a foot through an arc 8.7 cm into the ground on the way into 'roar'."""
        clip_z = self._clip_z
        np.copyto(clip_z, anim_pos[:, 2])
        anim_pos += kx * self._off_pos + kv * self._off_vel
        rv = kx * self._off_rot     # rotations: the offset alone (see _start_blend)
        _rotate_by_rotvec(rv, anim_rot)
        # The decaying offset must not take a body into the ground: a foot still falling in
        # the simulation while the found clip lifts it (the offset's velocity term) dipped the
        # centipede's first foot 4.4 cm under the ground on the way into fall_right_low (its
        # height is 7 cm). No body goes lower than it rests on the terrain, or than the clip
        # itself puts it (a clip may sink a body; the blend does not add to it).
        t = self.model2.terrain
        for b in range(anim_pos.shape[0]):
            h = terrain_sample(t.height, t.x0, t.y0, t.cell, float(anim_pos[b, 0]), float(anim_pos[b, 1]))[0]
            low = min(h + self._rest_height[b], clip_z[b])
            if anim_pos[b, 2] < low:
                anim_pos[b, 2] = low

def _qmul(a, b):
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, axis=-1, keepdims=True),
                           aw * bv + bw * av + np.cross(av, bv)], axis=-1)


def _qconj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _qrot(q, v):
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _slerp_into(a: np.ndarray, b: np.ndarray, u: float, out: np.ndarray) -> None:
    """Per-row slerp of unit quaternions (shortest way)."""
    d = np.sum(a * b, axis=1)
    sign = np.where(d < 0, -1.0, 1.0)
    d = np.minimum(np.abs(d), 1.0)
    th = np.arccos(d)
    st = np.sin(th)
    small = st < 1e-6
    wa = np.where(small, 1.0 - u, np.sin((1.0 - u) * th) / np.where(small, 1.0, st))
    wb = np.where(small, u, np.sin(u * th) / np.where(small, 1.0, st)) * sign
    np.multiply(a, wa[:, None], out=out)
    out += b * wb[:, None]
    out /= np.linalg.norm(out, axis=1)[:, None]


def _rotate_by_rotvec(rv: np.ndarray, q: np.ndarray) -> None:
    """q <- exp(rv) q for stacks (n, 3), (n, 4), in place."""
    ang = np.linalg.norm(rv, axis=1)
    half = 0.5 * ang
    s = np.where(ang > 1e-12, np.sin(half) / np.maximum(ang, 1e-300), 0.5)
    dw = np.cos(half)
    dv = rv * s[:, None]
    w, v = q[:, 0].copy(), q[:, 1:].copy()
    q[:, 0] = dw * w - np.sum(dv * v, axis=1)
    q[:, 1:] = dw[:, None] * v + w[:, None] * dv + np.cross(dv, v)
    q /= np.linalg.norm(q, axis=1)[:, None]


__all__ = ["ImpactError", "ImpactParams", "ImpactResponse", "PHASES", "chain_bodies", "chain_mass", "hovers",
           "servo_hz_of"]
