"""glTF import and export speed (issue 15's floors: importing a 50-joint rig <= 0.5 s,
exporting a 3-second clip on a 50-body creature <= 0.5 s). Medians of several runs.

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
    print(json.dumps(out))


if __name__ == "__main__":
    main()
