"""Capabilities from shape on skeletons the importer never saw: every library creature (and
some random ones) written as a BVH skeleton in its rest pose (names kept, capabilities
dropped), imported again, and the counts a person gives (legs, arms, heads, tails as chains,
wings as chains) compared with the creature's own. Names are kept because real files have
them; ``--scramble`` renames every joint ``j0, j1, ...`` so the shape alone decides.

    .venv/bin/python benchmarks/shape_caps_check.py [--scramble] [--random N] [--first-seed S]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile

import engine
from engine.io.bake import recording_to_bvh
from engine.io.bvh import save_bvh
from engine.io.bvh_creature import creature_from_bvh
from engine.io.gltf_export import Recording
from engine.model.caps import CAP_BIT

ROOT = os.path.join(os.path.dirname(__file__), "..")


def chains(c, cap):
    """Number of separate chains of bodies with ``cap`` (a two-body tail is one tail)."""
    bit = CAP_BIT[cap]
    has = (c.body_caps & bit) != 0
    return int(sum(1 for i in range(c.nbody) if has[i] and not (c.body_parent[i] >= 0 and has[c.body_parent[i]])))


def person_counts(c):
    k = c.counts()
    return {"legs": k["legs"], "arms": k["arms"], "heads": k["heads"], "tails": chains(c, "tail"),
            "wings": chains(c, "wing")}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--scramble", action="store_true")
    ap.add_argument("--random", type=int, default=0)
    ap.add_argument("--first-seed", type=int, default=0, help="first random seed (default 0)")
    args = ap.parse_args(argv)
    from engine.model import build_creature
    from engine.model.random import random_creature_def
    from engine.paths import LIBRARY_CREATURES

    creatures = [engine.load_creature(p) for p in sorted(LIBRARY_CREATURES.glob("*.yaml"))]
    creatures += [build_creature(random_creature_def(s)) for s in range(args.first_seed, args.first_seed + args.random)]
    keys = ["legs", "arms", "heads", "tails", "wings"]
    exact = {k: 0 for k in keys}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for c in creatures:
            rec = Recording("rest", 30.0, c.body_rest_pos[None].copy(), c.body_rest_rot[None].copy())
            clip = recording_to_bvh(c, rec)
            if args.scramble:
                from engine.io.bvh import BvhClip

                clip = BvhClip(joint_names=tuple(f"j{i}" for i in range(clip.njoint)), joint_parent=clip.joint_parent,
                               joint_offset=clip.joint_offset, joint_channels=clip.joint_channels,
                               joint_end_site=clip.joint_end_site, frame_time=clip.frame_time, motion=clip.motion)
            path = os.path.join(tmp, f"{c.name}.bvh")
            save_bvh(clip, path)
            try:
                back = creature_from_bvh(path, scale=0.01, rest="file")
                got = person_counts(back)
            except Exception as exc:  # noqa: BLE001 - a failed import is a row of the table
                got = {k: -1 for k in keys}
                print(f"{c.name}: {type(exc).__name__}: {exc}", file=sys.stderr)
            want = person_counts(c)
            for k in keys:
                exact[k] += got[k] == want[k]
            rows.append((c.name, want, got))
    print(f"{'creature':<16}" + "".join(f"{k:>12}" for k in keys))
    for name, want, got in rows:
        cells = "".join(f"{(str(want[k]) + ('' if got[k] == want[k] else ' -> ' + str(got[k]))):>12}" for k in keys)
        print(f"{name:<16}{cells}")
    n = len(rows)
    all_ok = sum(all(g[k] == w[k] for k in keys) for _, w, g in rows)
    print("exact per count: " + ", ".join(f"{k} {exact[k]}/{n}" for k in keys) + f"; all counts {all_ok}/{n}")
    print(json.dumps({"creatures": n, "all_counts_exact": all_ok, **{f"{k}_exact": exact[k] for k in keys},
                      "scramble": args.scramble}))


if __name__ == "__main__":
    main()
