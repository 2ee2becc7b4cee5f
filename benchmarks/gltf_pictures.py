"""Rigs in and out, seen: every shared rig and capture in its relaxed rest, and one exported
frame as three.js poses it next to our own render of the same frame, with the Khronos
validator's verdict on the exports.

    .venv/bin/python benchmarks/gltf_pictures.py [--out benchmarks/pictures] [--force]

Writes ``gltf_rigs_relaxed.png`` (the rigs of ``../shared/data/rigs`` and the captures of
``../shared/data/mocap`` as imported, each drawn at the same size, true height under the
name) and ``gltf_three_vs_ours.png`` (the library humanoid's ``wave`` at t = 1 s: three.js
in headless Chromium on the left, Menagerie's viewer on the right). Needs the test tools
(``bash setup.sh dev``: npm ``gltf-validator`` and ``three``, Debian ``chromium``). Prints the
validator's error and warning counts per export, the largest distance between three.js's
body origins and ours at the pictured time, and one JSON line.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys
import tempfile
import warnings

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))

import numpy as np  # noqa: E402

import engine  # noqa: E402
from engine.outputs import output_file  # noqa: E402

DATA = os.path.join(ROOT, "..", "shared", "data")
SHOT_T = 1.0


def rigs_picture(path: str) -> list[str]:
    from authoring.viewer import snapshot_creatures

    files = (sorted(glob.glob(os.path.join(DATA, "rigs", "*.glb")))
             + sorted(glob.glob(os.path.join(DATA, "mocap", "*.bvh"))))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")       # the boxing capture's frame count
        snapshot_creatures(files, path, 1600, 1400, columns=4)
    return [os.path.basename(f) for f in files]


def three_vs_ours(path: str, work: str) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    import gltf_clients as clients
    import matplotlib.pyplot as plt

    from authoring.pose_sheet import pose_sheet
    from engine.io.gltf_export import _joint_frames, _to_gltf_vec, record_clip, save_gltf

    c = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    anim = engine.load_animation(os.path.join(ROOT, "animations", "wave.yaml"))
    rec = record_clip(c, anim, fps=30)
    glb = save_gltf(c, [rec], os.path.join(work, "humanoid_wave.glb"), overwrite=True)
    k = int(round(SHOT_T * 30))
    three_png = os.path.join(work, "three.png")
    got = clients.three_pose(glb, [float(rec.times[k])], screenshot=three_png, shot_time=float(rec.times[k]))
    ours = _to_gltf_vec(_joint_frames(c, rec.body_pos[k], rec.body_rot[k]))
    err = float(np.abs(np.array(got["frames"][0]["pos"]) - ours).max())
    ours_png = pose_sheet(os.path.join(ROOT, "animations", "wave.yaml"), SHOT_T, os.path.join(work, "ours.png"),
                          ["humanoid"], width=800, height=640)
    fig, axes = plt.subplots(1, 2, figsize=(16, 6.4), dpi=100)
    for ax, png, title in ((axes[0], three_png, "three.js (headless Chromium) reading our .glb"),
                           (axes[1], ours_png, "Menagerie's viewer, the same frame")):
        ax.imshow(plt.imread(png))
        ax.set_title(title)
        ax.axis("off")
    fig.suptitle(f"wave on the humanoid, t = {SHOT_T:g} s: body origins agree within {1e3 * err:.3f} mm")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return {"three_max_error_mm": round(1e3 * err, 4), "export": glb}


def validator_counts(work: str) -> dict:
    import gltf_clients as clients

    from engine.io.gltf import creature_from_gltf, import_gltf
    from engine.io.gltf_export import record_clip, save_gltf

    wave = engine.load_animation(os.path.join(ROOT, "animations", "wave.yaml"))
    out = {}
    for name, clip in (("humanoid", "wave"), ("spider", "wave"), ("snake", "look_around")):
        c = engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))
        a = engine.load_animation(os.path.join(ROOT, "animations", f"{clip}.yaml"))
        out[f"{name} {clip}"] = save_gltf(c, [record_clip(c, a, fps=30)], os.path.join(work, f"{name}.glb"),
                                          overwrite=True)
    rig = os.path.join(DATA, "rigs", "godot_mannequiny.glb")
    c = creature_from_gltf(rig)
    out["mannequin (its own mesh)"] = save_gltf(c, [record_clip(c, wave, fps=30)], os.path.join(work, "mannequin.glb"),
                                                overwrite=True, mesh=import_gltf(rig, mesh=True).mesh)
    ch = engine.Character(c)
    ch.play(wave)
    rec = ch.record()
    for _ in range(60):
        ch.tick(1 / 60)
    out["mannequin session (char.record)"] = rec.stop().save(os.path.join(work, "session.glb"), overwrite=True)
    counts = {}
    for label, p in out.items():
        issues = clients.validate(p)["issues"]
        counts[label] = (int(issues["numErrors"]), int(issues["numWarnings"]))
    return counts


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "benchmarks", "pictures"), help="directory for the PNGs")
    ap.add_argument("--force", action="store_true", help="replace existing pictures")
    args = ap.parse_args()
    rigs_png = os.path.join(args.out, "gltf_rigs_relaxed.png")
    three_png = os.path.join(args.out, "gltf_three_vs_ours.png")
    try:
        for p in (rigs_png, three_png):
            output_file(p, args.force, flag="--out", suffixes=(".png",))
    except engine.MenagerieError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    figures: dict = {}
    names = rigs_picture(rigs_png)
    print(f"wrote {rigs_png}: {len(names)} skeletons in their relaxed rest")
    with tempfile.TemporaryDirectory() as work:
        counts = validator_counts(work)
        for label, (e, w) in counts.items():
            print(f"  validator: {label:34s} {e} errors, {w} warnings")
        figures.update(three_vs_ours(three_png, work))
        figures.pop("export")
    print(f"wrote {three_png}: three.js against ours within {figures['three_max_error_mm']} mm")
    figures["validator_errors"] = sum(e for e, _ in counts.values())
    figures["validator_warnings"] = sum(w for _, w in counts.values())
    figures["skeletons_pictured"] = len(names)
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
