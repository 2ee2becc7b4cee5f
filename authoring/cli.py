"""menagerie: animation for creatures whose shape nobody knew in advance.

The ``menagerie`` console script:

    menagerie demo [--headless] [--gaits] [--out DIR]   the zoo (window, or PNGs without a display)
    menagerie view FILE [--snapshot OUT.png]     look at a creature file
    menagerie author ANIM.yaml [CREATURE...] [--random N] [--time T] [--variant V] [--headless --snapshot OUT.png]
                                                 the authoring tool (a new animation if ANIM does not exist)
    menagerie play CREATURE ANIM [--snapshot OUT.png | --gif OUT.gif] [--time T]
                                                 one animation on one creature
    menagerie grid [--library] [--random N] ...  the validation grid and its report
    menagerie creatures list|generate|from-bvh   the engine's batch commands (engine.cli)
    menagerie mocap simulate|tune ...            motion capture on physical bodies

The tools that draw live here, in ``authoring``; the batch commands come from
``engine.cli``, which never imports ``authoring``. Errors a user can cause print one line
naming the fault and exit with status 2; they never show a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys

from engine.cli import add_batch_commands, run
from engine.errors import MenagerieError


def cmd_view(args: argparse.Namespace) -> int:
    from authoring.viewer import view_file

    if not os.path.exists(args.file):
        raise MenagerieError(f"{args.file}: no such file")
    out = view_file(args.file, snapshot=args.snapshot)
    if out:
        print(f"wrote {out}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    if args.gaits:
        from authoring.gait_demo import run_gait_demo

        return run_gait_demo(headless=args.headless, out_dir=args.out, seconds=args.seconds)
    from authoring.demo import run_demo

    status = run_demo(headless=args.headless, out_dir=args.out, seconds=args.seconds)
    from authoring import render as rd

    if status == 0 and (args.headless or rd.want_headless()):
        # Without a window the demo also renders the gait contact sheet (walking, trotting,
        # crawling on rolling ground along curved paths) next to the zoo.
        from authoring.gait_demo import run_gait_demo

        status = run_gait_demo(headless=True, out_dir=os.path.join(args.out, "gaits"), seconds=args.seconds)
    return status


def cmd_author(args: argparse.Namespace) -> int:
    from authoring.author import run_author

    creatures = list(args.creatures) + list(args.creatures_opt or [])
    return run_author(args.animation, creatures, random_count=args.random, first_seed=args.first_seed,
                      headless=args.headless, snapshot=args.snapshot, width=args.width, height=args.height,
                      time=args.time, channel=args.channel, variant=args.variant, help_panel=args.help_panel,
                      overwrite=args.force, samples=args.samples)


def cmd_play(args: argparse.Namespace) -> int:
    from authoring.play import run_play

    if not os.path.exists(args.animation):
        raise MenagerieError(f"{args.animation}: no such file")
    return run_play(args.creature, args.animation, snapshot=args.snapshot, gif=args.gif, time=args.time,
                    force=args.force)


def add_tool_commands(sub) -> None:
    """The commands that draw: demo, view, author, play, grid (its report has pictures)."""
    from authoring.grid_report import add_grid_parser

    demo = sub.add_parser("demo", help="the creature zoo, animated")
    demo.add_argument("--headless", action="store_true", help="render offscreen even with a display")
    demo.add_argument("--out", default="out/demo", help="where headless output goes (default out/demo)")
    demo.add_argument("--seconds", type=float, default=4.0, help="headless clip length in seconds")
    demo.add_argument("--gaits", action="store_true", help="the gait demo: creatures walking on rolling ground")
    demo.set_defaults(func=cmd_demo)

    view = sub.add_parser("view", help="look at a creature file")
    view.add_argument("file")
    view.add_argument("--snapshot", metavar="OUT.png", help="render offscreen to a PNG and exit")
    view.set_defaults(func=cmd_view)

    author = sub.add_parser("author", help="the authoring tool: one animation on several creatures")
    author.add_argument("animation", help="animation file (a new animation if it does not exist)")
    author.add_argument("creatures", nargs="*",
                        help="library names, creature files or BVH skeletons (default: humanoid, dog, "
                             "spider, snake and a random creature)")
    author.add_argument("--creatures", dest="creatures_opt", nargs="+", metavar="CREATURE",
                        help="the same, as an option (what the grid's report prints)")
    author.add_argument("--random", type=int, default=0, metavar="N", help="add N random creatures")
    author.add_argument("--first-seed", type=int, default=1, metavar="S",
                        help="seed of the first random creature (the next ones S+1, ...)")
    author.add_argument("--variant", default=None, help="play this variant (id) on the creatures that have it")
    author.add_argument("--time", type=float, default=None, metavar="T", help="open at time T (s)")
    author.add_argument("--channel", default=None, help="open with this channel selected")
    author.add_argument("--headless", action="store_true", help="no window: render one frame (see --snapshot)")
    author.add_argument("--snapshot", metavar="OUT.png", help="write one frame of the tool to OUT.png and exit")
    author.add_argument("--help-panel", action="store_true", help="show the keyboard and mouse help panel")
    author.add_argument("--samples", type=int, default=4,
                        help="antialiasing samples of the 3-D view (0 is about twice as fast on a software renderer)")
    author.add_argument("--width", type=int, default=1400)
    author.add_argument("--height", type=int, default=800)
    author.add_argument("--force", action="store_true", help="overwrite an existing snapshot")
    author.set_defaults(func=cmd_author)

    play = sub.add_parser("play", help="play one animation on one creature")
    play.add_argument("creature", help="library name, creature file or BVH skeleton")
    play.add_argument("animation", help="animation file")
    play.add_argument("--snapshot", metavar="OUT.png", help="write the pose at --time to a PNG (no window)")
    play.add_argument("--gif", metavar="OUT.gif", help="write the whole animation as a GIF (no window)")
    play.add_argument("--time", type=float, default=None, help="snapshot time, s (default: half the length)")
    play.add_argument("--force", action="store_true", help="overwrite existing output files")
    play.set_defaults(func=cmd_play)

    add_grid_parser(sub)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="menagerie", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    add_tool_commands(sub)
    add_batch_commands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
