"""glTF import on the real rigs in ../shared/data/rigs, capabilities from shape (glTF and BVH),
the CLI, and the errors for bad files (each naming the file and the node or field)."""

from __future__ import annotations

import json
import os
import struct
import warnings

import numpy as np
import pytest

pytest.importorskip("pygltflib")

from engine.errors import CreatureError  # noqa: E402
from engine.io.gltf import GltfError, import_gltf, load_gltf, read_accessor  # noqa: E402
from engine.io.sources import creature_from_file, explain_creature_source  # noqa: E402
from engine.model.builder import build_creature  # noqa: E402

HERE = os.path.dirname(__file__)
RIGS = os.path.join(HERE, "..", "..", "shared", "data", "rigs")
MOCAP = os.path.join(HERE, "..", "..", "shared", "data", "mocap")

# What a person counts on each rig: spine chain present, legs, arms (graspers), heads, tails
# (tail bodies), wings (wing bodies).
EXPECTED = {
    "fox_khronos.glb": dict(legs=4, arms=0, heads=1, tails=3, wings=0),
    "godot_mannequiny.glb": dict(legs=2, arms=2, heads=1, tails=0, wings=0),
    "quaternius_bee.glb": dict(legs=0, arms=0, heads=1, tails=0, wings=4),
    "quaternius_horse.glb": dict(legs=4, arms=0, heads=1, tails=7, wings=0),
    "quaternius_snake.glb": dict(legs=0, arms=0, heads=1, tails=4, wings=0),
    "quaternius_spider.glb": dict(legs=8, arms=0, heads=1, tails=0, wings=0),
    "riggedfigure_khronos.glb": dict(legs=2, arms=2, heads=1, tails=0, wings=0),
}


@pytest.fixture(scope="module")
def imports():
    return {name: import_gltf(os.path.join(RIGS, name)) for name in EXPECTED}


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_every_rig_imports_with_a_persons_counts(imports, name):
    imp = imports[name]
    c = build_creature(imp.cdef)
    k = c.counts()
    for key, value in EXPECTED[name].items():
        assert k[key] == value, (name, key, k)
    assert k["spine"] >= 2 and k["mouths"] >= 1
    # Standing on the ground, root above the origin, a plausible size in metres.
    assert abs(c.bounds[0, 2]) < 1e-9
    assert 0.3 < c.height < 6.0
    # Every body has a real box.
    ext = np.array([b.extents for b in imp.cdef.bodies])
    assert np.all(ext > 0)


def test_helpers_are_left_out_and_detached_feet_reattached(imports):
    horse = imports["quaternius_horse.glb"]
    assert sorted(horse.helpers) == ["PoleTarget.L", "PoleTarget.R", "PoleTargetBack.L", "PoleTargetBack.R"]
    assert "IKBackLeg.L -> BackLowerLeg.L" in horse.reattached
    names = [b.name for b in horse.cdef.bodies]
    assert "PoleTarget.L" not in names and "FFB.L" in names
    spider = imports["quaternius_spider.glb"]
    assert len(spider.reattached) == 8
    c = build_creature(spider.cdef)
    # Each leg now runs from its root on the body to the foot bone on the ground.
    assert all(c.leg_body_num >= 4)


def test_conversion_nodes_and_units(imports):
    # RiggedFigure: a Z_UP matrix node over a non-joint Armature; it stands 1.48 m tall, head up.
    fig = imports["riggedfigure_khronos.glb"]
    assert "Z_UP" in fig.skipped and "Armature" in fig.skipped
    body = {b.name: b for b in fig.cdef.bodies}
    assert body["neck_joint_2"].joint[2] > body["torso_joint_1"].joint[2] + 0.4
    # The Fox is authored in centimetres: taken as 0.01 and said so.
    fox = imports["fox_khronos.glb"]
    assert fox.scale == 0.01 and any("centimetres" in n for n in fox.notes)
    assert 0.5 < build_creature(fox.cdef).height < 1.0
    # The fox's head is in front of its tail (+X forward).
    fb = {b.name: b for b in fox.cdef.bodies}
    assert fb["b_Head_05"].joint[0] > fb["b_Tail03_014"].joint[0]
    # Legs are mirrored across the sagittal plane (+Y left).
    assert fb["b_LeftLeg01_015"].joint[1] == pytest.approx(-fb["b_RightLeg01_019"].joint[1], abs=1e-3)
    assert fb["b_LeftLeg01_015"].joint[1] > 0


def test_nan_weights_are_weight_zero(imports):
    bee = imports["quaternius_bee.glb"]
    assert any("non-finite WEIGHTS_0" in n for n in bee.notes)


def test_scale_and_skin_options():
    path = os.path.join(RIGS, "riggedfigure_khronos.glb")
    a = build_creature(import_gltf(path).cdef)
    b = build_creature(import_gltf(path, scale=2.0).cdef)
    assert b.height == pytest.approx(2 * a.height, rel=1e-9)
    with pytest.raises(GltfError, match="skin 3 does not exist"):
        import_gltf(path, skin=3)
    with pytest.raises(GltfError, match="scale must be a positive number"):
        import_gltf(path, scale=-1)


def test_creature_from_file_reads_gltf():
    c = creature_from_file(os.path.join(RIGS, "quaternius_spider.glb"))
    assert c.nleg == 8


def test_read_accessor_strides_and_sparse():
    gf = load_gltf(os.path.join(RIGS, "riggedfigure_khronos.glb"))
    ibm = read_accessor(gf, gf.doc.skins[0].inverseBindMatrices)
    assert ibm.shape == (19, 4, 4)
    np.testing.assert_allclose(ibm[:, 3], np.broadcast_to([0, 0, 0, 1], (19, 4)), atol=1e-6)


# -- capabilities from shape on BVH --------------------------------------------------------


@pytest.mark.parametrize("name", ["cmu_02_01_walk.bvh", "cmu_131_01_start_walk_stop_3dsmax.bvh",
                                  "boxing_toes_punch_hit_fall.bvh"])
def test_captures_get_legs_arms_head_from_shape(name):
    c = creature_from_file(os.path.join(MOCAP, name))
    k = c.counts()
    assert (k["legs"], k["arms"], k["heads"], k["tails"]) == (2, 2, 1, 0)


#: Library creatures of kinds no shared rig covers, written as bare BVH skeletons with every
#: joint renamed j0, j1, ...: a person's counts (legs, arms, heads, tail chains).
SHAPE_ONLY = {
    "twoheaded": (2, 2, 2, 0),    # two heads on necks off one chest
    "forkstrider": (4, 2, 1, 0),  # each leg forks into two feet
    "crab": (8, 2, 1, 0),         # legs and claws hang off the carapace, which is the head
    "scorpion": (8, 2, 1, 1),     # the tail curls up over the back; the head is in front
    "mantis": (4, 2, 1, 0),       # a small head on a long prothorax with raptorial arms
    "octopus": (0, 8, 1, 0),      # arms lying out over the ground are not legs
    "tripod": (3, 0, 1, 0),       # the front leg is on the sagittal plane
    "threearmed": (2, 3, 1, 0),   # a third arm with no mirror partner
    "elephant": (4, 1, 1, 1),     # the trunk is an arm
    "kangaroo": (2, 2, 1, 1),     # the tail trails down to the ground behind: a tail, not a leg
}


@pytest.mark.parametrize("name", sorted(SHAPE_ONLY))
def test_held_back_skeletons_get_a_persons_counts_from_shape_alone(tmp_path, name):
    import engine
    from engine.io.bake import recording_to_bvh
    from engine.io.bvh import BvhClip, save_bvh
    from engine.io.bvh_creature import creature_from_bvh
    from engine.io.gltf_export import Recording
    from engine.model.caps import CAP_BIT
    from engine.paths import LIBRARY_CREATURES

    c = engine.load_creature(LIBRARY_CREATURES / f"{name}.yaml")
    clip = recording_to_bvh(c, Recording("rest", 30.0, c.body_rest_pos[None].copy(), c.body_rest_rot[None].copy()))
    clip = BvhClip(joint_names=tuple(f"j{i}" for i in range(clip.njoint)), joint_parent=clip.joint_parent,
                   joint_offset=clip.joint_offset, joint_channels=clip.joint_channels,
                   joint_end_site=clip.joint_end_site, frame_time=clip.frame_time, motion=clip.motion)
    save_bvh(clip, tmp_path / f"{name}.bvh")
    back = creature_from_bvh(tmp_path / f"{name}.bvh", scale=0.01, rest="file")
    k = back.counts()
    tail = (back.body_caps & CAP_BIT["tail"]) != 0
    tails = int(sum(1 for i in range(back.nbody) if tail[i] and not (back.body_parent[i] >= 0
                                                                      and tail[back.body_parent[i]])))
    assert (k["legs"], k["arms"], k["heads"], tails) == SHAPE_ONLY[name], (name, k, tails)


def test_a_part_named_before_its_segments_says_what_it_is():
    """``wing0_l_seg2`` is a wing, ``tail0_seg1`` a tail, ``upperarm_twist_01_l`` an arm bone;
    the last token still wins where it says something (``arm0_l_hand`` is a hand)."""
    from engine.io.bvh_creature import _DEFAULT_COMPILED
    from engine.model.shape_caps import name_caps

    assert name_caps("wing0_l_seg2", _DEFAULT_COMPILED) == ["wing"]
    assert name_caps("tail0_seg1", _DEFAULT_COMPILED) == ["tail"]
    assert name_caps("upperarm_twist_01_l", _DEFAULT_COMPILED) == ["limb"]
    assert name_caps("arm0_l_hand", _DEFAULT_COMPILED) == ["limb", "grasper"]
    assert name_caps("seg1", _DEFAULT_COMPILED) is None


# Random creatures (seeds 600-659 were held out while the rule was written on 500-559) whose
# skeletons, exported as BVH with their names, come back with their wings and tails.
RANDOM_BACK = {603: "wings", 615: "wings", 628: "wings", 635: "tails"}


@pytest.mark.parametrize("seed", sorted(RANDOM_BACK))
def test_random_skeletons_get_their_wings_and_tails(tmp_path, seed):
    from engine.io.bake import recording_to_bvh
    from engine.io.bvh import save_bvh
    from engine.io.bvh_creature import creature_from_bvh
    from engine.io.gltf_export import Recording
    from engine.model import build_creature
    from engine.model.caps import CAP_BIT
    from engine.model.random import random_creature_def

    c = build_creature(random_creature_def(seed))
    save_bvh(recording_to_bvh(c, Recording("rest", 30.0, c.body_rest_pos[None].copy(),
                                           c.body_rest_rot[None].copy())), tmp_path / "r.bvh")
    back = creature_from_bvh(tmp_path / "r.bvh", scale=0.01, rest="file")

    def chains(x, cap):
        has = (x.body_caps & CAP_BIT[cap]) != 0
        return int(sum(1 for i in range(x.nbody) if has[i] and not (x.body_parent[i] >= 0
                                                                     and has[x.body_parent[i]])))

    cap = RANDOM_BACK[seed][:-1]
    assert chains(back, cap) == chains(c, cap) > 0
    assert back.counts()["arms"] == c.counts()["arms"]


def test_character_creator_names_get_their_limbs(tmp_path):
    """A capture with Character Creator joint names (CC_Base_...): names say nothing the table
    knows, the shape says two legs, two arms, a head."""
    from engine.io.bvh import load_bvh

    src = load_bvh(os.path.join(MOCAP, "cmu_02_01_walk.bvh"))
    rename = {"Hips": "CC_Base_Hip", "LHipJoint": "CC_Base_L_Pelvis", "LeftUpLeg": "CC_Base_L_Thigh",
              "LeftLeg": "CC_Base_L_Calf", "LeftFoot": "CC_Base_L_Foot", "LeftToeBase": "CC_Base_L_ToeBase",
              "LowerBack": "CC_Base_Waist", "Spine": "CC_Base_Spine01", "Spine1": "CC_Base_Spine02",
              "Neck": "CC_Base_NeckTwist01", "Neck1": "CC_Base_NeckTwist02", "Head": "CC_Base_Head",
              "LeftShoulder": "CC_Base_L_Clavicle", "LeftArm": "CC_Base_L_Upperarm",
              "LeftForeArm": "CC_Base_L_Forearm", "LeftHand": "CC_Base_L_Hand"}
    for k in list(rename):
        if k.startswith("Left"):
            rename[k.replace("Left", "Right")] = rename[k].replace("_L_", "_R_")
        if k.startswith("LHip"):
            rename["RHipJoint"] = "CC_Base_R_Pelvis"
    text = open(os.path.join(MOCAP, "cmu_02_01_walk.bvh"), encoding="utf-8").read()
    import re

    for old in sorted(src.joint_names, key=len, reverse=True):
        new = rename.get(old, "CC_Base_" + old)
        text = re.sub(rf"(JOINT|ROOT) {old}\b", rf"\1 {new}", text)
    path = tmp_path / "cc_capture.bvh"
    path.write_text(text)
    c = creature_from_file(path)
    k = c.counts()
    assert (k["legs"], k["arms"], k["heads"]) == (2, 2, 1)
    assert c.body_caps[c.body("CC_Base_Head")] & 64  # head
    report = explain_creature_source(path)
    assert "CC_Base_L_Thigh" in report and "leg:" in report


def test_explain_names_every_body():
    report = explain_creature_source(os.path.join(RIGS, "quaternius_horse.glb"))
    assert "helper bones left out" in report and "PoleTarget.L" in report
    assert "tail: a sagittal chain" in report and "foot:" in report


def test_a_user_caps_table_has_the_last_word():
    path = os.path.join(RIGS, "riggedfigure_khronos.glb")
    imp = import_gltf(path, caps_table={"arm_joint_L_3": ["limb"]})
    assert build_creature(imp.cdef).counts()["arms"] == 1


# -- the command line ---------------------------------------------------------------------


def test_cli_from_gltf_writes_and_refuses_to_overwrite(tmp_path, capsys):
    from engine.cli import main
    from engine.model import load_creature

    out = tmp_path / "spider.yaml"
    src = os.path.join(RIGS, "quaternius_spider.glb")
    assert main(["creatures", "from-gltf", src, "--out", str(out)]) == 0
    assert "helper bones" in capsys.readouterr().out
    assert load_creature(out).nleg == 8
    assert main(["creatures", "from-gltf", src, "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err
    assert main(["creatures", "from-gltf", src, "--out", str(out), "--force", "--scale", "0.5"]) == 0
    assert main(["creatures", "explain", src]) == 0


# -- bad files ----------------------------------------------------------------------------


def _glb(doc: dict, blob: bytes = b"") -> bytes:
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    blob += b"\0" * (-len(blob) % 4)
    chunks = struct.pack("<II", len(js), 0x4E4F534A) + js
    if blob:
        chunks += struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks


BAD = [
    ({"asset": {"version": "2.0"}, "nodes": [{"name": "a"}]}, "no skin"),
    ({"asset": {"version": "2.0"}, "nodes": [{"name": "a"}], "skins": [{"joints": [4]}]}, "joint node 4 does not exist"),
    ({"asset": {"version": "2.0"}, "nodes": [{"name": "a", "children": [0]}], "skins": [{"joints": [0]}]},
     "cycle"),
    ({"asset": {"version": "2.0"}, "nodes": [{"name": "a", "rotation": [0, 0, 0, 0]}], "skins": [{"joints": [0]}]},
     "node '0 \\(a\\)', field 'rotation'"),
    ({"asset": {"version": "2.0"}, "nodes": [{"name": "a", "translation": [0, 1]}], "skins": [{"joints": [0]}]},
     "translation must be 3"),
    ({"asset": {"version": "2.0"}, "nodes": [{"name": "a", "children": [1]}, {"name": "a"}],
      "skins": [{"joints": [0, 1]}]}, "two joints are both named 'a'"),
    ({"asset": {"version": "1.0"}, "nodes": []}, "version 1.0"),
]


@pytest.mark.parametrize("doc,words", BAD)
def test_bad_files_name_file_and_node(tmp_path, doc, words):
    path = tmp_path / "bad.glb"
    path.write_bytes(_glb(doc))
    with pytest.raises(GltfError, match=words) as info:
        import_gltf(path)
    assert str(path) in str(info.value)


def test_unreadable_and_truncated(tmp_path):
    path = tmp_path / "junk.glb"
    path.write_bytes(b"glTF\x02\0\0\0garbage")
    with pytest.raises(GltfError, match="not a readable glTF"):
        import_gltf(path)
    with pytest.raises(GltfError, match="no such file"):
        import_gltf(tmp_path / "missing.glb")
    # An accessor reading past its bufferView.
    doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 8}],
           "bufferViews": [{"buffer": 0, "byteLength": 8}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "MAT4"}],
           "nodes": [{"name": "a"}], "skins": [{"joints": [0], "inverseBindMatrices": 0}],
           "meshes": [], }
    path = tmp_path / "short.glb"
    path.write_bytes(_glb(doc, b"\0" * 8))
    with pytest.raises(GltfError, match="accessor '0'.*past the end"):
        gf = load_gltf(path)
        read_accessor(gf, 0)


def test_builder_errors_come_back_as_gltf_errors():
    # A caps table that makes the spine branch: the builder's complaint, naming the file.
    path = os.path.join(RIGS, "riggedfigure_khronos.glb")
    with pytest.raises((GltfError, CreatureError), match="riggedfigure_khronos.glb"):
        import_gltf(path, caps_table={"arm_joint_._1": ["spine"]})


# -- the relaxed rest pose -----------------------------------------------------------------


def _arm_drop(cdef, shoulder, hand):
    body = {b.name: b for b in cdef.bodies}
    return np.array(body[hand].joint) - np.array(body[shoulder].joint)


def test_t_pose_arms_hang_down_in_the_relaxed_rest():
    path = os.path.join(RIGS, "godot_mannequiny.glb")
    tpose = import_gltf(path, rest="file")
    relaxed = import_gltf(path)
    d0 = _arm_drop(tpose.cdef, "upperarm.l", "hand.l")
    d1 = _arm_drop(relaxed.cdef, "upperarm.l", "hand.l")
    assert abs(d0[2]) < 0.3 * np.linalg.norm(d0)          # out at the side in the file
    assert d1[2] < -0.95 * np.linalg.norm(d1) and d1[1] > 0  # hanging, a little outward (left)
    assert np.linalg.norm(d1) == pytest.approx(np.linalg.norm(d0), rel=1e-9)  # the arm keeps its length
    assert len(relaxed.relaxed) == 2
    # Bodies off the arms do not move; the feet are where they were.
    b0 = {b.name: b for b in tpose.cdef.bodies}
    for b in relaxed.cdef.bodies:
        if b.name in ("foot.l", "head", "pelvis", "clavicle.l"):
            np.testing.assert_allclose(b.pos, b0[b.name].pos, atol=1e-12)
    # rest_delta undoes it: the file's box rotations come back.
    from engine.mathx import quat_mul

    k = [b.name for b in relaxed.cdef.bodies].index("lowerarm.l")
    dq = relaxed.rest_delta[k] * np.array([1, -1, -1, -1])
    back = quat_mul(dq, np.array(relaxed.cdef.bodies[k].rot, dtype=float))
    assert abs(abs(np.dot(back, tpose.cdef.bodies[k].rot)) - 1) < 1e-9


def test_capture_arms_hang_and_arms_already_down_stay():
    from engine.io.bvh_creature import creature_def_from_bvh

    cdef = creature_def_from_bvh(os.path.join(MOCAP, "cmu_02_01_walk.bvh"))
    d = _arm_drop(cdef, "LeftArm", "LeftHand")
    assert d[2] < -0.95 * np.linalg.norm(d)
    # The library humanoid's arms already hang: nothing to do.
    from engine.model import load_creature
    from engine.model.rest_pose import relax_arms

    h = load_creature(os.path.join(HERE, "..", "creatures", "humanoid.yaml"))
    caps = [[c for c in ("spine", "grasper") if h.body_caps[i] & {"spine": 1, "grasper": 4}[c]]
            for i in range(h.nbody)]
    cdef_h = h.to_def()
    _, _, _, _, turned = relax_arms(h.body_parent, caps, [b.joint for b in cdef_h.bodies],
                                    [b.pos for b in cdef_h.bodies], [b.rot for b in cdef_h.bodies])
    assert turned == []


@pytest.mark.parametrize("name", sorted(n for n in os.listdir(MOCAP) if n.endswith(".bvh")))
def test_capture_feet_stand_under_the_hips(name):
    """A capture whose OFFSET pose splays the legs (CMU's thighs lean 20 degrees out) stands
    with its feet under its hips in the relaxed rest: each leg turned about the forward axis
    at its hip, its length and forward lean kept, the foot's sole as in the file, the
    lowest box on the ground. A capture standing straight already is left as it is."""
    from engine.io.bvh_creature import _box_min_z, creature_def_from_bvh
    from engine.model.rest_pose import LEG_MIN_SPLAY, LEG_SPLAY

    path = os.path.join(MOCAP, name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        file_def = creature_def_from_bvh(path, rest="file")
        relaxed = creature_def_from_bvh(path)
    b0 = {b.name: b for b in file_def.bodies}
    b1 = {b.name: b for b in relaxed.bodies}
    feet = [b.name for b in relaxed.bodies if "foot" in b.caps and not (b.parent and "foot" in b1[b.parent].caps)]
    assert len(feet) == 2
    for foot in feet:
        hip = b1[b1[foot].parent].parent                 # the thigh's joint: foot <- shin <- thigh
        d0 = np.subtract(b0[foot].joint, b0[hip].joint)
        d1 = np.subtract(b1[foot].joint, b1[hip].joint)
        side = np.sign(b0[hip].joint[1] - file_def.bodies[0].joint[1])
        lean0 = np.arctan2(side * d0[1], -d0[2])
        lean1 = np.arctan2(side * d1[1], -d1[2])
        assert np.linalg.norm(d1) == pytest.approx(np.linalg.norm(d0), rel=1e-9)     # the leg keeps its length
        assert d1[0] == pytest.approx(d0[0], abs=1e-9)                               # ... and its forward lean
        if lean0 > LEG_MIN_SPLAY:
            assert lean1 < LEG_SPLAY + np.radians(2.0), (foot, np.degrees(lean0), np.degrees(lean1))
            assert abs(abs(np.dot(b1[foot].rot, b0[foot].rot)) - 1) < 1e-9           # the sole lies as before
        else:
            np.testing.assert_allclose(b1[foot].joint, b0[foot].joint, atol=1e-12)
    centre = np.array([b.pos for b in relaxed.bodies])
    rot = np.array([b.rot for b in relaxed.bodies])
    half = np.array([b.extents for b in relaxed.bodies])
    assert _box_min_z(centre, rot, half) == pytest.approx(0.0, abs=1e-12)


def test_many_legged_and_standing_rigs_keep_their_legs():
    """The spider's eight splayed legs and the mannequin's straight ones stay as the file
    has them (only a biped's splay is a capture's pose, not its build)."""
    for rig, feet in (("quaternius_spider.glb", 8), ("godot_mannequiny.glb", 2)):
        a, b = import_gltf(os.path.join(RIGS, rig), rest="file"), import_gltf(os.path.join(RIGS, rig))
        fa = {x.name: x for x in a.cdef.bodies}
        got = [x for x in b.cdef.bodies if "foot" in x.caps and not (x.parent and "foot" in fa[x.parent].caps)]
        assert len(got) == feet
        for x in got:
            np.testing.assert_allclose(x.joint, fa[x.name].joint, atol=1e-12)
        assert not any("leg turned" in r for r in b.relaxed)


@pytest.mark.parametrize("name", ["fox_khronos.glb", "quaternius_bee.glb"])
def test_our_reader_agrees_with_pygltflib(name):
    import pygltflib

    path = os.path.join(RIGS, name)
    ours = load_gltf(path)
    ref = pygltflib.GLTF2().load(path)
    assert [n.name for n in ours.doc.nodes] == [n.name for n in ref.nodes]
    assert [n.children or [] for n in ours.doc.nodes] == [n.children or [] for n in ref.nodes]
    assert [s.joints for s in ours.doc.skins] == [s.joints for s in ref.skins]
    blob = ref.binary_blob()
    assert ours.buffers[0][:len(blob)] == blob
    for k, acc in enumerate(ref.accessors[:12]):
        a = read_accessor(ours, k, finite=False)
        assert a.shape[0] == acc.count


def test_rest_from_a_capture_frame(tmp_path):
    from engine.cli import main
    from engine.io.bvh import load_bvh
    from engine.io.bvh_creature import creature_def_from_bvh
    from engine.model import load_creature

    path = os.path.join(MOCAP, "cmu_02_01_walk.bvh")
    clip = load_bvh(path)
    cdef = creature_def_from_bvh(clip, rest=100)
    c = build_creature(cdef)
    assert (c.nleg, c.counts()["arms"]) == (2, 2)
    assert abs(c.bounds[0, 2]) < 1e-9
    # The arms hang as the walker holds them at frame 100, not out in the T-pose.
    body = {b.name: b for b in cdef.bodies}
    d = np.array(body["LeftHand"].joint) - np.array(body["LeftArm"].joint)
    assert d[2] < -0.8 * np.linalg.norm(d)
    with pytest.raises(Exception, match="rest frame 99999 is outside"):
        creature_def_from_bvh(clip, rest=99999)
    out = tmp_path / "walk100.yaml"
    assert main(["creatures", "from-bvh", path, "--out", str(out), "--rest-frame", "100"]) == 0
    assert load_creature(out).nleg == 2


# Hand-made skeletons of kinds neither the shared rigs nor the library have (Y up, Z forward,
# centimetres, joints named j0, j1, ...): (name, offset, children) trees.
def _side(tree):
    name, (x, y, z), kids = tree
    return [tree, (name + "r", (-x, y, z), [_side(k)[1] for k in kids])]


def _chain(prefix, offsets):
    node = None
    for i in reversed(range(len(offsets))):
        node = (f"{prefix}{i}", offsets[i], [node] if node else [])
    return node


HELD_OUT = {
    # a frog crouched on long hind feet and short forelegs: four legs
    "frog": (("pelvis", (0, 10, 0), [
        *_side(_chain("hind", [(3, 0, -1), (5, -3, 5), (1, -4, -7), (1, -3, 5), (1, 0, 4)])),
        ("sp1", (0, 2, 5), [("sp2", (0, 1, 5), [
            ("skull", (0, 1, 4), [("snout", (0, 0, 4), [])]),
            *_side(_chain("fore", [(3, -1, 1), (1, -5, 2), (0, -5, 1), (1, -2, 2)]))])])]),
        (4, 0, 1, 0)),
    # an armless walker: two digitigrade legs under a hip block, a cab with a sensor on top
    "mech": (("hip", (0, 100, 0), [
        *_side(_chain("strut", [(20, 0, 0), (2, -45, 15), (0, -45, -20), (0, -10, 8), (0, 0, 18)])),
        ("turret", (0, 20, 0), [("cab", (0, 15, 5), [("sensor", (0, 10, 20), [])])])]),
        (2, 0, 1, 0)),
    # a shark: pectoral fins, a dorsal fin, a tail with a forked fluke: no legs, one tail
    "shark": (("body", (0, 60, 0), [
        ("fore", (0, 0, 25), [("skull", (0, 0, 25), [("jaw", (0, -5, 15), []), ("snout", (0, 0, 20), [])]),
                              *_side(_chain("fin", [(12, -6, 0), (20, -10, -10)])),
                              ("dorsal", (0, 15, -10), [("dorsal1", (0, 20, -10), [])])]),
        ("aft", (0, 0, -30), [("aft1", (0, 0, -30), [("aft2", (0, 0, -25), [
            ("aft3", (0, 0, -20), [("up", (0, 20, -20), []), ("dn", (0, -12, -12), [])])])])])]),
        (0, 0, 1, 1)),
    # a hand lying flat: four fingers and a thumb, nothing a person calls a leg or a head
    "hand": (("wrist", (0, 3, 0), [("palm", (0, 0, 4), [
        *[_chain(f, [base, (0, 0, 3), (0, 0, 2.4), (0, 0, 1.9)])
          for f, base in (("a", (-3, 0, 4)), ("b", (-1, 0, 5)), ("c", (1, 0, 5)), ("d", (3, 0, 4)))],
        _chain("t", [(-4, 0, -1), (-2, 0, 2), (-1, 0, 2), (0, 0, 2)])])]),
        (0, 0, 0, 0)),
}


def _skeleton_bvh(tree):
    lines, count = ["HIERARCHY"], [0]

    def emit(node, depth):
        _, off, kids = node
        pad = "\t" * depth
        lines.append(f"{pad}{'ROOT' if depth == 0 else 'JOINT'} j{count[0]}")
        count[0] += 1
        lines.extend([f"{pad}{{", f"{pad}\tOFFSET {off[0]} {off[1]} {off[2]}",
                  f"{pad}\tCHANNELS " + ("6 Xposition Yposition Zposition " if depth == 0 else "3 ")
                  + "Zrotation Yrotation Xrotation"])
        for k in kids:
            emit(k, depth + 1)
        if not kids:
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET 0 0 0", f"{pad}\t}}"])
        lines.append(f"{pad}}}")

    emit(tree, 0)
    root = tree[1]
    lines += ["MOTION", "Frames: 1", "Frame Time: 0.0333333",
              " ".join(str(v) for v in (*root, *([0] * (3 * count[0]))))]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("name", ["frog", "mech", "shark", "hand"])
def test_hand_made_skeletons_of_new_kinds_get_a_persons_counts(tmp_path, name):
    from engine.io.bvh_creature import creature_from_bvh
    from engine.model.caps import CAP_BIT

    tree, want = HELD_OUT[name]
    path = tmp_path / f"{name}.bvh"
    path.write_text(_skeleton_bvh(tree))
    c = creature_from_bvh(path, scale=0.01, rest="file")
    k = c.counts()
    tail = (c.body_caps & CAP_BIT["tail"]) != 0
    tails = int(sum(1 for i in range(c.nbody) if tail[i] and not (c.body_parent[i] >= 0 and tail[c.body_parent[i]])))
    assert (k["legs"], k["arms"], k["heads"], tails) == want, (name, k, tails)


# Random creatures with a leg on the sagittal plane at the rear end of their back: the back
# runs level, then the leg comes down. Seeds 700-799 were held out while the rule was
# written on 500-559 (benchmarks/shape_caps_check.py --random 100 --first-seed 700: every
# count exact on 90 of 137 skeletons, 82 before the rule; legs 127, 117 before).
SAGITTAL_REAR_LEGS = (704, 717, 741, 754, 768, 771, 772)


@pytest.mark.parametrize("scramble", [False, True], ids=["names", "shape-only"])
@pytest.mark.parametrize("seed", SAGITTAL_REAR_LEGS)
def test_a_leg_at_the_rear_of_a_long_back_is_a_leg_and_the_back_is_spine(tmp_path, seed, scramble):
    from engine.io.bake import recording_to_bvh
    from engine.io.bvh import BvhClip, save_bvh
    from engine.io.bvh_creature import creature_from_bvh
    from engine.io.gltf_export import Recording
    from engine.model import build_creature
    from engine.model.caps import CAP_BIT
    from engine.model.random import random_creature_def

    c = build_creature(random_creature_def(seed))
    clip = recording_to_bvh(c, Recording("rest", 30.0, c.body_rest_pos[None].copy(), c.body_rest_rot[None].copy()))
    if scramble:
        clip = BvhClip(joint_names=tuple(f"j{i}" for i in range(clip.njoint)), joint_parent=clip.joint_parent,
                       joint_offset=clip.joint_offset, joint_channels=clip.joint_channels,
                       joint_end_site=clip.joint_end_site, frame_time=clip.frame_time, motion=clip.motion)
    save_bvh(clip, tmp_path / "r.bvh")
    back = creature_from_bvh(tmp_path / "r.bvh", scale=0.01, rest="file")
    assert back.nleg == c.nleg, (seed, back.nleg, c.nleg)
    # the sagittal leg's foot is found, and every body the creature calls spine is spine again
    side = [int(back.body_side[f]) for f in back.leg_foot]
    assert side.count(0) == [int(c.body_side[f]) for f in c.leg_foot].count(0) >= 1, (seed, side)
    spine = (c.body_caps & CAP_BIT["spine"]) != 0
    assert np.all((back.body_caps[spine] & CAP_BIT["spine"]) != 0), [c.body_names[i] for i in np.flatnonzero(
        spine & ((back.body_caps & CAP_BIT["spine"]) == 0))]
