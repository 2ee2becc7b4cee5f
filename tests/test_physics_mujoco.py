"""engine.physics against MuJoCo (the ``bench`` extra): the same model, the same answers.

Skipped when mujoco is not installed, so the core suite runs without it. The MJCF comes
from ``benchmarks/physics.py`` (explicit masses and inertias, ball joints at the joint
points), so the benchmark and this test compare the same thing.
"""

from __future__ import annotations

import importlib.util
import os

import numpy as np
import pytest

mj = pytest.importorskip("mujoco")

_spec = importlib.util.spec_from_file_location(
    "bench_physics", os.path.join(os.path.dirname(os.path.dirname(__file__)), "benchmarks", "physics.py"))
bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench)


def test_free_fall_and_pendulum_agree_with_mujoco():
    ours, theirs, exact = bench.free_fall(mj)
    # both are first-order in h; they bracket the exact answer by g h t / 2 = 2.5 mm
    assert abs(ours - exact) < 3e-3 and abs(theirs - exact) < 3e-3
    ours, theirs, analytic = bench.pendulum(mj)
    print(f"\npendulum period: ours {ours:.6f} s, MuJoCo {theirs:.6f} s, small-angle {analytic:.6f} s")
    assert ours == pytest.approx(theirs, rel=1e-4)


def test_ragdoll_rests_at_the_mujoco_height():
    model, pos, rot = bench.humanoid_drop(0.3)
    ours = bench.rest_figures_ours(model, pos, rot, seconds=2.0)
    theirs = bench.rest_figures_mujoco(mj, bench.mjcf_from_model(model, pos, rot), model, seconds=2.0)
    print(f"\nhumanoid drop, 2 s: pelvis height ours {ours[0]:.4f} m, MuJoCo {theirs[0]:.4f} m")
    assert np.isfinite(ours[0])
    assert ours[0] == pytest.approx(theirs[0], abs=0.02)
