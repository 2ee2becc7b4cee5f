"""Crossfades between clips, measured: a one-shot clip crossfaded into a loop (idle_breathe
by default), as a game queues its idle behind an action.

    .venv/bin/python benchmarks/transitions.py                     # library + random 4242-4261
    .venv/bin/python benchmarks/transitions.py --library 0 --creatures ../shared/data/rigs ../shared/data/mocap
    .venv/bin/python benchmarks/transitions.py --random 50 --first-seed 10000 --library 0

The validation grid plays each clip alone, fading out to the standing pose; a transition
into another clip changes which goals the IK reads and which bodies it poses (its plan),
which the grid never sees (random 4259's arm turned 2.07 rad in the first frame of
hold_platter's crossfade into idle_breathe; random 24's head 0.79). Per (creature, clip):
the largest turn of any body in one 60 Hz frame from 0.35 s before the clip ends to 0.8 s
after, with the loop queued behind it and without (the clip fading out alone). A pop is
a turn over ``--pop`` rad (the grid's flip line) that the clip alone does not make. Ends
with one JSON line: pairs, pops, pops_alone (the clip's own end pops), worst.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import engine  # noqa: E402
from engine.io.sources import creature_from_file  # noqa: E402
from engine.model import build_creature, random_creature_def  # noqa: E402
from engine.physics.world import rotvec_between  # noqa: E402
from engine.runtime import Character  # noqa: E402


def worst_turn(creature, clip, then, fade: float) -> tuple[float, str]:
    """Largest one-frame turn (rad) and its body, around the end of ``clip`` played with
    ``then`` queued behind it (None: the clip fading out alone)."""
    ch = Character(creature)
    ch.play(clip, fade=0.2, loop=False, fade_out=fade)
    if then is not None:
        ch.queue(then, fade=fade)
    prev, worst = None, (0.0, "")
    for k in range(int((clip.length + 0.8) * 60)):
        ch.tick(1 / 60)
        if prev is not None and (k + 1) / 60 > clip.length - 0.35:
            turn = np.linalg.norm(rotvec_between(prev, ch.world_rotations), axis=1)
            b = int(np.argmax(turn))
            if turn[b] > worst[0]:
                worst = (float(turn[b]), creature.body_names[b])
        prev = ch.world_rotations.copy()
    return worst


def creatures(args) -> list:
    out = [creature_from_file(p) for p in sorted(glob.glob(os.path.join(ROOT, "creatures", "*.yaml")))[: args.library]]
    for path in args.creatures:
        files = sorted(glob.glob(os.path.join(path, "*"))) if os.path.isdir(path) else [path]
        out += [creature_from_file(f) for f in files if os.path.splitext(f)[1].lower() in (".yaml", ".bvh", ".glb",
                                                                                          ".gltf")]
    out += [build_creature(random_creature_def(s)) for s in range(args.first_seed, args.first_seed + args.random)]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--library", type=int, default=1000, help="library creatures (first N by name)")
    ap.add_argument("--random", type=int, default=20, help="random creatures")
    ap.add_argument("--first-seed", type=int, default=4242)
    ap.add_argument("--creatures", nargs="*", default=[], help="creature files or folders (YAML, BVH, glTF)")
    ap.add_argument("--into", default="idle_breathe", help="the loop queued behind each clip")
    ap.add_argument("--fade", type=float, default=0.3, help="crossfade, s")
    ap.add_argument("--pop", type=float, default=0.5, help="a turn over this in one frame is a pop, rad")
    args = ap.parse_args()
    then = engine.load_animation(os.path.join(ROOT, "animations", f"{args.into}.yaml"))
    clips = [engine.load_animation(p) for p in sorted(glob.glob(os.path.join(ROOT, "animations", "*.yaml")))]
    clips = [a for a in clips if not a.loop and a.name != then.name and a.follows is None]
    t0 = time.perf_counter()
    rows = []
    for c in creatures(args):
        for a in clips:
            try:
                x = worst_turn(c, a, then, args.fade)
            except engine.MenagerieError:
                continue            # the clip does not play on this creature
            alone = worst_turn(c, a, None, args.fade)
            rows.append((c.name, a.name, x[0], x[1], alone[0]))
    rows.sort(key=lambda r: -r[2])
    pops = [r for r in rows if r[2] > args.pop and r[4] <= args.pop]
    print(f"{len(rows)} (creature, clip) pairs crossfaded into {then.name} ({time.perf_counter() - t0:.0f} s): "
          f"{len(pops)} pop over {args.pop} rad that the clip alone does not make; "
          f"{sum(r[4] > args.pop for r in rows)} clips pop fading out alone")
    for r in rows[:12]:
        print(f"  {r[0][:28]:28s} {r[1]:16s} {r[2]:.3f} rad at {r[3]:20s} (alone {r[4]:.3f})")
    print(json.dumps(dict(pairs=len(rows), pops=len(pops), pops_alone=sum(r[4] > args.pop for r in rows),
                          worst=[dict(creature=r[0], clip=r[1], turn=round(r[2], 3), body=r[3],
                                      alone=round(r[4], 3)) for r in pops[:10]])))


if __name__ == "__main__":
    main()
