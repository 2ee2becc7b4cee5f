"""PhysicsState (like mjData) and the step: the per-frame side of the integrator.

    model = engine.physics.model_from_creatures(creature)
    state = engine.physics.PhysicsState(model)              # rest pose, at rest
    state = engine.physics.state_from_kinematic(model, pos, rot, prev_pos, prev_rot, dt)
    engine.physics.step(model, state, 0.0005)               # or dt=1/60, substeps=32
    state.body_pos, state.body_rot                          # body transforms, read back

The state owns every array the kernels write, allocated once; ``step`` allocates nothing.
Controls live in the state, set them between steps:
    joint_target_rot (j, 4)      PD servo target: child rotation relative to its parent
    joint_target_angvel (j, 3)   target relative angular velocity, parent frame (rad/s)
    joint_pd_hz (j,), joint_pd_zeta (j,)  servo stiffness as a frequency and damping
                                 ratio (0 Hz: passive joint); kp = (2 pi hz)^2, kv = 2 zeta
                                 2 pi hz, inertia-scaled (Zordan et al. 2005, section 4)
    joint_pd_max_torque (j,)     torque limit, N m (0: none)
    body_track_vel (n, 3), body_track_gain (n,)  proportional velocity controller
                                 F = K_f m (v_target - v) (Wilke & Semwal eq. 2), K_f 1/s
    body_force (n, 3), body_torque (n, 3)   external force / torque, N and N m
Bodies' hot state: body_pos (n, 3), body_rot (n, 4), body_linvel (n, 3), body_angvel (n, 3).
"""

from __future__ import annotations

import hashlib
import math
from typing import NamedTuple

import numpy as np

from engine.physics import _kernels as K
from engine.physics.model import PhysicsError, PhysicsModel, SimulationDiverged


class StateArrays(NamedTuple):
    body_pos: np.ndarray
    body_rot: np.ndarray
    body_linvel: np.ndarray
    body_angvel: np.ndarray
    body_force: np.ndarray
    body_torque: np.ndarray
    body_track_vel: np.ndarray
    body_track_gain: np.ndarray
    joint_target_rot: np.ndarray
    joint_target_angvel: np.ndarray
    joint_pd_hz: np.ndarray
    joint_pd_zeta: np.ndarray
    joint_pd_max_torque: np.ndarray
    # solver scratch
    body_iinv_world: np.ndarray
    joint_ra: np.ndarray
    joint_rb: np.ndarray
    joint_kinv: np.ndarray
    joint_ang_kinv: np.ndarray
    joint_pd_mass: np.ndarray
    joint_pd_invmass: np.ndarray
    sub_mass: np.ndarray
    sub_moment: np.ndarray
    sub_second: np.ndarray
    sub_fixed: np.ndarray
    joint_imp: np.ndarray
    joint_lock_imp: np.ndarray
    joint_pd_imp: np.ndarray
    feat_active: np.ndarray
    feat_point: np.ndarray
    feat_r: np.ndarray
    feat_normal: np.ndarray
    feat_t1: np.ndarray
    feat_t2: np.ndarray
    feat_sep: np.ndarray
    feat_mass: np.ndarray
    feat_imp: np.ndarray
    pair_active: np.ndarray
    pair_point: np.ndarray
    pair_ra: np.ndarray
    pair_rb: np.ndarray
    pair_local: np.ndarray
    pair_normal: np.ndarray
    pair_t1: np.ndarray
    pair_t2: np.ndarray
    pair_sep: np.ndarray
    pair_mass: np.ndarray
    pair_imp: np.ndarray
    node_dim: np.ndarray
    joint_servo_direct: np.ndarray
    node_D: np.ndarray
    node_Dinv: np.ndarray
    node_L: np.ndarray
    node_H: np.ndarray
    node_work: np.ndarray
    node_x: np.ndarray
    node_z: np.ndarray
    # ground contacts through the tree (direct solver): k = min(contact bodies, MAX_CONTACT_BODIES)
    cbody: np.ndarray            # (k,) int32 body of each contact slot
    cbody_n: np.ndarray          # (1,) int32 slots in use this substep
    body_cslot: np.ndarray       # (n,) int32 slot of each body, -1: none
    cbody_phi: np.ndarray        # (k, k, 6, 6) articulated inverse inertia between slots
    cbody_vel: np.ndarray        # (k, 6) slot bodies' velocity (lin, ang) during the solve
    node_need: np.ndarray        # (n + j,) int32 1 + the highest slot in the node's subtree, 0: none
    need_order: np.ndarray       # (n + j,) int32 those nodes, root first; count in need_n
    need_n: np.ndarray           # (1,) int32
    feat_amass: np.ndarray       # (f, 5) articulated masses: normal, 2x2 tangent inverse, spin
    feat_imp0: np.ndarray        # (f, 4) accumulated impulses when a contact pass began
    clock: np.ndarray


_HOT = ("body_pos", "body_rot", "body_linvel", "body_angvel")


class PhysicsState:
    """Preallocated state of a PhysicsModel, at its rest pose and at rest."""

    def __init__(self, model: PhysicsModel) -> None:
        n, j = model.nbody, model.njoint
        f, p = model.feat_body.shape[0], model.pair_a.shape[0]
        k = min(int(np.count_nonzero(np.asarray(model.body_contact_kind) != K.KIND_NONE)), K.MAX_CONTACT_BODIES)
        z = np.zeros
        self.model = model
        self.arrays = StateArrays(
            body_pos=np.array(model.body_rest_pos, dtype=np.float64), body_rot=np.array(model.body_rest_rot),
            body_linvel=z((n, 3)), body_angvel=z((n, 3)), body_force=z((n, 3)), body_torque=z((n, 3)),
            body_track_vel=z((n, 3)), body_track_gain=z(n),
            joint_target_rot=np.array(model.joint_rest_rot), joint_target_angvel=z((j, 3)),
            joint_pd_hz=np.array(model.joint_servo_hz), joint_pd_zeta=np.array(model.joint_servo_zeta),
            joint_pd_max_torque=z(j),
            body_iinv_world=z((n, 3, 3)), joint_ra=z((j, 3)), joint_rb=z((j, 3)), joint_kinv=z((j, 3, 3)),
            joint_ang_kinv=z((j, 3, 3)), joint_pd_mass=z((j, 3, 3)), joint_pd_invmass=z((j, 3, 3)),
            sub_mass=z(n), sub_moment=z((n, 3)), sub_second=z((n, 3, 3)), sub_fixed=z(n, np.int32),
            joint_imp=z((j, 3)), joint_lock_imp=z((j, 3)), joint_pd_imp=z((j, 3)),
            feat_active=z(f, np.int32), feat_point=z((f, 3)), feat_r=z((f, 3)), feat_normal=z((f, 3)),
            feat_t1=z((f, 3)), feat_t2=z((f, 3)), feat_sep=z(f), feat_mass=z((f, 4)), feat_imp=z((f, 4)),
            pair_active=z(p, np.int32), pair_point=z((p, 3)), pair_ra=z((p, 3)), pair_rb=z((p, 3)),
            pair_local=z((p, 6)), pair_normal=z((p, 3)), pair_t1=z((p, 3)), pair_t2=z((p, 3)), pair_sep=z(p),
            pair_mass=z((p, 3)), pair_imp=z((p, 3)),
            node_dim=np.full(n + j, 3, np.int32), joint_servo_direct=z(j, np.int32),
            node_D=z((n + j, 6, 6)), node_Dinv=z((n + j, 6, 6)), node_L=z((n + j, 6, 6)), node_H=z((6, 6)),
            node_work=z((6, 12)), node_x=z((n + j, 6)), node_z=z((n + j, 6)),
            cbody=z(k, np.int32), cbody_n=z(1, np.int32), body_cslot=np.full(n, -1, np.int32),
            cbody_phi=z((k, k, 6, 6)), cbody_vel=z((k, 6)), node_need=z(n + j, np.int32),
            need_order=z(n + j, np.int32), need_n=z(1, np.int32), feat_amass=z((f, 5)), feat_imp0=z((f, 4)),
            clock=z(2),
        )

    def __getattr__(self, name):
        arrays = self.__dict__.get("arrays")
        if arrays is not None and name in StateArrays._fields:
            return getattr(arrays, name)
        raise AttributeError(name)

    @property
    def time(self) -> float:
        return float(self.arrays.clock[0])

    @property
    def steps(self) -> int:
        return int(self.arrays.clock[1])

    def copy(self) -> PhysicsState:
        other = PhysicsState.__new__(PhysicsState)
        other.model = self.model
        other.arrays = StateArrays(*[a.copy() for a in self.arrays])
        return other

    def set_pose(self, pos, rot, linvel=None, angvel=None) -> None:
        """Set every body's transform (and velocities, default zero); validated."""
        n = self.model.nbody
        for name, value, shape in (("pos", pos, (n, 3)), ("rot", rot, (n, 4)), ("linvel", linvel, (n, 3)),
                                   ("angvel", angvel, (n, 3))):
            if value is None:
                continue
            a = np.asarray(value, dtype=np.float64)
            if a.shape != shape:
                raise PhysicsError(f"{name} must have shape {shape}, got {a.shape}", field=name, kind="state",
                                   subject="pose")
            bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
            if bad.size:
                raise PhysicsError(f"{name} is not finite", field=name, subject=self.model.body_names[bad[0]])
        q = np.asarray(rot, dtype=np.float64)
        norms = np.linalg.norm(q, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
        if bad.size:
            raise PhysicsError(f"rot must be unit quaternions (|q| = {norms[bad[0]]:.6g})", field="rot",
                               subject=self.model.body_names[bad[0]])
        self.arrays.body_pos[:] = pos
        self.arrays.body_rot[:] = q / norms[:, None]
        self.arrays.body_linvel[:] = 0.0 if linvel is None else linvel
        self.arrays.body_angvel[:] = 0.0 if angvel is None else angvel
        for name in ("joint_imp", "joint_lock_imp", "joint_pd_imp", "feat_imp", "pair_imp"):
            getattr(self.arrays, name)[:] = 0.0

    def digest(self) -> str:
        """SHA-256 of the bodies' hot state, bit for bit (determinism tests)."""
        h = hashlib.sha256()
        for name in _HOT:
            h.update(np.ascontiguousarray(getattr(self.arrays, name)).tobytes())
        return h.hexdigest()


def state_from_kinematic(model: PhysicsModel, pos, rot, prev_pos=None, prev_rot=None, dt: float = 1 / 60):
    """A state at the pose (pos, rot) whose velocities are the finite difference from
    the previous pose (the runtime's output one frame earlier): v = (x - x_prev)/dt,
    w = rotvec(q q_prev^-1)/dt (world frame)."""
    state = PhysicsState(model)
    pos = np.asarray(pos, dtype=np.float64)
    rot = np.asarray(rot, dtype=np.float64)
    linvel = angvel = None
    if prev_pos is not None or prev_rot is not None:
        if not (math.isfinite(dt) and dt > 0):
            raise PhysicsError(f"dt must be > 0, got {dt}", field="dt", kind="state", subject="pose")
        prev_pos = pos if prev_pos is None else np.asarray(prev_pos, dtype=np.float64)
        prev_rot = rot if prev_rot is None else np.asarray(prev_rot, dtype=np.float64)
        if prev_pos.shape != pos.shape or prev_rot.shape != rot.shape:
            raise PhysicsError("the previous pose must have the shape of the pose", field="prev_pos",
                               kind="state", subject="pose")
        linvel = (pos - prev_pos) / dt
        angvel = rotvec_between(prev_rot, rot) / dt
    state.set_pose(pos, rot, linvel, angvel)
    return state


def rotvec_between(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """World rotation vectors of q1 q0^-1 for stacks of quaternions (shortest way)."""
    w0, v0 = q0[..., 0], q0[..., 1:]
    w1, v1 = q1[..., 0], q1[..., 1:]
    # d = q1 * conj(q0)
    dw = w1 * w0 + np.sum(v1 * v0, axis=-1)
    dv = -w1[..., None] * v0 + w0[..., None] * v1 - np.cross(v1, v0)
    sign = np.where(dw < 0, -1.0, 1.0)
    dw = dw * sign
    dv = dv * sign[..., None]
    s = np.linalg.norm(dv, axis=-1)
    angle = 2.0 * np.arctan2(s, dw)
    k = np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0)
    return dv * k[..., None]


def step(model: PhysicsModel, state: PhysicsState, dt: float, *, substeps: int = 1, iterations: int = 1,
         steps: int = 1, projections: int = 1) -> None:
    """Advance ``steps`` fixed steps of ``dt`` s (each in ``substeps`` substeps). The
    substep h = dt/substeps should stay near 0.0005-0.002 s for ragdolls (Zordan et al.
    found 0.0005 s needed for good contact); 0.0005 with one substep works, and a game
    frame of 1/60 with 32 substeps is the same thing. Raises SimulationDiverged on a
    non-finite state (never returns NaN)."""
    if state.model is not model:
        raise PhysicsError("state was made for another model", kind="state", subject="state", field="model")
    if not (math.isfinite(dt) and dt > 0):
        raise PhysicsError(f"dt must be a positive number of seconds, got {dt}", kind="state", subject="step",
                           field="dt")
    if int(projections) != projections or projections < 0:
        raise PhysicsError(f"projections must be >= 0, got {projections}", kind="state", subject="step",
                           field="projections")
    for name, v in (("substeps", substeps), ("iterations", iterations), ("steps", steps)):
        if int(v) != v or v < 1:
            raise PhysicsError(f"{name} must be a positive integer, got {v}", kind="state", subject="step",
                               field=name)
    if K.step_kernel(model.arrays, state.arrays, float(dt), int(substeps), int(iterations), int(projections),
                     int(steps)):
        raise SimulationDiverged(f"simulation became non-finite at t = {state.time:.6f} s")


def servo_targets_from_pose(model: PhysicsModel, body_rot, out: np.ndarray | None = None) -> np.ndarray:
    """PD servo targets (child rotation relative to its parent, (njoint, 4)) that hold the
    world body rotations ``body_rot`` (n, 4): q_parent^-1 q_child. Write them into
    ``state.joint_target_rot`` to make the servos track a kinematic pose."""
    q = np.asarray(body_rot, dtype=np.float64)
    if q.shape != (model.nbody, 4):
        raise PhysicsError(f"body_rot must have shape ({model.nbody}, 4), got {q.shape}", field="body_rot",
                           kind="state", subject="pose")
    if out is None:
        out = np.empty((model.njoint, 4))
    qa = q[model.joint_parent]
    qb = q[model.joint_child]
    aw, av = qa[:, 0], -qa[:, 1:]
    bw, bv = qb[:, 0], qb[:, 1:]
    out[:, 0] = aw * bw - np.sum(av * bv, axis=1)
    out[:, 1:] = aw[:, None] * bv + bw[:, None] * av + np.cross(av, bv)
    return out


def joint_separation(model: PhysicsModel, state: PhysicsState, out: np.ndarray | None = None) -> np.ndarray:
    """Distance (m) between the two sides of each ball joint (njoint,)."""
    if out is None:
        out = np.zeros(model.njoint)
    K.joint_separation_kernel(model.arrays, state.arrays, out)
    return out


def energy(model: PhysicsModel, state: PhysicsState) -> dict:
    """Kinetic (linear + angular) and gravitational potential energy, J (fixed bodies
    excluded)."""
    a = state.arrays
    live = model.body_inv_mass > 0
    m = model.body_mass[live]
    lin = 0.5 * float(np.sum(m * np.sum(a.body_linvel[live] ** 2, axis=1)))
    # angular: 1/2 w_b . I w_b with w_b the body-frame angular velocity
    q = a.body_rot[live]
    w = a.body_angvel[live]
    qv, qw = q[:, 1:], q[:, 0:1]
    t = 2.0 * np.cross(-qv, w)
    wb = w + qw * t + np.cross(-qv, t)
    ang = 0.5 * float(np.sum(model.body_inertia[live] * wb * wb))
    g = np.asarray(model.settings.gravity)
    pot = -float(np.sum(m * (a.body_pos[live] @ g)))
    return {"kinetic": lin + ang, "linear": lin, "angular": ang, "potential": pot, "total": lin + ang + pot}
