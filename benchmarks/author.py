"""Frames per second of the authoring tool with six creatures on screen, off screen on
this machine's software renderer (Mesa llvmpipe through headless EGL).

    .venv/bin/python benchmarks/author.py [--frames 120] [--size 1400x800] [--animation FILE]

One frame is what the window does every frame: every creature ticked by the runtime
(``engine.Character``, playing the animation), the Dear ImGui panels built (channel list,
query editor, timeline, curve editor with its keys), the 3-D picture drawn with the
active channel's curve and manipulator, the panels drawn over it, and the pixels read
copied to the window, finished (``glFinish``). Prints a table, the median of three runs,
and ends with one JSON line: creatures, bodies, width, height, frames, fps (median of the
runs' medians), median_ms, p90_ms, fps_runs, fps_read (the same frames with the pixels
read back too, as a snapshot or a test does), tick_ms (the runtime's share: six
creatures' ticks alone), samples (multisampling of the 3-D view), gl (the renderer
string), load (the machine's 1-minute load: it is shared). The goal is >= 30 fps.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

import engine  # noqa: E402
from authoring import render as rd  # noqa: E402

CREATURES = ("humanoid", "dog", "spider", "snake", "threearmed", "trex")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--size", default="1400x800")
    ap.add_argument("--samples", type=int, default=4, help="antialiasing samples of the 3-D view")
    ap.add_argument("--animation", default=os.path.join(ROOT, "animations", "pick_fruit.yaml"))
    args = ap.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    rd.load_pyglet(headless=True)
    from authoring.author import measure_fps
    from authoring.document import Document
    from authoring.editor import Editor

    cs = [engine.load_creature(os.path.join(ROOT, "creatures", f"{n}.yaml")) for n in CREATURES]
    runs = []
    for _ in range(args.runs):
        ed = Editor(Document.open(args.animation), cs)
        runs.append(measure_fps(ed, width=width, height=height, frames=args.frames, samples=args.samples))
    ed = Editor(Document.open(args.animation), cs)
    ed.play(True)
    ticks = []
    for _ in range(args.frames):
        t0 = time.perf_counter()
        ed.preview.advance(1 / 60)
        ticks.append(time.perf_counter() - t0)
    ed = Editor(Document.open(args.animation), cs)
    read = measure_fps(ed, width=width, height=height, frames=args.frames, read=True, samples=args.samples)
    fps = [r["fps"] for r in runs]
    best = runs[int(np.argsort(fps)[len(fps) // 2])]
    out = {"creatures": len(cs), "bodies": int(sum(c.nbody for c in cs)), "width": width, "height": height,
           "frames": args.frames, "runs": args.runs, "fps": round(best["fps"], 1),
           "median_ms": round(best["median_ms"], 2), "p90_ms": round(best["p90_ms"], 2),
           "fps_runs": [round(f, 1) for f in fps], "fps_read": round(read["fps"], 1),
           "tick_ms": round(float(np.median(ticks)) * 1e3, 3), "samples": best["samples"],
           "gl": best["gl"], "load": round(os.getloadavg()[0], 2)}
    print(f"{'creatures':<14}{out['creatures']} ({', '.join(CREATURES)}), {out['bodies']} bodies")
    print(f"{'picture':<14}{width} x {height}, {out['gl']}")
    print(f"{'frame':<14}{out['median_ms']} ms median, {out['p90_ms']} ms p90  ->  {out['fps']} fps "
          f"(runs: {out['fps_runs']})")
    print(f"{'read back':<14}{out['fps_read']} fps with the pixels read back too")
    print(f"{'runtime':<14}{out['tick_ms']} ms of it ticking the six creatures")
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
