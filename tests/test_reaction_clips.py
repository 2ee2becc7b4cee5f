"""The generalized reaction clips (animations/reactions/, written by its _generate.py) step the
way a push goes on every creature: the goals they give, checked on the library and on random
creatures. Until stop 32 the lateral clips mirrored their keys on right-side bodies: the
right feet of a stagger to the left stepped right (away from the push), stagger_right and the
falls to the side crossed the feet, and the brace stepped the right feet inward across the
midline (the grid's reaction run: 265 cells with flips, shins turning 2-3 rad)."""

from __future__ import annotations

import glob
import os

import numpy as np
import pytest

import engine
from engine.anim import evaluate_goals, load_animation
from engine.anim.binding import BindError
from engine.model import build_creature
from engine.model.caps import FOOT, GRASPER
from engine.model.random import random_creature_def

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REACTIONS = os.path.join(ROOT, "animations", "reactions")
DIRS = {"left": (0.0, 1.0), "right": (0.0, -1.0), "front": (1.0, 0.0), "back": (-1.0, 0.0)}


@pytest.fixture(scope="module")
def creatures():
    names = ["humanoid", "dog", "spider", "hexapod", "trex", "gorilla", "centaur", "tripod"]
    out = [engine.load_creature(os.path.join(ROOT, "creatures", f"{n}.yaml")) for n in names]
    out += [build_creature(random_creature_def(seed)) for seed in range(20)]
    return out


@pytest.fixture(scope="module")
def reactions():
    return {os.path.basename(p)[:-5]: load_animation(p) for p in sorted(glob.glob(os.path.join(REACTIONS, "*.yaml")))}


def _goals(anim, creature, times):
    """Position goals (t, nbody, 3) and weights, or None where the clip does not bind."""
    out = []
    for t in times:
        try:
            g = evaluate_goals(anim, creature, float(t))
        except BindError:
            return None
        out.append((g.goal_pos.copy(), g.goal_pos_weight.copy()))
    return out


def _bodies(creature, cap):
    return np.flatnonzero((creature.body_caps & np.uint32(cap)) != 0)


def test_a_stagger_steps_every_foot_toward_the_push(reactions, creatures):
    """Every foot ends displaced along the push, by the same amount for all of them (the clip
    ends in the rest pose moved over), and no foot moves against the push on the way."""
    checked = 0
    for c in creatures:
        feet = _bodies(c, FOOT)
        size = float(np.max(c.size))
        for d, (ux, uy) in DIRS.items():
            a = reactions[f"stagger_{d}"]
            times = np.linspace(0.0, a.length, 23)
            gs = _goals(a, c, times)
            if gs is None:
                continue
            u = np.array([ux, uy, 0.0])
            ends = []
            for pos, w in gs:
                for f in feet:
                    if w[f] <= 0.0:
                        continue
                    disp = pos[f] - c.body_rest_pos[f]
                    assert disp @ u > -0.01 * size, (c.name, d, c.body_names[f], disp)
            pos, w = gs[-1]
            for f in feet:
                if w[f] > 0.0:
                    disp = pos[f] - c.body_rest_pos[f]
                    assert disp @ u > 0.01 * size and disp @ u > 0.99 * np.linalg.norm(disp), \
                        (c.name, d, c.body_names[f], disp)
                    ends.append(disp)
                    checked += 1
            if ends:
                spread = np.ptp(np.array(ends), axis=0)
                assert np.all(spread < 1e-6 * max(1.0, size)), (c.name, d, spread)
    assert checked > 200


def test_reactions_keep_left_and_right_bodies_on_their_sides(reactions, creatures):
    """For every mirror pair of feet and graspers both held by a reaction clip, the left body
    stays to the left of its partner at every sampled time (crossed feet flip the legs)."""
    checked = 0
    for c in creatures:
        pairs = [(int(b), int(c.body_mirror[b])) for b in np.concatenate([_bodies(c, FOOT), _bodies(c, GRASPER)])
                 if c.body_side[b] > 0 and c.body_mirror[b] >= 0]
        if not pairs:
            continue
        for name, a in reactions.items():
            gs = _goals(a, c, np.linspace(0.0, a.length, 13))
            if gs is None:
                continue
            for pos, w in gs:
                for left, right in pairs:
                    if w[left] > 0.0 and w[right] > 0.0:
                        rest_gap = c.body_rest_pos[left, 1] - c.body_rest_pos[right, 1]
                        gap = pos[left, 1] - pos[right, 1]
                        assert gap * np.sign(rest_gap) > 0.0, (c.name, name, c.body_names[left], gap, rest_gap)
                        checked += 1
    assert checked > 2000


def test_the_brace_steps_every_foot_outward(reactions, creatures):
    checked = 0
    a = reactions["brace"]
    for c in creatures:
        gs = _goals(a, c, [0.5])
        if gs is None:
            continue
        pos, w = gs[0]
        for f in _bodies(c, FOOT):
            side = int(c.body_side[f])
            if w[f] > 0.0 and side != 0:
                out = (pos[f, 1] - c.body_rest_pos[f, 1]) * side
                assert out > 0.0, (c.name, c.body_names[f], out)
                checked += 1
    assert checked > 50
