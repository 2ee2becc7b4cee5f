"""Blender reads our glTF and BVH exports (a benchmark-level check, not a CI test: bpy 5.0.1
needs its own Python 3.11 venv with numpy < 2, ~1 GB).

    # 1. in Menagerie's venv: write the exports and the expected joint positions
    .venv/bin/python benchmarks/blender_check.py write OUT_DIR
    # 2. in a bpy venv (python3.11 -m venv V && V/bin/pip install bpy==5.0.1):
    V/bin/python benchmarks/blender_check.py check OUT_DIR

Step 2 imports humanoid_wave.glb (bpy.ops.import_scene.gltf) and humanoid_wave.bvh
(bpy.ops.import_anim.bvh), poses each at the recorded times and compares every bone's head
with our joint point (Blender axes: Menagerie (x, y, z) -> (y, -x, z) for glTF; BVH is
imported Y-up -> Z-up the same way). Prints the max error per file and one JSON line.
"""

from __future__ import annotations

import json
import os
import sys

TIMES = [0.0, 0.5, 1.0, 1.5]


def write(out):
    import numpy as np

    import engine
    from engine.io.bake import recording_to_bvh
    from engine.io.bvh import save_bvh
    from engine.io.gltf_export import _joint_frames, record_clip, safe_names, save_gltf

    root = os.path.join(os.path.dirname(__file__), "..")
    os.makedirs(out, exist_ok=True)
    c = engine.load_creature(os.path.join(root, "creatures", "humanoid.yaml"))
    rec = record_clip(c, engine.load_animation(os.path.join(root, "animations", "wave.yaml")), fps=30)
    save_gltf(c, [rec], os.path.join(out, "humanoid_wave.glb"), overwrite=True)
    save_bvh(recording_to_bvh(c, rec), os.path.join(out, "humanoid_wave.bvh"), overwrite=True)
    frames = [int(round(t * 30)) for t in TIMES]
    joints = _joint_frames(c, rec.body_pos, rec.body_rot)
    expected = {"names": safe_names(c.body_names), "times": TIMES,
                "joints": [joints[f].tolist() for f in frames]}
    with open(os.path.join(out, "expected.json"), "w") as f:
        json.dump(expected, f)
    print(f"wrote {out}: humanoid_wave.glb, humanoid_wave.bvh, expected.json")
    _ = np


def _pose_error(bpy, arm, expected, fps, to_blender):
    import mathutils

    scene = bpy.context.scene
    worst = 0.0
    for t, joints in zip(expected["times"], expected["joints"], strict=True):
        frame = t * fps
        scene.frame_set(int(frame), subframe=frame - int(frame))
        for name, p in zip(expected["names"], joints, strict=True):
            pb = arm.pose.bones.get(name)
            if pb is None:
                raise SystemExit(f"bone {name} missing after import")
            head = arm.matrix_world @ pb.head
            want = mathutils.Vector(to_blender(p))
            worst = max(worst, (head - want).length)
    return worst


def check(out):
    import bpy

    with open(os.path.join(out, "expected.json")) as f:
        expected = json.load(f)
    results = {"blender": bpy.app.version_string}
    # glTF
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=os.path.join(out, "humanoid_wave.glb"))
    arm = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    results["gltf_bones"] = len(arm.pose.bones)
    results["gltf_max_error_m"] = _pose_error(bpy, arm, expected, fps, lambda p: (p[1], -p[0], p[2]))
    # BVH (centimetres; Blender's importer: Y up -> Z up)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=os.path.join(out, "humanoid_wave.bvh"), global_scale=0.01,
                            update_scene_fps=True, update_scene_duration=True)
    arm = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    fps = bpy.context.scene.render.fps / bpy.context.scene.render.fps_base
    # the BVH importer starts at frame 1
    exp = dict(expected, times=[t + 1.0 / fps for t in expected["times"]])
    results["bvh_bones"] = len(arm.pose.bones)
    results["bvh_max_error_m"] = _pose_error(bpy, arm, exp, fps, lambda p: (p[1], -p[0], p[2]))
    for k, v in results.items():
        print(f"{k}: {v}")
    print(json.dumps(results))


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("write", "check"):
        sys.exit(__doc__)
    (write if sys.argv[1] == "write" else check)(sys.argv[2])
