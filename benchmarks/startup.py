"""Start-up cost: importing Menagerie, loading a creature, the first numba-compiled call,
and the first frame of a character, each in a fresh process with an empty numba cache
(cold) and again with the cache it left behind (warm).

    .venv/bin/python benchmarks/startup.py

Ends with one JSON line: seconds per probe, cold and warm.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

PROBES = {
    "import_engine": "import engine",
    "load_creature": "import engine; engine.load_creature(R + '/creatures/humanoid.yaml')",
    "first_mathx_call": ("import numpy as np; from engine.mathx import quat_mul, quat_between, hermite5; "
                         "quat_mul(np.array([1.,0,0,0]), np.array([1.,0,0,0])); "
                         "quat_between(np.array([1.,0,0]), np.array([0.,1,0]))"),
    "first_ik_solve": ("import engine, numpy as np; from engine.ik import IKSolver; "
                       "c = engine.load_creature(R + '/creatures/humanoid.yaml'); "
                       "s = IKSolver(c, ['hand_l']); s.goals.set(c.body('hand_l'), pos=(0.3, 0.3, 1.2)); "
                       "s.solve(c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy())"),
    "first_tick": ("import engine; c = engine.load_creature(R + '/creatures/humanoid.yaml'); "
                   "ch = engine.Character(c); ch.play(engine.load_animation(R + '/animations/perform.yaml')); "
                   "ch.tick(1 / 60)"),
}


def run(code: str, cache: str) -> float:
    prog = (f"import time, sys; t0 = time.perf_counter(); R = {ROOT!r}; sys.path.insert(0, R)\n{code}\n"
            "print(time.perf_counter() - t0)")
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    out = subprocess.run([sys.executable, "-c", prog], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    results = {}
    for name, code in PROBES.items():
        with tempfile.TemporaryDirectory() as cache:
            cold = run(code, cache)
            warm = run(code, cache)
        results[name] = {"cold_s": round(cold, 3), "warm_s": round(warm, 3)}
    print(f"{'probe':<20}{'cold s':>10}{'warm s':>10}")
    for name, r in results.items():
        print(f"{name:<20}{r['cold_s']:>10.3f}{r['warm_s']:>10.3f}")
    print(json.dumps(results))


if __name__ == "__main__":
    main()
