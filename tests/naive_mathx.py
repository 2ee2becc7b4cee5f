"""Slow, obvious plain-numpy references for engine.mathx (the STUMPY ``naive.py`` idea).

Each one is written the textbook way, deliberately different from the kernel it checks:
products through 4x4 matrices, rotations through Rodrigues' formula on an axis and an
angle found with arccos, splines through their polynomial coefficients found with
np.linalg.solve, fits with np.linalg.lstsq. Speed and edge-case robustness do not
matter here; clarity does.
"""

from __future__ import annotations

import numpy as np


def quat_mul(a, b):
    """Hamilton product as the left-multiplication matrix L(a) applied to b."""
    w, x, y, z = a
    left = np.array([[w, -x, -y, -z],
                     [x, w, -z, y],
                     [y, z, w, -x],
                     [z, -y, x, w]])
    return left @ np.asarray(b, dtype=float)


def quat_conj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def axis_angle(q):
    """Unit axis and angle in [0, 2 pi) of a unit quaternion, through arccos."""
    q = np.asarray(q, dtype=float) / np.linalg.norm(q)
    angle = 2.0 * np.arccos(np.clip(q[0], -1.0, 1.0))
    s = np.sqrt(max(1.0 - q[0] ** 2, 0.0))
    if s < 1e-12:
        return np.array([1.0, 0.0, 0.0]), 0.0
    return q[1:] / s, angle


def rodrigues(axis, angle):
    """Rotation matrix I + sin(a) K + (1 - cos(a)) K^2 for a unit axis."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -axis[2], axis[1]],
                  [axis[2], 0.0, -axis[0]],
                  [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def quat_to_matrix(q):
    axis, angle = axis_angle(q)
    return rodrigues(axis, angle)


def quat_rotate(q, v):
    return quat_to_matrix(q) @ np.asarray(v, dtype=float)


def quat_from_axis_angle(axis, angle):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def quat_from_matrix(m):
    """The unit quaternion of a rotation matrix as the top eigenvector of the symmetric
    4x4 matrix of Bar-Itzhack (2000), sign chosen so w >= 0."""
    m = np.asarray(m, dtype=float)
    k = np.array([
        [m[0, 0] - m[1, 1] - m[2, 2], m[1, 0] + m[0, 1], m[2, 0] + m[0, 2], m[2, 1] - m[1, 2]],
        [m[1, 0] + m[0, 1], m[1, 1] - m[0, 0] - m[2, 2], m[2, 1] + m[1, 2], m[0, 2] - m[2, 0]],
        [m[2, 0] + m[0, 2], m[2, 1] + m[1, 2], m[2, 2] - m[0, 0] - m[1, 1], m[1, 0] - m[0, 1]],
        [m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1], m[0, 0] + m[1, 1] + m[2, 2]],
    ]) / 3.0
    vals, vecs = np.linalg.eigh(k)
    x, y, z, w = vecs[:, np.argmax(vals)]
    q = np.array([w, x, y, z])
    return q if q[0] >= 0 else -q


def quat_slerp(a, b, t):
    """a * (a^-1 b)^t through axis and angle, on the shorter arc."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if np.dot(a, b) < 0:
        b = -b
    rel = quat_mul(quat_conj(a), b)
    axis, angle = axis_angle(rel)
    return quat_mul(a, quat_from_axis_angle(axis, t * angle))


def quat_rotvec(q):
    """Rotation vector, angle in [0, pi]."""
    q = np.asarray(q, dtype=float)
    if q[0] < 0:
        q = -q
    axis, angle = axis_angle(q)
    return axis * angle


def quat_between(u, v):
    """Rotation about u x v by arccos of the cosine between u and v (not for opposite or
    parallel directions)."""
    u = np.asarray(u, dtype=float) / np.linalg.norm(u)
    v = np.asarray(v, dtype=float) / np.linalg.norm(v)
    axis = np.cross(u, v)
    angle = np.arccos(np.clip(np.dot(u, v), -1.0, 1.0))
    return quat_from_axis_angle(axis, angle)


def quat_blend(qs, weights):
    qs = np.array(qs, dtype=float)
    weights = np.asarray(weights, dtype=float)
    nonzero = np.flatnonzero(weights != 0)
    if len(nonzero) == 0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    ref = qs[nonzero[0]]
    signs = np.where(qs @ ref < 0, -1.0, 1.0)
    total = (weights * signs) @ qs
    return total / np.linalg.norm(total)


def rotation_angle(a, b):
    """Angle of a^-1 b through arccos, in [0, pi]."""
    rel = quat_mul(quat_conj(a), b)
    return 2.0 * np.arccos(np.clip(abs(rel[0]), 0.0, 1.0))


def hermite_coefficients(conditions):
    """Monomial coefficients c (lowest power first) of the polynomial of degree
    2 * len(conditions) / 2 - 1 whose derivatives at t = 0 and t = 1 are given:
    conditions = ([p(0), p'(0), ...], [p(1), p'(1), ...]), scalars."""
    at0, at1 = conditions
    order = len(at0)
    degree = 2 * order - 1
    rows, rhs = [], []
    for end, values in ((0.0, at0), (1.0, at1)):
        for k, value in enumerate(values):
            row = np.zeros(degree + 1)
            for p in range(k, degree + 1):
                # d^k/dt^k t^p = p! / (p - k)! t^(p - k)
                row[p] = np.prod(np.arange(p - k + 1, p + 1)) * end ** (p - k)
            rows.append(row)
            rhs.append(value)
    return np.linalg.solve(np.array(rows), np.array(rhs))


def polynomial_eval(coeffs, t, derivative=0):
    poly = np.polynomial.Polynomial(coeffs)
    return poly.deriv(derivative)(t) if derivative else poly(t)


def hermite(ends0, ends1, t, derivative=0):
    """Vector Hermite curve through its coefficient polynomial, one component at a time.
    ends0 = [p0, v0(, a0)], ends1 = [p1, v1(, a1)], each a (d,) array."""
    d = len(ends0[0])
    out = np.empty(d)
    for c in range(d):
        coeffs = hermite_coefficients(([e[c] for e in ends0], [e[c] for e in ends1]))
        out[c] = polynomial_eval(coeffs, t, derivative)
    return out


def hermite5_basis(t, derivative=0):
    """Quintic Hermite basis functions of (p0, v0, a0, p1, v1, a1), from unit conditions."""
    out = np.empty(6)
    for k in range(6):
        unit = np.zeros(6)
        unit[k] = 1.0
        coeffs = hermite_coefficients((unit[:3], unit[3:]))
        out[k] = polynomial_eval(coeffs, t, derivative)
    return out


def fit_hermite5(points, params, p0, p1):
    """Least squares over the full design matrix with np.linalg.lstsq; the under-
    determined part is the minimum-norm correction to v0 = v1 = p1 - p0, a0 = a1 = 0."""
    points = np.asarray(points, dtype=float)
    basis = np.array([hermite5_basis(t) for t in params]).reshape(len(params), 6)
    design = basis[:, [1, 2, 4, 5]]
    prior = np.array([p1 - p0, np.zeros_like(p0), p1 - p0, np.zeros_like(p0)])
    residual = points - np.outer(basis[:, 0], p0) - np.outer(basis[:, 3], p1) - design @ prior
    if len(params) == 0:
        return prior
    correction, *_ = np.linalg.lstsq(design, residual, rcond=None)
    return prior + correction


def parabola_slope(times, values, i):
    """Derivative at times[i] of the parabola through keys i-1, i, i+1 (np.polyfit)."""
    coeffs = np.polyfit(times[i - 1:i + 2], values[i - 1:i + 2], 2)
    return np.polyval(np.polyder(coeffs), times[i])


def frame_transport(points, tangent0, rot0):
    """Parallel transport written as a plain loop over Rodrigues rotations."""
    points = np.asarray(points, dtype=float)
    n = len(points)
    tangents = []
    for i in range(n):
        lo, hi = max(i - 1, 0), min(i + 1, n - 1)
        tangents.append(points[hi] - points[lo])
    rots = []
    rot = np.asarray(rot0, dtype=float)
    prev = np.asarray(tangent0, dtype=float)
    for i in range(n):
        cur = tangents[i]
        cross = np.cross(prev, cur)
        if np.linalg.norm(cross) > 1e-15 * np.linalg.norm(prev) * np.linalg.norm(cur):
            rot = quat_mul(quat_between(prev, cur), rot)
        rots.append(rot)
        prev = cur
    return np.array(rots)


def spline_frame_transport(ends0, ends1, params, rot0, substeps):
    """Transport along a quintic Hermite with tangents from the coefficient polynomial,
    as a plain loop of Rodrigues steps."""
    rot = np.asarray(rot0, dtype=float)
    prev = np.asarray(ends0[1], dtype=float)
    t_prev = 0.0
    points, rots = [], []
    for t_next in params:
        for s in range(1, substeps + 1):
            t = t_prev + (t_next - t_prev) * s / substeps
            cur = hermite(ends0, ends1, t, 1)
            if np.linalg.norm(np.cross(prev, cur)) > 1e-15 * np.linalg.norm(prev) * np.linalg.norm(cur):
                rot = quat_mul(quat_between(prev, cur), rot)
            prev = cur
        points.append(hermite(ends0, ends1, t_next))
        rots.append(rot)
        t_prev = t_next
    return np.array(points), np.array(rots)
