"""engine.mathx: quaternions, frames and Hermite splines against plain-numpy references.

Opens with the list of degenerate and invalid inputs, each with what it must give (an
identity, an unchanged vector, an error; never NaN), then every kernel against the slow
references in ``tests/naive_mathx.py`` on seeded random inputs, then the ``_into`` twins
(bit-identical to the returning versions, alias-safe, allocation-free inside kernels),
then hand-checkable cases (opposite vectors, antipodal quaternions, straight lines and
circle arcs, a quintic recovered from its own samples), then hypothesis properties.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from numba import njit
from numba.core.runtime import _nrt_python, rtsys

import engine.mathx as mx

try:
    import naive_mathx as naive  # tests/ on sys.path (pytest's default rootdir mode)
except ImportError:  # tests/ imported as a package
    from tests import naive_mathx as naive

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
ZERO3 = np.zeros(3)
ZERO4 = np.zeros(4)
NAN4 = np.full(4, np.nan)
INF4 = np.array([np.inf, 0.0, 0.0, 0.0])
EX, EY, EZ = np.eye(3)

RNG_SEED = 20080811  # SIGGRAPH 2008


def unit_quats(rng, n):
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def same_rotation(a, b, atol=1e-12):
    """q and -q are the same rotation."""
    return np.allclose(a, b, atol=atol) or np.allclose(a, -np.asarray(b), atol=atol)


# ---------------------------------------------------------------------------------------
# Degenerate and invalid inputs: each with the answer it must give
# ---------------------------------------------------------------------------------------

DEGENERATE = [
    ("normalize zero", lambda: mx.quat_normalize(ZERO4), IDENTITY),
    ("normalize NaN", lambda: mx.quat_normalize(NAN4), IDENTITY),
    ("normalize inf", lambda: mx.quat_normalize(INF4), IDENTITY),
    ("normalize underflowing", lambda: mx.quat_normalize(np.full(4, 1e-170)), IDENTITY),
    ("inverse of zero", lambda: mx.quat_inv(ZERO4), IDENTITY),
    ("rotate by zero quaternion", lambda: mx.quat_rotate(ZERO4, np.array([1.0, 2, 3])),
     np.array([1.0, 2, 3])),
    ("rotate_inv by zero quaternion",
     lambda: mx.quat_rotate_inv(ZERO4, np.array([1.0, 2, 3])), np.array([1.0, 2, 3])),
    ("matrix of zero quaternion", lambda: mx.quat_to_matrix(ZERO4), np.eye(3)),
    ("axis-angle zero axis", lambda: mx.quat_from_axis_angle(ZERO3, 1.0), IDENTITY),
    ("axis-angle NaN axis", lambda: mx.quat_from_axis_angle(np.full(3, np.nan), 1.0),
     IDENTITY),
    ("rotvec of zero", lambda: mx.quat_from_rotvec(ZERO3), IDENTITY),
    ("log of zero quaternion", lambda: mx.quat_to_rotvec(ZERO4), ZERO3),
    ("log of identity", lambda: mx.quat_to_rotvec(IDENTITY), ZERO3),
    ("between zero and x", lambda: mx.quat_between(ZERO3, EX), IDENTITY),
    ("between x and zero", lambda: mx.quat_between(EX, ZERO3), IDENTITY),
    ("between NaN and x", lambda: mx.quat_between(np.full(3, np.nan), EX), IDENTITY),
    ("between parallel", lambda: mx.quat_between(EX, 3 * EX), IDENTITY),
    ("blend all-zero weights", lambda: mx.quat_blend(unit_quats(np.random.default_rng(1), 3),
                                                     np.zeros(3)), IDENTITY),
    ("blend no quaternions", lambda: mx.quat_blend(np.zeros((0, 4)), np.zeros(0)), IDENTITY),
    ("blend cancelling weights",
     lambda: mx.quat_blend(np.array([IDENTITY, IDENTITY]), np.array([1.0, -1.0])), IDENTITY),
    ("swing-twist about zero axis",
     lambda: mx.quat_swing_twist(np.array([0.0, 0.0, 1.0, 0.0]), ZERO3)[1], IDENTITY),
    ("swing-twist, half turn perpendicular to the axis",
     lambda: mx.quat_swing_twist(np.array([0.0, 1.0, 0.0, 0.0]), EZ)[1], IDENTITY),
    ("transport of a single point",
     lambda: mx.frame_transport(np.zeros((1, 3)), EX, np.array([0.0, 0, 1, 0]))[0],
     np.array([0.0, 0, 1, 0])),
    ("transport of no points", lambda: mx.frame_transport(np.zeros((0, 3)), EX, IDENTITY),
     np.zeros((0, 4))),
    ("minimal twist with zero new direction",
     lambda: mx.minimal_twist_rotate(np.array([0.0, 0, 1, 0]), EX, ZERO3),
     np.array([0.0, 0, 1, 0])),
    ("fit with no samples is the straight segment",
     lambda: np.array(mx.fit_hermite5(np.zeros((0, 3)), np.zeros(0), ZERO3, EX)),
     np.array([EX, ZERO3, EX, ZERO3])),
    ("tangents of a single key", lambda: mx.auto_tangents(np.zeros(1), np.ones((1, 2))),
     np.zeros((1, 2))),
    ("matrix with NaN", lambda: mx.quat_from_matrix(np.full((3, 3), np.nan)), IDENTITY),
    ("zero matrix", lambda: mx.quat_from_matrix(np.zeros((3, 3))), IDENTITY),
    ("rotvec with NaN", lambda: mx.quat_from_rotvec(np.full(3, np.nan)), IDENTITY),
    ("rotvec overflowing", lambda: mx.quat_from_rotvec(np.full(3, 1e200)), IDENTITY),
    ("axis-angle NaN angle", lambda: mx.quat_from_axis_angle(EX, np.nan), IDENTITY),
    ("axis-angle of NaN quaternion",
     lambda: np.concatenate([*mx.quat_to_axis_angle(NAN4)[:1], [mx.quat_to_axis_angle(NAN4)[1]]]),
     np.array([1.0, 0.0, 0.0, 0.0])),
    ("slerp of zero quaternions", lambda: mx.quat_slerp(ZERO4, ZERO4, 0.5), IDENTITY),
    ("spline transport, zero spline keeps the frame",
     lambda: mx.spline_frame_transport(ZERO3, ZERO3, ZERO3, ZERO3, ZERO3, ZERO3,
                                       np.array([0.5, 1.0]), np.array([0.0, 1, 0, 0]), 3)[1],
     np.array([[0.0, 1, 0, 0], [0.0, 1, 0, 0]])),
    ("keyed curve with a single key",
     lambda: mx.hermite3_keys(np.zeros(1), np.array([[2.0, 3.0]]), np.zeros((1, 2)), 5.0),
     np.array([2.0, 3.0])),
]


@pytest.mark.parametrize("name,call,expected", DEGENERATE, ids=[d[0] for d in DEGENERATE])
def test_degenerate_inputs(name, call, expected):
    result = np.asarray(call())
    assert np.all(np.isfinite(result)), name
    np.testing.assert_allclose(result, expected, atol=1e-15, err_msg=name)


INVALID_FITS = [
    ("NaN sample", np.full((4, 3), np.nan), np.linspace(0.2, 0.8, 4), ZERO3, EX,
     "non-finite sample point"),
    ("infinite parameter", np.zeros((2, 3)), np.array([0.5, np.inf]), ZERO3, EX,
     "non-finite spline parameter"),
    ("NaN end point", np.zeros((2, 3)), np.array([0.2, 0.5]), np.full(3, np.nan), EX,
     "non-finite end point"),
    ("params shorter than points", np.zeros((3, 3)), np.array([0.2, 0.5]), ZERO3, EX,
     "disagree in shape"),
    ("end point of another dimension", np.zeros((2, 3)), np.array([0.2, 0.5]), np.zeros(2),
     EX, "disagree in shape"),
]


@pytest.mark.parametrize("name,points,params,p0,p1,message", INVALID_FITS,
                         ids=[f[0] for f in INVALID_FITS])
def test_fit_hermite5_rejects(name, points, params, p0, p1, message):
    with pytest.raises(ValueError, match=message):
        mx.fit_hermite5(points, params, p0, p1)


@pytest.mark.parametrize("times", [np.array([0.0, 0.0, 1.0]), np.array([0.0, 2.0, 1.0]),
                                   np.array([0.0, np.nan, 1.0])])
def test_auto_tangents_rejects_non_increasing_times(times):
    with pytest.raises(ValueError, match="strictly increase"):
        mx.auto_tangents(times, np.zeros((3, 2)))


# ---------------------------------------------------------------------------------------
# Kernels against plain-numpy references (seeded random inputs)
# ---------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rng():
    return np.random.default_rng(RNG_SEED)


def test_mul_conj_inv_dot(rng):
    qa, qb = unit_quats(rng, 50), 2.0 * unit_quats(rng, 50)
    for a, b in zip(qa, qb, strict=True):
        np.testing.assert_allclose(mx.quat_mul(a, b), naive.quat_mul(a, b), atol=1e-14)
        np.testing.assert_array_equal(mx.quat_conj(b), naive.quat_conj(b))
        np.testing.assert_allclose(mx.quat_mul(b, mx.quat_inv(b)), IDENTITY, atol=1e-14)
        assert mx.quat_dot(a, b) == pytest.approx(float(np.dot(a, b)), abs=1e-15)
    # Composition order: a * b applies b first.
    v = rng.normal(size=3)
    a, b = qa[0], qa[1]
    np.testing.assert_allclose(mx.quat_rotate(mx.quat_mul(a, b), v),
                               naive.quat_rotate(a, naive.quat_rotate(b, v)), atol=1e-13)


def test_rotate_and_matrix(rng):
    for q in unit_quats(rng, 50):
        v = rng.normal(size=3)
        ref = naive.quat_to_matrix(q)
        np.testing.assert_allclose(mx.quat_rotate(q, v), ref @ v, atol=1e-12)
        np.testing.assert_allclose(mx.quat_rotate_inv(q, v), ref.T @ v, atol=1e-12)
        np.testing.assert_allclose(mx.quat_to_matrix(q), ref, atol=1e-12)
        # A non-unit quaternion rotates like its normalized self.
        np.testing.assert_allclose(mx.quat_rotate(3.5 * q, v), ref @ v, atol=1e-12)
        np.testing.assert_allclose(mx.quat_to_matrix(0.2 * q), ref, atol=1e-12)
        pose = mx.mat4_from_pose(v, q)
        np.testing.assert_allclose(pose[:3, :3], ref, atol=1e-12)
        np.testing.assert_array_equal(pose[:3, 3], v)
        np.testing.assert_array_equal(pose[3], [0.0, 0.0, 0.0, 1.0])


def test_from_matrix_shepperd_every_branch(rng):
    # Rotations near the identity (trace branch) and near half turns about x, y and z
    # (each diagonal branch).
    cases = list(unit_quats(rng, 40))
    for axis in np.eye(3):
        for _ in range(5):
            wobble = 0.05 * rng.normal(size=3)
            cases.append(naive.quat_from_axis_angle(axis + wobble, math.pi - 0.01))
    for q in cases:
        m = naive.quat_to_matrix(q)
        got = mx.quat_from_matrix(m)
        assert got[0] >= 0.0
        np.testing.assert_allclose(got, naive.quat_from_matrix(m), atol=1e-12)
        assert same_rotation(got, q)
    # Exact half turns: w = 0 and the sign rule still gives a valid unit quaternion.
    for axis in np.eye(3):
        m = naive.rodrigues(axis, math.pi)
        got = mx.quat_from_matrix(m)
        assert same_rotation(got, np.concatenate([[0.0], axis]))
    # A slightly non-orthogonal matrix gives a nearby unit quaternion.
    m = naive.quat_to_matrix(cases[0]) + 1e-6 * rng.normal(size=(3, 3))
    got = mx.quat_from_matrix(m)
    assert np.linalg.norm(got) == pytest.approx(1.0, abs=1e-15)
    assert same_rotation(got, cases[0], atol=1e-5)


def test_axis_angle_and_rotvec(rng):
    for q in unit_quats(rng, 50):
        axis, angle = mx.quat_to_axis_angle(q)
        assert 0.0 <= angle <= math.pi
        assert np.linalg.norm(axis) == pytest.approx(1.0, abs=1e-14)
        assert same_rotation(mx.quat_from_axis_angle(axis, angle), q)
        np.testing.assert_allclose(mx.quat_to_rotvec(q), naive.quat_rotvec(q), atol=1e-10)
        np.testing.assert_allclose(mx.quat_to_rotvec(-q), mx.quat_to_rotvec(q), atol=1e-15)
        r = rng.normal(size=3)
        ref = naive.quat_from_axis_angle(r, np.linalg.norm(r))
        np.testing.assert_allclose(mx.quat_from_rotvec(r), ref, atol=1e-14)
        # Axis length does not matter.
        np.testing.assert_allclose(mx.quat_from_axis_angle(5 * r, 0.7),
                                   naive.quat_from_axis_angle(r, 0.7), atol=1e-15)


def test_rotvec_stable_near_zero():
    # The series branch and the closed form meet without a seam, and tiny rotations are
    # exact to rounding in both directions (arccos-based code loses half the digits).
    for theta in [1e-15, 1e-9, 1e-6, 9.99e-4, 1e-3, 1.001e-3, 0.1]:
        r = theta * np.array([0.6, 0.0, 0.8])
        q = mx.quat_from_rotvec(r)
        exact = np.concatenate([[math.cos(theta / 2)], math.sin(theta / 2) / theta * r])
        np.testing.assert_allclose(q, exact, rtol=1e-15, atol=0)
        np.testing.assert_allclose(mx.quat_to_rotvec(q), r, rtol=1e-13, atol=0)


def test_slerp_nlerp(rng):
    qa, qb = unit_quats(rng, 30), unit_quats(rng, 30)
    for a, b in zip(qa, qb, strict=True):
        for t in [0.0, 0.25, 0.5, 0.9, 1.0, -0.3, 1.4]:
            got = mx.quat_slerp(a, b, t)
            assert same_rotation(got, naive.quat_slerp(a, b, t), atol=1e-12)
            # Angles grow linearly in t along the shorter arc.
            total = naive.rotation_angle(a, b)
            if 0.0 <= t <= 1.0:
                # (the reference angle comes from arccos: good to ~1e-8)
                assert naive.rotation_angle(a, got) == pytest.approx(t * total, abs=1e-7)
        lerp = mx.quat_nlerp(a, b, 0.3)
        bb = b if np.dot(a, b) >= 0 else -b
        ref = 0.7 * a + 0.3 * bb
        np.testing.assert_allclose(lerp, ref / np.linalg.norm(ref), atol=1e-15)


def test_slerp_endpoints_and_antipodes(rng):
    for a, b in zip(unit_quats(rng, 20), unit_quats(rng, 20), strict=True):
        np.testing.assert_allclose(mx.quat_slerp(a, b, 0.0), a, atol=1e-15)
        assert same_rotation(mx.quat_slerp(a, b, 1.0), b, atol=1e-15)
        # q and -q are the same rotation: slerp toward -b is slerp toward b.
        np.testing.assert_allclose(mx.quat_slerp(a, -b, 0.4), mx.quat_slerp(a, b, 0.4),
                                   atol=1e-15)
        np.testing.assert_allclose(mx.quat_nlerp(a, -b, 0.4), mx.quat_nlerp(a, b, 0.4),
                                   atol=1e-15)
        # Between a and -a there is nothing to interpolate.
        assert same_rotation(mx.quat_slerp(a, -a, 0.5), a, atol=1e-15)
        # Nearly equal inputs take the nlerp fallback and still interpolate.
        c = mx.quat_normalize(a + 1e-9 * rng.normal(size=4))
        got = mx.quat_slerp(a, c, 0.5)
        assert np.all(np.isfinite(got))
        assert mx.quat_angle(a, got) == pytest.approx(0.5 * mx.quat_angle(a, c), rel=1e-6)


def test_blend(rng):
    for _ in range(30):
        qs = unit_quats(rng, 4)
        w = rng.uniform(0.0, 1.0, size=4)
        np.testing.assert_allclose(mx.quat_blend(qs, w), naive.quat_blend(qs, w), atol=1e-14)
        # Flipping any input's sign changes nothing.
        flipped = qs * np.array([[1.0], [-1.0], [1.0], [-1.0]])
        np.testing.assert_allclose(mx.quat_blend(flipped, w), mx.quat_blend(qs, w), atol=1e-15)
        # The hemisphere reference is the first quaternion with nonzero weight.
        w0 = w.copy()
        w0[0] = 0.0
        np.testing.assert_allclose(mx.quat_blend(qs, w0), naive.quat_blend(qs, w0), atol=1e-14)
    # Two rotations with equal weights blend to the slerp midpoint (same great circle).
    a, b = unit_quats(rng, 2)
    np.testing.assert_allclose(mx.quat_blend(np.array([a, -b]), np.array([0.5, 0.5])),
                               mx.quat_slerp(a, b, 0.5), atol=1e-14)
    # A single weighted rotation is itself.
    np.testing.assert_allclose(mx.quat_blend(np.array([a]), np.array([0.3])), a, atol=1e-15)


def test_between(rng):
    for _ in range(50):
        u, v = rng.normal(size=3), rng.normal(size=3)
        q = mx.quat_between(u, v)
        np.testing.assert_allclose(q, naive.quat_between(u, v), atol=1e-13)
        np.testing.assert_allclose(mx.quat_rotate(q, u / np.linalg.norm(u)),
                                   v / np.linalg.norm(v), atol=1e-14)
        # Minimal twist: the rotation axis is perpendicular to both directions.
        axis, _ = mx.quat_to_axis_angle(q)
        assert abs(np.dot(axis, u)) < 1e-12 * np.linalg.norm(u)
        assert abs(np.dot(axis, v)) < 1e-12 * np.linalg.norm(v)


def test_between_opposite_and_nearly_opposite(rng):
    directions = [EX, EY, EZ, -EX, np.array([1.0, 1.0, 1.0]), np.array([0.0, 3.0, -4.0])]
    directions += list(rng.normal(size=(10, 3)))
    for u in directions:
        q = mx.quat_between(u, -2.5 * u)
        n = u / np.linalg.norm(u)
        np.testing.assert_allclose(mx.quat_rotate(q, n), -n, atol=1e-15)
        assert q[0] == 0.0                                   # exactly a half turn
        assert abs(np.dot(q[1:], n)) < 1e-15                 # about an axis perpendicular to u
        np.testing.assert_array_equal(mx.quat_between(u, -u), q)  # deterministic
    # The axis rule: u x e_k for the coordinate axis e_k least aligned with u.
    np.testing.assert_allclose(mx.quat_between(EZ, -EZ), [0.0, 0.0, 1.0, 0.0], atol=0)
    np.testing.assert_allclose(mx.quat_between(EX, -EX), [0.0, 0.0, 0.0, 1.0], atol=0)
    # Nearly opposite: still maps u onto v to rounding.
    for eps in [1e-4, 1e-7, 1e-10, 1e-11]:
        u = np.array([0.3, -0.5, 0.8])
        v = -u + eps * np.cross(u, EX)
        q = mx.quat_between(u, v)
        np.testing.assert_allclose(mx.quat_rotate(q, u / np.linalg.norm(u)),
                                   v / np.linalg.norm(v), atol=1e-14)


def test_swing_twist(rng):
    for q in unit_quats(rng, 40):
        axis = rng.normal(size=3)
        n = axis / np.linalg.norm(axis)
        swing, twist = mx.quat_swing_twist(q, axis)
        np.testing.assert_allclose(mx.quat_mul(swing, twist), q, atol=1e-14)
        assert twist[0] >= 0.0
        assert np.linalg.norm(np.cross(twist[1:], n)) < 1e-14       # twist about the axis
        assert abs(np.dot(swing[1:], n)) < 1e-14                    # swing perpendicular
        # The swing is the shortest arc taking the axis to where q takes it.
        assert same_rotation(swing, mx.quat_between(n, mx.quat_rotate(q, n)), atol=1e-12)


def test_quat_angle(rng):
    for a, b in zip(unit_quats(rng, 30), unit_quats(rng, 30), strict=True):
        angle = mx.quat_angle(a, b)
        assert 0.0 <= angle <= math.pi
        assert angle == pytest.approx(naive.rotation_angle(a, b), abs=1e-7)
        assert mx.quat_angle(a, -b) == angle
        assert mx.quat_angle(a, a) == 0.0
    # Tiny angles stay exact (acos of the dot product would return 0 or ~2e-8).
    a = unit_quats(rng, 1)[0]
    b = mx.quat_mul(a, mx.quat_from_rotvec(np.array([0.0, 1e-10, 0.0])))
    assert mx.quat_angle(a, b) == pytest.approx(1e-10, rel=1e-5)


def test_batch_helpers(rng):
    a, b = unit_quats(rng, 7), unit_quats(rng, 7)
    v = rng.normal(size=(7, 3))
    np.testing.assert_allclose(mx.quat_mul_batch(a, b),
                               np.array([naive.quat_mul(x, y) for x, y in zip(a, b, strict=True)]),
                               atol=1e-14)
    np.testing.assert_allclose(mx.quat_rotate_batch(a, v),
                               np.array([naive.quat_rotate(x, y) for x, y in zip(a, v, strict=True)]),
                               atol=1e-12)
    assert mx.quat_mul_batch(a[:0], b[:0]).shape == (0, 4)


# ---------------------------------------------------------------------------------------
# Frames
# ---------------------------------------------------------------------------------------

def test_minimal_twist_rotate(rng):
    for rest in unit_quats(rng, 10):
        u, v = rng.normal(size=3), rng.normal(size=3)
        got = mx.minimal_twist_rotate(rest, u, v)
        np.testing.assert_allclose(got, naive.quat_mul(naive.quat_between(u, v), rest),
                                   atol=1e-13)


def test_frame_transport_straight_line_keeps_the_frame(rng):
    rot0 = unit_quats(rng, 1)[0]
    direction = np.array([0.2, -0.4, 1.0])
    spacing = np.cumsum(rng.uniform(0.1, 1.0, size=9))     # uneven steps, one direction
    points = np.outer(spacing, direction) + rng.normal(size=3)
    rots = mx.frame_transport(points, direction, rot0)
    np.testing.assert_allclose(rots, np.tile(rot0, (9, 1)), atol=1e-15)


def test_frame_transport_circle_arc_turns_by_the_arc_angle(rng):
    # Evenly spaced points on a circle in a tilted plane: the central-difference tangent
    # at each interior point is the circle's tangent, so frames of interior points differ
    # by exactly the arc angle between them, about the plane normal.
    normal = np.array([0.3, -0.2, 0.9])
    normal /= np.linalg.norm(normal)
    e1 = np.cross(normal, EX)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    n, arc, radius = 12, 2.5, 0.7
    theta = np.linspace(0.0, arc, n)
    points = radius * (np.outer(np.cos(theta), e1) + np.outer(np.sin(theta), e2))
    tangent_at_start = e2                                  # d/dtheta at theta = 0
    rot0 = unit_quats(rng, 1)[0]
    rots = mx.frame_transport(points, tangent_at_start, rot0)
    np.testing.assert_allclose(rots, naive.frame_transport(points, tangent_at_start, rot0),
                               atol=1e-13)
    step = arc / (n - 1)
    # The first point's tangent is the chord to the next point: half a step ahead.
    assert mx.quat_angle(rot0, rots[0]) == pytest.approx(step / 2, abs=1e-13)
    for i in range(1, n - 1):
        relative = mx.quat_mul(rots[i], mx.quat_conj(rots[1]))
        expected = mx.quat_from_axis_angle(normal, (i - 1) * step)
        assert same_rotation(relative, expected, atol=1e-13)
    # Full interior sweep turns by the arc between the second and second-to-last points.
    assert mx.quat_angle(rots[1], rots[n - 2]) == pytest.approx(arc - 2 * step, abs=1e-12)


def test_frame_transport_helix_against_reference(rng):
    t = np.linspace(0, 3, 25)
    points = np.stack([np.cos(t), np.sin(t), 0.3 * t], axis=1)
    rot0 = unit_quats(rng, 1)[0]
    tangent0 = np.array([0.0, 1.0, 0.3])
    np.testing.assert_allclose(mx.frame_transport(points, tangent0, rot0),
                               naive.frame_transport(points, tangent0, rot0), atol=1e-12)
    # Without tangent0 the first frame is rot0 itself; the rest follow the same steps.
    out = np.empty((25, 4))
    mx.frame_transport_into(points, rot0, out)
    np.testing.assert_array_equal(out[0], rot0)
    step = mx.quat_mul(out[1], mx.quat_conj(out[0]))
    np.testing.assert_allclose(step, mx.quat_between(points[1] - points[0],
                                                     points[2] - points[0]), atol=1e-14)


def test_frame_transport_repeated_points_skip():
    # A repeated point has a zero one-sided tangent at the end; the frame carries over.
    points = np.array([[0.0, 0, 0], [1.0, 0, 0], [1.0, 1.0, 0], [1.0, 1.0, 0]])
    rots = mx.frame_transport(points, EX, IDENTITY)
    assert np.all(np.isfinite(rots))
    np.testing.assert_array_equal(rots[3], rots[2])
    np.testing.assert_array_equal(mx.polyline_tangent_into(points, 3, np.empty(3)), ZERO3)
    np.testing.assert_array_equal(mx.polyline_tangent_into(points, 1, np.empty(3)),
                                  [1.0, 1.0, 0.0])


def _quintic_ends(rng):
    return [rng.normal(size=3) for _ in range(3)], [rng.normal(size=3) for _ in range(3)]


def test_spline_frame_transport_against_reference(rng):
    ends0, ends1 = _quintic_ends(rng)
    params = np.array([0.1, 0.35, 0.5, 0.8, 1.0])
    rot0 = unit_quats(rng, 1)[0]
    for substeps in [1, 5]:
        points, rots = mx.spline_frame_transport(*ends0, *ends1, params, rot0, substeps)
        ref_points, ref_rots = naive.spline_frame_transport(ends0, ends1, params, rot0,
                                                            substeps)
        np.testing.assert_allclose(points, ref_points, atol=1e-12)
        np.testing.assert_allclose(rots, ref_rots, atol=1e-12)
        # The axis rot0 put on the tangent stays on the tangent.
        local_axis = mx.quat_rotate_inv(rot0, ends0[1] / np.linalg.norm(ends0[1]))
        for t, rot in zip(params, rots, strict=True):
            tangent = mx.hermite5_deriv(*ends0, *ends1, t)
            np.testing.assert_allclose(mx.quat_rotate(rot, local_axis),
                                       tangent / np.linalg.norm(tangent), atol=1e-12)


def test_spline_frame_transport_straight_planar_and_converging(rng):
    rot0 = unit_quats(rng, 1)[0]
    params = np.linspace(0.0, 1.0, 6)
    # A straight spline keeps the frame; its points lie on the segment.
    p0, p1 = rng.normal(size=(2, 3))
    points, rots = mx.spline_frame_transport(p0, p1 - p0, ZERO3, p1, p1 - p0, ZERO3, params,
                                             rot0, 4)
    np.testing.assert_allclose(rots, np.tile(rot0, (6, 1)), atol=1e-15)
    np.testing.assert_allclose(points, p0 + np.outer(params, p1 - p0), atol=1e-14)
    # A planar spline: each frame is rot0 turned about the plane normal by the tangent's
    # turn angle, whatever the step count (while no step turns past a half turn).
    ends = [np.concatenate([rng.normal(size=2), [0.0]]) for _ in range(6)]
    ends[1] = np.array([1.0, 0.0, 0.0])
    ends[4] = np.array([1.0, 0.5, 0.0])
    for substeps in [1, 7]:
        _, rots = mx.spline_frame_transport(*ends, params, rot0, substeps)
        angle = 0.0
        tangent_prev = ends[1]
        t_prev = 0.0
        for t, rot in zip(params, rots, strict=True):
            for s in range(1, 200 + 1):   # unwrap the tangent angle finely
                tangent = mx.hermite5_deriv(*ends, t_prev + (t - t_prev) * s / 200)
                angle += math.atan2(np.cross(tangent_prev, tangent)[2],
                                    np.dot(tangent_prev, tangent))
                tangent_prev = tangent
            t_prev = t
            expected = mx.quat_mul(mx.quat_from_axis_angle(EZ, angle), rot0)
            assert same_rotation(rot, expected, atol=1e-10)
    # A twisted spline: the discrete transport converges as the step count grows.
    ends0, ends1 = _quintic_ends(rng)
    last = [mx.spline_frame_transport(*ends0, *ends1, params, rot0, k)[1][-1]
            for k in (16, 64, 256)]
    coarse, fine = mx.quat_angle(last[0], last[2]), mx.quat_angle(last[1], last[2])
    assert fine < coarse / 8 + 1e-12


def test_mirror_sagittal(rng):
    mirror = np.diag([1.0, -1.0, 1.0])
    for q in unit_quats(rng, 10):
        mq = mx.quat_mirror_sagittal(q)
        np.testing.assert_allclose(mx.quat_to_matrix(mq),
                                   mirror @ naive.quat_to_matrix(q) @ mirror, atol=1e-13)
        v = rng.normal(size=3)
        np.testing.assert_allclose(mx.quat_rotate(mq, mirror @ v),
                                   mirror @ mx.quat_rotate(q, v), atol=1e-13)
        np.testing.assert_array_equal(mx.quat_mirror_sagittal(mq), q)
    # Yaw to the left (about +Z) mirrors to yaw to the right; pitch (about Y) is kept.
    yaw = mx.quat_from_axis_angle(EZ, 0.4)
    np.testing.assert_allclose(mx.quat_mirror_sagittal(yaw), mx.quat_from_axis_angle(EZ, -0.4))
    pitch = mx.quat_from_axis_angle(EY, 0.4)
    np.testing.assert_array_equal(mx.quat_mirror_sagittal(pitch), pitch)


# ---------------------------------------------------------------------------------------
# Splines
# ---------------------------------------------------------------------------------------

def test_hermite3_against_polynomial(rng):
    for _ in range(10):
        p0, m0, p1, m1 = rng.normal(size=(4, 3))
        for t in [0.0, 0.3, 0.77, 1.0]:
            np.testing.assert_allclose(mx.hermite3(p0, m0, p1, m1, t),
                                       naive.hermite([p0, m0], [p1, m1], t), atol=1e-13)
            np.testing.assert_allclose(mx.hermite3_deriv(p0, m0, p1, m1, t),
                                       naive.hermite([p0, m0], [p1, m1], t, 1), atol=1e-12)
            assert mx.hermite3_scalar(p0[0], m0[0], p1[0], m1[0], t) == pytest.approx(
                mx.hermite3(p0, m0, p1, m1, t)[0], abs=1e-15)
            assert mx.hermite3_scalar_deriv(p0[0], m0[0], p1[0], m1[0], t) == pytest.approx(
                mx.hermite3_deriv(p0, m0, p1, m1, t)[0], abs=1e-15)
            basis = mx.hermite3_basis(t)
            np.testing.assert_allclose(basis @ np.array([p0, m0, p1, m1]),
                                       mx.hermite3(p0, m0, p1, m1, t), atol=1e-14)
            np.testing.assert_allclose(mx.hermite3_basis_deriv(t) @ np.array([p0, m0, p1, m1]),
                                       mx.hermite3_deriv(p0, m0, p1, m1, t), atol=1e-13)
        # End conditions exactly.
        np.testing.assert_array_equal(mx.hermite3(p0, m0, p1, m1, 0.0), p0)
        np.testing.assert_allclose(mx.hermite3(p0, m0, p1, m1, 1.0), p1, atol=1e-15)
        np.testing.assert_allclose(mx.hermite3_deriv(p0, m0, p1, m1, 0.0), m0, atol=1e-15)
        np.testing.assert_allclose(mx.hermite3_deriv(p0, m0, p1, m1, 1.0), m1, atol=1e-14)


def test_hermite5_against_polynomial(rng):
    for t in [0.0, 0.1, 0.5, 0.83, 1.0]:
        for order, fn in enumerate([mx.hermite5_basis, mx.hermite5_basis_deriv,
                                    mx.hermite5_basis_deriv2]):
            np.testing.assert_allclose(fn(t), naive.hermite5_basis(t, order), atol=1e-12)
    for _ in range(10):
        c = rng.normal(size=(6, 4))                      # any dimension: d = 4 here
        for t in [0.0, 0.37, 1.0]:
            for order, fn in enumerate([mx.hermite5, mx.hermite5_deriv, mx.hermite5_deriv2]):
                np.testing.assert_allclose(fn(*c, t), naive.hermite(c[:3], c[3:], t, order),
                                           atol=1e-11)
        p0, v0, a0, p1, v1, a1 = c
        np.testing.assert_array_equal(mx.hermite5(*c, 0.0), p0)
        np.testing.assert_allclose(mx.hermite5(*c, 1.0), p1, atol=1e-14)
        np.testing.assert_allclose(mx.hermite5_deriv(*c, 0.0), v0, atol=1e-15)
        np.testing.assert_allclose(mx.hermite5_deriv(*c, 1.0), v1, atol=1e-13)
        np.testing.assert_allclose(mx.hermite5_deriv2(*c, 0.0), a0, atol=1e-15)
        np.testing.assert_allclose(mx.hermite5_deriv2(*c, 1.0), a1, atol=1e-12)


def test_fit_hermite5_recovers_a_known_quintic(rng):
    for m in [4, 6, 15]:
        p0, v0, a0, p1, v1, a1 = rng.normal(size=(6, 3))
        params = np.sort(rng.uniform(0.05, 0.95, size=m))
        points = np.array([mx.hermite5(p0, v0, a0, p1, v1, a1, t) for t in params])
        got = mx.fit_hermite5(points, params, p0, p1)
        for fitted, true in zip(got, [v0, a0, v1, a1], strict=True):
            np.testing.assert_allclose(fitted, true, atol=1e-7)


def test_fit_hermite5_least_squares_against_lstsq(rng):
    # Noisy samples of a spine-like wiggle, including samples at the ends (which
    # constrain nothing), in 3-D and 2-D.
    for d in [3, 2]:
        params = np.concatenate([[0.0], np.sort(rng.uniform(0, 1, size=10)), [1.0]])
        points = np.stack([params, np.sin(7 * params), params ** 2][:d], axis=1)
        points += 0.01 * rng.normal(size=points.shape)
        p0, p1 = points[0], points[-1]
        got = np.array(mx.fit_hermite5(points, params, p0, p1))
        np.testing.assert_allclose(got, naive.fit_hermite5(points, params, p0, p1), atol=1e-8)


def test_fit_hermite5_under_determined(rng):
    p0, p1 = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 0.4])
    for m in [1, 2, 3]:
        params = np.sort(rng.uniform(0.1, 0.9, size=m))
        points = rng.normal(size=(m, 3))
        got = np.array(mx.fit_hermite5(points, params, p0, p1))
        assert np.all(np.isfinite(got))
        # Minimum-norm correction to the straight segment: numpy's lstsq agrees ...
        np.testing.assert_allclose(got, naive.fit_hermite5(points, params, p0, p1), atol=1e-9)
        # ... and with fewer samples than unknowns the curve passes through every sample.
        for t, point in zip(params, points, strict=True):
            np.testing.assert_allclose(mx.hermite5(p0, got[0], got[1], p1, got[2], got[3], t),
                                       point, atol=1e-9)
    # Four samples at only two distinct params are rank-deficient too.
    params = np.array([0.3, 0.3, 0.6, 0.6])
    points = rng.normal(size=(4, 3))
    got = np.array(mx.fit_hermite5(points, params, p0, p1))
    np.testing.assert_allclose(got, naive.fit_hermite5(points, params, p0, p1), atol=1e-9)
    # No interior samples: the straight segment at constant speed.
    got = np.array(mx.fit_hermite5(np.array([p0, p1]), np.array([0.0, 1.0]), p0, p1))
    np.testing.assert_array_equal(got, [p1 - p0, ZERO3, p1 - p0, ZERO3])
    for t in [0.25, 0.5]:
        np.testing.assert_allclose(mx.hermite5(p0, got[0], got[1], p1, got[2], got[3], t),
                                   p0 + t * (p1 - p0), atol=1e-15)


def test_chord_params(rng):
    points = np.array([[0.0, 0, 0], [3.0, 0, 0], [3.0, 4.0, 0], [3.0, 4.0, 0], [3.0, 4.0, 2.0]])
    np.testing.assert_allclose(mx.chord_params(points), [0.0, 3 / 9, 7 / 9, 7 / 9, 1.0], atol=1e-15)
    np.testing.assert_array_equal(mx.chord_params(np.zeros((4, 3))), [0.0, 1 / 3, 2 / 3, 1.0])
    np.testing.assert_array_equal(mx.chord_params(np.ones((1, 3))), [0.0])
    assert mx.chord_params(np.zeros((0, 3))).shape == (0,)
    points = rng.normal(size=(9, 2))
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
    np.testing.assert_allclose(mx.chord_params(points),
                               np.concatenate([[0.0], np.cumsum(lengths) / lengths.sum()]), atol=1e-15)


def test_auto_tangents(rng):
    times = np.cumsum(rng.uniform(0.1, 1.0, size=6))
    values = rng.normal(size=(6, 2))
    tangents = mx.auto_tangents(times, values)
    for i in range(1, 5):
        for c in range(2):
            assert tangents[i, c] == pytest.approx(
                naive.parabola_slope(times, values[:, c], i), abs=1e-10)
    np.testing.assert_allclose(tangents[0], (values[1] - values[0]) / (times[1] - times[0]))
    np.testing.assert_allclose(tangents[-1], (values[-1] - values[-2]) / (times[-1] - times[-2]))
    np.testing.assert_array_equal(mx.auto_tangents(times, values, True), np.zeros((6, 2)))
    # Even spacing: Catmull-Rom, (p[i+1] - p[i-1]) / (2 h).
    even = np.arange(6) * 0.5
    np.testing.assert_allclose(mx.auto_tangents(even, values)[1:-1],
                               (values[2:] - values[:-2]) / 1.0, atol=1e-14)
    # Keys on a quadratic reproduce its slope inside.
    quad = (3 * times ** 2 - times)[:, None]
    np.testing.assert_allclose(mx.auto_tangents(times, quad)[1:-1, 0],
                               6 * times[1:-1] - 1, atol=1e-12)


def test_hermite3_keys(rng):
    times = np.array([0.0, 0.4, 1.5, 2.0])
    values = rng.normal(size=(4, 3))
    tangents = mx.auto_tangents(times, values)
    for i, t in enumerate(times):
        np.testing.assert_allclose(mx.hermite3_keys(times, values, tangents, t), values[i],
                                   atol=1e-15)
    np.testing.assert_array_equal(mx.hermite3_keys(times, values, tangents, -1.0), values[0])
    np.testing.assert_array_equal(mx.hermite3_keys(times, values, tangents, 9.0), values[-1])
    t = 1.1                                               # inside segment [0.4, 1.5]
    u, h = (t - 0.4) / 1.1, 1.1
    ref = naive.hermite([values[1], h * tangents[1]], [values[2], h * tangents[2]], u)
    np.testing.assert_allclose(mx.hermite3_keys(times, values, tangents, t), ref, atol=1e-13)
    # Keyed curve slope matches the tangent at a key (value units per second).
    eps = 1e-6
    slope = (mx.hermite3_keys(times, values, tangents, 0.4 + eps)
             - mx.hermite3_keys(times, values, tangents, 0.4 - eps)) / (2 * eps)
    # (central differences across a key see the jump in curvature: error ~ eps)
    np.testing.assert_allclose(slope, tangents[1], atol=1e-5)
    assert [mx.find_segment(times, t) for t in [-1.0, 0.0, 0.5, 1.5, 1.9, 2.0, 3.0]] == \
        [0, 0, 1, 2, 2, 2, 2]


def test_natural_end_tangent():
    # A natural cubic end: zero second derivative at t = 1 of the Hermite segment.
    p_prev, v_prev, p_end = np.array([0.0, 1.0]), np.array([0.5, -2.0]), np.array([2.0, 0.5])
    v_end = mx.natural_end_tangent(p_prev, p_end, v_prev)
    coeffs = [naive.hermite_coefficients(([p_prev[c], v_prev[c]], [p_end[c], v_end[c]]))
              for c in range(2)]
    for c in range(2):
        assert naive.polynomial_eval(coeffs[c], 1.0, 2) == pytest.approx(0.0, abs=1e-12)
    assert mx.natural_end_tangent(0.0, 1.0, 0.0) == 1.5


# ---------------------------------------------------------------------------------------
# The _into twins: bit-identical, alias-safe, writing into views, allocation-free
# ---------------------------------------------------------------------------------------

def _twin_cases():
    rng = np.random.default_rng(7)
    a, b, c = unit_quats(rng, 3)
    u, v = rng.normal(size=(2, 3))
    qs, w = unit_quats(rng, 5), rng.uniform(size=5)
    m = mx.quat_to_matrix(a)
    pts = np.cumsum(rng.normal(size=(6, 3)), axis=0)
    h3 = tuple(rng.normal(size=(4, 3)))
    h5 = tuple(rng.normal(size=(6, 3)))
    times, values = np.array([0.0, 0.3, 1.0, 1.2]), rng.normal(size=(4, 2))
    params = np.linspace(0.1, 0.9, 5)
    samples = rng.normal(size=(5, 3))
    return [
        (mx.quat_mul, mx.quat_mul_into, (a, b), (4,)),
        (mx.quat_conj, mx.quat_conj_into, (a,), (4,)),
        (mx.quat_inv, mx.quat_inv_into, (2 * a,), (4,)),
        (mx.quat_normalize, mx.quat_normalize_into, (3 * a,), (4,)),
        (mx.quat_rotate, mx.quat_rotate_into, (a, u), (3,)),
        (mx.quat_rotate_inv, mx.quat_rotate_inv_into, (a, u), (3,)),
        (mx.quat_slerp, mx.quat_slerp_into, (a, b, 0.3), (4,)),
        (mx.quat_nlerp, mx.quat_nlerp_into, (a, b, 0.3), (4,)),
        (mx.quat_blend, mx.quat_blend_into, (qs, w), (4,)),
        (mx.quat_from_axis_angle, mx.quat_from_axis_angle_into, (u, 0.8), (4,)),
        (mx.quat_from_rotvec, mx.quat_from_rotvec_into, (u,), (4,)),
        (mx.quat_to_rotvec, mx.quat_to_rotvec_into, (a,), (3,)),
        (mx.quat_to_matrix, mx.quat_to_matrix_into, (a,), (3, 3)),
        (mx.quat_from_matrix, mx.quat_from_matrix_into, (m,), (4,)),
        (mx.quat_between, mx.quat_between_into, (u, v), (4,)),
        (mx.mat4_from_pose, mx.mat4_from_pose_into, (u, a), (4, 4)),
        (mx.quat_mul_batch, mx.quat_mul_batch_into, (qs, qs[::-1].copy()), (5, 4)),
        (mx.quat_rotate_batch, mx.quat_rotate_batch_into, (qs, rng.normal(size=(5, 3))),
         (5, 3)),
        (mx.minimal_twist_rotate, mx.minimal_twist_rotate_into, (c, u, v), (4,)),
        (mx.hermite3, mx.hermite3_into, h3 + (0.4,), (3,)),
        (mx.hermite3_deriv, mx.hermite3_deriv_into, h3 + (0.4,), (3,)),
        (mx.hermite3_basis, mx.hermite3_basis_into, (0.4,), (4,)),
        (mx.hermite3_basis_deriv, mx.hermite3_basis_deriv_into, (0.4,), (4,)),
        (mx.hermite5, mx.hermite5_into, h5 + (0.6,), (3,)),
        (mx.hermite5_deriv, mx.hermite5_deriv_into, h5 + (0.6,), (3,)),
        (mx.hermite5_deriv2, mx.hermite5_deriv2_into, h5 + (0.6,), (3,)),
        (mx.hermite5_basis, mx.hermite5_basis_into, (0.6,), (6,)),
        (mx.hermite5_basis_deriv, mx.hermite5_basis_deriv_into, (0.6,), (6,)),
        (mx.hermite5_basis_deriv2, mx.hermite5_basis_deriv2_into, (0.6,), (6,)),
        (mx.auto_tangents, lambda t, x, out: mx.auto_tangents_into(t, x, False, out),
         (times, values), (4, 2)),
        (mx.hermite3_keys, mx.hermite3_keys_into, (times, values, values, 0.7), (2,)),
        (mx.chord_params, mx.chord_params_into, (pts,), (6,)),
        (lambda *args: np.array(mx.fit_hermite5(*args)), mx.fit_hermite5_into,
         (samples, params, u, v), (4, 3)),
        (mx.quat_mirror_sagittal, mx.quat_mirror_sagittal_into, (a,), (4,)),
        (lambda *args: mx.quat_swing_twist(*args)[0],
         lambda q, ax, out: mx.quat_swing_twist_into(q, ax, out, np.empty(4))[0], (a, u), (4,)),
        (lambda *args: mx.quat_swing_twist(*args)[1],
         lambda q, ax, out: mx.quat_swing_twist_into(q, ax, np.empty(4), out)[1], (a, u), (4,)),
        (lambda *args: mx.spline_frame_transport(*args)[1],
         lambda *args: mx.spline_frame_transport_into(*args[:-1], np.empty((5, 3)), args[-1])[1],
         h5 + (params, a, 3), (5, 4)),
        (lambda *args: mx.spline_frame_transport(*args)[0],
         lambda *args: mx.spline_frame_transport_into(*args[:-1], args[-1], np.empty((5, 4)))[0],
         h5 + (params, a, 3), (5, 3)),
        (lambda p, q0, t0: mx.frame_transport(p, t0, q0),
         lambda p, q0, t0, out: mx.frame_transport_into(p, q0, out, t0), (pts, a, u), (6, 4)),
    ]


TWINS = _twin_cases()


@pytest.mark.parametrize("fn,fn_into,args,shape", TWINS, ids=[str(i) for i in range(len(TWINS))])
def test_into_twin_is_bit_identical(fn, fn_into, args, shape):
    expected = np.asarray(fn(*args))
    out = np.full(shape, np.nan)
    returned = fn_into(*args, out)
    np.testing.assert_array_equal(out, expected)
    assert returned is out or np.shares_memory(returned, out)


def test_into_twins_write_into_views_and_may_alias():
    rng = np.random.default_rng(3)
    q = unit_quats(rng, 4)
    v = rng.normal(size=(4, 3))
    # Rows of a state array and strided views.
    state = np.zeros((3, 8))
    mx.quat_mul_into(q[0], q[1], state[1, 2:6])
    np.testing.assert_array_equal(state[1, 2:6], mx.quat_mul(q[0], q[1]))
    strided = np.zeros(8)
    mx.quat_rotate_into(q[2], v[0], strided[::3])
    np.testing.assert_array_equal(strided[::3], mx.quat_rotate(q[2], v[0]))
    mats = np.zeros((2, 4, 4))
    mx.mat4_from_pose_into(v[1], q[3], mats[1])
    np.testing.assert_array_equal(mats[1], mx.mat4_from_pose(v[1], q[3]))
    # out aliasing an input.
    for fn, fn_into, args in [
        (mx.quat_mul, mx.quat_mul_into, (q[0], q[1])),
        (mx.quat_slerp, mx.quat_slerp_into, (q[0], q[1], 0.4)),
        (mx.quat_nlerp, mx.quat_nlerp_into, (q[0], q[1], 0.4)),
        (mx.quat_inv, mx.quat_inv_into, (q[0],)),
        (mx.quat_conj, mx.quat_conj_into, (q[0],)),
        (mx.quat_normalize, mx.quat_normalize_into, (2 * q[0],)),
    ]:
        expected = fn(*args)
        for k in range(len(args)):
            if not isinstance(args[k], np.ndarray):
                continue
            copies = [x.copy() if isinstance(x, np.ndarray) else x for x in args]
            fn_into(*copies, copies[k])
            np.testing.assert_array_equal(copies[k], expected)
    vector = v[0].copy()
    mx.quat_rotate_into(q[0], vector, vector)
    np.testing.assert_array_equal(vector, mx.quat_rotate(q[0], v[0]))
    rest = q[1].copy()
    mx.minimal_twist_rotate_into(rest, v[0], v[1], rest)
    np.testing.assert_array_equal(rest, mx.minimal_twist_rotate(q[1], v[0], v[1]))


def _tuple_cases():
    rng = np.random.default_rng(11)
    a, b = unit_quats(rng, 2)
    u, v = rng.normal(size=(2, 3))
    h5 = tuple(rng.normal(size=(6, 3)))
    return [
        (mx.quat_mul_t, mx.quat_mul_into, (a, b), 4),
        (mx.quat_conj_t, mx.quat_conj_into, (a,), 4),
        (mx.quat_inv_t, mx.quat_inv_into, (2 * a,), 4),
        (mx.quat_normalize_t, mx.quat_normalize_into, (3 * a,), 4),
        (mx.quat_rotate_t, mx.quat_rotate_into, (a, u), 3),
        (mx.quat_rotate_inv_t, mx.quat_rotate_inv_into, (a, u), 3),
        (mx.quat_nlerp_t, mx.quat_nlerp_into, (a, b, 0.3), 4),
        (mx.quat_slerp_t, mx.quat_slerp_into, (a, b, 0.3), 4),
        (mx.quat_from_axis_angle_t, mx.quat_from_axis_angle_into, (u, 0.3), 4),
        (mx.quat_from_rotvec_t, mx.quat_from_rotvec_into, (u,), 4),
        (mx.quat_to_rotvec_t, mx.quat_to_rotvec_into, (a,), 3),
        (mx.quat_between_t, mx.quat_between_into, (u, v), 4),
        (mx.quat_mirror_sagittal_t, mx.quat_mirror_sagittal_into, (a,), 4),
        (mx.minimal_twist_rotate_t, mx.minimal_twist_rotate_into, (a, u, v), 4),
        (mx.hermite5_t, mx.hermite5_into, h5 + (0.3,), 3),
        (mx.hermite5_deriv_t, mx.hermite5_deriv_into, h5 + (0.3,), 3),
    ]


TUPLES = _tuple_cases()


@pytest.mark.parametrize("fn_t,fn_into,args,size", TUPLES, ids=[str(i) for i in range(len(TUPLES))])
def test_tuple_twin_is_bit_identical(fn_t, fn_into, args, size):
    out = np.full(size, np.nan)
    fn_into(*args, out)
    # Arrays in, tuple out ...
    got = fn_t(*args)
    assert isinstance(got, tuple) and len(got) == size
    np.testing.assert_array_equal(np.array(got), out)
    # ... and tuples in, tuple out.
    as_tuples = [tuple(float(x) for x in arg) if isinstance(arg, np.ndarray) else arg for arg in args]
    np.testing.assert_array_equal(np.array(fn_t(*as_tuples)), out)


@njit
def _hot_path(n, a, b, u, v, qs, w, pts, times, values, p0, m0, p1, m1, a0, a1,
              q_out, v_out, m_out, rots_out, swing, twist):
    # What a frame of IK, blending and sampling calls, n times over.
    for _ in range(n):
        mx.quat_mul_into(a, b, q_out)
        mx.quat_rotate_into(a, u, v_out)
        mx.quat_rotate_inv_into(a, u, v_out)
        mx.quat_slerp_into(a, b, 0.3, q_out)
        mx.quat_nlerp_into(a, b, 0.3, q_out)
        mx.quat_blend_into(qs, w, q_out)
        mx.quat_between_into(u, v, q_out)
        mx.quat_from_rotvec_into(u, q_out)
        mx.quat_to_rotvec_into(a, v_out)
        mx.quat_from_axis_angle_into(u, 0.5, q_out)
        mx.quat_to_matrix_into(a, m_out)
        mx.quat_from_matrix_into(m_out, q_out)
        mx.quat_swing_twist_into(a, u, swing, twist)
        mx.quat_normalize_into(a, q_out)
        mx.quat_inv_into(a, q_out)
        mx.minimal_twist_rotate_into(a, u, v, q_out)
        mx.frame_transport_into(pts, a, rots_out)
        mx.frame_transport_into(pts, a, rots_out, u)
        mx.hermite3_into(p0, m0, p1, m1, 0.4, v_out)
        mx.hermite3_deriv_into(p0, m0, p1, m1, 0.4, v_out)
        mx.hermite5_into(p0, m0, a0, p1, m1, a1, 0.4, v_out)
        mx.hermite5_deriv_into(p0, m0, a0, p1, m1, a1, 0.4, v_out)
        mx.hermite5_deriv2_into(p0, m0, a0, p1, m1, a1, 0.4, v_out)
        mx.hermite3_keys_into(times, values, values, 0.7, v_out)
        mx.spline_frame_transport_into(p0, m0, a0, p1, m1, a1, times, a, 3, pts, rots_out[:3])
        mx.quat_mirror_sagittal_into(a, q_out)
        r = mx.quat_mul_t(mx.quat_between_t((u[0], u[1], u[2]), v), (a[0], a[1], a[2], a[3]))
        q_out[0] = mx.quat_slerp_t(r, b, 0.5)[0]
        v_out[0] = mx.hermite5_t(p0, m0, a0, p1, m1, a1, 0.2)[0]
        mx.quat_dot(a, b)
        mx.quat_angle(a, b)


def test_into_twins_allocate_nothing_inside_kernels():
    """The per-frame path allocates nothing: NRT allocation counts of a kernel running
    the hot functions 1 or 200 times are the same."""
    rng = np.random.default_rng(5)
    a, b = unit_quats(rng, 2)
    qs, w = unit_quats(rng, 4), rng.uniform(size=4)
    pts = np.cumsum(rng.normal(size=(7, 3)), axis=0)
    times, values = np.array([0.0, 0.5, 1.0]), rng.normal(size=(3, 3))
    vecs = rng.normal(size=(8, 3))
    args = (a, b, vecs[0], vecs[1], qs, w, pts, times, values, vecs[2], vecs[3], vecs[4],
            vecs[5], vecs[6], vecs[7], np.empty(4), np.empty(3), np.empty((3, 3)),
            np.empty((7, 4)), np.empty(4), np.empty(4))
    _hot_path(1, *args)                                    # compile
    _nrt_python.memsys_enable_stats()
    try:
        before = rtsys.get_allocation_stats()
        _hot_path(1, *args)
        middle = rtsys.get_allocation_stats()
        _hot_path(200, *args)
        after = rtsys.get_allocation_stats()
    finally:
        _nrt_python.memsys_disable_stats()
    once = middle.alloc - before.alloc
    many = after.alloc - middle.alloc
    assert many == once, f"{many - once} allocations in 199 extra iterations"


# ---------------------------------------------------------------------------------------
# Properties (hypothesis)
# ---------------------------------------------------------------------------------------

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
vec3 = arrays(np.float64, 3, elements=finite)
vec4 = arrays(np.float64, 4, elements=finite)


def _unit(q):
    n = np.linalg.norm(q)
    return q / n if n > 1e-6 else None


@settings(max_examples=150, deadline=None)
@given(vec4)
def test_property_matrix_round_trip(q):
    q = _unit(q)
    if q is None:
        return
    assert same_rotation(mx.quat_from_matrix(mx.quat_to_matrix(q)), q, atol=1e-13)


@settings(max_examples=150, deadline=None)
@given(vec4)
def test_property_rotvec_round_trip(q):
    q = _unit(q)
    if q is None:
        return
    r = mx.quat_to_rotvec(q)
    assert np.linalg.norm(r) <= math.pi + 1e-12
    assert same_rotation(mx.quat_from_rotvec(r), q, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(vec3, vec3)
def test_property_between_maps_u_to_v(u, v):
    nu, nv = np.linalg.norm(u), np.linalg.norm(v)
    q = mx.quat_between(u, v)
    assert np.all(np.isfinite(q))
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-14)
    if nu < 1e-100 or nv < 1e-100:
        return
    np.testing.assert_allclose(mx.quat_rotate(q, u / nu), v / nv, atol=1e-12)


@settings(max_examples=150, deadline=None)
@given(vec4, vec4, st.floats(-1.0, 2.0))
def test_property_slerp_unit_and_finite(a, b, t):
    a, b = _unit(a), _unit(b)
    if a is None or b is None:
        return
    q = mx.quat_slerp(a, b, t)
    assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-14)
    # Constant angular speed: the angle from a is |t| times the full angle (mod the
    # shorter way round, which extrapolation past a half turn may take).
    full = mx.quat_angle(a, b)
    if 0.0 <= t <= 1.0:
        assert mx.quat_angle(a, q) == pytest.approx(t * full, abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, (5, 3), elements=st.floats(-10, 10)), vec4)
def test_property_transport_keeps_the_tangent_axis(points, rot0):
    """Whatever local axis rot0 puts on the first tangent stays on the tangent of every
    point (for polylines without zero or reversing tangents)."""
    rot0 = _unit(rot0)
    tangents = np.array([mx.polyline_tangent_into(points, i, np.empty(3)) for i in range(5)])
    norms = np.linalg.norm(tangents, axis=1)
    if rot0 is None or np.any(norms < 1e-3):
        return
    units = tangents / norms[:, None]
    if np.any(np.sum(units[1:] * units[:-1], axis=1) < -0.999):
        return
    rots = mx.frame_transport(points, tangents[0], rot0)
    local_axis = mx.quat_rotate_inv(rot0, units[0])
    for rot, unit in zip(rots, units, strict=True):
        np.testing.assert_allclose(mx.quat_rotate(rot, local_axis), unit, atol=1e-9)


@settings(max_examples=150, deadline=None)
@given(vec4, vec3)
def test_property_swing_twist_recomposes(q, axis):
    q = _unit(q)
    if q is None:
        return
    swing, twist = mx.quat_swing_twist(q, axis)
    assert np.all(np.isfinite(swing)) and np.all(np.isfinite(twist))
    np.testing.assert_allclose(mx.quat_mul(swing, twist), q, atol=1e-13)
