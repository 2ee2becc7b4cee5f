"""glTF 2.0 rigs (``.gltf``/``.glb``) as Menagerie creatures: one body per deforming joint.

``creature_def_from_gltf`` reads a skinned rig and returns a ``CreatureDef``;
``creature_from_gltf`` builds it. The JSON and the GLB container are read here with the
standard library (pygltflib's dataclass parse took 1.1 s on the 45-joint mannequin against
the 0.5 s budget for a whole import; the tests check that both read the rigs alike), and
accessors are decoded in numpy (byte strides, sparse substitution, normalized integers, a
missing bufferView meaning zeros).

How each piece is made (Menagerie axes and metres, see ``ecosystem.md`` section 2.7):

* **World transforms.** The node hierarchy of the scene is walked from its roots applying
  every node's ``matrix`` or T*R*S, so conversion nodes (COLLADA2GLTF's ``Z_UP``), scaled
  armature nodes (Quaternius' x100, the Fox's 0.0254) and non-joint nodes between joints
  are folded in. The result is converted at the border: glTF is +Y up with the front
  facing +Z and the left +X, so ``v_menagerie = (v.z, v.x, v.y)`` (a proper rotation).
  Each joint's world rotation is the polar part of its world 3x3 (scale is dropped).
* **Bodies.** The joints of one skin (``skin=None``: the skin with the most joints). A
  body's parent is its nearest joint ancestor. Helper bones that deform nothing (IK
  targets, pole targets, ``_end`` bones), i.e. joints neither they nor any joint below
  them carries vertex weight, are left out and listed in ``GltfImport.helpers``. Several
  remaining roots get a common root body at their centroid (``GLTF_COMMON_ROOT``).
* **Boxes.** The mesh is skinned at rest (``sum_j w_j W_j IBM_j v``, every mesh node that
  uses the skin) and each vertex goes to its heaviest kept joint. A body's box is the
  2-98 percentile extent of its vertices in a frame whose X axis runs along the bone (to
  the mean of its child joints; a leaf along its vertices' principal axis away from the
  joint), so leaf bones (heads, hands, tail tips) get boxes too. A body with fewer than
  ``MIN_BOX_VERTICES`` vertices gets a box along its bone as the BVH importer makes.
* **Our own exports** (every joint node carries ``extras.menagerie``) come back exactly:
  the bodies' names, boxes and capabilities are read from the extras, nothing is moved.
* **Capabilities** come from the shape first, names as a hint
  (``engine.model.shape_caps``); ``caps_table`` adds the user's name patterns.
* **Rest pose**: T- and A-pose arms are swung down (``engine.model.rest_pose``); the
  file's bind pose is kept in ``GltfImport.rest_delta`` (``rest="file"`` keeps it as is).
* **Placement.** The creature stands on the ground (lowest box corner at z = 0) with the
  root joint above the origin; ``scale`` multiplies everything after the hierarchy.

Errors (``GltfError``) name the file, and the node, accessor or field at fault.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field

import numpy as np

from engine.errors import DataError
from engine.model.definition import BodyDef, CreatureDef

#: Name of the body added above several roots.
GLTF_COMMON_ROOT = "gltf_root"
#: Fewer skinned vertices than this: the box is made along the bone instead.
MIN_BOX_VERTICES = 8
#: A joint whose summed vertex weight is at most this deforms nothing.
DEFORM_EPS = 1e-4
#: With ``scale=None``, a skeleton taller than this many units is taken to be in centimetres.
AUTO_CM_HEIGHT = 20.0
#: Smallest half-extent of any box, as a fraction of the creature's size.
MIN_HALF_FRACTION = 0.004

#: glTF (x, y, z) -> Menagerie: row i of this matrix picks the glTF axis of Menagerie axis i.
GLTF_TO_MENAGERIE = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])

_COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
_NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


class GltfError(DataError):
    """A glTF file that cannot be read or turned into a creature."""


class _Obj(dict):
    """A glTF JSON object with attribute access (``node.children``); a missing property is
    None, nested objects and lists of objects are wrapped too. Still a dict (extras)."""

    __slots__ = ()

    def __getattr__(self, name):
        return _wrap(self.get(name))


def _wrap(value):
    if isinstance(value, dict) and not isinstance(value, _Obj):
        return _Obj(value)
    if isinstance(value, list) and value and isinstance(value[0], dict):
        return [_wrap(v) for v in value]
    return value


class _Document:
    """The parsed JSON of a glTF file: top-level arrays as lists of ``_Obj``."""

    _ARRAYS = ("accessors", "animations", "buffers", "bufferViews", "cameras", "images", "materials",
               "meshes", "nodes", "samplers", "scenes", "skins", "textures")

    def __init__(self, root: dict, blob: bytes | None):
        self.json = root
        for key in self._ARRAYS:
            items = root.get(key)
            setattr(self, key, [_Obj(v) if isinstance(v, dict) else _Obj() for v in items]
                    if isinstance(items, list) else None)
        asset = root.get("asset")
        self.asset = _Obj(asset) if isinstance(asset, dict) else None
        self.scene = root.get("scene")
        self._blob = blob

    def binary_blob(self):
        return self._blob


def _parse(path: str) -> _Document:
    import json

    with open(path, "rb") as f:
        raw = f.read()
    blob = None
    if raw[:4] == b"glTF":
        if len(raw) < 20:
            raise ValueError("GLB shorter than its header")
        _, version, length = struct.unpack_from("<III", raw, 0)
        if version != 2:
            raise ValueError(f"GLB container version {version}")
        offset, text = 12, None
        while offset + 8 <= min(length, len(raw)):
            clen, ctype = struct.unpack_from("<II", raw, offset)
            chunk = raw[offset + 8:offset + 8 + clen]
            if len(chunk) < clen:
                raise ValueError("GLB chunk runs past the end of the file")
            if ctype == 0x4E4F534A and text is None:
                text = chunk.decode("utf-8")
            elif ctype == 0x004E4942 and blob is None:
                blob = bytes(chunk)
            offset += 8 + clen + ((-clen) % 4 if (offset + 8 + clen) % 4 else 0)
        if text is None:
            raise ValueError("GLB has no JSON chunk")
    else:
        text = raw.decode("utf-8")
    root = json.loads(text)
    if not isinstance(root, dict):
        raise ValueError("the JSON is not an object")
    return _Document(root, blob)


# -- the file ----------------------------------------------------------------------------


@dataclass
class GltfFile:
    """A parsed glTF file: the document (``_Document``), its binary buffers and its path."""

    doc: object
    buffers: list
    path: str

    def error(self, message: str, node: int | None = None, field: str | None = None, kind: str = "node"):
        subject = None
        if node is not None:
            nodes = self.doc.nodes or []
            name = nodes[node].name if 0 <= node < len(nodes) else None
            subject = f"{node} ({name})" if name else str(node)
        return GltfError(message, path=self.path, subject=subject, field=field, kind=kind)


def load_gltf(path: str | os.PathLike) -> GltfFile:
    """Parse a ``.gltf`` or ``.glb`` file and load its buffers (GLB chunk, files, data URIs)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise GltfError("no such file", path=path)
    try:
        doc = _parse(path)
    except (ValueError, UnicodeDecodeError, struct.error, OSError) as exc:
        raise GltfError(f"not a readable glTF file ({type(exc).__name__}: {exc})", path=path) from None
    if doc is None or doc.asset is None:
        raise GltfError("not a glTF file (no asset)", path=path)
    if doc.asset.version is not None and not str(doc.asset.version).startswith("2"):
        raise GltfError(f"glTF version {doc.asset.version} is not supported (2.x only)", path=path,
                        field="asset.version")
    buffers = []
    for i, buf in enumerate(doc.buffers or []):
        data = None
        if buf.uri is None:
            blob = doc.binary_blob()
            data = bytes(blob) if blob is not None else None
        elif buf.uri.startswith("data:"):
            import base64

            try:
                data = base64.b64decode(buf.uri.split(",", 1)[1])
            except Exception:
                raise GltfError("bad data URI", path=path, subject=str(i), kind="buffer", field="uri") from None
        else:
            from urllib.parse import unquote

            file = os.path.join(os.path.dirname(path), unquote(buf.uri))
            try:
                with open(file, "rb") as f:
                    data = f.read()
            except OSError as exc:
                raise GltfError(f"cannot read buffer file {buf.uri!r}: {exc.strerror}", path=path,
                                subject=str(i), kind="buffer", field="uri") from None
        if data is None:
            raise GltfError("buffer has no data (no uri and no GLB binary chunk)", path=path,
                            subject=str(i), kind="buffer")
        if buf.byteLength is not None and len(data) < buf.byteLength:
            raise GltfError(f"buffer holds {len(data)} bytes, byteLength says {buf.byteLength}", path=path,
                            subject=str(i), kind="buffer", field="byteLength")
        buffers.append(data)
    return GltfFile(doc=doc, buffers=buffers, path=path)


def read_accessor(gf: GltfFile, index: int, finite: bool = True) -> np.ndarray:
    """Accessor ``index`` as a float64 array (count, ncomp), or (count, 4, 4) for MAT4.

    Handles ``byteStride``, a missing ``bufferView`` (zeros), sparse substitution and
    normalized integers. Errors name the accessor; ``finite=False`` lets non-finite
    numbers through (the caller deals with them).
    """
    doc = gf.doc
    accessors = doc.accessors or []
    if not (0 <= index < len(accessors)):
        raise GltfError(f"accessor {index} does not exist ({len(accessors)} accessors)", path=gf.path)
    acc = accessors[index]

    def fail(msg, fld=None):
        return GltfError(msg, path=gf.path, subject=str(index), kind="accessor", field=fld)

    if acc.componentType not in _COMPONENT:
        raise fail(f"unknown componentType {acc.componentType}", "componentType")
    if acc.type not in _NCOMP:
        raise fail(f"unknown type {acc.type!r}", "type")
    dtype = np.dtype(_COMPONENT[acc.componentType]).newbyteorder("<")
    ncomp = _NCOMP[acc.type]
    count = int(acc.count)

    def view_bytes(view_index, offset, n, stride_default):
        views = doc.bufferViews or []
        if not (0 <= view_index < len(views)):
            raise fail(f"bufferView {view_index} does not exist", "bufferView")
        view = views[view_index]
        if not (0 <= view.buffer < len(gf.buffers)):
            raise fail(f"bufferView {view_index} points at missing buffer {view.buffer}", "bufferView")
        data = gf.buffers[view.buffer]
        start = (view.byteOffset or 0) + (offset or 0)
        stride = view.byteStride or stride_default
        end = start + (n - 1) * stride + stride_default if n else start
        if end > (view.byteOffset or 0) + view.byteLength or end > len(data):
            raise fail(f"reads past the end of bufferView {view_index}", "count")
        return data, start, stride

    elem = dtype.itemsize * ncomp
    if acc.type in ("MAT2", "MAT3") and dtype.itemsize < 4:
        raise fail("padded MAT2/MAT3 of bytes or shorts are not supported", "type")
    if acc.bufferView is None:
        out = np.zeros((count, ncomp), dtype)
    else:
        data, start, stride = view_bytes(acc.bufferView, acc.byteOffset, count, elem)
        out = np.ndarray((count, ncomp), dtype=dtype, buffer=data, offset=start,
                         strides=(stride, dtype.itemsize)).copy()
    if acc.sparse is not None and acc.sparse.count:
        sp = acc.sparse
        itype = np.dtype(_COMPONENT.get(sp.indices.componentType, np.uint32)).newbyteorder("<")
        data, start, stride = view_bytes(sp.indices.bufferView, sp.indices.byteOffset, sp.count, itype.itemsize)
        idx = np.ndarray((sp.count,), dtype=itype, buffer=data, offset=start, strides=(stride,)).astype(np.int64)
        data, start, stride = view_bytes(sp.values.bufferView, sp.values.byteOffset, sp.count, elem)
        vals = np.ndarray((sp.count, ncomp), dtype=dtype, buffer=data, offset=start,
                          strides=(elem, dtype.itemsize))
        if idx.size and (idx.min() < 0 or idx.max() >= count):
            raise fail("sparse index out of range", "sparse.indices")
        out[idx] = vals
    result = out.astype(np.float64)
    if acc.normalized and dtype.kind in "iu":
        info = np.iinfo(dtype)
        result = result / info.max if dtype.kind == "u" else np.maximum(result / info.max, -1.0)
    if finite and not np.all(np.isfinite(result)):
        raise fail("holds non-finite numbers")
    if acc.type == "MAT4":
        return result.reshape(count, 4, 4).transpose(0, 2, 1)  # column-major in the file
    return result


# -- transforms --------------------------------------------------------------------------


def _quat_xyzw_to_matrix(q) -> np.ndarray:
    x, y, z, w = q
    n = x * x + y * y + z * z + w * w
    if n < 1e-12:
        raise ValueError("zero quaternion")
    s = 2.0 / n
    return np.array([
        [1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)],
    ])


def node_local_matrix(gf: GltfFile, i: int, trs=None) -> np.ndarray:
    """Node ``i``'s local 4x4 (its ``matrix``, or T*R*S; ``trs`` overrides T, R, S)."""
    node = gf.doc.nodes[i]
    if trs is None and node.matrix is not None:
        m = np.asarray(node.matrix, float)
        if m.shape != (16,) or not np.all(np.isfinite(m)):
            raise gf.error("matrix must be 16 finite numbers", i, "matrix")
        return m.reshape(4, 4).T
    t, r, s = trs if trs is not None else (node.translation, node.rotation, node.scale)
    m = np.eye(4)
    for name, value, n in (("translation", t, 3), ("rotation", r, 4), ("scale", s, 3)):
        if value is not None and (len(value) != n or not np.all(np.isfinite(np.asarray(value, float)))):
            raise gf.error(f"{name} must be {n} finite numbers", i, name)
    try:
        rot = _quat_xyzw_to_matrix(r) if r is not None else np.eye(3)
    except ValueError:
        raise gf.error("rotation is a zero quaternion", i, "rotation") from None
    m[:3, :3] = rot * (np.asarray(s, float) if s is not None else 1.0)
    if t is not None:
        m[:3, 3] = t
    return m


def node_parents(gf: GltfFile) -> np.ndarray:
    """Parent node of every node (-1 for roots); errors on a node with two parents or a cycle."""
    nodes = gf.doc.nodes or []
    parent = np.full(len(nodes), -1, np.int64)
    for i, node in enumerate(nodes):
        for c in node.children or []:
            if not (0 <= c < len(nodes)):
                raise gf.error(f"child {c} does not exist", i, "children")
            if parent[c] >= 0:
                raise gf.error(f"node {c} has two parents ({parent[c]} and {i})", i, "children")
            parent[c] = i
    for i in range(len(nodes)):  # cycles
        seen, j = 0, i
        while j >= 0:
            j = parent[j]
            seen += 1
            if seen > len(nodes):
                raise gf.error("the node hierarchy has a cycle", i, "children")
    return parent


def world_matrices(gf: GltfFile, parent: np.ndarray, local: list[np.ndarray] | None = None) -> np.ndarray:
    """World 4x4 of every node in glTF axes (nnode, 4, 4)."""
    n = len(parent)
    local = local if local is not None else [node_local_matrix(gf, i) for i in range(n)]
    world = np.zeros((n, 4, 4))
    done = np.zeros(n, bool)

    def solve(i):
        chain = []
        while i >= 0 and not done[i]:
            chain.append(i)
            i = parent[i]
        for j in reversed(chain):
            p = parent[j]
            world[j] = local[j] if p < 0 else world[p] @ local[j]
            done[j] = True

    for i in range(n):
        solve(i)
    return world


def polar_rotation(m3: np.ndarray) -> np.ndarray:
    """The rotation part of a 3x3 (U V^T of its SVD, sign-fixed so the result is proper)."""
    u, _, vt = np.linalg.svd(m3)
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, -1] *= -1
        r = u @ vt
    return r


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """A rotation matrix as a (w, x, y, z) quaternion with w >= 0."""
    t = np.trace(r)
    if t > 0:
        s = np.sqrt(t + 1.0) * 2
        q = np.array([0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s])
    elif r[0, 0] > r[1, 1] and r[0, 0] > r[2, 2]:
        s = np.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2]) * 2
        q = np.array([(r[2, 1] - r[1, 2]) / s, 0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s])
    elif r[1, 1] > r[2, 2]:
        s = np.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2]) * 2
        q = np.array([(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s])
    else:
        s = np.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1]) * 2
        q = np.array([(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s])
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """(w, x, y, z) -> 3x3."""
    w, x, y, z = q
    return _quat_xyzw_to_matrix((x, y, z, w))


# -- the import --------------------------------------------------------------------------


@dataclass
class GltfImport:
    """What ``import_gltf`` found: the definition and how it was made.

    Attributes:
        cdef: the creature definition (bodies in joint order, a common root first if added).
        skin: the skin used.
        body_node: glTF node of each body (-1 for an added common root).
        helpers: names of joints left out because they deform nothing.
        reattached: detached chains hung on the end of another chain ("child -> new parent").
        notes: fix-ups made while reading (e.g. non-finite weights taken as 0).
        skipped: names of non-joint nodes between or above the joints (folded into world space).
        reasons: per body, why it got its capabilities (``menagerie creatures explain``).
        joint_world: rest world transform of each body's joint, Menagerie axes (nbody, 4, 4),
            before grounding (``shift`` moves it onto the ground).
        shift: the grounding translation added to every position.
        scale: the scale applied after the hierarchy.
        rest_delta: world rotation (w, x, y, z) the relaxed rest applied to each body
            (identity for bodies it did not move); the file's bind pose is this undone.
        relaxed: the arms swung down, one line each.
        file_box_pos, file_box_rot: the bodies' boxes in the file's bind pose (grounded),
            before the relaxed rest moved any; animations are carried from these.
        mesh: the rig's own skinned mesh bound to the bodies (``import_gltf(mesh=True)``).
    """

    cdef: CreatureDef
    skin: int
    body_node: list[int]
    helpers: list[str] = field(default_factory=list)
    reattached: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    reasons: list[str] = field(default_factory=list)
    joint_world: np.ndarray | None = None
    shift: np.ndarray | None = None
    scale: float = 1.0
    rest_delta: np.ndarray | None = None
    file_box_pos: np.ndarray | None = None
    file_box_rot: np.ndarray | None = None
    relaxed: list[str] = field(default_factory=list)
    mesh: SourceMesh | None = None


def _skin_primitives(gf: GltfFile, skin_index: int, nj: int, notes: list[str]):
    """Every triangle primitive of every mesh node that uses the skin: ``(node, mesh, index,
    primitive, POSITION, joint slots (nv, k), weights (nv, k) normalized)``; a vertex whose
    weights are all zero has weight 0 everywhere."""
    doc = gf.doc
    for ni, node in enumerate(doc.nodes or []):
        if node.skin != skin_index or node.mesh is None:
            continue
        if not (0 <= node.mesh < len(doc.meshes or [])):
            raise gf.error(f"mesh {node.mesh} does not exist", ni, "mesh")
        for pi, prim in enumerate(doc.meshes[node.mesh].primitives):
            attrs = prim.attributes
            if attrs.POSITION is None or attrs.JOINTS_0 is None or attrs.WEIGHTS_0 is None:
                continue
            pos = read_accessor(gf, attrs.POSITION)
            jsets = [read_accessor(gf, attrs.JOINTS_0)]
            wsets = [read_accessor(gf, attrs.WEIGHTS_0, finite=False)]
            extra_j = getattr(attrs, "JOINTS_1", None)
            extra_w = getattr(attrs, "WEIGHTS_1", None)
            if extra_j is not None and extra_w is not None:
                jsets.append(read_accessor(gf, extra_j))
                wsets.append(read_accessor(gf, extra_w, finite=False))
            jj = np.concatenate(jsets, axis=1).astype(np.int64)
            ww = np.concatenate(wsets, axis=1)
            bad = ~np.isfinite(ww)
            if bad.any():  # exporters do write NaN weights (Quaternius' bee): they weigh nothing
                notes.append(f"mesh {node.mesh} primitive {pi}: {int(bad.any(axis=1).sum())} vertices with "
                             "non-finite WEIGHTS_0 taken as weight 0")
                ww = np.where(bad, 0.0, ww)
            if jj.shape[0] != pos.shape[0] or ww.shape[0] != pos.shape[0]:
                raise gf.error(f"mesh {node.mesh} primitive {pi}: JOINTS/WEIGHTS and POSITION counts differ",
                               ni, "attributes")
            used = ww > 0
            if used.any() and (jj[used].min() < 0 or jj[used].max() >= nj):
                raise gf.error(f"mesh {node.mesh} primitive {pi}: JOINTS_0 index out of range for skin "
                               f"{skin_index} ({nj} joints)", ni, "attributes.JOINTS_0")
            jj = np.where(used, jj, 0)
            wsum = ww.sum(axis=1, keepdims=True)
            ok = wsum[:, 0] > 1e-8
            ww = np.where(ok[:, None], ww / np.where(ok[:, None], wsum, 1.0), 0.0)
            yield ni, node.mesh, pi, prim, pos, jj, ww


def _skin_matrices(gf: GltfFile, skin_index: int, world: np.ndarray, joints: list[int]) -> np.ndarray:
    """``W_j @ IBM_j`` of each joint of the skin (nj, 4, 4): what skins a vertex at rest."""
    skin = gf.doc.skins[skin_index]
    nj = len(joints)
    if skin.inverseBindMatrices is not None:
        ibm = read_accessor(gf, skin.inverseBindMatrices)
        if ibm.shape[0] < nj:
            raise GltfError(f"inverseBindMatrices has {ibm.shape[0]} matrices for {nj} joints",
                            path=gf.path, subject=str(skin_index), kind="skin", field="inverseBindMatrices")
    else:
        ibm = np.broadcast_to(np.eye(4), (nj, 4, 4))
    return np.array([world[j] @ ibm[k] for k, j in enumerate(joints)])


def _skinned_vertices(gf: GltfFile, skin_index: int, world: np.ndarray, joints: list[int], notes: list[str],
                      primitives: list | None = None):
    """Rest-skinned vertex positions (glTF world axes) and per-vertex (joint slot, weight).
    ``primitives``: a list that also gets each primitive's ``(mesh, index, primitive, POSITION,
    slots, weights, skinning matrices, skinned positions)`` for every vertex (``_source_mesh``)."""
    skin_mat = _skin_matrices(gf, skin_index, world, joints)
    all_pos, all_slot, all_w = [], [], []
    for _ni, mi, pi, prim, pos, jj, ww in _skin_primitives(gf, skin_index, len(joints), notes):
        ok = ww.sum(axis=1) > 0
        hom = np.concatenate([pos, np.ones((len(pos), 1))], axis=1)
        mats = np.einsum("vk,vkab->vab", ww, skin_mat[jj])  # (nv, 4, 4)
        skinned = np.einsum("vab,vb->va", mats, hom)[:, :3]
        if primitives is not None:
            primitives.append((mi, pi, prim, pos, jj, ww, mats, skinned))
        all_pos.append(skinned[ok])
        all_slot.append(jj[ok])
        all_w.append(ww[ok])
    if not all_pos:
        return np.zeros((0, 3)), np.zeros((0, 4), np.int64), np.zeros((0, 4))
    width = max(s.shape[1] for s in all_slot)
    pad = [(np.pad(s, ((0, 0), (0, width - s.shape[1]))), np.pad(w, ((0, 0), (0, width - w.shape[1]))))
           for s, w in zip(all_slot, all_w, strict=True)]
    return (np.concatenate(all_pos), np.concatenate([p[0] for p in pad]), np.concatenate([p[1] for p in pad]))


@dataclass
class SourceMesh:
    """A rig's own skinned mesh carried to export, bound to the creature's bodies.

    Menagerie axes and metres, the import's scale and grounding applied, at the file's
    bind pose. ``joints``/``weights`` (nv, 4): bodies and weights (summed where several of
    the file's joints became one body or a helper bone's weight went to its kept ancestor,
    the four heaviest kept, normalized; a vertex no joint weighs follows the root).
    ``primitives``: (first index, index count, material) per primitive, triangles.
    ``materials``: the file's materials, their factors kept and textures dropped.
    ``bind_pos``/``bind_rot``: each body's box pose at the bind pose (the inverse bind
    matrices of an export come from these). Bodies are indexed as in ``body_names`` (the
    definition's order; an export matches them to the creature's bodies by name).
    """

    positions: np.ndarray
    normals: np.ndarray | None
    joints: np.ndarray
    weights: np.ndarray
    indices: np.ndarray
    primitives: list[tuple[int, int, int]]
    materials: list[dict]
    bind_pos: np.ndarray
    bind_rot: np.ndarray
    body_names: list[str]
    notes: list[str] = field(default_factory=list)


_MATERIAL_KEYS = ("name", "doubleSided", "alphaMode", "alphaCutoff", "emissiveFactor")
_PBR_KEYS = ("baseColorFactor", "metallicFactor", "roughnessFactor")


def _source_mesh(gf: GltfFile, skinned_prims: list, slot_body: np.ndarray, scale: float, shift: np.ndarray,
                 bind_pos: np.ndarray, bind_rot: np.ndarray, body_names: list[str]) -> SourceMesh | None:
    """The skin's triangle primitives (as ``_skinned_vertices`` skinned them at rest) as one
    ``SourceMesh`` (see there); None without any."""
    C = GLTF_TO_MENAGERIE
    notes: list[str] = []
    nb = int(slot_body.max()) + 1
    pos_all, nrm_all, jnt_all, wgt_all, idx_all, prims, mat_of = [], [], [], [], [], [], {}
    has_normals = True
    nv = 0
    n_index = 0
    dropped_tex = False
    for mi, pi, prim, pos, jj, ww, mats, skinned in skinned_prims:
        mode = prim.mode if prim.mode is not None else 4
        if mode != 4:
            notes.append(f"mesh {mi} primitive {pi}: mode {mode} is not triangles; left out")
            continue
        body = slot_body[jj]                                   # (nv, k)
        acc = np.zeros((len(pos), nb))
        np.add.at(acc, (np.repeat(np.arange(len(pos)), jj.shape[1]), body.ravel()), ww.ravel())
        none = acc.sum(axis=1) <= 0
        acc[none, 0] = 1.0
        top = np.argsort(-acc, axis=1)[:, :4]
        w4 = np.take_along_axis(acc, top, axis=1)
        w4 /= w4.sum(axis=1, keepdims=True)
        top = np.where(w4 > 0, top, 0)
        p_g = np.where(none[:, None], pos, skinned)          # a vertex no joint weighs stays put
        pos_all.append(scale * (p_g @ C.T) + shift)
        if prim.attributes.NORMAL is not None and has_normals:
            n = read_accessor(gf, prim.attributes.NORMAL)
            rot = np.where(none[:, None, None], np.eye(3), mats[:, :3, :3])
            n_g = np.einsum("vab,vb->va", rot, n)
            n_m = n_g @ C.T
            nrm_all.append(n_m / np.maximum(np.linalg.norm(n_m, axis=1, keepdims=True), 1e-12))
        else:
            has_normals = False
        jnt_all.append(top)
        wgt_all.append(w4)
        if prim.indices is not None:
            idx = read_accessor(gf, prim.indices).astype(np.int64).ravel()
            if idx.size and (idx.min() < 0 or idx.max() >= len(pos)):
                raise GltfError(f"mesh {mi} primitive {pi}: an index is out of range ({len(pos)} vertices)",
                                path=gf.path, subject=str(mi), kind="mesh", field="indices")
        else:
            idx = np.arange(len(pos), dtype=np.int64)
        idx = idx[: len(idx) - len(idx) % 3]
        idx_all.append(idx + nv)
        m = prim.material
        if m is not None and m not in mat_of:
            src = (gf.doc.materials or [])[m] if 0 <= m < len(gf.doc.materials or []) else {}
            out = {k: src[k] for k in _MATERIAL_KEYS if k in src}
            pbr = src.get("pbrMetallicRoughness") or {}
            out["pbrMetallicRoughness"] = {k: pbr[k] for k in _PBR_KEYS if k in pbr}
            dropped_tex |= any(k.endswith("Texture") for k in list(src) + list(pbr))
            mat_of[m] = out
        prims.append((n_index, len(idx), -1 if m is None else m))
        n_index += len(idx)
        nv += len(pos)
    if not pos_all:
        return None
    if dropped_tex:
        notes.append("textures are not carried to the export (material factors are)")
    order = sorted(mat_of)
    remap = {m: k for k, m in enumerate(order)}
    materials = [mat_of[m] for m in order]
    if any(p[2] < 0 for p in prims):
        materials.append({"name": "default", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}})
    default = len(materials) - 1
    prims = [(a, b, remap[m] if m >= 0 else default) for a, b, m in prims]
    return SourceMesh(positions=np.concatenate(pos_all), normals=np.concatenate(nrm_all) if has_normals else None,
                      joints=np.concatenate(jnt_all), weights=np.concatenate(wgt_all),
                      indices=np.concatenate(idx_all), primitives=prims, materials=materials,
                      bind_pos=np.asarray(bind_pos, float).copy(), bind_rot=np.asarray(bind_rot, float).copy(),
                      body_names=list(body_names), notes=notes)


def _menagerie_extras(doc, body_node: list[int]) -> list[dict] | None:
    """Each body node's ``extras.menagerie`` when every one has it (a Menagerie export)."""
    out = []
    for j in body_node:
        extras = doc.nodes[j].extras if j >= 0 else None
        m = extras.get("menagerie") if isinstance(extras, dict) else None
        if not (isinstance(m, dict) and {"caps", "box_offset", "extents"} <= set(m)):
            return None
        out.append(m)
    return out


def _is_below(k: int, r: int, parent: list[int]) -> bool:
    """Whether slot ``k`` is ``r`` or below it in the ``parent`` list."""
    while k >= 0:
        if k == r:
            return True
        k = parent[k]
    return False


def _frame_x_along(d: np.ndarray) -> np.ndarray:
    """A rotation matrix whose X column is the unit vector ``d`` (minimal arc from +X)."""
    from engine.io.bvh_creature import _quat_from_x_to

    return quat_to_matrix(_quat_from_x_to(d))


def _fit_boxes(parent, joint_pos, vert_pos, vert_body, size):
    """Box centre (n,3), rotation matrix (n,3,3) and half-extents (n,3) for every body."""
    n = len(parent)
    children = [[] for _ in range(n)]
    for j in range(1, n):
        if parent[j] >= 0:
            children[parent[j]].append(j)
    min_half = MIN_HALF_FRACTION * size
    centre = np.zeros((n, 3))
    rot = np.zeros((n, 3, 3))
    half = np.zeros((n, 3))
    axis = np.zeros((n, 3))
    length = np.zeros(n)
    eps = 1e-6 * size
    for j in range(n):
        p = joint_pos[j]
        verts = vert_pos[vert_body == j]
        kids = [joint_pos[c] - p for c in children[j] if np.linalg.norm(joint_pos[c] - p) > eps]
        if kids:
            mean = np.mean(kids, axis=0)
            d = mean if np.linalg.norm(mean) > eps else max(kids, key=np.linalg.norm)
        elif len(verts) >= MIN_BOX_VERTICES:
            rel = verts - p
            c = rel.mean(axis=0)
            if np.linalg.norm(c) > eps:
                d = c
            else:
                _, _, vt = np.linalg.svd(rel - c, full_matrices=False)
                d = vt[0]
        elif parent[j] >= 0 and length[parent[j]] > eps:
            d = axis[parent[j]]
        else:
            d = np.array([0.0, 0.0, 1.0])
        d = d / np.linalg.norm(d)
        if parent[j] < 0 and kids and len(kids) > 1:
            r = np.eye(3)  # a root with several children: a box along the character axes
        else:
            r = _frame_x_along(d)
        bone = max((float(np.linalg.norm(k)) for k in kids), default=0.0)
        if bone <= eps and parent[j] >= 0:
            bone = 0.5 * length[parent[j]]
        if len(verts) >= MIN_BOX_VERTICES:
            local = (verts - p) @ r
            lo = np.percentile(local, 2, axis=0)
            hi = np.percentile(local, 98, axis=0)
        else:
            pts = np.array([np.zeros(3)] + [k @ r for k in kids] + ([bone * np.array([1.0, 0, 0])] if not kids else []))
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            h = max(0.15 * bone, min_half)
            mid = 0.5 * (lo + hi)
            lo = np.minimum(lo, mid - h)
            hi = np.maximum(hi, mid + h)
        ext = np.maximum(0.5 * (hi - lo), min_half)
        centre[j] = p + r @ (0.5 * (lo + hi))
        rot[j] = r
        half[j] = ext
        axis[j] = d
        length[j] = bone
    return centre, rot, half


def import_gltf(path: str | os.PathLike, skin: int | None = None, caps_table: dict | None = None,
                scale: float | None = None, name: str | None = None, caps_from: str = "shape",
                rest: str = "relaxed", mesh: bool = False) -> GltfImport:
    """Read a rig and make its creature definition (see the module docstring).

    Args:
        skin: index of the skin to import; None picks the one with the most joints.
        caps_table: extra ``{regex: [caps]}`` name patterns (``engine.io.load_caps_table``).
        scale: multiplies positions after the node hierarchy (default 1: glTF is metres).
        name: the creature's name (default: the file's stem).
        caps_from: ``"shape"`` (geometry first, names as a hint) or ``"names"`` (the name
            table alone, as the BVH importer used to).
        rest: ``"relaxed"`` (arms of a T- or A-pose hang down, ``engine.model.rest_pose``)
            or ``"file"`` (the file's bind pose as it is).
        mesh: also carry the rig's own skinned mesh, bound to the bodies, in
            ``GltfImport.mesh`` (for export; costs a second pass over the vertices).
    """
    from engine.model.builder import build_creature
    from engine.model.shape_caps import find_caps

    gf = load_gltf(path)
    doc = gf.doc
    path = gf.path
    auto = scale is None
    scale = 1.0 if auto else float(scale)
    if not (np.isfinite(scale) and scale > 0):
        raise GltfError(f"scale must be a positive number, got {scale!r}", path=path, field="scale")
    skins = doc.skins or []
    if not skins:
        raise GltfError("the file has no skin (no skeleton to import)", path=path, field="skins")
    if skin is None:
        skin = max(range(len(skins)), key=lambda k: len(skins[k].joints or []))
    if not (0 <= skin < len(skins)):
        raise GltfError(f"skin {skin} does not exist (the file has {len(skins)})", path=path, field="skin")
    joints = [int(j) for j in (skins[skin].joints or [])]
    if not joints:
        raise GltfError("skin has no joints", path=path, subject=str(skin), kind="skin", field="joints")
    nnode = len(doc.nodes or [])
    for j in joints:
        if not (0 <= j < nnode):
            raise GltfError(f"joint node {j} does not exist", path=path, subject=str(skin), kind="skin",
                            field="joints")
    if len(set(joints)) != len(joints):
        raise GltfError("a node is listed twice as a joint", path=path, subject=str(skin), kind="skin",
                        field="joints")
    parent_node = node_parents(gf)
    world = world_matrices(gf, parent_node)

    # Deformation per joint: summed weights, then keep joints that deform or have a deforming joint below.
    notes: list[str] = []
    skinned_prims: list | None = [] if mesh else None
    vpos, vslot, vw = _skinned_vertices(gf, skin, world, joints, notes, skinned_prims)
    slot_of = {j: k for k, j in enumerate(joints)}
    weight = np.zeros(len(joints))
    np.add.at(weight, vslot.ravel(), vw.ravel())
    jparent = []  # nearest joint ancestor, as a slot
    skipped = set()
    for j in joints:
        p = parent_node[j]
        while p >= 0 and p not in slot_of:
            skipped.add(p)
            p = parent_node[p]
        jparent.append(slot_of[p] if p >= 0 else -1)
    above = set()
    for j in range(nnode):  # non-joint ancestors above the roots, too
        if j not in slot_of:
            continue
        p = parent_node[j]
        while p >= 0:
            if p not in slot_of:
                above.add(p)
            p = parent_node[p]
    skipped |= above
    deforms = weight > DEFORM_EPS
    if not deforms.any():
        deforms[:] = True  # no mesh weights at all: every joint is a body
    keep = deforms.copy()
    for k in range(len(joints)):
        if deforms[k]:
            p = jparent[k]
            while p >= 0 and not keep[p]:
                keep[p] = True
                p = jparent[p]
    helpers = [doc.nodes[j].name or f"node{j}" for k, j in enumerate(joints) if not keep[k]]

    # Bone ends: the farthest non-joint, mesh-less child node (exporters' ``_end`` bones).
    jpos_g = np.array([world[j][:3, 3] for j in joints])
    tip_g = np.full((len(joints), 3), np.nan)
    for k, j in enumerate(joints):
        ends = [world[c][:3, 3] for c in (doc.nodes[j].children or [])
                if c not in slot_of and doc.nodes[c].mesh is None]
        if ends:
            tip_g[k] = max(ends, key=lambda e: float(np.linalg.norm(e - jpos_g[k])))

    # Detached chains: a deforming chain hung off a root (an IK-driven foot) whose joint sits
    # at the end of another chain's last bone is re-attached there.
    kept = [k for k in range(len(joints)) if keep[k]]
    size_g = float(np.max(np.ptp(jpos_g[kept], axis=0))) if len(kept) > 1 else 1.0
    reattached = []
    roots0 = [k for k in kept if jparent[k] < 0]
    main_root = max(roots0, key=lambda r: sum(1 for k in kept if _is_below(k, r, jparent)))
    for k in kept:
        p = jparent[k]
        if k == main_root or not (p < 0 or p == main_root):
            continue
        best, best_d = -1, 0.05 * size_g
        for leaf in kept:
            if np.isnan(tip_g[leaf, 0]) or _is_below(leaf, k, jparent) or any(
                    jparent[c] == leaf for c in kept):
                continue
            d = float(np.linalg.norm(tip_g[leaf] - jpos_g[k]))
            if d < best_d:
                best, best_d = leaf, d
        if best >= 0:
            jparent[k] = best
            reattached.append(f"{doc.nodes[joints[k]].name} -> {doc.nodes[joints[best]].name}")

    # Bodies in parents-first order over the kept joints.
    kids = {k: [] for k in kept}
    roots = []
    for k in kept:
        (kids[jparent[k]].append(k) if jparent[k] >= 0 else roots.append(k))
    order = []
    stack = list(reversed(roots))
    while stack:
        k = stack.pop()
        order.append(k)
        stack.extend(reversed(kids[k]))

    # Menagerie axes and metres.
    C = GLTF_TO_MENAGERIE
    jw = np.zeros((len(order), 4, 4))
    for b, k in enumerate(order):
        m = world[joints[k]]
        jw[b] = np.eye(4)
        jw[b, :3, :3] = C @ polar_rotation(m[:3, :3]) @ C.T
        jw[b, :3, 3] = scale * (C @ m[:3, 3])
    if auto:  # glTF is metres; a rig far taller than any creature was left in centimetres
        zs = (C @ jpos_g[kept].T)[2]
        if float(np.ptp(zs)) > AUTO_CM_HEIGHT:
            scale = 0.01
            jw[:, :3, 3] *= scale
            notes.append(f"skeleton {float(np.ptp(zs)):.4g} units tall: taken as centimetres (x0.01)")
    joint_pos = jw[:, :3, 3].copy()
    tip = np.array([scale * (C @ tip_g[k]) for k in order])
    body_of_slot = {k: b for b, k in enumerate(order)}
    bparent = np.array([body_of_slot[jparent[k]] if jparent[k] >= 0 else -1 for k in order], np.int64)
    names = [doc.nodes[joints[k]].name or f"node{joints[k]}" for k in order]
    body_node = [joints[k] for k in order]
    if len(roots) > 1:  # a common root at the centroid of the roots
        root_pos = joint_pos[bparent < 0].mean(axis=0)
        cname = GLTF_COMMON_ROOT
        while cname in names:
            cname += "_"
        names = [cname] + names
        bparent = np.concatenate([[-1], np.where(bparent < 0, 0, bparent + 1)])
        joint_pos = np.concatenate([root_pos[None], joint_pos])
        extra = np.eye(4)
        extra[:3, 3] = root_pos
        jw = np.concatenate([extra[None], jw])
        tip = np.concatenate([np.full((1, 3), np.nan), tip])
        body_node = [-1] + body_node
    seen = {}
    for b, nm in enumerate(names):
        if nm in seen:
            raise GltfError(f"two joints are both named {nm!r} (nodes {body_node[seen[nm]]} and {body_node[b]})",
                            path=path, subject=str(body_node[b]), kind="node", field="name")
        seen[nm] = b

    vert = scale * (vpos @ C.T)
    vert_body = np.full(len(vert), -1, np.int64)
    if len(vert):
        wk = vw.copy()
        for col in range(vslot.shape[1]):
            wk[:, col] = np.where(keep[vslot[:, col]], wk[:, col], 0.0)
        heaviest = vslot[np.arange(len(vert)), np.argmax(wk, axis=1)]
        lookup = np.full(len(joints), -1, np.int64)
        for k, b in body_of_slot.items():
            lookup[k] = b + (1 if len(roots) > 1 else 0)
        vert_body = lookup[heaviest]
    pts = np.concatenate([joint_pos, vert]) if len(vert) else joint_pos
    size = float(np.max(np.ptp(pts, axis=0))) if len(pts) > 1 else 1.0
    if size <= 0:
        size = 1.0
    own = _menagerie_extras(doc, body_node)
    if own is not None:
        # Our own export: bodies, boxes and capabilities as they were written, in place.
        rotq = np.array([matrix_to_quat(m[:3, :3]) for m in jw])
        centre = np.array([joint_pos[b] + quat_to_matrix(rotq[b]) @ np.asarray(e["box_offset"], float)
                           for b, e in enumerate(own)])
        half = np.array([e["extents"] for e in own], float)
        names = [str(e.get("body", nm)) for e, nm in zip(own, names, strict=True)]
        caps = [list(e["caps"]) for e in own]
        reasons = ["from the Menagerie export's extras"] * len(names)
        shift = np.zeros(3)
    else:
        centre, rotm, half = _fit_boxes(bparent, joint_pos, vert, vert_body, size)
        rotq = np.array([matrix_to_quat(r) for r in rotm])

        # Stand on the ground, root above the origin.
        from engine.io.bvh_creature import _box_min_z

        shift = np.array([-joint_pos[0, 0], -joint_pos[0, 1], -_box_min_z(centre, rotq, half)])
        joint_pos = joint_pos + shift
        centre = centre + shift
        tip = tip + shift

        caps, reasons = find_caps(names, bparent, joint_pos, centre, rotq, half, caps_table=caps_table,
                                  mode=caps_from, tip=tip)
    rest_delta = np.tile([1.0, 0.0, 0.0, 0.0], (len(names), 1))
    file_box = (centre.copy(), rotq.copy())
    source_mesh = None
    if mesh:
        # Each of the file's joints to a body: a kept joint to its own, a helper bone to its
        # nearest kept ancestor (it deforms nothing, so this only places stray weight).
        offset = 1 if len(roots) > 1 else 0
        slot_body = np.zeros(len(joints), np.int64)
        for k in range(len(joints)):
            a = k
            while a >= 0 and a not in body_of_slot:
                a = jparent[a]
            slot_body[k] = body_of_slot[a] + offset if a >= 0 else 0
        source_mesh = _source_mesh(gf, skinned_prims, slot_body, scale, shift, file_box[0], file_box[1], names)
    relaxed = []
    if rest == "relaxed":
        from engine.io.bvh_creature import _back_on_ground
        from engine.model.rest_pose import relax_arms, relax_legs

        joint_pos, centre, rotq, rest_delta, turned = relax_arms(bparent, caps, joint_pos, centre, rotq)
        relaxed = [f"{names[g]} (turned at {names[sh]}, {ang:.0f} deg from hanging)" for g, sh, ang in turned]
        joint_pos, centre, rotq, rest_delta, legs = relax_legs(bparent, caps, joint_pos, centre, rotq, rest_delta)
        relaxed += [f"{names[f]} (leg turned in under the hip at {names[sh]}, {ang:.0f} deg out before)"
                    for f, sh, ang in legs]
        if turned or legs:
            joint_pos, centre = _back_on_ground(joint_pos, centre, rotq, half)
    elif rest != "file":
        raise GltfError(f"rest must be 'relaxed' or 'file', got {rest!r}", path=path, field="rest")
    if name is None:
        name = os.path.splitext(os.path.basename(path))[0]
    bodies = []
    for b, nm in enumerate(names):
        p = int(bparent[b])
        bodies.append(BodyDef(name=nm, parent=names[p] if p >= 0 else None, caps=caps[b],
                              pos=tuple(float(v) for v in centre[b]), rot=tuple(float(v) for v in rotq[b]),
                              joint=tuple(float(v) for v in joint_pos[b]),
                              extents=tuple(float(v) for v in half[b])))
    note = f"from {os.path.basename(path)}: skin {skin}, {len(names)} bodies"
    if helpers:
        note += f", {len(helpers)} helper bones left out"
    if scale != 1.0:
        note += f", x{scale:.6g}"
    cdef = CreatureDef(name=name, description=note, bodies=bodies, path=path)
    try:
        build_creature(cdef)
    except DataError as exc:
        raise GltfError(f"the imported skeleton is not a valid creature: {exc.reason}", path=path,
                        subject=exc.subject, kind="node") from None
    return GltfImport(cdef=cdef, skin=skin, body_node=body_node, helpers=helpers, reattached=reattached,
                      notes=notes,
                      skipped=sorted(doc.nodes[i].name or f"node{i}" for i in skipped), reasons=reasons,
                      joint_world=jw, shift=shift, scale=scale, rest_delta=rest_delta, relaxed=relaxed,
                      file_box_pos=file_box[0], file_box_rot=file_box[1], mesh=source_mesh)


def rig_mesh_of(creature) -> SourceMesh | None:
    """The own mesh of the glTF rig ``creature`` was made from (``Creature.source``, written
    by ``menagerie creatures from-gltf``), bound to its bodies; None for a creature made
    from no rig. Errors name the creature file and ``source.file`` when the rig is gone or
    its joints no longer match the creature's bodies."""
    src = getattr(creature, "source", None)
    if not src:
        return None
    base = os.path.dirname(os.path.abspath(creature.path)) if creature.path else os.getcwd()
    rig = os.path.normpath(os.path.join(base, src["file"]))
    if not os.path.exists(rig):
        raise GltfError(f"the rig {rig} this creature was made from is not there (bake with --mesh boxes "
                        "for boxes)", path=creature.path, field="source.file")
    imp = import_gltf(rig, skin=src.get("skin"), scale=src.get("scale"), mesh=True)
    if imp.mesh is None:
        return None
    missing = sorted(set(imp.mesh.body_names) ^ set(creature.body_names))
    if missing:
        raise GltfError(f"the creature's bodies no longer match the joints of its rig {rig} (only in one: "
                        f"{', '.join(missing[:6])}); bake with --mesh boxes for boxes", path=creature.path,
                        field="source.file")
    return imp.mesh


def creature_def_from_gltf(path: str | os.PathLike, skin: int | None = None, caps_table: dict | None = None,
                           scale: float | None = None, name: str | None = None, rest: str = "relaxed") -> CreatureDef:
    """A ``CreatureDef`` for the rig in ``path``; arguments as ``import_gltf``."""
    return import_gltf(path, skin=skin, caps_table=caps_table, scale=scale, name=name, rest=rest).cdef


def creature_from_gltf(path: str | os.PathLike, skin: int | None = None, caps_table: dict | None = None,
                       scale: float | None = None, name: str | None = None, rest: str = "relaxed"):
    """The built ``Creature`` for the rig in ``path``; arguments as ``import_gltf``."""
    from engine.model.builder import build_creature

    return build_creature(creature_def_from_gltf(path, skin=skin, caps_table=caps_table, scale=scale, name=name,
                                                 rest=rest))


# -- animations ------------------------------------------------------------------------------


@dataclass
class GltfMotion:
    """One glTF animation sampled as poses of the bodies ``import_gltf`` made (a BVH-like
    clip for the motion-capture tools): ``times`` (nf,) s, ``body_pos`` (nf, nb, 3) world box
    centres, ``body_rot`` (nf, nb, 4) w-first, Menagerie axes, metres, the import's
    grounding applied. ``frame_time`` is the sampling step."""

    name: str
    times: np.ndarray
    body_pos: np.ndarray
    body_rot: np.ndarray

    @property
    def frame_time(self) -> float:
        return float(self.times[1] - self.times[0]) if len(self.times) > 1 else 0.0


def _sample_channel(gf: GltfFile, sampler, times: np.ndarray, path: str, anim_index: int) -> np.ndarray:
    t_in = read_accessor(gf, sampler.input)[:, 0]
    out = read_accessor(gf, sampler.output)
    interp = sampler.interpolation or "LINEAR"
    if len(t_in) == 0 or np.any(np.diff(t_in) <= 0):
        raise GltfError("sampler input times must be strictly increasing", path=gf.path, subject=str(anim_index),
                        kind="animation", field="samplers.input")
    cubic = interp == "CUBICSPLINE"
    if out.shape[0] != len(t_in) * (3 if cubic else 1):
        raise GltfError(f"sampler output has {out.shape[0]} values for {len(t_in)} times ({interp})",
                        path=gf.path, subject=str(anim_index), kind="animation", field="samplers.output")
    t = np.clip(times, t_in[0], t_in[-1])
    k = np.clip(np.searchsorted(t_in, t, side="right") - 1, 0, len(t_in) - 1)
    k1 = np.minimum(k + 1, len(t_in) - 1)
    span = np.where(k1 > k, t_in[k1] - t_in[k], 1.0)
    u = np.where(k1 > k, (t - t_in[k]) / span, 0.0)[:, None]
    if interp == "STEP":
        return out[k]
    if cubic:
        v, a, b = out[1::3], out[0::3], out[2::3]
        u2, u3 = u * u, u * u * u
        res = ((2 * u3 - 3 * u2 + 1) * v[k] + (u3 - 2 * u2 + u) * span[:, None] * b[k]
               + (-2 * u3 + 3 * u2) * v[k1] + (u3 - u2) * span[:, None] * a[k1])
        if path == "rotation":
            res /= np.linalg.norm(res, axis=1, keepdims=True)
        return res
    if path == "rotation":  # slerp, short path (xyzw)
        qa, qb = out[k], out[k1]
        d = np.sum(qa * qb, axis=1, keepdims=True)
        qb = np.where(d < 0, -qb, qb)
        d = np.clip(np.abs(d), -1.0, 1.0)
        th = np.arccos(d)
        sn = np.sin(th)
        small = sn < 1e-9
        wa = np.where(small, 1 - u, np.sin((1 - u) * th) / np.where(small, 1.0, sn))
        wb = np.where(small, u, np.sin(u * th) / np.where(small, 1.0, sn))
        res = wa * qa + wb * qb
        return res / np.linalg.norm(res, axis=1, keepdims=True)
    return out[k] + u * (out[k1] - out[k])


def gltf_motion(path: str | os.PathLike, animation: int | str = 0, fps: float | None = None,
                imported: GltfImport | None = None, **import_args) -> GltfMotion:
    """Sample animation ``animation`` (index or name) of the rig in ``path`` as body poses.

    Times are the animation's own key times (the union over its samplers), or a regular
    ``fps`` grid over its range. Every channel is honoured (LINEAR slerp/lerp, STEP,
    CUBICSPLINE Hermite with normalized rotations), also on non-joint nodes above the
    joints. A body moves rigidly with its joint node: pose(t) = W(t) W_rest^-1 box_rest (the
    box in the file's bind pose). ``imported``: a ``GltfImport`` of the same file to reuse.
    """
    gf = load_gltf(path)
    imp = imported if imported is not None else import_gltf(path, **import_args)
    anims = gf.doc.animations or []
    if isinstance(animation, str):
        names = [a.name for a in anims]
        if animation not in names:
            raise GltfError(f"no animation named {animation!r} (the file has: {', '.join(map(str, names))})",
                            path=gf.path, field="animations")
        animation = names.index(animation)
    if not (0 <= animation < len(anims)):
        raise GltfError(f"animation {animation} does not exist (the file has {len(anims)})", path=gf.path,
                        field="animations")
    anim = anims[animation]
    samplers = anim.samplers or []
    key_times = [read_accessor(gf, s.input)[:, 0] for s in samplers]
    lo = min(float(t[0]) for t in key_times)
    hi = max(float(t[-1]) for t in key_times)
    if fps is not None:
        times = np.arange(int(np.floor((hi - lo) * fps + 1e-9)) + 1) / fps + lo
    else:
        times = np.unique(np.concatenate(key_times))
    parent = node_parents(gf)
    nnode = len(gf.doc.nodes)
    base = []
    for i, node in enumerate(gf.doc.nodes):
        if node.matrix is not None:
            m = node_local_matrix(gf, i)
            r = polar_rotation(m[:3, :3])
            sc = np.linalg.norm(m[:3, :3], axis=0)
            q = matrix_to_quat(r)
            base.append([m[:3, 3].copy(), np.array([q[1], q[2], q[3], q[0]]), sc])
        else:
            base.append([np.asarray(node.translation if node.translation is not None else [0, 0, 0], float),
                         np.asarray(node.rotation if node.rotation is not None else [0, 0, 0, 1], float),
                         np.asarray(node.scale if node.scale is not None else [1, 1, 1], float)])
    tracks = {}
    for ch in anim.channels or []:
        target = ch.target
        if target is None or target.node is None or target.path not in ("translation", "rotation", "scale"):
            continue  # weights (morph targets) and pointers move no joint
        if not (0 <= target.node < nnode) or not (0 <= ch.sampler < len(samplers)):
            raise GltfError("channel points at a missing node or sampler", path=gf.path, subject=str(animation),
                            kind="animation", field="channels")
        tracks[(target.node, target.path)] = _sample_channel(gf, samplers[ch.sampler], times, target.path, animation)
    C = GLTF_TO_MENAGERIE
    nb = len(imp.body_node)
    nf = len(times)
    body_pos = np.zeros((nf, nb, 3))
    body_rot = np.zeros((nf, nb, 4))
    rest_w = imp.joint_world  # Menagerie axes, before the shift
    for f in range(nf):
        local = []
        for i in range(nnode):
            t, r, s = base[i]
            t = tracks.get((i, "translation"), None)[f] if (i, "translation") in tracks else t
            r = tracks.get((i, "rotation"), None)[f] if (i, "rotation") in tracks else r
            s = tracks.get((i, "scale"), None)[f] if (i, "scale") in tracks else s
            local.append(node_local_matrix(gf, i, trs=(t, r, s)))
        world = world_matrices(gf, parent, local)
        for b, j in enumerate(imp.body_node):
            if j < 0:
                w = rest_w[b]
            else:
                w = np.eye(4)
                w[:3, :3] = C @ polar_rotation(world[j][:3, :3]) @ C.T
                w[:3, 3] = imp.scale * (C @ world[j][:3, 3])
            rel = w @ np.linalg.inv(rest_w[b])
            box_rest = np.eye(4)
            box_rest[:3, :3] = quat_to_matrix(imp.file_box_rot[b])
            box_rest[:3, 3] = imp.file_box_pos[b] - imp.shift
            box = rel @ box_rest
            body_pos[f, b] = box[:3, 3] + imp.shift
            body_rot[f, b] = matrix_to_quat(polar_rotation(box[:3, :3]))
    return GltfMotion(name=anim.name or f"animation_{animation}", times=times - lo, body_pos=body_pos,
                      body_rot=body_rot)


def gltf_bvh_clip(path: str | os.PathLike, animation: int | str = 0, fps: float = 30.0, **import_args):
    """Animation ``animation`` of a rig as a ``BvhClip`` on the imported creature's skeleton
    (for the motion-capture tools and the impact library, which read BVH clips), sampled at
    ``fps``. Returns (creature, clip)."""
    from engine.io.bake import recording_to_bvh
    from engine.io.gltf_export import Recording
    from engine.model.builder import build_creature

    imp = import_gltf(path, **import_args)
    motion = gltf_motion(path, animation, fps=fps, imported=imp)
    creature = build_creature(imp.cdef)
    rec = Recording(name=motion.name, fps=fps, body_pos=motion.body_pos, body_rot=motion.body_rot)
    return creature, recording_to_bvh(creature, rec)
