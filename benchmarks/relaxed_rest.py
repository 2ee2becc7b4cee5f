"""Where pick_up_rock puts an imported human's hand, with the file's T-pose as rest and with
the relaxed rest (engine.model.rest_pose): the hand's position at its lowest point in the
clip, relative to the root joint (x forward, y out to the side), next to the library humanoid.

    .venv/bin/python benchmarks/relaxed_rest.py
"""

from __future__ import annotations

import json
import os

import numpy as np

import engine
from engine.io.bvh_creature import creature_from_bvh
from engine.io.gltf import creature_from_gltf
from engine.model.caps import GRASPER

ROOT = os.path.join(os.path.dirname(__file__), "..")
DATA = os.path.join(ROOT, "..", "shared", "data")


def lowest_hand(creature, anim, fps=60):
    char = engine.Character(creature)
    char.play(anim, fade=0.0, loop=False)
    hands = np.flatnonzero(creature.body_caps & GRASPER)
    root = creature.body_joint[0]
    best = None
    for _ in range(int(anim.length * fps)):
        char.tick(1.0 / fps)
        p = char.world_positions[hands]
        k = int(np.argmin(p[:, 2]))
        if best is None or p[k, 2] < best[2]:
            best = p[k].copy()
    return best - [root[0], root[1], 0.0]


def main():
    anim = engine.load_animation(os.path.join(ROOT, "animations", "pick_up_rock.yaml"))
    rows = {"humanoid (library)": engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))}
    bvh = os.path.join(DATA, "mocap", "cmu_02_01_walk.bvh")
    rig = os.path.join(DATA, "rigs", "godot_mannequiny.glb")
    rows["cmu_02_01_walk, T-pose rest"] = creature_from_bvh(bvh, rest="file")
    rows["cmu_02_01_walk, relaxed rest"] = creature_from_bvh(bvh)
    rows["godot_mannequiny, T-pose rest"] = creature_from_gltf(rig, rest="file")
    rows["godot_mannequiny, relaxed rest"] = creature_from_gltf(rig)
    print(f"{'creature':<34}{'forward m':>10}{'side m':>9}{'height m':>10}")
    out = {}
    for name, c in rows.items():
        x, y, z = lowest_hand(c, anim)
        out[name] = {"forward": round(float(x), 3), "side": round(float(abs(y)), 3), "height": round(float(z), 3)}
        print(f"{name:<34}{x:>10.3f}{abs(y):>9.3f}{z:>10.3f}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
