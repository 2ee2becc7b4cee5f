"""Pictures of a capture next to its asymmetric-scaled and zombie simulations.

    .venv/bin/python benchmarks/mocap_pictures.py [FILE.bvh] [--out .notes] [--gif]

Left to right in every picture: the capture, the constrained skeleton with the right
foot's velocity scaled (Wilke & Semwal section 2.1), and the zombie (section 2.2: left
hand and foot uncontrolled, left knee locked, the paper's masses on the left side).
Each actor is drawn as the BVH creature (engine.io.creature_from_bvh) posed from the
simulated BVH, shifted so the capture's root stays in the middle of its slot. Writes
one PNG per chosen frame, a contact sheet, and with --gif a short clip.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from authoring.render import Renderer, want_headless  # noqa: E402
from authoring.scene import Actor, Label, Scene  # noqa: E402
from engine.io import bvh_body_poses, creature_from_bvh, load_bvh  # noqa: E402
from engine.paths import shared_data  # noqa: E402
from engine.response.tracking import ControlOptions, MocapRig, TrackingParams, VelocityScale, track  # noqa: E402

WALK = str(shared_data("mocap", "cmu_02_01_walk.bvh"))  # $MENAGERIE_SHARED or ../shared
ZOMBIE = ControlOptions(uncontrolled=("LeftHand", "LeftFoot"), locked=("LeftLeg",),
                        mass={"LeftFoot": 5.0, "LeftLeg": 10.0, "LHipJoint": 20.0, "LeftHand": 0.25,
                              "LeftForeArm": 2.0, "LeftArm": 5.0})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", default=WALK)
    ap.add_argument("--out", default=os.path.join(ROOT, ".notes"))
    ap.add_argument("--scale", default="RightFoot:1.5@100-300", help="asymmetric scale JOINT:K@F0-F1")
    ap.add_argument("--frames", default="60,130,200,270,340", help="frames to draw")
    ap.add_argument("--gif", action="store_true", help="also write a clip (every 4th frame)")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    clip = load_bvh(args.file)
    params = TrackingParams(k_f=40.0, gravity_comp=True)
    plain = MocapRig(clip, "constrained", params=params)
    scaled = track(plain, params, scales=[VelocityScale.parse(args.scale)])
    zombie = track(MocapRig(clip, "constrained", params=params, control=ZOMBIE), params)
    creature = creature_from_bvh(clip, scale=plain.scale)
    poses = [bvh_body_poses(c, scale=plain.scale) for c in (clip, scaled.to_bvh(), zombie.to_bvh())]
    root = plain.joint_pos[:, 0]
    names = ["capture", f"scaled {args.scale}", "zombie (left side)"]
    stats = {"scaled_mse_m2": scaled.mse, "zombie_mse_m2": zombie.mse}
    frames = [int(f) for f in args.frames.split(",") if int(f) < plain.nframe]

    def scene_at(f: int) -> Scene:
        scene = Scene(caption=f"{os.path.basename(args.file)}  frame {f}", view_elevation=np.radians(12.0),
                      view_azimuth=np.radians(25.0))
        for k, (pos, rot) in enumerate(poses):
            shift = np.array([-root[f, 0], -root[f, 1] + (k - 1) * 1.1, 0.0])
            scene.add(Actor(creature, pos[f] + shift, rot[f], show_joints=False, show_links=False))
            scene.add(Label(np.array([0.0, (k - 1) * 1.1, 2.0]), names[k]))
        return scene

    renderer = Renderer(1200, 600, headless=want_headless(snapshot=True))
    written = []
    try:
        for f in frames:
            path = os.path.join(args.out, f"mocap_compare_{f:04d}.png")
            renderer.draw(scene_at(f))
            renderer.save_png(path)
            written.append(path)
        try:
            from PIL import Image

            tiles = [Image.open(p) for p in written]
            sheet = Image.new("RGB", (tiles[0].width, tiles[0].height * len(tiles)), "white")
            for i, t in enumerate(tiles):
                sheet.paste(t, (0, i * t.height))
            sheet_path = os.path.join(args.out, "mocap_compare_sheet.png")
            sheet.save(sheet_path)
            written.append(sheet_path)
            if args.gif:
                small = Renderer(600, 300, headless=want_headless(snapshot=True))
                images = []
                try:
                    for f in range(0, plain.nframe, 4):
                        small.draw(scene_at(f))
                        images.append(Image.fromarray(small.read_pixels().copy()))
                finally:
                    small.close()
                gif = os.path.join(args.out, "mocap_compare.gif")
                images[0].save(gif, save_all=True, append_images=images[1:],
                               duration=int(4000 * clip.frame_time), loop=0)
                written.append(gif)
        except ImportError:
            pass
    finally:
        renderer.close()
    for p in written:
        print("wrote", p)
    print(json.dumps(stats))
    return 0


if __name__ == "__main__":
    sys.exit(main())
