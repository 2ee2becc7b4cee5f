"""Start-up cost: the first frame of a character in a fresh process with an empty numba
cache (cold: every kernel compiled) and again with the cache that run left behind
(warm), with the compile time of every kernel the cold run compiled.

    .venv/bin/python benchmarks/startup.py [--warm-runs 3] [--cold-runs 1] [--top 25] [--probes] [--llvm]

The cold run records numba's ``numba:compile`` events: per kernel and signature the
inclusive time (the kernels it calls compiled inside it) and the self time (without
them), wall clock and process CPU time (on a loaded machine the CPU time is the figure
to compare; the wall clock is what a user waits). ``--probes`` adds the older probes
(importing, loading a creature, a first mathx call, a first IK solve), each cold and warm.
``--llvm`` records numba's LLVM pass timings in the cold run and splits each listed kernel's
compile into function passes (its own fresh IR), module passes (its whole module, every
linked callee included, optimized again) and code generation (measured at s38: of the IK's
solve_one 7.4 s, 4.1 function passes, 2.4 module passes, 0.9 code generation).

Ends with one JSON line: cold_start_s and warm_start_s (medians, seconds from process
start to the end of the first tick), cold_start_cpu_s, compile_cpu_s (sum of the self
CPU times), kernels (self CPU seconds of the slowest, "module.function[signature #]"),
by_module, and load (the machine's 1-minute load average before and after).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: What a new user's first run does: import, load a creature and an animation, one tick.
FIRST_TICK = """
import engine
c = engine.load_creature(R + '/creatures/humanoid.yaml')
ch = engine.Character(c)
ch.play(engine.load_animation(R + '/animations/perform.yaml'))
ch.tick(1 / 60)
"""

#: The child: times ``code`` from process start, with a compile listener installed
#: before anything imports numba's kernels.
CHILD = """
import json, sys, time
t0 = time.perf_counter(); c0 = time.process_time()
R = {root!r}; sys.path.insert(0, R)
from numba.core import event as _ev
_stack, _recs = [], []
class _Listener(_ev.Listener):
    def on_start(self, event):
        _stack.append([time.perf_counter(), time.process_time(), 0.0, 0.0])
    def on_end(self, event):
        w0, c0_, cw, cc = _stack.pop()
        w = time.perf_counter() - w0
        c = time.process_time() - c0_
        if _stack:
            _stack[-1][2] += w
            _stack[-1][3] += c
        f = event.data["dispatcher"].py_func
        _recs.append([f.__module__ + "." + f.__qualname__, str(event.data["args"]), w, w - cw, c, c - cc])
        _disp[id(event.data["dispatcher"])] = event.data["dispatcher"]
_disp = {{}}
_ev.register("numba:compile", _Listener())
{code}
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
_llvm = {{}}
for _d in _disp.values():
    _f = _d.py_func
    for _k, _cres in enumerate(_d.overloads.values()):
        _t = {{"function": 0.0, "module": 0.0, "codegen": 0.0}}
        for _name, _info in _cres.library.recorded_timings:
            _kind = ("function" if _name.startswith("Function passes") else
                     "codegen" if _name.startswith("Finalize object") else "module")
            _t[_kind] += _info.get_total_time()
        _llvm[_f.__module__ + "." + _f.__qualname__ + ("" if _k == 0 else f"[{{_k + 1}}]")] = _t
print(json.dumps({{"wall": wall, "cpu": cpu, "compiles": _recs, "llvm": _llvm}}))
"""

PROBES = {
    "import_engine": "import engine",
    "load_creature": "import engine; engine.load_creature(R + '/creatures/humanoid.yaml')",
    "first_mathx_call": ("import numpy as np; from engine.mathx import quat_mul, quat_between; "
                         "quat_mul(np.array([1.,0,0,0]), np.array([1.,0,0,0])); "
                         "quat_between(np.array([1.,0,0]), np.array([0.,1,0]))"),
    "first_ik_solve": ("import engine; from engine.ik import IKSolver; "
                       "c = engine.load_creature(R + '/creatures/humanoid.yaml'); "
                       "s = IKSolver(c, ['hand_l']); s.goals.set(c.body('hand_l'), pos=(0.3, 0.3, 1.2)); "
                       "s.solve(c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy())"),
}


def run(code: str, cache: str, llvm: bool = False) -> dict:
    """Run ``code`` in a fresh interpreter whose numba cache is ``cache`` (``llvm``: with
    numba's LLVM pass timings recorded, per kernel in the result's ``llvm``)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    if llvm:
        env["NUMBA_LLVM_PASS_TIMINGS"] = "1"
    env.pop("NUMBA_DISABLE_JIT", None)
    prog = CHILD.format(root=ROOT, code=code)
    out = subprocess.run([sys.executable, "-c", prog], env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"startup probe failed:\n{out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def median(xs: list[float]) -> float:
    s = sorted(xs)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def kernel_table(compiles: list) -> tuple[dict, dict]:
    """Self CPU seconds per kernel (signatures of one kernel numbered) and per module."""
    per: dict[str, float] = {}
    sigs: dict[str, list[str]] = {}
    for name, sig, _w, _ws, _c, cs in compiles:
        seen = sigs.setdefault(name, [])
        if sig not in seen:
            seen.append(sig)
        key = name if len(seen) == 1 else f"{name}[{seen.index(sig) + 1}]"
        per[key] = per.get(key, 0.0) + cs
    by_module: dict[str, float] = {}
    for name, _sig, _w, _ws, _c, cs in compiles:
        mod = name.split(".<locals>")[0].rsplit(".", 1)[0]
        if not mod.startswith(("engine", "authoring")):
            mod = "numba (library overloads)"
        by_module[mod] = by_module.get(mod, 0.0) + cs
    return per, by_module


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cold-runs", type=int, default=1, help="cold runs (each compiles everything)")
    ap.add_argument("--warm-runs", type=int, default=3)
    ap.add_argument("--top", type=int, default=25, help="kernels listed")
    ap.add_argument("--probes", action="store_true", help="also the import / load / mathx / IK probes")
    ap.add_argument("--llvm", action="store_true",
                    help="split each listed kernel's compile into LLVM function passes, module passes (the "
                         "whole module again, linked callees included) and code generation; the rest of its "
                         "self CPU is numba's own typing and lowering")
    args = ap.parse_args()
    load0 = os.getloadavg()[0]
    colds, warms = [], []
    for _ in range(max(args.cold_runs, 1)):
        with tempfile.TemporaryDirectory() as cache:
            colds.append(run(FIRST_TICK, cache, llvm=args.llvm))
            for _ in range(max(args.warm_runs, 1)):
                warms.append(run(FIRST_TICK, cache))
    cold = min(colds, key=lambda r: r["wall"])   # the table of the median-ish run
    per, by_module = kernel_table(cold["compiles"])
    probes = {}
    if args.probes:
        for name, code in PROBES.items():
            with tempfile.TemporaryDirectory() as cache:
                cold_p = run(code, cache)["wall"]
                probes[name] = {"cold_s": round(cold_p, 3), "warm_s": round(run(code, cache)["wall"], 3)}
    load1 = os.getloadavg()[0]

    cold_s = median([r["wall"] for r in colds])
    cold_cpu = median([r["cpu"] for r in colds])
    warm_s = median([r["wall"] for r in warms])
    compile_cpu = sum(r[5] for r in cold["compiles"])
    print(f"first tick of a humanoid (load average {load0:.1f} -> {load1:.1f} on {os.cpu_count()} cores)")
    print(f"{'cold start, s (wall)':<44}{cold_s:>10.2f}")
    print(f"{'cold start, s (process CPU)':<44}{cold_cpu:>10.2f}")
    print(f"{'  of it compiling, s (CPU)':<44}{compile_cpu:>10.2f}")
    print(f"{'  kernels compiled (with signatures)':<44}{len(cold['compiles']):>10d}")
    print(f"{'warm start, s (wall)':<44}{warm_s:>10.2f}")
    print()
    print(f"{'module':<44}{'self CPU s':>10}")
    for k, v in sorted(by_module.items(), key=lambda kv: -kv[1]):
        print(f"{k:<44}{v:>10.2f}")
    print()
    print(f"{'kernel (slowest ' + str(args.top) + ')':<64}{'self CPU s':>10}")
    top = sorted(per.items(), key=lambda kv: -kv[1])[:args.top]
    for k, v in top:
        print(f"{k:<64}{v:>10.2f}")
    llvm = {}
    if args.llvm:
        print()
        print(f"{'kernel: LLVM s (function / module / codegen)':<64}{'fn':>7}{'mod':>7}{'gen':>7}")
        for k, _v in top:
            t = cold["llvm"].get(k)
            if t is not None:
                llvm[k] = {a: round(b, 2) for a, b in t.items()}
                print(f"{k:<64}{t['function']:>7.2f}{t['module']:>7.2f}{t['codegen']:>7.2f}")
        total = {a: sum(t[a] for t in cold["llvm"].values()) for a in ("function", "module", "codegen")}
        print(f"{'all kernels':<64}{total['function']:>7.2f}{total['module']:>7.2f}{total['codegen']:>7.2f}")
        llvm["all"] = {a: round(b, 2) for a, b in total.items()}
    for name, r in probes.items():
        print(f"probe {name:<38}{r['cold_s']:>10.3f}{r['warm_s']:>10.3f}")
    print(json.dumps({"cold_start_s": round(cold_s, 2), "warm_start_s": round(warm_s, 3),
                      "cold_start_cpu_s": round(cold_cpu, 2), "compile_cpu_s": round(compile_cpu, 2),
                      "kernels_compiled": len(cold["compiles"]),
                      "kernels": {k: round(v, 2) for k, v in top},
                      "by_module": {k: round(v, 2) for k, v in sorted(by_module.items(), key=lambda kv: -kv[1])},
                      "probes": probes, "llvm": llvm, "load": [round(load0, 2), round(load1, 2)],
                      "cpus": os.cpu_count()}))


if __name__ == "__main__":
    main()
