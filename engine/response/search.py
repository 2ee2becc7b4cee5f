"""The search for where to re-enter animation (Zordan et al. 2005 section 3).

Windows of Simulation 1's trajectory against windows of the library. Both windows are
normalized by aligning their roots at the window's first frame by yaw about +Z and
translation in the ground plane only (so the tilt of a fall counts). The distance is

    D = sum_i w_i sum_b ( wp_b |p_b(sim_i) - p_b(lib_i)| / h + wq_b angle(q_b(sim_i), q_b(lib_i)) )

with, all from the creature's morphology, never tuned per creature:
    wp_b   the body's share of the mass divided by (1 + its depth in edges from the root):
           heavy trunk bodies dominate, limbs (far, light) count less because "differences
           in the positions of the limbs can be more easily modified" by the transition.
           Normalized to sum 1; positions are divided by the creature's height h, so the
           distance is the same for a mouse and a giant.
    support the foot nearest the centre of mass (ground plane) at the sim window's first
           frame gets +1 (as much as all other bodies together): a match that moves the
           supporting foot would make it slide (paper: "the closest ground-support body").
    wq_b   0.5 wp_b (radians against fractions of the height: a 0.1 rad tilt of the trunk
           costs as much as a 5% of height shift).
    w_i    1 - 0.75 (i / (W - 1))^2: quadratic, highest at the window's start.

The push (``search(..., push=J)``, the hits' horizontal impulse): a library window whose
entry still carries the root a distance t (``MotionLibrary.travel``: a stagger's steps, a
fall's slide) costs, on top of D,

    T = (sum_i w_i) (|t| - t . j) / h          j the push's direction in the window's heading

zero for a clip played in place or one that travels along the push, 2 (sum w_i) |t| / h for
one that travels against it: as if the whole window's root stood that far off. The paper has
no such term; its window (0.2 s) sees the pose, not where the re-entered clip will carry the
body, and a body pushed far over its feet springs back under the servos within that time:
the windows of a stagger stepping back then match best (the bird hit at the pelvis from
behind at 2.1 m/s, 40% of its height along the push, re-entered a stagger that stepped it
23% of its height back, s40). The issue's staggers step *toward the push*. The prefilter
below ranks windows by pose alone; T re-ranks its best (and the refinement's) windows.

Unique-frame culling keeps the library starts that differ from the last kept one by
``library.UNIQUE_TOL``; the best culled window is then refined over every start within
``REFINE`` frames of it and every simulation start within ``REFINE`` frames.

Coarse to fine (a game frame holds a 20,000-frame library): every culled window has a
short feature vector (``build_prefilter``): the positions of the heaviest bodies (by
``wp_b``, up to ``PREFILTER_BODIES``, together most of the weight) and the x and z axes
of the heaviest two, at the window's first and last frames, each scaled by the square root of its
weight, so the squared Euclidean distance between two vectors is a weighted sum of
squares of the same terms D adds up. One matrix product scores every culled window
against every simulation start; only the ``PREFILTER_K`` best per start get the exact
distance D (the support foot included), and the refinement runs around the best of those.
``search(..., exhaustive=True)`` scores D on every culled window (tests; the benchmark's
recall figure compares the two). With the 8 heaviest bodies and 2 axes (until s38) the
prefilter missed the exhaustive search's window in 7 of 12 trunk hits on the humanoid
(recall 0.42, found D up to 1.23 times the best): near a held pose the windows differ in
the light bodies (arms, head), which it did not see, and its top 32 held none of the best.
With up to 32 bodies (all of the humanoid's) and 6 axes, 12 of 12 (recall 1.0) at the same
search time (2.2 ms median on a loaded machine; the feature rows are 222 floats instead of 72).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from engine.response import _kernels as K

REFINE = 3
SIM_STRIDE = 6          # coarse simulation starts every 0.2 s at 30 Hz (the refinement covers +-0.1 s)
PREFILTER_BODIES = 32   # positions of at most this many heaviest bodies in the prefilter (8 until s38: above)
PREFILTER_AXES = 6      # axes of this many (2 until s38)
PREFILTER_K = 32        # windows per simulation start that get the exact distance


class SearchResult(NamedTuple):
    clip: int
    clip_time: float
    lib_frame: int
    sim_frame: int
    distance: float
    place_yaw: float
    place_pos: np.ndarray
    candidates: int


def _rest_yaw(creature) -> float:
    q = creature.body_rest_rot[0]
    return float(np.arctan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] ** 2 + q[3] ** 2)))


def yaw_of(creature, root_rot, root_pos):
    """Heading (rad about +Z) of the root's forward axis relative to its rest, and the
    root's ground-plane position, per row."""
    q = np.asarray(root_rot).reshape(-1, 4)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    rest = creature.body_rest_rot[0]
    # forward = R(q R_rest^-1) X: use the rotated rest forward
    rw, rx, ry, rz = rest
    # q * conj(rest)
    cw = w * rw + x * rx + y * ry + z * rz
    cx = -w * rx + x * rw - y * rz + z * ry
    cy = -w * ry + x * rz + y * rw - z * rx
    cz = -w * rz - x * ry + y * rx + z * rw
    fx = 1 - 2 * (cy * cy + cz * cz)
    fy = 2 * (cx * cy + cw * cz)
    yaw = np.arctan2(fy, fx)
    return yaw, np.asarray(root_pos).reshape(-1, 3)[:, :2].copy()


def body_weights(creature) -> np.ndarray:
    m = np.prod(np.maximum(np.asarray(creature.body_extent, float), 1e-6), axis=1)   # volume ~ mass
    w = (m / m.sum()) / (1.0 + np.asarray(creature.body_depth, float))
    return w / w.sum()


def _unyaw(yaw, xy, pos, rot):
    """Positions and rotations (..., n, 3/4) expressed in the frame of heading ``yaw`` at
    ground point ``xy`` (broadcast over the leading axes)."""
    c, s = np.cos(-yaw), np.sin(-yaw)
    px = pos[..., 0] - xy[..., 0:1]
    py = pos[..., 1] - xy[..., 1:2]
    out_p = np.empty_like(pos)
    out_p[..., 0] = c[..., None] * px - s[..., None] * py
    out_p[..., 1] = s[..., None] * px + c[..., None] * py
    out_p[..., 2] = pos[..., 2]
    hw, hz = np.cos(-yaw / 2)[..., None], np.sin(-yaw / 2)[..., None]
    w, x, y, z = rot[..., 0], rot[..., 1], rot[..., 2], rot[..., 3]
    out_q = np.empty_like(rot)
    out_q[..., 0] = hw * w - hz * z
    out_q[..., 1] = hw * x - hz * y
    out_q[..., 2] = hw * y + hz * x
    out_q[..., 3] = hw * z + hz * w
    return out_p, out_q


def library_windows(lib, starts):
    """(S, W, n, 3), (S, W, n, 4): the library windows at ``starts`` in their first frame's
    yaw frame."""
    idx = starts[:, None] + np.arange(lib.window)[None, :]
    yaw = lib.yaw[starts][:, None].repeat(lib.window, 1)
    xy = lib.xy[starts][:, None, :].repeat(lib.window, 1)
    return _unyaw(yaw, xy, lib.pos[idx], lib.rot[idx])


def frame_distance_rows(creature, pa, ra, pb, rb, w) -> np.ndarray:
    h = max(creature.height, 1e-6)
    dp = np.linalg.norm(pa - pb, axis=-1) / h
    dq = 2 * np.arccos(np.clip(np.abs(np.sum(ra * rb, axis=-1)), 0.0, 1.0))
    return (dp + 0.5 * dq) @ w


class SimFeatures(NamedTuple):
    pos: np.ndarray
    rot: np.ndarray
    yaw: np.ndarray
    xy: np.ndarray
    support_body: np.ndarray   # per sim frame, the support foot (-1: none)


def window_features(creature, pos, rot) -> SimFeatures:
    yaw, xy = yaw_of(creature, rot[:, 0], pos[:, 0])
    feet = np.asarray(creature.leg_foot, np.int64)
    sup = np.full(pos.shape[0], -1, np.int64)
    if feet.size:
        m = np.prod(np.maximum(np.asarray(creature.body_extent, float), 1e-6), axis=1)
        com = np.einsum("b,fbk->fk", m / m.sum(), pos)
        d = np.linalg.norm(pos[:, feet, :2] - com[:, None, :2], axis=-1)
        sup = feet[np.argmin(d, axis=1)]
    return SimFeatures(pos, rot, yaw, xy, sup)


def _sim_window(lib, f: SimFeatures, k: int):
    W = lib.window
    yaw = np.full(W, f.yaw[k])
    xy = np.repeat(f.xy[k][None], W, 0)
    return _unyaw(yaw, xy, f.pos[k:k + W], f.rot[k:k + W])


def window_weights(W: int) -> np.ndarray:
    i = np.arange(W) / max(W - 1, 1)
    return 1.0 - 0.75 * i * i


class Prefilter(NamedTuple):
    bodies: np.ndarray      # (m,) bodies whose positions are features
    axes: np.ndarray        # (a,) bodies whose x and z axes are features
    frames: np.ndarray      # window frames sampled
    scale_pos: np.ndarray   # (frames, m) sqrt(w_i wp_b) / h
    scale_ax: np.ndarray    # (frames, a) sqrt(w_i 0.5 wp_b) / 2 (chord of an axis ~ the angle; D has 0.5 angle)
    feats: np.ndarray       # (S, D) float32, the culled windows
    sq: np.ndarray          # (S,) |feats|^2
    feet: np.ndarray        # (nfeet,) foot bodies
    foot_feats: np.ndarray  # (nfeet, S, frames * 3) float32, sqrt(w_i) p / h (the support term's weight 1)
    foot_sq: np.ndarray     # (nfeet, S)


def _axes_of(rot):
    """x and z axes (..., 6) of unit quaternions (..., 4)."""
    w, x, y, z = rot[..., 0], rot[..., 1], rot[..., 2], rot[..., 3]
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),
                     2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)


def _feature_rows(pf: Prefilter, wpos, wrot):
    """(N, D) prefilter features of aligned windows (N, W, n, 3/4)."""
    fr = pf.frames
    p = wpos[:, fr][:, :, pf.bodies] * pf.scale_pos[None, :, :, None]
    a = _axes_of(wrot[:, fr][:, :, pf.axes]) * pf.scale_ax[None, :, :, None]
    return np.concatenate([p.reshape(len(wpos), -1), a.reshape(len(wpos), -1)], axis=1).astype(np.float32)


def _foot_rows(pf: Prefilter, wpos, foot: int, h: float):
    fr = pf.frames
    wi = np.sqrt(window_weights(wpos.shape[1])[fr])
    return (wpos[:, fr, foot] * (wi[None, :, None] / h)).reshape(len(wpos), -1).astype(np.float32)


def build_prefilter(lib) -> Prefilter:
    c = lib.creature
    h = max(c.height, 1e-6)
    w = lib.weights
    order = np.argsort(-w, kind="stable")
    m = int(min(PREFILTER_BODIES, len(order)))
    bodies = np.sort(order[:m])
    axes = np.sort(order[: min(PREFILTER_AXES, len(order))])
    W = lib.window
    frames = np.unique(np.array([0, W - 1]))
    wi = window_weights(W)[frames]
    scale_pos = np.sqrt(wi[:, None] * w[bodies][None, :]) / h
    scale_ax = np.sqrt(wi[:, None] * 0.5 * w[axes][None, :]) * 0.5
    pf = Prefilter(bodies, axes, frames, scale_pos, scale_ax, np.zeros((0, 0), np.float32), np.zeros(0, np.float32),
                   np.asarray(c.leg_foot, np.int64), np.zeros((0, 0, 0), np.float32), np.zeros((0, 0), np.float32))
    feats = _feature_rows(pf, lib.win_pos, lib.win_rot)
    foot_feats = np.stack([_foot_rows(pf, lib.win_pos, int(b), h) for b in pf.feet]) if pf.feet.size else \
        np.zeros((0, len(feats), len(frames) * 3), np.float32)
    return pf._replace(feats=feats, sq=np.einsum("sd,sd->s", feats, feats), foot_feats=foot_feats,
                       foot_sq=np.einsum("fsd,fsd->fs", foot_feats, foot_feats))


def _sim_windows(lib, f: SimFeatures, ks):
    W = lib.window
    idx = np.asarray(ks)[:, None] + np.arange(W)[None, :]
    yaw = np.repeat(f.yaw[np.asarray(ks)][:, None], W, 1)
    xy = np.repeat(f.xy[np.asarray(ks)][:, None, :], W, 1)
    return _unyaw(yaw, xy, f.pos[idx], f.rot[idx])


def _travel_cost(lib, f: SimFeatures, ks, frames, push, wsum: float, h: float) -> np.ndarray:
    """T (module docstring) of library frames ``frames`` (nsim, K; -1 ignored) against the
    sim starts ``ks`` (nsim,)."""
    travel = getattr(lib, "travel", None)
    out = np.zeros(np.shape(frames))
    if push is None or travel is None:
        return out
    p = np.asarray(push, float)[:2]
    n = float(np.linalg.norm(p))
    if n <= 0.0:
        return out
    yaw = f.yaw[np.asarray(ks)]
    ang = np.arctan2(p[1], p[0]) - yaw                       # the push in each sim start's heading
    j = np.stack([np.cos(ang), np.sin(ang)], axis=1)          # (nsim, 2)
    fr = np.asarray(frames)
    t = travel[np.maximum(fr, 0)]                             # (nsim, K, 2)
    cost = np.linalg.norm(t, axis=-1) - np.einsum("jkc,jc->jk", t, j)
    out[:] = np.where(fr >= 0, wsum * cost / h, 0.0)
    return out


def search(lib, f: SimFeatures, k0: int, k1: int, *, allow_gait: bool = True, exhaustive: bool = False,
           push=None) -> SearchResult:
    """The best (sim start in k0..k1, library start) pair; see the module docstring.
    ``push``: the hits' impulse (world, N s; its ground-plane direction is used), or None."""
    h = max(lib.creature.height, 1e-6)
    wi = window_weights(lib.window)
    ks = list(range(k0, k1 + 1, SIM_STRIDE)) or [k0]
    if ks[-1] != k1:
        ks.append(k1)
    allowed = None
    is_gait = getattr(lib, "is_gait", None)
    if not allow_gait and is_gait is not None and is_gait.any():
        allowed = ~is_gait[lib.clip_of[lib.starts]]
    sps, sqs = _sim_windows(lib, f, ks)
    pf = getattr(lib, "prefilter", None)
    S = len(lib.starts)
    nsim = len(ks)
    wb = np.repeat(lib.weights[None, :], nsim, 0)
    sup = f.support_body[np.asarray(ks)]
    has = sup >= 0
    wb[np.flatnonzero(has), sup[has]] += 1.0
    if not exhaustive and pf is not None and S > PREFILTER_K:
        q = _feature_rows(pf, sps, sqs)                                   # (nsim, D) float32
        E = pf.foot_feats.shape[2] if pf.foot_feats.ndim == 3 else len(pf.frames) * 3
        g = np.zeros((nsim, E), np.float32)
        foot_of = np.full(nsim, -1, np.int64)
        for j in np.flatnonzero(has):
            hit = np.flatnonzero(pf.feet == sup[j])
            if hit.size:
                foot_of[j] = int(hit[0])
                g[j] = _foot_rows(pf, sps[j:j + 1], int(sup[j]), h)[0]
        ok = allowed if allowed is not None else np.ones(S, bool)
        c = np.empty((nsim, PREFILTER_K), np.int64)
        scores = np.empty((nsim, PREFILTER_K))
        K.prefilter_topk(pf.feats, pf.sq, q, pf.foot_feats, pf.foot_sq, g, foot_of, ok, c, scores)
    else:
        c = np.repeat(np.arange(S, dtype=np.int64)[None, :], nsim, 0)
        if allowed is not None:
            c[:, ~allowed] = -1
    D = np.empty(c.shape)
    K.window_distances(lib.win_pos, lib.win_rot, c, sps, sqs, wb, wi, 1.0 / h, D)
    wsum = float(wi.sum())
    D += _travel_cost(lib, f, ks, np.where(c >= 0, lib.starts[np.maximum(c, 0)], -1), push, wsum, h)
    ncand = int(D.size)
    jj, ii = np.unravel_index(int(np.argmin(D)), D.shape)
    best = (float(D[jj, ii]), ks[jj], int(lib.starts[c[jj, ii]]))
    # local refinement: every start around the best, every sim start around it (one kernel call)
    _, kb, sb = best
    cand = np.arange(max(0, sb - REFINE), min(lib.frames, sb + REFINE + 1))
    cand = cand[lib.valid[cand] & (lib.clip_of[cand] == lib.clip_of[sb])]
    wpos, wrot = library_windows(lib, cand)
    rks = list(range(max(k0, kb - REFINE), min(k1, kb + REFINE) + 1))
    rp, rq = _sim_windows(lib, f, rks)
    rwb = np.repeat(lib.weights[None, :], len(rks), 0)
    rsup = f.support_body[np.asarray(rks)]
    rhas = rsup >= 0
    rwb[np.flatnonzero(rhas), rsup[rhas]] += 1.0
    rc = np.repeat(np.arange(len(cand), dtype=np.int64)[None, :], len(rks), 0)
    RD = np.empty(rc.shape)
    K.window_distances(np.ascontiguousarray(wpos), np.ascontiguousarray(wrot), rc, rp, rq, rwb, wi, 1.0 / h, RD)
    RD += _travel_cost(lib, f, rks, cand[rc], push, wsum, h)
    ncand += int(RD.size)
    jj, ii = np.unravel_index(int(np.argmin(RD)), RD.shape)
    if RD[jj, ii] < best[0]:
        best = (float(RD[jj, ii]), rks[jj], int(cand[ii]))
    dist, k, s = best
    yaw = float(f.yaw[k] - lib.yaw[s])
    c, sn = np.cos(yaw), np.sin(yaw)
    lx, ly = lib.xy[s]
    pos = np.array([f.xy[k, 0] - (c * lx - sn * ly), f.xy[k, 1] - (sn * lx + c * ly), 0.0])
    return SearchResult(int(lib.clip_of[s]), float(lib.time[s]), s, k, dist, yaw, pos, ncand)


def search_brute(lib, f: SimFeatures, k0: int, k1: int):
    """Reference: every valid library start against every sim start, loops (tests)."""
    h = max(lib.creature.height, 1e-6)
    wi = window_weights(lib.window)
    best = (np.inf, -1, -1)
    for k in range(k0, k1 + 1):
        sp, sq = _sim_window(lib, f, k)
        wb = lib.weights.copy()
        if f.support_body[k] >= 0:
            wb[f.support_body[k]] += 1.0
        for s in np.flatnonzero(lib.valid):
            lp, lq = library_windows(lib, np.array([s]))
            total = 0.0
            for i in range(lib.window):
                for b in range(lib.pos.shape[1]):
                    dp = np.linalg.norm(lp[0, i, b] - sp[i, b]) / h
                    dq = 2 * np.arccos(min(abs(float(np.dot(lq[0, i, b], sq[i, b]))), 1.0))
                    total += wi[i] * wb[b] * (dp + 0.5 * dq)
            if total < best[0]:
                best = (total, k, int(s))
    return best
