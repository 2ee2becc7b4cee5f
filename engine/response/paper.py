"""The impact response as the paper wrote it (Zordan, Majkowska, Chiu, Fast 2005), offline.

``engine.response.impact`` answers a hit inside the game's frames: Simulation 1 in slices
during the reaction delay, Simulation 2 live, a causal hand-off. This module runs the
paper's pipeline whole, ahead of display, for comparison (issue 13 item 6):

    res = paper_response(char, "spine1", impulse=(0, 60, 0))
    res.seconds          # {'sim1': .., 'search': .., 'sim2': .., 'blend': .., 'total': ..}
    res.pos, res.rot     # (F, n, 3), (F, n, 4): what is shown from the impact on, at ``rate``
    res.clip, res.clip_time, res.place_pos, res.place_yaw   # where animation takes over

1. **Simulation 1** from the impact (the displayed pose and its finite-difference
   velocities, as ``Character.hit`` starts), at the paper's step (0.5 ms, section 5),
   friction 1.0, the servos holding the interrupted pose (the live mode's choice, see
   ``impact``'s docstring), up to ``match_max`` plus a window.
2. **The full search**: every culled library window (``search(..., exhaustive=True)``, no
   coarse prefilter) against every simulation start from ``match_min`` (pushed later while
   contact lasts) to ``match_max``; the found clip is aligned on Simulation 1's root (yaw and
   ground-plane translation), as the paper aligns it.
3. **Simulation 2**, re-run from the impact at friction 0.5 and the same step: the servos
   hold the interrupted pose for the reaction delay, then slerp with ease-in/out toward the
   found clip's pose at the match (section 4), up to the match time ``T``.
4. **The final blend** (section 4): Simulation 2's end differs from the found clip at its
   matched frame; that error is spread linearly over the transition. The root's position
   error at ``T`` is added with weight t / T ("spreading the root position error over the
   whole sequence"), each body's rotation error at ``T`` is slerped in with the same linear
   weight, and the bodies hang from the root through their joints (so the blend opens no
   joint). At ``T`` the shown pose is the clip's: animation takes over with no offset.

The blend needs Simulation 2's end before its first frame is shown, so the whole response
is computed before the hit is displayed: ``seconds['total']`` is the delay a game would
have to hide (the paper: about a minute on its machine). The live mode replaces step 4 by
a causal offset decay and steps 1-3 by slices inside the frames.

No collisions between bodies during the blend (the paper has none either, section 5); the
blend keeps each body no lower than it rests on the terrain, as the live hand-off does.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from engine.physics import step
from engine.physics._kernels import terrain_sample
from engine.response.impact import ImpactParams, ImpactResponse, _qconj, _qmul, _qrot, _slerp_into
from engine.response.library import MotionLibrary
from engine.response.search import SearchResult, search, window_features

PAPER_STEP = 0.0005      # s: the paper's simulation step ("about 0.0005 s", section 5)


@dataclass
class PaperResult:
    """One hit answered offline; every array starts at the impact tick."""

    t: np.ndarray                 #: (F,) s after the impact, at ``rate``
    pos: np.ndarray               #: (F, n, 3) the shown pose: the final blend to ``T``, the clip after
    rot: np.ndarray               #: (F, n, 4)
    sim2_pos: np.ndarray          #: (K + 1, n, 3) Simulation 2 at the same times, to ``T``
    sim2_rot: np.ndarray
    sim1_t: np.ndarray            #: (M,) s after the impact, at the library's rate
    sim1_pos: np.ndarray          #: (M, n, 3) Simulation 1
    sim1_rot: np.ndarray
    handoff: float                #: T, s: the match time; the clip alone from here
    match: SearchResult
    clip: object                  #: the found Animation (None for a gait cycle)
    clip_time: float              #: its time at ``handoff``, s
    place_pos: np.ndarray         #: the clip's placement (ground plane), world
    place_yaw: float              #: ... and heading, rad
    seconds: dict                 #: CPU seconds per stage: sim1, search, sim2, blend, total
    substep: float                #: the simulations' step, s
    rate: float                   #: frames per second of ``t``/``pos``/``rot``


def paper_response(char, body, impulse, point=None, duration: float = 0.0, *,
                   params: ImpactParams | None = None, substep: float = PAPER_STEP, rate: float = 60.0,
                   after: float = 0.5, library: MotionLibrary | None = None) -> PaperResult:
    """The paper's offline response to a hit on ``char`` now (see the module docstring).

    ``body``, ``impulse`` (N s, world), ``point`` and ``duration`` as ``Character.hit`` takes
    them, with its checks and errors (``ImpactError`` naming the body and the value). The
    character is not changed: its pose at the impact is read, nothing is written back.
    ``substep``: both simulations' step, s (the paper's 0.5 ms by default); ``rate``: frames
    per second of the result; ``after``: seconds of the found clip shown after the match."""
    if not (isinstance(substep, (int, float)) and math.isfinite(substep) and 1e-5 <= substep <= 0.01):
        raise ValueError(f"paper_response: substep must be 1e-5 .. 0.01 s, got {substep!r}")
    if not (isinstance(rate, (int, float)) and math.isfinite(rate) and 10.0 <= rate <= 1000.0):
        raise ValueError(f"paper_response: rate must be 10 .. 1000 frames per second, got {rate!r}")
    if not (isinstance(after, (int, float)) and math.isfinite(after) and 0.0 <= after <= 10.0):
        raise ValueError(f"paper_response: after must be 0 .. 10 s, got {after!r}")
    p = dataclasses.replace(params or ImpactParams(), substep=float(substep), lookahead_substep=float(substep))
    r = ImpactResponse(char, p, library=library)
    lib = r.library                       # built (or loaded) before the clock starts: a game has it
    r.hit(body, impulse, point, duration)
    start = r.sim2.copy()                 # Simulation 2 starts where Simulation 1 does
    c = char.creature
    fdt = r._frame_dt

    # 1. Simulation 1, whole
    t0 = time.perf_counter()
    r._advance_sim1(1e9)
    t1 = time.perf_counter()

    # 2. The full search over the paper's window of match times
    lo = min(p.match_min + min(r._contact_end, p.contact_push), p.match_max)
    k0 = max(int(math.ceil(lo / fdt - 1e-9)), 1)
    last = r._sim1_count - lib.window
    k1 = min(max(k0, int(p.match_max / fdt + 1e-9)), last)
    k0 = min(k0, k1)
    feats = window_features(c, r._sim1_pos[: r._sim1_count], r._sim1_rot[: r._sim1_count])
    res = search(lib, feats, k0, k1, allow_gait=r.locomoting(), exhaustive=True, push=r._push)
    t2 = time.perf_counter()

    # 3. Simulation 2 from the impact to the match time T
    T = res.sim_frame * fdt
    K = max(int(round(T * rate)), 1)
    dt = T / K
    r.sim2 = start                        # (Simulation 1 kept its own copy of the contact: r._contact is whole)
    r.match = res
    r._found_down = lib.goes_down(res.lib_frame)     # the balance fades only into a fall, as live
    r.entry = lib.entries[res.clip]
    r._handoff = T
    r._plan_time = min(p.reaction_delay, T)
    if r.stand2 is not None:
        r.stand2.reset()
    n = c.nbody
    s2p = np.empty((K + 1, n, 3))
    s2q = np.empty((K + 1, n, 4))
    anim_pos = np.asarray(char.world_positions, float)
    anim_rot = np.asarray(char.world_rotations, float)
    r._entry_t = 0.0
    r._physics_pose(anim_pos, anim_rot)
    s2p[0], s2q[0] = r._phys_pos, r._phys_rot
    sub = max(1, int(math.ceil(dt / p.substep - 1e-9)))
    r.time = 0.0
    r._balance = 1.0
    for k in range(1, K + 1):
        r.time = (k - 1) * dt
        if r.time >= r._plan_time:
            r._transition_targets()          # theta_d: hold -> found clip, ease-in/out
        r._apply_contacts(r.model2, r.sim2, r._contact, dt)
        if r.stand2 is not None and p.stand_live:
            r.stand2.apply(r.sim2, r._balance, dt)
        step(r.model2, r.sim2, dt, substeps=sub)
        r._entry_t += dt
        r._physics_pose(anim_pos, anim_rot)
        s2p[k], s2q[k] = r._phys_pos, r._phys_rot
    t3 = time.perf_counter()

    # 4. The final blend: Simulation 2's error against the clip at T, spread linearly
    clip_p, clip_q = _placed(lib, res.lib_frame, res.place_pos, res.place_yaw)
    root_err = clip_p[0] - s2p[K, 0]
    rot_err = _qmul(clip_q, _qconj(s2q[K]))
    rot_err *= np.where(rot_err[:, :1] < 0.0, -1.0, 1.0)
    ident = np.zeros_like(rot_err)
    ident[:, 0] = 1.0
    nafter = int(round(after * rate))
    F = K + 1 + nafter
    out_p = np.empty((F, n, 3))
    out_q = np.empty((F, n, 4))
    e = np.empty((n, 4))
    for k in range(K + 1):
        u = k / K
        _slerp_into(ident, rot_err, u, e)
        out_q[k] = _qmul(e, s2q[k])
        # Simulation 2's pose carries the displayed pose's joint gaps at the impact, decaying
        # (``ImpactResponse._physics_pose``); the bodies hang from the root without them, then
        # get them back, so the first frame is the displayed pose
        tk = k * dt
        gap = (1.0 + p.blend_omega * tk) * math.exp(-p.blend_omega * tk) if tk < p.blend_time else 0.0
        out_p[k] = _hang(r, s2p[k, 0] - gap * r._entry_res[0] + u * root_err, out_q[k]) + gap * r._entry_res
    out_p[K], out_q[K] = clip_p, clip_q       # exactly the clip where it takes over
    _above_terrain(r, out_p[: K + 1], s2p, clip_p)
    # the clip after the match, from the library's frames (linear in time between them)
    i_end = int(np.searchsorted(lib.clip_of, lib.clip_of[res.lib_frame], side="right")) - 1
    for j in range(1, nafter + 1):
        x = res.lib_frame + j / (rate * fdt)
        f0 = min(int(x), i_end)
        f1 = min(f0 + 1, i_end)
        w = x - int(x) if f1 > f0 else 0.0
        pa, qa = _placed(lib, f0, res.place_pos, res.place_yaw)
        pb, qb = _placed(lib, f1, res.place_pos, res.place_yaw)
        out_p[K + j] = (1.0 - w) * pa + w * pb
        _slerp_into(qa, qb, w, out_q[K + j])
    t4 = time.perf_counter()

    seconds = dict(sim1=t1 - t0, search=t2 - t1, sim2=t3 - t2, blend=t4 - t3, total=t4 - t0)
    m = r._sim1_count
    return PaperResult(
        t=np.arange(F) * dt if nafter == 0 else np.r_[np.arange(K + 1) * dt, T + np.arange(1, nafter + 1) / rate],
        pos=out_p, rot=out_q, sim2_pos=s2p, sim2_rot=s2q,
        sim1_t=np.arange(m) * fdt, sim1_pos=r._sim1_pos[:m].copy(), sim1_rot=r._sim1_rot[:m].copy(),
        handoff=T, match=res, clip=r.entry.animation, clip_time=res.clip_time,
        place_pos=np.asarray(res.place_pos, float), place_yaw=float(res.place_yaw),
        seconds=seconds, substep=float(p.substep), rate=float(rate))


def _placed(lib, f: int, place_pos, yaw: float):
    """Library frame ``f`` (character space) placed at ``place_pos`` turned by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    q = np.array([math.cos(0.5 * yaw), 0.0, 0.0, math.sin(0.5 * yaw)])
    lp = lib.pos[f]
    pos = np.stack([c * lp[:, 0] - s * lp[:, 1], s * lp[:, 0] + c * lp[:, 1], lp[:, 2]], axis=1)
    pos += np.asarray(place_pos, float)
    rot = _qmul(np.broadcast_to(q, lib.rot[f].shape), lib.rot[f])
    return pos, rot


def _hang(r: ImpactResponse, root, rot) -> np.ndarray:
    """Body positions for rotations ``rot`` with the root at ``root``: each body hung from its
    parent's joint point in the physics model (closed joints)."""
    out = np.empty((rot.shape[0], 3))
    out[0] = root
    for bs, ps, ap, ac in r._join_levels:
        out[bs] = out[ps] + _qrot(rot[ps], ap) - _qrot(rot[bs], ac)
    return out


def _above_terrain(r: ImpactResponse, pos, sim_pos, clip_pos) -> None:
    """No blended body lower than it rests on the terrain, or than Simulation 2 or the clip
    put it (the blend adds no depth of its own)."""
    t = r.model2.terrain
    for k in range(pos.shape[0]):
        for b in range(pos.shape[1]):
            h = terrain_sample(t.height, t.x0, t.y0, t.cell, float(pos[k, b, 0]), float(pos[k, b, 1]))[0]
            low = min(h + r._rest_height[b], sim_pos[k, b, 2], clip_pos[b, 2])
            if pos[k, b, 2] < low:
                pos[k, b, 2] = low


__all__ = ["PAPER_STEP", "PaperResult", "paper_response"]
