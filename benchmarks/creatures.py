"""Random creatures: generate and build N seeds in memory, time both, count failures.

    .venv/bin/python benchmarks/creatures.py [--count 1000] [--seed 0]

Prints a table of per-creature times (generation: ``random_creature_def``; build: the
validating builder and morphology analysis, ``build_creature``), the distribution of
bodies, spine, legs, arms and heads, the failures with their seed and error (there must
be none), and ends with one JSON line of figures.

A failure is an exception from either step, a builder warning, a body-count outside
20-80, a foot more than 1 cm off the ground or a body more than 1 cm below it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from engine.model import build_creature  # noqa: E402
from engine.model.random import MAX_BODIES, MIN_BODIES, random_creature_def  # noqa: E402


def _lowest_corners(c) -> np.ndarray:
    """Lowest z of every body box: centre z minus |R row z| . extents."""
    w, x, y, z = c.body_rest_rot.T
    row = np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)
    return c.body_rest_pos[:, 2] - np.sum(np.abs(row) * c.body_extent, axis=1)


def _problem(c) -> str | None:
    if not MIN_BODIES <= c.nbody <= MAX_BODIES:
        return f"{c.nbody} bodies"
    low = _lowest_corners(c)
    if low.min() < -0.01:
        return f"body {c.body_names[int(np.argmin(low))]} {-low.min():.3g} m below the ground"
    if c.nleg and np.abs(low[c.leg_foot]).max() > 0.01:
        return "a foot off the ground"
    return None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)

    gen_ms, build_ms, failures = [], [], []
    rows = []
    t_all = time.perf_counter()
    for seed in range(args.seed, args.seed + args.count):
        try:
            t0 = time.perf_counter()
            cdef = random_creature_def(seed)
            t1 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                c = build_creature(cdef)
            t2 = time.perf_counter()
        except Exception as exc:  # noqa: BLE001 - every failure is reported with its seed
            failures.append((seed, f"{type(exc).__name__}: {exc}"))
            continue
        gen_ms.append(1e3 * (t1 - t0))
        build_ms.append(1e3 * (t2 - t1))
        problem = _problem(c)
        if problem:
            failures.append((seed, problem))
        k = c.counts()
        rows.append((k["bodies"], k["spine"], k["legs"], k["arms"], k["heads"], c.height,
                     "asymmetric" in c.description))
    wall = time.perf_counter() - t_all

    print(f"random creatures: seeds {args.seed}..{args.seed + args.count - 1}, wall {wall:.1f} s")
    print(f"{'step':<10}{'median ms':>11}{'mean ms':>10}{'p95 ms':>9}{'max ms':>9}")
    for name, ms in (("generate", gen_ms), ("build", build_ms)):
        a = np.array(ms) if ms else np.zeros(1)
        print(f"{name:<10}{np.median(a):>11.2f}{a.mean():>10.2f}{np.percentile(a, 95):>9.2f}{a.max():>9.2f}")
    figures = {"creatures": args.count, "failures": len(failures),
               "generate_ms_median": round(float(np.median(gen_ms)), 3) if gen_ms else None,
               "generate_ms_mean": round(float(np.mean(gen_ms)), 3) if gen_ms else None,
               "build_ms_median": round(float(np.median(build_ms)), 3) if build_ms else None,
               "build_ms_mean": round(float(np.mean(build_ms)), 3) if build_ms else None}
    if rows:
        table = np.array(rows, float)
        print(f"\n{'count':<10}{'min':>8}{'median':>8}{'max':>8}")
        for col, name in enumerate(("bodies", "spine", "legs", "arms", "heads", "height_m")):
            v = table[:, col]
            print(f"{name:<10}{v.min():>8.3g}{np.median(v):>8.3g}{v.max():>8.3g}")
            key = name.split("_")[0]
            figures[f"{key}_min"], figures[f"{key}_median"], figures[f"{key}_max"] = (
                round(float(v.min()), 3), round(float(np.median(v)), 3), round(float(v.max()), 3))
        figures["asymmetric_share"] = round(float(table[:, 6].mean()), 3)
        figures["legless_share"] = round(float(np.mean(table[:, 2] == 0)), 3)
        print(f"asymmetric {figures['asymmetric_share']:.1%}, legless {figures['legless_share']:.1%}")
    print(f"\nfailures: {len(failures)}")
    for seed, error in failures[:20]:
        print(f"  seed {seed}: {error}")
    print(json.dumps(figures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
