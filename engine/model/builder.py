"""Validate a ``CreatureDef`` and build the immutable ``Creature``.

Steps, in order:
1. per-body checks (names, caps, numbers, extents, quaternions) with the body's line;
2. the tree: parents exist, exactly one authored root, no cycles;
3. the spine: at least one spine body, and the spine bodies form one serial chain;
4. the root: the spine body with the most legs hanging off it, ties broken by the
   horizontal distance to the centre of the feet (or of the whole creature), then by
   authored order (Hecker et al. 2008, section 1.2);
5. re-root there and order the bodies depth first, parents before children;
6. derive everything ``Creature`` lists.

Non-unit rotations: a rotation whose norm is within 1e-6 of 1 is normalised silently (it
is rounding); one further off is normalised with a ``CreatureWarning`` naming the file,
line and body, since a slightly denormalised quaternion from a tool is common and its
meaning is clear. A zero or non-finite rotation is an error.
"""

from __future__ import annotations

import warnings

import numpy as np

from engine.errors import CreatureError
from engine.model.caps import CAP_BIT, CAPABILITIES, FOOT, SPINE, caps_to_bits
from engine.model.creature import Creature
from engine.model.definition import BodyDef, CreatureDef

#: Bodies whose |y| is below this fraction of the character's size lie on the sagittal plane.
SIDE_TOLERANCE = 1e-3


class CreatureWarning(UserWarning):
    """Something in a creature file was accepted after a fix-up (e.g. a normalised rotation)."""


# -- small numpy quaternion helpers (build time only) ------------------------------------


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ])


def _qconj(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _qrot(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate v by q; q (..., 4) and v (..., 3) broadcast. v' = v + w t + u x t, t = 2 u x v."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    vx, vy, vz = v[..., 0], v[..., 1], v[..., 2]
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return np.stack([vx + w * tx + (y * tz - z * ty),
                     vy + w * ty + (z * tx - x * tz),
                     vz + w * tz + (x * ty - y * tx)], axis=-1)


def _qcanon(q: np.ndarray) -> np.ndarray:
    """The same rotation with w >= 0, so relative rotations compare stably."""
    return -q if q[0] < 0.0 else q


# -- build -------------------------------------------------------------------------------


def build_creature(cdef: CreatureDef) -> Creature:
    """Validate ``cdef`` and return the ``Creature``; raises ``CreatureError`` naming the body."""
    path = cdef.path
    bodies = cdef.bodies
    if not bodies:
        raise CreatureError("a creature needs at least one body", path=path)

    def fail(msg: str, body: BodyDef | None = None, field: str | None = None):
        line = None
        if body is not None:
            line = getattr(body, "_field_lines", {}).get(field, body.line) or None
        raise CreatureError(msg, path=path, line=line,
                            subject=body.name if body is not None else None, field=field)

    # 1. per-body checks ---------------------------------------------------------------
    index: dict[str, int] = {}
    caps = np.zeros(len(bodies), np.uint32)
    pos = np.zeros((len(bodies), 3))
    rot = np.zeros((len(bodies), 4))
    joint = np.zeros((len(bodies), 3))
    extent = np.zeros((len(bodies), 3))
    for i, b in enumerate(bodies):
        if not isinstance(b.name, str) or not b.name:
            fail(f"body {i} has no name", b, "name")
        if b.name in index:
            first = bodies[index[b.name]]
            fail(f"duplicate body name (first defined at line {first.line})", b, "name")
        index[b.name] = i
        for c in b.caps:
            if c not in CAP_BIT:
                fail(f"unknown capability '{c}' (known: {', '.join(CAPABILITIES)})", b, "caps")
        caps[i] = caps_to_bits(b.caps)
        for field, value, n in (("pos", b.pos, 3), ("rot", b.rot, 4), ("extents", b.extents, 3),
                                ("joint", b.joint if b.joint is not None else b.pos, 3)):
            arr = np.asarray(value, dtype=float) if _is_numeric_seq(value, n) else None
            if arr is None:
                fail(f"expected {n} numbers, got {value!r}", b, field)
            if not np.all(np.isfinite(arr)):
                fail(f"non-finite number in {list(value)}", b, field)
        pos[i] = b.pos
        joint[i] = b.joint if b.joint is not None else b.pos
        extent[i] = b.extents
        if np.any(extent[i] <= 0.0):
            fail(f"box half-extents must be > 0, got {list(b.extents)}", b, "extents")
        q = np.asarray(b.rot, dtype=float)
        norm = float(np.linalg.norm(q))
        if norm < 1e-9:
            fail("rotation quaternion has zero length", b, "rot")
        if abs(norm - 1.0) > 1e-6:
            line = getattr(b, "_field_lines", {}).get("rot", b.line)
            warnings.warn(
                f"{path or cdef.name}:{line}: body '{b.name}' field 'rot': quaternion norm is "
                f"{norm:.6g}, normalised", CreatureWarning, stacklevel=2)
        # Leave rotations that are unit to rounding as authored, so save/load round-trips
        # bit for bit; divide the others by their norm.
        rot[i] = q if abs(norm - 1.0) <= 8 * np.finfo(float).eps else q / norm

    # 2. the tree ----------------------------------------------------------------------
    n = len(bodies)
    parent0 = np.full(n, -1, np.int64)
    roots = []
    for i, b in enumerate(bodies):
        if b.parent is None:
            roots.append(i)
            continue
        if b.parent not in index:
            close = _close(b.parent, index)
            fail(f"unknown parent '{b.parent}'{close}", b, "parent")
        if b.parent == b.name:
            fail("a body cannot be its own parent", b, "parent")
        parent0[i] = index[b.parent]
    for i in range(n):  # cycles: walking up from any body must end at a root
        seen = set()
        j = i
        while j >= 0:
            if j in seen:
                cycle = []
                k = j
                while True:
                    cycle.append(bodies[k].name)
                    k = int(parent0[k])
                    if k == j:
                        break
                fail(f"parent cycle: {' -> '.join(cycle + [bodies[j].name])}", bodies[j], "parent")
            seen.add(j)
            j = int(parent0[j])
    if len(roots) > 1:
        names = ", ".join(f"'{bodies[r].name}' (line {bodies[r].line})" for r in roots)
        fail(f"several bodies have no parent: {names}; a creature is one tree", bodies[roots[1]],
             "parent")
    if not roots:  # unreachable: no root means a cycle, caught above
        fail("no body without a parent")

    adjacency: list[list[int]] = [[] for _ in range(n)]  # authored order kept
    for i in range(n):
        p = int(parent0[i])
        if p >= 0:
            adjacency[p].append(i)
            adjacency[i].append(p)
    # The joint of an edge (parent p, child c) is the child's authored joint point.
    edge_joint: dict[tuple[int, int], np.ndarray] = {}
    for i in range(n):
        p = int(parent0[i])
        if p >= 0:
            edge_joint[(min(i, p), max(i, p))] = joint[i]

    # 3. the spine ---------------------------------------------------------------------
    is_spine = (caps & np.uint32(SPINE)) != 0
    spine = [i for i in range(n) if is_spine[i]]
    if not spine:
        fail("no body has the 'spine' capability; every creature needs a spine", bodies[0], "caps")
    for s in spine:
        neighbours = [j for j in adjacency[s] if is_spine[j]]
        if len(neighbours) > 2:
            fail(f"the spine is not a serial chain: spine body '{bodies[s].name}' joins "
                 f"{len(neighbours)} spine bodies ({', '.join(bodies[j].name for j in neighbours)})",
                 bodies[s], "caps")
    component = _spine_component(spine[0], adjacency, is_spine)
    if len(component) != len(spine):
        stray = next(s for s in spine if s not in component)
        fail(f"the spine is not one connected chain: spine body '{bodies[stray].name}' is cut off "
             f"from '{bodies[spine[0]].name}' by non-spine bodies", bodies[stray], "caps")

    # Which spine body each non-spine body hangs off (BFS outward from the spine).
    attach0 = np.full(n, -1, np.int64)
    frontier = list(spine)
    for s in spine:
        attach0[s] = s
    while frontier:
        nxt = []
        for a in frontier:
            for j in adjacency[a]:
                if attach0[j] < 0:
                    attach0[j] = attach0[a]
                    nxt.append(j)
        frontier = nxt

    # 4. the root ----------------------------------------------------------------------
    feet = [i for i in range(n) if (caps[i] & FOOT) and not is_spine[i]]
    legs_on = {s: 0 for s in spine}
    for f in feet:
        legs_on[int(attach0[f])] += 1
    corners = _box_corners(pos, rot, extent)
    lo, hi = corners.min(axis=(0, 1)), corners.max(axis=(0, 1))
    centre = pos[feet].mean(axis=0) if feet else 0.5 * (lo + hi)
    root = min(spine, key=lambda s: (-legs_on[s], round(float(np.hypot(*(pos[s, :2] - centre[:2]))), 9), s))

    # 5. re-root and order depth first, children in authored order ----------------------
    order: list[int] = []
    new_parent_old: dict[int, int] = {root: -1}
    stack = [root]
    while stack:
        a = stack.pop()
        order.append(a)
        kids = [j for j in adjacency[a] if j != new_parent_old[a]]
        for j in kids:
            new_parent_old[j] = a
        stack.extend(reversed(kids))
    old_to_new = {old: new for new, old in enumerate(order)}
    names = tuple(bodies[o].name for o in order)
    body_parent = np.array([old_to_new[new_parent_old[o]] if new_parent_old[o] >= 0 else -1
                            for o in order], np.int32)
    body_caps = caps[order]
    body_pos = pos[order]
    body_rot = rot[order]
    body_extent = extent[order]
    body_joint = np.empty((n, 3))
    for new, old in enumerate(order):
        p = new_parent_old[old]
        body_joint[new] = body_pos[new] if p < 0 else edge_joint[(min(old, p), max(old, p))]
    return _derive(cdef, names, body_parent, body_caps, body_pos, body_rot, body_joint, body_extent)


def _derive(cdef, names, parent, caps, pos, rot, joint, extent) -> Creature:
    """Everything derived from the ordered tree (step 6)."""
    n = len(names)
    is_spine = (caps & np.uint32(SPINE)) != 0

    # Local and root-relative rest transforms.
    local_pos = np.empty((n, 3))
    local_rot = np.empty((n, 4))
    local_joint = np.empty((n, 3))
    joint_offset = np.empty((n, 3))
    rootrel_pos = np.empty((n, 3))
    rootrel_rot = np.empty((n, 4))
    rootrel_joint = np.empty((n, 3))
    root_inv = _qconj(rot[0])
    for i in range(n):
        p = parent[i]
        if p < 0:
            local_pos[i], local_rot[i], local_joint[i] = pos[i], rot[i], joint[i]
        else:
            inv = _qconj(rot[p])
            local_pos[i] = _qrot(inv, pos[i] - pos[p])
            local_rot[i] = _qcanon(_qmul(inv, rot[i]))
            local_joint[i] = _qrot(inv, joint[i] - pos[p])
        joint_offset[i] = _qrot(_qconj(rot[i]), pos[i] - joint[i])
        rootrel_pos[i] = _qrot(root_inv, pos[i] - pos[0])
        rootrel_rot[i] = _qcanon(_qmul(root_inv, rot[i]))
        rootrel_joint[i] = _qrot(root_inv, joint[i] - pos[0])

    # Tree bookkeeping.
    depth = np.zeros(n, np.int32)
    child_num = np.zeros(n, np.int32)
    for i in range(1, n):
        depth[i] = depth[parent[i]] + 1
        child_num[parent[i]] += 1
    child_adr = np.zeros(n, np.int32)
    child_adr[1:] = np.cumsum(child_num)[:-1]
    child_list = np.zeros(max(n - 1, 0), np.int32)
    fill = child_adr.copy()
    for i in range(1, n):
        child_list[fill[parent[i]]] = i
        fill[parent[i]] += 1
    subtree_end = np.arange(1, n + 1, dtype=np.int32)
    for i in range(n - 1, 0, -1):
        subtree_end[parent[i]] = max(subtree_end[parent[i]], subtree_end[i])

    # Spine attachment, limbs and limb lengths.
    spine_attach = np.empty(n, np.int32)
    limb_of = np.full(n, -1, np.int32)
    limb_length = np.zeros(n)
    limb_root, limb_attach = [], []
    for i in range(n):
        if is_spine[i]:
            spine_attach[i] = i
            continue
        p = parent[i]
        spine_attach[i] = spine_attach[p]
        if is_spine[p]:
            limb_of[i] = len(limb_root)
            limb_root.append(i)
            limb_attach.append(p)
        else:
            limb_of[i] = limb_of[p]
            limb_length[i] = limb_length[p] + float(np.linalg.norm(joint[i] - joint[p]))

    spine_chain = _order_spine(parent, is_spine, pos)
    spine_root_index = int(np.flatnonzero(spine_chain == 0)[0])

    # Legs: every foot on a limb, up to its hip.
    leg_foot, leg_hip, leg_len, leg_adr, leg_num, leg_bodies = [], [], [], [], [], []
    for i in range(n):
        if (caps[i] & FOOT) and not is_spine[i]:
            path = []
            j = i
            while not is_spine[j]:
                path.append(j)
                j = parent[j]
            leg_foot.append(i)
            leg_hip.append(j)
            leg_len.append(limb_length[i])
            leg_adr.append(len(leg_bodies))
            leg_num.append(len(path))
            leg_bodies.extend(path)

    # Bounds, sides and mirror partners.
    corners = _box_corners(pos, rot, extent)
    bounds = np.stack([corners.min(axis=(0, 1)), corners.max(axis=(0, 1))])
    ncap = len(CAPABILITIES)
    cap_bounds = np.zeros((ncap, 2, 3))
    cap_count = np.zeros(ncap, np.int32)
    for c, cap in enumerate(CAPABILITIES):
        sel = np.flatnonzero(caps & np.uint32(CAP_BIT[cap]))
        cap_count[c] = len(sel)
        if len(sel):
            cap_bounds[c, 0] = corners[sel].min(axis=(0, 1))
            cap_bounds[c, 1] = corners[sel].max(axis=(0, 1))
    tol = max(1e-9, SIDE_TOLERANCE * float(np.max(bounds[1] - bounds[0])))
    side = np.where(pos[:, 1] > tol, 1, np.where(pos[:, 1] < -tol, -1, 0)).astype(np.int8)
    mirror = np.full(n, -1, np.int32)
    mirrored = pos * np.array([1.0, -1.0, 1.0])
    for i in range(n):
        if side[i] == 0:
            mirror[i] = i
            continue
        d = np.linalg.norm(mirrored - pos[i], axis=1)
        d[caps != caps[i]] = np.inf
        d[side != -side[i]] = np.inf
        j = int(np.argmin(d))
        if d[j] <= 10 * tol:
            mirror[i] = j

    arrays = dict(
        body_parent=parent, body_caps=caps, body_rest_pos=pos, body_rest_rot=rot,
        body_joint=joint, body_extent=extent, body_local_pos=local_pos, body_local_rot=local_rot,
        body_local_joint=local_joint, body_joint_offset=joint_offset,
        body_rootrel_pos=rootrel_pos, body_rootrel_rot=rootrel_rot, body_rootrel_joint=rootrel_joint,
        body_depth=depth, body_subtree_end=subtree_end, body_child_adr=child_adr,
        body_child_num=child_num, child_list=child_list, body_side=side, body_mirror=mirror,
        body_is_spine=is_spine, body_spine_attach=spine_attach, body_limb=limb_of,
        body_limb_length=limb_length,
        spine_chain=spine_chain, limb_root=np.array(limb_root, np.int32),
        limb_attach=np.array(limb_attach, np.int32),
        leg_foot=np.array(leg_foot, np.int32), leg_hip=np.array(leg_hip, np.int32),
        leg_length=np.array(leg_len, float), leg_body_adr=np.array(leg_adr, np.int32),
        leg_body_num=np.array(leg_num, np.int32), leg_bodies=np.array(leg_bodies, np.int32),
        bounds=bounds, cap_bounds=cap_bounds, cap_count=cap_count,
    )
    return Creature(name=cdef.name, description=cdef.description, path=cdef.path,
                    body_names=names, arrays=arrays, spine_root_index=spine_root_index,
                    source=dict(cdef.source) if cdef.source else None)


def _order_spine(parent: np.ndarray, is_spine: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """The spine chain end to end. The root (index 0) has at most two spine children; the
    chain runs from the end of one branch through the root to the end of the other. It is
    oriented so its last body lies further along +X+Z (front/top) than its first."""
    n = len(parent)
    spine_children = [[j for j in range(1, n) if parent[j] == i and is_spine[j]] for i in range(n)]

    def walk(start: int) -> list[int]:
        out = [start]
        while spine_children[out[-1]]:
            out.append(spine_children[out[-1]][0])
        return out

    branches = [walk(c) for c in spine_children[0]]
    if not branches:
        chain = [0]
    elif len(branches) == 1:
        chain = [0] + branches[0]
    else:
        chain = list(reversed(branches[0])) + [0] + branches[1]
    chain_arr = np.array(chain, np.int32)
    axis = np.array([1.0, 0.0, 1.0])
    if len(chain) > 1 and float((pos[chain[-1]] - pos[chain[0]]) @ axis) < 0.0:
        chain_arr = chain_arr[::-1].copy()
    return chain_arr


def _box_corners(pos: np.ndarray, rot: np.ndarray, extent: np.ndarray) -> np.ndarray:
    """The 8 corners of every body box in character space, shape (n, 8, 3)."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    local = signs[None, :, :] * extent[:, None, :]
    return pos[:, None, :] + _qrot(rot[:, None, :], local)


def _spine_component(start: int, adjacency, is_spine) -> set[int]:
    seen = {start}
    stack = [start]
    while stack:
        a = stack.pop()
        for j in adjacency[a]:
            if is_spine[j] and j not in seen:
                seen.add(j)
                stack.append(j)
    return seen


def _is_numeric_seq(value, n: int) -> bool:
    try:
        return len(value) == n and all(
            not isinstance(v, bool) and isinstance(v, (int, float, np.floating, np.integer)) for v in value)
    except TypeError:
        return False


def _close(name: str, index: dict[str, int]) -> str:
    import difflib

    close = difflib.get_close_matches(name, list(index), n=3)
    return f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""


