"""Keyed curves, blending and key remapping (Hecker 2008 sec 3.2.3 and 3.3)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_channels import MINI

from engine.anim import animation_from_text, remap_channel
from engine.channels import (
    PositionSpec,
    RotationSpec,
    Slot,
    auto_tangents,
    build_slots,
    ownership,
    rotation_auto_tangents,
    sample_rotation,
    sample_vector,
    specialize,
)
from engine.channels._kernels import blend_kernel
from engine.mathx.quat import quat_from_rotvec, quat_mul, quat_slerp
from engine.model import build_creature, creature_from_text, load_creature
from engine.model.random import random_creature_def


def hermite_reference(times, values, tout, tin, t):
    """Plain cubic Hermite, written from the textbook formula."""
    if t <= times[0]:
        return values[0]
    if t >= times[-1]:
        return values[-1]
    a = int(np.searchsorted(times, t, side="right")) - 1
    h = times[a + 1] - times[a]
    s = (t - times[a]) / h
    return ((2 * s**3 - 3 * s**2 + 1) * values[a] + (s**3 - 2 * s**2 + s) * h * tout[a]
            + (-2 * s**3 + 3 * s**2) * values[a + 1] + (s**3 - s**2) * h * tin[a + 1])


def test_vector_curve_matches_reference():
    rng = np.random.default_rng(0)
    times = np.cumsum(rng.uniform(0.1, 0.5, 6))
    values, tout, tin = rng.normal(size=(3, 6, 3))
    for t in np.linspace(times[0] - 0.2, times[-1] + 0.2, 97):
        np.testing.assert_allclose(sample_vector(times, values, tout, tin, t),
                                   hermite_reference(times, values, tout, tin, t), atol=1e-12)


def test_auto_tangents():
    times = np.array([0.0, 0.3, 1.0, 1.2])
    values = (times**2)[:, None] * [1.0, -2.0, 0.5]           # a parabola
    m = auto_tangents(times, values)
    np.testing.assert_allclose(m[1:3], (2 * times[1:3])[:, None] * [1.0, -2.0, 0.5], atol=1e-12)  # exact
    np.testing.assert_allclose(m[[0, -1]], 0.0)                 # ends ease in and out
    # clamped: extrema and plateaus get flat tangents, so holds hold and nothing overshoots
    m = auto_tangents([0.0, 1.0, 2.0, 3.0, 4.0], [[0.0], [1.0], [1.0], [0.5], [2.0]])
    assert m[1, 0] == 0.0 and m[2, 0] == 0.0 and m[3, 0] == 0.0
    for t in np.linspace(1.0, 2.0, 11):
        assert sample_vector([0.0, 1.0, 2.0, 3.0, 4.0], [[0.0], [1.0], [1.0], [0.5], [2.0]], m, m, t)[0] == 1.0
    # looping with the first key at 0 and the last at the length: the ends share a tangent
    loop = np.array([[0.0], [1.0], [0.0], [-1.0], [0.0]])
    lt = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    m = auto_tangents(lt, loop, loop_length=2.0)
    assert m[0, 0] == m[-1, 0] == pytest.approx(2.0)           # (1 - (-1)) / 1
    # sampling just either side of the loop point gives the same slope
    eps = 1e-6
    s0 = (sample_vector(lt, loop, m, m, eps) - sample_vector(lt, loop, m, m, 0.0)) / eps
    s1 = (sample_vector(lt, loop, m, m, 2.0) - sample_vector(lt, loop, m, m, 2.0 - eps)) / eps
    assert s0[0] == pytest.approx(s1[0], rel=1e-4)


def rand_quats(rng, n):
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_rotation_curve_with_geodesic_tangents_is_slerp():
    rng = np.random.default_rng(1)
    qa, qb = rand_quats(rng, 2)
    from engine.mathx.quat import quat_conj, quat_to_rotvec
    r = quat_to_rotvec(quat_mul(quat_conj(qa), qb))
    w = r / 2.0  # two keys 2 s apart, constant angular velocity
    times = np.array([0.0, 2.0])
    tang = np.array([w, w])
    for t in np.linspace(0, 2, 11):
        q = sample_rotation(times, np.array([qa, qb]), tang, tang, t)
        s = quat_slerp(qa, qb, t / 2.0)
        assert abs(abs(float(q @ s)) - 1.0) < 1e-12


def test_rotation_curve_passes_through_keys_stays_unit_and_is_c1():
    rng = np.random.default_rng(2)
    times = np.array([0.0, 0.4, 1.0, 1.3, 2.0])
    keys = [np.array([1.0, 0, 0, 0])]
    for _ in range(4):  # keys less than 180 degrees apart
        keys.append(quat_mul(keys[-1], quat_from_rotvec(rng.normal(size=3) * 0.8)))
    keys = np.array(keys)
    m = rotation_auto_tangents(times, keys)
    for i, t in enumerate(times):
        q = sample_rotation(times, keys, m, m, t)
        assert abs(abs(float(q @ keys[i])) - 1.0) < 1e-12
    for t in np.linspace(0, 2, 41):
        assert np.linalg.norm(sample_rotation(times, keys, m, m, t)) == pytest.approx(1.0, abs=1e-12)
    from engine.mathx.quat import quat_conj, quat_to_rotvec

    def omega(t0, t1):  # body-frame angular velocity by finite difference
        q0 = sample_rotation(times, keys, m, m, t0)
        q1 = sample_rotation(times, keys, m, m, t1)
        return quat_to_rotvec(quat_mul(quat_conj(q0), q1)) / (t1 - t0)

    eps = 1e-6
    for i in (1, 2, 3):
        left = omega(times[i] - eps, times[i])
        right = omega(times[i], times[i] + eps)
        np.testing.assert_allclose(left, right, atol=1e-4)   # C1 across the key
        np.testing.assert_allclose(right, m[i], atol=1e-4)   # and the tangent is honoured


# -- blending ----------------------------------------------------------------------------------------


def test_ownership_by_blend_group_separately_per_dof():
    # slots in ownership order: body 0 posed by groups 7 (pos+rot), 7 (pos), 9 (pos+rot), 9 (rot)
    body = np.array([0, 0, 0, 0, 1])
    group = np.array([7, 7, 9, 9, 9])
    has_pos = np.array([1, 1, 1, 0, 1], bool)
    has_rot = np.array([1, 0, 1, 1, 1], bool)
    pos_on, rot_on = ownership(body, group, has_pos, has_rot)
    assert pos_on.tolist() == [1, 1, 0, 0, 1]
    assert rot_on.tolist() == [1, 0, 0, 0, 1]
    # rotation-only ownership: a first channel that poses only the rotation leaves the
    # position to the next group
    pos_on, rot_on = ownership(np.array([0, 0]), np.array([1, 2]), np.array([0, 1], bool), np.array([1, 1], bool))
    assert pos_on.tolist() == [0, 1] and rot_on.tolist() == [1, 0]


def test_blend_kernel_weighted_position_and_rotation():
    rest_pos = np.array([[0.0, 0, 1], [5.0, 5, 5]])
    rest_rot = np.array([[1.0, 0, 0, 0], [0.0, 1, 0, 0]])
    slot_body = np.array([0, 0, 0], np.int32)
    on = np.array([1, 1, 0], np.int8)
    weight = np.array([0.25, 0.75, 1.0])
    pos = np.array([[1.0, 0, 0], [0, 1.0, 0], [9.0, 9, 9]])
    qa, qb = np.array([1.0, 0, 0, 0]), quat_from_rotvec(np.array([0, 0, 1.0]))
    rot = np.array([qa, qb, [0.0, 0, 1, 0]])
    gp, gr, gpw, grw = np.zeros((2, 3)), np.zeros((2, 4)), np.zeros(2), np.zeros(2)
    blend_kernel(slot_body, on, on, weight, pos, rot, rest_pos, rest_rot, gp, gr, gpw, grw)
    np.testing.assert_allclose(gp[0], [0.25, 0.75, 0])
    assert gpw[0] == 1.0 and grw[0] == 1.0
    np.testing.assert_allclose(gr[0], quat_slerp(qa, qb, 0.75), atol=1e-12)
    # body 1 has no goal: weight 0 and the rest pose
    np.testing.assert_allclose(gp[1], rest_pos[1])
    np.testing.assert_allclose(gr[1], rest_rot[1])
    assert gpw[1] == 0 and grw[1] == 0
    # a single channel fading in: the goal stays put, its weight fades
    blend_kernel(slot_body[:1], on[:1], on[:1], np.array([0.3]), pos[:1], rot[:1], rest_pos, rest_rot, gp, gr, gpw,
                 grw)
    np.testing.assert_allclose(gp[0], pos[0])
    assert gpw[0] == pytest.approx(0.3)


# -- key remapping ------------------------------------------------------------------------------------

REMAP = """\
format: 1
name: remap
length: 2.0
targets: {goal: [0.6, 0.2, 0.7]}
channels:
  - name: hand
    select: {type: grasper}
    target: goal
    position: {mode: rest, scale: limb_length}
    rotation: {mode: rest}
    keys:
      position:
        - {t: 0, v: [0, 0, 0]}
        - {t: 0.5, v: [0.3, 0.1, 0.4], tout: [0.2, 0, 0.1], tin: [0.1, 0.1, 0]}
        - {t: 1.2, v: [-0.2, 0.4, 0.1]}
        - {t: 2.0, v: [0, 0, 0]}
      rotation:
        - {t: 0, aa: [0, 0, 1, 0]}
        - {t: 0.7, aa: [1, 2, 0, 60], tout: [0.3, -0.2, 0.5]}
        - {t: 1.5, aa: [0, 1, 1, -40]}
        - {t: 2.0, aa: [0, 0, 1, 10]}
"""


def specialized_curve(anim, creature, body, target, times):
    ch = anim.channels[0]
    cv = anim.curves
    slots = build_slots(creature, [Slot(body, ch.position, ch.rotation, mirror=False, target=0)])
    out = []
    for t in times:
        p = sample_vector(cv.pos_time, cv.pos_value, cv.pos_tout, cv.pos_tin, t)
        q = sample_rotation(cv.rot_time, cv.rot_value, cv.rot_tout, cv.rot_tin, t)
        ps, rs = specialize(slots, [p], [q], [target])
        out.append(np.concatenate([ps[0], rs[0] * np.sign(rs[0, 0])]))
    return np.array(out)


@pytest.mark.parametrize("creature_src", ["mini", "humanoid", "random3", "random11"])
def test_key_remapping_keeps_the_active_body_curve(creature_src):
    if creature_src == "mini":
        c = creature_from_text(MINI)
    elif creature_src.startswith("random"):
        c = build_creature(random_creature_def(int(creature_src[6:]), narms=2))
    else:
        import os
        path = os.path.join(os.path.dirname(__file__), "..", "creatures", "humanoid.yaml")
        if not os.path.exists(path):
            pytest.skip("creature library not present")
        c = load_creature(path)
    anim = animation_from_text(REMAP)
    ch = anim.channels[0]
    body = int(ch.query.evaluate(c)[0])
    target = c.body_rest_pos[0] + np.array([0.7, 0.3, 0.4]) * c.size
    times = np.linspace(0, 2, 41)
    before = specialized_curve(anim, c, body, target, times)
    for pos, rot in [(PositionSpec("rest", ground=True, sagittal=True), RotationSpec("absolute")),
                     (PositionSpec("secondary", scale="creature_size"), RotationSpec("lookat")),
                     (PositionSpec("secondary", directional_only=True, scale="limb_length"), RotationSpec("rest")),
                     (PositionSpec("absolute", scale="creature_size"), RotationSpec("lookat", limits=(45.0, 135.0)))]:
        new = remap_channel(ch, c, body, position=pos, rotation=rot, target=target)
        assert new.position == pos and new.rotation == rot
        assert all(k.tin is not None and k.tout is not None for k in new.position_keys + new.rotation_keys)
        anim2 = dataclasses.replace(anim, channels=(new,))
        after = specialized_curve(anim2, c, body, target, times)
        scale = max(1.0, float(np.max(c.size)))
        np.testing.assert_allclose(after[:, :3], before[:, :3], atol=1e-9 * scale)
        np.testing.assert_allclose(after[:, 3:], before[:, 3:], atol=1e-9)
        # the keys themselves changed (so the test is not vacuous)
        assert not np.allclose([k.value for k in new.position_keys], [k.value for k in ch.position_keys])


def test_remapping_other_bodies_changes_as_the_paper_says():
    """LimbLength off, remapped on a long limb: the long limb keeps its motion and a short
    limb's small motion becomes as large (section 3.3's example)."""
    from engine.channels import body_reach
    c = creature_from_text(MINI)
    anim = animation_from_text(REMAP)
    ch = anim.channels[0]
    ch = dataclasses.replace(ch, query=dataclasses.replace(ch.query, type="foot"), rotation=None, rotation_keys=())
    foot, thigh = c.body("foot_l"), c.body("thigh_l")
    new = remap_channel(ch, c, foot, position=PositionSpec("rest"))
    k_old = np.array(ch.position_keys[1].value)
    k_new = np.array(new.position_keys[1].value)
    np.testing.assert_allclose(k_new, k_old * body_reach(c, foot))   # the active long limb moves as before
    # a short limb (the thigh) playing the same keys moved k_old * its small reach with
    # LimbLength; without it, it moves as far as the foot does
    before = k_old * body_reach(c, thigh)
    after = k_new
    assert body_reach(c, thigh) < body_reach(c, foot)
    np.testing.assert_allclose(after / before, body_reach(c, foot) / body_reach(c, thigh))


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from test_channels import POSITION_SPECS, ROTATION_SPECS  # noqa: E402


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 25), pick=st.integers(0, 1000), old_pos=st.sampled_from(POSITION_SPECS),
       new_pos=st.sampled_from(POSITION_SPECS), old_rot=st.sampled_from(ROTATION_SPECS),
       new_rot=st.sampled_from(ROTATION_SPECS), draw=st.integers(0, 2**31))
def test_key_remapping_between_any_two_modes_on_random_creatures(seed, pick, old_pos, new_pos, old_rot, new_rot,
                                                                  draw):
    c = build_creature(random_creature_def(seed))
    rng = np.random.default_rng(draw)
    anim = animation_from_text(REMAP)
    ch = dataclasses.replace(anim.channels[0], query=dataclasses.replace(anim.channels[0].query, type="spine"),
                             position=old_pos, rotation=old_rot)
    anim = dataclasses.replace(anim, channels=(ch,))
    spine = ch.query.evaluate(c)
    body = int(spine[pick % len(spine)])
    target = c.body_rest_pos[body] + rng.normal(size=3) * float(np.max(c.size))
    times = np.linspace(0, 2, 11)
    before = specialized_curve(anim, c, body, target, times)
    new = remap_channel(ch, c, body, position=new_pos, rotation=new_rot, target=target)
    after = specialized_curve(dataclasses.replace(anim, channels=(new,)), c, body, target, times)
    scale = max(1.0, float(np.max(c.size)))
    np.testing.assert_allclose(after[:, :3], before[:, :3], atol=1e-8 * scale)
    np.testing.assert_allclose(after[:, 3:], before[:, 3:], atol=1e-8)
