"""Animated glTF export checked by real clients: the Khronos validator reports 0 errors, three.js
in headless Chromium poses the export like our runtime did (within 1 mm per body), and our
own importer reads the creature back."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import engine
from engine.io.gltf_export import (
    _joint_frames,
    _to_gltf_quat,
    _to_gltf_vec,
    gltf_document,
    record_clip,
    reduce_keys,
    safe_names,
    save_gltf,
)

sys.path.insert(0, os.path.dirname(__file__))
import gltf_clients as clients  # noqa: E402

HERE = os.path.dirname(__file__)
ROOT = os.path.join(HERE, "..")
RIGS = os.path.join(ROOT, "..", "shared", "data", "rigs")


def _creature(name):
    return engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))


def _anim(name):
    return engine.load_animation(os.path.join(ROOT, "animations", f"{name}.yaml"))


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    out = tmp_path_factory.mktemp("exports")
    files = {}
    for cname, aname in (("humanoid", "wave"), ("spider", "wave"), ("snake", "tail_wag")):
        c = _creature(cname)
        rec = record_clip(c, _anim(aname), fps=30)
        files[cname] = (c, rec, save_gltf(c, [rec], out / f"{cname}.glb"))
    from engine.io.gltf import creature_from_gltf

    horse = creature_from_gltf(os.path.join(RIGS, "quaternius_horse.glb"))
    rec = record_clip(horse, _anim("tail_wag"), fps=30)
    files["horse"] = (horse, rec, save_gltf(horse, [rec], out / "horse.glb"))
    files["horse_mesh"] = (horse, rec, save_gltf(horse, [rec], out / "horse_mesh.glb", mesh=_rig_mesh("quaternius_horse")))
    return files


def _rig_mesh(name):
    from engine.io.gltf import import_gltf

    return import_gltf(os.path.join(RIGS, f"{name}.glb"), mesh=True).mesh


@pytest.mark.skipif(not clients.validator_available(), reason="npm gltf-validator not installed (setup.sh dev)")
@pytest.mark.parametrize("name", ["humanoid", "spider", "snake", "horse", "horse_mesh"])
def test_validator_reports_no_errors(exports, name):
    report = clients.validate(exports[name][2])
    issues = report["issues"]
    assert issues["numErrors"] == 0, issues["messages"][:5]
    assert issues["numWarnings"] == 0, issues["messages"][:5]
    assert report["info"]["animationCount"] == 1


@pytest.mark.skipif(not clients.three_available(), reason="chromium or npm three not installed (setup.sh dev)")
def test_three_js_poses_match_ours(exports):
    c, rec, path = exports["humanoid"]
    frames = [0, 7, 22, 45, len(rec.times) - 1]
    got = clients.three_pose(path, [float(rec.times[k]) for k in frames])
    assert got["names"] == safe_names(c.body_names)
    assert got["duration"] == pytest.approx(float(rec.times[-1]), abs=1e-6)
    for f, k in zip(got["frames"], frames, strict=True):
        ours = _to_gltf_vec(_joint_frames(c, rec.body_pos[k], rec.body_rot[k]))
        np.testing.assert_allclose(np.array(f["pos"]), ours, atol=1e-3)  # 1 mm per body
        dot = np.abs(np.sum(np.array(f["rot"]) * _to_gltf_quat(rec.body_rot[k]), axis=1))
        assert np.all(dot > 1 - 1e-6)  # a quaternion order mistake shows here, not in the validator


def test_export_reimports_as_the_same_creature(exports):
    from engine.io.gltf import import_gltf

    c, _, path = exports["spider"]
    back = engine.model.build_creature(import_gltf(path, rest="file").cdef)
    assert back.body_names == c.body_names
    assert back.counts() == c.counts()
    np.testing.assert_allclose(back.body_joint, c.body_joint, atol=2e-6)
    np.testing.assert_allclose(back.body_rest_pos, c.body_rest_pos, atol=2e-6)
    np.testing.assert_allclose(back.body_extent, c.body_extent, atol=2e-6)
    dots = np.abs(np.sum(back.body_rest_rot * c.body_rest_rot, axis=1))
    assert np.all(dots > 1 - 1e-9)


def test_loops_close_and_keys_are_every_body(exports):
    c, rec, path = exports["humanoid"]
    assert rec.loop
    np.testing.assert_array_equal(rec.body_pos[0], rec.body_pos[-1])
    doc, _ = gltf_document(c, [rec])
    targets = {(ch["target"]["node"], ch["target"]["path"]) for ch in doc["animations"][0]["channels"]}
    assert targets == {(i, p) for i in range(c.nbody) for p in ("rotation", "translation")}
    assert doc["animations"][0]["extras"]["loop"] is True


def _file_skinned(path, t=None):
    """Vertices (Menagerie axes) of an export's first mesh, skinned by its own nodes: at
    their rest TRS, or with the first animation sampled at ``t``."""
    from engine.io.gltf import (
        GLTF_TO_MENAGERIE,
        _sample_channel,
        load_gltf,
        node_local_matrix,
        node_parents,
        read_accessor,
        world_matrices,
    )

    gf = load_gltf(path)
    doc = gf.doc
    local = None
    if t is not None:
        trs = {}
        anim = doc.animations[0]
        for ch in anim.channels:
            v = _sample_channel(gf, anim.samplers[ch.sampler], np.array([t]), ch.target.path, 0)[0]
            trs.setdefault(ch.target.node, {})[ch.target.path] = v
        local = []
        for i, node in enumerate(doc.nodes):
            x = trs.get(i, {})
            local.append(node_local_matrix(gf, i, trs=(x.get("translation", node.translation),
                                                       x.get("rotation", node.rotation), node.scale))
                         if x else node_local_matrix(gf, i))
    world = world_matrices(gf, node_parents(gf), local)
    skin = doc.skins[0]
    ibm = read_accessor(gf, skin.inverseBindMatrices)
    m = np.array([world[j] @ ibm[k] for k, j in enumerate(skin.joints)])
    attrs = doc.meshes[0].primitives[0].attributes
    pos = read_accessor(gf, attrs.POSITION)
    jj = read_accessor(gf, attrs.JOINTS_0).astype(np.int64)
    ww = read_accessor(gf, attrs.WEIGHTS_0)
    skinned = np.einsum("vab,vb->va", np.einsum("vk,vkab->vab", ww, m[jj]), np.c_[pos, np.ones(len(pos))])
    return skinned[:, :3] @ GLTF_TO_MENAGERIE.T, doc


@pytest.mark.parametrize("rig", ["riggedfigure_khronos", "quaternius_horse"])
def test_a_rigs_own_mesh_follows_the_bodies(tmp_path, rig):
    """A creature made from a glTF rig exports with the rig's mesh: every triangle of the
    file, one primitive per material, and at any frame each vertex where linear blend
    skinning of *our* recorded body poses puts it (the bind pose's inverse matrices and the
    animated nodes agree); at the rest nodes the arms the relaxed rest swung down carry
    their skin with them and the rest of the mesh stays where the file had it."""
    from engine.io.gltf import import_gltf
    from engine.io.gltf_export import _qconj, _qmul, _qrot
    from engine.model.builder import build_creature

    imp = import_gltf(os.path.join(RIGS, f"{rig}.glb"), mesh=True)
    mesh = imp.mesh
    c = build_creature(imp.cdef)
    anim = "wave" if c.counts()["arms"] else "tail_wag"
    rec = record_clip(c, _anim(anim), fps=30)
    path = save_gltf(c, [rec], tmp_path / f"{rig}.glb", mesh=mesh)

    rest, doc = _file_skinned(path)
    assert len(doc.meshes[0].primitives) == len(mesh.primitives) == len({m for _, _, m in mesh.primitives})
    assert len(doc.materials) == len(mesh.materials)
    assert np.allclose(mesh.weights.sum(axis=1), 1.0) and mesh.joints.max() < c.nbody
    moved = np.linalg.norm(imp.rest_delta[:, 1:], axis=1) > 1e-9  # per mesh body (definition order)
    still = ~moved[mesh.joints].any(axis=1)
    assert still.sum() > 0.5 * len(still)
    size = float(np.ptp(mesh.positions, axis=0).max())
    assert np.abs(rest[still] - mesh.positions[still]).max() < 1e-5 * size
    if moved.any():  # a T- or A-pose: the hands came down
        hands = mesh.weights[:, 0] * moved[mesh.joints[:, 0]] > 0.99
        assert (rest[hands, 2] < mesh.positions[hands, 2] - 0.01 * size).mean() > 0.5

    for k in (len(rec.times) // 3, len(rec.times) - 1):
        got, _ = _file_skinned(path, t=float(rec.times[k]))
        # Independent of the file: body b's motion from bind to frame k moves its vertices.
        pos, rot = rec.body_pos[k], rec.body_rot[k]
        perm = np.array([c.body(nm) for nm in mesh.body_names])           # mesh body -> creature body
        pos, rot = pos[perm], rot[perm]
        rel = _qmul(rot, _qconj(mesh.bind_rot))                            # (nb, 4)
        want = np.zeros_like(mesh.positions)
        for slot in range(4):
            b = mesh.joints[:, slot]
            moved_v = pos[b] + _qrot(rel[b], mesh.positions - mesh.bind_pos[b])
            want += mesh.weights[:, slot, None] * moved_v
        assert np.abs(got - want).max() < 1e-4 * size, (rig, k)


def test_bake_writes_a_rigs_own_mesh_or_boxes_on_request(tmp_path):
    from engine.cli import main

    rig = os.path.join(RIGS, "riggedfigure_khronos.glb")
    wave = os.path.join(ROOT, "animations", "wave.yaml")
    assert main(["bake", wave, rig, "--out", str(tmp_path / "own"), "--workers", "0", "--quiet"]) == 0
    assert main(["bake", wave, rig, "--out", str(tmp_path / "box"), "--workers", "0", "--quiet", "--mesh",
                 "boxes"]) == 0
    own, doc_own = _file_skinned(tmp_path / "own" / "riggedfigure_khronos_wave.glb")
    box, doc_box = _file_skinned(tmp_path / "box" / "riggedfigure_khronos_wave.glb")
    assert doc_own.meshes[0].name.endswith("_mesh") and doc_box.meshes[0].name.endswith("_boxes")
    assert len(box) == 24 * len(doc_box.skins[0].joints) and len(own) != len(box)


def test_reduce_keys_against_a_plain_reference():
    t = np.linspace(0, 1, 31)[:, None]
    line = np.hstack([t, 2 * t, 0 * t])
    assert list(reduce_keys(line, rotation=False)) == [0, 30]
    bent = np.vstack([line[:16], line[15] + (line[16:] - line[15]) * [1, -1, 0]])
    keep = reduce_keys(bent, rotation=False)
    assert 15 in keep and len(keep) == 3
    # Every dropped key is reproduced within the tolerance by LINEAR between the kept ones.
    rng = np.random.default_rng(3)
    v = np.cumsum(rng.normal(size=(60, 3)) * 1e-3, axis=0)
    keep = reduce_keys(v, rotation=False, tol=1e-3)
    interp = np.stack([np.interp(np.arange(60), keep, v[keep, d]) for d in range(3)], axis=1)
    assert np.abs(interp - v).max() <= 1e-3 + 1e-12


def test_names_are_safe_and_unique():
    assert safe_names(["Wing1.L", "Wing1 L", "a:b", ""]) == ["Wing1_L", "Wing1_L_2", "a_b", "body"]


def test_refuses_to_overwrite(tmp_path):
    c = _creature("minimal")
    path = tmp_path / "m.glb"
    save_gltf(c, [], path)
    with pytest.raises(FileExistsError):
        save_gltf(c, [], path)
    save_gltf(c, [], path, overwrite=True)


def test_bvh_export_plays_back_our_motion(tmp_path):
    from engine.io.bake import recording_to_bvh
    from engine.io.bvh import load_bvh, save_bvh, to_menagerie_axes

    c = _creature("humanoid")
    rec = record_clip(c, _anim("wave"), fps=30, seconds=1.0)
    path = tmp_path / "wave.bvh"
    save_bvh(recording_to_bvh(c, rec), path)
    clip = load_bvh(path)
    assert clip.joint_names == tuple(safe_names(c.body_names)) and clip.nframe == len(rec.times)
    world_pos, world_rot = clip.forward_kinematics()
    # Rotations: each joint's is its body's rotation from rest, exactly.
    from engine.io.bvh import quat_mul, quat_to_menagerie_axes

    ours = quat_mul(rec.body_rot, np.broadcast_to(c.body_rest_rot * [1, -1, -1, -1], rec.body_rot.shape))
    dot = np.abs(np.sum(quat_to_menagerie_axes(world_rot) * ours, axis=-1))
    assert np.all(dot > 1 - 1e-9)
    # Positions: BVH bones are rigid, so joints land where ours are up to the runtime's own
    # joint gaps (a child's joint seen from the parent body vs from itself), summed down the tree.
    joints = to_menagerie_axes(world_pos, 0.01)
    own = _joint_frames(c, rec.body_pos, rec.body_rot)
    err = np.linalg.norm(joints - own, axis=-1)
    assert err[:, 0].max() < 1e-9  # the root joint exactly
    assert err.max() < 5e-3


def test_bake_command_writes_each_creature_and_reports_failures(tmp_path, capsys):
    from engine.cli import main

    out = tmp_path / "baked"
    args = ["bake", os.path.join(ROOT, "animations", "wave.yaml"), os.path.join(ROOT, "creatures", "humanoid.yaml"),
            os.path.join(ROOT, "creatures", "snake.yaml"), "--out", str(out), "--workers", "0", "--quiet"]
    assert main(args) == 2  # the snake has no graspers: named, the humanoid still baked
    captured = capsys.readouterr()
    assert "snake.yaml" in captured.err and "has_graspers" in captured.err
    assert (out / "humanoid_wave.glb").exists()
    assert main(args[:3] + ["--out", str(out), "--workers", "0", "--quiet"]) == 2  # exists: needs --force
    assert "exists" in capsys.readouterr().err
    assert main(args[:3] + ["--out", str(out), "--workers", "0", "--quiet", "--force", "--format", "bvh",
                            "--variant", "hand_l"]) == 0
    assert (out / "humanoid_wave_hand_l.bvh").exists()


@pytest.mark.skipif(not clients.validator_available(), reason="npm gltf-validator not installed (setup.sh dev)")
def test_bake_on_dask_writes_valid_files(tmp_path):
    pytest.importorskip("distributed")
    from engine.io.bake import bake

    out = tmp_path / "dask"
    files = [os.path.join(ROOT, "creatures", f"{n}.yaml") for n in ("humanoid", "gorilla")]
    results = bake(files, os.path.join(ROOT, "animations", "wave.yaml"), str(out), workers=1, progress=False)
    assert [r.error for r in results] == ["", ""]
    for r in results:
        assert clients.validate(r.paths[0])["issues"]["numErrors"] == 0


def test_reduce_keys_kernel_matches_the_numpy_reference():
    from engine.io.gltf_export import reduce_keys_reference

    rng = np.random.default_rng(7)
    for _ in range(6):
        v = np.cumsum(rng.normal(size=(50, 3)) * 1e-3, axis=0)
        v[10:30] = v[10] + np.linspace(0, 1, 20)[:, None] * (v[29] - v[10])  # a straight run to drop
        assert list(reduce_keys(v, False, 1e-3)) == list(reduce_keys_reference(v, False, 1e-3))
        q = rng.normal(size=(40, 4)) * 0.02 + [1, 0, 0, 0]
        q = np.cumsum(q, axis=0)
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        assert list(reduce_keys(q, True, 1e-3)) == list(reduce_keys_reference(q, True, 1e-3))


def test_motion_round_trip_is_exact_to_float32(tmp_path):
    from engine.io.gltf import gltf_motion

    c = _creature("humanoid")
    rec = record_clip(c, _anim("wave"), fps=30)
    path = save_gltf(c, [rec], tmp_path / "rt.glb", tolerance=0.0)
    m = gltf_motion(path, rest="file")
    np.testing.assert_array_equal(m.times, rec.times)
    np.testing.assert_allclose(m.body_pos, rec.body_pos, atol=1e-6)  # float32 of metres
    assert np.all(np.abs(np.sum(m.body_rot * rec.body_rot, axis=-1)) > 1 - 1e-12)
    # With keys reduced (the default) the motion is within the reduction's tolerance.
    path = save_gltf(c, [rec], tmp_path / "reduced.glb")
    m = gltf_motion(path, rest="file")
    np.testing.assert_allclose(m.body_pos, rec.body_pos, atol=1e-4)


def test_rig_animations_import_as_clips():
    from engine.io.gltf import GltfError, gltf_bvh_clip, gltf_motion, import_gltf

    path = os.path.join(RIGS, "fox_khronos.glb")
    imp = import_gltf(path)
    walk = gltf_motion(path, "Walk", imported=imp)
    assert walk.body_pos.shape[1] == len(imp.cdef.bodies)
    assert walk.times[-1] == pytest.approx(0.708, abs=0.01)
    assert np.all(np.isfinite(walk.body_pos)) and np.all(np.isfinite(walk.body_rot))
    # The feet step: each foot body swings forward and back by a good part of a stride.
    names = [b.name for b in imp.cdef.bodies]
    foot = walk.body_pos[:, names.index("b_LeftFoot02_018")]
    assert np.ptp(foot[:, 0]) > 0.2
    # The first key of the survey clip is near the rest pose: the bodies stay connected.
    creature, clip = gltf_bvh_clip(path, "Run", fps=30)
    assert clip.njoint == creature.nbody and clip.nframe >= 30
    with pytest.raises(GltfError, match="no animation named 'Swim'"):
        gltf_motion(path, "Swim", imported=imp)


def test_a_live_session_records_and_exports(tmp_path):
    from engine.io.gltf import gltf_motion
    from engine.io.gltf_export import SessionRecorder

    c = _creature("humanoid")
    char = engine.Character(c)
    char.play(_anim("wave"))
    rec = SessionRecorder(char, fps=30)
    char.tick(1e-6)
    rec.capture()
    steps = [1 / 60, 1 / 45, 1 / 90] * 20  # uneven game frames
    for dt in steps:
        char.tick(dt)
        rec.capture(dt)
    r = rec.recording("session")
    assert r.body_pos.shape == (int(np.floor(sum(steps) * 30 + 1e-9)) + 1, c.nbody, 3)
    np.testing.assert_allclose(r.body_pos[0], rec._pos[0])
    path = save_gltf(c, [r], tmp_path / "session.glb", tolerance=0.0)
    m = gltf_motion(path, rest="file")
    np.testing.assert_allclose(m.body_pos, r.body_pos, atol=1e-6)
    with pytest.raises(ValueError, match="positive"):
        rec.capture(0.0)


def test_char_record_captures_every_tick_alone_and_in_a_crowd(tmp_path):
    """``Character.record()`` captures after each tick by itself, for a character alone
    and for one ticked by a ``Crowd``, a hit's physical reaction included; ``stop`` ends
    it; ``save`` writes .glb (validator: 0 errors), .gltf and .bvh and keeps what exists."""
    from engine.io.bvh import load_bvh
    from engine.io.gltf import gltf_motion

    c = _creature("humanoid")
    alone, member, other = engine.Character(c), engine.Character(c), engine.Character(c, position=(2, 0, 0))
    crowd = engine.Crowd([member, other])
    for ch in (alone, member):
        ch.play(_anim("wave"))
    alone.tick(1 / 60)
    crowd.tick(1 / 60)
    recs = [alone.record(fps=60), member.record(fps=60)]
    seen = [[alone.world_positions.copy()], [member.world_positions.copy()]]
    for k in range(40):
        if k == 10:
            alone.hit("spine2", (-40.0, 0.0, 0.0))
            member.hit("spine2", (0.0, 30.0, 0.0))
        alone.tick(1 / 60)
        crowd.tick(1 / 60)
        seen[0].append(alone.world_positions.copy())
        seen[1].append(member.world_positions.copy())
    assert alone.response.hits == 1 and member.response.hits == 1   # reactions ran in the recorded ticks
    for rec, want in zip(recs, seen, strict=True):
        r = rec.recording()
        assert r.body_pos.shape == (41, c.nbody, 3)
        np.testing.assert_allclose(r.body_pos, np.array(want), atol=1e-9)
    assert not other.recorders
    recs[1].stop()
    assert not member.recorders and not recs[1].attached
    crowd.tick(1 / 60)
    assert recs[1].recording().body_pos.shape[0] == 41          # nothing after stop
    recs[0].stop()
    glb = recs[0].save(tmp_path / "session.glb")
    m = gltf_motion(glb, rest="file")
    np.testing.assert_allclose(m.body_pos, recs[0].recording().body_pos, atol=1e-4)
    if clients.validator_available():
        assert clients.validate(glb)["issues"]["numErrors"] == 0
    assert recs[0].save(tmp_path / "session.gltf").endswith(".gltf")
    bvh = load_bvh(recs[0].save(tmp_path / "session.bvh"))
    assert bvh.nframe == 41 and bvh.njoint == c.nbody
    with pytest.raises(FileExistsError, match="overwrite"):
        recs[0].save(tmp_path / "session.glb")
    with pytest.raises(engine.errors.DataError, match=".glb, .gltf or .bvh"):
        recs[0].save(tmp_path / "session.fbx")
    with pytest.raises(ValueError, match="fps"):
        alone.record(fps=0)
    fresh = engine.Character(c).record()
    with pytest.raises(ValueError, match="tick the character"):
        fresh.recording()


def test_char_record_of_a_rig_exports_its_own_mesh(tmp_path):
    """A creature file made from a glTF rig records and saves with the rig's own mesh."""
    import json
    import struct

    from engine.cli import main
    from engine.io.gltf import gltf_motion, rig_mesh_of

    yml = tmp_path / "fig.yaml"
    assert main(["creatures", "from-gltf", os.path.join(RIGS, "riggedfigure_khronos.glb"), "--out", str(yml)]) == 0
    c = engine.load_creature(yml)
    ch = engine.Character(c)
    ch.play(_anim("wave"))
    rec = ch.record()
    for _ in range(20):
        ch.tick(1 / 30)
    path = rec.stop().save(tmp_path / "fig.glb")
    own = rig_mesh_of(c)
    with open(path, "rb") as f:
        blob = f.read()
    doc = json.loads(blob[20:20 + struct.unpack("<I", blob[12:16])[0]])
    written = sum(doc["accessors"][p["attributes"]["POSITION"]]["count"] for m in doc["meshes"] for p in m["primitives"])
    assert written == own.positions.shape[0]            # the rig's vertices, not a box per body
    assert gltf_motion(path, rest="file").body_pos.shape[0] == rec.recording().body_pos.shape[0]


def test_a_creature_file_made_from_a_rig_bakes_with_the_rigs_mesh(tmp_path):
    """``creatures from-gltf --out X.yaml`` writes where the rig is (``source:``); the file
    reads back with it, saves with it, and a bake of the YAML carries the rig's own mesh.
    A rig that is gone, or bad ``source`` fields, are errors naming the file and field."""
    from engine.cli import main
    from engine.errors import DataError
    from engine.io.gltf import rig_mesh_of

    rig = os.path.join(RIGS, "riggedfigure_khronos.glb")
    yml = tmp_path / "fig.yaml"
    assert main(["creatures", "from-gltf", rig, "--out", str(yml)]) == 0
    c = engine.load_creature(yml)
    assert os.path.samefile(os.path.join(tmp_path, c.source["file"]), rig) and c.source["skin"] == 0
    c.save(tmp_path / "again.yaml")
    assert engine.load_creature(tmp_path / "again.yaml").source == c.source
    mesh = rig_mesh_of(c)
    assert mesh is not None and sorted(mesh.body_names) == sorted(c.body_names)
    wave = os.path.join(ROOT, "animations", "wave.yaml")
    assert main(["bake", wave, str(yml), "--out", str(tmp_path / "out"), "--workers", "0", "--quiet"]) == 0
    got, doc = _file_skinned(tmp_path / "out" / "riggedfigure_khronos_wave.glb")
    assert doc.meshes[0].name.endswith("_mesh") and len(got) == len(mesh.positions)

    text = yml.read_text()
    moved = tmp_path / "elsewhere"
    moved.mkdir()
    (moved / "fig.yaml").write_text(text)          # the relative rig path no longer resolves
    with pytest.raises(DataError) as err:
        rig_mesh_of(engine.load_creature(moved / "fig.yaml"))
    assert "fig.yaml" in str(err.value) and "source.file" in str(err.value)
    for bad, field in (("  skin: 0", "  skin: -2"), ("  scale: 1.0", "  scale: nope")):
        (tmp_path / "bad.yaml").write_text(text.replace(bad, field))
        with pytest.raises(DataError) as err:
            engine.load_creature(tmp_path / "bad.yaml")
        assert "bad.yaml:" in str(err.value) and f"source.{bad.split(':')[0].strip()}" in str(err.value)
