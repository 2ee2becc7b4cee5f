"""``menagerie mocap``: motion capture replayed on physical bodies (engine.response.tracking).

    menagerie mocap simulate FILE.bvh [--mode constrained] [--scale JOINT:K@F0-F1 ...]
                             [--uncontrolled A,B] [--lock JOINT ...] [--mass JOINT=KG ...]
                             [--order 5] [--kf 40] [--kvc 1] [--dt 0.0005] [--gravity-comp]
                             [--frames F0-F1] [--out OUT.bvh] [--report report.json] [--force]
    menagerie mocap tune FILE.bvh [--mode constrained] [--points 10] [--max-order 19]
                         [--seed 0] [--kf 40] [--kvc 1] [--frames F0-F1] [--report tune.json]

``engine/cli.py`` calls ``add_mocap_parser(subparsers)``. Errors a user can
cause raise ``MenagerieError`` subclasses, which the ``menagerie`` command prints in one
line (exit status 2).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

from engine.errors import MenagerieError


def _frames(text: str | None):
    if text is None:
        return None
    try:
        a, b = text.split("-")
        return int(a), int(b)
    except ValueError:
        raise MenagerieError(f"--frames must be F0-F1 (e.g. 0-600), got '{text}'") from None


def _names(values) -> tuple:
    out = []
    for v in values or ():
        out.extend(x.strip() for x in v.split(",") if x.strip())
    return tuple(out)


def _masses(values) -> dict:
    out = {}
    for v in values or ():
        for item in v.split(","):
            if not item.strip():
                continue
            name, sep, kg = item.partition("=")
            try:
                out[name.strip()] = float(kg)
            except ValueError:
                raise MenagerieError(f"--mass must be JOINT=KG (e.g. LeftFoot=5), got '{item}'") from None
            if not sep:
                raise MenagerieError(f"--mass must be JOINT=KG (e.g. LeftFoot=5), got '{item}'")
    return out


def _rig_and_params(args):
    from engine.io import load_bvh
    from engine.response.tracking import ControlOptions, MocapRig, TrackingParams

    clip = load_bvh(args.file)
    params = TrackingParams(order=args.order, k_f=args.kf, k_vc=args.kvc, dt=args.dt, substeps=args.substeps,
                            ground=not args.no_ground, gravity_comp=args.gravity_comp)
    control = ControlOptions(uncontrolled=_names(getattr(args, "uncontrolled", None)),
                             locked=_names(getattr(args, "lock", None)), mass=_masses(getattr(args, "mass", None)))
    rig = MocapRig(clip, args.mode, scale=args.unit_scale, control=control, params=params,
                   frames=_frames(args.frames))
    return rig, params


def _check_outputs(args) -> None:
    """Every output checked before the simulation starts (none is lost to a late error)."""
    from engine.outputs import output_file

    if getattr(args, "out", None):
        output_file(args.out, args.force, flag="--out", suffixes=(".bvh",))
    if args.report:
        output_file(args.report, args.force, flag="--report", suffixes=(".json",))
    if getattr(args, "out", None) and args.report and os.path.abspath(args.out) == os.path.abspath(args.report):
        raise MenagerieError(f"{args.out}: --out and --report name the same file")


def _write_json(path: str, data: dict, force: bool) -> None:
    if os.path.exists(path) and not force:
        raise MenagerieError(f"{path} exists; pass --force to replace it")
    directory = os.path.dirname(path)
    if directory:
        os.makedirs(directory, exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
        f.write("\n")


def _meaning(params) -> str:
    """What the error figure mostly is, in words."""
    if params.gravity_comp:
        return "--gravity-comp holds the bodies up against gravity; what is left is tracking lag"
    return (f"mostly the paper's controller sagging under gravity (velocity error g/K_f = {9.81 / params.k_f:.2f} "
            "m/s); --gravity-comp (not in the paper) removes it")


def cmd_mocap_simulate(args: argparse.Namespace) -> int:
    """Simulate one capture, print the error summary, write the BVH and the report."""
    from engine.io import save_bvh
    from engine.response.tracking import VelocityScale, track

    _check_outputs(args)
    scales = [VelocityScale.parse(s) for s in (args.scale or ())]
    rig, params = _rig_and_params(args)
    result = track(rig, params, scales=scales)   # says once when its kernels compile
    report = result.report()
    print(f"{os.path.basename(args.file)}  mode {rig.mode}  frames {rig.nframe}  bodies {rig.model.nbody}")
    print(f"  mean squared error {result.mse:.6f} m^2   variance {result.var:.6g} m^4   "
          f"last frame {result.final_mse:.6f} m^2")
    print(f"  max joint separation {report['max_joint_separation_mm']:.3f} mm   "
          f"{result.sim_seconds:.2f} s simulated in {result.wall_seconds:.2f} s "
          f"({result.realtime_factor:.1f}x real time)")
    worst = sorted(report["joints"].items(), key=lambda kv: -kv[1]["mse_m2"])[:5]
    print("  worst joints: " + ", ".join(f"{n} {v['mse_m2']:.5f}" for n, v in worst))
    print(f"  {math.sqrt(max(result.mse, 0.0)) * 100:.1f} cm RMS: {_meaning(params)}")
    if args.out:
        save_bvh(result.to_bvh(), args.out, overwrite=True)
        print(f"wrote {args.out}")
    if args.report:
        _write_json(args.report, report, args.force)
        print(f"wrote {args.report}")
    return 0


def cmd_mocap_tune(args: argparse.Namespace) -> int:
    """The paper's Monte Carlo search of (order, K_f, K_vc) on one capture."""
    from engine.response.tracking import tune

    _check_outputs(args)
    rig, params = _rig_and_params(args)

    def progress(i, n, p, mse, best):
        print(f"  point {i + 1}/{args.points} order {n:2d}  K_f {p.k_f:8.3f}  K_vc {p.k_vc:6.4f}  "
              f"mse {mse:.6f}  best {best:.6f}", flush=True)

    result = tune(rig, points=args.points, max_order=args.max_order, seed=args.seed, start=params,
                  step_f=args.step_kf, step_vc=args.step_kvc, progress=None if args.quiet else progress)
    b = result.best
    print(f"best: order {b.order}  K_f {b.k_f:.4f}  K_vc {b.k_vc:.4f}  mean squared error {result.best_mse:.6f} m^2 "
          f"({len(result.history)} simulations, seed {args.seed})")
    if args.report:
        _write_json(args.report, {"file": args.file, "mode": rig.mode, "seed": args.seed, "points": args.points,
                                  "max_order": args.max_order, "best": {"order": b.order, "k_f": b.k_f,
                                                                        "k_vc": b.k_vc, "mse_m2": result.best_mse},
                                  "history": [{"order": n, "k_f": kf, "k_vc": kvc, "mse_m2": m}
                                              for n, kf, kvc, m in result.history]}, args.force)
        print(f"wrote {args.report}")
    return 0


def _common(p: argparse.ArgumentParser) -> None:
    from engine.response.tracking import MODES, TrackingParams

    d = TrackingParams()
    p.add_argument("file", help="a BVH capture")
    p.add_argument("--mode", choices=MODES, default="constrained",
                   help="independent bodies, physical skeleton, or constrained skeleton (default)")
    p.add_argument("--order", type=int, default=d.order, help=f"central-difference points, odd 3..19 ({d.order})")
    p.add_argument("--kf", type=float, default=d.k_f, help=f"controller gain K_f, 1/s ({d.k_f})")
    p.add_argument("--kvc", type=float, default=d.k_vc, help=f"symmetric velocity scale K_vc ({d.k_vc})")
    p.add_argument("--dt", type=float, default=d.dt, help=f"physics step, s ({d.dt})")
    p.add_argument("--substeps", type=int, default=d.substeps, help="substeps per step (1)")
    p.add_argument("--gravity-comp", action="store_true",
                   help="add m g to controlled bodies (not in the paper; removes the g/K_f sag)")
    p.add_argument("--no-ground", action="store_true", help="no floor")
    p.add_argument("--frames", default=None, help="frame range F0-F1 of the capture (default: all)")
    p.add_argument("--unit-scale", type=float, default=None, help="file units to metres (default: auto)")
    p.add_argument("--uncontrolled", action="append", help="bodies left uncontrolled, A,B (repeatable)")
    p.add_argument("--lock", action="append", help="joints locked (constrained mode), A,B (repeatable)")
    p.add_argument("--mass", action="append", help="body masses, JOINT=KG[,JOINT=KG] (repeatable)")
    p.add_argument("--report", default=None, metavar="FILE.json", help="write the report as JSON")
    p.add_argument("--force", action="store_true", help="replace existing output files")


def add_mocap_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``mocap simulate`` and ``mocap tune`` to the ``menagerie`` command's sub-parsers."""
    mocap = subparsers.add_parser("mocap", help="motion capture replayed on physical bodies")

    def need_subcommand(args):
        raise MenagerieError(f"{mocap.prog}: say which: simulate or tune (see {mocap.prog} --help)")

    mocap.set_defaults(func=need_subcommand)
    sub = mocap.add_subparsers(dest="mocap_command", metavar="simulate|tune")
    sim = sub.add_parser("simulate", help="simulate a capture, write BVH and an error report")
    _common(sim)
    sim.add_argument("--scale", action="append",
                     help="asymmetric scaling JOINT:K or JOINT:K@F0-F1, e.g. RightFoot:1.2@200-600 (repeatable)")
    sim.add_argument("--out", default=None, metavar="FILE.bvh", help="write the simulated motion as BVH")
    sim.set_defaults(func=cmd_mocap_simulate)
    tun = sub.add_parser("tune", help="Monte Carlo search of order, K_f and K_vc (Wilke & Semwal Algorithm 1)")
    _common(tun)
    tun.add_argument("--points", type=int, default=10, help="points per run (10)")
    tun.add_argument("--max-order", type=int, default=19, help="largest central-difference order (19)")
    tun.add_argument("--seed", type=int, default=0, help="random seed (0)")
    tun.add_argument("--step-kf", type=float, default=1.0, help="K_f random step (1.0)")
    tun.add_argument("--step-kvc", type=float, default=0.01, help="K_vc random step (0.01)")
    tun.add_argument("--quiet", action="store_true", help="no per-simulation lines")
    tun.set_defaults(func=cmd_mocap_tune)
    return mocap


def main(argv=None) -> int:
    """Stand-alone entry (``python -m engine.mocap_cli simulate ...``) for when the
    ``menagerie`` command is not installed."""
    parser = argparse.ArgumentParser(prog="menagerie")
    sub = parser.add_subparsers(dest="command")
    add_mocap_parser(sub)
    args = parser.parse_args(["mocap", *(sys.argv[1:] if argv is None else argv)])
    try:
        return int(args.func(args) or 0)
    except MenagerieError as exc:
        print(f"menagerie: error: {exc}", file=sys.stderr)
        return 2
    except FileNotFoundError as exc:
        print(f"menagerie: error: {exc.filename}: no such file", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
