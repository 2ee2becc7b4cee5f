"""Animated glTF 2.0 export (``.glb``/``.gltf``) of what the runtime produces.

``record_clip`` plays an animation on a ``Character`` (player, sampling, specialization,
gait, IK, jiggles: the whole ``tick``) at a fixed rate and keeps every body's world pose;
``gltf_bytes``/``save_gltf`` write one creature and its recorded clips:

* **Nodes**: one per body, in the creature's tree; a node's origin is the body's joint and
  its rotation the body's rotation (so the node TRS *is* the body pose). One mesh node with
  the skin sits at the scene root with no transform, beside the root joint (ecosystem.md
  2.2: ``NODE_SKINNED_MESH_NON_ROOT`` otherwise).
* **Mesh**: a box per body (24 vertices with flat normals), bound rigidly to its body
  (``JOINTS_0 = [i, 0, 0, 0]``, ``WEIGHTS_0 = [1, 0, 0, 0]``); or, for a creature made
  from a glTF rig, the rig's own mesh (``mesh=``, ``engine.io.gltf.SourceMesh``: its
  vertices at the file's bind pose, its weights moved onto the bodies, one primitive per
  material, material factors kept, textures not).
* **inverseBindMatrices**: the exact inverse of each node's world matrix at the mesh's
  bind pose (the rest pose for boxes, the file's bind pose for a rig's mesh), fourth row
  written as exact ``[0, 0, 0, 1]``, column-major (the validator compares with ``==``).
* **Animations**: one per clip, every body keyed (rotation and translation: "non-animated
  properties keep their values", so switching clips leaves no stale pose), LINEAR at the
  recording rate with keys that LINEAR between their neighbours reproduces within
  ``KEY_TOLERANCE`` dropped; times ``arange(n, float32) / fps``; a looping clip's last key
  is its first pose (the loop closes; three.js plays [0, last key]); ``extras.loop``.
* **Axes**: Menagerie (Z up, X forward) -> glTF (Y up, +Z front): ``v_g = (v.y, v.z, v.x)``,
  quaternion ``xyzw = (q.y, q.z, q.x, q.w)``; a proper rotation, baked into the data.
* **Names**: unique, ``[A-Za-z0-9_-]`` only (three.js binds tracks by sanitized node name).
* **extras.menagerie** on each body node: capabilities, the box (centre offset, rotation,
  half-extents in the joint frame), so ``engine.io.gltf`` reads our own files back exactly.

The GLB container is written here (two chunks, 4-byte padded); pygltflib is not needed to
write.
"""

from __future__ import annotations

import json
import os
import re
import struct
from dataclasses import dataclass

import numpy as np

from engine.errors import DataError
from engine.model.caps import bits_to_caps

#: Keys that LINEAR interpolation between their neighbours reproduces within this are
#: dropped: metres for translations, radians for rotations.
KEY_TOLERANCE = 1e-5
#: glTF's generator string.
GENERATOR = "Menagerie glTF exporter"

_M2G = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])  # v_g = _M2G @ v_m


@dataclass
class Recording:
    """A recorded clip: world poses of every body per frame.

    Attributes:
        name: the clip's name.
        fps: frames per second.
        body_pos: (nframe, nbody, 3) world box centres, m; body_rot: (nframe, nbody, 4) w-first.
        loop: whether the clip loops (its last frame is then its first pose).
    """

    name: str
    fps: float
    body_pos: np.ndarray
    body_rot: np.ndarray
    loop: bool = False

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.body_pos.shape[0], dtype=np.float32) / np.float32(self.fps)


def record_clip(creature, animation, variant=None, fps: float = 30.0, seconds: float | None = None,
                name: str | None = None) -> Recording:
    """Play ``animation`` on a fresh ``Character`` for its length (or ``seconds``) at ``fps``
    and keep each frame's world poses. A looping clip gets its first pose again as the last
    key, at t = length, so the exported loop closes."""
    from engine.runtime import Character

    if not (np.isfinite(fps) and fps > 0):
        raise DataError(f"fps must be a positive number, got {fps!r}", field="fps")
    length = float(seconds if seconds is not None else animation.length)
    nstep = max(1, int(round(length * fps)))
    char = Character(creature)
    char.play(animation, variant=variant, fade=0.0, loop=animation.loop)
    dt = 1.0 / fps
    pos = np.zeros((nstep + 1, creature.nbody, 3))
    rot = np.zeros((nstep + 1, creature.nbody, 4))
    char.tick(1e-6)  # pose the first frame at t ~ 0
    for k in range(nstep + 1):
        pos[k] = char.world_positions
        rot[k] = char.world_rotations
        if k < nstep:
            char.tick(dt)
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(rot))):
        raise DataError("the recorded motion has non-finite poses", subject=creature.name, kind="creature")
    if animation.loop:
        pos[-1] = pos[0]
        rot[-1] = rot[0]
    label = name or (animation.name if getattr(animation, "name", None) else "clip")
    if name is None and variant is not None:
        label = f"{label}_{variant}"
    return Recording(name=label, fps=float(fps), body_pos=pos, body_rot=rot, loop=bool(animation.loop))


class SessionRecorder:
    """Records a live ``Character`` (a game session, the viewer) for export.
    ``recording(name)`` gives a ``Recording`` resampled to ``fps`` (linear positions,
    normalized-lerp rotations between captured frames), so ticks of any length export as
    regular keys. ``Character.record()`` makes one that captures after every tick by
    itself (``stop()`` ends that); one made directly captures when told:

        rec = SessionRecorder(char)
        for dt in frame_times: char.tick(dt); rec.capture(dt)
        save_gltf(char.creature, [rec.recording("session")], "session.glb")
    """

    def __init__(self, char, fps: float = 30.0):
        if not (isinstance(fps, (int, float)) and np.isfinite(fps) and 0.0 < fps <= 1000.0):
            raise ValueError(f"record: fps must be a number of frames per second in (0, 1000], got {fps!r}")
        self.char = char
        self.fps = float(fps)
        #: Whether the character captures into this recorder after each tick (``Character.record``).
        self.attached = False
        self.t = 0.0
        self._times: list[float] = []
        self._pos: list[np.ndarray] = []
        self._rot: list[np.ndarray] = []

    def capture(self, dt: float = 0.0) -> None:
        """Keep the character's current world pose, ``dt`` seconds after the previous one."""
        if self._times:
            if not (np.isfinite(dt) and dt > 0):
                raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
            self.t += float(dt)
        self._times.append(self.t)
        self._pos.append(np.array(self.char.world_positions))
        self._rot.append(np.array(self.char.world_rotations))

    @property
    def seconds(self) -> float:
        """Time from the first captured frame to the last."""
        return self.t

    def stop(self) -> SessionRecorder:
        """Capture no more frames (what was captured stays); returns the recorder."""
        if self.attached:
            self.char._stop_recording(self)
            self.attached = False
        return self

    def save(self, path: str | os.PathLike, *, name: str = "session", overwrite: bool = False,
             mesh: str = "auto") -> str:
        """Write the recording: ``.glb`` or ``.gltf`` (a box per body, or, with ``mesh``
        ``"auto"``, the rig's own mesh for a creature made from a glTF rig), or ``.bvh``
        (the creature's hierarchy). An existing file is kept unless ``overwrite``."""
        path = os.fspath(path)
        suffix = os.path.splitext(path)[1].lower()
        if suffix not in (".glb", ".gltf", ".bvh"):
            raise DataError("a session is saved as .glb, .gltf or .bvh", path=path)
        if mesh not in ("auto", "boxes"):
            raise DataError(f"mesh must be 'auto' or 'boxes', got {mesh!r}", path=path, field="mesh")
        if os.path.exists(path) and not overwrite:
            raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
        rec = self.recording(name)
        creature = self.char.creature
        if suffix == ".bvh":
            from engine.io.bake import recording_to_bvh
            from engine.io.bvh import save_bvh

            save_bvh(recording_to_bvh(creature, rec), path, overwrite=overwrite)
            return path
        source_mesh = None
        if mesh == "auto" and getattr(creature, "source", None):
            from engine.io.gltf import rig_mesh_of

            source_mesh = rig_mesh_of(creature)
        return save_gltf(creature, [rec], path, overwrite=overwrite, mesh=source_mesh)

    def recording(self, name: str = "session") -> Recording:
        if len(self._times) < 2:
            raise ValueError("a recording needs at least two captured frames (tick the character after record())")
        times = np.array(self._times)
        pos, rot = np.array(self._pos), _continuous(np.array(self._rot))
        out_t = np.arange(int(np.floor(times[-1] * self.fps + 1e-9)) + 1) / self.fps
        k = np.clip(np.searchsorted(times, out_t, side="right") - 1, 0, len(times) - 2)
        u = ((out_t - times[k]) / (times[k + 1] - times[k]))[:, None, None]
        p = pos[k] + u * (pos[k + 1] - pos[k])
        q = rot[k] + u * (rot[k + 1] - rot[k])
        q /= np.linalg.norm(q, axis=-1, keepdims=True)
        return Recording(name=name, fps=self.fps, body_pos=p, body_rot=q, loop=False)


# -- small quaternion helpers ---------------------------------------------------------------


def _qmul(a, b):
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], axis=-1)


def _qconj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _qrot(q, v):
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + q[..., :1] * t + np.cross(u, t)


def _to_gltf_quat(q):
    """(..., 4) Menagerie w-first -> glTF xyzw in glTF axes."""
    return np.stack([q[..., 2], q[..., 3], q[..., 1], q[..., 0]], axis=-1)


def _to_gltf_vec(v):
    return v @ _M2G.T


def safe_names(names) -> list[str]:
    """Unique names of ``[A-Za-z0-9_-]`` (three.js strips other characters from track names)."""
    out, seen = [], set()
    for nm in names:
        base = re.sub(r"[^A-Za-z0-9_-]", "_", nm) or "body"
        cand, k = base, 2
        while cand in seen:
            cand = f"{base}_{k}"
            k += 1
        seen.add(cand)
        out.append(cand)
    return out


# -- local transforms of the body tree ------------------------------------------------------


def _joint_frames(creature, pos, rot):
    """World joint points (..., n, 3) of bodies at box poses ``pos``/``rot``."""
    return pos - _qrot(rot, np.broadcast_to(creature.body_joint_offset, pos.shape))


def _local_trs(creature, pos, rot):
    """Local translation (..., n, 3) and rotation (..., n, 4) of each node (joint frame)."""
    joint = _joint_frames(creature, pos, rot)
    parent = creature.body_parent
    t = joint.copy()
    r = rot.copy()
    child = np.flatnonzero(parent >= 0)
    p = parent[child]
    pinv = _qconj(rot[..., p, :])
    t[..., child, :] = _qrot(pinv, joint[..., child, :] - joint[..., p, :])
    r[..., child, :] = _qmul(pinv, rot[..., child, :])
    return t, r


def _continuous(q):
    """Flip quaternions along axis 0 into one hemisphere, key to key."""
    q = q.copy()
    for k in range(1, len(q)):
        flip = np.sum(q[k] * q[k - 1], axis=-1) < 0
        q[k][flip] *= -1
    return q


def _slerp(a, b, u):
    d = np.clip(np.sum(a * b, axis=-1, keepdims=True), -1.0, 1.0)
    b = np.where(d < 0, -b, b)
    d = np.abs(d)
    theta = np.arccos(d)
    s = np.sin(theta)
    small = s < 1e-9
    wa = np.where(small, 1.0 - u, np.sin((1.0 - u) * theta) / np.where(small, 1.0, s))
    wb = np.where(small, u, np.sin(u * theta) / np.where(small, 1.0, s))
    out = wa * a + wb * b
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def reduce_keys(values: np.ndarray, rotation: bool, tol: float = KEY_TOLERANCE) -> np.ndarray:
    """Indices of the keys to keep (first and last always): a key is dropped when LINEAR
    (slerp for rotations) between the kept neighbours reproduces every frame in between
    within ``tol`` (metres, or radians)."""
    n = len(values)
    if n <= 2:
        return np.arange(n)
    from engine.io._kernels import reduce_keys_kernel

    mask = np.zeros(n, np.bool_)
    reduce_keys_kernel(np.ascontiguousarray(values, dtype=np.float64), bool(rotation), float(tol), mask)
    return np.flatnonzero(mask)


def reduce_keys_reference(values: np.ndarray, rotation: bool, tol: float = KEY_TOLERANCE) -> np.ndarray:
    """``reduce_keys`` written plainly in numpy (the kernel's reference in the tests)."""
    n = len(values)
    if n <= 2:
        return np.arange(n)
    keep = [0]
    a = 0
    k = 2
    while k < n:
        seg = values[a + 1:k]
        u = (np.arange(a + 1, k) - a)[:, None] / (k - a)
        if rotation:
            approx = _slerp(np.broadcast_to(values[a], seg.shape), np.broadcast_to(values[k], seg.shape), u)
            err = 2.0 * np.arccos(np.clip(np.abs(np.sum(approx * seg, axis=-1)), 0.0, 1.0))
        else:
            approx = values[a] + u * (values[k] - values[a])
            err = np.linalg.norm(approx - seg, axis=-1)
        if err.max() > tol:
            a = k - 1
            keep.append(a)
        k += 1
    keep.append(n - 1)
    return np.array(sorted(set(keep)))


# -- the document ---------------------------------------------------------------------------


class _Buffer:
    """Binary chunk builder: views 4-byte aligned, accessors with float32 min/max."""

    def __init__(self):
        self.data = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, array: np.ndarray, gltf_type: str, component: int, target: int | None = None,
            minmax: bool = False) -> int:
        arr = np.ascontiguousarray(array)
        pad = (-len(self.data)) % 4
        self.data += b"\0" * pad
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": arr.nbytes}
        if target is not None:
            view["target"] = target
        self.data += arr.tobytes()
        self.views.append(view)
        ncomp = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[gltf_type]
        acc = {"bufferView": len(self.views) - 1, "componentType": component,
               "count": int(arr.size // ncomp), "type": gltf_type}
        if minmax:
            flat = arr.reshape(-1, ncomp)
            acc["min"] = flat.min(axis=0).astype(float).tolist()
            acc["max"] = flat.max(axis=0).astype(float).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1


_FACES = [  # (normal axis, sign): 4 corners each, counter-clockwise seen from outside
    (0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1)]


def _box_template():
    """Unit-box corners (24, 3) in +-1, normals (24, 3) and triangle indices (36,), outward faces
    counter-clockwise seen from outside."""
    corners, normals, idx = [], [], []
    for axis, sign in _FACES:
        u, v = [a for a in range(3) if a != axis]
        base = len(corners)
        quad = []
        for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            p = np.zeros(3)
            p[axis], p[u], p[v] = sign, su, sv
            quad.append(p)
        nrm = np.zeros(3)
        nrm[axis] = sign
        ccw = np.cross(quad[1] - quad[0], quad[2] - quad[0]) @ nrm > 0
        corners += quad
        normals += [nrm] * 4
        idx += [base, base + 1, base + 2, base, base + 2, base + 3] if ccw else \
               [base, base + 2, base + 1, base, base + 3, base + 2]
    return np.array(corners), np.array(normals), np.array(idx)


_BOX_CORNERS, _BOX_NORMALS, _BOX_INDEX = _box_template()


def _box_mesh(creature):
    """Vertices (24n, 3), normals (24n, 3), joints (24n,) and indices (36n,) at rest, Menagerie axes."""
    n = creature.nbody
    local = _BOX_CORNERS[None] * creature.body_extent[:, None]            # (n, 24, 3)
    rot = np.broadcast_to(creature.body_rest_rot[:, None], (n, 24, 4))
    verts = creature.body_rest_pos[:, None] + _qrot(rot, local)
    norms = _qrot(rot, np.broadcast_to(_BOX_NORMALS, (n, 24, 3)))
    joints = np.repeat(np.arange(n), 24)
    idx = (_BOX_INDEX[None] + 24 * np.arange(n)[:, None]).ravel()
    return verts.reshape(-1, 3), norms.reshape(-1, 3), joints, idx


def gltf_document(creature, recordings: list[Recording], name: str | None = None,
                  tolerance: float = KEY_TOLERANCE, mesh=None) -> tuple[dict, bytes]:
    """The glTF JSON (a dict) and the binary chunk for ``creature`` with ``recordings``;
    ``mesh``: a rig's own skinned mesh (``engine.io.gltf.SourceMesh``) instead of boxes."""
    n = creature.nbody
    names = safe_names(creature.body_names)
    buf = _Buffer()

    # Rest nodes: local TRS of each joint frame.
    t_rest, r_rest = _local_trs(creature, creature.body_rest_pos, creature.body_rest_rot)
    nodes = []
    children = [[] for _ in range(n)]
    for i in range(1, n):
        children[creature.body_parent[i]].append(i)
    joint_rest = _joint_frames(creature, creature.body_rest_pos, creature.body_rest_rot)
    for i in range(n):
        q = _to_gltf_quat(r_rest[i])
        q = q / np.linalg.norm(q)
        off = _qrot(_qconj(creature.body_rest_rot[i]), creature.body_rest_pos[i] - joint_rest[i])
        node = {"name": names[i], "translation": _to_gltf_vec(t_rest[i]).tolist(), "rotation": q.tolist(),
                "extras": {"menagerie": {"body": creature.body_names[i],
                                         "caps": bits_to_caps(creature.body_caps[i]),
                                         "box_offset": off.tolist(),
                                         "extents": creature.body_extent[i].tolist()}}}
        if children[i]:
            node["children"] = children[i]
        nodes.append(node)

    if mesh is None:
        # Boxes at rest in glTF world axes, each bound to its body.
        verts, norms, vjoint, idx = _box_mesh(creature)
        vj = np.zeros((len(vjoint), 4), np.int64)
        vj[:, 0] = vjoint
        vw = np.zeros((len(vjoint), 4))
        vw[:, 0] = 1.0
        prims = [(0, len(idx), 0)]
        materials = [{"name": "body", "pbrMetallicRoughness": {"baseColorFactor": [0.55, 0.6, 0.7, 1.0],
                                                                "metallicFactor": 0.0, "roughnessFactor": 0.8}}]
        bind_pos, bind_rot = creature.body_rest_pos, creature.body_rest_rot
        mesh_name = "boxes"
    else:
        # The rig's own mesh at its bind pose; the inverse bind matrices are the bind pose's.
        index = {nm: i for i, nm in enumerate(creature.body_names)}
        missing = [nm for nm in mesh.body_names if nm not in index]
        if missing or len(mesh.body_names) != n:
            raise DataError(f"the source mesh is bound to {len(mesh.body_names)} bodies, the creature has {n}"
                            + (f"; not in the creature: {', '.join(missing[:5])}" if missing else ""),
                            subject=creature.name, kind="creature")
        perm = np.array([index[nm] for nm in mesh.body_names], np.int64)  # mesh body -> creature body
        verts, norms, vw, idx = mesh.positions, mesh.normals, mesh.weights, mesh.indices
        vj = np.where(vw > 0, perm[mesh.joints], 0)  # unused slots name joint 0 (the validator checks)
        prims, materials = mesh.primitives, mesh.materials
        bind_pos = np.empty((n, 3))
        bind_rot = np.empty((n, 4))
        bind_pos[perm] = mesh.bind_pos
        bind_rot[perm] = mesh.bind_rot
        mesh_name = "mesh"
    vg = _to_gltf_vec(verts).astype(np.float32)
    jtype, jcomp = (np.uint8, 5121) if n <= 256 else (np.uint16, 5123)
    a_pos = buf.add(vg, "VEC3", 5126, target=34962, minmax=True)
    attributes = {"POSITION": a_pos}
    if norms is not None:
        attributes["NORMAL"] = buf.add(_to_gltf_vec(norms).astype(np.float32), "VEC3", 5126, target=34962)
    attributes["JOINTS_0"] = buf.add(np.asarray(vj).astype(jtype), "VEC4", jcomp, target=34962)
    attributes["WEIGHTS_0"] = buf.add(np.asarray(vw).astype(np.float32), "VEC4", 5126, target=34962)
    itype, icomp = (np.uint16, 5123) if len(vg) < 65535 else (np.uint32, 5125)
    primitives = []
    for first, count, material in prims:
        a_idx = buf.add(np.asarray(idx[first:first + count]).astype(itype), "SCALAR", icomp, target=34963)
        primitives.append({"attributes": dict(attributes), "indices": a_idx, "material": int(material)})

    # Inverse bind matrices: inverse bind world matrix of each joint frame (glTF axes).
    joint_bind = _joint_frames(creature, np.asarray(bind_pos, float), np.asarray(bind_rot, float))
    ibm = np.zeros((n, 4, 4))
    for i in range(n):
        rg = _M2G @ _quat_matrix(bind_rot[i]) @ _M2G.T
        jg = _M2G @ joint_bind[i]
        ibm[i, :3, :3] = rg.T
        ibm[i, :3, 3] = -rg.T @ jg
        ibm[i, 3] = (0.0, 0.0, 0.0, 1.0)  # exact: the validator compares with ==
    ibm32 = np.ascontiguousarray(ibm.transpose(0, 2, 1)).astype(np.float32)  # column-major; 0 and 1 stay exact
    a_ibm = buf.add(ibm32, "MAT4", 5126)

    mesh_node = len(nodes)
    stem = safe_names([name or creature.name])[0]
    nodes.append({"name": f"{stem}_mesh", "mesh": 0, "skin": 0})
    doc = {
        "asset": {"version": "2.0", "generator": GENERATOR},
        "scene": 0,
        "scenes": [{"name": name or creature.name, "nodes": [0, mesh_node]}],
        "nodes": nodes,
        "meshes": [{"name": f"{stem}_{mesh_name}", "primitives": primitives}],
        "materials": materials,
        "skins": [{"name": "bodies", "joints": list(range(n)), "inverseBindMatrices": a_ibm, "skeleton": 0}],
    }

    animations = []
    used = set()
    for rec in recordings:
        if rec.body_pos.shape[1:] != (n, 3) or rec.body_rot.shape[1:] != (n, 4):
            raise DataError(f"recording {rec.name!r} has {rec.body_pos.shape[1]} bodies, the creature {n}",
                            subject=creature.name, kind="creature")
        times = rec.times
        t_loc, r_loc = _local_trs(creature, rec.body_pos, rec.body_rot)
        r_loc = _continuous(r_loc / np.linalg.norm(r_loc, axis=-1, keepdims=True))
        samplers, channels = [], []
        input_cache: dict[bytes, int] = {}

        for i in range(n):
            for path, values, rotation in (("rotation", r_loc[:, i], True), ("translation", t_loc[:, i], False)):
                keep = reduce_keys(values, rotation, tolerance)
                if rotation:
                    out = _to_gltf_quat(values[keep]).astype(np.float32)
                    out /= np.linalg.norm(out, axis=-1, keepdims=True)
                    acc = buf.add(out, "VEC4", 5126)
                else:
                    acc = buf.add(_to_gltf_vec(values[keep]).astype(np.float32), "VEC3", 5126)
                key = keep.tobytes()  # channels with the same kept keys share one input accessor
                if key not in input_cache:
                    input_cache[key] = buf.add(times[keep], "SCALAR", 5126, minmax=True)
                samplers.append({"input": input_cache[key], "output": acc, "interpolation": "LINEAR"})
                channels.append({"sampler": len(samplers) - 1, "target": {"node": i, "path": path}})
        aname = safe_names([rec.name])[0]
        while aname in used:
            aname += "_"
        used.add(aname)
        animations.append({"name": aname, "samplers": samplers, "channels": channels,
                           "extras": {"loop": rec.loop, "fps": rec.fps}})
    if animations:
        doc["animations"] = animations
    doc["accessors"] = buf.accessors
    doc["bufferViews"] = buf.views
    data = bytes(buf.data) + b"\0" * ((-len(buf.data)) % 4)
    doc["buffers"] = [{"byteLength": len(data)}]
    return doc, data


def _quat_matrix(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def glb_bytes(doc: dict, data: bytes) -> bytes:
    """A GLB container: header, JSON chunk (space padded), BIN chunk (zero padded)."""
    js = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    js += b" " * ((-len(js)) % 4)
    out = struct.pack("<II", len(js), 0x4E4F534A) + js
    if data:
        out += struct.pack("<II", len(data), 0x004E4942) + data
    return struct.pack("<III", 0x46546C67, 2, 12 + len(out)) + out


def save_gltf(creature, recordings: list[Recording], path: str | os.PathLike, *, overwrite: bool = False,
              name: str | None = None, tolerance: float = KEY_TOLERANCE, mesh=None) -> str:
    """Write ``.glb`` (one file) or ``.gltf`` (JSON with the buffer as a data URI); ``mesh``
    as ``gltf_document``."""
    import base64

    path = os.fspath(path)
    if os.path.exists(path) and not overwrite:
        raise FileExistsError(f"{path} exists; pass overwrite=True (or --force) to replace it")
    doc, data = gltf_document(creature, recordings, name=name, tolerance=tolerance, mesh=mesh)
    suffix = os.path.splitext(path)[1].lower()
    if suffix == ".glb":
        blob = glb_bytes(doc, data)
        with open(path, "wb") as f:
            f.write(blob)
    elif suffix == ".gltf":
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
        with open(path, "w", encoding="utf-8") as f:
            json.dump(doc, f)
    else:
        raise DataError("a glTF export ends in .glb or .gltf", path=path)
    return path
