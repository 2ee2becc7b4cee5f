"""Jiggles (Hecker et al. 2008, sec. 4.4): passive, never feeding back, settling, stable."""

from __future__ import annotations

import numpy as np
import pytest

from engine.jiggle import JiggleRig, JiggleState, jiggle_step
from engine.mathx.quat import quat_from_axis_angle, quat_mul, quat_rotate
from engine.model import build_creature, creature_from_text

TEXT = """\
format: 1
name: tailed
description: a body with legs, a head with ears and a three-segment tail
bodies:
  - {name: hips, caps: [spine], pos: [0, 0, 0.5], extents: [0.15, 0.1, 0.08]}
  - {name: chest, parent: hips, caps: [spine], pos: [0.35, 0, 0.55], joint: [0.17, 0, 0.52], extents: [0.15, 0.1, 0.1]}
  - {name: leg_l, parent: hips, caps: [limb, foot], pos: [0, 0.08, 0.22], joint: [0, 0.08, 0.44], extents: [0.03, 0.03, 0.22]}
  - {name: leg_r, parent: hips, caps: [limb, foot], pos: [0, -0.08, 0.22], joint: [0, -0.08, 0.44], extents: [0.03, 0.03, 0.22]}
  - {name: head, parent: chest, caps: [head], pos: [0.6, 0, 0.65], joint: [0.5, 0, 0.6], extents: [0.08, 0.07, 0.07]}
  - {name: ear_l, parent: head, caps: [ear], pos: [0.6, 0.05, 0.78], joint: [0.6, 0.05, 0.72], extents: [0.01, 0.02, 0.06]}
  - {name: ear_r, parent: head, caps: [ear], pos: [0.6, -0.05, 0.78], joint: [0.6, -0.05, 0.72], extents: [0.01, 0.02, 0.06]}
  - {name: tail1, parent: hips, caps: [tail, limb], pos: [-0.25, 0, 0.5], joint: [-0.15, 0, 0.5], extents: [0.1, 0.03, 0.03]}
  - {name: tail2, parent: tail1, caps: [tail, limb], pos: [-0.45, 0, 0.5], joint: [-0.35, 0, 0.5], extents: [0.1, 0.025, 0.025]}
  - {name: tail3, parent: tail2, caps: [tail, limb], pos: [-0.65, 0, 0.5], joint: [-0.55, 0, 0.5], extents: [0.1, 0.02, 0.02]}
"""


@pytest.fixture(scope="module")
def creature():
    return creature_from_text(TEXT)


def _driven(c):
    driven = np.zeros(c.nbody, np.bool_)
    for name in ("hips", "chest", "leg_l", "leg_r"):
        driven[c.body(name)] = True
    return driven


def _pose_driven(c, driven, root_pos, root_rot, pos, rot):
    """Rigid FK of the driven bodies from a moving root (what IK would hand over)."""
    pos[0], rot[0] = root_pos, root_rot
    for i in range(1, c.nbody):
        if driven[i]:
            p = c.body_parent[i]
            rot[i] = quat_mul(rot[p], c.body_local_rot[i])
            pos[i] = pos[p] + quat_rotate(rot[p], c.body_local_pos[i])


def _root_motion(t, stop=1.0):
    """A brisk back-and-forth swing with a turn, stopping dead at ``stop`` seconds."""
    t = min(t, stop)
    pos = np.array([0.4 * np.sin(6.0 * t), 0.1 * np.sin(9.0 * t), 0.5 + 0.05 * np.sin(12.0 * t)])
    rot = quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), 0.8 * np.sin(5.0 * t))
    return pos, rot


def _run(c, rig, dt, seconds, simulate=True, stop=1.0):
    driven = _driven(c)
    state = JiggleState(c.nbody)
    pos = np.array(c.body_rest_pos, dtype=float)
    rot = np.array(c.body_rest_rot, dtype=float)
    frames = []
    for f in range(int(round(seconds / dt))):
        root_pos, root_rot = _root_motion(f * dt, stop)
        _pose_driven(c, driven, root_pos, root_rot, pos, rot)
        jiggle_step(rig, state, driven, pos, rot, dt, simulate=simulate)
        frames.append((pos.copy(), rot.copy(), state.err.copy()))
    return frames, state


def _rigid(c, pos, rot):
    """Where the passive bodies sit at their rest offsets from the current driven pose."""
    out_pos, out_rot = pos.copy(), rot.copy()
    driven = _driven(c)
    for i in range(1, c.nbody):
        if not driven[i]:
            p = c.body_parent[i]
            out_rot[i] = quat_mul(out_rot[p], c.body_local_rot[i])
            out_pos[i] = out_pos[p] + quat_rotate(out_rot[p], c.body_local_pos[i])
    return out_pos, out_rot


def test_driven_bodies_are_bit_identical_with_jiggle_on_and_off(creature):
    rig = JiggleRig.for_creature(creature)
    on, _ = _run(creature, rig, 1 / 60, 1.5, simulate=True)
    off, _ = _run(creature, rig, 1 / 60, 1.5, simulate=False)
    driven = _driven(creature)
    for (p_on, r_on, _), (p_off, r_off, _) in zip(on, off, strict=True):
        assert np.array_equal(p_on[driven], p_off[driven])
        assert np.array_equal(r_on[driven], r_off[driven])
    # ...and the passive bodies really did move differently (the test can fail).
    tail3 = creature.body("tail3")
    lag = max(np.linalg.norm(a[0][tail3] - b[0][tail3]) for a, b in zip(on, off, strict=True))
    assert lag > 0.01


def test_off_means_rigid_at_rest_offsets(creature):
    rig = JiggleRig.for_creature(creature)
    frames, _ = _run(creature, rig, 1 / 60, 0.5, simulate=False)
    for pos, rot, _ in frames:
        rp, rr = _rigid(creature, pos, rot)
        assert np.allclose(pos, rp, atol=1e-12) and np.allclose(rot, rr, atol=1e-12)


@pytest.mark.parametrize("dt", [1 / 240, 1 / 60, 1 / 30, 1 / 15])
def test_stable_and_settles_exactly(creature, dt):
    rig = JiggleRig.for_creature(creature)
    frames, state = _run(creature, rig, dt, 5.0, stop=1.0)
    lever = np.linalg.norm(rig.lever, axis=1)
    for pos, rot, err in frames:
        assert np.all(np.isfinite(pos)) and np.all(np.isfinite(rot))
        assert np.all(np.linalg.norm(err, axis=1) <= rig.max_err + 1e-12)
        assert np.allclose(np.linalg.norm(rot, axis=1), 1.0)
    # Within 3 s of the stop every passive body is exactly back at its rest offset (asleep).
    settle = int(round(4.0 / dt))
    for pos, rot, err in frames[settle:]:
        assert np.all(err == 0.0)
        rp, rr = _rigid(creature, pos, rot)
        assert np.allclose(pos, rp, atol=1e-12 * (1 + lever.max()))
    # No twitching: the last frames do not move at all.
    assert np.array_equal(frames[-1][0], frames[-2][0])


def test_tips_lag_more_than_roots(creature):
    rig = JiggleRig.for_creature(creature)
    frames, _ = _run(creature, rig, 1 / 60, 1.0)
    t1, t3 = creature.body("tail1"), creature.body("tail3")
    dev = {i: max(np.linalg.norm(err[i]) / np.linalg.norm(rig.lever[i]) for _, _, err in frames) for i in (t1, t3)}
    assert dev[t3] > dev[t1] > 0.0


def _long_tail(links: int = 8) -> str:
    lines = ["format: 1", "name: longtail", "description: hips on two legs and a long passive tail", "bodies:",
             "  - {name: hips, caps: [spine], pos: [0, 0, 0.5], extents: [0.15, 0.1, 0.08]}",
             "  - {name: leg_l, parent: hips, caps: [limb, foot], pos: [0, 0.08, 0.22], joint: [0, 0.08, 0.44], "
             "extents: [0.03, 0.03, 0.22]}",
             "  - {name: leg_r, parent: hips, caps: [limb, foot], pos: [0, -0.08, 0.22], joint: [0, -0.08, 0.44], "
             "extents: [0.03, 0.03, 0.22]}"]
    for k in range(links):
        parent = "hips" if k == 0 else f"tail{k}"
        x0 = -0.15 - 0.2 * k
        lines.append(f"  - {{name: tail{k + 1}, parent: {parent}, caps: [tail, limb], pos: [{x0 - 0.1:.2f}, 0, 0.5], "
                     f"joint: [{x0:.2f}, 0, 0.5], extents: [0.1, 0.03, 0.03]}}")
    return "\n".join(lines) + "\n"


def test_a_passive_chain_is_not_a_whip():
    """The hips drop by d and stop: no link of a long passive tail strays further than d
    from where the rigid tail would be, and the tail lags the right way (up). (A chain of
    springs each driven by its own jiggling parent is a whip: this tail's tip swung 6.7 d.)"""
    c = creature_from_text(_long_tail())
    rig = JiggleRig.for_creature(c)
    driven = np.zeros(c.nbody, np.bool_)
    for name in ("hips", "leg_l", "leg_r"):
        driven[c.body(name)] = True
    state = JiggleState(c.nbody)
    pos = np.array(c.body_rest_pos, dtype=float)
    rot = np.array(c.body_rest_rot, dtype=float)
    d, dt = 0.2, 1 / 60
    tail = [i for i in range(c.nbody) if not driven[i]]
    worst = np.zeros(c.nbody)
    tip = c.body(f"tail{len(tail)}")
    first_lag = None
    for f in range(240):
        t = min(f * dt / 0.3, 1.0)
        drop = d * (3 * t * t - 2 * t * t * t)
        pos[0], rot[0] = (0.0, 0.0, 0.5 - drop), (1.0, 0.0, 0.0, 0.0)
        for i in (c.body("leg_l"), c.body("leg_r")):
            pos[i] = pos[0] + c.body_local_pos[i]
        jiggle_step(rig, state, driven, pos, rot, dt)
        rigid = pos[0] + (c.body_rest_pos - c.body_rest_pos[0])     # the hips only translate
        worst = np.maximum(worst, np.linalg.norm(pos - rigid, axis=1))
        if f == 10:
            first_lag = pos[tip, 2] - rigid[tip, 2]
    assert np.all(worst[tail] > 0.0) and np.all(worst[tail] <= d), worst[tail]
    assert first_lag > 0.0


def _all_driven_at_rest(c):
    """A fresh rig and state, the rest pose, and every body driven."""
    return (JiggleRig.for_creature(c), JiggleState(c.nbody), np.array(c.body_rest_pos, dtype=float),
            np.array(c.body_rest_rot, dtype=float), np.ones(c.nbody, np.bool_))


def test_body_becoming_passive_starts_where_it_was(creature):
    rig, state, pos, rot, driven = _all_driven_at_rest(creature)
    head = creature.body("head")
    # The head is animated, tilted 0.5 rad; next frame the animation lets go of it.
    tilt = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.5)
    rot[head] = quat_mul(tilt, rot[head])
    pos[head] = creature.body_joint[head] + quat_rotate(rot[head], creature.body_joint_offset[head])
    before = pos[head].copy(), rot[head].copy()
    driven[head] = False
    driven[creature.body("ear_l")] = driven[creature.body("ear_r")] = False
    jiggle_step(rig, state, driven, pos, rot, 1 / 60)
    # One frame later it has moved back toward rest a little, not snapped there.
    moved = np.linalg.norm(pos[head] - before[0])
    rest_gap = np.linalg.norm(creature.body_rest_pos[head] - before[0])
    assert 0.0 < moved < 0.5 * rest_gap


def _angle(a, b) -> float:
    return float(2.0 * np.arccos(min(1.0, abs(float(np.dot(a, b))))))


def test_body_becoming_passive_keeps_its_twist_and_springs_it_back(creature):
    """The lever alone does not say how a body is turned about it: a tail segment the
    animation (or the IK) twisted 0.8 rad about its own lever, let go of, used to turn
    back in one frame (a 0.8 rad pop as every clip ended). The twist is kept at the
    hand-off and springs back to zero like the deflection: one frame later it has moved
    a little, and within two seconds it is at rest."""
    rig, state, pos, rot, driven = _all_driven_at_rest(creature)
    tail = creature.body("tail1")
    lever = quat_rotate(rot[tail], rig.lever[tail])
    twist = quat_from_axis_angle(lever / np.linalg.norm(lever), 0.8)
    rot[tail] = quat_mul(twist, rot[tail])
    before = rot[tail].copy()
    for name in ("tail1", "tail2", "tail3"):
        driven[creature.body(name)] = False
    jiggle_step(rig, state, driven, pos, rot, 1 / 60)
    first = _angle(rot[tail], before)
    assert first < 0.1, f"turned {first:.3f} rad in the hand-off frame"
    np.testing.assert_allclose(np.linalg.norm(rot[tail]), 1.0, atol=1e-12)
    turns = [first]
    for _ in range(120):
        prev = rot[tail].copy()
        jiggle_step(rig, state, driven, pos, rot, 1 / 60)
        turns.append(_angle(rot[tail], prev))
    assert max(turns) < 0.1, f"largest turn per frame {max(turns):.3f} rad"
    assert _angle(rot[tail], creature.body_rest_rot[tail]) < 1e-6
    assert state.twist[tail, 0] == 0.0   # asleep: exactly at rest


def test_eyes_ride_rigidly_in_their_heads():
    """An eye has no lever to swing on: under a head that whips back and forth and stops
    dead, the humanoid's eyes keep their rest pose relative to the head exactly (as a
    stiff 8 Hz spring each swung 0.59 rad in the frame the head stopped in pick_fruit)."""
    import engine
    from engine.paths import LIBRARY_CREATURES

    c = engine.load_creature(LIBRARY_CREATURES / "humanoid.yaml")
    rig, state, pos, rot, driven = _all_driven_at_rest(c)
    eyes = [c.body("eye_l"), c.body("eye_r")]
    head = c.body("head")
    for e in eyes:
        driven[e] = False
    rest_rel = [quat_mul(np.array([c.body_rest_rot[head][0], *(-c.body_rest_rot[head][1:])]), c.body_rest_rot[e])
                for e in eyes]
    worst = 0.0
    for k in range(60):
        ang = 0.9 * np.sin(0.5 * k) if k < 30 else 0.9 * np.sin(15.0)
        rot[head] = quat_mul(quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), ang), c.body_rest_rot[head])
        jiggle_step(rig, state, driven, pos, rot, 1 / 60)
        hinv = np.array([rot[head][0], *(-rot[head][1:])])
        for e, rel in zip(eyes, rest_rel, strict=True):
            worst = max(worst, _angle(quat_mul(hinv, rot[e]), rel))
    assert worst < 1e-6, worst   # arccos of a dot product within rounding of 1


def test_invalid_input(creature):
    rig = JiggleRig.for_creature(creature)
    state = JiggleState(creature.nbody)
    pos = np.array(creature.body_rest_pos, dtype=float)
    rot = np.array(creature.body_rest_rot, dtype=float)
    with pytest.raises(ValueError, match="dt"):
        jiggle_step(rig, state, _driven(creature), pos, rot, 0.0)
    with pytest.raises(ValueError, match="dt"):
        jiggle_step(rig, state, _driven(creature), pos, rot, float("nan"))
    with pytest.raises(ValueError, match="root"):
        jiggle_step(rig, state, np.zeros(creature.nbody, np.bool_), pos, rot, 1 / 60)
    with pytest.raises(ValueError, match="damping"):
        rig.with_params(damping_ratio=np.zeros(creature.nbody))


def test_flexibility_heuristic_orders(creature):
    rig = JiggleRig.for_creature(creature)
    f = rig.omega / (2 * np.pi)
    b = creature.body
    assert f[b("tail3")] < f[b("tail1")]          # placement: further out is floppier
    assert f[b("ear_l")] < f[b("head")]           # capability: ears flop
    big_def = creature.to_def()
    for body in big_def.bodies:
        body.pos = tuple(10 * v for v in body.pos)
        body.joint = tuple(10 * v for v in body.joint)
        body.extents = tuple(10 * v for v in body.extents)
    big = build_creature(big_def)
    assert JiggleRig.for_creature(big).omega[b("tail1")] < rig.omega[b("tail1")]  # size


def _lift(rot, joint=(0.0, 0.0, 0.05), extent=(0.041, 0.005, 0.025), offset=(0.041, 0.0, 0.0)):
    """The ground lift of one box (``engine.jiggle._kernels._ground_contact``) turned as
    ``rot`` about a joint at ``joint``, on the plane z = 0, four steps of it: the lifted
    rotation."""
    from engine.jiggle import _kernels as JK

    q = np.array(rot, float)
    for _ in range(4):          # a step lifts at most LIFT_MAX; frames repeat it
        JK._ground_contact(q, np.array(joint, float), np.array(offset, float), np.array(extent, float),
                           np.array([0.0, 0.0, 1.0, 0.0]), np.zeros((8, 3)), np.zeros(4))
    return q


def _angle(a, b):
    return 2.0 * np.arccos(min(abs(float(np.dot(a, b))), 1.0))


def _lowest(rot, joint=(0.0, 0.0, 0.05), extent=(0.041, 0.005, 0.025), offset=(0.041, 0.0, 0.0)):
    origin = np.array(joint) + quat_rotate(rot, np.array(offset))
    return min(float((origin + quat_rotate(rot, np.array(extent) * np.array(s)))[2])
               for s in np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).T.reshape(-1, 3))


def test_the_ground_lift_is_continuous_as_the_lowest_corner_changes():
    """A flat body (a bat's tail membrane: 8 x 5 x 1 cm, wide in the plane it pitches in)
    pitched into the ground from a joint 5 cm up, rolled a hair either side of level: its
    two far corners swap which one is lowest, and the lifted pose must not jump. The rule
    that lifted the lowest corner about its own arm turned the body one way or the other
    (0.87 rad apart in one frame of the grid, on a still pelvis)."""
    pitch = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), 1.2)      # far end down into the ground
    worst = 0.0
    for eps in (1e-4, 1e-3):
        roll_p = quat_mul(pitch, quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), eps))
        roll_m = quat_mul(pitch, quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), -eps))
        a, b = _lift(roll_p), _lift(roll_m)
        assert _lowest(roll_p) < -0.01 and _lowest(a) > -1e-4 and _lowest(b) > -1e-4, "lifted onto the plane"
        worst = max(worst, _angle(a, b) / (2 * eps))
    assert worst < 5.0, f"lifted rotations differ by {worst:.1f} x the roll between the inputs"


def test_the_ground_lift_does_not_chase_what_no_turn_lifts():
    """A box centred on its joint, the joint at the ground (a jaw on a head put there by the
    IK): turning it about the joint lifts one end and sinks the other, so the lift leaves it
    where its lowest point is highest instead of swinging it (0.5 rad a frame on a snake)."""
    tilt = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.15)
    q = _lift(tilt, joint=(0.0, 0.0, 0.0), extent=(0.04, 0.03, 0.005), offset=(0.0, 0.0, 0.003))
    assert _angle(q, tilt) < 0.2
    assert _lowest(q, (0.0, 0.0, 0.0), (0.04, 0.03, 0.005), (0.0, 0.0, 0.003)) >= \
        _lowest(tilt, (0.0, 0.0, 0.0), (0.04, 0.03, 0.005), (0.0, 0.0, 0.003)) - 1e-9


def test_a_tail_lying_on_the_ground_rests_there():
    """A random creature (seed 4257, nobody tuned on it) falls on its back and lies: its tail
    lies on the ground while its rigid pose points through the body into it. When the spring
    carried the ground's lift, it could hold at most 0.9 of its lever of that, was lifted
    anew every frame and swept half a circle round its joint in 10 frames (0.88 rad a
    frame); the ground's hold is kept apart from the spring now."""
    import glob
    import os

    import engine
    from engine.model import random_creature_def
    from engine.physics.world import rotvec_between

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    c = build_creature(random_creature_def(4257))
    fall, lie = (engine.load_animation(glob.glob(os.path.join(root, "animations", "reactions", f"{n}.yaml"))[0])
                 for n in ("fall_back", "lie_back"))
    ch = engine.Character(c)
    ch.play(fall, fade=0.2)
    ch.queue(lie, fade=0.2, fade_out=0.2, loop=False)
    tail = c.body_names.index("tail0_seg1")
    prev = ch.world_rotations.copy()
    worst, low = 0.0, np.inf
    for _ in range(int((fall.length + lie.length) * 60)):
        ch.tick(1 / 60)
        worst = max(worst, float(np.linalg.norm(rotvec_between(prev[tail:tail + 1],
                                                               ch.world_rotations[tail:tail + 1]))))
        low = min(low, float(ch.world_positions[tail, 2]))
        prev = ch.world_rotations.copy()
    assert worst < 0.5, f"the tail turned {worst:.2f} rad in one frame"
    assert low > -0.01 * c.height, f"the tail's centre {low:.4f} m under the ground"
