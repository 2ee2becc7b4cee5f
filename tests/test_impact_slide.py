"""Planted feet during the impact response's lookahead (Simulation 1): a foot on the ground at
the hit should not slide while it carries load unless the push exceeds friction. Measured by
benchmarks/impact_slide.py (slip of the contact point every substep)."""

from __future__ import annotations

import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "benchmarks"))

import impact_slide  # noqa: E402


@pytest.mark.xfail(strict=True, reason=(
    "the solver does not converge on planted feet: the friction row's effective mass is the foot "
    "alone and the exact tree joint solve after it shares the correction with the whole body; "
    "measured 0.42 m/s mean unsaturated slip in Simulation 1 at 1 iteration (0.10 at 2, 0.010 at 4, "
    "too costly per tick): the s25-impact5 note"))
def test_planted_feet_do_not_slide_in_the_lookahead():
    o = impact_slide.run("humanoid", [0.3], ndir=2)
    s = o["sim1"]
    assert s["n"] > 100                         # feet were planted and carried load
    assert s["mean_unsat"] < 0.02, s            # m/s where friction was not exceeded
