"""glTF import and export speed (issue 15's floors: importing a 50-joint rig <= 0.5 s,
exporting a 3-second clip on a 50-body creature <= 0.5 s), and an export that carries a
rig's own mesh. Medians of several runs.

    .venv/bin/python benchmarks/gltf_io.py
"""

from __future__ import annotations

import json
import os
import statistics
import tempfile
import time

import engine
from engine.io.gltf import import_gltf
from engine.io.gltf_export import glb_bytes, gltf_document, record_clip

ROOT = os.path.join(os.path.dirname(__file__), "..")
RIGS = os.path.join(ROOT, "..", "shared", "data", "rigs")


def median_time(fn, repeat=5):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def main():
    out = {}
    print(f"{'rig':<28}{'joints':>7}{'bodies':>7}{'import s':>10}")
    for name in sorted(os.listdir(RIGS)):
        path = os.path.join(RIGS, name)
        imp = import_gltf(path)
        import pygltflib

        joints = max(len(s.joints) for s in pygltflib.GLTF2().load(path).skins)
        t = median_time(lambda p=path: import_gltf(p))
        out[f"import_{name}"] = round(t, 4)
        print(f"{name:<28}{joints:>7}{len(imp.cdef.bodies):>7}{t:>10.3f}")
    spider = engine.load_creature(os.path.join(ROOT, "creatures", "spider.yaml"))
    anim = engine.load_animation(os.path.join(ROOT, "animations", "wave.yaml"))
    rec = record_clip(spider, anim, fps=30, seconds=3.0)
    t_rec = median_time(lambda: record_clip(spider, anim, fps=30, seconds=3.0), repeat=3)

    def export():
        doc, data = gltf_document(spider, [rec])
        with tempfile.TemporaryFile() as f:
            f.write(glb_bytes(doc, data))

    t_exp = median_time(export)
    print(f"export: spider ({spider.nbody} bodies), 3 s at 30 fps: record {t_rec:.3f} s, write {t_exp:.3f} s")
    out.update(export_bodies=spider.nbody, export_record_s=round(t_rec, 4), export_write_s=round(t_exp, 4))

    # A rig's own mesh: the mannequin (12,597 vertices, three materials) with its skin.
    from engine.model.builder import build_creature

    rig = os.path.join(RIGS, "godot_mannequiny.glb")
    t_mesh_imp = median_time(lambda: import_gltf(rig, mesh=True), repeat=3)
    imp = import_gltf(rig, mesh=True)
    man = build_creature(imp.cdef)
    rec_m = record_clip(man, anim, fps=30, seconds=3.0)

    def export_mesh():
        doc, data = gltf_document(man, [rec_m], mesh=imp.mesh)
        with tempfile.TemporaryFile() as f:
            f.write(glb_bytes(doc, data))

    t_mesh = median_time(export_mesh)
    nv = len(imp.mesh.positions)
    print(f"export with the rig's mesh: mannequin ({man.nbody} bodies, {nv} vertices), 3 s: "
          f"import with mesh {t_mesh_imp:.3f} s, write {t_mesh:.3f} s")
    out.update(mesh_vertices=nv, import_mesh_s=round(t_mesh_imp, 4), export_mesh_write_s=round(t_mesh, 4))
    print(json.dumps(out))


if __name__ == "__main__":
    main()
