"""One animation, posed by the whole runtime, on several creatures side by side.

Hecker et al. 2008, section 3.4 (preview one animation on many creatures): where
``authoring.goals_view`` shows the goals before the IK, this plays the animation through
``engine.Character`` (bind, sample, blend, standing or gait, IK, Jiggles) up to time ``t``
and draws the poses, so what an animator sees is what the game gets::

    .venv/bin/python -m authoring.pose_sheet animations/crouch.yaml 1.0 out.png humanoid dog trex spider

Creatures are library names (``creatures/NAME.yaml``), creature files or BVH skeletons. Named
external targets are put a little in front of each creature at chest height.
"""

from __future__ import annotations

import argparse
import os
import sys

import engine
from authoring import scene as sc
from authoring.render import render_png
from engine.anim import load_animation

FPS = 60


def _creature(name: str):
    from engine.io.sources import creature_from_file
    from engine.paths import creature_path

    return creature_from_file(creature_path(name))


def pose_sheet(animation_path: str, t: float, out: str, creatures: list[str], *, width: int = 1400,
               height: int = 700) -> str:
    """Play the animation on each creature for ``t`` seconds (at 60 Hz) and render the
    poses into the PNG ``out``. Returns the path."""
    if not t >= 0.0:
        raise ValueError(f"t must be a time >= 0 in seconds, got {t!r}")
    anim = load_animation(animation_path)
    cs = [_creature(n) for n in creatures]
    zoo = sc.layout_zoo(cs, normalize_size=True, labels=True)
    for c, actor in zip(cs, zoo.actors, strict=True):
        ch = engine.Character(c)
        for name in anim.target_names:
            ch.set_target(name, (0.7 * c.height, 0.25 * c.height, 0.7 * c.height))
        ch.play(anim, fade=0.0)
        for _ in range(max(int(round(t * FPS)), 1)):
            ch.tick(1.0 / FPS)
        actor.set_pose(ch.world_positions, ch.world_rotations)
    zoo.caption = f"{anim.name}  t = {t:g} s"
    return render_png(zoo, out, width, height)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("animation")
    ap.add_argument("t", type=float, help="time, s")
    ap.add_argument("out", help="PNG to write")
    ap.add_argument("creatures", nargs="+", help="library names or creature files")
    ap.add_argument("--force", action="store_true", help="overwrite an existing OUT")
    args = ap.parse_args(argv)
    from engine import compiling
    from engine.outputs import output_file

    try:
        output_file(args.out, args.force, flag="OUT", suffixes=(".png",))
        if not os.path.isfile(args.animation):
            raise engine.MenagerieError(f"{args.animation}: no such file")
        compiling.notice("viewer")
        print(pose_sheet(args.animation, args.t, args.out, args.creatures))
    except (engine.MenagerieError, ValueError, OSError) as exc:
        print(f"pose_sheet: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
