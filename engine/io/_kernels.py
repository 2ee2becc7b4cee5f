"""numba kernels of the glTF exporter: key reduction (see ``engine.io.gltf_export.reduce_keys``)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _err_lerp(values, a, k, i):
    u = (i - a) / (k - a)
    s = 0.0
    for d in range(values.shape[1]):
        e = values[a, d] + u * (values[k, d] - values[a, d]) - values[i, d]
        s += e * e
    return np.sqrt(s)


@njit(cache=True)
def _err_slerp(q, a, k, i):
    u = (i - a) / (k - a)
    dot = 0.0
    for d in range(4):
        dot += q[a, d] * q[k, d]
    sign = 1.0
    if dot < 0.0:
        sign = -1.0
        dot = -dot
    if dot > 1.0:
        dot = 1.0
    theta = np.arccos(dot)
    s = np.sin(theta)
    if s < 1e-9:
        wa, wb = 1.0 - u, u
    else:
        wa, wb = np.sin((1.0 - u) * theta) / s, np.sin(u * theta) / s
    r = np.zeros(4)
    n = 0.0
    for d in range(4):
        r[d] = wa * q[a, d] + wb * sign * q[k, d]
        n += r[d] * r[d]
    n = np.sqrt(n)
    c = 0.0
    for d in range(4):
        c += r[d] / n * q[i, d]
    c = abs(c)
    if c > 1.0:
        c = 1.0
    return 2.0 * np.arccos(c)


@njit(cache=True)
def reduce_keys_kernel(values, rotation, tol, keep):
    """Greedy key reduction of one channel: ``values`` (n, d) float64, ``keep`` (n,) bool out."""
    n = values.shape[0]
    for i in range(n):
        keep[i] = False
    keep[0] = True
    keep[n - 1] = True
    a = 0
    k = 2
    while k < n:
        worst = 0.0
        for i in range(a + 1, k):
            e = _err_slerp(values, a, k, i) if rotation else _err_lerp(values, a, k, i)
            if e > worst:
                worst = e
        if worst > tol:
            a = k - 1
            keep[a] = True
        k += 1
