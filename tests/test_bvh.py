"""BVH import/export and BVH skeletons as creatures.

Opens with the list of invalid BVH texts, each with the error and line it must raise; then
every real capture in the shared data's ``mocap`` folder (``engine.paths.shared_data``) (counts from SOURCES.md), forward kinematics
against a slow per-joint 4x4-matrix reference, the axis map, round trips, and creatures
built from every file.
"""

from __future__ import annotations

import glob
import os
import re
import time
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import BvhError, CreatureError
from engine.io.bvh import (
    AXIS_MAP,
    UNIT_SCALES,
    BvhClip,
    BvhWarning,
    auto_scale,
    bvh_text,
    load_bvh,
    parse_bvh_text,
    quat_rotate,
    quat_to_menagerie_axes,
    save_bvh,
    to_menagerie_axes,
)
from engine.io.bvh_creature import (
    MIN_HALF_EXTENT,
    THICKNESS_FRACTION,
    CapsTableError,
    bvh_body_poses,
    creature_def_from_bvh,
    creature_from_bvh,
    joint_caps,
    load_caps_table,
)
from engine.model import build_creature
from engine.model.caps import CAP_BIT
from engine.paths import has_shared_data, shared_data

MOCAP = str(shared_data("mocap")) if has_shared_data() else ""
FILES = sorted(glob.glob(os.path.join(MOCAP, "*.bvh")))

# A two-joint skeleton; line numbers are used by the invalid-input list below.
TINY = """\
HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Chest
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.1
0 0 0 0 0 0 0 0 0
1 2 3 4 5 6 7 8 9
"""


def edit(line: int, new: str | None = None, insert: str | None = None, cut_after: int | None = None) -> str:
    """TINY with 1-based ``line`` replaced by ``new`` (None deletes it), or ``insert`` put
    before it, or everything after line ``cut_after`` removed."""
    lines = TINY.splitlines()
    if cut_after is not None:
        return "\n".join(lines[:cut_after]) + "\n"
    if insert is not None:
        lines.insert(line - 1, insert)
    elif new is None:
        del lines[line - 1]
    else:
        lines[line - 1] = new
    return "\n".join(lines) + "\n"


INVALID = [
    # (text, line the error must name, words the message must contain)
    ("", 1, "end of file"),
    (edit(1, "HIERARCHYX"), 1, "HIERARCHY"),
    (edit(2, "ROOT"), 2, "without a name"),
    (edit(2, "JOINT Hips"), 2, "ROOT"),
    (edit(3, None), 3, "expected '{'"),
    (edit(4, None), 4, "missing OFFSET"),
    (edit(8, "    OFFSET 0 10"), 8, "3 numbers"),
    (edit(8, "    OFFSET 0 abc 0"), 8, "expected a number"),
    (edit(8, "    OFFSET 0 1e999 0"), 8, "out of range"),
    (edit(9, "    CHANNELS 3 Zrotation Xrotation Wrotation"), 9, "unknown channel name 'Wrotation'"),
    (edit(9, "    CHANNELS 3 Zrotation Xrotation"), 9, "says 3 channels but lists 2"),
    (edit(9, "    CHANNELS 3 Zrotation Zrotation Yrotation"), 9, "listed twice"),
    (edit(9, "    CHANNELS 7 Zrotation Xrotation Yrotation Xposition Yposition Zposition Zrotation"), 9,
     "more than 6"),
    (edit(9, "    CHANNELS three Zrotation"), 9, "count"),
    (edit(9, "    JOINT Foot"), 9, "missing CHANNELS"),
    (edit(6, "  JOINT Hips"), 6, "duplicate joint name"),
    (edit(7, None), 7, "expected '{'"),
    (edit(10, "    Endd Site"), 10, "unexpected 'Endd'"),
    (edit(10, "    End Sight"), 10, "End Site"),
    (edit(12, "      OFFSET 0 5"), 12, "3 numbers"),
    (edit(14, insert="    End Site\n    {\n      OFFSET 0 1 0\n    }"), 14, "second End Site"),
    (edit(14, None), 15, "unbalanced braces"),                  # MOTION with Hips still open
    (edit(16, insert="}"), 16, "unbalanced braces"),           # one '}' too many
    (edit(16, insert="ROOT Other"), 16, "second ROOT"),
    (edit(16, insert="OFFSET 1 2 3"), 16, "expected MOTION"),
    (edit(0, cut_after=15), 15, "no MOTION section"),
    (edit(17, "Frames: x"), 17, "whole number"),
    (edit(17, "Frame: 2"), 17, "Frames:"),
    (edit(18, "Frame Time: 0"), 18, "> 0"),
    (edit(18, "Frame Time: abc"), 18, "expected a number"),
    (edit(18, "Frametime 0.1"), 18, "Frame Time"),
    (edit(20, "1 2 3 4 5 6 7 8"), 20, "has 8 values, expected 9"),
    (edit(20, "1 2 3 4 5 6 7 8 9 10"), 20, "has 10 values, expected 9"),
    (edit(19, "0 0 0 0 0 x 0 0 0"), 19, "'x' is not a finite number"),
    (edit(20, "1 2 3 4 nan 6 7 8 9"), 20, "'nan' is not a finite number"),
    (edit(20, "1 2 3 4 1e999 6 7 8 9"), 20, "not a finite number"),
]


@pytest.mark.parametrize("text,line,words", INVALID)
def test_invalid_bvh_raises_with_line(text, line, words):
    with pytest.raises(BvhError) as info:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", BvhWarning)
            parse_bvh_text(text, "bad.bvh")
    err = info.value
    assert err.path == "bad.bvh"
    assert err.line == line, str(err)
    assert words in str(err), str(err)
    assert str(err).startswith(f"bad.bvh:{line}")


def test_missing_file_names_it(tmp_path):
    with pytest.raises(BvhError, match="cannot read BVH file"):
        load_bvh(tmp_path / "nope.bvh")


# -- small texts answered by hand --------------------------------------------------------


def test_tiny_parses_to_hand_values():
    clip = parse_bvh_text(TINY)
    assert clip.joint_names == ("Hips", "Chest")
    assert clip.joint_parent.tolist() == [-1, 0]
    assert clip.joint_channels[1] == ("Zrotation", "Xrotation", "Yrotation")
    assert clip.joint_channel_adr.tolist() == [0, 6]
    np.testing.assert_array_equal(clip.joint_offset, [[0, 0, 0], [0, 10, 0]])
    assert np.isnan(clip.joint_end_site[0]).all()
    np.testing.assert_array_equal(clip.joint_end_site[1], [0, 5, 0])
    assert clip.nframe == 2 and clip.frame_time == 0.1 and clip.nchannel == 9
    np.testing.assert_array_equal(clip.motion[1], np.arange(1, 10))
    np.testing.assert_array_equal(clip.root_translation()[1], [1, 2, 3])
    assert clip.joint_line.tolist() == [2, 6]
    assert not clip.motion.flags.writeable and not clip.joint_offset.flags.writeable


def one_joint_motion(channels: str, values: str, child_offset=(1.0, 0.0, 0.0)) -> BvhClip:
    n = len(channels.split())
    text = (f"HIERARCHY\nROOT A\n{{\nOFFSET 0 0 0\nCHANNELS {n} {channels}\nJOINT B\n{{\n"
            f"OFFSET {child_offset[0]} {child_offset[1]} {child_offset[2]}\nCHANNELS 0\n}}\n}}\n"
            f"MOTION\nFrames: 1\nFrame Time: 0.04\n{values}\n")
    return parse_bvh_text(text)


def test_rotation_is_intrinsic_in_listed_order():
    # Zrotation 90 then Xrotation 90: R = Rz(90) Rx(90). The child at (0, 1, 0) goes by
    # Rx to (0, 0, 1), which Rz leaves alone. (Extrinsic, Rx Rz, would give (-1, 0, 0).)
    clip = one_joint_motion("Zrotation Xrotation", "90 90", (0.0, 1.0, 0.0))
    pos, _ = clip.forward_kinematics()
    np.testing.assert_allclose(pos[0, 1], [0, 0, 1], atol=1e-12)
    # Listed the other way round the same angles give Rx(90) Rz(90): (0,1,0) -> (-1,0,0) -> (-1,0,0).
    clip = one_joint_motion("Xrotation Zrotation", "90 90", (0.0, 1.0, 0.0))
    pos, _ = clip.forward_kinematics()
    np.testing.assert_allclose(pos[0, 1], [-1, 0, 0], atol=1e-12)


def test_zrotation_90_turns_x_to_y_and_position_channels_replace_offset():
    clip = one_joint_motion("Yposition Zrotation", "5 90")
    pos, rot = clip.forward_kinematics()
    np.testing.assert_allclose(pos[0, 0], [0, 5, 0])
    np.testing.assert_allclose(pos[0, 1], [0, 6, 0], atol=1e-12)
    np.testing.assert_allclose(rot[0, 0], [np.sqrt(0.5), 0, 0, np.sqrt(0.5)])


def test_layout_variants_parse_identically():
    """CRLF, CR, tabs, irregular indentation, '{' on the JOINT line, 'End Site {',
    lowercase keywords and channel names, a BOM, blank lines: all the same clip."""
    base = parse_bvh_text(TINY)
    variants = [
        TINY.replace("\n", "\r\n"),
        TINY.replace("\n", "\r"),
        "\ufeff" + TINY,
        re.sub(r"^ +", lambda m: "\t" * (len(m.group()) % 3) + " " * (len(m.group()) // 2), TINY, flags=re.M),
        TINY.replace("JOINT Chest\n  {", "JOINT Chest {").replace("End Site\n    {", "End Site {"),
        TINY.replace("Zrotation Xrotation Yrotation", "zrotation XROTATION yRotation"),
        TINY.replace("OFFSET 0 10 0", "offset 0 10 0").replace("Frames: 2", "FRAMES:2"),
        TINY.replace("0.1\n0 0", "0.1\n\n0 0").replace("\n1 2 3", "\n  1   2\t3"),
    ]
    for text in variants:
        clip = parse_bvh_text(text)
        assert clip.joint_names == base.joint_names
        assert clip.joint_channels == base.joint_channels
        np.testing.assert_array_equal(clip.joint_offset, base.joint_offset)
        np.testing.assert_array_equal(clip.joint_end_site, base.joint_end_site)
        np.testing.assert_array_equal(clip.motion, base.motion)


def test_joint_names_with_spaces_and_zero_channel_joints():
    text = TINY.replace("JOINT Chest", "JOINT Upper Chest").replace(
        "    End Site\n    {\n      OFFSET 0 5 0\n    }",
        "    JOINT Neck Tip\n    {\n      OFFSET 0 5 0\n      CHANNELS 0\n    }")
    clip = parse_bvh_text(text)
    assert clip.joint_names == ("Hips", "Upper Chest", "Neck Tip")
    assert clip.joint_channel_num.tolist() == [6, 3, 0]
    pos, _ = clip.forward_kinematics([0])
    np.testing.assert_allclose(pos[0, 2], [0, 15, 0])


def test_frame_count_disagreeing_with_header_warns_and_uses_the_data():
    for declared in (1, 3):
        text = TINY.replace("Frames: 2", f"Frames: {declared}")
        with pytest.warns(BvhWarning, match=rf"x.bvh: header declares {declared} frames but the file has 2"):
            clip = parse_bvh_text(text, "x.bvh")
        assert clip.nframe == 2 and clip.declared_frames == declared


# -- forward kinematics against a slow reference -----------------------------------------


def _axis_matrix(axis: str, degrees: float) -> np.ndarray:
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    if axis == "X":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "Y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def slow_fk(clip: BvhClip, frame: int):
    """Per joint 4x4 matrices: T(offset, position channels replacing) @ R(c1) @ R(c2) @ R(c3)."""
    world = []
    for j in range(clip.njoint):
        local = np.eye(4)
        local[:3, 3] = clip.joint_offset[j]
        rot = np.eye(3)
        adr = clip.joint_channel_adr[j]
        for k, c in enumerate(clip.joint_channels[j]):
            v = clip.motion[frame, adr + k]
            if c.endswith("position"):
                local[:3, 3]["XYZ".index(c[0])] = v
            else:
                rot = rot @ _axis_matrix(c[0], v)
        local[:3, :3] = rot
        p = clip.joint_parent[j]
        world.append(local if p < 0 else world[p] @ local)
    return np.array([m[:3, 3] for m in world]), np.array([m[:3, :3] for m in world])


@pytest.fixture(scope="module")
def clips():
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", BvhWarning)
        for f in FILES:
            out[os.path.basename(f)] = load_bvh(f)
    return out


def test_fk_matches_slow_matrix_reference(clips):
    rng = np.random.default_rng(7)
    cases = list(clips.values())
    # A made-up clip with mixed orders, a 2-channel root and a 6-channel inner joint.
    text = """HIERARCHY
ROOT R
{
 OFFSET 1 2 3
 CHANNELS 2 Yrotation Zposition
 JOINT A
 {
  OFFSET 0 4 0
  CHANNELS 3 Xrotation Yrotation Zrotation
  JOINT B
  {
   OFFSET 2 0 1
   CHANNELS 6 Yrotation Xposition Zrotation Yposition Xrotation Zposition
   End Site
   {
    OFFSET 0 0 1
   }
  }
 }
 JOINT C
 {
  OFFSET -1 0 0
  CHANNELS 3 Yrotation Xrotation Zrotation
 }
}
MOTION
Frames: 3
Frame Time: 0.5
"""
    motion = rng.uniform(-180, 180, (3, 14))
    text += "\n".join(" ".join(repr(float(v)) for v in row) for row in motion) + "\n"
    cases.append(parse_bvh_text(text))
    for clip in cases:
        frames = sorted(set(rng.integers(0, clip.nframe, 3).tolist()))
        pos, rot = clip.forward_kinematics(frames)
        for k, f in enumerate(frames):
            ref_pos, ref_rot = slow_fk(clip, f)
            np.testing.assert_allclose(pos[k], ref_pos, atol=1e-9 * (1 + np.abs(ref_pos).max()))
            for j in range(clip.njoint):
                np.testing.assert_allclose(_quat_matrix(rot[k, j]), ref_rot[j], atol=1e-9)


def test_fk_preserves_bone_lengths_over_whole_clip(clips):
    clip = clips["cmu_05_06_dance_pirouettes.bvh"]
    pos, rot = clip.forward_kinematics()
    assert pos.shape == (clip.nframe, clip.njoint, 3) and rot.shape == (clip.nframe, clip.njoint, 4)
    child = np.arange(1, clip.njoint)
    lengths = np.linalg.norm(pos[:, child] - pos[:, clip.joint_parent[child]], axis=2)
    np.testing.assert_allclose(lengths, np.broadcast_to(np.linalg.norm(clip.joint_offset[child], axis=1),
                                                        lengths.shape), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(rot, axis=2), 1.0, atol=1e-12)


# -- the real captures -------------------------------------------------------------------

# From the shared data's SOURCES.md: joints, end sites, channels, frames in the file, frame time.
EXPECTED = {
    "boxing_toes_punch_hit_fall.bvh": (21, 5, 66, 3070, 0.01),
    "cmu_01_01_playground_forward_jumps.bvh": (31, 7, 96, 2752, 0.0083333),
    "cmu_02_01_walk.bvh": (31, 7, 96, 343, 0.008333),
    "cmu_05_06_dance_pirouettes.bvh": (31, 7, 96, 885, 0.008333),
    "cmu_102_01_basketball_wide_turn_3dsmax.bvh": (31, 7, 96, 277, 0.0083333),
    "cmu_131_01_start_walk_stop_3dsmax.bvh": (31, 7, 96, 994, 0.0083333),
    "cmu_131_02_start_walk_stop_3dsmax.bvh": (31, 7, 96, 1247, 0.0083333),
    "cmu_131_03_start_hop_stop_3dsmax.bvh": (31, 7, 96, 1102, 0.0083333),
}


def test_every_capture_parses_with_documented_counts(clips):
    assert sorted(clips) == sorted(EXPECTED)
    for name, clip in clips.items():
        nj, nend, nchan, nframe, ft = EXPECTED[name]
        assert (clip.njoint, clip.nend_site, clip.nchannel, clip.nframe) == (nj, nend, nchan, nframe), name
        assert clip.frame_time == pytest.approx(ft)
        assert clip.joint_names[0] == "Hips" and clip.joint_channel_num[0] == 6
        orders = {"".join(c[0] for c in ch if c.endswith("rotation")) for ch in clip.joint_channels}
        expected_orders = {"ZXY"} if name.startswith("boxing") else (
            {"ZXY", "ZYX"} if "3dsmax" in name else {"ZYX"})
        assert orders == expected_orders, name


def test_boxing_declares_one_frame_fewer_than_it_has():
    path = os.path.join(MOCAP, "boxing_toes_punch_hit_fall.bvh")
    start = time.perf_counter()
    with pytest.warns(BvhWarning, match="declares 3069 frames but the file has 3070") as record:
        clip = load_bvh(path)
    elapsed = time.perf_counter() - start
    assert "boxing_toes_punch_hit_fall.bvh" in str(record[0].message)
    assert clip.nframe == 3070 and clip.declared_frames == 3069
    assert elapsed < 1.0, f"parsing the 2.6 MB boxing file took {elapsed:.2f} s"


def test_crlf_capture_parses_like_its_lf_text():
    path = os.path.join(MOCAP, "cmu_131_01_start_walk_stop_3dsmax.bvh")
    raw = open(path, "rb").read()
    assert b"\r\n" in raw
    lf = parse_bvh_text(raw.decode().replace("\r\n", "\n"))
    crlf = load_bvh(path)
    assert crlf.joint_names == lf.joint_names and crlf.joint_channels == lf.joint_channels
    np.testing.assert_array_equal(crlf.joint_offset, lf.joint_offset)
    np.testing.assert_array_equal(crlf.motion, lf.motion)
    assert crlf.joint_line.tolist() == lf.joint_line.tolist()


# -- axes and units ----------------------------------------------------------------------


def test_axis_map_is_a_proper_rotation_and_quaternions_follow_it():
    assert np.linalg.det(AXIS_MAP) == pytest.approx(1.0)
    np.testing.assert_allclose(AXIS_MAP @ AXIS_MAP.T, np.eye(3))
    # BVH facing +Z -> Menagerie +X forward; BVH +X (the actor's left) -> +Y left; Y up -> Z up.
    np.testing.assert_array_equal(to_menagerie_axes([0, 0, 1]), [1, 0, 0])
    np.testing.assert_array_equal(to_menagerie_axes([1, 0, 0]), [0, 1, 0])
    np.testing.assert_array_equal(to_menagerie_axes([0, 1, 0]), [0, 0, 1])
    rng = np.random.default_rng(3)
    v = rng.normal(size=(50, 3))
    np.testing.assert_allclose(to_menagerie_axes(v, 2.0), 2.0 * v @ AXIS_MAP.T)
    q = rng.normal(size=(50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    # Rotating then converting equals converting then rotating with the converted rotation.
    np.testing.assert_allclose(to_menagerie_axes(quat_rotate(q, v)),
                               quat_rotate(quat_to_menagerie_axes(q), to_menagerie_axes(v)), atol=1e-12)


def test_auto_scale_picks_the_file_unit(clips):
    assert auto_scale(clips["boxing_toes_punch_hit_fall.bvh"]) == (0.01, "centimetres")
    for name, clip in clips.items():
        if name.startswith("cmu"):
            assert auto_scale(clip) == (UNIT_SCALES["cmu-asf-units"], "cmu-asf-units"), name


def test_jump_flight_confirms_the_cmu_unit(clips):
    """Gravity measured in the captured flight phases of the forward jumps, in file units,
    gives metres per unit: it must agree with the unit auto_scale picks."""
    clip = clips["cmu_01_01_playground_forward_jumps.bvh"]
    pos, _ = clip.forward_kinematics()
    feet = [clip.joint(n) for n in ("LeftToeBase", "RightToeBase", "LeftFoot", "RightFoot")]
    lowest = pos[:, feet, 1].min(axis=1)
    airborne = lowest > np.percentile(lowest, 5) + 1.0
    t = np.arange(clip.nframe) * clip.frame_time
    edges = np.flatnonzero(np.diff(airborne.astype(int)))
    units = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if airborne[a + 1] and b - a > 20:
            seg = slice(a + 6, b - 4)  # trim take-off and landing
            g = -2.0 * np.polyfit(t[seg], pos[seg, 0, 1], 2)[0]
            units.append(9.81 / g)
    assert len(units) >= 6
    scale, _ = auto_scale(clip)
    assert np.median(units) == pytest.approx(scale, rel=0.05)


def test_walk_looks_like_a_walk(clips):
    """CMU 02_01 in Menagerie axes: walks forward along +X, left foot on +Y, upright, and
    the stance foot does not slide (a wrong Euler order makes it skate 3-5x faster)."""
    clip = clips["cmu_02_01_walk.bvh"]
    scale, _ = auto_scale(clip)
    pos, _ = clip.forward_kinematics()
    pos = to_menagerie_axes(pos, scale)
    travel = pos[-1, 0] - pos[0, 0]
    assert travel[0] > 2.5 and abs(travel[1]) < 0.3
    left, right = clip.joint("LeftToeBase"), clip.joint("RightToeBase")
    hip_l, hip_r = clip.joint("LeftUpLeg"), clip.joint("RightUpLeg")
    assert np.all(pos[:, hip_l, 1] - pos[:, hip_r, 1] > 0.1)  # heading is +X, so left is +Y
    assert np.mean(pos[:, left, 1] - pos[:, right, 1]) > 0.05  # (the feet cross now and then)
    head, hips = clip.joint("Head"), 0
    assert np.all(pos[:, head, 2] > pos[:, hips, 2] + 0.3)
    assert np.all(pos[:, hips, 2] > pos[:, [left, right], 2].max(axis=1) + 0.5)
    for toe in (left, right):
        z = pos[:, toe, 2]
        stance = z[1:] < np.percentile(z, 2) + 0.02
        speed = np.linalg.norm(np.diff(pos[:, toe, :2], axis=0), axis=1) / clip.frame_time
        assert stance.mean() > 0.05
        assert np.median(speed[stance]) < 0.12


# -- writing -----------------------------------------------------------------------------


def test_save_load_round_trip_every_capture(clips, tmp_path):
    for name, clip in clips.items():
        out = tmp_path / name
        save_bvh(clip, out)
        back = load_bvh(out)
        assert back.joint_names == clip.joint_names and back.joint_channels == clip.joint_channels
        assert back.joint_parent.tolist() == clip.joint_parent.tolist()
        np.testing.assert_allclose(back.joint_offset, clip.joint_offset, atol=1e-6)
        np.testing.assert_allclose(back.joint_end_site, clip.joint_end_site, atol=1e-6)
        np.testing.assert_allclose(back.motion, clip.motion, atol=1e-6)
        assert back.frame_time == clip.frame_time and back.declared_frames == clip.nframe


def test_save_exact_with_repr_and_refuses_to_overwrite(tmp_path):
    clip = parse_bvh_text(TINY.replace("1 2 3 4 5 6 7 8 9", "0.1 0.2 0.3 -1e-7 5.123456789 6 7 8 9"))
    out = tmp_path / "t.bvh"
    save_bvh(clip, out, precision=None)
    back = load_bvh(out)
    np.testing.assert_array_equal(back.motion, clip.motion)
    with pytest.raises(FileExistsError):
        save_bvh(clip, out)
    save_bvh(clip, out, overwrite=True)
    assert "-0.000000" not in bvh_text(clip)


def test_clip_built_in_code_is_validated_and_written_depth_first():
    clip = BvhClip(joint_names=("r", "a", "b", "a1"), joint_parent=np.array([-1, 0, 0, 1]),
                   joint_offset=np.ones((4, 3)), joint_channels=(("Zrotation",), (), ("Xrotation",), ()),
                   joint_end_site=np.full((4, 3), np.nan), frame_time=0.5, motion=np.array([[10.0, 20.0]]))
    back = parse_bvh_text(bvh_text(clip))
    assert back.joint_names == ("r", "a", "a1", "b")
    np.testing.assert_array_equal(back.motion, [[10.0, 20.0]])
    for bad in (dict(joint_parent=np.array([-1, 0, 3, 1])), dict(motion=np.zeros((1, 3))),
                dict(frame_time=0.0), dict(joint_channels=(("Wrotation",), (), ("Xrotation",), ()))):
        kwargs = dict(joint_names=clip.joint_names, joint_parent=clip.joint_parent,
                      joint_offset=clip.joint_offset, joint_channels=clip.joint_channels,
                      joint_end_site=clip.joint_end_site, frame_time=0.5, motion=clip.motion)
        kwargs.update(bad)
        with pytest.raises(BvhError):
            BvhClip(**kwargs)


# -- creatures ---------------------------------------------------------------------------


def _sided(name: str) -> int:
    """+1 for the actor's left, -1 for the right, 0 unsided, from the joint name."""
    if re.match(r"Left|L[A-Z]|l[a-z]", name) and not name.lower().startswith("lower"):
        return 1
    if re.match(r"Right|R[A-Z]|r[a-z]", name):
        return -1
    return 0


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_creature_from_every_capture(clips, name):
    clip = clips[name]
    cdef = creature_def_from_bvh(clip)
    creature = build_creature(cdef)
    assert creature.nbody == clip.njoint
    assert creature.name == os.path.splitext(name)[0]
    assert creature.body_names[0] == "Hips"                       # root: the pelvis
    assert creature.nleg == 2
    assert creature.counts()["arms"] == 2
    assert creature.counts()["heads"] == 1
    # The spine is one serial chain, walked parent to child, from Hips to Head.
    chain = [creature.body_names[i] for i in creature.spine_chain]
    assert chain[0] == "Hips" and chain[-1] == "Head"
    for a, b in zip(creature.spine_chain[:-1], creature.spine_chain[1:], strict=True):
        assert creature.body_parent[b] == a
    # Stands on the ground at a human height (CMU actors measure 1.37-1.50 m in their
    # own unit, which the jump test confirms against gravity).
    assert creature.bounds[0, 2] == pytest.approx(0.0, abs=1e-12)
    assert 1.3 < creature.size[2] < 2.0
    assert np.abs(np.array(cdef.bodies[0].joint[:2])).max() < 1e-12  # root joint above the origin
    # Left is +Y: the axis map does not mirror.
    for i, body in enumerate(creature.body_names):
        s = _sided(body)
        if s:
            assert np.sign(creature.body_rest_pos[i, 1]) == s, body
            assert creature.body_side[i] == s, body
    assert np.all(creature.body_extent >= MIN_HALF_EXTENT - 1e-15)
    # Feet are the ankle joints, graspers the first hand joint.
    feet = sorted(creature.body_names[i] for i in creature.leg_foot)
    assert feet in (["LeftAnkle", "RightAnkle"], ["LeftFoot", "RightFoot"])


def test_boxes_follow_bones_by_hand():
    # Hips -> Knee 4 units down, Knee -> End Site 3 units forward (BVH +Z), centimetres.
    text = """HIERARCHY
ROOT Hips
{
 OFFSET 0 100 0
 CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
 JOINT Neck
 {
  OFFSET 0 10 0
  CHANNELS 3 Zrotation Xrotation Yrotation
  JOINT Head
  {
   OFFSET 0 10 0
   CHANNELS 3 Zrotation Xrotation Yrotation
   End Site
   {
    OFFSET 0 0 0
   }
  }
 }
 JOINT LeftKnee
 {
  OFFSET 10 -40 0
  CHANNELS 3 Zrotation Xrotation Yrotation
  JOINT LeftAnkle
  {
   OFFSET 0 -40 0
   CHANNELS 3 Zrotation Xrotation Yrotation
   End Site
   {
    OFFSET 0 0 20
   }
  }
 }
}
MOTION
Frames: 1
Frame Time: 0.1
0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
"""
    cdef = creature_def_from_bvh(parse_bvh_text(text), scale=0.01, name="hand")
    body = {b.name: b for b in cdef.bodies}
    assert cdef.name == "hand"
    ankle = body["LeftAnkle"]
    # The foot bone runs 0.2 m forward (+X) from the ankle: identity rotation, centre 0.1
    # ahead, half-length 0.1, half-thickness max(0.15 * 0.2, floor) = 0.03; it is the
    # lowest box, so the ankle stands 0.03 above the ground.
    np.testing.assert_allclose(ankle.rot, [1, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(ankle.extents, [0.1, 0.03, 0.03])
    np.testing.assert_allclose(ankle.joint, [0.0, 0.1, 0.03], atol=1e-12)
    np.testing.assert_allclose(ankle.pos, [0.1, 0.1, 0.03], atol=1e-12)
    # The knee bone points straight down (-Z): X turned onto -Z by a quarter turn about +Y.
    knee = body["LeftKnee"]
    np.testing.assert_allclose(knee.rot, [np.sqrt(0.5), 0, np.sqrt(0.5), 0], atol=1e-12)
    np.testing.assert_allclose(knee.extents, [0.2, 0.06, 0.06])
    np.testing.assert_allclose(knee.pos, [0.0, 0.1, 0.03 + 0.2], atol=1e-12)
    # Head: a zero-length End Site continues the neck bone (0.1 m up) for another 0.1 m.
    head = body["Head"]
    np.testing.assert_allclose(head.extents[0], 0.05)
    np.testing.assert_allclose(np.array(head.pos) - np.array(head.joint), [0, 0, 0.05], atol=1e-12)
    # The root: an axis-aligned box around the hips joint and its targets (neck and knee).
    hips = body["Hips"]
    np.testing.assert_allclose(hips.rot, [1, 0, 0, 0])
    h = THICKNESS_FRACTION * np.hypot(0.1, 0.4)  # the longest joint-to-target distance
    np.testing.assert_allclose(hips.extents, [h, h, 0.25])
    np.testing.assert_allclose(hips.pos, [0.0, 0.05, 0.85 - 0.17], atol=1e-12)
    caps = {b.name: b.caps for b in cdef.bodies}
    assert caps == {"Hips": ["spine"], "Neck": ["spine"], "Head": ["spine", "head", "mouth"],
                    "LeftKnee": ["limb"], "LeftAnkle": ["limb", "foot"]}


def test_caps_rules_for_unknown_names_and_custom_tables(tmp_path):
    text = """HIERARCHY
ROOT base
{
 OFFSET 0 0 0
 CHANNELS 3 Xposition Yposition Zposition
 JOINT mid
 {
  OFFSET 0 10 0
  CHANNELS 0
  JOINT Chest
  {
   OFFSET 0 10 0
   CHANNELS 0
   JOINT gizmo
   {
    OFFSET 5 0 0
    CHANNELS 0
   }
  }
 }
 JOINT paw_l
 {
  OFFSET 5 -10 0
  CHANNELS 0
 }
}
MOTION
Frames: 1
Frame Time: 1
0 0 0
"""
    clip = parse_bvh_text(text)
    # 'base' and 'mid' link up to the spine joint 'Chest', so they join the spine;
    # 'gizmo' and 'paw_l' are unknown limbs.
    assert joint_caps(clip) == [["spine"], ["spine"], ["spine"], ["limb"], ["limb"]]
    table = {"paw.*": ["foot"], "gizmo": "detail"}
    assert joint_caps(clip, table)[3:] == [["detail"], ["foot"]]
    yaml_path = tmp_path / "caps.yaml"
    yaml_path.write_text("# my rig\npaw.*: [foot]\ngizmo: detail\n")
    assert load_caps_table(yaml_path) == {"paw.*": ["foot"], "gizmo": ["detail"]}
    creature = creature_from_bvh(clip, caps_table=load_caps_table(yaml_path), scale=0.1)
    assert creature.nleg == 1
    # A table that makes the spine branch fails in the builder, naming the BVH file and
    # the line of the joint where it branches.
    walk = os.path.join(MOCAP, "cmu_02_01_walk.bvh")
    with pytest.raises(CreatureError) as info:
        creature_def_from_bvh(walk, caps_table={"[LR]HipJoint": ["spine"]})
    assert info.value.path == walk and info.value.line == 2 and info.value.subject == "Hips"
    assert "serial chain" in str(info.value)


CAPS_FILES_INVALID = [
    ("paw: [foot]\n'(': [limb]\n", 2, "bad regular expression"),
    ("paw: [foot]\ngizmo: [claw]\n", 2, "unknown capability 'claw'"),
    ("paw: [foot]\ngizmo: 3\n", 2, "capabilities must be a list"),
    ("- paw\n- foot\n", 1, "must be a mapping"),
    ("paw: [foot\n", 2, "YAML syntax error"),
]


@pytest.mark.parametrize("text,line,words", CAPS_FILES_INVALID)
def test_invalid_caps_files(tmp_path, text, line, words):
    path = tmp_path / "caps.yaml"
    path.write_text(text)
    with pytest.raises(CapsTableError) as info:
        load_caps_table(path)
    assert info.value.line == line and words in str(info.value), str(info.value)
    assert str(path) in str(info.value)


def test_scale_argument_and_defaults(clips):
    clip = clips["cmu_02_01_walk.bvh"]
    auto = creature_from_bvh(clip)
    double = creature_from_bvh(clip, scale=2 * UNIT_SCALES["cmu-asf-units"])
    assert double.size[2] == pytest.approx(2 * auto.size[2])
    with pytest.raises(Exception, match="scale must be a positive number"):
        creature_def_from_bvh(clip, scale=-1.0)
    # The caps are as documented for the MotionBuilder-friendly naming.
    caps = dict(zip(clip.joint_names, joint_caps(clip), strict=True))
    assert caps["LHipJoint"] == ["limb"] and caps["LeftToeBase"] == ["detail"]
    assert caps["LeftHand"] == ["limb", "grasper"] and caps["LThumb"] == ["detail"]
    assert caps["LeftHandIndex1"] == ["detail"] and caps["LeftFingerBase"] == ["detail"]
    assert caps["Neck1"] == ["spine"] and caps["Head"] == ["spine", "head", "mouth"]
    c = creature_from_bvh(clip)
    assert c.body_caps[c.body("Head")] & CAP_BIT["mouth"]


def test_creature_def_writes_and_loads(clips, tmp_path):
    from engine.model import load_creature, write_creature_def

    cdef = creature_def_from_bvh(os.path.join(MOCAP, "cmu_102_01_basketball_wide_turn_3dsmax.bvh"))
    out = tmp_path / "basketball.yaml"
    write_creature_def(cdef, out)
    creature = load_creature(out)
    assert creature.nleg == 2 and creature.nbody == 31
    assert "cmu-asf-units" in creature.description


def _qconj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def test_body_poses_move_rigidly_with_their_joints(clips):
    clip = clips["cmu_131_03_start_hop_stop_3dsmax.bvh"]
    scale, _ = auto_scale(clip)
    frames = np.arange(0, clip.nframe, 97)
    body_pos, body_rot = bvh_body_poses(clip, frames=frames)
    cdef = creature_def_from_bvh(clip)
    centre = np.array([b.pos for b in cdef.bodies])
    box_rot = np.array([b.rot for b in cdef.bodies])
    joint = np.array([b.joint for b in cdef.bodies])
    joint_pos, _ = clip.forward_kinematics(frames)
    joint_pos = to_menagerie_axes(joint_pos, scale)
    # Each body's joint point, carried by the body, lands on the captured joint...
    own = quat_rotate(_qconj(box_rot), joint - centre)
    np.testing.assert_allclose(body_pos + quat_rotate(body_rot, own), joint_pos, atol=1e-9)
    # ...and on the same point carried by its parent body: the bodies stay connected.
    child = np.arange(1, clip.njoint)
    parent = clip.joint_parent[child]
    in_parent = quat_rotate(_qconj(box_rot[parent]), joint[child] - centre[parent])
    np.testing.assert_allclose(body_pos[:, parent] + quat_rotate(body_rot[:, parent], in_parent),
                               joint_pos[:, child], atol=1e-9)


def test_body_poses_at_the_offset_pose_are_the_rest_boxes():
    clip = parse_bvh_text(TINY.replace("1 2 3 4 5 6 7 8 9", "0 50 0 0 0 0 0 0 0"))
    body_pos, body_rot = bvh_body_poses(clip, scale=0.01, frames=[1])
    cdef = creature_def_from_bvh(clip, scale=0.01)
    rest = np.array([b.pos for b in cdef.bodies])
    lift = body_pos[0, 0, 2] - rest[0, 2]
    np.testing.assert_allclose(body_pos[0], rest + [0, 0, lift], atol=1e-12)
    np.testing.assert_allclose(body_rot[0], [b.rot for b in cdef.bodies], atol=1e-12)


def test_a_jaw_takes_the_mouth_from_the_head():
    text = TINY.replace("    End Site\n    {\n      OFFSET 0 5 0\n    }",
                        "    JOINT Head\n    {\n      OFFSET 0 5 0\n      CHANNELS 0\n"
                        "      JOINT Jaw\n      {\n        OFFSET 0 0 2\n        CHANNELS 0\n      }\n    }")
    clip = parse_bvh_text(text)
    caps = dict(zip(clip.joint_names, joint_caps(clip), strict=True))
    assert caps["Head"] == ["spine", "head"] and caps["Jaw"] == ["mouth"]


@st.composite
def random_clips(draw):
    """Random skeletons: any tree, 0-6 channels per joint in any order, End Sites anywhere."""
    nj = draw(st.integers(1, 7))
    parent = [-1] + [draw(st.integers(0, j - 1)) for j in range(1, nj)]
    # Depth-first order with children in index order (the order a file has).
    kids = [[c for c in range(nj) if parent[c] == j] for j in range(nj)]
    order, stack = [], [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(kids[j]))
    new = {old: k for k, old in enumerate(order)}
    parent = [-1] + [new[parent[o]] for o in order[1:]]
    finite = st.floats(-100, 100, allow_nan=False)
    channels = tuple(tuple(draw(st.permutations(list(CHANNEL_NAMES_ALL)))[:draw(st.sampled_from([0, 1, 3, 6]))])
                     for _ in range(nj))
    nframe = draw(st.integers(0, 3))
    nchan = sum(len(c) for c in channels)
    motion = np.array(draw(st.lists(finite, min_size=nframe * nchan, max_size=nframe * nchan))).reshape(nframe, nchan)
    offset = np.array(draw(st.lists(finite, min_size=3 * nj, max_size=3 * nj))).reshape(nj, 3)
    end = np.array([draw(st.one_of(st.just((np.nan,) * 3), st.tuples(finite, finite, finite))) for _ in range(nj)])
    names = tuple(f"j{k} {draw(st.sampled_from(['', 'x', 'Left']))}".strip() for k in range(nj))
    return BvhClip(joint_names=names, joint_parent=np.array(parent), joint_offset=offset, joint_channels=channels,
                   joint_end_site=end, frame_time=draw(st.floats(1e-3, 1.0)), motion=motion)


CHANNEL_NAMES_ALL = ("Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation")


@settings(max_examples=60, deadline=None)
@given(random_clips())
def test_random_clips_round_trip_exactly_and_match_the_reference(clip):
    back = parse_bvh_text(bvh_text(clip, precision=None))
    assert back.joint_names == clip.joint_names and back.joint_channels == clip.joint_channels
    assert back.joint_parent.tolist() == clip.joint_parent.tolist()
    np.testing.assert_array_equal(back.joint_offset, clip.joint_offset)
    np.testing.assert_array_equal(back.joint_end_site, clip.joint_end_site)
    np.testing.assert_array_equal(back.motion, clip.motion)
    assert back.frame_time == clip.frame_time
    if clip.nframe:
        pos, rot = clip.forward_kinematics([clip.nframe - 1])
        ref_pos, ref_rot = slow_fk(clip, clip.nframe - 1)
        np.testing.assert_allclose(pos[0], ref_pos, atol=1e-9 * (1 + np.abs(ref_pos).max()))
        for j in range(clip.njoint):
            np.testing.assert_allclose(_quat_matrix(rot[0, j]), ref_rot[j], atol=1e-9)
    # Every random skeleton also makes a valid creature.
    creature = creature_from_bvh(clip, scale=0.01)
    assert creature.nbody == clip.njoint and creature.bounds[0, 2] == pytest.approx(0.0, abs=1e-12)
    assert np.all(creature.body_extent > 0)
