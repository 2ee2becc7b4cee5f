"""The Creature model: the file format, validation, re-rooting and derived morphology.

Opens with the list of invalid inputs, each with the error it must raise (the style of
ozz-animation's JobValidity tests), then tiny creatures whose answers are worked out by
hand.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from engine.errors import CreatureError
from engine.model import CreatureWarning, creature_from_text, load_creature

BIPED = """\
format: 1
name: mini
description: a seven-body biped authored from the chest
bodies:
  - name: chest
    caps: [spine]
    pos: [0, 0, 1.3]
    extents: [0.1, 0.15, 0.15]
  - name: pelvis
    parent: chest
    caps: [spine]
    pos: [0, 0, 1.0]
    joint: [0, 0, 1.15]
    extents: [0.1, 0.15, 0.1]
  - name: thigh_l
    parent: pelvis
    caps: [limb]
    pos: [0, 0.1, 0.75]
    joint: [0, 0.1, 0.95]
    extents: [0.05, 0.05, 0.2]
  - name: foot_l
    parent: thigh_l
    caps: [foot]
    pos: [0.05, 0.1, 0.04]
    joint: [0, 0.1, 0.5]
    extents: [0.1, 0.04, 0.04]
  - name: thigh_r
    parent: pelvis
    caps: [limb]
    pos: [0, -0.1, 0.75]
    joint: [0, -0.1, 0.95]
    extents: [0.05, 0.05, 0.2]
  - name: foot_r
    parent: thigh_r
    caps: [foot]
    pos: [0.05, -0.1, 0.04]
    joint: [0, -0.1, 0.5]
    extents: [0.1, 0.04, 0.04]
  - name: head
    parent: chest
    caps: [head, mouth]
    pos: [0, 0, 1.6]
    joint: [0, 0, 1.45]
    extents: [0.1, 0.1, 0.12]
"""


def _edit(old: str, new: str, text: str = BIPED) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


# (what is wrong, the text, the fragments the message must contain)
INVALID = [
    ("yaml syntax", BIPED + "  - name: [unclosed\n", ["mini.yaml:", "YAML syntax"]),
    ("not a mapping", "- 1\n- 2\n", ["mapping"]),
    ("missing format", BIPED.replace("format: 1\n", ""), ["format"]),
    ("future format", _edit("format: 1", "format: 7"), ["format 7", ":1"]),
    ("unknown top field", BIPED + "colour: red\n", ["unknown top-level field 'colour'", ":45"]),
    ("no bodies", "format: 1\nname: x\nbodies: []\n", ["non-empty"]),
    ("body not a mapping", "format: 1\nname: x\nbodies:\n  - 3\n", [":4", "mapping"]),
    ("body without name", _edit("  - name: head\n", "  - nom: head\n"), ["without a 'name'"]),
    ("unknown body field", _edit("    caps: [head, mouth]", "    caps: [head, mouth]\n    colour: 3"),
     ["'head'", "unknown field 'colour'", ":42"]),
    ("duplicate name", _edit("name: thigh_r", "name: thigh_l"), ["duplicate body name", "'thigh_l'", ":27"]),
    ("unknown parent", _edit("parent: thigh_r", "parent: thigh_rr"), ["unknown parent 'thigh_rr'", "foot_r",
                                                                    "did you mean"]),
    ("self parent", _edit("parent: thigh_r", "parent: foot_r"), ["own parent", "foot_r"]),
    ("cycle", _edit("  - name: chest\n    caps: [spine]", "  - name: chest\n    parent: head\n    caps: [spine]"),
     ["cycle"]),
    ("several roots", _edit("    parent: thigh_r\n", ""), ["several bodies have no parent", "chest", "foot_r"]),
    ("unknown capability", _edit("caps: [head, mouth]", "caps: [head, snout]"), ["unknown capability 'snout'",
                                                                                "'head'", ":41"]),
    ("no spine", BIPED.replace("[spine]", "[limb]"), ["no body has the 'spine' capability"]),
    ("spine not a chain (branch)", _edit("caps: [head, mouth]", "caps: [spine, head]").replace(
        "name: thigh_l\n    parent: pelvis\n    caps: [limb]", "name: thigh_l\n    parent: pelvis\n    caps: [spine]").replace(
        "name: thigh_r\n    parent: pelvis\n    caps: [limb]", "name: thigh_r\n    parent: pelvis\n    caps: [spine]"),
     ["not a serial chain", "pelvis"]),
    ("spine cut by a limb", _edit("name: foot_l\n    parent: thigh_l\n    caps: [foot]",
                                  "name: foot_l\n    parent: thigh_l\n    caps: [spine]"),
     ["not one connected chain", "foot_l"]),
    ("non-finite", _edit("pos: [0, 0, 1.6]", "pos: [0, .nan, 1.6]"), ["non-finite", "'head'", "'pos'", ":42"]),
    ("infinite", _edit("pos: [0, 0, 1.6]", "pos: [0, .inf, 1.6]"), ["non-finite", "'head'"]),
    ("string in vector", _edit("pos: [0, 0, 1.6]", "pos: [0, zero, 1.6]"), ["expected a number", "'head'"]),
    ("bool in vector", _edit("pos: [0, 0, 1.6]", "pos: [0, true, 1.6]"), ["expected a number"]),
    ("short vector", _edit("pos: [0, 0, 1.6]", "pos: [0, 1.6]"), ["list of 3 numbers", "'head'"]),
    ("zero extent", _edit("extents: [0.1, 0.1, 0.12]", "extents: [0.1, 0.0, 0.12]"), ["> 0", "'head'",
                                                                                    "'extents'", ":44"]),
    ("negative extent", _edit("extents: [0.1, 0.1, 0.12]", "extents: [0.1, -0.1, 0.12]"), ["> 0", "'head'"]),
    ("zero quaternion", _edit("caps: [head, mouth]", "caps: [head, mouth]\n    rot: [0, 0, 0, 0]"),
     ["zero length", "'head'", "'rot'"]),
    ("caps not a list", _edit("caps: [head, mouth]", "caps: head"), ["list of capability names", "'head'"]),
    ("missing extents", _edit("    extents: [0.1, 0.1, 0.12]\n", ""), ["missing 'extents'", "'head'"]),
    ("duplicate key", _edit("    pos: [0, 0, 1.6]", "    pos: [0, 0, 1.6]\n    pos: [0, 0, 1.7]"),
     ["duplicate key 'pos'", ":43"]),
    ("name not a string", _edit("name: head", "name: [1]"), ["non-empty string"]),
]


@pytest.mark.parametrize("what,text,fragments", INVALID, ids=[c[0] for c in INVALID])
def test_invalid_creature_files_name_the_fault(what, text, fragments, tmp_path):
    path = tmp_path / "mini.yaml"
    path.write_text(text)
    with pytest.raises(CreatureError) as info:
        load_creature(path)
    message = str(info.value)
    assert str(path) in message
    for fragment in fragments:
        assert fragment in message, f"{what}: {fragment!r} not in {message!r}"


def test_missing_file_and_binary_file(tmp_path):
    with pytest.raises(CreatureError, match="cannot read"):
        load_creature(tmp_path / "nope.yaml")
    binary = tmp_path / "b.yaml"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(CreatureError, match="UTF-8"):
        load_creature(binary)


def test_non_unit_quaternion_is_normalised_with_a_warning():
    text = _edit("caps: [head, mouth]", "caps: [head, mouth]\n    rot: [2, 0, 0, 0]")
    with pytest.warns(CreatureWarning, match="head"):
        c = creature_from_text(text, "mini.yaml")
    assert np.allclose(c.body_rest_rot[c.body("head")], [1, 0, 0, 0])
    # Rounding-level error is accepted silently.
    text = _edit("caps: [head, mouth]", "caps: [head, mouth]\n    rot: [1.0000000001, 0, 0, 0]")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        creature_from_text(text)


# -- worked by hand ------------------------------------------------------------------------


@pytest.fixture(scope="module")
def biped():
    return creature_from_text(BIPED, "mini.yaml")


def test_reroots_at_the_hip_and_orders_parents_first(biped):
    # The pelvis carries both legs, so it becomes the root although the file starts at the chest.
    assert biped.body_names[0] == "pelvis"
    assert biped.body_parent[0] == -1
    assert all(biped.body_parent[i] < i for i in range(1, biped.nbody))
    assert biped.body_names[biped.body_parent[biped.body("chest")]] == "pelvis"
    # The joint of the pelvis-chest edge moved from the pelvis to the chest.
    assert np.allclose(biped.body_joint[biped.body("chest")], [0, 0, 1.15])
    assert np.allclose(biped.body_joint[0], biped.body_rest_pos[0])
    # Depth-first: each sub-tree is a contiguous range.
    thigh = biped.body("thigh_l")
    assert biped.body_subtree_end[thigh] == thigh + 2
    assert biped.body_names[thigh + 1] == "foot_l"


def test_spine_limbs_legs(biped):
    names = biped.body_names
    assert [names[i] for i in biped.spine_chain] == ["pelvis", "chest"]
    assert biped.spine_root_index == 0
    assert biped.nleg == 2
    assert sorted(names[f] for f in biped.leg_foot) == ["foot_l", "foot_r"]
    assert all(names[h] == "pelvis" for h in biped.leg_hip)
    # Limb length: thigh joint (0.95) to foot joint (0.5).
    assert np.allclose(biped.leg_length, 0.45)
    assert biped.body_limb_length[biped.body("thigh_l")] == 0.0
    assert biped.body_limb_length[biped.body("head")] == 0.0
    assert [names[i] for i in biped.leg_path(0)] in (["foot_l", "thigh_l"], ["foot_r", "thigh_r"])
    assert names[biped.body_spine_attach[biped.body("foot_r")]] == "pelvis"
    assert names[biped.body_spine_attach[biped.body("head")]] == "chest"
    assert biped.nlimb == 3  # two legs and the head


def test_sides_mirrors_bounds(biped):
    b = biped.body
    assert biped.body_side[b("thigh_l")] == 1 and biped.body_side[b("foot_r")] == -1
    assert biped.body_side[b("head")] == 0
    assert biped.body_mirror[b("foot_l")] == b("foot_r")
    assert biped.body_mirror[b("head")] == b("head")
    assert np.allclose(biped.bounds, [[-0.1, -0.15, 0.0], [0.15, 0.15, 1.72]])
    assert np.isclose(biped.height, 1.72)
    assert biped.counts() == {"bodies": 7, "spine": 2, "legs": 2, "arms": 0, "heads": 1, "mouths": 1,
                              "eyes": 0, "wings": 0, "tails": 0}
    foot = biped.bodies_with("foot")
    assert list(foot) == sorted(foot)


def test_root_relative_rest_pose_with_a_rotated_root():
    # A root turned 90 degrees about Z: the root-relative pose is in the root's frame.
    text = _edit("    caps: [spine]\n    pos: [0, 0, 1.0]",
                 "    caps: [spine]\n    pos: [0, 0, 1.0]\n    rot: [0.7071067811865476, 0, 0, 0.7071067811865476]")
    c = creature_from_text(text)
    i = c.body("thigh_l")
    # thigh_l is 0.1 m to the left (+Y) and 0.25 m below; in the root frame +Y is its +X.
    assert np.allclose(c.body_rootrel_pos[i], [0.1, 0.0, -0.25])
    assert np.allclose(c.body_rootrel_rot[i], [0.7071067811865476, 0, 0, -0.7071067811865476])
    assert np.allclose(c.body_rootrel_pos[0], 0.0)


def test_immutable(biped):
    with pytest.raises(ValueError):
        biped.body_rest_pos[0, 0] = 1.0
    with pytest.raises(AttributeError):
        biped.name = "other"


def test_body_lookup_suggests_names(biped):
    assert biped.body("head") == biped.body_names.index("head")
    with pytest.raises(KeyError, match="did you mean 'foot_l'"):
        biped.body("foot_ll")


def test_round_trip_is_exact(biped, tmp_path):
    path = tmp_path / "again.yaml"
    biped.save(path)
    again = load_creature(path)
    assert again.body_names == biped.body_names
    for key, value in vars(biped).items():
        if isinstance(value, np.ndarray):
            assert np.array_equal(value, getattr(again, key)), key
    with pytest.raises(FileExistsError):
        biped.save(path)
    text = path.read_text()
    biped.save(path, overwrite=True)
    assert path.read_text() == text


def test_spine_chain_runs_through_a_middle_root():
    # A snake-like spine with the legs in the middle: the root is mid-spine and the chain
    # still runs end to end, back to front.
    bodies = ["format: 1", "name: lizard", "bodies:"]
    for k in range(5):
        bodies += [f"  - name: s{k}", "    caps: [spine]" + ("" if k == 0 else ""),
                   f"    pos: [{0.2 * k}, 0, 0.3]", "    extents: [0.1, 0.08, 0.05]"]
        if k:
            bodies.insert(-3, f"    parent: s{k - 1}")
    for side, y in (("l", 0.2), ("r", -0.2)):
        bodies += [f"  - name: leg_{side}", "    parent: s2", "    caps: [limb, foot]",
                   f"    pos: [0.4, {y}, 0.15]", f"    joint: [0.4, {y / 2}, 0.3]", "    extents: [0.03, 0.03, 0.15]"]
    c = creature_from_text("\n".join(bodies) + "\n")
    assert c.body_names[0] == "s2"
    assert [c.body_names[i] for i in c.spine_chain] == ["s0", "s1", "s2", "s3", "s4"]
    assert c.spine_root_index == 2
