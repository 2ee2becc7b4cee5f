"""Mid-stance knee flexion of walkers (issue 16 item 5), measured on the runtime's output.

    .venv/bin/python benchmarks/stance_knee.py [--speed 1.2] [--seconds 6] [NAME ...]

Each creature walks straight on flat ground at ``--speed`` m/s (the humanoid's 1.2 m/s is a
person's walk; other creatures at the same share of their leg length as the humanoid). Per
stance, the frame in the middle of the stance is taken and each interior joint of the leg's
chain (limb root to foot) is measured from the joint points: flexion = the angle between
consecutive segments (0 = straight). Prints the median and largest over the stances of the
leg's most bent joint, and ends with one JSON line {creature: [median_deg, max_deg]}.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import engine  # noqa: E402
from engine.runtime import Character  # noqa: E402


def _rot(q, v):
    u = q[1:]
    t = 2.0 * np.cross(u, v)
    return v + q[0] * t + np.cross(u, t)


def chain_of(c, foot):
    """Bodies from the foot's limb root down to the foot."""
    root = int(c.limb_root[c.body_limb[foot]])
    out = [int(foot)]
    while out[-1] != root and c.body_parent[out[-1]] >= 0:
        out.append(int(c.body_parent[out[-1]]))
    return out[::-1]


def knee_flexion(c, speed_share: float, seconds: float, dt: float = 1.0 / 60.0):
    ch = Character(c)
    ch.locomote((0.0, 0.0), 0.0)
    rig = ch.gait.rig
    L = float(np.max(rig.group_length))
    feet = rig.foot_body
    chains = [chain_of(c, f) for f in feet]
    frames = [[] for _ in feet]
    per_stance = []
    in_stance = np.zeros(len(feet), bool)
    for i in range(int(seconds / dt)):
        ch.locomote((speed_share * L, 0.0), 0.0)
        ch.tick(dt)
        if i < 90:                                   # settle into the walk
            continue
        wp, wr = ch.world_positions, ch.world_rotations
        st = ch.gait.step_state[rig.foot_stepper] == 0
        for k, ch_b in enumerate(chains):
            joints = [wp[b] - _rot(wr[b], c.body_joint_offset[b]) for b in ch_b] + [wp[ch_b[-1]]]
            flex = 0.0
            for j in range(1, len(joints) - 2):
                a = joints[j] - joints[j - 1]
                b = joints[j + 1] - joints[j]
                na, nb = np.linalg.norm(a), np.linalg.norm(b)
                if na > 1e-9 and nb > 1e-9:
                    flex = max(flex, float(np.degrees(np.arccos(np.clip(a @ b / (na * nb), -1.0, 1.0)))))
            if st[k]:
                frames[k].append(flex)
            elif in_stance[k] and frames[k]:
                per_stance.append(frames[k][len(frames[k]) // 2])
                frames[k] = []
        in_stance = st
    return per_stance


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("names", nargs="*", default=["humanoid", "giant", "kangaroo", "centaur"])
    ap.add_argument("--speed", type=float, default=1.2, help="the humanoid's speed, m/s")
    ap.add_argument("--seconds", type=float, default=6.0)
    args = ap.parse_args()
    hum = Character(engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml")))
    hum.locomote((0.0, 0.0), 0.0)
    share = args.speed / float(np.max(hum.gait.rig.group_length))
    out = {}
    for name in args.names:
        c = engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))
        s = knee_flexion(c, share, args.seconds)
        med = float(np.median(s)) if s else float("nan")
        top = float(np.max(s)) if s else float("nan")
        print(f"{name:12s} stances {len(s):3d}  mid-stance flexion median {med:5.1f} deg  max {top:5.1f} deg")
        out[name] = [round(med, 1), round(top, 1)]
    print(json.dumps(out))


if __name__ == "__main__":
    main()
