"""Dense capture-style skeletons for the validation grid: fingers, toes and faces.

Real capture and game rigs carry far more joints than the library's creatures: five
three-joint fingers per hand, toes, and a face (jaw, tongue, eyes and lids, brows, lips,
cheeks, ears). Nothing in ``../shared/data`` has them, and the engine is judged on such
skeletons too. This script writes BVH skeletons of that kind, in T-pose, Y up, in
centimetres, under several naming conventions (Mixamo-like, Unreal-like, Character
Creator-like, plain), of different proportions, so ``menagerie grid --creatures DIR``
can play every animation on them:

    .venv/bin/python benchmarks/dense_skeletons.py --out out/dense           # writes the BVH files
    .venv/bin/menagerie grid --creatures out/dense --out out/grid-dense --force

The skeletons are made here from a description of a human body, not copied from any
file; they exist to exercise the importer and the runtime on 100-170 joint trees, not to
stand for a particular rig. Ends with one JSON line (files written, joints per file).
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

#: Naming conventions: (side prefix/suffix builder, joint names).
STYLES = {
    "plain": dict(side=lambda s, n: f"{'Left' if s == 'l' else 'Right'}{n}", hips="Hips", spine=["Spine", "Spine1",
                  "Spine2"], neck="Neck", head="Head"),
    "mixamo": dict(side=lambda s, n: f"mixamorig:{'Left' if s == 'l' else 'Right'}{n}", hips="mixamorig:Hips",
                   spine=["mixamorig:Spine", "mixamorig:Spine1", "mixamorig:Spine2"], neck="mixamorig:Neck",
                   head="mixamorig:Head"),
    "unreal": dict(side=lambda s, n: f"{n.lower()}_{s}", hips="pelvis", spine=["spine_01", "spine_02", "spine_03"],
                   neck="neck_01", head="head"),
    "cc": dict(side=lambda s, n: f"CC_Base_{s.upper()}_{n}", hips="CC_Base_Hip", spine=["CC_Base_Waist",
               "CC_Base_Spine01", "CC_Base_Spine02"], neck="CC_Base_NeckTwist01", head="CC_Base_Head"),
}

# limb names per style role (the side builder adds the side)
ROLE = {"shoulder": "Shoulder", "arm": "Arm", "forearm": "ForeArm", "hand": "Hand", "upleg": "UpLeg", "leg": "Leg",
        "foot": "Foot", "toe": "ToeBase", "eye": "Eye", "lid": "EyeLid", "brow": "Brow", "cheek": "Cheek",
        "ear": "Ear", "lip": "LipCorner"}
FINGERS = ("Thumb", "Index", "Middle", "Ring", "Pinky")
TOES = ("BigToe", "IndexToe", "MiddleToe", "RingToe", "PinkyToe")


class Joint:
    def __init__(self, name: str, offset, children=None) -> None:
        self.name = name
        self.offset = np.asarray(offset, float)
        self.children = list(children or [])

    def count(self) -> int:
        return 1 + sum(c.count() for c in self.children)


def human(style: str, height: float, arm: float, rng: np.random.Generator, toes: bool, face: bool) -> Joint:
    """A T-posed human of ``height`` cm (arm span ratio ``arm``), Y up, facing +Z."""
    st = STYLES[style]
    side = st["side"]
    h = height / 170.0
    j = lambda name, off, ch=None: Joint(name, np.asarray(off, float) * h, ch)  # noqa: E731

    def hand(s):
        sx = 1.0 if s == "l" else -1.0
        fingers = []
        for k, f in enumerate(FINGERS):
            spread = (k - 2) * 1.1
            base = (sx * (2.0 if f == "Thumb" else 8.3), -2.3 if f == "Thumb" else 0.0,
                    3.2 if f == "Thumb" else spread)
            segs = [3.0, 2.6, 2.3] if f == "Thumb" else [4.6 - 0.4 * abs(k - 2), 2.5, 2.2]
            tip = j(side(s, f"Hand{f}4"), (sx * segs[2] * 0.9, 0, 0))
            chain = tip
            for n in (3, 2):
                chain = j(side(s, f"Hand{f}{n}"), (sx * segs[n - 1], 0, 0), [chain])
            fingers.append(j(side(s, f"Hand{f}1"), base, [chain]))
        return j(side(s, ROLE["hand"]), (sx * 27.0 * arm, 0, 0), fingers)

    def arm_chain(s):
        sx = 1.0 if s == "l" else -1.0
        fore = j(side(s, ROLE["forearm"]), (sx * 27.8 * arm, 0, 0), [hand(s)])
        upper = j(side(s, ROLE["arm"]), (sx * 17.7 * arm, 0, 0), [fore])
        return j(side(s, ROLE["shoulder"]), (sx * 3.9, 16.0, -0.1), [upper])

    def leg_chain(s):
        sx = 1.0 if s == "l" else -1.0
        toe_children = []
        if toes:
            for k, t in enumerate(TOES):
                toe_children.append(j(side(s, t), (sx * (k - 2) * 1.4, -0.5, 2.0),
                                      [j(side(s, t + "2"), (0, 0, 1.6 - 0.15 * k))]))
        toe = j(side(s, ROLE["toe"]), (0, -6.3, 14.6), toe_children)
        foot = j(side(s, ROLE["foot"]), (0, -47.3, 0), [toe])
        leg = j(side(s, ROLE["leg"]), (0, -47.9, 0), [foot])
        return j(side(s, ROLE["upleg"]), (sx * 9.8, 0, 0), [leg])

    head_children = []
    if face:
        head_children.append(j("Jaw" if style != "cc" else "CC_Base_JawRoot", (0, -2.5, 3.0),
                               [j("Tongue1", (0, -1.0, 3.0), [j("Tongue2", (0, 0, 2.0), [j("Tongue3", (0, 0, 1.5))])]),
                                j("LowerLip", (0, -3.5, 6.0)), j("Chin", (0, -5.5, 5.5))]))
        head_children.append(j("UpperLip", (0, -1.0, 9.0)))
        head_children.append(j("Nose", (0, 3.0, 10.0), [j("NoseTip", (0, -1.0, 1.5))]))
        for s in ("l", "r"):
            sx = 1.0 if s == "l" else -1.0
            head_children += [j(side(s, ROLE["eye"]), (sx * 3.2, 5.0, 8.5)),
                              j(side(s, ROLE["lid"]), (sx * 3.2, 6.2, 8.8)),
                              j(side(s, ROLE["brow"]), (sx * 3.5, 8.0, 9.0),
                                [j(side(s, "BrowOuter"), (sx * 2.0, 0, -1.0))]),
                              j(side(s, ROLE["cheek"]), (sx * 4.5, 1.0, 7.0)),
                              j(side(s, ROLE["lip"]), (sx * 2.5, -1.5, 8.0)),
                              j(side(s, ROLE["ear"]), (sx * 7.5, 4.0, 0.0), [j(side(s, "EarTip"), (sx * 1.0, 3.0, 0))])]
    head_children.append(j("HeadTop_End" if style == "mixamo" else "HeadEnd", (0, 19.5, 0)))
    head = j(st["head"], (0, 11.8, 2.0), head_children)
    neck = j(st["neck"], (0, 17.3, 0), [head])
    s2 = j(st["spine"][2], (0, 10.0, 0), [neck, arm_chain("l"), arm_chain("r")])
    s1 = j(st["spine"][1], (0, 10.7, 0), [s2])
    s0 = j(st["spine"][0], (0, 10.0, 0), [s1])
    root = j(st["hips"], (0, 0, 0), [s0, leg_chain("l"), leg_chain("r")])
    return root


def bvh_text(root: Joint, frames: int = 2) -> str:
    lines = ["HIERARCHY"]
    nchan = [0]

    def emit(joint: Joint, depth: int, is_root: bool) -> None:
        pad = "  " * depth
        lines.append(f"{pad}{'ROOT' if is_root else 'JOINT'} {joint.name}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {joint.offset[0]:.6f} {joint.offset[1]:.6f} {joint.offset[2]:.6f}")
        if is_root:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
            nchan[0] += 6
        else:
            lines.append(f"{pad}  CHANNELS 3 Zrotation Xrotation Yrotation")
            nchan[0] += 3
        if joint.children:
            for c in joint.children:
                emit(c, depth + 1, False)
        else:
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            d = joint.offset / max(np.linalg.norm(joint.offset), 1e-9) * 1.0
            lines.append(f"{pad}    OFFSET {d[0]:.6f} {d[1]:.6f} {d[2]:.6f}")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    emit(root, 0, True)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    hip_height = 95.0
    for _ in range(frames):
        vals = [0.0] * nchan[0]
        vals[1] = hip_height
        lines.append(" ".join(f"{v:.4f}" for v in vals))
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/dense")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    written = {}
    specs = [("plain", 170, 1.0, True, True), ("mixamo", 182, 1.05, False, True), ("unreal", 158, 0.95, True, False),
             ("cc", 175, 1.0, True, True), ("plain", 120, 0.9, False, False), ("mixamo", 200, 1.1, True, True)]
    for k, (style, height, arm, toes, face) in enumerate(specs):
        root = human(style, height, arm, rng, toes, face)
        path = os.path.join(args.out, f"dense_{k}_{style}.bvh")
        with open(path, "w") as f:
            f.write(bvh_text(root))
        written[os.path.basename(path)] = root.count()
    for name, n in written.items():
        print(f"{name}: {n} joints")
    print(json.dumps({"files": len(written), "joints": written}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
