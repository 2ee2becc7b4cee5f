"""The IK plan's hand-over (``engine.runtime._blend_switches``): a clip starting or ending
changes which bodies the IK poses and which goals it reads, and the pose the new plan
gives differs from the old one's even with the new goals at weight zero (a body entering
the IK sub-tree leaves the pose its parent carried it in; a spine body with a goal becomes
a particle of its own). Crossfading a one-shot clip into idle_breathe (which puts goals on
every spine body) turned random creature 4259's arm 2.07 rad and random 24's head 0.79 rad
in one frame. The pose shown last frame is now handed over, decaying in each body's parent
frame, the legs of planted feet excepted."""

from __future__ import annotations

import os

import numpy as np
import pytest

import engine
from engine.mathx import quat_mul, quat_rotate_batch
from engine.model import build_creature, random_creature_def
from engine.physics.world import rotvec_between
from engine.runtime import Character, Crowd
from engine.validation.thresholds import BY_METRIC

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
IDLE = engine.load_animation(os.path.join(ROOT, "animations", "idle_breathe.yaml"))

#: The grid's warning line for a turn in one 60 Hz frame: what a crossfade may turn a body.
STEP = BY_METRIC["rotation_pop"].warn


def _anim(name):
    return engine.load_animation(os.path.join(ROOT, "animations", f"{name}.yaml"))


def _crossfade(chars, clip, ticks):
    """Play ``clip`` on each character, queue idle_breathe behind it, tick ``ticks``
    frames (the characters alone, or as a Crowd when given one); per frame the world
    poses, stacked (ticks, nchar, nbody, ...)."""
    crowd = Crowd(chars) if len(chars) > 1 else None
    for ch in chars:
        ch.play(clip, fade=0.2, loop=False, fade_out=0.3)
        ch.queue(IDLE, fade=0.3)
    pos, rot = [], []
    for _ in range(ticks):
        if crowd is None:
            chars[0].tick(1 / 60)
        else:
            crowd.tick(1 / 60)
        pos.append(np.stack([ch.world_positions.copy() for ch in chars]))
        rot.append(np.stack([ch.world_rotations.copy() for ch in chars]))
    return np.array(pos), np.array(rot)


def _worst_turn(rot):
    return float(np.linalg.norm(rotvec_between(rot[:-1], rot[1:]), axis=-1).max())


@pytest.mark.parametrize("seed,clip,before", [
    (4259, "hold_platter", 2.07),   # the spine's delegated swing at weight 0+ (engine/ik/_kernels.py)
    (24, "hold_platter", 0.79),     # the plan's hand-over: the head enters the IK
])
def test_a_crossfade_into_idle_does_not_pop(seed, clip, before):
    c = build_creature(random_creature_def(seed))
    a = _anim(clip)
    n = int((a.length + 0.8) * 60)
    _, rot = _crossfade([Character(c)], a, n)
    turn = _worst_turn(rot[:, 0])
    assert turn < STEP, f"random {seed} {clip} -> idle_breathe: {turn:.3f} rad in a frame (was {before})"


def test_the_hand_over_in_a_crowd_is_the_characters_alone():
    """Crowd members hand over the same way (the crowd's own stage), and a member ticked
    in a crowd shows what it shows ticked alone (random 24: the hand-over's case)."""
    c = build_creature(random_creature_def(24))
    a = _anim("hold_platter")
    n = int((a.length + 0.8) * 60)
    _, alone = _crossfade([Character(c)], a, n)
    _, crowd = _crossfade([Character(c), Character(c)], a, n)
    assert _worst_turn(crowd[:, 0]) < STEP and _worst_turn(crowd[:, 1]) < STEP
    np.testing.assert_allclose(crowd[:, 0], alone[:, 0], atol=1e-9)


def test_the_hand_over_keeps_joints_joined_and_planted_feet_still():
    """Offsets decay in each body's parent frame: every joint stays where its parent
    carries it (as in the poses on either side of the hand-over); the legs of feet that
    stand show the pose of the frame, so they do not slide."""
    c = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    a = _anim("hold_platter")
    n = int((a.length + 0.8) * 60)
    pos, rot = _crossfade([Character(c)], a, n)
    pos, rot = pos[:, 0], rot[:, 0]
    gaps = []
    for b in range(1, c.nbody):
        p = int(c.body_parent[b])
        joint = pos[:, b] - quat_rotate_batch(rot[:, b], np.tile(c.body_joint_offset[b], (len(pos), 1)))
        local = quat_rotate_batch(rot[:, p] * np.array([1, -1, -1, -1]), joint - pos[:, p])
        gaps.append(np.linalg.norm(local - c.body_local_joint[b], axis=-1).max() / np.linalg.norm(c.body_local_joint[b]))
    # the IK stretches bones by at most 2% (limbs) and 20% (spine chords, spread over
    # their bodies): nothing in a hand-over adds to it
    assert max(gaps) < 0.2
    for f in c.leg_foot:
        drift = np.linalg.norm(pos[1:, f] - pos[:-1, f], axis=-1).max()
        assert drift < 1e-9, f"{c.body_names[f]} moved {drift:.2e} m in a frame while standing"


def test_a_teleport_carries_the_shown_pose_passive_bodies_too():
    """``set_placement(..., teleport=True)`` moves the character with the pose it shows:
    every body, the passive ones (posed in the world by Jiggles, whose character-space rows
    are stale) included, carried rigidly from the old placement to the new one. It rebuilt
    the pose from the character-space rows, and the impact response's stagger, placed
    where it stepped to as it ended, showed random 31's jaw 0.68 rad off for a frame."""
    c = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    ch = Character(c)
    ch.play(_anim("jump_in_place"))
    for _ in range(20):
        ch.tick(1 / 60)                  # passive bodies (ears, jaw) swing behind the jump
    passive = ~ch._stack.driven[ch._row]
    assert passive.any()
    pos0, rot0 = ch.world_positions.copy(), ch.world_rotations.copy()
    heading = 0.7
    ch.set_placement(position=(1.0, -2.0, 0.0), heading=heading, teleport=True)
    q = np.array([np.cos(heading / 2), 0.0, 0.0, np.sin(heading / 2)])
    want_pos = quat_rotate_batch(np.repeat(q[None], c.nbody, axis=0), pos0) + np.array([1.0, -2.0, 0.0])
    np.testing.assert_allclose(ch.world_positions, want_pos, atol=1e-12)
    want_rot = np.array([quat_mul(q, r) for r in rot0])
    d = np.abs(np.sum(ch.world_rotations * want_rot, axis=1))
    assert d.min() > 1 - 1e-12
    ch.tick(1 / 60)                      # and the next frame goes on from there
    assert _worst_turn(np.stack([ch.world_rotations * 0 + want_rot, ch.world_rotations])) < STEP
