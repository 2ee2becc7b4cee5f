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
    from authoring import render as rd
    from authoring.viewer import _free_path, view_file
    from engine import compiling
    from engine.io.sources import creature_from_file
    from engine.outputs import output_file
    from engine.paths import creature_path

    path = creature_path(args.file)
    creature_from_file(path)   # a bad file fails here, before anything is said or made
    snapshot, fallback = args.snapshot, False
    if snapshot is not None:
        output_file(snapshot, args.force, flag="--snapshot", suffixes=(".png",))
    elif rd.want_headless():
        # No window can open: a picture in out/, never over an earlier one.
        name = os.path.splitext(os.path.basename(path))[0]
        snapshot, fallback = _free_path(os.path.join("out", f"{name}.png")), True
        os.makedirs("out", exist_ok=True)
    compiling.notice("view")
    out = view_file(path, snapshot=snapshot)
    if fallback:
        print(f"menagerie view: no display here (DISPLAY is not set): wrote {out} "
              "(--snapshot OUT.png names the picture)")
    elif out:
        print(f"wrote {out}")
    return 0


#: What the demo writes into --out (the gait demo writes into --out/gaits).
DEMO_OUTPUTS = ("contact_sheet.png", "frame_*.png", "demo.gif", "gaits", "gait_contact_sheet.png",
                "impacts_frame_*.png", "impacts_contact_sheet.png", "impacts.gif", "impacts_figure1.png")


def cmd_demo(args: argparse.Namespace) -> int:
    from authoring import render as rd
    from engine import compiling
    from engine.outputs import output_dir

    if not args.seconds >= 0.1:
        raise MenagerieError(f"--seconds must be at least 0.1 (a few frames), got {args.seconds:g}")
    headless = args.headless or rd.want_headless()
    if headless:
        output_dir(args.out, args.force, writes=DEMO_OUTPUTS)
    compiling.notice("viewer")
    if args.impacts:
        from authoring.impact_demo import run_impact_demo

        if not headless:
            print("menagerie demo --impacts: renders offscreen (PNGs, a GIF, the Figure-1 plot)")
            output_dir(args.out, args.force, writes=DEMO_OUTPUTS)
        return run_impact_demo(headless=True, out_dir=args.out, seconds=max(args.seconds, 4.5))
    if args.gaits:
        from authoring.gait_demo import run_gait_demo

        return run_gait_demo(headless=args.headless, out_dir=args.out, seconds=args.seconds)
    from authoring.demo import run_demo

    status = run_demo(headless=args.headless, out_dir=args.out, seconds=args.seconds)
    if status == 0 and headless:
        # Without a window the demo also renders the gait contact sheet (walking, trotting,
        # crawling on rolling ground along curved paths) next to the zoo.
        from authoring.gait_demo import run_gait_demo

        status = run_gait_demo(headless=True, out_dir=os.path.join(args.out, "gaits"), seconds=args.seconds)
    return status


def cmd_author(args: argparse.Namespace) -> int:
    from authoring.author import run_author
    from engine import compiling

    compiling.notice("viewer")
    creatures = list(args.creatures) + list(args.creatures_opt or [])
    return run_author(args.animation, creatures, random_count=args.random, first_seed=args.first_seed,
                      headless=args.headless, snapshot=args.snapshot, width=args.width, height=args.height,
                      time=args.time, channel=args.channel, variant=args.variant, help_panel=args.help_panel,
                      overwrite=args.force, samples=args.samples)


def cmd_play(args: argparse.Namespace) -> int:
    from authoring.play import run_play
    from engine import compiling

    if not os.path.exists(args.animation):
        raise MenagerieError(f"{args.animation}: no such file")
    compiling.notice("viewer")
    return run_play(args.creature, args.animation, snapshot=args.snapshot, gif=args.gif, time=args.time,
                    force=args.force)


def add_tool_commands(sub) -> None:
    """The commands that draw: demo, view, author, play, grid (its report has pictures)."""
    from authoring.grid_report import add_grid_parser

    demo = sub.add_parser("demo", help="the creature zoo, animated")
    demo.add_argument("--headless", action="store_true", help="render offscreen even with a display")
    demo.add_argument("--out", default="out/demo", metavar="DIR",
                      help="folder the headless output goes into (default out/demo)")
    demo.add_argument("--seconds", type=float, default=4.0, help="headless clip length in seconds (>= 0.1)")
    demo.add_argument("--force", action="store_true", help="replace an earlier demo's output in --out")
    demo.add_argument("--gaits", action="store_true", help="the gait demo: creatures walking on rolling ground")
    demo.add_argument("--impacts", action="store_true",
                      help="the impact demo: creatures hit from several directions and in series, a punch "
                           "between two humanoids, the Figure-1 plot (offscreen)")
    demo.set_defaults(func=cmd_demo)

    view = sub.add_parser("view", help="look at a creature file")
    view.add_argument("file", help="library name (humanoid), creature file or BVH skeleton")
    view.add_argument("--snapshot", metavar="OUT.png", help="render offscreen to a PNG and exit")
    view.add_argument("--force", action="store_true", help="replace an existing snapshot")
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
    from engine.cli import version

    parser = argparse.ArgumentParser(prog="menagerie", description=__doc__.split("\n\n")[0])
    parser.add_argument("--version", action="version", version=f"menagerie {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_tool_commands(sub)
    add_batch_commands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
