"""Numba kernels of motion-capture tracking (see ``engine.response.tracking``)."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def welford_update(count, mean, m2, values):
    """One pass of Welford's online mean and variance (Knuth TAOCP vol. 2; Wilke &
    Semwal Algorithm 2) for each slot k: count[k] += 1, delta = x - mean,
    mean += delta / count, M2 += delta * (x - mean_new). Variance = M2 / (count - 1).
    count (k,) int64, mean (k,), m2 (k,), values (k,) float64."""
    for k in range(values.shape[0]):
        count[k] += 1
        delta = values[k] - mean[k]
        mean[k] += delta / count[k]
        m2[k] += delta * (values[k] - mean[k])


@njit(cache=True)
def tracked_points_kernel(body_pos, body_rot, point_local, out):
    """World position of one body-fixed point per body: out[b] = x_b + R_b point_local[b]."""
    for b in range(body_pos.shape[0]):
        w, x, y, z = body_rot[b, 0], body_rot[b, 1], body_rot[b, 2], body_rot[b, 3]
        vx, vy, vz = point_local[b, 0], point_local[b, 1], point_local[b, 2]
        tx = 2.0 * (y * vz - z * vy)
        ty = 2.0 * (z * vx - x * vz)
        tz = 2.0 * (x * vy - y * vx)
        out[b, 0] = body_pos[b, 0] + vx + w * tx + (y * tz - z * ty)
        out[b, 1] = body_pos[b, 1] + vy + w * ty + (z * tx - x * tz)
        out[b, 2] = body_pos[b, 2] + vz + w * tz + (x * ty - y * tx)


@njit(cache=True)
def squared_errors_kernel(target, actual, out):
    """out[j] = |target[j] - actual[j]|^2 (Wilke & Semwal e_p^2(j, f))."""
    for j in range(target.shape[0]):
        dx = target[j, 0] - actual[j, 0]
        dy = target[j, 1] - actual[j, 1]
        dz = target[j, 2] - actual[j, 2]
        out[j] = dx * dx + dy * dy + dz * dz


@njit(cache=True)
def finite_or_zero(x):
    return x if math.isfinite(x) else 0.0
