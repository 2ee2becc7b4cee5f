"""The validation grid's floors (issue 12), measured: pass rate, flips, time.

    .venv/bin/python benchmarks/grid.py        # library + random 0-999, held out 10000-10199, a 30-creature grid
    .venv/bin/python benchmarks/grid.py --random 100 --heldout 50 --no-daily     # a quicker look
    .venv/bin/python benchmarks/grid.py --pictures --out out/grid-bench          # with the report's pictures

Each grid runs on a Dask LocalCluster (one worker process per core) through ``menagerie
grid``'s own code and writes its report under ``--out`` (``main/``, ``heldout/``,
``daily/``). Prints a table per grid and ends with one JSON line:

    pass_rate, flips, nonfinite, cells, plays, fail, seconds, cells_per_second   (library + seeds 0..N-1)
    heldout_pass_rate, heldout_flips, heldout_cells, heldout_seconds              (seeds 10000..)
    daily_creatures, daily_seconds                                                (the library's first 30)

``flips`` counts cells in which some body turns more than 0.5 rad between two 60 Hz
frames beyond what its goals ask (``rotation_pop``, ``start_pop`` or ``end_pop`` failing).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from authoring.grid_report import picture_task, write_report  # noqa: E402
from engine.validation import grid as G  # noqa: E402


def run(label: str, sources, paths, out: str, pictures: bool, workers: int | None) -> dict:
    task = picture_task if pictures else G.cell_task
    t0 = time.perf_counter()
    r = G.run_grid(sources, paths, task=task, workers=workers, progress=sys.stderr.isatty())
    wall = time.perf_counter() - t0
    s = write_report(out, r, animations=paths, command=f"benchmarks/grid.py ({label})", pictures=pictures)
    s["wall_seconds"] = wall
    print(f"\n{label}: {len(sources)} creatures, {s['cells']} cells ({s['plays']} played, {s['not_applicable']} "
          f"not applicable)")
    print(f"  pass {s['pass']}  warn {s['warn']}  fail {s['fail']}  pass_rate {s['pass_rate']:.4f}  "
          f"(pass or warn {s['pass_or_warn_rate']:.4f})")
    print(f"  flips {s['flips']}  non-finite {s['nonfinite']}  known fails {s['known_fail']}")
    print(f"  {wall:.1f} s, {s['cells'] / wall:.1f} cells/s, {r.workers} workers ({r.scheduler})")
    print("  failing metrics: " + ", ".join(f"{k} {v}" for k, v in list(s["fail_by_metric"].items())[:10]))
    for w in s["worst"][:8]:
        print(f"    {w['creature']} / {w['animation']} / {w['variant_id']}: {w['reason']}")
    print(f"  report: {os.path.join(out, 'index.html')}")
    return s


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--random", type=int, default=1000, help="random creatures with the library (seeds 0..N-1)")
    ap.add_argument("--heldout", type=int, default=200, help="held-out random creatures (seeds 10000..)")
    ap.add_argument("--heldout-first-seed", type=int, default=10000)
    ap.add_argument("--no-daily", action="store_true", help="skip the 30-creature everyday grid")
    ap.add_argument("--pictures", action="store_true", help="render the report's pictures (slower)")
    ap.add_argument("--workers", type=int, default=None, help="LocalCluster workers (default: one per core)")
    ap.add_argument("--out", default="out/grid-bench", help="where the reports go")
    args = ap.parse_args(argv)
    paths = G.library_animation_paths()
    figures: dict = {}
    s = run("library + random", G.library_sources() + G.random_sources(args.random), paths,
            os.path.join(args.out, "main"), args.pictures, args.workers)
    figures.update(pass_rate=s["pass_rate"], flips=s["flips"], nonfinite=s["nonfinite"], cells=s["cells"],
                   plays=s["plays"], fail=s["fail"], known_fail=s["known_fail"], seconds=round(s["wall_seconds"], 1),
                   cells_per_second=round(s["cells"] / s["wall_seconds"], 2), creatures=len(G.library_sources())
                   + args.random, fail_by_metric=s["fail_by_metric"])
    if args.heldout:
        h = run("held-out random", G.random_sources(args.heldout, args.heldout_first_seed), paths,
                os.path.join(args.out, "heldout"), args.pictures, args.workers)
        figures.update(heldout_pass_rate=h["pass_rate"], heldout_flips=h["flips"], heldout_cells=h["cells"],
                       heldout_nonfinite=h["nonfinite"], heldout_seconds=round(h["wall_seconds"], 1),
                       heldout_fail_by_metric=h["fail_by_metric"])
    if not args.no_daily:
        d = run("everyday (30 library creatures, pictures)", G.library_sources()[:30], paths,
                os.path.join(args.out, "daily"), True, args.workers)
        figures.update(daily_creatures=30, daily_seconds=round(d["wall_seconds"], 1))
    figures["cores"] = os.cpu_count()
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
