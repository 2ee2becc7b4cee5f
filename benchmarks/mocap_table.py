"""Tables 1 and 2 of Wilke & Semwal on Menagerie's integrator and the captures we have.

    .venv/bin/python benchmarks/mocap_table.py [--points 3] [--quick]

Table 1: per mode, the seeded Monte Carlo search (paper Algorithm 1) of (order, K_f,
K_vc) on one capture (the dance, frames 0-600: the paper tuned on its longest, most
varied capture), from the paper's start points ((100, 1) independent, (20, 1) skeletons;
K_vc in our metres is ~1 where the paper's is ~100).
Table 2: every capture (walks, jumps, dance, boxing) and mode with the tuned
parameters: mean squared positional error over joints and frames (m^2) and its variance
(m^4), as the paper's Table 2, for the paper's controller and with gravity compensation.
Ends with one JSON line holding every row.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from engine.io import load_bvh  # noqa: E402
from engine.paths import shared_data  # noqa: E402
from engine.response.tracking import MODES, MocapRig, TrackingParams, track, tune  # noqa: E402

MOCAP = str(shared_data("mocap"))  # $MENAGERIE_SHARED or ../shared
FILES = [
    ("walk", "cmu_02_01_walk.bvh"),
    ("walk (start-walk-stop)", "cmu_131_01_start_walk_stop_3dsmax.bvh"),
    ("jumps", "cmu_01_01_playground_forward_jumps.bvh"),
    ("dance", "cmu_05_06_dance_pirouettes.bvh"),
    ("boxing", "boxing_toes_punch_hit_fall.bvh"),
]
TUNE_FILE = "cmu_05_06_dance_pirouettes.bvh"
START = {"independent": (100.0, 1.0), "skeleton": (20.0, 1.0), "constrained": (20.0, 1.0)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=3, help="Monte Carlo points per mode (3)")
    ap.add_argument("--max-order", type=int, default=19)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="first 600 frames of every capture")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    clips = {name: load_bvh(os.path.join(MOCAP, name)) for _, name in FILES}

    tuned = {}
    rows1 = []
    for gc in (False, True):
        for mode in MODES:
            kf, kvc = START[mode]
            start = TrackingParams(order=5, k_f=kf, k_vc=kvc, gravity_comp=gc)
            rig = MocapRig(clips[TUNE_FILE], mode, params=start, frames=(0, 600))
            res = tune(rig, points=args.points, max_order=args.max_order, seed=args.seed, start=start,
                       step_f=1.0, step_vc=0.01)
            tuned[(mode, gc)] = res.best
            best = track(rig, res.best)
            rows1.append({"mode": mode, "gravity_comp": gc, "order": res.best.order, "k_f": res.best.k_f,
                          "k_vc": res.best.k_vc, "mse_m2": best.mse, "var_m4": best.var,
                          "points": args.points, "simulations": len(res.history)})
    print(f"Table 1: tuned on {TUNE_FILE} frames 0-600, {args.points} points x orders 3..{args.max_order}, "
          f"seed {args.seed}")
    print(f"{'mode':<14}{'g-comp':>7}{'n':>4}{'K_f':>10}{'K_vc':>8}{'mse m^2':>12}{'var m^4':>12}")
    for r in rows1:
        print(f"{r['mode']:<14}{str(r['gravity_comp']):>7}{r['order']:>4}{r['k_f']:>10.3f}{r['k_vc']:>8.4f}"
              f"{r['mse_m2']:>12.5f}{r['var_m4']:>12.3g}")

    rows2 = []
    for label, name in FILES:
        clip = clips[name]
        frames = (0, min(600, clip.nframe - 1)) if args.quick else None
        for gc in (False, True):
            for mode in MODES:
                p = tuned[(mode, gc)]
                rig = MocapRig(clip, mode, params=p, frames=frames)
                r = track(rig, p)
                rows2.append({"file": name, "motion": label, "mode": mode, "gravity_comp": gc,
                              "frames": rig.nframe, "seconds": round(rig.nframe * clip.frame_time, 2),
                              "mse_m2": r.mse, "var_m4": r.var, "final_mse_m2": r.final_mse,
                              "max_joint_separation_mm": r.max_joint_separation * 1000.0,
                              "realtime_factor": r.realtime_factor})
    print("\nTable 2: every capture with the tuned parameters (mean over joints and frames of e_p^2)")
    print(f"{'file':<40}{'mode':<13}{'g-comp':>7}{'s':>7}{'mse m^2':>11}{'var m^4':>11}{'last m^2':>10}"
          f"{'sep mm':>8}{'x rt':>7}")
    for r in rows2:
        print(f"{r['file']:<40}{r['mode']:<13}{str(r['gravity_comp']):>7}{r['seconds']:>7.1f}{r['mse_m2']:>11.4f}"
              f"{r['var_m4']:>11.3g}{r['final_mse_m2']:>10.4f}{r['max_joint_separation_mm']:>8.3f}"
              f"{r['realtime_factor']:>7.1f}")
    print(f"\n[{time.perf_counter() - t0:.1f} s]")
    print(json.dumps({"table1": rows1, "table2": rows2}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
