"""Jiggles: passive secondary motion for the bodies nothing drives this frame.

Hecker et al. 2008, section 4.4: the sub-trees that have no IK are found each frame from
what the playing animations select (the caller passes the ``driven`` mask), and a highly
damped pseudo-physical simulation moves them from their parents' motion. It never feeds
back into driven bodies.

``JiggleRig`` holds per-body constants derived once from the creature by a flexibility
heuristic; ``JiggleState`` holds the per-frame arrays; ``jiggle_step`` runs the kernel.

The flexibility heuristic (frequency f in Hz, damping ratio z):
- by capability: ears, tails, wings and details are floppy (f 1.6 to 2.5 Hz, z 0.75);
  limbs, graspers, feet, heads and mouths moderate (3 to 5 Hz, z 0.9); spikes stiff
  (8 Hz, z 1.0); spine bodies 3 Hz, z 0.9; eyes do not lag at all (f 0: carried rigidly
  by their head). An eye sits in a socket: it has no lever to swing on, and as a stiff
  spring its tiny lever rang at every kink of the head's motion (the humanoid's
  ``pick_fruit``: the head stops dead from 9.6 rad/s, and each eye swung 0.59 rad in
  that frame, a flip in the validation grid);
- by size: like a pendulum, longer levers swing slower: f scales with sqrt(0.25 m / L),
  clamped to [0.4, 2.5] times the capability's frequency, so a mouse twitches and a giant
  sways;
- by placement: each step further from the driven body it hangs off lowers f by 12%, so
  tail and antenna tips lag more than their roots.
All three are in ``flexibility`` and can be overridden per body with ``JiggleRig.with_params``.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from engine.jiggle._kernels import jiggle_kernel
from engine.mathx.quat import quat_rotate
from engine.model.caps import DETAIL, EAR, EYE, FOOT, GRASPER, HEAD, LIMB, MOUTH, SPIKE, SPINE, TAIL, WING
from engine.model.creature import Creature

# (capability bit, frequency Hz, damping ratio), first match wins.
_CAP_FLEX = (
    (EYE, 0.0, 1.0),      # rigid in its socket (see the module note)
    (SPIKE, 8.0, 1.0),
    (EAR, 2.2, 0.75),
    (WING, 2.0, 0.75),
    (TAIL, 1.6, 0.75),
    (DETAIL, 2.5, 0.75),
    (MOUTH, 5.0, 0.9),
    (GRASPER, 4.0, 0.9),
    (FOOT, 4.5, 0.9),
    (HEAD, 3.0, 0.9),
    (LIMB, 3.5, 0.9),
    (SPINE, 3.0, 0.9),
)
_DEFAULT_FLEX = (3.0, 0.9)
LEVER_REFERENCE = 0.25      # m: lever length at which the capability frequency applies
DEPTH_FACTOR = 0.88         # frequency factor per step away from the driven ancestor
MAX_DEFLECTION = 0.6        # largest tip error as a fraction of the lever length
SLEEP = 1e-6                # sleep threshold as a fraction of the lever length (m, m/s)
FOLLOW_RATIO = 0.5          # a body whose lever is shorter than this share of its parent's hangs
                            # from the posed parent (see the kernel)


def flexibility(creature: Creature) -> tuple[np.ndarray, np.ndarray]:
    """Per-body spring frequency (Hz) and damping ratio from capability and size.

    Placement (depth below the driven ancestor) is applied per frame-set by
    ``JiggleRig``, since it depends on which bodies are driven; here the depth counts from
    the nearest spine body, which is the common case of limbs left passive.
    """
    n = creature.nbody
    freq = np.empty(n)
    zeta = np.empty(n)
    lever = _levers(creature)
    length = np.linalg.norm(lever, axis=1)
    for i in range(n):
        caps = int(creature.body_caps[i])
        f, z = _DEFAULT_FLEX
        for bit, cf, cz in _CAP_FLEX:
            if caps & bit:
                f, z = cf, cz
                break
        size = np.clip(np.sqrt(LEVER_REFERENCE / max(length[i], 1e-6)), 0.4, 2.5)
        depth = 0
        j = i
        while j > 0 and not creature.body_is_spine[j]:
            depth += 1
            j = int(creature.body_parent[j])
        freq[i] = f * size * DEPTH_FACTOR ** max(depth - 1, 0)
        zeta[i] = z
    return freq, zeta


def _levers(creature: Creature) -> np.ndarray:
    """Lever of each body in its own frame: from its joint to its box centre, or, when the
    centre sits on the joint, along the box's longest half-extent (pointing away from the
    parent)."""
    lever = np.array(creature.body_joint_offset, dtype=float)
    size = float(np.max(creature.size))
    for i in range(creature.nbody):
        if np.linalg.norm(lever[i]) < 1e-4 * size:
            axis = int(np.argmax(creature.body_extent[i]))
            v = np.zeros(3)
            v[axis] = creature.body_extent[i, axis]
            # Point it away from the parent's joint if we can tell.
            if i > 0:
                away = creature.body_rest_pos[i] - creature.body_rest_pos[creature.body_parent[i]]
                if float(quat_rotate(creature.body_rest_rot[i], v) @ away) < 0.0:
                    v = -v
            lever[i] = v
    return lever


@dataclass(frozen=True)
class JiggleRig:
    """Per-body jiggle constants for one creature (read-only arrays, n = nbody)."""

    creature: Creature
    lever: np.ndarray      # (n, 3) joint-to-tip lever in the body frame, m
    omega: np.ndarray      # (n,) spring angular frequency 2 pi f, rad/s
    zeta: np.ndarray       # (n,) damping ratio
    max_err: np.ndarray    # (n,) largest tip deflection, m
    sleep: np.ndarray      # (n,) sleep threshold, m and m/s
    follow: np.ndarray     # (n,) bool: hangs from its posed parent, not the rigid chain (short
                           #   bodies on long parents: eyes, ears, jaws on a head)

    @classmethod
    def for_creature(cls, creature: Creature) -> JiggleRig:
        """The creature's default rig (made once per creature and shared: it is read-only)."""
        hit = _DEFAULT_RIGS.get(creature)
        if hit is None:
            freq, zeta = flexibility(creature)
            hit = _DEFAULT_RIGS[creature] = cls._make(creature, freq, zeta)
        return hit

    @classmethod
    def _make(cls, creature, freq, zeta) -> JiggleRig:
        lever = _levers(creature)
        length = np.linalg.norm(lever, axis=1)
        parent_length = np.array([length[p] if p >= 0 else np.inf for p in creature.body_parent])
        arrays = dict(lever=lever, omega=2.0 * np.pi * np.asarray(freq, float),
                      zeta=np.asarray(zeta, float), max_err=MAX_DEFLECTION * length,
                      sleep=SLEEP * np.maximum(length, 1e-6),
                      # an eye rides its posed head whatever its size (it has no lag of its own)
                      follow=(length < FOLLOW_RATIO * parent_length) | ((creature.body_caps & np.uint32(EYE)) != 0))
        for a in arrays.values():
            a.flags.writeable = False
        return cls(creature=creature, **arrays)

    def with_params(self, frequency_hz: np.ndarray | None = None,
                    damping_ratio: np.ndarray | None = None) -> JiggleRig:
        """A rig with overridden per-body frequency (Hz; 0 = rigid) and/or damping ratio."""
        freq = self.omega / (2.0 * np.pi) if frequency_hz is None else np.asarray(frequency_hz, float)
        zeta = self.zeta if damping_ratio is None else np.asarray(damping_ratio, float)
        n = self.creature.nbody
        if freq.shape != (n,) or zeta.shape != (n,):
            raise ValueError(f"expected ({n},) arrays for creature '{self.creature.name}'")
        if np.any(~np.isfinite(freq)) or np.any(freq < 0) or np.any(~np.isfinite(zeta)) or np.any(zeta <= 0):
            raise ValueError("frequencies must be finite and >= 0, damping ratios finite and > 0")
        return JiggleRig._make(self.creature, freq, zeta)


_DEFAULT_RIGS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class JiggleState:
    """Per-character jiggle state, preallocated (n = nbody)."""

    def __init__(self, nbody: int) -> None:
        self.err = np.zeros((nbody, 3))
        self.err_vel = np.zeros((nbody, 3))
        self.target = np.zeros((nbody, 3))
        self.target_vel = np.zeros((nbody, 3))
        self.active = np.zeros(nbody, np.bool_)
        self.twist = np.zeros((nbody, 2))          # hand-off twist about the lever, rad, and its rate
        self.contact = np.zeros((nbody, 4))        # the turn the ground holds the body by (w-first)
        self.contact[:, 0] = 1.0
        self.chain_joint = np.zeros((nbody, 3))     # kernel scratch (no state)
        self.chain_rot = np.zeros((nbody, 4))

    def reset(self) -> None:
        """Forget all motion (e.g. after a teleport): passive bodies restart at rest."""
        self.err[:] = 0.0
        self.err_vel[:] = 0.0
        self.twist[:] = 0.0
        self.contact[:] = (1.0, 0.0, 0.0, 0.0)
        self.active[:] = False


def jiggle_step(rig: JiggleRig, state: JiggleState, driven: np.ndarray, world_pos: np.ndarray,
                world_rot: np.ndarray, dt: float, simulate: bool = True, ground=(0.0, 0.0, 1.0, 0.0)) -> None:
    """Pose every body not in ``driven`` from its parent, with passive lag when ``simulate``.

    Args:
        driven: (nbody,) bool, the bodies IK or the animation posed this frame (the root
            must be driven). Their transforms are read and never written.
        world_pos, world_rot: (nbody, 3) and (nbody, 4) character or world space; driven
            rows are inputs, the other rows are outputs (and hold last frame's output on
            input, which a body that just became passive starts from).
        dt: the frame step in seconds (> 0).
        simulate: False poses passive bodies rigidly at their rest offsets (the stage off).
        ground: the plane (nx, ny, nz, d), n . x = d with n the unit up normal, that passive
            bodies rest on (default the plane z = 0).
    """
    if not (dt > 0.0 and np.isfinite(dt)):
        raise ValueError(f"jiggle_step: dt must be a positive finite number of seconds, got {dt!r}")
    if not driven[0]:
        raise ValueError("jiggle_step: the root body must be driven")
    c = rig.creature
    jiggle_kernel(c.body_parent, c.body_local_rot, c.body_local_joint, c.body_joint_offset,
                  rig.lever, rig.omega, rig.zeta, rig.max_err, rig.sleep, rig.follow, c.body_extent,
                  np.asarray(ground, dtype=float), driven, world_pos, world_rot,
                  state.err, state.err_vel, state.target, state.target_vel, state.active, state.twist, state.contact,
                  state.chain_joint, state.chain_rot, float(dt), bool(simulate))
