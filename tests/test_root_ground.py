"""The root's own box stays out of the ground a standing character stands on
(``engine._runtime_kernels.root_above_ground``): the clip poses the root, so the goals'
ground rule never reached it, and a jump's wind-up pushed a legless crawler's root, which
rests on the ground, a tenth of its height into it (random creature 4248)."""

from __future__ import annotations

import os

import numpy as np

import engine
from engine.ik.plan import body_floor
from engine.model import build_creature
from engine.model.random import random_creature_def

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIGNS = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])


def lowest_corner(c, pos, rot, b) -> float:
    from engine.mathx import quat_rotate

    return float(pos[b, 2] + min(quat_rotate(rot[b], s * c.body_extent[b])[2] for s in SIGNS))


def play(c, name, seconds):
    ch = engine.Character(c)
    ch.play(engine.load_animation(os.path.join(ROOT, "animations", f"{name}.yaml")))
    lows, roots = [], []
    for _ in range(int(seconds * 60)):
        ch.tick(1 / 60)
        lows.append(lowest_corner(c, ch.world_positions, ch.world_rotations, 0))
        roots.append(ch.world_positions[0].copy())
    return np.array(lows), np.array(roots)


def test_a_crawlers_root_stays_on_the_ground_through_a_jump():
    c = build_creature(random_creature_def(4248))
    assert c.nleg == 0
    floor = float(body_floor(c)[0])
    assert lowest_corner(c, c.body_rest_pos, c.body_rest_rot, 0) < 0.05 * c.height   # it lies low, near the ground
    lows, roots = play(c, "jump_in_place", 1.2)
    assert lows.min() >= floor - 1e-9 * c.height
    # lifted just enough, and smoothly: the root never jumps between frames
    assert np.max(np.abs(np.diff(roots[:, 2]))) < 0.02 * c.height


def test_a_standing_humanoid_crouches_as_the_clip_says():
    """A root well above the ground is left where the clip puts it."""
    c = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    lows, roots = play(c, "crouch", 1.0)
    assert roots[:, 2].min() < c.body_rest_pos[0, 2] - 0.05      # it does crouch
    assert lows.min() > 0.0
