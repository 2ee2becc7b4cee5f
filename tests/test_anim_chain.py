"""Clips that continue one another (``follows``): the file field, the chain found next to
the file, the validation grid playing a continued clip after what it continues (never from
the rest pose), and the impact response's library queueing the chain after a fall."""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

import engine
from engine.anim import AnimationError, animation_from_text, load_animation
from engine.anim.chain import lead_in, successor
from engine.mathx import quat_rotate
from engine.validation.record import record_cell

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REACTIONS = os.path.join(ROOT, "animations", "reactions")

CLIP = """\
format: 1
name: second
length: 1.0
follows: first
channels:
  - name: root
    select: {type: root}
    rotation: {mode: rest}
    keys:
      rotation:
        - {t: 0.0, aa: [0, 1, 0, 10]}
"""


def test_follows_round_trips_and_bad_values_name_the_field(tmp_path):
    a = animation_from_text(CLIP)
    assert a.follows == "first"
    path = tmp_path / "second.yaml"
    a.save(path)
    assert load_animation(path) == a and "follows: first" in path.read_text()
    with pytest.raises(AnimationError, match="follows") as exc:
        animation_from_text(CLIP.replace("follows: first", "follows: second"))
    assert exc.value.field == "follows"
    with pytest.raises(AnimationError, match="non-empty string") as exc:
        animation_from_text(CLIP.replace("follows: first", "follows: [first]"))
    assert exc.value.field == "follows" and exc.value.line == 4


def test_the_reaction_chains_are_found_next_to_their_files():
    get_up = load_animation(os.path.join(REACTIONS, "get_up_back.yaml"))
    assert [a.name for a in lead_in(get_up)] == ["fall_back", "lie_back"]
    fall = load_animation(os.path.join(REACTIONS, "fall_left_low.yaml"))
    assert lead_in(fall) == () and successor(fall).name == "lie_left_low"
    assert successor(successor(fall)).name == "get_up_left_low" and successor(get_up) is None
    for name in sorted(os.listdir(REACTIONS)):       # every lying and getting up continues a fall
        if name.startswith(("lie_", "get_up_")):
            chain = lead_in(load_animation(os.path.join(REACTIONS, name)))
            assert chain and chain[0].name.startswith("fall_"), name


def test_a_clip_that_follows_a_missing_or_looping_chain_is_a_clear_error(tmp_path):
    shutil.copy(os.path.join(REACTIONS, "lie_back.yaml"), tmp_path / "lie_back.yaml")
    lie = load_animation(tmp_path / "lie_back.yaml")
    with pytest.raises(AnimationError, match="no fall_back.yaml next to it") as exc:
        lead_in(lie)
    assert exc.value.field == "follows" and str(tmp_path) in str(exc.value)
    text = (tmp_path / "lie_back.yaml").read_text()
    (tmp_path / "fall_back.yaml").write_text(text.replace("name: lie_back", "name: fall_back")
                                             .replace("follows: fall_back", "follows: lie_back"))
    with pytest.raises(AnimationError, match="a cycle"):
        lead_in(load_animation(tmp_path / "lie_back.yaml"))


@pytest.fixture(scope="module")
def humanoid():
    return engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))


def _tilt(rot):
    """Angle of the body's local up axis from the world's, rad."""
    up = quat_rotate(rot, np.array([0.0, 0.0, 1.0]))
    return float(np.arccos(np.clip(up[2], -1.0, 1.0)))


def test_the_grid_plays_a_lying_after_its_fall_and_hands_it_on_to_getting_up(humanoid):
    """``lie_back`` from the rest pose would be a jump from standing to lying in the fade (a
    flip the game never shows: the response plays it after ``fall_back``). Its cell starts
    lying, with no pop in the hand-over, and ends handing over to ``get_up_back``."""
    lie = load_animation(os.path.join(REACTIONS, "lie_back.yaml"))
    rec = record_cell(humanoid, lie)
    assert rec.error is None
    pelvis = 0
    assert _tilt(rec.world_rot[0, pelvis]) > 1.0, "the first frame is lying, where fall_back ends"
    assert rec.meta["then"] == "get_up_back"
    turn = [2.0 * np.arccos(np.clip(np.abs(np.sum(rec.world_rot[i] * rec.world_rot[i + 1], axis=-1)), 0, 1)).max()
            for i in range(rec.nframe - 1)]
    assert max(turn) < 0.5, f"a body turned {max(turn):.2f} rad in one frame"
    assert _tilt(rec.world_rot[-1, pelvis]) < _tilt(rec.world_rot[0, pelvis]) - 0.3, "getting up in the settle"
