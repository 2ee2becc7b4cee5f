"""Quaternion kernels: (w, x, y, z) float64, Hamilton convention.

Every function is ``@njit(cache=True)`` and can be called from Python or from another
numba kernel. Each function that returns an array ``f(...)`` has an allocation-free twin
``f_into(..., out)`` that writes into a preallocated array (or a view of one); the
returning version allocates ``out`` and calls the twin, so the two agree bit for bit.
Hot kernels use the ``_into`` twins.

Conventions (see DESIGN.md):
- ``quat_mul(a, b)`` is the Hamilton product ``a * b``: rotating by it applies ``b``
  first, then ``a``. A body's world rotation is ``parent_world * local``.
- Rotations act on column vectors: ``quat_rotate(q, v) = q v q*``; ``quat_to_matrix``
  gives ``R`` with ``R @ v == quat_rotate(q, v)``.
- ``q`` and ``-q`` are the same rotation. Functions that must pick one (axis-angle,
  rotation vectors, matrices to quaternions) return the one with ``w >= 0``.

Robustness (Menagerie's rule: no NaN in output):
- A zero (or non-finite) quaternion normalizes to the identity.
- Functions taking a rotation accept non-unit quaternions where it costs nothing
  (rotate, to_matrix divide by ``|q|^2``); the rest expect unit input and say so.
- Every ``_into`` twin reads all of its inputs before it writes, so ``out`` may alias an
  input (``quat_mul_into(a, b, a)`` is fine).

Tuple twins: for kernels that keep small vectors in registers, ``f_t(...)`` returns the
result as a tuple ((w, x, y, z) or (x, y, z)) and accepts arrays or tuples as inputs.
They hold the formulas; ``f_into`` stores what ``f_t`` returns, so all three agree bit
for bit. Passing arrays between numba functions costs reference counting on every call;
tuples cost nothing.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Below this 4-D angle between two quaternions slerp falls back to nlerp: the two agree
# to O(theta^3) there, ~1e-19, and nlerp never divides by sin(theta) ~ 0.
_SLERP_NLERP_ANGLE = 1e-6
# Below this |u x v| (for unit u, v pointing apart) two directions count as exactly
# opposite and quat_between picks its deterministic perpendicular axis.
_OPPOSITE_SIN = 1e-12
# Below this angle quat_from_rotvec uses the Taylor series of sin(theta/2)/theta.
_ROTVEC_SERIES = 1e-3


# ---------------------------------------------------------------------------------------
# Products, conjugates, normalization
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def _normalize4(w, x, y, z):
    # Shared tail of every function that ends in a normalization. A zero, tiny-enough-to-
    # underflow or non-finite quaternion has no direction: it becomes the identity.
    n2 = w * w + x * x + y * y + z * z
    if not (n2 > 0.0 and n2 < np.inf):
        return 1.0, 0.0, 0.0, 0.0
    n = math.sqrt(n2)
    return w / n, x / n, y / n, z / n


@njit(cache=True)
def quat_mul_t(a, b):
    """Hamilton product a * b as a (w, x, y, z) tuple (the rotation applies b, then a)."""
    aw, ax, ay, az = a[0], a[1], a[2], a[3]
    bw, bx, by, bz = b[0], b[1], b[2], b[3]
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(cache=True)
def quat_mul_into(a, b, out):
    """out = a * b (Hamilton product; the rotation applies b, then a)."""
    w, x, y, z = quat_mul_t(a, b)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_mul(a, b):
    """Hamilton product a * b, a new (4,) array."""
    return quat_mul_into(a, b, np.empty(4))


@njit(cache=True)
def quat_conj_t(q):
    """Conjugate (w, -x, -y, -z) as a tuple."""
    return q[0], -q[1], -q[2], -q[3]


@njit(cache=True)
def quat_conj_into(q, out):
    """out = conjugate of q, (w, -x, -y, -z)."""
    w, x, y, z = quat_conj_t(q)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_conj(q):
    """Conjugate of q (the inverse rotation for a unit q)."""
    return quat_conj_into(q, np.empty(4))


@njit(cache=True)
def quat_inv_t(q):
    """q^-1 = conj(q) / |q|^2 as a tuple; a zero or non-finite q gives the identity."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    n2 = w * w + x * x + y * y + z * z
    if not (n2 > 0.0 and n2 < np.inf):
        return 1.0, 0.0, 0.0, 0.0
    return w / n2, -x / n2, -y / n2, -z / n2


@njit(cache=True)
def quat_inv_into(q, out):
    """out = q^-1 = conj(q) / |q|^2; a zero quaternion gives the identity."""
    w, x, y, z = quat_inv_t(q)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_inv(q):
    """Inverse of q (conjugate over squared norm); zero gives identity."""
    return quat_inv_into(q, np.empty(4))


@njit(cache=True)
def quat_dot(a, b):
    """4-D dot product of two quaternions (cos of half the angle between unit rotations,
    up to sign)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]


@njit(cache=True)
def quat_normalize_t(q):
    """q / |q| as a tuple; a zero or non-finite quaternion gives the identity."""
    return _normalize4(q[0], q[1], q[2], q[3])


@njit(cache=True)
def quat_normalize_into(q, out):
    """out = q / |q|; a zero or non-finite quaternion becomes the identity (never NaN)."""
    w, x, y, z = _normalize4(q[0], q[1], q[2], q[3])
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_normalize(q):
    """q / |q| as a new array; zero or non-finite input gives the identity."""
    return quat_normalize_into(q, np.empty(4))


# ---------------------------------------------------------------------------------------
# Rotating vectors
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def _rotate(w, x, y, z, vx, vy, vz):
    # q v q* / |q|^2 for any nonzero q, expanded (u = (x, y, z)):
    #   ((w^2 - u.u) v + 2 (u.v) u + 2 w (u x v)) / (w^2 + u.u)
    # which is the rotation by q/|q|. A zero q rotates nothing.
    uu = x * x + y * y + z * z
    n2 = w * w + uu
    if not (n2 > 0.0 and n2 < np.inf):
        return vx, vy, vz
    uv = x * vx + y * vy + z * vz
    cx = y * vz - z * vy
    cy = z * vx - x * vz
    cz = x * vy - y * vx
    s = w * w - uu
    return ((s * vx + 2.0 * uv * x + 2.0 * w * cx) / n2,
            (s * vy + 2.0 * uv * y + 2.0 * w * cy) / n2,
            (s * vz + 2.0 * uv * z + 2.0 * w * cz) / n2)


@njit(cache=True)
def quat_rotate_t(q, v):
    """v rotated by q as an (x, y, z) tuple (q need not be unit; zero q leaves v)."""
    return _rotate(q[0], q[1], q[2], q[3], v[0], v[1], v[2])


@njit(cache=True)
def quat_rotate_into(q, v, out):
    """out = q v q^-1, the 3-vector v rotated by q (q need not be unit; zero q leaves v)."""
    x, y, z = _rotate(q[0], q[1], q[2], q[3], v[0], v[1], v[2])
    out[0] = x
    out[1] = y
    out[2] = z
    return out


@njit(cache=True)
def quat_rotate(q, v):
    """The 3-vector v rotated by q, a new (3,) array."""
    return quat_rotate_into(q, v, np.empty(3))


@njit(cache=True)
def quat_rotate_inv_t(q, v):
    """v rotated by the inverse of q, as a tuple."""
    return _rotate(q[0], -q[1], -q[2], -q[3], v[0], v[1], v[2])


@njit(cache=True)
def quat_rotate_inv_into(q, v, out):
    """out = q^-1 v q, v rotated by the inverse of q (world to local)."""
    x, y, z = _rotate(q[0], -q[1], -q[2], -q[3], v[0], v[1], v[2])
    out[0] = x
    out[1] = y
    out[2] = z
    return out


@njit(cache=True)
def quat_rotate_inv(q, v):
    """The 3-vector v rotated by the inverse of q, a new (3,) array."""
    return quat_rotate_inv_into(q, v, np.empty(3))


# ---------------------------------------------------------------------------------------
# Interpolation and blending
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def _half_angle_between(aw, ax, ay, az, bw, bx, by, bz):
    # The 4-D angle between unit quaternions a and b, 2 atan2(|a - b|, |a + b|): exact to
    # rounding everywhere, unlike acos(a.b), which loses half the digits near a.b = 1.
    dw, dx, dy, dz = aw - bw, ax - bx, ay - by, az - bz
    sw, sx, sy, sz = aw + bw, ax + bx, ay + by, az + bz
    d = math.sqrt(dw * dw + dx * dx + dy * dy + dz * dz)
    s = math.sqrt(sw * sw + sx * sx + sy * sy + sz * sz)
    return 2.0 * math.atan2(d, s)


@njit(cache=True)
def quat_nlerp_t(a, b, t):
    """nlerp on the shorter arc as a tuple; see ``quat_nlerp_into``."""
    aw, ax, ay, az = a[0], a[1], a[2], a[3]
    bw, bx, by, bz = b[0], b[1], b[2], b[3]
    if aw * bw + ax * bx + ay * by + az * bz < 0.0:
        bw, bx, by, bz = -bw, -bx, -by, -bz
    s = 1.0 - t
    return _normalize4(s * aw + t * bw, s * ax + t * bx, s * ay + t * by, s * az + t * bz)


@njit(cache=True)
def quat_nlerp_into(a, b, t, out):
    """out = normalize((1 - t) a + t b'), b' = b or -b, whichever is on a's hemisphere
    (so the blend takes the shorter arc). Unit inputs expected."""
    w, x, y, z = quat_nlerp_t(a, b, t)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_nlerp(a, b, t):
    """Normalized linear interpolation on the shorter arc, a new (4,) array."""
    return quat_nlerp_into(a, b, t, np.empty(4))


@njit(cache=True)
def quat_slerp_t(a, b, t):
    """slerp on the shorter arc as a tuple; see ``quat_slerp_into``."""
    aw, ax, ay, az = a[0], a[1], a[2], a[3]
    bw, bx, by, bz = b[0], b[1], b[2], b[3]
    if aw * bw + ax * bx + ay * by + az * bz < 0.0:
        bw, bx, by, bz = -bw, -bx, -by, -bz
    theta = _half_angle_between(aw, ax, ay, az, bw, bx, by, bz)
    if theta < _SLERP_NLERP_ANGLE:
        ka = 1.0 - t
        kb = t
    else:
        st = math.sin(theta)
        ka = math.sin((1.0 - t) * theta) / st
        kb = math.sin(t * theta) / st
    return _normalize4(ka * aw + kb * bw, ka * ax + kb * bx, ka * ay + kb * by,
                       ka * az + kb * bz)


@njit(cache=True)
def quat_slerp_into(a, b, t, out):
    """out = spherical linear interpolation from a (t = 0) to b (t = 1) on the shorter arc
    (b is negated when a.b < 0). t outside [0, 1] extrapolates along the same great
    circle. Nearly equal inputs fall back to nlerp. Unit inputs expected; the result is
    normalized."""
    w, x, y, z = quat_slerp_t(a, b, t)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_slerp(a, b, t):
    """Spherical linear interpolation on the shorter arc, a new (4,) array."""
    return quat_slerp_into(a, b, t, np.empty(4))


@njit(cache=True)
def quat_blend_into(qs, weights, out):
    """out = normalize(sum_i w_i s_i q_i), the weighted blend of k rotations qs (k, 4)
    with weights (k,). Each q_i is first moved to the hemisphere of the first quaternion
    with a nonzero weight (s_i = +-1), so q and -q blend as the same rotation. All-zero
    weights (or weights that cancel) give the identity. Weights need not sum to 1."""
    k = qs.shape[0]
    ref = -1
    for i in range(k):
        if weights[i] != 0.0:
            ref = i
            break
    if ref < 0:
        out[0] = 1.0
        out[1] = 0.0
        out[2] = 0.0
        out[3] = 0.0
        return out
    rw, rx, ry, rz = qs[ref, 0], qs[ref, 1], qs[ref, 2], qs[ref, 3]
    sw = 0.0
    sx = 0.0
    sy = 0.0
    sz = 0.0
    for i in range(ref, k):
        wi = weights[i]
        if wi == 0.0:
            continue
        qw, qx, qy, qz = qs[i, 0], qs[i, 1], qs[i, 2], qs[i, 3]
        if qw * rw + qx * rx + qy * ry + qz * rz < 0.0:
            wi = -wi
        sw += wi * qw
        sx += wi * qx
        sy += wi * qy
        sz += wi * qz
    w, x, y, z = _normalize4(sw, sx, sy, sz)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_blend(qs, weights):
    """Normalized weighted blend of qs (k, 4) by weights (k,), a new (4,) array."""
    return quat_blend_into(qs, weights, np.empty(4))


# ---------------------------------------------------------------------------------------
# Axis-angle, rotation vectors (exp / log maps)
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def quat_from_axis_angle_t(axis, angle):
    """Rotation by angle about axis as a tuple; see ``quat_from_axis_angle_into``."""
    x, y, z = axis[0], axis[1], axis[2]
    n = math.sqrt(x * x + y * y + z * z)
    if not (n > 0.0 and n < np.inf and math.isfinite(angle)):
        return 1.0, 0.0, 0.0, 0.0
    h = 0.5 * angle
    s = math.sin(h) / n
    return math.cos(h), x * s, y * s, z * s


@njit(cache=True)
def quat_twist_angle_t(q, axis):
    """Signed angle (rad, in (-pi, pi]) of the twist part of q about the unit ``axis``
    (the swing-twist split). ``engine.ik._kernels.twist_angle`` is the IK's private twin."""
    p = q[1] * axis[0] + q[2] * axis[1] + q[3] * axis[2]
    ang = 2.0 * math.atan2(p, q[0])
    if ang > math.pi:
        ang -= 2.0 * math.pi
    elif ang <= -math.pi:
        ang += 2.0 * math.pi
    return ang


@njit(cache=True)
def quat_from_axis_angle_into(axis, angle, out):
    """out = rotation by angle (rad, right-handed) about axis; the axis need not be unit,
    a zero or non-finite axis, or a non-finite angle, gives the identity."""
    w, x, y, z = quat_from_axis_angle_t(axis, angle)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_from_axis_angle(axis, angle):
    """Rotation by angle about axis (any nonzero length), a new (4,) array."""
    return quat_from_axis_angle_into(axis, angle, np.empty(4))


@njit(cache=True)
def quat_to_axis_angle(q):
    """(axis (3,), angle) of the rotation q, with angle in [0, pi] and a unit axis. q is
    normalized first; the identity (and a zero q) give axis (1, 0, 0) and angle 0."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    n2 = w * w + x * x + y * y + z * z
    if not (n2 > 0.0 and n2 < np.inf):
        w, x, y, z = 1.0, 0.0, 0.0, 0.0
    else:
        nn = math.sqrt(n2)
        w, x, y, z = w / nn, x / nn, y / nn, z / nn
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    axis = np.zeros(3)
    if s > 0.0:
        axis[0] = x / s
        axis[1] = y / s
        axis[2] = z / s
    else:
        axis[0] = 1.0
    return axis, 2.0 * math.atan2(s, w)


@njit(cache=True)
def quat_from_rotvec_t(r):
    """exp(r / 2) as a tuple; see ``quat_from_rotvec_into``."""
    x, y, z = r[0], r[1], r[2]
    theta2 = x * x + y * y + z * z
    theta = math.sqrt(theta2)
    if not (theta < np.inf):
        return 1.0, 0.0, 0.0, 0.0
    if theta < _ROTVEC_SERIES:
        # sin(theta/2)/theta = 1/2 - theta^2/48 + theta^4/3840 - ...
        k = 0.5 - theta2 / 48.0 + theta2 * theta2 / 3840.0
    else:
        k = math.sin(0.5 * theta) / theta
    return math.cos(0.5 * theta), x * k, y * k, z * k


@njit(cache=True)
def quat_from_rotvec_into(r, out):
    """out = exp(r / 2): the rotation by |r| rad about r. Stable near r = 0 (Taylor series
    of sin(|r|/2)/|r| below 1e-3 rad). A non-finite r (or |r| > 1e154) gives the
    identity."""
    w, x, y, z = quat_from_rotvec_t(r)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_from_rotvec(r):
    """Rotation from a rotation vector (axis * angle), a new (4,) array."""
    return quat_from_rotvec_into(r, np.empty(4))


@njit(cache=True)
def quat_to_rotvec_t(q):
    """2 log(q) as an (x, y, z) tuple; see ``quat_to_rotvec_into``."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    n2 = w * w + x * x + y * y + z * z
    if not (n2 > 0.0 and n2 < np.inf):
        return 0.0, 0.0, 0.0
    nn = math.sqrt(n2)
    w, x, y, z = w / nn, x / nn, y / nn, z / nn
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    # angle / s, with angle = 2 atan2(s, w); atan2 stays exact for tiny s, and s = 0 is
    # the identity, where the limit is 2 / w = 2.
    if s > 0.0:
        k = 2.0 * math.atan2(s, w) / s
    else:
        k = 2.0
    return x * k, y * k, z * k


@njit(cache=True)
def quat_to_rotvec_into(q, out):
    """out = 2 log(q): axis * angle with angle in [0, pi] (the shorter way round; q and -q
    give the same vector). q is normalized first; a zero q gives 0. Stable near the
    identity."""
    x, y, z = quat_to_rotvec_t(q)
    out[0] = x
    out[1] = y
    out[2] = z
    return out


@njit(cache=True)
def quat_to_rotvec(q):
    """Rotation vector (axis * angle, angle in [0, pi]) of q, a new (3,) array."""
    return quat_to_rotvec_into(q, np.empty(3))


# ---------------------------------------------------------------------------------------
# Matrices
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def _matrix3_into(w, x, y, z, out):
    # The rotation matrix of q/|q|, written with s = 2/|q|^2 so a non-unit q still gives
    # an orthonormal matrix; a zero q gives the identity.
    n2 = w * w + x * x + y * y + z * z
    if not (n2 > 0.0 and n2 < np.inf):
        w, x, y, z = 1.0, 0.0, 0.0, 0.0
        n2 = 1.0
    s = 2.0 / n2
    xx, yy, zz = x * x * s, y * y * s, z * z * s
    xy, xz, yz = x * y * s, x * z * s, y * z * s
    wx, wy, wz = w * x * s, w * y * s, w * z * s
    out[0, 0] = 1.0 - (yy + zz)
    out[0, 1] = xy - wz
    out[0, 2] = xz + wy
    out[1, 0] = xy + wz
    out[1, 1] = 1.0 - (xx + zz)
    out[1, 2] = yz - wx
    out[2, 0] = xz - wy
    out[2, 1] = yz + wx
    out[2, 2] = 1.0 - (xx + yy)
    return out


@njit(cache=True)
def quat_to_matrix_into(q, out):
    """out (3, 3) = the rotation matrix R of q, with R @ v == quat_rotate(q, v)."""
    return _matrix3_into(q[0], q[1], q[2], q[3], out)


@njit(cache=True)
def quat_to_matrix(q):
    """Rotation matrix (3, 3) of q (column vectors), a new array."""
    return quat_to_matrix_into(q, np.empty((3, 3)))


@njit(cache=True)
def quat_from_matrix_into(m, out):
    """out = the unit quaternion (w >= 0) of the rotation matrix m (3, 3), by Shepperd's
    method: take the square root of the largest of 1 + trace, 1 + 2 m_ii - trace, so the
    divisor is never small. A slightly non-orthogonal m gives a nearby rotation (the
    result is normalized); any m gives a finite unit quaternion."""
    m00, m01, m02 = m[0, 0], m[0, 1], m[0, 2]
    m10, m11, m12 = m[1, 0], m[1, 1], m[1, 2]
    m20, m21, m22 = m[2, 0], m[2, 1], m[2, 2]
    tr = m00 + m11 + m22
    if tr >= m00 and tr >= m11 and tr >= m22:
        r = math.sqrt(1.0 + tr)
        s = 0.5 / r
        w = 0.5 * r
        x = (m21 - m12) * s
        y = (m02 - m20) * s
        z = (m10 - m01) * s
    elif m00 >= m11 and m00 >= m22:
        r = math.sqrt(1.0 + m00 - m11 - m22)
        s = 0.5 / r
        x = 0.5 * r
        w = (m21 - m12) * s
        y = (m01 + m10) * s
        z = (m02 + m20) * s
    elif m11 >= m22:
        r = math.sqrt(1.0 - m00 + m11 - m22)
        s = 0.5 / r
        y = 0.5 * r
        w = (m02 - m20) * s
        x = (m01 + m10) * s
        z = (m12 + m21) * s
    else:
        r = math.sqrt(1.0 - m00 - m11 + m22)
        s = 0.5 / r
        z = 0.5 * r
        w = (m10 - m01) * s
        x = (m02 + m20) * s
        y = (m12 + m21) * s
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    w, x, y, z = _normalize4(w, x, y, z)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_from_matrix(m):
    """Unit quaternion (w >= 0) of a rotation matrix (3, 3), a new (4,) array."""
    return quat_from_matrix_into(m, np.empty(4))


@njit(cache=True)
def mat4_from_pose_into(pos, q, out):
    """out (4, 4) = the rigid transform [[R, pos], [0, 0, 0, 1]] (row-major storage,
    acting on column vectors: out @ (p, 1) = R p + pos)."""
    _matrix3_into(q[0], q[1], q[2], q[3], out[:3, :3])
    out[0, 3] = pos[0]
    out[1, 3] = pos[1]
    out[2, 3] = pos[2]
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0
    return out


@njit(cache=True)
def mat4_from_pose(pos, q):
    """Rigid transform (4, 4) of a position and rotation, a new array."""
    return mat4_from_pose_into(pos, q, np.empty((4, 4)))


# ---------------------------------------------------------------------------------------
# Rotations between directions, decompositions, distances
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def quat_between_t(u, v):
    """Shortest-arc rotation from direction u to direction v as a tuple (u, v: arrays or
    tuples); see ``quat_between_into``."""
    ux, uy, uz = u[0], u[1], u[2]
    vx, vy, vz = v[0], v[1], v[2]
    nu = math.sqrt(ux * ux + uy * uy + uz * uz)
    nv = math.sqrt(vx * vx + vy * vy + vz * vz)
    if not (nu > 0.0 and nu < np.inf and nv > 0.0 and nv < np.inf):
        return 1.0, 0.0, 0.0, 0.0
    ux, uy, uz = ux / nu, uy / nu, uz / nu
    vx, vy, vz = vx / nv, vy / nv, vz / nv
    d = ux * vx + uy * vy + uz * vz
    # u x v computed as u x (u + v): the same vector, but when u and v nearly oppose,
    # h = u + v is exact (Sterbenz) and nearly perpendicular to u, so the cross product
    # keeps full relative precision and stays perpendicular to u; u x v directly would
    # cancel to ~1e-16 absolute and tilt the axis by 1e-16 / |u x v|.
    hx, hy, hz = ux + vx, uy + vy, uz + vz
    cx = uy * hz - uz * hy
    cy = uz * hx - ux * hz
    cz = ux * hy - uy * hx
    sin_angle = math.sqrt(cx * cx + cy * cy + cz * cz)
    if d < 0.0 and sin_angle < _OPPOSITE_SIN:
        # Opposite: any axis perpendicular to u will do; pick one deterministically.
        ax, ay, az = abs(ux), abs(uy), abs(uz)
        if ax <= ay and ax <= az:
            px, py, pz = 0.0, uz, -uy          # u x e_x
        elif ay <= az:
            px, py, pz = -uz, 0.0, ux          # u x e_y
        else:
            px, py, pz = uy, -ux, 0.0          # u x e_z
        n = math.sqrt(px * px + py * py + pz * pz)
        return 0.0, px / n, py / n, pz / n
    # (1 + cos a, sin a * axis) = 2 cos(a/2) (cos(a/2), sin(a/2) axis): normalizing gives
    # the half-angle quaternion without any trigonometry. 1 + cos a is computed as
    # |u + v|^2 / 2, which keeps its relative precision when u and v nearly oppose.
    w = 0.5 * (hx * hx + hy * hy + hz * hz)
    n = math.sqrt(w * w + cx * cx + cy * cy + cz * cz)
    return w / n, cx / n, cy / n, cz / n


@njit(cache=True)
def quat_between_into(u, v, out):
    """out = the shortest-arc (minimal-twist) rotation taking direction u to direction v:
    rotation about u x v by the angle between them, so nothing turns about u itself.
    Lengths do not matter. A zero-length (or non-finite) u or v gives the identity.
    Exactly (or, to |u x v| < 1e-12, numerically) opposite directions give 180 degrees
    about a fixed axis perpendicular to u: u x e_k, with e_k the coordinate axis least
    aligned with u (the lowest k on ties), normalized. (Hecker 2008 sec 4.3.2 builds
    spine and limb orientations from these.)
    """
    w, x, y, z = quat_between_t(u, v)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_between(u, v):
    """Shortest-arc rotation taking direction u to direction v, a new (4,) array."""
    return quat_between_into(u, v, np.empty(4))


@njit(cache=True)
def quat_swing_twist_into(q, axis, swing_out, twist_out):
    """Split the unit rotation q into q = swing * twist: twist turns about axis (a 3-vector,
    any nonzero length), swing turns about an axis perpendicular to it. twist has w >= 0.
    When q turns 180 degrees about an axis perpendicular to axis the twist is undefined;
    Menagerie returns the identity twist there (and for a zero axis)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    ax, ay, az = axis[0], axis[1], axis[2]
    na = math.sqrt(ax * ax + ay * ay + az * az)
    if na > 0.0 and na < np.inf:
        ax, ay, az = ax / na, ay / na, az / na
        p = x * ax + y * ay + z * az
        tw, tx, ty, tz = w, p * ax, p * ay, p * az
    else:
        tw, tx, ty, tz = 1.0, 0.0, 0.0, 0.0
    if tw < 0.0:
        tw, tx, ty, tz = -tw, -tx, -ty, -tz
    tw, tx, ty, tz = _normalize4(tw, tx, ty, tz)
    twist_out[0] = tw
    twist_out[1] = tx
    twist_out[2] = ty
    twist_out[3] = tz
    # swing = q * conj(twist)
    swing_out[0] = w * tw + x * tx + y * ty + z * tz
    swing_out[1] = -w * tx + x * tw - y * tz + z * ty
    swing_out[2] = -w * ty + x * tz + y * tw - z * tx
    swing_out[3] = -w * tz - x * ty + y * tx + z * tw
    return swing_out, twist_out


@njit(cache=True)
def quat_swing_twist(q, axis):
    """(swing (4,), twist (4,)) with q = swing * twist and twist about axis."""
    return quat_swing_twist_into(q, axis, np.empty(4), np.empty(4))


@njit(cache=True)
def quat_angle(a, b):
    """The angle (rad, in [0, pi]) of the rotation taking orientation a to orientation b,
    i.e. of a^-1 b; q and -q count as equal. Unit inputs expected. Uses 4 atan2(|a-b|,
    |a+b|) on the same hemisphere, exact to rounding even for tiny angles."""
    aw, ax, ay, az = a[0], a[1], a[2], a[3]
    bw, bx, by, bz = b[0], b[1], b[2], b[3]
    if aw * bw + ax * bx + ay * by + az * bz < 0.0:
        bw, bx, by, bz = -bw, -bx, -by, -bz
    return 2.0 * _half_angle_between(aw, ax, ay, az, bw, bx, by, bz)


# ---------------------------------------------------------------------------------------
# Sagittal mirroring (DESIGN.md: mirroring negates Y and mirrors rotations to match)
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def quat_mirror_sagittal_t(q):
    """q mirrored through the sagittal (XZ) plane, (w, -x, y, -z), as a tuple."""
    return q[0], -q[1], q[2], -q[3]


@njit(cache=True)
def quat_mirror_sagittal_into(q, out):
    """out = q mirrored through the sagittal (XZ) plane: with M = diag(1, -1, 1), the
    rotation M R M, which is (w, -x, y, -z). Mirroring a pose negates Y of positions and
    maps each rotation this way, so mirrored bodies turn as the mirror image of the
    originals (a left arm raised forward becomes a right arm raised forward)."""
    w, x, y, z = quat_mirror_sagittal_t(q)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def quat_mirror_sagittal(q):
    """q mirrored through the sagittal (XZ) plane, (w, -x, y, -z), a new (4,) array."""
    return quat_mirror_sagittal_into(q, np.empty(4))


# ---------------------------------------------------------------------------------------
# Batch helpers (Python-side conveniences, not for per-frame code)
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def quat_mul_batch_into(a, b, out):
    """out[i] = a[i] * b[i] for (n, 4) arrays."""
    for i in range(a.shape[0]):
        quat_mul_into(a[i], b[i], out[i])
    return out


@njit(cache=True)
def quat_mul_batch(a, b):
    """Row-wise Hamilton products of a (n, 4) and b (n, 4), a new (n, 4) array."""
    return quat_mul_batch_into(a, b, np.empty((a.shape[0], 4)))


@njit(cache=True)
def quat_rotate_batch_into(q, v, out):
    """out[i] = q[i] rotating v[i] for q (n, 4), v (n, 3)."""
    for i in range(q.shape[0]):
        quat_rotate_into(q[i], v[i], out[i])
    return out


@njit(cache=True)
def quat_rotate_batch(q, v):
    """Row-wise rotations of v (n, 3) by q (n, 4), a new (n, 3) array."""
    return quat_rotate_batch_into(q, v, np.empty((q.shape[0], 3)))
