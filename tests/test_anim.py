"""The animation format and goal evaluation: invalid files (each error names the file, line,
channel and field), exact round trips, blending by group and priority, and events."""

from __future__ import annotations

import glob
import os

import numpy as np
import pytest
from test_channels import MINI

from engine.anim import AnimationError, Goals, animation_from_text, bind_all, evaluate_goals, load_animation
from engine.channels import ground_height
from engine.model import creature_from_text

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LIBRARY = sorted(glob.glob(os.path.join(ROOT, "animations", "*.yaml")))

GOOD = """\
format: 1
name: good
description: a valid animation to break in the tests below
length: 2.0
loop: false
targets:
  goal: [0.5, 0.0, 0.5]
channels:
  - name: hand
    select: {type: grasper, y: left}
    target: goal
    position: {mode: secondary, scale: limb_length}
    rotation: {mode: rest}
    keys:
      position:
        - {t: 0.0, v: [0, 0, 0]}
        - {t: 1.0, v: [1, 0, 0]}
      rotation:
        - {t: 0.0, aa: [0, 0, 1, 0]}
        - {t: 1.0, aa: [0, 0, 1, 30]}
"""

# (replace this, with that) -> the line, channel and field the error must name
INVALID = [
    ("format: 1", "format: 2", 1, None, "format"),
    ("length: 2.0", "length: -1", 4, None, "length"),
    ("length: 2.0", "length: two", 4, None, "length"),
    ("loop: false", "loop: 3", 5, None, "loop"),
    ("name: good\n", "name: good\nspeed: 3\n", 3, None, "speed"),
    ("select: {type: grasper, y: left}", "select: {type: hand}", 10, "hand", "select.type"),
    ("select: {type: grasper, y: left}", "select: {type: grasper, y: up}", 10, "hand", "select.y"),
    ("select: {type: grasper, y: left}", "select: {type: grasper, side: left}", 10, "hand", "select.side"),
    ("    select: {type: grasper, y: left}\n", "", 9, "hand", "select"),
    ("position: {mode: secondary, scale: limb_length}", "position: {mode: orbit}", 12, "hand",
     "position.mode"),
    ("position: {mode: secondary, scale: limb_length}", "position: {mode: secondary, scale: 2}", 12, "hand",
     "position.scale"),
    ("position: {mode: secondary, scale: limb_length}", "position: {mode: secondary, ground: true}", 12, "hand",
     "position.ground"),
    ("rotation: {mode: rest}", "rotation: {mode: lookat, limits: [90, 270]}", 13, "hand", "rotation.limits"),
    ("    target: goal\n", "", 11, "hand", "position"),
    ("    target: goal\n", "    target: goal\n    secondary: {type: mouth}\n", 11, "hand", "target"),
    ("- {t: 1.0, v: [1, 0, 0]}", "- {t: 3.0, v: [1, 0, 0]}", 17, "hand", "keys.position"),
    ("- {t: 1.0, v: [1, 0, 0]}", "- {t: 0.0, v: [1, 0, 0]}", 17, "hand", "keys.position"),
    ("- {t: 1.0, v: [1, 0, 0]}", "- {t: 1.0, v: [1, 0]}", 17, "hand", "keys.position"),
    ("- {t: 1.0, v: [1, 0, 0]}", "- {t: 1.0, v: [1, 0, .nan]}", 17, "hand", "keys.position"),
    ("- {t: 1.0, aa: [0, 0, 1, 30]}", "- {t: 1.0, aa: [0, 0, 1, 180]}", 20, "hand", "keys.rotation"),
    ("- {t: 1.0, aa: [0, 0, 1, 30]}", "- {t: 1.0, v: [0, 0, 0, 0]}", 20, "hand", "keys.rotation"),
    ("- {t: 1.0, aa: [0, 0, 1, 30]}", "- {t: 1.0, aa: [0, 0, 1, 30], v: [1, 0, 0, 0]}", 20, "hand",
     "keys.rotation"),
    ("    rotation: {mode: rest}\n", "    rotation: {mode: rest}\n    side: same\n", 14, "hand", "side"),
    ("    rotation: {mode: rest}\n", "    rotation: {mode: rest}\n    priority: high\n", 14, "hand", "priority"),
    ("    rotation: {mode: rest}\n", "    rotation: {mode: rest}\n    mirror: maybe\n", 14, "hand", "mirror"),
    ("loop: false", "loop: false\nbranches: {has_claws: true}", 6, None, "branches.has_claws"),
    ("goal: [0.5, 0.0, 0.5]", "goal: [0.5, 0.0]", 7, None, "targets.goal"),
    ("  - name: hand\n", "  - name: hand\n    colour: red\n", 10, "hand", "colour"),
    ("position: {mode: secondary, scale: limb_length}", "position: {mode: secondary, scale: [limb_length}",
     None, None, None),  # a YAML syntax error: located, no traceback from yaml
]


@pytest.mark.parametrize("old,new,line,channel,field", INVALID)
def test_invalid_files_name_file_line_channel_and_field(old, new, line, channel, field):
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    with pytest.raises(AnimationError) as exc:
        animation_from_text(text, "bad.yaml")
    err = exc.value
    assert err.path == "bad.yaml"
    if line is not None:
        assert err.line == line, str(err)
    else:
        assert err.line is not None, str(err)
    assert err.subject == channel, str(err)
    assert err.field == field, str(err)
    assert "bad.yaml" in str(err)


def test_duplicate_channel_and_unknown_file():
    text = GOOD + GOOD[GOOD.index("  - name: hand"):]
    with pytest.raises(AnimationError, match="duplicate channel name"):
        animation_from_text(text)
    with pytest.raises(AnimationError, match="cannot read"):
        load_animation("/nonexistent/anim.yaml")


def test_good_file_loads_and_round_trips_exactly(tmp_path):
    a = animation_from_text(GOOD)
    assert a.channel("hand").rotation_keys[1].value[0] == pytest.approx(np.cos(np.radians(15)))
    path = tmp_path / "good.yaml"
    a.save(path)
    b = load_animation(path)
    assert b == a and b.to_text() == a.to_text()
    with pytest.raises(FileExistsError):
        a.save(path)


@pytest.mark.parametrize("path", LIBRARY, ids=[os.path.basename(p)[:-5] for p in LIBRARY])
def test_library_file_round_trips(path, tmp_path):
    a = load_animation(path)
    assert a.description and "\n" not in a.description  # each file says in one line what it shows
    out = tmp_path / "a.yaml"
    a.save(out)
    assert load_animation(out) == a


def test_the_library_has_20_animations_covering_every_mode():
    anims = [load_animation(p) for p in LIBRARY]
    assert len(anims) >= 20
    seen = set()
    for a in anims:
        for ch in a.channels:
            if ch.position is not None:
                p = ch.position
                seen.add(("pos", p.mode))
                seen |= {("flag", f) for f in ("ground", "sagittal", "directional_only") if getattr(p, f)}
                seen.add(("scale", p.scale))
            if ch.rotation is not None:
                seen.add(("rot", ch.rotation.mode))
            seen.add(("secondary", "query" if ch.secondary else "target" if ch.target else "none"))
            if ch.query.limb:
                seen.add(("limb", ch.query.limb))
    want = {("pos", m) for m in ("absolute", "rest", "secondary")} | {("rot", m) for m in ("absolute", "rest", "lookat")}
    want |= {("flag", f) for f in ("ground", "sagittal", "directional_only")}
    want |= {("scale", s) for s in ("none", "creature_size", "limb_length")}
    want |= {("secondary", "query"), ("secondary", "target"), ("limb", "spine_segment")}
    assert want <= seen, want - seen


# -- evaluation on a hand-checkable creature ----------------------------------------------------------

BLEND = """\
format: 1
name: blend
length: 2.0
channels:
  - name: a
    select: {type: grasper}
    position: {mode: rest}
    blend_group: arms
    keys:
      position:
        - {t: 0.0, v: [1, 0, 0]}
      weight:
        - {t: 0.0, v: 1}
        - {t: 2.0, v: 0}
  - name: b
    select: {type: grasper}
    position: {mode: rest}
    rotation: {mode: rest}
    blend_group: arms
    keys:
      position:
        - {t: 0.0, v: [0, 0, 1]}
      rotation:
        - {t: 0.0, aa: [0, 0, 1, 40]}
      weight:
        - {t: 0.0, v: 0}
        - {t: 2.0, v: 1}
  - name: c
    select: {type: grasper, y: left}
    position: {mode: absolute}
    rotation: {mode: absolute}
    keys:
      position:
        - {t: 0.0, v: [9, 9, 9]}
  - name: d
    select: {type: head}
    position: {mode: rest}
    priority: -1
    keys:
      position:
        - {t: 0.0, v: [0, 0, 0.5]}
  - name: e
    select: {type: head}
    rotation: {mode: rest}
    position: {mode: rest}
    priority: 2
    keys:
      position:
        - {t: 0.0, v: [0, 0, -0.5]}
"""


def test_blending_by_group_weight_and_priority():
    c = creature_from_text(MINI)
    a = animation_from_text(BLEND)
    hl, hr, head = c.body("hand_l"), c.body("hand_r"), c.body("head")
    g = evaluate_goals(a, c, 1.0)
    # a and b share the group 'arms' and own the graspers first (c comes later, other group)
    for h in (hl, hr):
        np.testing.assert_allclose(g.goal_pos[h], c.body_rest_pos[h] + [0.5, 0, 0.5], atol=1e-12)
        assert g.goal_pos_weight[h] == pytest.approx(1.0)
        # only b poses the rotation: at weight 0.5 the goal is b's rotation at weight 0.5
        assert g.goal_rot_weight[h] == pytest.approx(0.5)
    # e has the higher priority and owns the head despite coming after d in the file
    np.testing.assert_allclose(g.goal_pos[head], c.body_rest_pos[head] + [0, 0, -0.5])
    # nothing poses the feet: weight 0, rest pose
    f = c.body("foot_l")
    assert g.goal_pos_weight[f] == 0 and g.goal_rot_weight[f] == 0
    np.testing.assert_allclose(g.goal_pos[f], c.body_rest_pos[f])
    # at t = 0 only a counts
    g = evaluate_goals(a, c, 0.0)
    np.testing.assert_allclose(g.goal_pos[hl], c.body_rest_pos[hl] + [1, 0, 0], atol=1e-12)
    assert g.goal_rot_weight[hl] == 0.0


def test_evaluate_goals_writes_in_place_and_is_deterministic():
    c = creature_from_text(MINI)
    a = animation_from_text(GOOD)
    out = Goals.empty(c.nbody)
    ids = [id(x) for x in out]
    r1 = evaluate_goals(a, c, 0.7, out=out, targets={"goal": (1.0, 0.5, 1.0)})
    assert [id(x) for x in r1] == ids
    snapshot = [x.copy() for x in out]
    evaluate_goals(a, c, 0.7, out=out, targets={"goal": (1.0, 0.5, 1.0)})
    for x, y in zip(out, snapshot, strict=True):
        assert np.array_equal(x, y)
    # x = 1 at t = 1 reaches the target
    evaluate_goals(a, c, 1.0, out=out, targets={"goal": (1.0, 0.5, 1.0)})
    np.testing.assert_allclose(out.goal_pos[c.body("hand_l")], [1.0, 0.5, 1.0], atol=1e-12)
    with pytest.raises(AnimationError, match="no external target 'fruit'"):
        evaluate_goals(a, c, 0.0, targets={"fruit": (0, 0, 0)})
    with pytest.raises(AnimationError, match="3 finite numbers"):
        evaluate_goals(a, c, 0.0, targets={"goal": (0, np.inf, 0)})


def test_bind_selects_nearest_secondary_and_drops_channels_without_one():
    c = creature_from_text(MINI)
    a = load_animation(os.path.join(ROOT, "animations", "hand_to_mouth.yaml"))
    b = bind_all(a, c)
    assert b.channel_bodies[0].tolist() == [c.body("hand_l")]  # frontmost: tie broken by index
    assert b.slots.slot_target[0] == len(b.target_names) + c.body("head")
    headless = creature_from_text(MINI.replace("caps: [head, mouth]", "caps: [spine]"))
    b = bind_all(a, headless)
    assert b.slots.nslot == 0
    g = evaluate_goals(a, headless, 1.0)
    assert not np.any(g.goal_pos_weight)


def test_events_and_time_wrapping():
    a = load_animation(os.path.join(ROOT, "animations", "clap.yaml"))
    ev = a.events_between(0.0, 0.8)
    assert [(ch, e.name, e.t) for ch, e in ev] == [("hands", "clap_sound", 0.4)]
    assert a.local_time(1.7) == pytest.approx(0.1)
    assert a.local_time(-0.1) == pytest.approx(1.5)
    b = load_animation(os.path.join(ROOT, "animations", "shake_head.yaml"))
    assert b.local_time(5.0) == b.length


def test_ground_relative_channel_touches_the_ground_at_one():
    c = creature_from_text(MINI)
    a = load_animation(os.path.join(ROOT, "animations", "pound_ground.yaml"))
    g = evaluate_goals(a, c, 0.55)
    for h in ("hand_l", "hand_r"):
        b = c.body(h)
        assert g.goal_pos[b, 2] == pytest.approx(ground_height(c, b), abs=1e-12)


def test_eat_fruit_cross_fades_from_the_fruit_to_the_mouth():
    """Two channels of one blend group with crossing weights (section 3.2.3's example): the
    hand's goal is at the fruit, then halfway between fruit and mouth, then at the mouth
    (where the hand's box touches the mouth's: the mouth channel's ``contact``)."""
    from engine.channels import PositionSpec, Slot, build_slots, specialize

    c = creature_from_text(MINI)
    a = load_animation(os.path.join(ROOT, "animations", "eat_fruit.yaml"))
    fruit = np.array([0.7, 0.6, 1.1])
    hand, mouth = c.body("hand_l"), c.body("head")
    slot = build_slots(c, [Slot(hand, PositionSpec("secondary", scale="limb_length", contact=True), None, target=0,
                                target_body=mouth)])
    near_mouth, _ = specialize(slot, [[1.0, 0, 0]], [[1.0, 0, 0, 0]], [c.body_rest_pos[mouth]])
    g = evaluate_goals(a, c, 1.0, targets={"fruit": fruit})
    np.testing.assert_allclose(g.goal_pos[hand], fruit, atol=1e-12)
    g = evaluate_goals(a, c, 1.5, targets={"fruit": fruit})   # weights 0.5 / 0.5
    np.testing.assert_allclose(g.goal_pos[hand], 0.5 * (fruit + near_mouth[0]), atol=1e-12)
    assert g.goal_pos_weight[hand] == pytest.approx(1.0)
    g = evaluate_goals(a, c, 2.0, targets={"fruit": fruit})
    np.testing.assert_allclose(g.goal_pos[hand], near_mouth[0], atol=1e-12)
    assert [e.name for _, e in a.events_between(0.0, a.length)] == ["grab", "eat"]
