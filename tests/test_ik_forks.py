"""Forked legs planted on the ground settle in the limb phase (``engine/ik/plan.py``,
``_param_vector``): a fork's branch point is dragged by two children in turn, so a plan
whose forks all end on held feet or graspers gets twice the limb iterations. With the
default count the forkstrider's four planted feet slid 1.4% of its leg (1.4 cm) as a
crouch started to bend its straight forked legs (the grid's standing_slide failing on
seven of its cells)."""

from __future__ import annotations

import os

import numpy as np

import engine
from engine.anim.binding import bind
from engine.anim.fileio import load_animation
from engine.ik import IKSolver
from engine.ik import _kernels as K
from engine.validation.cell import cell_target_sets
from engine.validation.record import record_cell

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_planted_forked_feet_hold_through_a_crouch():
    c = engine.load_creature(os.path.join(ROOT, "creatures", "forkstrider.yaml"))
    a = load_animation(os.path.join(ROOT, "animations", "crouch.yaml"))
    b = bind(a, c)
    r = record_cell(c, a, 0, cell_target_sets(a, c, b, b.variant(0))[0])
    feet = [f for f in c.leg_foot]
    worst = 0.0
    for f0 in range(4, 20):               # the crouch's first bend of the straight legs
        gb = [i for i in range(1, c.nbody) if r.goal_pw[f0, i] > 0 or r.goal_rw[f0, i] > 0]
        s = IKSolver(c, gb)
        for i in gb:
            s.goals.set(i, pos=r.goal_pos[f0, i], rot=r.goal_rot[f0, i], pos_weight=r.goal_pw[f0, i],
                        rot_weight=r.goal_rw[f0, i])
        s.solve(r.root_pos[f0], r.root_rot[f0])
        assert int(s.plan.arrays.params[K.P_LIMB_OUTER]) == 2 * int(s.plan.params.limb_outer)
        worst = max(worst, float(np.max(np.linalg.norm(s.out_pos[feet] - r.goal_pos[f0, feet], axis=1))))
    # a quarter of the slide the grid fails (1% of the leg); 1.4 cm with 6 iterations
    assert worst < 0.0025 * float(np.max(c.leg_length))


def test_a_head_turning_its_eyes_is_not_a_planted_fork():
    """Plans without such forks keep the default cost: the gorilla's head, a limb whose
    eyes and jaw turn to rotation goals, and the benchmark humanoid."""
    for name, bodies in (("gorilla", ["head", "eye_l", "eye_r", "jaw", "foot_l", "foot_r"]),
                         ("humanoid", ["hand_l", "hand_r", "foot_l", "foot_r", "head"])):
        c = engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))
        s = IKSolver(c, bodies)
        assert int(s.plan.arrays.params[K.P_LIMB_OUTER]) == int(s.plan.params.limb_outer), name
