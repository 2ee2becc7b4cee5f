"""The engine's batch commands of ``menagerie`` (no window, no OpenGL).

The ``menagerie`` console script is ``authoring.cli:main``: it adds the tools that draw
(demo, view, grid) to the commands here. ``engine`` never imports ``authoring``; this
module also runs alone (``python -m engine.cli ...``) on machines without the viewer.

    menagerie creatures list [DIR]               counts per creature
    menagerie creatures generate --seed S --count N --out DIR [--force]
    menagerie creatures from-bvh FILE.bvh --out FILE.yaml [--caps TABLE.yaml] [--scale K] [--force]
    menagerie mocap simulate|tune ...            motion capture on physical bodies

Errors a user can cause (bad files, missing paths) print one line naming the fault and
exit with status 2; they never show a traceback.
"""

from __future__ import annotations

import argparse
import glob
import os
import sys
import time

from engine import paths
from engine.errors import MenagerieError

#: Where the library lives, relative to the repository root (strings, for os.path users).
REPO_ROOT = str(paths.REPO_ROOT)
LIBRARY_CREATURES = str(paths.LIBRARY_CREATURES)


def _creature_files(target: str) -> list[str]:
    """The creature files of a folder (every ``*.yaml``), or the one file named."""
    if os.path.isfile(target):
        return [target]
    if not os.path.isdir(target):
        raise MenagerieError(f"{target}: no such folder or file (creatures list takes a folder of creature "
                             "files, or one file)")
    files = sorted(glob.glob(os.path.join(target, "*.yaml")))
    if not files:
        raise MenagerieError(f"{target}: no creature files (*.yaml)")
    return files


def _need_subcommand(parser: argparse.ArgumentParser, choices: str):
    def fail(args: argparse.Namespace) -> int:
        raise MenagerieError(f"{parser.prog}: say which: {choices} (see {parser.prog} --help)")
    return fail


# -- creatures ---------------------------------------------------------------------------


def cmd_creatures_list(args: argparse.Namespace) -> int:
    import warnings

    from engine.errors import DataError
    from engine.model import load_creature

    target = args.dir or LIBRARY_CREATURES
    files = _creature_files(target)
    rows, skipped = [], []
    for path in files:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                c = load_creature(path)
        except DataError as exc:
            if len(files) == 1:
                raise
            skipped.append(str(exc))
            continue
        rows.append((c.name, c.counts(), c.height, c.description))
    width = max([len("creature")] + [len(r[0]) for r in rows]) + 2
    header = (f"{'creature':<{width}}{'bodies':>7}{'spine':>6}{'legs':>5}{'arms':>5}{'heads':>6}{'height m':>10}"
              "  description")
    print(header)
    print("-" * len(header))
    for name, k, height, description in rows:
        print(f"{name:<{width}}{k['bodies']:>7}{k['spine']:>6}{k['legs']:>5}{k['arms']:>5}{k['heads']:>6}"
              f"{height:>10.3f}  {description}")
    print(f"{len(rows)} creature{'' if len(rows) == 1 else 's'}")
    for reason in skipped:
        print(f"skipped {reason}", file=sys.stderr)
    return 0


def cmd_creatures_generate(args: argparse.Namespace) -> int:
    from engine.model.random import generate_creatures
    from engine.outputs import output_dir

    if args.count < 1:
        raise MenagerieError(f"--count must be at least 1, got {args.count}")
    if args.seed < 0:
        raise MenagerieError(f"--seed must be a whole number >= 0, got {args.seed}")
    names = [f"random_{args.seed + k}.yaml" for k in range(args.count)]
    output_dir(args.out, args.force, writes=tuple(names))
    paths = generate_creatures(args.seed, args.count, args.out, overwrite=args.force)
    print(f"wrote {len(paths)} creature{'' if len(paths) == 1 else 's'} to {args.out}")
    return 0


def cmd_creatures_from_bvh(args: argparse.Namespace) -> int:
    from engine.io.bvh_creature import creature_def_from_bvh, load_caps_table
    from engine.model import build_creature, write_creature_def
    from engine.outputs import output_file

    output_file(args.out, args.force, suffixes=(".yaml", ".yml"))
    unit = args.unit_scale
    if args.scale is not None:
        print("menagerie: warning: --scale is now --unit-scale in from-bvh (as in mocap)", file=sys.stderr)
        unit = args.scale if unit is None else unit
    table = load_caps_table(args.caps) if args.caps else None
    cdef = creature_def_from_bvh(args.file, caps_table=table, scale=unit)
    creature = build_creature(cdef)  # validate before writing anything
    write_creature_def(cdef, args.out, overwrite=args.force)
    print(f"wrote {args.out}: {creature!r}")
    return 0


# -- entry point -------------------------------------------------------------------------


def add_batch_commands(sub) -> None:
    """Add the engine's batch commands (creatures, mocap) to an argparse subparsers object."""
    creatures = sub.add_parser("creatures", help="list, generate or import creatures")
    creatures.set_defaults(func=_need_subcommand(creatures, "list, generate or from-bvh"))
    csub = creatures.add_subparsers(dest="creatures_command", metavar="list|generate|from-bvh")
    lst = csub.add_parser("list", help="counts per creature file")
    lst.add_argument("dir", nargs="?", help="a folder of creature files, or one file (default: the library)")
    lst.set_defaults(func=cmd_creatures_list)
    gen = csub.add_parser("generate", help="write random creatures")
    gen.add_argument("--seed", type=int, required=True)
    gen.add_argument("--count", type=int, default=1)
    gen.add_argument("--out", required=True, metavar="DIR", help="folder to write random_S.yaml... into")
    gen.add_argument("--force", action="store_true", help="overwrite existing files")
    gen.set_defaults(func=cmd_creatures_generate)
    bvh = csub.add_parser("from-bvh", help="turn a BVH skeleton into a creature file")
    bvh.add_argument("file")
    bvh.add_argument("--out", required=True, metavar="FILE.yaml", help="creature file to write")
    bvh.add_argument("--caps", help="YAML table of joint-name patterns to capabilities")
    bvh.add_argument("--unit-scale", type=float, default=None, metavar="K",
                     help="file units to metres (default: auto)")
    bvh.add_argument("--scale", type=float, default=None, help=argparse.SUPPRESS)   # the old name
    bvh.add_argument("--force", action="store_true", help="overwrite an existing file")
    bvh.set_defaults(func=cmd_creatures_from_bvh)

    try:
        from engine.mocap_cli import add_mocap_parser
    except ImportError:
        pass
    else:
        add_mocap_parser(sub)


def version() -> str:
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as _v

    try:
        return _v("menagerie")
    except PackageNotFoundError:
        return "unknown (not installed)"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="menagerie", description=__doc__.split("\n\n")[0])
    parser.add_argument("--version", action="version", version=f"menagerie {version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    add_batch_commands(sub)
    return parser


def _format_warning(message, category, filename, lineno, line=None) -> str:
    """Warnings to a command-line user: one line, no Python source."""
    return f"menagerie: warning: {message}\n"


#: The library's Python wording for "replace an existing file", and the flag that says it.
_PYTHON_WORDS = ("overwrite=True (menagerie: --force)", "overwrite=True (or --force)", "overwrite=True")


def _cli_words(message: str) -> str:
    for words in _PYTHON_WORDS:
        message = message.replace(words, "--force")
    return message


def run(parser: argparse.ArgumentParser, argv: list[str] | None = None) -> int:
    """Parse ``argv`` with ``parser`` and run the chosen command: a ``MenagerieError`` (a
    fault the user can fix) prints one line and gives status 2, never a traceback."""
    import warnings

    warnings.formatwarning = _format_warning
    args = parser.parse_args(argv)
    started = time.perf_counter()
    try:
        status = args.func(args)
    except (MenagerieError, FileExistsError) as exc:
        print(f"menagerie: error: {_cli_words(str(exc))}", file=sys.stderr)
        return 2
    except IsADirectoryError as exc:
        print(f"menagerie: error: {exc.filename}: is a folder, a file path is wanted", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"menagerie: error: {exc.filename}: no such file", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    if os.environ.get("MENAGERIE_TIMING"):
        print(f"[{time.perf_counter() - started:.2f} s]", file=sys.stderr)
    return int(status or 0)


def main(argv: list[str] | None = None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
