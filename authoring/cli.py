"""menagerie: animation for creatures whose shape nobody knew in advance.

The ``menagerie`` console script:

    menagerie demo [--headless] [--gaits] [--out DIR]   the zoo (window, or PNGs without a display)
    menagerie view FILE [--snapshot OUT.png]     look at a creature file
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


def add_tool_commands(sub) -> None:
    """The commands that draw: demo, view, grid (its report has pictures)."""
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
