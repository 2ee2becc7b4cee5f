"""Numba kernels of motion-capture tracking (see ``engine.response.tracking``) and of the
impact response's library search (``engine.response.search``)."""

from __future__ import annotations

import math

import numpy as np
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


# -- impact response: the library search (engine.response.search) -------------------------


@njit(cache=True, inline="always")
def _track_worst(out_score, wslot, worst, j, K):
    """Remember which of row ``j``'s ``K`` kept scores is the worst (the one a better
    candidate replaces)."""
    m = 0
    for kk in range(1, K):
        if out_score[j, kk] > out_score[j, m]:
            m = kk
    wslot[j] = m
    worst[j] = out_score[j, m]

@njit(cache=True, fastmath=True)
def prefilter_topk(feats, sq, q, foot_feats, foot_sq, g, foot_of, allowed, out_idx, out_score):
    """The ``K = out_idx.shape[1]`` culled windows with the smallest prefilter score per
    simulation start j: score(s, j) = |feats[s] - q[j]|^2 (+ |foot_feats[f, s] - g[j]|^2 for
    the support foot f = foot_of[j] >= 0), over windows with ``allowed[s]``. feats (S, D)
    float32, sq (S,) |feats|^2, q (nsim, D), foot_feats (nfeet, S, E), foot_sq (nfeet, S),
    g (nsim, E), foot_of (nsim,) int64, allowed (S,) bool; out_idx (nsim, K) int64 and
    out_score (nsim, K) float64 are filled (unused slots: index -1, score inf)."""
    S, D = feats.shape
    nsim = q.shape[0]
    K = out_idx.shape[1]
    E = g.shape[1]
    qq = np.zeros(nsim)
    gg = np.zeros(nsim)
    for j in range(nsim):
        acc = 0.0
        for d in range(D):
            acc += q[j, d] * q[j, d]
        qq[j] = acc
        acc = 0.0
        for e in range(E):
            acc += g[j, e] * g[j, e]
        gg[j] = acc
        for k in range(K):
            out_idx[j, k] = -1
            out_score[j, k] = np.inf
    worst = np.full(nsim, np.inf)      # the largest score kept so far, per j
    wslot = np.zeros(nsim, np.int64)   # where it sits
    filled = np.zeros(nsim, np.int64)
    for s in range(S):
        if not allowed[s]:
            continue
        for j in range(nsim):
            dot = 0.0
            for d in range(D):
                dot += feats[s, d] * q[j, d]
            sc = sq[s] - 2.0 * dot + qq[j]
            f = foot_of[j]
            if f >= 0:
                fd = 0.0
                for e in range(E):
                    fd += foot_feats[f, s, e] * g[j, e]
                sc += foot_sq[f, s] - 2.0 * fd + gg[j]
            if filled[j] < K:
                k = filled[j]
                out_idx[j, k] = s
                out_score[j, k] = sc
                filled[j] = k + 1
                if filled[j] == K:
                    _track_worst(out_score, wslot, worst, j, K)
            elif sc < worst[j]:
                m = wslot[j]
                out_idx[j, m] = s
                out_score[j, m] = sc
                _track_worst(out_score, wslot, worst, j, K)


@njit(cache=True)
def window_distances(win_pos, win_rot, cand, sp, sq, wb, wi, inv_h, out):
    """The paper's window distance D (``engine.response.search``) of simulation window j
    (sp[j] (W, n, 3), sq[j] (W, n, 4), aligned) against the library windows cand[j, :]
    (win_pos / win_rot (S, W, n, 3/4), aligned; -1: skipped, inf): out[j, k] =
    sum_i wi[i] sum_b wb[j, b] (|dp| inv_h + 2 acos|q.q| / 2). Not fastmath: it is compared
    with the brute-force reference to 1e-9."""
    nsim, K = cand.shape
    W = win_pos.shape[1]
    n = win_pos.shape[2]
    for j in range(nsim):
        for k in range(K):
            s = cand[j, k]
            if s < 0:
                out[j, k] = np.inf
                continue
            total = 0.0
            for i in range(W):
                acc = 0.0
                for b in range(n):
                    dx = win_pos[s, i, b, 0] - sp[j, i, b, 0]
                    dy = win_pos[s, i, b, 1] - sp[j, i, b, 1]
                    dz = win_pos[s, i, b, 2] - sp[j, i, b, 2]
                    dp = math.sqrt(dx * dx + dy * dy + dz * dz) * inv_h
                    dot = abs(win_rot[s, i, b, 0] * sq[j, i, b, 0] + win_rot[s, i, b, 1] * sq[j, i, b, 1]
                              + win_rot[s, i, b, 2] * sq[j, i, b, 2] + win_rot[s, i, b, 3] * sq[j, i, b, 3])
                    if dot > 1.0:
                        dot = 1.0
                    acc += wb[j, b] * (dp + math.acos(dot))
                total += wi[i] * acc
            out[j, k] = total
