"""The limb aim through the creature's forward (``IKParams.aim_via``, issue 16): a goal
opposite a limb's rest direction (a hanging arm's hand raised to the head) no longer turns
the limb over between two frames."""

from __future__ import annotations

import numpy as np

import engine
from engine.ik.plan import DEFAULT_PARAMS, IKParams, plan_for
from engine.paths import LIBRARY_ANIMATIONS, LIBRARY_CREATURES
from engine.runtime import Character
from engine.validation.record import record_cell


def _worst_turn(rec) -> float:
    r = rec.world_rot
    dots = np.abs(np.sum(r[1:] * r[:-1], axis=-1)).clip(0.0, 1.0)
    return float(np.max(2.0 * np.arccos(dots)))


def test_the_humanoids_wave_does_not_turn_its_arm_over():
    """Measured at 60 Hz: 2.98 rad in one frame (upperarm_l at t = 3.67 s) with the shortest
    arc, 0.51 (clavicle_l, where the hand passes close to the shoulder) through forward. The
    bound is a turn a viewer reads as fast, not as a flip."""
    c = engine.load_creature(LIBRARY_CREATURES / "humanoid.yaml")
    wave = engine.load_animation(LIBRARY_ANIMATIONS / "wave.yaml")
    on = _worst_turn(record_cell(c, wave, 0, settle=0.3, character=Character(c, ik_params=IKParams(aim_via=True))))
    off = _worst_turn(record_cell(c, wave, 0, settle=0.3, character=Character(c, ik_params=IKParams(aim_via=False))))
    assert on < 0.6, on
    assert off > 2.0, off   # the defect this replaces (so the test can fail)


def test_aim_goes_through_forward_across_each_limb_and_only_at_limb_roots():
    """The plan's via directions: unit at every limb root, zero for
    the groups inside a limb (a fork's branches) and everywhere with the switch off."""
    c = engine.load_creature(LIBRARY_CREATURES / "spider.yaml")
    goals = [int(f) for f in c.leg_foot]
    P = plan_for(c, goals, IKParams(aim_via=True)).arrays
    assert P.ag_via.shape == (P.ag_pivot.shape[0], 3)
    roots = P.lp_parent[P.ag_pivot] < 0
    n = np.linalg.norm(P.ag_via, axis=1)
    np.testing.assert_allclose(n[roots], 1.0, atol=1e-9)
    assert np.all(n[~roots] == 0.0)
    assert np.all(plan_for(c, goals, DEFAULT_PARAMS).arrays.ag_via == 0.0) == (not DEFAULT_PARAMS.aim_via)

