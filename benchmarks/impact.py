"""Impact response: search and decision time, per-tick cost during a response, success
of random hits (one, two and five in series) on library and random creatures.

    .venv/bin/python benchmarks/impact.py [--library 6] [--skip 0] [--spread N] [--random 5] [--first-seed 0] [--hits 4]
        [--seed 0] [--stand on|off|lookahead|live] [--lookahead-substep S] [--paper-hits 10]

A response succeeds when the output stays finite, the character is back on animation
(the found clip drives the pose again) within 2 s after the last hit, the hand-off ticks
(to physics, back to animation) and the animation after them turn no body more than 0.5
rad, no body centre goes more than 1 cm under the ground, and for a single hit strong
enough to move the creature (its momentum alone would carry it 2% of its size, the largest
extent, in 0.2 s) that moved the root more than 2% of its size, the root's ground-plane
displacement is within 60 degrees of the impulse (the physical ticks between the hand-offs
are not judged; ``physical_turn_*`` reports their largest turn per tick). Hits: a random body, a horizontal
direction, 0.2-2.5 m/s worth of the mass of the hit body's chain (``chain_mass``: its limb, or the
whole creature for a spine body; a tap to a knock-down).
Series: 2 and 5 hits 30-600 ms apart. The floors' timing keys (``decision_ms_*``,
``max_tick_ms_during_response``) are the 25-body humanoid's, as issue 13 states them, over
10 hits of its own; ``all_*`` are the same over every hit on every creature (the big ones
cost more). ``paper_mode_s``: the
median seconds of one response computed the paper's way, whole and ahead of display
(``engine.response.paper``, 0.5 ms step), over ``--paper-hits`` random hits on the humanoid. Ends with one JSON
line (keys as issue 13).
"""

from __future__ import annotations

import argparse
import dataclasses
import glob
import json
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

import engine  # noqa: E402
from engine.model import build_creature, random_creature_def  # noqa: E402
from engine.physics.world import rotvec_between  # noqa: E402
from engine.response import search as S  # noqa: E402
from engine.response.impact import ImpactParams, ImpactResponse, chain_mass  # noqa: E402
from engine.response.library import MotionLibrary, default_clips, library_for  # noqa: E402
from engine.response.paper import PAPER_STEP  # noqa: E402
from engine.runtime import Character  # noqa: E402

DT = 1 / 60
IDLE = engine.load_animation(os.path.join(ROOT, "animations", "idle_breathe.yaml"))


def _timed(resp, name, log):
    f = getattr(resp, name)

    def wrap(*a, **k):
        t = time.perf_counter()
        out = f(*a, **k)
        log.append(time.perf_counter() - t)
        return out
    setattr(resp, name, wrap)


def _stat(f, xs) -> float:
    """``f`` of ``xs``, 0 for none (``--library 0 --random 0`` times the humanoid alone)."""
    return float(f(xs)) if len(xs) else 0.0


def trial(creature, rng, nhits, stats, params=None):
    ch = Character(creature)
    if params is not None:
        ch.response = ImpactResponse(ch, params)
    try:
        ch.play(IDLE)
    except engine.MenagerieError:
        pass
    for _ in range(10):
        ch.tick(DT)
    hits, t = [], 0
    for _ in range(nhits):
        d = rng.normal(size=2)
        d /= np.linalg.norm(d)
        b = int(rng.integers(creature.nbody))
        J = np.array([d[0], d[1], 0.0]) * rng.uniform(0.2, 2.5) * chain_mass(creature, b)
        hits.append((t, b, J))
        t += int(rng.integers(2, 37))
    p0 = ch.world_positions[0].copy()
    prev = ch.world_rotations.copy()
    back, worst_turn, worst_impact, worst_anim, worst_phys, minz = None, 0.0, 0.0, 0.0, 0.0, np.inf
    back_clean = None
    last = hits[-1][0]
    for k in range(last + int(2.5 / DT)):
        phys = ch.reacting and ch.response.phase in ("burst", "transition")
        for tt, b, J in hits:
            if tt == k:
                ch.hit(b, J)
                if len(stats["wrapped"]) == 0 or stats["wrapped"][-1] is not ch.response:
                    _timed(ch.response, "_advance_sim1", stats["sim1"])
                    _timed(ch.response, "_plan", stats["plan"])
                    stats["wrapped"].append(ch.response)
        t0 = time.perf_counter()
        ch.tick(DT)
        dt_tick = time.perf_counter() - t0
        if ch.reacting:
            stats["tick"].append(dt_tick)
        if not (np.all(np.isfinite(ch.world_positions)) and np.all(np.isfinite(ch.world_rotations))):
            return False, "non-finite"
        turn = float(np.linalg.norm(rotvec_between(prev, ch.world_rotations), axis=1).max())
        if not phys and any(tt == k for tt, _, _ in hits):
            worst_impact = max(worst_impact, turn)      # the impact tick (includes the hit itself)
        elif not phys:
            worst_anim = max(worst_anim, turn)          # animation (the clip played after, resumed)
        elif not (ch.reacting and ch.response.phase in ("burst", "transition")):
            worst_turn = max(worst_turn, turn)          # the hand-off back to animation
        else:
            worst_phys = max(worst_phys, turn)          # physics alone (reported, not judged)
        prev = ch.world_rotations.copy()
        minz = min(minz, float(ch.world_positions[:, 2].min()))
        # back on an animation: the found clip drives the pose again (the hand-off's offset
        # may still be decaying on it: phase "blend"), as the issue has it; until s39 it
        # waited for the offset to be gone too (random 46: 2.017 s, a frame over)
        if k > last and back is None and not (ch.reacting and ch.response.phase in ("burst", "transition")):
            back = (k - last) * DT
        if k > last and back_clean is None and not ch.reacting:
            back_clean = (k - last) * DT
    stats.setdefault("impact_turn", []).append(worst_impact)
    stats.setdefault("handback_turn", []).append(worst_turn)
    stats.setdefault("anim_turn", []).append(worst_anim)
    stats.setdefault("phys_turn", []).append((worst_phys, creature.name))
    why = []
    if back is None or back > 2.0:
        why.append(f"not back in 2 s ({back})")
    if back_clean is None or back_clean > 2.0:
        stats.setdefault("offset_after_2s", []).append(creature.name)
    if worst_impact > 0.5:
        why.append(f"impact-tick turn {worst_impact:.2f} rad")
    if worst_turn > 0.5:
        why.append(f"hand-back turn {worst_turn:.2f} rad")
    if worst_anim > 0.5:
        why.append(f"animation turn {worst_anim:.2f} rad")
    if minz < -0.01:
        why.append(f"body centre {minz:.3f} m under ground")
    if nhits == 1:
        # "the root's displacement agrees with the hit's direction within 60 degrees for
        # hits strong enough to move it" (issue 13). Strong enough: the hit's momentum alone
        # would carry the whole creature 2% of its height in 0.2 s. Until s39 it read "the
        # root ended 2% of the height away", which counts every drift after a tap (an
        # antenna flicked, a light foot knocked: the clip re-entered carries the root a few
        # millimetres on a low creature) as a hit that moved it; that reading is kept as
        # ``root_moved_any_off`` in the stats.
        #
        # Lengths against the creature's size as the grid measures it (its largest extent,
        # engine.validation.cell): until s40 against its height, which called a 2 m snake
        # 7.5 cm tall "moved" by the 4 mm its idle sways its root and "strong enough to move"
        # by a 7 cm/s push. The height's reading is kept as ``root_off_by_height``.
        disp = (ch.world_positions[0] - p0)[:2]
        J = hits[0][2][:2]
        size = float(np.max(creature.size))
        v = float(np.linalg.norm(hits[0][2])) / chain_mass(creature, 0)
        cos = disp @ J / max(np.linalg.norm(disp) * np.linalg.norm(J), 1e-300)
        if cos < 0.5:
            off = f"root moved {np.degrees(np.arccos(cos)):.0f} deg off the hit"
            if np.linalg.norm(disp) > 0.02 * creature.height:
                stats.setdefault("root_moved_any_off", []).append(creature.name)
                if v * 0.2 >= 0.02 * creature.height:
                    stats.setdefault("root_off_by_height", []).append(creature.name)
            if np.linalg.norm(disp) > 0.02 * size and v * 0.2 >= 0.02 * size:
                why.append(off)
    return (not why), "; ".join(why)


def paper_trials(creature, rng, n, substep):
    """``n`` random single hits (as ``trial`` draws them) answered the paper's way, offline
    (``engine.response.paper``): per hit its stage times and whether the shown motion passes
    the same checks as a live response's (finite, no body over 0.5 rad in a 60 Hz frame, no
    body centre 1 cm under the ground, the root moving with the hit)."""
    from engine.response.paper import paper_response

    out = []
    for _ in range(n):
        ch = Character(creature)
        ch.play(IDLE)
        for _ in range(10):
            ch.tick(DT)
        d = rng.normal(size=2)
        d /= np.linalg.norm(d)
        b = int(rng.integers(creature.nbody))
        J = np.array([d[0], d[1], 0.0]) * rng.uniform(0.2, 2.5) * chain_mass(creature, b)
        r = paper_response(ch, b, J, substep=substep)
        turn = float(np.linalg.norm(rotvec_between(r.rot[:-1].reshape(-1, 4), r.rot[1:].reshape(-1, 4)),
                                    axis=1).max())
        disp = r.pos[-1, 0, :2] - r.pos[0, 0, :2]
        moved = np.linalg.norm(disp) > 0.02 * float(np.max(creature.size))   # the grid's size, as trial()
        along = (not moved) or float(disp @ J[:2]) / (np.linalg.norm(disp) * np.linalg.norm(J[:2])) > 0.5
        ok = bool(np.all(np.isfinite(r.pos)) and turn <= 0.5 and r.pos[..., 2].min() > -0.01 and along)
        out.append((r.seconds, ok, r.handoff))
    return out


def search_scaling(lib, feats):
    """Search ms (median of 5) on the humanoid's library cut or tiled to 1k, 10k, 100k frames."""
    out = {}
    for target in (1000, 10000, 100000):
        reps = max(1, int(np.ceil(target / lib.frames)))

        class L:  # noqa: N801 - a cut or tiled view of the library
            pass
        big = L()
        for name in ("creature", "rate", "window", "weights"):
            setattr(big, name, getattr(lib, name))
        big.pos = np.tile(lib.pos, (reps, 1, 1))[:target]
        big.rot = np.tile(lib.rot, (reps, 1, 1))[:target]
        big.clip_of = (np.arange(reps)[:, None] * 100000 + lib.clip_of[None]).reshape(-1)[:target]
        big.time = np.tile(lib.time, reps)[:target]
        big.valid = np.tile(lib.valid, reps)[:target].copy()
        big.valid[target - lib.window + 1:] = False
        big.yaw = np.tile(lib.yaw, reps)[:target]
        big.xy = np.tile(lib.xy, (reps, 1))[:target]
        st = np.concatenate([lib.starts + r * lib.frames for r in range(reps)])
        big.starts = st[(st < target)]
        big.starts = big.starts[big.valid[big.starts]]
        big.win_pos, big.win_rot = S.library_windows(big, big.starts)
        big.frames = target
        big.prefilter = S.build_prefilter(big)
        ts = []
        for _ in range(5):
            t = time.perf_counter()
            S.search(big, feats, 6, 30)
            ts.append(time.perf_counter() - t)
        out[str(target)] = round(1e3 * float(np.median(ts)), 2)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--library", type=int, default=6, help="library creatures (first N by name)")
    ap.add_argument("--random", type=int, default=5, help="random creatures (seeds --first-seed ..)")
    ap.add_argument("--hits", type=int, default=4, help="single hits per creature")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--first-seed", type=int, default=0, help="random creatures' first seed")
    ap.add_argument("--skip", type=int, default=0, help="library creatures: skip the first N by name")
    ap.add_argument("--stand", choices=("on", "off", "lookahead", "live"), default="on",
                    help="the standing controller as ImpactParams has it (on), in none, in the lookahead "
                         "only, or in both (live)")
    ap.add_argument("--lookahead-substep", type=float, default=None,
                    help="Simulation 1's substep, s (ImpactParams.lookahead_substep; default 1/240): the "
                         "lookahead is most of the decision's time")
    ap.add_argument("--spread", type=int, default=0, metavar="N",
                    help="N library creatures spread evenly over the library by name (instead of --library/--skip)")
    ap.add_argument("--paper-hits", type=int, default=10,
                    help="random single hits on the humanoid answered the paper's way, offline (paper_mode_s)")
    ap.add_argument("--creatures", nargs="*", default=None,
                    help="library creature names instead of the first --library N (random ones still by --random)")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    every = sorted(glob.glob(os.path.join(ROOT, "creatures", "*.yaml")))
    paths = every[args.skip: args.skip + args.library]
    if args.spread:
        # evenly over the whole library by name, not its first creatures (the snake, the
        # octopus and the spider sat past every set the first-N form made, s38)
        paths = [every[int(k)] for k in np.unique(np.linspace(0, len(every) - 1, min(args.spread, len(every))).round())]
    if args.creatures is not None:
        paths = [os.path.join(ROOT, "creatures", f"{n}.yaml") for n in args.creatures]
    params = {"on": None, "off": ImpactParams(stand=None),
              "lookahead": ImpactParams(stand_live=False), "live": ImpactParams(stand_live=True)}[args.stand]
    if args.lookahead_substep is not None:
        params = dataclasses.replace(params or ImpactParams(), lookahead_substep=args.lookahead_substep)
    seeds = range(args.first_seed, args.first_seed + args.random)
    creatures = [engine.load_creature(p) for p in paths] + [build_creature(random_creature_def(s)) for s in seeds]
    hum = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    t = time.perf_counter()
    lib = library_for(hum)
    load_s = time.perf_counter() - t
    t = time.perf_counter()
    MotionLibrary(hum, default_clips(), cache=False, progress=False)      # a fresh build, kernels warm
    build_s = time.perf_counter() - t
    print(f"humanoid library: {lib.frames} frames, {len(lib.starts)} unique starts, {len(lib.clips)} entries; "
          f"first {'loaded from the disk cache' if lib.from_cache else 'built'} in {load_s:.2f} s, "
          f"built afresh in {build_s:.2f} s")
    results = {1: [], 2: [], 5: []}
    stats = {"sim1": [], "plan": [], "tick": [], "wrapped": []}
    failures = []
    prepare_s = []
    for c in creatures:
        # the library and the kernels' first load ahead of the hits, as a game would
        # (Character.prepare_impacts): otherwise the first hit's tick carries them
        prepare_s.append(Character(c).prepare_impacts())
        for n, count in ((1, args.hits), (2, max(1, args.hits // 2)), (5, max(1, args.hits // 4))):
            for _ in range(count):
                ok, why = trial(c, rng, n, stats, params)
                results[n].append(ok)
                if not ok:
                    failures.append(f"{c.name} x{n}: {why}")
        print(f"  {c.name}: single {np.mean(results[1]):.2f} so far", flush=True)
    # the floors' own subject: the 25-body humanoid (its library >= 20,000 frames), 10 single
    # hits of its own (a separate random stream: the figures above do not change)
    Character(hum).prepare_impacts()
    hstats = {"sim1": [], "plan": [], "tick": [], "wrapped": []}
    hrng = np.random.default_rng(args.seed + 1000)
    hdec = []
    for _ in range(10):
        n0, p0 = len(hstats["sim1"]), len(hstats["plan"])
        trial(hum, hrng, 1, hstats, params)
        hdec.append(sum(hstats["sim1"][n0:]) + sum(hstats["plan"][p0:]))   # its lookahead slices + its search
    # search alone, on the humanoid, from a real Simulation 1
    ch = Character(hum)
    ch.play(IDLE)
    for _ in range(5):
        ch.tick(DT)
    ch.hit("spine2", (-60.0, 0, 0))
    for _ in range(12):
        ch.tick(DT)
    r = ch.response
    feats = S.window_features(hum, r._sim1_pos[: r._sim1_count], r._sim1_rot[: r._sim1_count])
    ts = []
    for _ in range(300):
        t = time.perf_counter()
        S.search(lib, feats, 6, 30)
        ts.append(time.perf_counter() - t)
    # recall of the coarse-to-fine search: the same window as scoring D on every culled one,
    # over hits on the trunk from four sides and three sizes (one hit, as until s38, read 0.0:
    # a shove that leaves the humanoid near its held pose, where many windows are close and the
    # prefilter's top PREFILTER_K missed idle_breathe for pick_fruit, D 0.0144 against 0.0171)
    same = []
    for J in [(x * m, y * m, 0.0) for x, y in ((1, 0), (0, 1), (-1, 0), (0, -1)) for m in (30.0, 60.0, 150.0)]:
        chr_ = Character(hum)
        chr_.play(IDLE)
        for _ in range(5):
            chr_.tick(DT)
        chr_.hit("spine2", J)
        for _ in range(12):
            chr_.tick(DT)
        rr = chr_.response
        ff = S.window_features(hum, rr._sim1_pos[: rr._sim1_count], rr._sim1_rot[: rr._sim1_count])
        for k0 in (6, 12):
            a = S.search(lib, ff, k0, 30)
            b = S.search(lib, ff, k0, 30, exhaustive=True)
            same.append(a.distance <= b.distance * (1 + 1e-9))
    scaling = search_scaling(lib, feats)
    # the paper's pipeline, offline at its 0.5 ms step, on the humanoid (issue 13 item 6)
    paper = paper_trials(hum, np.random.default_rng(args.seed + 2000), args.paper_hits, PAPER_STEP)
    paper_s = {k: round(float(np.median([p[0][k] for p in paper])), 3) for k in paper[0][0]} if paper else {}
    if paper:
        print(f"paper mode (humanoid, {len(paper)} hits, step {PAPER_STEP * 1e3:g} ms): median seconds per response "
              f"{paper_s}, success {np.mean([p[1] for p in paper]):.2f}, transition median "
              f"{np.median([p[2] for p in paper]):.2f} s")
    # decision = Simulation 1 slices + search, per hit (the plan includes the search)
    nplan = len(stats["plan"])
    sim1 = np.array(stats["sim1"])
    dec_per_hit = (sim1.sum() / max(nplan, 1)) + np.array(stats["plan"]) if nplan else np.zeros(1)
    out = dict(
        library_frames=lib.frames, unique_starts=int(len(lib.starts)),
        search_ms_median=round(1e3 * float(np.median(ts)), 2),
        search_ms_p99=round(1e3 * float(np.percentile(ts, 99)), 2),
        decision_ms_median=round(1e3 * float(np.median(hdec)), 2),
        decision_ms_p99=round(1e3 * float(np.percentile(hdec, 99)), 2),
        max_tick_ms_during_response=round(1e3 * float(np.max(hstats["tick"])), 2),
        all_decision_ms_median=round(1e3 * float(np.median(dec_per_hit)), 2),
        all_decision_ms_p99=round(1e3 * float(np.percentile(dec_per_hit, 99)), 2),
        sim1_slice_ms_max=round(1e3 * float(sim1.max()), 2) if sim1.size else 0.0,
        tick_ms_median_during_response=round(1e3 * _stat(np.median, stats["tick"]), 2),
        all_max_tick_ms_during_response=round(1e3 * _stat(np.max, stats["tick"]), 2),
        success_rate=round(_stat(np.mean, results[1]), 3), train2_success_rate=round(_stat(np.mean, results[2]), 3),
        train5_success_rate=round(_stat(np.mean, results[5]), 3), creatures=len(creatures),
        hits=int(len(results[1]) + 2 * len(results[2]) + 5 * len(results[5])),
        search_ms_by_library_frames=scaling, paper_mode_s=paper_s.get("total"), paper_mode_stages_s=paper_s,
        paper_mode_success_rate=round(float(np.mean([p[1] for p in paper])), 3) if paper else None,
        paper_mode_vs_live_decision=(round(paper_s["total"] / float(np.median(hdec)), 1)
                                     if paper and hdec else None), search_recall=round(float(np.mean(same)), 3),
        library_build_s=round(build_s, 2), library_load_s=round(load_s, 2),
        prepare_s_first=round(prepare_s[0], 3) if prepare_s else None,
        root_moved_any_off=len(stats.get("root_moved_any_off", [])),
        root_off_by_height=len(stats.get("root_off_by_height", [])),
        offset_after_2s=len(stats.get("offset_after_2s", [])),
        handback_turn_median=round(_stat(np.median, stats.get("handback_turn", [])), 3),
        handback_turn_max=round(_stat(np.max, stats.get("handback_turn", [])), 3),
        anim_turn_median=round(_stat(np.median, stats.get("anim_turn", [])), 3),
        anim_turn_max=round(_stat(np.max, stats.get("anim_turn", [])), 3),
        physical_turn_median=round(_stat(np.median, [t for t, _ in stats.get("phys_turn", [])]), 3),
        physical_turn_max=round(_stat(np.max, [t for t, _ in stats.get("phys_turn", [])]), 3),
    )
    print("failures:")
    for f in failures:
        print("  " + f)
    # the physical phase itself is not judged (a hit may fling a limb), but a body turning a
    # radian or more per tick there is a thrash worth seeing (s38: the snake, 2.3-3.1 rad)
    fast = {}
    for t, name in stats.get("phys_turn", []):
        if t >= 1.0:
            fast.setdefault(name, []).append(t)
    print("physics turning >= 1 rad in a tick:", {k: f"{len(v)} trials, max {max(v):.2f}" for k, v in fast.items()}
          or "none")
    print("search ms by library frames:", scaling)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
