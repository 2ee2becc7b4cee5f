"""The standing controller of the response's simulations: a balance wrench on the root and,
with ``StandParams(carry=True)``, gravity compensation carrying the weight to the supports
as joint torques (the kernel and its derivation are in ``engine.response._stand``).

    st = Stander(model)                 # one per PhysicsModel of one creature, arrays made once
    st.reset()                          # at a hit: hold the centre of mass and root from the next frame
    st.apply(state)                     # once per frame, after the frame's external forces are set

Why: the PD servos alone (5 Hz, inertia-scaled) hold a pose's shape but not its weight, and
a held pose on its feet is an inverted pendulum. Measured unhit on the lookahead
(Simulation 1, the root's height as a fraction of the creature's height after 1 s): the
humanoid 0.56 -> 0.34, the bat 0.50 -> 0.09, random creature 0 0.50 -> 0.18. So every tap
read as a fall. With this controller the same runs stand (see ``tests/test_impact.py``).

Since s31 the weight is carried by the servos themselves (anchored stance sides,
``engine.physics.WorldSettings.servo_anchor``) and ``carry`` is off: its joint torques,
held for a frame, spun a 15 cm creature's 0.2 g feet at thousands of rad/s (the same on a
bat's thumb and the humanoid's jaw once the stance servos were stiff).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.physics import _kernels as PK
from engine.physics.model import PhysicsModel
from engine.physics.world import PhysicsState
from engine.response._stand import stand_torques


@dataclass(frozen=True)
class StandParams:
    com_hz: float = 1.0          # centre of mass pulled back over the supports at this frequency
    com_zeta: float = 1.0
    root_hz: float = 2.0         # the root's orientation held at this frequency
    root_zeta: float = 1.0
    tol: float = 0.02            # a support's lowest feature within this fraction of the height of the ground
    press: float = 0.7           # a support's pressure centre moves up to this fraction of its features' reach
    carry: bool = False          # the weight-carrying joint torques (False: the root's balance wrench alone)
    # The supports' moment reaches at least this times the rest stance's lean (how far the
    # centre of mass stands from the supports' centre in the rest pose): a creature whose
    # animation stands with its weight ahead of small feet (random 3: 4.3 cm ahead of 1 cm
    # feet) is held as the animation holds it, not toppled by a tap.
    lean_margin: float = 1.5
    ref_height: float = 1.75     # m: com_hz and root_hz as given at this height and above
    # The wrench is computed once a frame and held for it (explicit): its frequencies, in
    # rad/s, never exceed this over the frame's length. A critically damped spring held over
    # T is stable for w T < 1 and decays fastest near 0.8 (its step map's spectral radius
    # 0.57; 0.70 at 0.5, 1.0 at 1). At the small creatures' raised frequencies the
    # lookahead's 1/30 s frames held a centipede's (6.5 cm high) root turn at 10 Hz,
    # 2 pi 10 / 30 = 2.2: it vibrated at 0.5-1 rad a frame after a 0.003 N s tap (s40).
    max_wdt: float = 0.8


class Stander:
    """Preallocated standing controller of a one-creature PhysicsModel."""

    def __init__(self, model: PhysicsModel, params: StandParams | None = None, height: float | None = None) -> None:
        self.model = model
        self.params = p = params or StandParams()
        n = model.nbody
        if len(model.characters) != 1:
            raise ValueError("Stander: one creature per model")
        jp = np.asarray(model.joint_parent)
        bj = np.asarray(model.body_joint, dtype=np.int32)
        parent = np.full(n, -1, np.int32)
        for b in range(n):
            if bj[b] >= 0:
                parent[b] = jp[bj[b]]
        if np.any(parent[1:] >= np.arange(1, n)) or parent[0] != -1:
            raise ValueError("Stander: bodies must be in tree order (parent before child, root first)")
        self.body_parent = parent
        self.body_joint = bj
        self.body_foot = (np.asarray(model.body_contact_kind) == PK.KIND_FOOT).astype(np.int32)
        fb = np.asarray(model.feat_body, dtype=np.int32)
        fl = np.asarray(model.feat_local, dtype=np.float64)
        reach = np.zeros(n)
        np.maximum.at(reach, fb, np.linalg.norm(fl[:, :2], axis=1) if fl.size else np.zeros(0))
        self.body_press = p.press * reach
        if height is None:
            z = model.body_rest_pos[:, 2]
            height = float(z.max() - z.min() + 2 * model.body_bound_radius.max())
        self.height = float(height)
        prm = model.arrays.params
        self.tparams = np.array([prm[PK.P_TERRAIN_X0], prm[PK.P_TERRAIN_Y0], prm[PK.P_TERRAIN_CELL]])
        self.gravity = np.array(prm[PK.P_GRAVITY_X:PK.P_GRAVITY_Z + 1])
        # frequencies scale as 1/sqrt(height) below ref_height (see ImpactParams.servo_height): a
        # body tipping on its feet falls at sqrt(g / L), and 2 Hz held a human but not a 15 cm creature
        self.hz_scale = math.sqrt(max(p.ref_height / max(self.height, 1e-6), 1.0)) if p.ref_height > 0 else 1.0
        wc, wr = 2 * math.pi * p.com_hz * self.hz_scale, 2 * math.pi * p.root_hz * self.hz_scale
        self._w = (wc, wr)
        self.rest_lean, self.on_feet = _rest_lean(model, self.body_foot, p.tol * self.height)
        self.gains = np.array([wc * wc, 2 * p.com_zeta * wc, wr * wr, 2 * p.root_zeta * wr, p.tol * self.height, 1.0,
                               1.0 if p.carry else 0.0, p.lean_margin * self.rest_lean])
        #: the rest pose stands on feet: an inverted pendulum the controller keeps up. A creature
        #: lying on its belly (a snake, an inchworm, an octopus) or hovering is not one, and the
        #: response runs without the controller for it (``ImpactResponse``): its balance wrench on
        #: a snake's head segment, at the frequencies a 7.5 cm creature gets, thrashed the chain
        #: at up to 3.1 rad a tick
        self.ref = np.zeros(7)
        self.scratch = np.zeros((n, 8))
        self.support = np.zeros((n, 4))
        self.out = np.zeros(8)

    def reset(self) -> None:
        """Take the reference (centre of mass over the supports, the root's orientation) from
        the next frame ``apply`` sees."""
        self.ref[6] = 0.0

    def apply(self, state: PhysicsState, fraction: float = 1.0, dt: float | None = None) -> None:
        """Add this frame's standing torques to ``state.body_torque``; ``fraction`` scales the
        balance term (1: full; gravity compensation is always whole). ``dt``: the frame the
        wrench is held for (s): the frequencies are capped so that held that long it stays
        stable (``StandParams.max_wdt``)."""
        m, a = self.model, state.arrays
        self.gains[5] = fraction
        p = self.params
        wc, wr = self._w
        if dt is not None and dt > 0.0 and p.max_wdt > 0.0:
            wc = min(wc, p.max_wdt / dt)
            wr = min(wr, p.max_wdt / dt)
        self.gains[0], self.gains[1] = wc * wc, 2 * p.com_zeta * wc
        self.gains[2], self.gains[3] = wr * wr, 2 * p.root_zeta * wr
        stand_torques(a.body_pos, a.body_rot, a.body_linvel, a.body_angvel, a.body_force, a.body_torque, m.body_mass,
                      m.body_inertia,
                      self.body_parent, self.body_joint, m.joint_anchor_parent, m.joint_locked, self.body_foot,
                      self.body_press, m.feat_body, m.feat_local, m.feat_radius, m.arrays.terrain_height,
                      self.tparams, self.gravity, self.ref, self.gains, self.scratch, self.support, self.out)

    @property
    def supports(self) -> int:
        return int(self.out[0])


def _rest_lean(model: PhysicsModel, body_foot: np.ndarray, tol: float) -> tuple[float, bool]:
    """Ground-plane distance (m) from the rest pose's supports' centre (the foot bodies with a
    feature within ``tol`` of the lowest one; every body's when no foot is that low) to its
    centre of mass, and whether those supports are feet (``Stander.on_feet``)."""
    fb = np.asarray(model.feat_body, dtype=np.int64)
    if fb.size == 0:
        return 0.0, False
    pos = np.asarray(model.body_rest_pos, float)
    rot = np.asarray(model.body_rest_rot, float)
    loc = np.asarray(model.feat_local, float)
    q = rot[fb]
    w, u = q[:, :1], q[:, 1:]
    t = 2.0 * np.cross(u, loc)
    pts = pos[fb] + loc + w * t + np.cross(u, t)
    low = pts[:, 2] - np.asarray(model.feat_radius, float)
    near = low < low.min() + tol
    on_foot = near & (body_foot[fb] != 0)
    pick = on_foot if on_foot.any() else near
    bodies = np.unique(fb[pick])
    centre = np.array([pts[pick & (fb == b), :2].mean(axis=0) for b in bodies]).mean(axis=0)
    mass = np.asarray(model.body_mass, float)
    com = (mass[:, None] * pos[:, :2]).sum(axis=0) / mass.sum()
    return float(np.linalg.norm(com - centre)), bool(on_foot.any())


__all__ = ["StandParams", "Stander"]
