"""Every library animation specialized onto every library creature and 100 random creatures,
for its whole length: goals are finite and well formed, and each mode keeps its promise
(ground-relative 1 touches the ground, secondary-relative 1 reaches the target, the
generalized origin is the rest pose)."""

from __future__ import annotations

import glob
import os

import numpy as np
import pytest

import engine
from engine.anim import Goals, bind_all, evaluate_goals, load_animation
from engine.channels import _kernels as K
from engine.channels import ground_height, specialize
from engine.model import build_creature
from engine.model.random import random_creature_def

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ANIMATIONS = sorted(glob.glob(os.path.join(ROOT, "animations", "*.yaml")))
CREATURE_FILES = sorted(glob.glob(os.path.join(ROOT, "creatures", "*.yaml")))
NRANDOM = 100
SAMPLES = 7


@pytest.fixture(scope="module")
def animations():
    return [load_animation(p) for p in ANIMATIONS]


@pytest.fixture(scope="module")
def creatures():
    out = [engine.load_creature(p) for p in CREATURE_FILES]
    out += [build_creature(random_creature_def(seed)) for seed in range(NRANDOM)]
    return out


def random_targets(anim, creature, rng):
    """External targets somewhere around the creature (sometimes behind or above it)."""
    size = float(np.max(creature.size))
    centre = 0.5 * (creature.bounds[0] + creature.bounds[1])
    return {name: centre + rng.uniform(-1.5, 1.5, 3) * size for name in anim.target_names}


def test_every_animation_on_every_creature_is_finite_and_well_formed(animations, creatures):
    assert len(animations) >= 20 and len(creatures) >= NRANDOM + len(CREATURE_FILES)
    rng = np.random.default_rng(0)
    posed_somewhere = {a.name: 0 for a in animations}
    for c in creatures:
        out = Goals.empty(c.nbody)
        scale = max(1.0, float(np.max(c.size)))
        for a in animations:
            targets = random_targets(a, c, rng)
            for t in np.linspace(0.0, a.length, SAMPLES):
                evaluate_goals(a, c, t, targets=targets, out=out)
                for arr in out:
                    assert np.all(np.isfinite(arr)), (a.name, c.name, t)
                assert np.all((out.goal_pos_weight >= 0) & (out.goal_pos_weight <= 1))
                assert np.all((out.goal_rot_weight >= 0) & (out.goal_rot_weight <= 1))
                np.testing.assert_allclose(np.linalg.norm(out.goal_rot, axis=1), 1.0, atol=1e-9)
                # goals stay within a few creature sizes of the creature (no blow-ups)
                far = np.abs(out.goal_pos - c.body_rest_pos).max()
                assert far < 10 * scale, (a.name, c.name, t, far)
                posed_somewhere[a.name] += int(np.any(out.goal_pos_weight > 0) or np.any(out.goal_rot_weight > 0))
    assert all(posed_somewhere.values()), posed_somewhere  # every animation plays on some creature


def test_mode_promises_hold_on_every_creature(animations, creatures):
    rng = np.random.default_rng(1)
    checked = {"ground": 0, "secondary": 0, "rest": 0}
    for c in creatures:
        for a in animations:
            b = bind_all(a, c)
            s = b.slots
            n = s.nslot
            if n == 0:
                continue
            table = np.zeros((len(b.target_names) + c.nbody, 3))
            table[:len(b.target_names)] = rng.normal(size=(len(b.target_names), 3)) * float(np.max(c.size))
            table[len(b.target_names):] = c.body_rest_pos
            ident = np.tile([1.0, 0, 0, 0], (n, 1))
            # the generalized origin is the rest pose (every mode but absolute; lookat's
            # origin is the rest pose aimed at the target, so only rest rotations here)
            ps, rs = specialize(s, np.zeros((n, 3)), ident, table)
            rel = s.slot_pos_mode != K.POS_ABSOLUTE
            has = s.slot_pos_mode != K.POS_NONE
            np.testing.assert_allclose(ps[rel & has], c.body_rest_pos[s.slot_body[rel & has]], atol=1e-12)
            rest_rot = s.slot_rot_mode == K.ROT_REST
            np.testing.assert_allclose(rs[rest_rot], c.body_rest_rot[s.slot_body[rest_rot]], atol=1e-12)
            checked["rest"] += int(np.sum(rel & has))
            # ground-relative z = 1: the body's rest box rests on the ground
            ground = (s.slot_pos_flags & K.FLAG_GROUND) != 0
            if np.any(ground):
                q = np.zeros((n, 3))
                q[:, 2] = 1.0
                ps, _ = specialize(s, q, ident, table)
                for i in np.flatnonzero(ground):
                    body = int(s.slot_body[i])
                    h = ground_height(c, body)
                    if c.body_rest_pos[body, 2] - h > 1e-6:  # bodies already on the ground stay put
                        assert ps[i, 2] == pytest.approx(h, abs=1e-9 * max(1.0, h)), (a.name, c.name)
                        checked["ground"] += 1
            # secondary-relative x = 1 reaches the target (not with SecondaryDirectionalOnly);
            # with contact it stops on the way there, the two boxes' half-widths short of it
            sec = (s.slot_pos_mode == K.POS_SECONDARY) & ((s.slot_pos_flags & K.FLAG_DIRECTIONAL) == 0)
            if np.any(sec):
                q = np.zeros((n, 3))
                q[:, 0] = 1.0
                ps, _ = specialize(s, q, ident, table)
                tol = 1e-9 * max(1.0, float(np.max(c.size)))
                contact = (s.slot_pos_flags & K.FLAG_CONTACT) != 0
                np.testing.assert_allclose(ps[sec & ~contact], table[s.slot_target[sec & ~contact]], atol=tol)
                for i in np.flatnonzero(sec & contact):
                    rest, t = c.body_rest_pos[s.slot_body[i]], table[s.slot_target[i]]
                    d = float(np.linalg.norm(t - rest))
                    u = (t - rest) / d
                    gap = float(np.abs(s.slot_contact[i] @ u).sum())
                    np.testing.assert_allclose(ps[i], rest + u * max(d - gap, K.CONTACT_KEEP * d), atol=tol)
                    checked["contact"] = checked.get("contact", 0) + 1
                checked["secondary"] += int(np.sum(sec))
    assert all(v > 50 for v in checked.values()), checked


def test_keyed_ground_contact_and_target_reach_through_the_whole_pipeline(animations, creatures):
    """pound_ground is keyed at z = 1 at t = 0.5 s: the fists' goals touch the ground on
    every creature that has front graspers; pick_fruit is keyed at x = 1 at t = 1 s: the
    grasper's goal is the fruit wherever the game puts it."""
    by_name = {a.name: a for a in animations}
    pound, pick = by_name["pound_ground"], by_name["pick_fruit"]
    rng = np.random.default_rng(2)
    touched = reached = 0
    for c in creatures:
        g = evaluate_goals(pound, c, 0.5)
        for body in bind_all(pound, c).channel_bodies[pound.channel_index("fists")]:
            h = ground_height(c, int(body))
            if c.body_rest_pos[body, 2] - h > 1e-6:
                assert g.goal_pos[body, 2] == pytest.approx(h, abs=1e-9 * max(1.0, h))
                touched += 1
        fruit = c.body_rest_pos[0] + rng.normal(size=3) * float(np.max(c.size))
        g = evaluate_goals(pick, c, 1.0, targets={"fruit": fruit})
        for body in bind_all(pick, c).channel_bodies[pick.channel_index("hand")]:
            np.testing.assert_allclose(g.goal_pos[body], fruit, atol=1e-9 * max(1.0, float(np.max(c.size))))
            reached += 1
    assert touched > 20 and reached > 20


def test_at_rest_for_one_creature_means_at_rest_for_all(animations, creatures):
    """Non-looping animations that start at the generalized origin start at the rest pose."""
    starts_at_rest = [a for a in animations if not a.loop and all(
        (not ch.position_keys or ch.position_keys[0].value == (0.0, 0.0, 0.0))
        and (ch.position is None or ch.position.mode != "absolute")
        and (ch.rotation is None or ch.rotation.mode == "rest")
        and (not ch.rotation_keys or abs(ch.rotation_keys[0].value[0]) == 1.0)
        for ch in a.channels)]
    assert len(starts_at_rest) >= 5
    for c in creatures[::7]:
        for a in starts_at_rest:
            g = evaluate_goals(a, c, 0.0)
            posed = g.goal_pos_weight > 0
            np.testing.assert_allclose(g.goal_pos[posed], c.body_rest_pos[posed], atol=1e-12)
            rot = g.goal_rot_weight > 0
            assert np.allclose(np.abs(np.sum(g.goal_rot[rot] * c.body_rest_rot[rot], axis=1)), 1.0, atol=1e-12)


def test_mirrored_channels_give_mirror_image_goals_on_symmetric_creatures(animations):
    """Sagittal mirroring (section 4.1.2): on an exactly symmetric creature, a mirroring
    channel gives the right-side body the mirror image of its left partner's goal, in
    position and rotation, through the whole pipeline."""
    by_name = {a.name: a for a in animations}
    names = ["clap", "dance", "wing_flap", "stretch", "hug", "shrug", "wave", "tail_wag"]
    pairs_checked = 0
    for seed in range(12):
        c = build_creature(random_creature_def(seed, symmetric=True))
        for name in names:
            a = by_name[name]
            if not all(ch.mirror for ch in a.channels):
                continue
            for t in np.linspace(0.0, a.length, 5):
                g = evaluate_goals(a, c, t)
                for left in np.flatnonzero(c.body_side > 0):
                    right = int(c.body_mirror[left])
                    if right < 0:
                        continue
                    if g.goal_pos_weight[left] > 0 and g.goal_pos_weight[right] > 0:
                        np.testing.assert_allclose(g.goal_pos[right], g.goal_pos[left] * [1, -1, 1],
                                                   atol=1e-9 * max(1.0, float(np.max(c.size))))
                        pairs_checked += 1
                    if g.goal_rot_weight[left] > 0 and g.goal_rot_weight[right] > 0:
                        m = g.goal_rot[left] * [1, -1, 1, -1]
                        assert abs(abs(float(m @ g.goal_rot[right])) - 1.0) < 1e-9
    assert pairs_checked > 100
