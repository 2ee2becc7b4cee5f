"""A grasper whose goal is past its reach does not lift the feet its body stands on
(``IKParams.foot_priority``): the library's prehensile creature waving with its tail, whose
root is the pelvis that also carries its hind legs. With equal shares of the pelvis's pull
(``foot_priority=1``, the rule before stop 32) the tail's goal a metre up lifted the pelvis
19 cm and the hind feet hung 22 cm over their goals (the grid's worst cell: standing_slide
0.55 leg)."""

from __future__ import annotations

import os

import numpy as np
import pytest

import engine
from engine.ik.plan import IKError, IKParams

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _feet_miss(params: IKParams, clip: str = "wave", seconds: float = 1.2) -> tuple[float, float]:
    """The hind feet's largest distance from their goals and the tail tip's, over the clip."""
    c = engine.load_creature(os.path.join(ROOT, "creatures", "prehensile.yaml"))
    a = engine.load_animation(os.path.join(ROOT, "animations", f"{clip}.yaml"))
    ch = engine.Character(c, ik_params=params)
    ch.play(a, variant="tail6", fade=0.0, loop=False)
    feet = [c.body("hindfoot_l"), c.body("hindfoot_r")]
    tip = c.body("tail6")
    worst_feet = worst_tip = 0.0
    for _ in range(int(seconds * 60)):
        ch.tick(1.0 / 60.0)
        s, r = ch._stack, ch._row
        for f in feet:
            assert s.goal_pw[r, f] == 1.0
            worst_feet = max(worst_feet, float(np.linalg.norm(s.char_pos[r, f] - s.goal_pos[r, f])))
        worst_tip = max(worst_tip, float(np.linalg.norm(s.char_pos[r, tip] - s.goal_pos[r, tip])))
    return worst_feet, worst_tip


def test_a_grasper_past_its_reach_leaves_the_feet_on_their_goals():
    height = engine.load_creature(os.path.join(ROOT, "creatures", "prehensile.yaml")).height
    feet, tip = _feet_miss(IKParams())
    assert feet < 1e-3 * height, feet
    # the old equal shares: the feet hang over their goals (what this test guards against)
    feet_eq, tip_eq = _feet_miss(IKParams(foot_priority=1.0))
    assert feet_eq > 0.2 * height, feet_eq
    # the tail still reaches for its goal, it just cannot lift the body to get closer
    assert tip < tip_eq + 0.5 * height, (tip, tip_eq)


def test_foot_priority_is_checked():
    with pytest.raises(IKError, match="foot_priority"):
        IKParams(foot_priority=1.5).validate()
    with pytest.raises(IKError, match="foot_priority"):
        IKParams(foot_priority=-0.1).validate()
