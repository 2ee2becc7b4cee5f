"""Gait quality and cost over every library creature and 100 random ones (issue 6).

    .venv/bin/python benchmarks/gait.py [--random 100] [--first-seed 0] [--no-library] [--seconds 8]
                                        [--terrain-only] [--only NAME]

Each creature walks ``engine.validation.gait.run_scenario``: a curved path with speed
changes, a sudden stop, a reverse and a sharp turn with a sidestep, on rolling terrain
scaled to its legs (``--flat``: also on flat ground; both are measured by default),
measured on the runtime's output (``char.world_positions`` after the IK). Prints a table
and ends with one JSON line: creatures, max_stance_slide_mm, max_touchdown_error_mm,
max_below_ground_mm, max_stretch_ratio, max_root_accel (leg lengths/s^2), max_foot_speed
(leg lengths/s), failures (creatures that crashed or produced non-finite output),
gait_ms_per_character (the gait stage alone, mean over the creatures),
tick_ms_per_character (the whole tick) and immobile (creatures that covered less than one
leg length: their gait found no stride the IK meets exactly, so they stand; a crawler's
"leg length" is the spacing of its pseudo-feet). ``--first-seed 100 --no-library`` runs a
held-out set of random creatures (seeds 100-199) that no gait choice was tuned on.

Continuity bound (``engine.validation.gait.continuity_bound``): foot speed <= 12 leg lengths/s
and root acceleration <= 25 leg lengths/s^2 (knee-less compass legs: 120, their hips' arc
turns over at each double support); ``over_continuity_bound`` lists the creatures past it.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import time
import traceback

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import engine  # noqa: E402
from engine.model import build_creature  # noqa: E402
from engine.model.random import random_creature_def  # noqa: E402
from engine.validation.gait import gait_ms, run_scenario  # noqa: E402


def creatures(n_random: int, only: str | None, first_seed: int = 0, library: bool = True):
    for path in sorted(glob.glob(os.path.join(ROOT, "creatures", "*.yaml"))) if library else ():
        name = os.path.basename(path)[:-5]
        if only and name != only:
            continue
        yield name, lambda p=path: engine.load_creature(p)
    if only and not only.startswith("random"):
        return
    for seed in range(first_seed, first_seed + n_random):
        if only and only != f"random{seed}":
            continue
        yield f"random{seed}", lambda s=seed: build_creature(random_creature_def(s))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--random", type=int, default=100)
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--only", default=None, help="one library creature or randomSEED")
    ap.add_argument("--first-seed", type=int, default=0, help="first random creature seed")
    ap.add_argument("--no-library", action="store_true", help="random creatures only")
    ap.add_argument("--terrain-only", action="store_true", help="skip the flat-ground run")
    args = ap.parse_args()
    rows = []
    failures = []
    t_start = time.perf_counter()
    print(f"{'creature':14s} {'mode':5s} {'legs':>4s} {'grp':>3s} {'slide':>7s} {'touch':>7s} {'below':>7s} "
          f"{'stretch':>7s} {'rootacc':>7s} {'footv':>6s} {'travel':>6s} {'gait':>6s} {'tick':>6s}  worst stance")
    for name, make in creatures(args.random, args.only, args.first_seed, not args.no_library):
        try:
            c = make()
            ms = []
            for terrain in ((True,) if args.terrain_only else (False, True)):
                ms.append(run_scenario(c, seconds=args.seconds, terrain=terrain))
            m = dict(ms[-1])
            for k in ("stance_slide_mm", "touchdown_error_mm", "below_ground_mm", "stretch_ratio", "root_accel",
                      "foot_speed"):
                m[k] = max(float(x[k]) for x in ms)
            worst = max(ms, key=lambda x: x["stance_slide_mm"])
            m["worst"] = worst["worst"]
            m["travel"] = min(float(x["travel"]) for x in ms)
            m["finite"] = all(x["finite"] for x in ms)
            m["over_bound"] = any(x["over_bound"] for x in ms)
            m["gait_ms"] = gait_ms(c)
            if not m["finite"]:
                failures.append(name)
        except Exception as exc:                                     # noqa: BLE001 - reported, not hidden
            failures.append(name)
            print(f"{name:14s} FAILED: {type(exc).__name__}: {exc}")
            traceback.print_exc(limit=3)
            continue
        rows.append(m)
        print(f"{name:14s} {m['mode']:5s} {m['legs']:4d} {m['groups']:3d} {m['stance_slide_mm']:7.3f} "
              f"{m['touchdown_error_mm']:7.3f} {m['below_ground_mm']:7.3f} {m['stretch_ratio']:7.3f} "
              f"{m['root_accel']:7.2f} {m['foot_speed']:6.2f} {m['travel']:6.2f} {m['gait_ms']:6.3f} "
              f"{m['tick_ms']:6.3f}  {m['worst']}",
              flush=True)
    legged = [r for r in rows if r["mode"] != "float"]
    walkers = [r for r in rows if r["mode"] == "walk"]

    def top(key, among):
        return round(max((float(r[key]) for r in among), default=0.0), 4)

    out = {
        "creatures": len(rows) + len([f for f in failures if f not in {r['creature'] for r in rows}]),
        "max_stance_slide_mm": top("stance_slide_mm", walkers),
        "max_touchdown_error_mm": top("touchdown_error_mm", walkers),
        "max_below_ground_mm": top("below_ground_mm", walkers),
        "crawler_max_stance_slide_mm": top("stance_slide_mm", [r for r in legged if r["mode"] == "crawl"]),
        "max_stretch_ratio": top("stretch_ratio", walkers),
        "max_root_accel": top("root_accel", rows),
        "max_foot_speed": top("foot_speed", walkers),
        "over_continuity_bound": [r["creature"] for r in rows if r["over_bound"]],
        "failures": failures,
        "immobile": [r["creature"] for r in rows if r["mode"] != "float" and r["travel"] < 1.0],
        "gait_ms_per_character": round(float(np.mean([r["gait_ms"] for r in rows])) if rows else 0.0, 4),
        "tick_ms_per_character": round(float(np.mean([r["tick_ms"] for r in rows])) if rows else 0.0, 4),
        "seconds": round(time.perf_counter() - t_start, 1),
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
