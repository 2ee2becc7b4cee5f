"""The engine's batch commands of ``menagerie`` (no window, no OpenGL).

The ``menagerie`` console script is ``authoring.cli:main``: it adds the tools that draw
(demo, view, grid) to the commands here. ``engine`` never imports ``authoring``; this
module also runs alone (``python -m engine.cli ...``) on machines without the viewer.

    menagerie creatures list [DIR]               counts per creature
    menagerie creatures generate --seed S --count N --out DIR [--force]
    menagerie creatures from-bvh FILE.bvh --out FILE.yaml [--caps TABLE.yaml] [--scale K] [--force]
    menagerie creatures from-gltf FILE.glb --out FILE.yaml [--skin N] [--caps TABLE.yaml] [--scale K] [--force]
    menagerie creatures explain FILE             what an imported skeleton's bodies are, and why
    menagerie bake ANIM.yaml CREATURE... --out DIR [--format glb|gltf|bvh] [--variant V] [--fps 30] [--mesh auto|boxes]
                                                 the runtime's output as animated glTF or BVH files
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
    rest = args.rest_frame if getattr(args, "rest_frame", None) is not None else "relaxed"
    cdef = creature_def_from_bvh(args.file, caps_table=table, scale=unit, rest=rest)
    creature = build_creature(cdef)  # validate before writing anything
    write_creature_def(cdef, args.out, overwrite=args.force)
    print(f"wrote {args.out}: {creature!r}")
    return 0


def cmd_creatures_from_gltf(args: argparse.Namespace) -> int:
    from engine.io.bvh_creature import load_caps_table
    from engine.io.gltf import import_gltf
    from engine.model import build_creature, write_creature_def
    from engine.outputs import output_file

    output_file(args.out, args.force, suffixes=(".yaml", ".yml"))
    table = load_caps_table(args.caps) if args.caps else None
    imp = import_gltf(args.file, skin=args.skin, caps_table=table, scale=args.scale)
    # The creature file remembers its rig, so a bake of it carries the rig's own mesh.
    rel = os.path.relpath(os.path.abspath(args.file), os.path.dirname(os.path.abspath(args.out)))
    imp.cdef.source = {"file": rel, "skin": int(imp.skin), "scale": float(imp.scale)}
    creature = build_creature(imp.cdef)
    try:
        write_creature_def(imp.cdef, args.out, overwrite=args.force)
    except FileExistsError as exc:
        raise MenagerieError(str(exc)) from None
    for note in imp.notes:
        print(f"note: {note}")
    if imp.helpers:
        print(f"left out {len(imp.helpers)} helper bones that deform nothing: {', '.join(imp.helpers)}")
    if imp.reattached:
        print(f"re-attached {len(imp.reattached)} detached chains: {', '.join(imp.reattached)}")
    if imp.relaxed:
        print(f"relaxed rest: arms swung down ({', '.join(imp.relaxed)})")
    print(f"wrote {args.out}: {creature!r}")
    return 0


def cmd_creatures_explain(args: argparse.Namespace) -> int:
    from engine.io.bvh_creature import load_caps_table
    from engine.io.sources import explain_creature_source

    table = load_caps_table(args.caps) if args.caps else None
    print(explain_creature_source(args.file, caps_table=table))
    return 0


def add_gltf_commands(csub) -> None:
    """``creatures from-gltf`` and ``creatures explain`` (kept apart for easy merging)."""
    gl = csub.add_parser("from-gltf", help="turn a glTF rig (.glb/.gltf) into a creature file")
    gl.add_argument("file")
    gl.add_argument("--out", required=True, help="creature file to write")
    gl.add_argument("--skin", type=int, default=None, help="skin index (default: the one with most joints)")
    gl.add_argument("--caps", help="YAML table of joint-name patterns to capabilities")
    gl.add_argument("--unit-scale", "--scale", dest="scale", type=float, default=None, metavar="K",
                    help="multiply positions (default: 1, or 0.01 for a rig left in centimetres)")
    gl.add_argument("--force", action="store_true", help="overwrite an existing file")
    gl.set_defaults(func=cmd_creatures_from_gltf)
    ex = csub.add_parser("explain", help="what an imported skeleton's bodies are, and why")
    ex.add_argument("file", help="a .bvh, .glb or .gltf file")
    ex.add_argument("--caps", help="YAML table of joint-name patterns to capabilities")
    ex.set_defaults(func=cmd_creatures_explain)


def cmd_bake(args: argparse.Namespace) -> int:
    from engine.io.bake import bake
    from engine.validation.grid import file_sources

    sources = [s.ref for s in file_sources(args.creatures)]
    results = bake(sources, args.animation, args.out, fmt=args.format, fps=args.fps, variant=args.variant,
                   overwrite=args.force, workers=args.workers, scheduler=args.scheduler, progress=not args.quiet,
                   mesh=args.mesh)
    failed = [r for r in results if r.error]
    for r in results:
        if r.error:
            print(f"{r.source}: {r.error.splitlines()[0]}", file=sys.stderr)
        elif not args.quiet:
            print(f"wrote {', '.join(r.paths)} ({r.clips} clip{'s' if r.clips != 1 else ''}, {r.seconds:.2f} s)")
    print(f"baked {len(results) - len(failed)} of {len(results)} creatures into {args.out}")
    return 2 if failed else 0


def add_bake_command(sub) -> None:
    """``bake`` (kept apart for easy merging)."""
    bk = sub.add_parser("bake", help="write what the runtime plays as animated glTF or BVH, per creature")
    bk.add_argument("animation", help="animation file")
    bk.add_argument("creatures", nargs="+", help="creature files, skeletons (BVH, glTF) or directories")
    bk.add_argument("--out", required=True, help="output directory")
    bk.add_argument("--format", default="glb", choices=["glb", "gltf", "bvh"])
    bk.add_argument("--variant", default=None, help="only this variant id (default: every variant, one clip each)")
    bk.add_argument("--fps", type=float, default=30.0, help="keys per second (default 30)")
    bk.add_argument("--mesh", default="auto", choices=["auto", "boxes"],
                    help="glTF skin: the rig's own mesh for a creature made from a glTF rig, else boxes "
                         "(auto, the default), or always a box per body")
    bk.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    bk.add_argument("--workers", type=int, default=None,
                    help="LocalCluster worker processes (default: one per core; 0 runs in this process)")
    bk.add_argument("--force", action="store_true", help="overwrite existing files")
    bk.add_argument("--quiet", action="store_true", help="no progress bar, only failures and the total")
    bk.set_defaults(func=cmd_bake)


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
    bvh.add_argument("--rest-frame", type=int, default=None,
                     help="take the rest pose from this capture frame (default: the relaxed OFFSET pose)")
    bvh.set_defaults(func=cmd_creatures_from_bvh)
    add_gltf_commands(csub)
    add_bake_command(sub)

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
