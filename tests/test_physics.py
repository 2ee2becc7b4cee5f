"""The rigid-body integrator (engine.physics).

Opens with the list of invalid inputs and the error each must raise; then shapes'
mass and inertia against a plain numpy voxel integration; then tiny scenes whose answer
can be worked out by hand (free fall, a pendulum's period, a PD servo's frequency from
a mouse-sized to a giant rod, the velocity controller's exponential approach); then
robustness with figures (energy of a passive chain, joint separation, a heavy kick,
tunnelling, two characters); then determinism (a canned scene hashed bit for bit).
Figures are printed (``pytest -s``) so the report can quote them.
"""

from __future__ import annotations

import glob
import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine
from engine.ik.testing import MINI_TEXT as MINI  # the shared seven-body test biped
from engine.mathx import quat_rotate
from engine.model import creature_from_text
from engine.physics import (
    BodySpec,
    ContactSettings,
    CreatureBodyOptions,
    PhysicsError,
    PhysicsState,
    Terrain,
    WorldSettings,
    build_model,
    energy,
    joint_separation,
    model_from_creatures,
    servo_targets_from_pose,
    shape_mass_inertia,
    state_from_kinematic,
    step,
)
from engine.physics.model import SHAPE_BOX, SHAPE_CAPSULE, SHAPE_SPHERE
from engine.validation.thresholds import BY_METRIC

ID = np.array([1.0, 0.0, 0.0, 0.0])
DT = 0.0005


def mini():
    return creature_from_text(MINI)


def qy(angle):
    return np.array([math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])


def rot(q, v):
    w, u = q[0], q[1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def hanging_rod(length=1.0, radius=0.05, settings=None, contact="none"):
    """A fixed anchor and a capsule rod hanging from it by a ball joint at its top end."""
    top = np.array([0.0, 0.0, 2.0 * length + 1.0])
    specs = [
        BodySpec("anchor", "sphere", top, ID, radius=radius, fixed=True, contact="none"),
        BodySpec("rod", "capsule", top - [0, 0, length / 2], ID, radius=radius,
                 half_length=length / 2 - radius, axis=2, parent=0, joint=top, contact=contact),
    ]
    return build_model(specs, settings=settings), top


def swing(model, state, top, length, angle):
    """Pose the rod swung by ``angle`` about y around its top."""
    q = qy(angle)
    state.set_pose(np.array([top, top + rot(q, np.array([0, 0, -length / 2]))]), np.array([ID, q]))


# ---------------------------------------------------------------------------------------
# Invalid inputs, each with the error it must raise
# ---------------------------------------------------------------------------------------

def _sphere(name="b", **kw):
    base = dict(name=name, shape="sphere", pos=np.zeros(3), rot=ID, radius=0.1)
    base.update(kw)
    return BodySpec(**base)


INVALID_SPECS = [
    ([_sphere(shape="cone")], "unknown shape 'cone'", "shape"),
    ([_sphere(radius=-1.0)], "radius must be > 0", "radius"),
    ([_sphere(radius=float("nan"))], "radius must be > 0", "radius"),
    ([_sphere(rot=np.array([1.0, 1.0, 0.0, 0.0]))], "unit quaternion", "rot"),
    ([_sphere(pos=np.array([0.0, np.inf, 0.0]))], "pos must be 3 finite numbers", "pos"),
    ([_sphere(mass=0.0)], "mass must be > 0", "mass"),
    ([_sphere(density=-3.0)], "density must be > 0", "density"),
    ([_sphere(contact="sticky")], "unknown contact kind", "contact"),
    ([_sphere(shape="box", half_extents=np.array([0.1, 0.0, 0.1]))], "half_extents must be > 0", "half_extents"),
    ([_sphere(shape="capsule", half_length=-0.1)], "half_length must be >= 0", "half_length"),
    ([_sphere(shape="capsule", half_length=0.1, axis=3)], "axis must be 0, 1 or 2", "axis"),
    ([_sphere(locked=True)], "only a body with a parent joint can be locked", "locked"),
    ([_sphere("a"), _sphere("a")], "unique", "name"),
    ([_sphere("a", parent=1, joint=np.zeros(3)), _sphere("b")], "must come before", "parent"),
    ([_sphere("a"), _sphere("b", parent=0)], "needs a joint point", "joint"),
    ([_sphere("a"), _sphere("b", parent=0, joint=np.zeros(3), character=1)], "crosses characters", "parent"),
    ([], "at least one body", "bodies"),
    ([_sphere("a"), _sphere("b", parent=0, joint=np.zeros(3), servo_hz=-1.0)], "servo_hz must be >= 0", "servo_hz"),
]


@pytest.mark.parametrize("specs,message,field", INVALID_SPECS)
def test_invalid_body_specs(specs, message, field):
    with pytest.raises(PhysicsError, match=message) as err:
        build_model(specs)
    assert err.value.field == field


def test_invalid_creature_options_name_the_body():
    with pytest.raises(PhysicsError, match="no body 'knee'") as err:
        model_from_creatures(mini(), options=CreatureBodyOptions(locked=("knee",)))
    assert err.value.subject == "knee" and err.value.field == "locked"
    with pytest.raises(PhysicsError, match="no body 'tail'"):
        model_from_creatures(mini(), options=CreatureBodyOptions(mass={"tail": 2.0}))
    with pytest.raises(PhysicsError, match="shape must be"):
        model_from_creatures(mini(), options=CreatureBodyOptions(shape="blob"))


def test_invalid_terrain():
    with pytest.raises(PhysicsError, match="non-finite"):
        Terrain(np.array([[0.0, np.nan]]))
    with pytest.raises(PhysicsError, match="cell size"):
        Terrain(np.zeros((2, 2)), cell=0.0)
    with pytest.raises(PhysicsError, match="2-D"):
        Terrain(np.zeros(3))


def test_invalid_step_and_state():
    model = model_from_creatures(mini())
    state = PhysicsState(model)
    for kwargs, message in ((dict(dt=0.0), "dt must be"), (dict(dt=float("nan")), "dt must be"),
                            (dict(dt=DT, substeps=0), "substeps"), (dict(dt=DT, iterations=1.5), "iterations"),
                            (dict(dt=DT, steps=-1), "steps")):
        with pytest.raises(PhysicsError, match=message):
            step(model, state, **kwargs)
    other = PhysicsState(model_from_creatures(mini()))
    with pytest.raises(PhysicsError, match="another model"):
        step(model, other, DT)
    with pytest.raises(PhysicsError, match="shape"):
        state.set_pose(np.zeros((3, 3)), np.tile(ID, (3, 1)))
    bad = np.array(model.body_rest_pos)
    bad[2, 1] = np.nan
    with pytest.raises(PhysicsError, match="not finite") as err:
        state.set_pose(bad, model.body_rest_rot)
    assert err.value.subject == "head"
    with pytest.raises(PhysicsError, match="unit quaternions"):
        state.set_pose(model.body_rest_pos, np.array(model.body_rest_rot) * 2.0)
    with pytest.raises(PhysicsError, match="dt must be"):
        state_from_kinematic(model, model.body_rest_pos, model.body_rest_rot, model.body_rest_pos,
                             model.body_rest_rot, dt=0.0)


# ---------------------------------------------------------------------------------------
# Mass and inertia against a voxel integration (plain numpy)
# ---------------------------------------------------------------------------------------

def _voxel_mass_inertia(inside, half, density, n=150):
    g = (np.arange(n) + 0.5) / n * 2 * half - half
    X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
    mask = inside(X, Y, Z)
    dv = (2 * half / n) ** 3
    m = density * dv * mask.sum()
    Ix = density * dv * np.sum(mask * (Y**2 + Z**2))
    Iy = density * dv * np.sum(mask * (X**2 + Z**2))
    Iz = density * dv * np.sum(mask * (X**2 + Y**2))
    return m, np.array([Ix, Iy, Iz])


@pytest.mark.parametrize("shape,size,inside,half", [
    (SHAPE_SPHERE, (0.3, 0, 0), lambda x, y, z: x * x + y * y + z * z <= 0.09, 0.3),
    (SHAPE_BOX, (0.1, 0.2, 0.3), lambda x, y, z: (abs(x) <= 0.1) & (abs(y) <= 0.2) & (abs(z) <= 0.3), 0.3),
    (SHAPE_CAPSULE, (0.1, 0.2, 0), lambda x, y, z: (np.clip(x, -0.2, 0.2) - x) ** 2 + y * y + z * z <= 0.01, 0.3),
    (SHAPE_CAPSULE, (0.1, 0.2, 2), lambda x, y, z: (np.clip(z, -0.2, 0.2) - z) ** 2 + y * y + x * x <= 0.01, 0.3),
])
def test_mass_inertia_against_voxels(shape, size, inside, half):
    m, inertia = shape_mass_inertia(shape, np.array(size, dtype=float), 1000.0)
    mv, iv = _voxel_mass_inertia(inside, half, 1000.0)
    assert m == pytest.approx(mv, rel=0.01)
    np.testing.assert_allclose(inertia, iv, rtol=0.02)


def test_creature_bodies_from_extents():
    model = model_from_creatures(mini())
    c = mini()
    thigh = model.body("thigh_l")
    assert model.body_shape[thigh] == SHAPE_CAPSULE and model.body_size[thigh, 2] == 2
    # capsule radius is the mean of the two short half-extents, total length the box's
    assert model.body_size[thigh, 0] == pytest.approx(0.05)
    assert model.body_size[thigh, 1] + model.body_size[thigh, 0] == pytest.approx(0.2)
    assert model.body_shape[model.body("chest")] == SHAPE_BOX
    assert model.body_contact_kind[model.body("foot_l")] == 2      # the paper's foot handler
    # joints sit at the creature's joint points on both sides
    state = PhysicsState(model)
    assert joint_separation(model, state).max() < 1e-12
    np.testing.assert_allclose(state.body_pos, c.body_rest_pos)
    # mass override scales the inertia with it
    heavy = model_from_creatures(c, options=CreatureBodyOptions(mass={"head": 5.0}))
    h = heavy.body("head")
    assert heavy.body_mass[h] == 5.0
    np.testing.assert_allclose(heavy.body_inertia[h] / model.body_inertia[h], 5.0 / model.body_mass[h])


# ---------------------------------------------------------------------------------------
# Hand-checkable scenes
# ---------------------------------------------------------------------------------------

def test_free_fall_is_symplectic_euler_exactly():
    model = build_model([_sphere(pos=np.array([0.0, 0.0, 100.0]))])
    state = PhysicsState(model)
    n = 2000
    step(model, state, DT, steps=n)
    # v_n = -g n h, z_n = z0 - g h^2 n (n + 1) / 2 (semi-implicit Euler)
    assert state.body_linvel[0, 2] == pytest.approx(-9.81 * n * DT, rel=1e-12)
    assert state.body_pos[0, 2] == pytest.approx(100.0 - 9.81 * DT * DT * n * (n + 1) / 2, rel=1e-12)
    print(f"\nfree fall 1 s: z error vs g t^2/2 = {abs(state.body_pos[0, 2] - (100 - 9.81 / 2)) * 1000:.3f} mm")


def test_pendulum_period_matches_the_analytic_one():
    length = 1.0
    model, top = hanging_rod(length)
    state = PhysicsState(model)
    swing(model, state, top, length, 0.05)
    n = 7000
    xs = np.empty(n)
    sep = 0.0
    for i in range(n):
        step(model, state, DT)
        xs[i] = state.body_pos[1, 0]
        if i % 50 == 0:
            sep = max(sep, joint_separation(model, state).max())
    t = (np.arange(n) + 1) * DT
    k = np.flatnonzero((xs[:-1] > 0) & (xs[1:] <= 0))
    crossings = t[k] + xs[k] / (xs[k] - xs[k + 1]) * DT
    period = float(np.mean(np.diff(crossings)))
    m, i_com = model.body_mass[1], model.body_inertia[1, 0]
    expected = 2 * math.pi * math.sqrt((i_com + m * (length / 2) ** 2) / (m * 9.81 * length / 2))
    print(f"\npendulum period {period:.5f} s, analytic {expected:.5f} s, rel {period / expected - 1:+.2e}, "
          f"joint separation max {sep * 1000:.4f} mm")
    assert period == pytest.approx(expected, rel=2e-3)
    assert sep < 1e-3


@pytest.mark.parametrize("scale", [0.01, 1.0, 10.0])
def test_pd_servo_frequency_is_mass_normalized(scale):
    """One gain setting (2 Hz, damping 0) swings a mouse-sized and a giant rod alike."""
    model, top = hanging_rod(scale, radius=0.05 * scale, settings=WorldSettings(gravity=(0.0, 0.0, 0.0)))
    state = PhysicsState(model)
    state.joint_pd_hz[0] = 2.0
    state.joint_pd_zeta[0] = 0.0
    state.joint_target_rot[0] = qy(0.1)
    n = 3000
    xs = np.empty(n)
    for i in range(n):
        step(model, state, DT)
        xs[i] = state.body_pos[1, 0]
    d = xs - 0.5 * (xs.max() + xs.min())
    k = np.flatnonzero((d[:-1] > 0) & (d[1:] <= 0))
    period = float(np.mean(np.diff(k))) * DT
    print(f"\nPD 2 Hz on a {scale} m rod (mass {model.body_mass[1]:.3g} kg): period {period:.4f} s")
    assert period == pytest.approx(0.5, rel=0.01)


def test_pd_servo_damping_settles_on_target():
    model, top = hanging_rod(1.0, settings=WorldSettings(gravity=(0.0, 0.0, 0.0)))
    state = PhysicsState(model)
    state.joint_pd_hz[0] = 3.0
    state.joint_pd_zeta[0] = 1.0
    state.joint_target_rot[0] = qy(0.4)
    step(model, state, DT, steps=4000)
    expect = top + rot(qy(0.4), np.array([0, 0, -0.5]))
    np.testing.assert_allclose(state.body_pos[1], expect, atol=1e-4)


def test_velocity_controller_is_exponential():
    """F = K_f m (v_t - v) without gravity: v_n = v_t (1 - (1 + h K_f)^-n) (implicit)."""
    model = build_model([_sphere(pos=np.array([0.0, 0.0, 5.0]))], settings=WorldSettings(gravity=(0, 0, 0)))
    state = PhysicsState(model)
    kf = 20.0
    state.body_track_gain[0] = kf
    state.body_track_vel[0] = [1.0, -2.0, 0.5]
    n = 300
    step(model, state, DT, steps=n)
    expect = np.array([1.0, -2.0, 0.5]) * (1 - (1 + DT * kf) ** -n)
    np.testing.assert_allclose(state.body_linvel[0], expect, rtol=1e-12)


def test_locked_joint_holds_its_rest_rotation():
    c = mini()
    opts = CreatureBodyOptions(locked=("thigh_l", "foot_l"))
    model = model_from_creatures(c, options=opts)
    state = PhysicsState(model)
    state.body_angvel[model.body("foot_l")] = [0.0, 8.0, 0.0]
    step(model, state, DT, steps=1500)
    q = state.body_rot
    worst = 0.0
    for j, name in enumerate(model.joint_names):
        if name in ("thigh_l", "foot_l"):
            a, b = model.joint_parent[j], model.joint_child[j]
            qa, qb = q[a], q[b]
            rel = np.array([qa[0], -qa[1], -qa[2], -qa[3]])
            w = (rel[0] * qb[0] - rel[1:] @ qb[1:])
            v = rel[0] * qb[1:] + qb[0] * rel[1:] + np.cross(rel[1:], qb[1:])
            r = model.joint_rest_rot[j]
            angle = 2 * math.acos(min(1.0, abs(w * r[0] + v @ r[1:])))
            worst = max(worst, angle)
    print(f"\nlocked joints: worst relative-rotation error {math.degrees(worst):.4f} deg")
    assert worst < math.radians(0.5)


def test_box_comes_to_rest_on_the_ground_with_dt_or_substeps():
    spec = [BodySpec("box", "box", np.array([0.0, 0.0, 1.0]), qy(0.3), half_extents=np.array([0.2, 0.1, 0.05]))]
    results = []
    for dt, sub, steps in ((DT, 1, 4000), (1 / 60, 32, 120), (1 / 60, 8, 120)):
        model = build_model(spec)
        state = PhysicsState(model)
        step(model, state, dt, substeps=sub, steps=steps)
        results.append(state.body_pos[0, 2])
        assert np.abs(state.body_linvel[0]).max() < 1e-3
        assert state.body_pos[0, 2] == pytest.approx(0.05, abs=1e-3)
    print(f"\nbox resting height (half-extent 0.05): {results}")


def test_slope_friction_and_terrain():
    slope = math.radians(20.0)
    terrain = Terrain.from_function(lambda x, y: -math.tan(slope) * x, -3.0, 3.0, -1.0, 1.0, cell=0.1)
    h, n = terrain.sample(0.35, 0.0)
    assert h == pytest.approx(-math.tan(slope) * 0.35)
    assert n[2] == pytest.approx(math.cos(slope))
    tilt = np.array([math.cos(slope / 2), 0.0, math.sin(slope / 2), 0.0])
    moved = {}
    for mu in (1.0, 0.1):
        settings = WorldSettings(ground=ContactSettings(hz=60.0, zeta=1.0, mu=mu))
        start = np.array([0.0, 0.0, 0.05 / math.cos(slope) + 0.001])
        model = build_model([BodySpec("box", "box", start, tilt, half_extents=np.array([0.2, 0.1, 0.05]))],
                            terrain=terrain, settings=settings)
        state = PhysicsState(model)
        step(model, state, DT, steps=2000)
        moved[mu] = float(state.body_pos[0, 0])
    print(f"\nbox on a 20 deg slope after 1 s: mu=1.0 moved {moved[1.0] * 1000:.2f} mm, "
          f"mu=0.1 moved {moved[0.1]:.3f} m")
    assert abs(moved[1.0]) < 0.005          # tan 20 deg = 0.36 < 1: sticks
    assert moved[0.1] > 1.0                  # slides: a = g (sin - 0.1 cos) = 2.4 m/s^2


def test_foot_spin_friction_stops_free_spinning():
    spun = {}
    for spin_mu in (0.0, 0.5):
        foot = ContactSettings(hz=60.0, zeta=1.0, mu=1.0, spin_mu=spin_mu)
        # a ball-like foot touches at one point: Coulomb friction there gives no torque
        # about the normal, only the rotational friction stops it spinning
        model = build_model([BodySpec("foot", "sphere", np.array([0.0, 0.0, 0.05]), ID, contact="foot",
                                      radius=0.05)], settings=WorldSettings(foot=foot))
        state = PhysicsState(model)
        step(model, state, DT, steps=100)
        state.body_angvel[0] = [0.0, 0.0, 6.0]
        step(model, state, DT, steps=1000)
        spun[spin_mu] = float(state.body_angvel[0, 2])
    print(f"\nball foot spinning at 6 rad/s, 0.5 s later: no spin friction {spun[0.0]:.3f} rad/s, "
          f"spin_mu 0.5 {spun[0.5]:.3f} rad/s")
    assert abs(spun[0.5]) < 1e-3
    assert spun[0.0] > 5.9


def _standing_leg(locked=False, spin=0.0):
    """A box foot on the ground, a shin and a thigh on it (ball joints, or locked), the
    thigh leaning over the toes."""
    foot = ContactSettings(hz=60.0, zeta=1.0, mu=0.5, spin_mu=spin)
    specs = [
        BodySpec("foot", "box", np.array([0.03, 0.0, 0.03]), ID, half_extents=np.array([0.1, 0.05, 0.03]),
                 contact="foot"),
        BodySpec("shin", "capsule", np.array([0.0, 0.0, 0.26]), ID, radius=0.04, half_length=0.16, axis=2,
                 parent=0, joint=np.array([0.0, 0.0, 0.06]), locked=locked, contact="none"),
        BodySpec("thigh", "capsule", np.array([0.05, 0.0, 0.66]), qy(0.2), radius=0.06, half_length=0.14,
                 axis=2, parent=1, joint=np.array([0.0, 0.0, 0.46]), locked=locked, contact="none"),
    ]
    return build_model(specs, settings=WorldSettings(foot=foot))


def test_contact_body_inverse_inertia_against_numpy():
    """Phi (the bodies' velocity for a unit impulse on a ground-contact body, every joint
    held) against the dense saddle-point system [[M, J^T], [J, 0]] in numpy."""
    from numba import njit

    from engine.physics import _kernels as K

    model = _standing_leg()
    state = PhysicsState(model)
    state.body_rot[2] = qy(0.5)                     # thigh turned off its rest: r_a, r_b both matter
    m, s = model.arrays, state.arrays
    njit(lambda m, s, h: K._prepare(m, s, h))(m, s, DT)   # kernels call _prepare; it has no Python wrapper
    assert s.cbody_n[0] == 1 and s.cbody[0] == 0
    n, nj = model.nbody, model.njoint
    M = np.zeros((6 * n, 6 * n))
    for b in range(n):
        M[6 * b:6 * b + 3, 6 * b:6 * b + 3] = model.body_mass[b] * np.eye(3)
        M[6 * b + 3:6 * b + 6, 6 * b + 3:6 * b + 6] = np.linalg.inv(s.body_iinv_world[b])

    def skew(r):
        return np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    J = np.zeros((3 * nj, 6 * n))
    for j in range(nj):
        a, b = model.joint_parent[j], model.joint_child[j]
        J[3 * j:3 * j + 3, 6 * a:6 * a + 3] = -np.eye(3)
        J[3 * j:3 * j + 3, 6 * a + 3:6 * a + 6] = skew(s.joint_ra[j])
        J[3 * j:3 * j + 3, 6 * b:6 * b + 3] = np.eye(3)
        J[3 * j:3 * j + 3, 6 * b + 3:6 * b + 6] = -skew(s.joint_rb[j])
    A = np.block([[M, J.T], [J, np.zeros((3 * nj, 3 * nj))]])
    inv = np.linalg.inv(A)[:6, :6]                  # the foot's rows and columns
    np.testing.assert_allclose(s.cbody_phi[0, 0], inv, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(s.cbody_phi[0, 0], s.cbody_phi[0, 0].T, atol=1e-12)
    # the leg answers a push at the foot: less velocity than the foot alone's 1/m
    assert s.cbody_phi[0, 0, 0, 0] < 0.9 / model.body_mass[0]


def test_planted_foot_holds_and_a_push_past_friction_slides():
    """A standing leg hit sideways on the thigh: a push the friction cone can hold leaves
    the planted foot where it is; one past it slides the foot."""
    slips = {}
    for v0 in (0.2, 2.0):
        model = _standing_leg()
        state = PhysicsState(model)
        step(model, state, DT, steps=200)
        state.body_linvel[2, 1] += v0
        slip = []
        for _ in range(20):
            step(model, state, DT, steps=10)
            slip.append(float(np.hypot(*state.body_linvel[0, :2])))
        assert np.all(np.isfinite(state.body_pos))
        slips[v0] = float(np.mean(slip))
    print(f"\nleg hit on the thigh: mean foot slip over 0.1 s after a 0.2 m/s push {slips[0.2]:.2e} m/s, "
          f"after 2 m/s {slips[2.0]:.2e} m/s")
    assert slips[0.2] < 1e-3                        # held (0.42 m/s was the humanoid's before)
    assert slips[2.0] > 10 * slips[0.2]             # slides


def test_a_foot_pushed_past_friction_decelerates_at_mu_g():
    """A box foot sent sliding: friction caps the contact impulse at mu times the normal
    one, so it stops after v^2 / (2 mu g)."""
    box = build_model([BodySpec("foot", "box", np.array([0.0, 0.0, 0.03]), ID,
                                half_extents=np.array([0.1, 0.05, 0.03]), contact="foot")],
                      settings=WorldSettings(foot=ContactSettings(hz=60.0, zeta=1.0, mu=0.5)))
    state = PhysicsState(box)
    step(box, state, DT, steps=200)
    state.body_linvel[0, 0] = 2.0
    step(box, state, DT, steps=2000)
    expect = 2.0 ** 2 / (2 * 0.5 * 9.81)
    print(f"\nbox foot at 2 m/s, mu 0.5: slid {state.body_pos[0, 0]:.4f} m (v^2 / 2 mu g = {expect:.4f})")
    assert abs(state.body_linvel[0, 0]) < 1e-3
    assert state.body_pos[0, 0] == pytest.approx(expect, rel=0.02)


def test_a_leaning_chain_on_a_planted_foot_topples_like_an_inverted_pendulum():
    """A foot on the ground, a passive ankle, a shin and a trunk held on it by a servo, leaning
    over the toes: the planted foot must hold, and nothing else. The ground contacts solved
    through the tree must not make the standing body stiffer than it is: the chain above the
    ankle tips as a rigid inverted pendulum, theta0 cosh(lambda t), lambda^2 = M g L / I."""
    lean = 0.02
    foot = ContactSettings(hz=60.0, zeta=1.0, mu=1.0, spin_mu=0.5)
    d = np.array([np.sin(lean), 0.0, np.cos(lean)])
    ank = np.array([0.0, 0.0, 0.06])
    knee, top = ank + 0.4 * d, ank + 1.0 * d
    specs = [
        BodySpec("foot", "box", np.array([0.03, 0.0, 0.03]), ID, half_extents=np.array([0.12, 0.05, 0.03]),
                 contact="foot"),
        BodySpec("shin", "capsule", (ank + knee) / 2, qy(lean), radius=0.05, half_length=0.15, axis=2, parent=0,
                 joint=ank, contact="none"),
        BodySpec("trunk", "capsule", (knee + top) / 2, qy(lean), radius=0.12, half_length=0.18, axis=2, parent=1,
                 joint=knee, contact="none", servo_hz=5.0),
    ]
    model = build_model(specs, settings=WorldSettings(foot=foot))
    state = PhysicsState(model)
    mass = model.body_mass[1:]
    inertia = model.arrays.body_inertia[1:]

    def pitch():
        com = (mass[:, None] * state.body_pos[1:]).sum(0) / mass.sum()
        r = com - ank
        return math.atan2(r[0], r[2]), math.hypot(r[0], r[2])
    th0, L = pitch()
    I = sum(inertia[i, 1] + mass[i] * ((state.body_pos[1 + i, 0] - ank[0]) ** 2
                                     + (state.body_pos[1 + i, 2] - ank[2]) ** 2)
            for i in range(2))                      # about y through the ankle (capsules along their z)
    lam = math.sqrt(mass.sum() * 9.81 * L / I)
    dt, t = 1 / 240, 0.0
    while pitch()[0] < 0.2 and t < 3.0:
        step(model, state, dt)
        t += dt
    expect = math.acosh(0.2 / th0) / lam
    slid = float(np.hypot(*(state.body_pos[0, :2] - [0.03, 0.0])))
    print(f"\nleaning chain: tipped to 0.2 rad in {t:.3f} s (rigid inverted pendulum {expect:.3f} s), "
          f"foot slid {slid * 1e3:.2f} mm")
    assert t == pytest.approx(expect, rel=0.1)
    assert slid < 2e-3


# ---------------------------------------------------------------------------------------
# Robustness, with figures
# ---------------------------------------------------------------------------------------

def chain(nlink=5, length=0.3, radius=0.03, masses=None):
    top = np.array([0.0, 0.0, 3.0])
    specs = [BodySpec("anchor", "sphere", top, ID, radius=radius, fixed=True, contact="none")]
    q = qy(math.pi / 2)          # links lying along +x: released horizontally
    for k in range(nlink):
        centre = top + [(k + 0.5) * length, 0.0, 0.0]
        specs.append(BodySpec(f"link{k}", "capsule", centre, q, radius=radius, half_length=length / 2 - radius,
                              axis=2, parent=k, joint=top + [k * length, 0.0, 0.0], contact="none",
                              mass=None if masses is None else masses[k]))
    return build_model(specs)


@pytest.mark.parametrize("masses,substeps", [
    ([10.0, 3.0, 1.0, 0.3, 0.1, 0.1], 1),     # torso to fingertip: 100:1 along the chain
    ([0.1, 0.3, 1.0, 3.0, 10.0, 10.0], 2),    # a heavy weight on a light rope: needs h = 0.00025
])
def test_passive_chain_energy_does_not_grow_and_joints_hold(masses, substeps):
    model = chain(6, masses=masses)
    state = PhysicsState(model)
    e0 = energy(model, state)["total"]
    worst_sep, worst_growth = 0.0, -np.inf
    for _ in range(40):
        step(model, state, DT, steps=100, substeps=substeps)
        worst_sep = max(worst_sep, joint_separation(model, state).max())
        worst_growth = max(worst_growth, energy(model, state)["total"] - e0)
    scale = float(np.sum(model.body_mass[1:]) * 9.81 * 1.8)   # the chain's potential-energy swing
    print(f"\npassive 6-link chain {masses}, {substeps} substep(s), 2 s: max energy growth "
          f"{worst_growth / scale:+.2e} of its energy swing, final change "
          f"{(energy(model, state)['total'] - e0) / scale:+.2e}, max joint separation {worst_sep * 1000:.3f} mm")
    assert worst_growth <= 1e-3 * scale
    assert worst_sep < 1e-3


def test_ragdoll_drop_heavy_kick_no_explosion_no_tunnelling():
    c = mini()
    model = model_from_creatures(c)
    state = PhysicsState(model)
    # drop from 0.5 m above its rest pose
    state.body_pos[:, 2] += 0.5
    head = model.body("head")
    lowest, worst_sep = np.inf, 0.0
    for k in range(3000):
        if k == 1200:
            # a heavy kick: 50 N s on the head (|(0, 40, -30)| = 50; 0.83 kN for 60 ms), sideways and down
            state.body_linvel[head] += np.array([0.0, 40.0, -30.0]) / model.body_mass[head]
        step(model, state, DT)
        if k % 10 == 0:
            worst_sep = max(worst_sep, joint_separation(model, state).max())
            lowest = min(lowest, float(np.min(state.body_pos[:, 2])))
    assert np.all(np.isfinite(state.body_pos))
    speed = float(np.abs(state.body_linvel).max())
    print(f"\nmini ragdoll drop + 50 N s kick: lowest body centre {lowest * 1000:.1f} mm, max joint separation "
          f"{worst_sep * 1000:.3f} mm, max speed at the end {speed:.3f} m/s")
    assert worst_sep < 1e-3
    assert lowest > 0.0            # every body centre stayed above the ground
    assert speed < 2.0


def test_fast_projectile_does_not_tunnel_through_another_character():
    target = BodySpec("torso", "capsule", np.array([0.0, 0.0, 1.0]), ID, radius=0.03, half_length=0.5, axis=2,
                      character=0, contact="none")
    bullet = BodySpec("fist", "sphere", np.array([-1.0, 0.0, 1.0]), ID, radius=0.02, character=1,
                      contact="none", mass=2.0)
    model = build_model([target, bullet], settings=WorldSettings(gravity=(0, 0, 0)))
    state = PhysicsState(model)
    state.body_linvel[1] = [60.0, 0.0, 0.0]       # 60 m/s, 3 cm per step: wider than the target
    furthest = -np.inf
    for _ in range(200):
        step(model, state, DT)
        furthest = max(furthest, state.body_pos[1, 0] - state.body_pos[0, 0])
    print(f"\n60 m/s fist vs a 6 cm torso: deepest overlap {(furthest + 0.05) * 1000:.2f} mm, "
          f"torso speed after {state.body_linvel[0, 0]:.2f} m/s")
    assert furthest < -0.045                       # the surfaces never passed each other
    assert state.body_linvel[0, 0] > 1.0           # the hit moved the torso


def test_two_creatures_collide():
    c = mini()
    model = model_from_creatures([c, c], offsets=[np.zeros(3), np.array([0.0, 0.5, 0.0])])
    assert model.pair_a.shape[0] == 7 * 7
    assert model.body_names[7] == "1:" + c.body_names[0]
    state = PhysicsState(model)
    state.body_linvel[7:] = [0.0, -3.0, 0.0]       # the second walks into the first
    step(model, state, DT, steps=600)
    first = state.body_pos[:7, 1].mean()
    second = state.body_pos[7:, 1].mean()
    assert second - first > 0.2                    # still apart
    assert state.body_linvel[:7, 1].mean() < -0.1  # momentum passed on


def test_state_from_kinematic_finite_difference():
    model = model_from_creatures(mini())
    pos = np.array(model.body_rest_pos)
    rot = np.array(model.body_rest_rot)
    prev = pos - [0.01, 0.0, 0.0]
    prev_rot = rot.copy()
    prev_rot[0] = np.array([math.cos(-0.005), 0.0, 0.0, math.sin(-0.005)])
    state = state_from_kinematic(model, pos, rot, prev, prev_rot, dt=0.01)
    np.testing.assert_allclose(state.body_linvel, np.tile([1.0, 0.0, 0.0], (7, 1)))
    np.testing.assert_allclose(state.body_angvel[0], [0.0, 0.0, 1.0], rtol=1e-9)


# ---------------------------------------------------------------------------------------
# Determinism
# ---------------------------------------------------------------------------------------

def _canned_scene():
    c = mini()
    model = model_from_creatures([c, c], offsets=[np.zeros(3), np.array([0.3, 0.35, 0.4])],
                                 options=CreatureBodyOptions(locked=("foot_r",)))
    state = PhysicsState(model)
    state.joint_pd_hz[:] = 3.0
    state.body_angvel[3] = [1.0, 2.0, 3.0]
    state.body_linvel[7:] = [0.0, -1.0, 0.0]
    step(model, state, DT, steps=400)
    return state


def test_determinism_bit_for_bit():
    a = _canned_scene()
    b = _canned_scene()
    assert a.digest() == b.digest()
    # stepping a copy gives the same bits as stepping the original
    c = a.copy()
    step(a.model, a, DT, steps=10)
    step(c.model, c, DT, steps=10)
    assert a.digest() == c.digest()


# ---------------------------------------------------------------------------------------
# Any creature: the library, random creatures, any size
# ---------------------------------------------------------------------------------------

LIBRARY = sorted(glob.glob(os.path.join(os.path.dirname(os.path.dirname(__file__)), "creatures", "*.yaml")))


def _lowest_points(model, state) -> np.ndarray:
    """(nbody,) height of each body's lowest surface point (sphere, capsule or box)."""
    z = state.body_pos[:, 2].copy()
    for b in range(model.nbody):
        r = model.body_size[b]
        shape = int(model.body_shape[b])
        q = state.body_rot[b]
        if shape == SHAPE_SPHERE:
            z[b] -= r[0]
        elif shape == SHAPE_CAPSULE:
            axis = np.zeros(3)
            axis[int(r[2])] = 1.0                # body_size: (radius, half length, axis)
            z[b] -= r[0] + abs(quat_rotate(q, axis)[2]) * r[1]
        else:
            corners = [quat_rotate(q, np.array([sx, sy, sz]) * r)[2]
                       for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]
            z[b] += min(corners)
    return z


def _drop_check(creature, start_dz=0.0):
    """Drop ``creature`` from 20% of its height (plus ``start_dz`` m), long enough to land:
    the free fall from its lowest surface point (sqrt(2 h / g)) and 0.25 s on the ground.
    Returns the worst joint separation, the mass ratio, how close it came to the ground (the
    lowest surface point of any body at its lowest; <= 0 touched), the deepest any body's
    surface went into the ground at the impact, and how deep it is at the end (settled);
    lengths over the creature's height."""
    model = model_from_creatures(creature)
    state = PhysicsState(model)
    state.body_pos[:, 2] += 0.2 * creature.height + start_dz
    fall = math.sqrt(2.0 * max(float(_lowest_points(model, state).min()), 0.0) / 9.81)
    worst, closest, deepest = 0.0, np.inf, 0.0
    for _ in range(int(math.ceil((fall + 0.25) / (10 * DT)))):
        step(model, state, DT, steps=10)
        worst = max(worst, float(joint_separation(model, state).max()))
        low = float(_lowest_points(model, state).min())
        closest = min(closest, low)
        deepest = max(deepest, -low)
    settled = max(-float(_lowest_points(model, state).min()), 0.0)
    ratio = model.body_mass.max() / model.body_mass.min()
    h = creature.height
    return worst, ratio, closest / h, deepest / h, settled / h


#: Landed: a body's surface deeper in the ground than this share of the creature's height
#: is a body visibly in it (the grid's below_ground failure, engine/validation/thresholds.py).
SETTLED_DEPTH = BY_METRIC["below_ground"].fail
#: At the impact the soft contacts let a body sink for a frame or two (measured up to 3.8%
#: of the height: the hexapod's 4 mm, the centaur's 5.7 cm); a sink of 5% of the height is
#: the most a viewer lets pass in a landing, and half a body's thickness (the old bound on
#: its centre) is a half-buried body.
IMPACT_DEPTH = 0.05
#: Touched the ground: its lowest surface point came within 1 mm of it.
TOUCH = 1e-3


def _assert_lands(c, sep, closest, deepest, settled):
    assert closest * c.height <= TOUCH, (c.name, "never touched the ground", closest)
    assert sep < 1e-3, (c.name, sep)
    assert deepest <= IMPACT_DEPTH, (c.name, "sank at the impact by", deepest, "of its height")
    assert settled <= SETTLED_DEPTH, (c.name, "rests in the ground by", settled, "of its height")


@pytest.mark.skipif(not LIBRARY, reason="creature library not present")
def test_every_library_creature_falls_as_a_ragdoll():
    rows = []
    for path in LIBRARY:
        c = engine.load_creature(path)
        sep, ratio, closest, deepest, settled = _drop_check(c)
        rows.append((c.name, c.nbody, ratio, sep, deepest, settled))
        _assert_lands(c, sep, closest, deepest, settled)
    worst = max(rows, key=lambda r: r[3])
    print(f"\n{len(rows)} library creatures dropped and landed: worst joint separation {worst[3] * 1000:.4f} mm "
          f"({worst[0]}), deepest at impact {max(r[4] for r in rows):.4f} and settled {max(r[5] for r in rows):.4f} "
          f"of the height, largest mass ratio {max(r[2] for r in rows):.0f}:1")


def test_a_half_buried_start_fails_the_depth_check():
    """The depth check is able to fail: a humanoid started with its feet a third of its
    height in the ground (a body half in it) is caught."""
    c = engine.load_creature(LIBRARY[[os.path.basename(p) for p in LIBRARY].index("humanoid.yaml")])
    sep, _, closest, deepest, settled = _drop_check(c, start_dz=-0.53 * c.height)
    with pytest.raises(AssertionError, match="sank|in the ground"):
        _assert_lands(c, sep, closest, deepest, settled)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(min_value=0, max_value=10_000))
def test_random_creatures_fall_as_ragdolls(seed):
    from engine.model import build_creature
    from engine.model.random import random_creature_def

    c = build_creature(random_creature_def(seed))
    sep, _, closest, deepest, settled = _drop_check(c)
    _assert_lands(c, sep, closest, deepest, settled)


def _scaled_humanoid(k):
    from engine.model import BodyDef, CreatureDef, build_creature

    c = engine.load_creature(LIBRARY[[os.path.basename(p) for p in LIBRARY].index("humanoid.yaml")])
    d = c.to_def()
    bodies = [BodyDef(name=b.name, parent=b.parent, caps=b.caps, pos=tuple(k * v for v in b.pos), rot=b.rot,
                      joint=None if b.joint is None else tuple(k * v for v in b.joint),
                      extents=tuple(k * v for v in b.extents)) for b in d.bodies]
    return build_creature(CreatureDef(name=f"humanoid_x{k}", bodies=bodies))


@pytest.mark.skipif("humanoid.yaml" not in [os.path.basename(p) for p in LIBRARY], reason="no humanoid")
def test_one_servo_setting_from_mouse_to_giant():
    """The same servo gains (6 Hz, damping 0.7) hold a 9 cm and a 9 m humanoid alike: the
    joint-angle error after a kick of 2 rad/s is the same curve at every size (pelvis
    pinned, in the air, no gravity: gravity itself is not scale-free)."""
    curves = {}
    for k in (0.05, 1.0, 5.0):
        c = _scaled_humanoid(k)
        model = model_from_creatures(c, options=CreatureBodyOptions(servo_hz=6.0, servo_zeta=0.7,
                                                                    fixed=(c.body_names[0],)),
                                     settings=WorldSettings(gravity=(0.0, 0.0, 0.0)), terrain=Terrain.flat(-1e6))
        state = PhysicsState(model)
        state.joint_target_rot[:] = servo_targets_from_pose(model, model.body_rest_rot)
        state.body_angvel[1:] = [0.0, 2.0, 0.0]
        errors = []
        for _ in range(10):
            step(model, state, DT, steps=100)
            rel = servo_targets_from_pose(model, state.body_rot)
            dots = np.abs(np.sum(rel * model.joint_rest_rot, axis=1))
            errors.append(2 * np.degrees(np.arccos(np.clip(dots, -1, 1))).max())
        curves[k] = np.array(errors)
    print("\nservo 6 Hz, worst joint angle error (deg) every 0.05 s: "
          + "; ".join(f"x{k}: " + " ".join(f"{e:.2f}" for e in v[::3]) for k, v in curves.items()))
    np.testing.assert_allclose(curves[0.05], curves[1.0], rtol=1e-3, atol=1e-3)
    np.testing.assert_allclose(curves[5.0], curves[1.0], rtol=1e-3, atol=1e-3)
    assert curves[1.0][-1] < 0.2 * curves[1.0].max()        # and it settles back


def test_gauss_seidel_option_and_the_direct_solve():
    seps = {}
    for solver in ("gauss-seidel", "direct"):
        top = np.array([0.0, 0.0, 3.0])
        q = qy(math.pi / 2)
        specs = [BodySpec("anchor", "sphere", top, ID, radius=0.03, fixed=True, contact="none")]
        for k, mass in enumerate([0.1, 0.3, 1.0, 3.0, 10.0, 10.0]):
            specs.append(BodySpec(f"l{k}", "capsule", top + [(k + 0.5) * 0.3, 0, 0], q, radius=0.03,
                                  half_length=0.12, axis=2, parent=k, joint=top + [k * 0.3, 0, 0], contact="none",
                                  mass=mass))
        model = build_model(specs, settings=WorldSettings(solver=solver))
        state = PhysicsState(model)
        worst = 0.0
        for _ in range(20):
            step(model, state, DT, steps=100)
            worst = max(worst, float(joint_separation(model, state).max()))
        seps[solver] = worst
    print(f"\nheavy weight on a light rope, dt 0.0005: joint separation Gauss-Seidel {seps['gauss-seidel'] * 1000:.3f} "
          f"mm, direct tree solve {seps['direct'] * 1000:.4f} mm")
    assert seps["direct"] < 1e-4 < seps["gauss-seidel"]
    with pytest.raises(PhysicsError, match="solver must be"):
        build_model([_sphere()], settings=WorldSettings(solver="magic"))


@pytest.mark.parametrize("d,sign", [(3, -1.0), (6, 1.0), (6, -1.0)])
def test_tree_block_inverse_against_numpy(d, sign):
    """The direct solve's LDL^T block inverse against numpy, on definite blocks of the
    sign the tree produces (bodies positive, joints negative)."""
    from engine.physics._kernels import _invert_sym_into

    rng = np.random.default_rng(d)
    for _ in range(20):
        B = rng.normal(size=(d, d))
        A = np.zeros((6, 6))
        A[:d, :d] = sign * (B @ B.T + 0.1 * np.eye(d))
        out = np.zeros((6, 6))
        _invert_sym_into(A, d, out, np.zeros((6, 12)))
        np.testing.assert_allclose(out[:d, :d], np.linalg.inv(A[:d, :d]), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("servos", [False, True])
def test_tree_schur_update_against_the_dense_edge_blocks(servos):
    """The factorization's L = D^-1 H and D_parent -= H^T L, written out for H's
    non-zeros, against dense H (the constraint Jacobian blocks) on the humanoid's tree in
    a turned pose: ball joints, and joints with direct servos (6-row nodes)."""
    from numba import njit

    from engine.physics import _kernels as K

    c = engine.load_creature(LIBRARY[[os.path.basename(p) for p in LIBRARY].index("humanoid.yaml")])
    model = model_from_creatures([c])
    state = PhysicsState(model)
    rng = np.random.default_rng(4)
    for b in range(model.nbody):
        q = rng.normal(size=4)
        state.body_rot[b] = q / np.linalg.norm(q)
    if servos:
        state.joint_pd_hz[:] = 5.0
        state.joint_pd_max_torque[:] = 0.0
    m, s = model.arrays, state.arrays
    njit(lambda m, s, h: K._prepare(m, s, h))(m, s, DT)
    nb = model.nbody

    def skew(r):
        return np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])

    run = njit(lambda m, s, i, d, p, dp, Di, L, Dp: K._schur_up(m, s, i, d, p, dp, Di, L, Dp))
    checked = 0
    for i in range(len(m.node_parent)):
        p = int(m.node_parent[i])
        if p < 0:
            continue
        d, dp = int(s.node_dim[i]), int(s.node_dim[p])
        H = np.zeros((6, 6))
        if i < nb:
            j = int(m.body_joint[i])
            H[:3, :3] = np.eye(3)
            H[3:, :3] = skew(s.joint_rb[j])
            if dp == 6:
                H[3:, 3:] = np.eye(3)
        else:
            j = i - nb
            H[:3, :3] = -np.eye(3)
            H[:3, 3:] = skew(s.joint_ra[j])
            if d == 6:
                H[3:, 3:] = -np.eye(3)
        Di = rng.normal(size=(6, 6))
        Dp = rng.normal(size=(6, 6))
        L = np.zeros((6, 6))
        want_L = Di[:d, :d] @ H[:d, :dp]
        want_Dp = Dp.copy()
        want_Dp[:dp, :dp] -= H[:d, :dp].T @ want_L
        run(m, s, i, d, p, dp, Di, L, Dp)
        np.testing.assert_allclose(L[:d, :dp], want_L, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(Dp, want_Dp, rtol=1e-12, atol=1e-12)
        checked += d == 6 and dp == 6
    assert (checked > 0) == servos   # servo joints make 6-row nodes below 6-row bodies
