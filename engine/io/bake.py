"""``menagerie bake``: what the runtime produces for an animation, written per creature as
glTF (``glb``/``gltf``, ``engine.io.gltf_export``) or BVH.

Each creature is one task: bind the animation, record every variant (or the one asked
for) with ``record_clip`` at ``fps``, write ``OUT/<creature>_<animation>.<format>``. Many
creatures run on Dask (a ``LocalCluster`` of processes by default, ``scheduler`` for a
running cluster; ``workers=0`` runs in this process) with a progress bar; a task that fails
is reported with its reason and the others go on. A creature made from a glTF rig is
exported with the rig's own mesh, skinned to its bodies (``mesh="boxes"``: a box per body).

BVH export (``recording_to_bvh``): one joint per body in the creature's tree, OFFSETs the
rest joint offsets in centimetres, Y up; the root has position and ZXY rotation channels,
other joints ZXY rotations; a joint's rotation is its body's rotation from rest, relative to
its parent's. Leaves get an End Site at the far end of their box.
"""

from __future__ import annotations

import os
import time
import traceback
from dataclasses import dataclass

import numpy as np

from engine.errors import DataError, MenagerieError

FORMATS = ("glb", "gltf", "bvh")
#: What a glTF export is skinned with: the rig's own mesh when the creature came from one
#: (``auto``), or a box per body.
MESHES = ("auto", "boxes")
#: BVH files are written in centimetres.
BVH_UNITS_PER_METRE = 100.0


def _qconj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def recording_to_bvh(creature, rec):
    """A ``BvhClip`` of recording ``rec`` on ``creature`` (see the module docstring)."""
    from engine.io.bvh import BvhClip, quat_mul, quat_rotate
    from engine.io.gltf_export import safe_names
    from engine.response.tracking import quat_to_euler

    n = creature.nbody
    parent = creature.body_parent
    k = BVH_UNITS_PER_METRE
    m2f = [1, 2, 0]  # Menagerie (x, y, z) -> file (x, y, z) = (y, z, x)
    joint = creature.body_joint
    offset = np.zeros((n, 3))
    for i in range(n):
        d = joint[i] - (joint[parent[i]] if parent[i] >= 0 else 0.0)
        offset[i] = d[m2f] * k
    end = np.full((n, 3), np.nan)
    has_child = np.zeros(n, bool)
    has_child[parent[parent >= 0]] = True
    for i in np.flatnonzero(~has_child):
        far = 2.0 * creature.body_rest_pos[i] - joint[i]
        end[i] = (far - joint[i])[m2f] * k
    # Joint world rotation = body rotation from rest; local = parent^-1 * own.
    world = quat_mul(rec.body_rot, np.broadcast_to(_qconj(creature.body_rest_rot), rec.body_rot.shape))
    local = world.copy()
    child = np.flatnonzero(parent >= 0)
    local[:, child] = quat_mul(_qconj(world[:, parent[child]]), world[:, child])
    local_file = local[..., [0, 2, 3, 1]]
    angles = np.degrees(quat_to_euler(local_file, "ZXY"))  # (nf, n, 3): Z, X, Y
    root_offset = np.broadcast_to(creature.body_joint_offset[0], (len(rec.body_pos), 3))
    root_joint = rec.body_pos[:, 0] - quat_rotate(rec.body_rot[:, 0], root_offset)
    root_file = root_joint[:, m2f] * k
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")] + \
        [("Zrotation", "Xrotation", "Yrotation")] * (n - 1)
    motion = np.concatenate([root_file, angles.reshape(len(angles), -1)], axis=1)
    return BvhClip(joint_names=tuple(safe_names(creature.body_names)), joint_parent=parent.astype(np.int32),
                   joint_offset=offset, joint_channels=tuple(channels), joint_end_site=end,
                   frame_time=1.0 / rec.fps, motion=motion)


@dataclass
class BakeResult:
    source: str
    paths: list[str]
    clips: int
    seconds: float
    error: str = ""


def bake_one(source: str, animation_path: str, out_dir: str, fmt: str = "glb", fps: float = 30.0,
             variant: str | None = None, overwrite: bool = False, mesh: str = "auto") -> BakeResult:
    """Bake one creature (a file ``creature_from_file`` reads); errors become ``BakeResult.error``.
    ``mesh``: ``"auto"`` writes a glTF rig's own mesh for a creature made from one and boxes
    otherwise, ``"boxes"`` always boxes."""
    t0 = time.perf_counter()
    try:
        import engine
        from engine.anim.binding import bind
        from engine.io.bvh import save_bvh
        from engine.io.gltf_export import record_clip, safe_names, save_gltf
        from engine.io.sources import creature_from_file

        if mesh not in MESHES:
            raise DataError(f"mesh must be one of {', '.join(MESHES)}, got {mesh!r}", field="mesh")
        source_mesh = None
        if fmt in ("glb", "gltf") and mesh == "auto" and os.path.splitext(source)[1].lower() in (".glb", ".gltf"):
            from engine.io.gltf import import_gltf
            from engine.model.builder import build_creature

            imported = import_gltf(source, mesh=True)
            creature = build_creature(imported.cdef)
            source_mesh = imported.mesh
        else:
            creature = creature_from_file(source)
            if fmt in ("glb", "gltf") and mesh == "auto" and getattr(creature, "source", None):
                from engine.io.gltf import rig_mesh_of

                source_mesh = rig_mesh_of(creature)   # a creature file made from a rig
        anim = engine.load_animation(animation_path)
        binding = bind(anim, creature)
        variants = [v for v in binding.variants if variant is None or v.id == variant]
        if not variants:
            known = ", ".join(v.id for v in binding.variants) or "none"
            raise DataError(f"no variant {variant!r} on this creature (it has: {known})", path=animation_path,
                            field="variant")
        recs = [record_clip(creature, anim, variant=v.index, fps=fps,
                            name=f"{anim.name}_{v.id}" if v.id and len(binding.variants) > 1 else anim.name)
                for v in variants]
        stem = safe_names([f"{creature.name}_{anim.name}"])[0]
        paths = []
        if fmt in ("glb", "gltf"):
            paths.append(save_gltf(creature, recs, os.path.join(out_dir, f"{stem}.{fmt}"), overwrite=overwrite,
                                   mesh=source_mesh))
        else:
            for rec in recs:
                p = os.path.join(out_dir, f"{safe_names([f'{creature.name}_{rec.name}'])[0]}.bvh")
                save_bvh(recording_to_bvh(creature, rec), p, overwrite=overwrite)
                paths.append(p)
        return BakeResult(source, paths, len(recs), time.perf_counter() - t0)
    except (MenagerieError, FileExistsError, ValueError) as exc:
        return BakeResult(source, [], 0, time.perf_counter() - t0, error=str(exc))
    except Exception as exc:  # noqa: BLE001 - a failed creature is a line in the report, not a lost batch
        return BakeResult(source, [], 0, time.perf_counter() - t0,
                          error=f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}")


def _bake_batch(sources, animation_path, out_dir, fmt, fps, variant, overwrite, mesh="auto"):
    return [bake_one(s, animation_path, out_dir, fmt, fps, variant, overwrite, mesh) for s in sources]


def bake(sources: list[str], animation_path: str, out_dir: str, fmt: str = "glb", fps: float = 30.0,
         variant: str | None = None, overwrite: bool = False, workers: int | None = None,
         scheduler: str | None = None, progress: bool = True, batch: int = 4,
         mesh: str = "auto") -> list[BakeResult]:
    """Bake ``animation_path`` onto every creature in ``sources`` (see the module docstring)."""
    if fmt not in FORMATS:
        raise MenagerieError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise MenagerieError(f"--fps must be a positive number, got {fps!r}")
    if not os.path.exists(animation_path):
        raise MenagerieError(f"{animation_path}: no such file")
    if mesh not in MESHES:
        raise MenagerieError(f"--mesh must be one of {', '.join(MESHES)}, got {mesh!r}")
    os.makedirs(out_dir, exist_ok=True)
    from engine.validation.grid import _NoBar, dask_available

    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None
    serial = workers == 0 or (address is None and (not dask_available() or len(sources) == 1))
    bar = _NoBar()
    if progress:
        try:
            from tqdm import tqdm

            bar = tqdm(total=len(sources), unit="creature", desc="bake")
        except ImportError:
            pass
    results: list[BakeResult] = []
    try:
        if serial:
            for s in sources:
                results.append(bake_one(s, animation_path, out_dir, fmt, fps, variant, overwrite, mesh))
                bar.update(1)
        else:
            import logging

            from distributed import Client, LocalCluster, as_completed

            cluster = None
            if address:
                client = Client(address)
            else:
                cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                                       processes=True, dashboard_address=":0", silence_logs=logging.CRITICAL)
                client = Client(cluster)
            try:
                chunks = [sources[i:i + batch] for i in range(0, len(sources), batch)]
                futures = client.map(_bake_batch, chunks, animation_path=animation_path, out_dir=out_dir, fmt=fmt,
                                     fps=fps, variant=variant, overwrite=overwrite, mesh=mesh, pure=False)
                for fut, out in as_completed(futures, with_results=True, raise_errors=False):
                    chunk = chunks[futures.index(fut)]
                    if isinstance(out, BaseException):
                        out = [BakeResult(s, [], 0, 0.0, error=f"the task failed: {type(out).__name__}: {out}")
                               for s in chunk]
                    results.extend(out)
                    bar.update(len(chunk))
            finally:
                client.close()
                if cluster is not None:
                    cluster.close()
    finally:
        bar.close()
    order = {s: i for i, s in enumerate(sources)}
    return sorted(results, key=lambda r: order.get(r.source, 0))
