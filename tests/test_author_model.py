"""The authoring tool's editing model, without a window: documents (undo, save, round
trips, backups, broken files), selection and highlighting, modes with exact key remap,
posing through G, keys, events, the rest of the asset, presets, gait styles, and a
scripted session of more than twenty edits on three creatures that plays identically in
the runtime after saving and reloading.
"""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

import engine
from authoring.document import Document, DocumentError, new_animation
from authoring.editor import EditError, Editor
from engine.anim import load_animation
from engine.channels.modes import PositionSpec, RotationSpec
from engine.model import build_creature
from engine.model.random import random_creature_def
from engine.query import Query

LIB = "animations"


@pytest.fixture(scope="module")
def creatures():
    names = ("humanoid", "spider", "threearmed")
    return [engine.load_creature(f"creatures/{n}.yaml") for n in names]


@pytest.fixture
def wave(tmp_path):
    p = tmp_path / "wave.yaml"
    shutil.copy(f"{LIB}/wave.yaml", p)
    return p


# -- documents -------------------------------------------------------------------------------


def test_untouched_file_saves_byte_for_byte_and_edits_keep_other_channels(tmp_path):
    src = tmp_path / "pick.yaml"
    text = open(f"{LIB}/pick_fruit.yaml").read().replace("  - name: look\n", "  # the head follows the fruit\n"
                                                         "  - name: look\n")
    src.write_text(text)
    doc = Document.open(src)
    assert doc.load_error is None and not doc.dirty
    assert doc.text() == text
    anim = doc.animation
    hand = anim.channel("hand")
    keys = list(hand.position_keys)
    keys[1] = dataclasses.replace(keys[1], value=(0.5, 0.0, 0.25))
    doc.apply(dataclasses.replace(anim, channels=(dataclasses.replace(hand, position_keys=tuple(keys)),
                                                  anim.channel("look"))), "edit")
    assert doc.dirty
    out = doc.save()
    saved = open(out).read()
    assert "# the head follows the fruit" in saved          # the untouched channel kept its comment
    assert load_animation(out) == doc.animation             # reads back exactly
    assert open(str(src) + ".bak").read() == text           # the old file is the backup
    doc.undo()
    doc.save()
    assert open(out).read() == text                          # undo gives the file back byte for byte


def test_save_never_overwrites_another_file_without_asking(tmp_path, wave):
    doc = Document.open(wave)
    other = tmp_path / "other.yaml"
    other.write_text("keep me\n")
    with pytest.raises(FileExistsError):
        doc.save_as(other)
    assert other.read_text() == "keep me\n"
    doc.save_as(other, overwrite=True)
    assert load_animation(other) == doc.animation


def test_broken_file_opens_with_its_error_and_is_not_saved_over(tmp_path, creatures):
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: 1\nname: bad\nlength: 2.0\nchannels:\n  - name: a\n    select: {type: wing, x: up}\n")
    doc = Document.open(bad)
    assert doc.load_error is not None and "bad.yaml:6" in doc.load_error and "select.x" in doc.load_error
    ed = Editor(doc, creatures[:1])                    # the tool still opens
    assert ed.message == doc.load_error
    with pytest.raises(DocumentError, match="did not load"):
        ed.save()
    assert "x: up" in bad.read_text()
    ed.save(force=True)
    assert load_animation(bad).name == "bad"


def test_a_missing_file_is_a_new_animation(tmp_path, creatures):
    doc = Document.open(tmp_path / "new_move.yaml")
    assert doc.animation.name == "new_move" and doc.dirty
    ed = Editor(doc, creatures[:1])
    ed.save()
    assert load_animation(tmp_path / "new_move.yaml") == new_animation("new_move")


def test_a_drag_is_one_undo_step(wave, creatures):
    ed = Editor(Document.open(wave), creatures)
    ed.set_time(0.5)
    p, _ = ed.specialize_now()
    ed.begin_pose()
    for dz in np.linspace(0.01, 0.2, 12):
        ed.pose(position=p + [0.0, 0.0, dz])
    ed.end_pose()
    assert ed.doc.history() == ["open", "pose hand at 0.5 s"]
    ed.undo()
    assert ed.animation == load_animation(wave) and not ed.doc.dirty
    ed.redo()
    assert np.allclose(ed.specialize_now()[0], p + [0, 0, 0.2])


# -- selecting --------------------------------------------------------------------------------


def test_query_selects_and_highlights_the_right_bodies(wave, creatures):
    ed = Editor(Document.open(wave), creatures[:2])
    human, spider = creatures[0], creatures[1]
    ed.set_query("hand", type="foot", y=None, extent=None)
    assert set(human.body_names[b] for b in ed.query_bodies(0)) == {"foot_l", "foot_r"}
    # the channel varies (variant group): it poses one of the feet its query selects
    assert len(ed.selected_bodies(0)) == 1
    assert len(ed.query_bodies(1)) == 8
    assert all("foot" in spider.caps_of(b) for b in ed.selected_bodies(1))
    ed.set_channel_fields("hand", variant_group=None)
    assert len(ed.selected_bodies(1)) == 8
    colors = ed.preview.items[1].actor.colors
    feet = ed.selected_bodies(1)
    others = np.setdiff1d(np.arange(spider.nbody), feet)
    from authoring.preview import SELECTED_COLOR
    assert np.all(np.linalg.norm(colors[feet] - SELECTED_COLOR, axis=1) < 0.35)
    assert np.all(np.linalg.norm(colors[others] - SELECTED_COLOR, axis=1) > 0.35)
    ed.set_query("hand", type="tail")
    assert "'hand' selects no body" in ed.preview.items[0].actor.label


def test_declines_in_words_and_variants_with_mirrors(creatures):
    dog = engine.load_creature("creatures/dog.yaml")
    ed = Editor(Document.open(f"{LIB}/wave.yaml"), [creatures[0], dog])
    assert ed.decline_reason(1) == "declines: has_graspers is false, the animation needs true"
    assert "declines" in ed.preview.items[1].actor.label
    assert ed.variants(0) == [("hand_l", False), ("hand_r", True)]
    ed.set_variant(0, "hand_r")
    assert ed.selected_bodies(0).tolist() == [creatures[0].body("hand_r")]
    with pytest.raises(EditError, match="no variant"):
        ed.set_variant(0, "tail")


def test_clicking_a_body_activates_it_and_picks_its_channel(creatures):
    ed = Editor(Document.open(f"{LIB}/pick_fruit.yaml"), creatures[:1])
    human = creatures[0]
    assert ed.activate(0, human.body("head"))
    assert ed.channel == "look" and ed.body == human.body("head")
    assert not ed.activate(0, human.body("foot_l"))      # no channel poses a foot here
    assert ed.body is None


# -- modes and key remapping -------------------------------------------------------------------------


@pytest.mark.parametrize("position", [PositionSpec("rest", scale="creature_size"), PositionSpec("rest"),
                                      PositionSpec("rest", ground=True), PositionSpec("rest", sagittal=True),
                                      PositionSpec("absolute", scale="limb_length")])
def test_a_mode_change_keeps_the_active_body_motion(wave, creatures, position):
    ed = Editor(Document.open(wave), creatures)
    ed.set_channel_fields("hand", variant_group=None)
    human = creatures[0]
    ed.activate(0, human.body("hand_l"))
    _, before = ed.curve("position", "specialized")
    others_before = [ed.goal_path() for _ in range(1)]
    ed.set_modes(position=position)
    _, after = ed.curve("position", "specialized")
    assert np.abs(after - before).max() < 1e-9
    assert ed.animation.channel("hand").position == position
    del others_before


def test_mode_change_to_secondary_and_rotation_remap(creatures):
    ed = Editor(Document.open(f"{LIB}/wave.yaml"), creatures)
    ed.activate(0, creatures[0].body("hand_l"))
    _, pos0 = ed.curve("position", "specialized")
    _, rot0 = ed.curve("rotation", "specialized")
    ed.set_modes(position=PositionSpec("secondary", scale="limb_length"), rotation=RotationSpec("rest"))
    ch = ed.animation.channel("hand")
    assert ch.target is not None and ch.target in ed.animation.target_names
    _, pos1 = ed.curve("position", "specialized")
    _, rot1 = ed.curve("rotation", "specialized")
    assert np.abs(pos1 - pos0).max() < 1e-9 and np.abs(rot1 - rot0).max() < 1e-6
    ed.undo()
    assert ed.animation == load_animation(f"{LIB}/wave.yaml")


# -- posing, keys, curves ---------------------------------------------------------------------------


def test_posing_moves_every_selected_body_through_g_and_s(creatures):
    ed = Editor(Document.open(f"{LIB}/wave.yaml"), creatures)
    ed.set_channel_fields("hand", variant_group=None)   # all graspers of each creature
    ed.set_query("hand", y=None, extent=None)
    ed.set_time(1.0)
    ed.activate(0, creatures[0].body("hand_l"))
    p, r = ed.specialize_now()
    goal = p + [0.0, 0.1, 0.05]
    ed.pose(position=goal)
    ed.end_pose()
    assert np.allclose(ed.specialize_now()[0], goal)
    # Every other selected body, on every creature, plays the same generalized pose.
    qg, _, _ = ed.sample("hand", 1.0)
    from engine.channels import modes as M
    for k in range(3):
        for b in ed.selected_bodies(k):
            single, table = ed.slot(k, int(b))
            sp, _ = M.specialize(single, qg[None], np.array([[1.0, 0, 0, 0]]), table)
            gp, _ = M.generalize(single, sp, np.array([[1.0, 0, 0, 0]]), table)
            assert np.allclose(gp[0], qg)
    # and the runtime's goals are there on the spider too
    assert ed.preview.items[1].character.world_positions is not None


def test_keys_insert_move_delete_tangents_and_specialized_edits(wave, creatures):
    ed = Editor(Document.open(wave), creatures[:1])
    n = len(ed.keys("position"))
    i = ed.set_key("position", 0.75, (0.2, 0.1, 0.5))
    assert len(ed.keys("position")) == n + 1 and ed.keys("position")[i].t == 0.75
    new = ed.move_keys("position", [i], dt=0.1, dvalue=(0.0, 0.0, 0.1))
    k = ed.keys("position")[new[0]]
    assert abs(k.t - 0.85) < 1e-12 and abs(k.value[2] - 0.6) < 1e-12
    # keys never pass their neighbours
    new = ed.move_keys("position", new, dt=5.0)
    assert ed.keys("position")[new[0]].t < 1.0
    ed.set_tangents("position", new[0], tin=(0, 0, 0), tout=(0.1, 0, 0))
    assert ed.keys("position")[new[0]].tout == (0.1, 0.0, 0.0)
    ed.delete_keys("position", new)
    assert len(ed.keys("position")) == n
    # a key edited in specialized space is stored generalized: the active body goes there
    ed.activate(0, creatures[0].body("hand_l"))
    _, spec = ed.curve("position", "specialized", samples=5)
    target = spec[2] + [0.0, 0.0, 0.05]
    ed.set_key_value("position", 2, target, space="specialized")
    _, spec2 = ed.curve("position", "specialized", samples=5)
    assert np.allclose(spec2[2], target)
    ed.key_now()
    assert any(abs(k.t - ed.time) < 1e-9 for k in ed.keys("rotation"))


def test_events_asset_fields_branches_targets(wave, creatures):
    ed = Editor(Document.open(wave), creatures[:1])
    ed.add_event(1.2, "whoosh", "sfx/whoosh")
    ev = ed.animation.channel("hand").events
    assert [e.name for e in ev] == ["wave_peak", "whoosh", "wave_peak"]
    ed.edit_event(1, t=1.3, name="swish")
    ed.remove_event(0)
    assert [(e.t, e.name) for e in ed.animation.channel("hand").events] == [(1.3, "swish"), (1.5, "wave_peak")]
    ed.set_length(1.4)
    assert ed.animation.length == 1.4
    assert max(k.t for k in ed.keys("position")) <= 1.4
    ed.set_branch("has_feet", True)
    ed.set_branch("min_graspers", 2)
    assert dict(ed.animation.branches) == {"has_graspers": True, "has_feet": True, "min_graspers": 2}
    with pytest.raises(EditError, match="unknown branch predicate"):
        ed.set_branch("has_fins", True)
    ed.set_asset_fields(loop=False, description="a short wave")
    ed.set_channel_fields("hand", blend_group="arm", priority=2, mirror=False)
    ch = ed.animation.channel("hand")
    assert (ch.blend_group, ch.priority, ch.mirror) == ("arm", 2, False)
    ed.save()
    assert load_animation(wave) == ed.animation


def test_channels_add_rename_duplicate_remove_mute_solo(wave, creatures):
    ed = Editor(Document.open(wave), creatures[:1])
    name = ed.add_channel(query=Query(type="head"), position=None, rotation=RotationSpec("rest"))
    assert name == "head" and ed.channel == "head"
    ed.rename_channel("head", "nod")
    dup = ed.duplicate_channel("nod")
    assert [c.name for c in ed.animation.channels] == ["hand", "nod", "nod_copy"]
    with pytest.raises(EditError, match="already a channel"):
        ed.rename_channel("nod_copy", "nod")
    ed.remove_channel(dup)
    ed.set_mute("hand", True)
    assert "hand" not in [c.name for c in ed.preview.played.channels]
    ed.set_mute("hand", False)
    ed.set_solo("nod")
    assert [c.name for c in ed.preview.played.channels] == ["nod"]
    assert [c.name for c in ed.animation.channels] == ["hand", "nod"]   # mute/solo is never saved


def test_channel_library_presets(tmp_path, wave, creatures, monkeypatch):
    monkeypatch.setenv("MENAGERIE_CHANNEL_LIBRARY", str(tmp_path / "lib" / "channels.yaml"))
    ed = Editor(Document.open(wave), creatures[:1])
    ed.save_preset("hand")
    presets = ed.presets()
    assert [p.name for p in presets] == ["hand"] and presets[0].position_keys == ()
    other = Editor(Document.open(f"{LIB}/crouch.yaml"), creatures[:1])
    name = other.add_preset("hand")
    ch = other.animation.channel(name)
    assert ch.query == ed.animation.channel("hand").query and ch.position == ed.animation.channel("hand").position


def test_gait_style_edit_keeps_the_file_and_previews_walking(tmp_path, creatures):
    from authoring.gait_edit import GaitEditor
    from authoring.preview import Preview

    path = tmp_path / "walk.yaml"
    shutil.copy("animations/gaits/walk.yaml", path)
    pv = Preview([engine.load_creature("creatures/dog.yaml")])
    pv.show(load_animation(f"{LIB}/idle_breathe.yaml"), 0.0)
    g = GaitEditor(pv, str(path))
    assert g.set_cell(1, "lift", 0.2)
    assert not g.set_cell(1, "duty", 1.5) and "duty" in g.message
    assert g.set_arc("peak", 0.6)
    g.save()
    text = path.read_text()
    assert "# cycles/s for a 1 m leg" in text                       # comments outside the blocks stay
    from engine.gait.style import parse_style_text
    st = parse_style_text(text)
    assert st.table[1, 3] == 0.2
    g.set_walking(True)
    x0 = pv.items[0].character.world_positions[0, 0]
    for _ in range(60):
        g.update(1 / 60)
        pv.advance(1 / 60)
    assert pv.items[0].character.world_positions[0, 0] > x0 + 0.05   # it walked forward


# -- a scripted session -------------------------------------------------------------------------------


def _play(anim, creature, frames=90):
    ch = engine.Character(creature)
    for name in anim.target_names:
        h = creature.height
        ch.set_target(name, (0.7 * h, 0.25 * h, 0.7 * h))
    ch.play(anim, fade=0.0)
    out = []
    for _ in range(frames):
        ch.tick(1 / 60)
        out.append(np.concatenate([ch.world_positions.ravel(), ch.world_rotations.ravel()]))
    return np.array(out)


def test_scripted_session_of_twenty_edits_saves_and_plays_identically(tmp_path):
    cs = [engine.load_creature("creatures/humanoid.yaml"), engine.load_creature("creatures/spider.yaml"),
          build_creature(random_creature_def(11))]
    path = tmp_path / "session.yaml"
    ed = Editor(Document.open(path), cs)                                     # a new animation
    edits = 0

    def count():
        nonlocal edits
        edits += 1

    ed.set_length(2.0)
    count()
    hand = ed.add_channel("reach", Query(type="grasper", x="front"), position=PositionSpec("rest"),
                          rotation=RotationSpec("absolute"))
    count()
    ed.set_query(hand, extent="topmost")
    count()
    ed.set_channel_fields(hand, variant_group="hand")
    count()
    ed.activate(0, int(ed.selected_bodies(0)[0]))
    for t, dz in ((0.5, 0.15), (1.0, 0.3), (1.5, 0.1)):
        ed.set_time(t)
        p, _ = ed.specialize_now()
        ed.begin_pose()
        for s in np.linspace(0, 1, 5):
            ed.pose(position=p + [0.05 * s, 0.0, dz * s])
        ed.end_pose()
        count()
    ed.set_modes(position=PositionSpec("rest", scale="limb_length"))
    count()
    ed.set_key("rotation", 1.0, (0.9238795325112867, 0.0, -0.3826834323650898, 0.0))
    count()
    ed.move_keys("position", [1], dt=0.05)
    count()
    ed.add_event(1.0, "grab", "fruit")
    count()
    head = ed.add_channel("look", Query(type="head"), position=None, rotation=RotationSpec("rest"))
    count()
    ed.set_key("rotation", 0.8, (0.9659258262890683, 0.0, 0.0, 0.25881904510252074), name=head)
    count()
    ed.set_key("weight", 0.0, (0.0,), name=head)
    count()
    ed.set_key("weight", 0.6, (1.0,), name=head)
    count()
    ed.rename_channel(head, "gaze")
    count()
    ed.set_channel_fields("gaze", priority=1)
    count()
    spine = ed.add_channel("bend", Query(type="spine", z="top"), position=None,
                           rotation=RotationSpec("rest"))
    count()
    ed.set_key("rotation", 1.0, (0.9848077530095796, 0.0, 0.17364817766693033, 0.0), name=spine)
    count()
    ed.set_branch("has_head", True)
    count()
    ed.set_asset_fields(loop=True, description="scripted session")
    count()
    ed.duplicate_channel("gaze")
    count()
    ed.remove_channel("gaze_copy")
    count()
    ed.remove_channel("root")
    count()
    ed.set_tangents("position", 2, tout=(0.0, 0.0, 0.2), name="reach")
    count()
    assert edits >= 20 and len(ed.doc.history()) >= 21
    ed.save()
    again = load_animation(path)
    assert again == ed.animation
    for c in cs:
        if not engine.anim.binding.branch_failures(again, c):
            a = _play(ed.animation, c)
            b = _play(again, c)
            assert np.all(np.isfinite(a))
            np.testing.assert_array_equal(a, b)
