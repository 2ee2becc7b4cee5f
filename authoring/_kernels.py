"""Numba kernels that turn poses into the viewer's vertex arrays, once per frame.

Every kernel writes into a preallocated ``verts (capacity, VERTEX_SIZE) float32`` array
from a given start row, so drawing a frame allocates nothing. One vertex is
``x y z | nx ny nz | r g b a | size``: position (world, m), unit normal (faces; zero for
lines and points), colour, point size in pixels (points only). ``authoring.geometry``
decides where each part goes; ``tests/test_viewer.py`` checks the kernels against the
plain numpy of ``authoring.scene.box_corners``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Floats per vertex: position 3, normal 3, colour 4, point size 1.
VERTEX_SIZE = 11
#: Vertices per box: 6 faces x 2 triangles x 3.
BOX_TRI_VERTS = 36
#: Vertices per box outline: 12 edges x 2.
BOX_EDGE_VERTS = 24


@njit(cache=True)
def _rotation(q, m):
    """Rotation matrix of the (normalised) w-first quaternion q into m (3, 3)."""
    norm = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    w = q[0] / norm
    x = q[1] / norm
    y = q[2] / norm
    z = q[3] / norm
    m[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    m[0, 1] = 2.0 * (x * y - w * z)
    m[0, 2] = 2.0 * (x * z + w * y)
    m[1, 0] = 2.0 * (x * y + w * z)
    m[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    m[1, 2] = 2.0 * (y * z - w * x)
    m[2, 0] = 2.0 * (x * z - w * y)
    m[2, 1] = 2.0 * (y * z + w * x)
    m[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit(cache=True)
def _put(verts, row, p, n0, n1, n2, r, g, b, a, size):
    verts[row, 0] = p[0]
    verts[row, 1] = p[1]
    verts[row, 2] = p[2]
    verts[row, 3] = n0
    verts[row, 4] = n1
    verts[row, 5] = n2
    verts[row, 6] = r
    verts[row, 7] = g
    verts[row, 8] = b
    verts[row, 9] = a
    verts[row, 10] = size


@njit(cache=True)
def pose_fault(body_pos, body_rot):
    """First body whose pose cannot be drawn: (body, what) with what 0 = position not
    finite, 1 = rotation not finite, 2 = |rotation| outside [0.9, 1.1]; (-1, -1) if none."""
    for i in range(body_pos.shape[0]):
        for k in range(3):
            if not np.isfinite(body_pos[i, k]):
                return i, 0
        s = 0.0
        for k in range(4):
            if not np.isfinite(body_rot[i, k]):
                return i, 1
            s += body_rot[i, k] * body_rot[i, k]
        if s < 0.81 or s > 1.21:
            return i, 2
    return -1, -1


@njit(cache=True)
def fill_boxes(body_pos, body_rot, body_extent, body_color, offset, scale, edge_shade,
               verts, tri_start, edge_start):
    """Faces and outlines of each body's box.

    body_pos (n, 3), body_rot (n, 4), body_extent (n, 3) half-extents, body_color (n, 3);
    the world point of a pose point p is offset + scale * p. Writes 36 face vertices per
    body from row ``tri_start`` and 24 edge vertices (colour times ``edge_shade``) from
    row ``edge_start``.
    """
    m = np.empty((3, 3))
    axis = np.empty((3, 3))  # axis[a] = box half-extent vector along local axis a, world
    centre = np.empty(3)
    corner = np.empty((4, 3))
    p0 = np.empty(3)
    p1 = np.empty(3)
    n = body_pos.shape[0]
    for i in range(n):
        _rotation(body_rot[i], m)
        for a in range(3):
            for k in range(3):
                axis[a, k] = m[k, a] * body_extent[i, a] * scale
        for k in range(3):
            centre[k] = offset[k] + scale * body_pos[i, k]
        r = body_color[i, 0]
        g = body_color[i, 1]
        b = body_color[i, 2]

        # Faces: for local axis a and side s, the quad centred at centre + s axis[a],
        # spanned by the other two axes; flat normal s * (column a of the rotation).
        row = tri_start + i * 36
        for a in range(3):
            bb = (a + 1) % 3
            cc = (a + 2) % 3
            for side in range(2):
                s = 2.0 * side - 1.0
                for k in range(3):
                    fc = centre[k] + s * axis[a, k]
                    corner[0, k] = fc + axis[bb, k] + axis[cc, k]
                    corner[1, k] = fc - axis[bb, k] + axis[cc, k]
                    corner[2, k] = fc - axis[bb, k] - axis[cc, k]
                    corner[3, k] = fc + axis[bb, k] - axis[cc, k]
                nx = s * m[0, a]
                ny = s * m[1, a]
                nz = s * m[2, a]
                for t in (0, 1, 2, 0, 2, 3):
                    _put(verts, row, corner[t], nx, ny, nz, r, g, b, 1.0, 0.0)
                    row += 1

        # Edges: the 12 edges, 4 parallel to each local axis.
        row = edge_start + i * 24
        er = r * edge_shade
        eg = g * edge_shade
        eb = b * edge_shade
        for a in range(3):
            bb = (a + 1) % 3
            cc = (a + 2) % 3
            for sb in (-1.0, 1.0):
                for sc in (-1.0, 1.0):
                    for k in range(3):
                        side_k = centre[k] + sb * axis[bb, k] + sc * axis[cc, k]
                        p0[k] = side_k - axis[a, k]
                        p1[k] = side_k + axis[a, k]
                    _put(verts, row, p0, 0.0, 0.0, 0.0, er, eg, eb, 1.0, 0.0)
                    _put(verts, row + 1, p1, 0.0, 0.0, 0.0, er, eg, eb, 1.0, 0.0)
                    row += 2


@njit(cache=True)
def fill_skeleton(body_pos, body_rot, body_joint_offset, body_parent, offset, scale,
                  link_rgba, joint_rgba, root_rgba, joint_size, verts, line_start, point_start):
    """Parent links and joint markers.

    A body's joint in the pose is pos - R(rot) body_joint_offset (the offset is the body
    origin relative to its joint, in its own frame). Each non-root body i adds two link
    segments, parent centre -> joint i -> centre i (4 vertices from ``line_start``, in
    body order, skipping the root), and one marker at its joint; the root's marker sits at
    its centre, 1.5 x larger, in ``root_rgba`` (n markers from ``point_start``).
    """
    m = np.empty((3, 3))
    joint = np.empty(3)
    centre = np.empty(3)
    parent_centre = np.empty(3)
    n = body_pos.shape[0]
    row = line_start
    for i in range(n):
        for k in range(3):
            centre[k] = offset[k] + scale * body_pos[i, k]
        p = body_parent[i]
        if p < 0:
            _put(verts, point_start + i, centre, 0.0, 0.0, 0.0, root_rgba[0], root_rgba[1],
                 root_rgba[2], root_rgba[3], 1.5 * joint_size)
            continue
        _rotation(body_rot[i], m)
        for k in range(3):
            local = (m[k, 0] * body_joint_offset[i, 0] + m[k, 1] * body_joint_offset[i, 1]
                     + m[k, 2] * body_joint_offset[i, 2])
            joint[k] = offset[k] + scale * (body_pos[i, k] - local)
            parent_centre[k] = offset[k] + scale * body_pos[p, k]
        lr = link_rgba[0]
        lg = link_rgba[1]
        lb = link_rgba[2]
        la = link_rgba[3]
        _put(verts, row, parent_centre, 0.0, 0.0, 0.0, lr, lg, lb, la, 0.0)
        _put(verts, row + 1, joint, 0.0, 0.0, 0.0, lr, lg, lb, la, 0.0)
        _put(verts, row + 2, joint, 0.0, 0.0, 0.0, lr, lg, lb, la, 0.0)
        _put(verts, row + 3, centre, 0.0, 0.0, 0.0, lr, lg, lb, la, 0.0)
        row += 4
        _put(verts, point_start + i, joint, 0.0, 0.0, 0.0, joint_rgba[0], joint_rgba[1],
             joint_rgba[2], joint_rgba[3], joint_size)


@njit(cache=True)
def pose_bounds(body_pos, body_rot, body_extent, offset, scale, out):
    """World bounding box [min, max] -> out (2, 3) of every box corner of a pose placed
    at offset + scale * p. A box's extent along world axis k is sum_a |R[k, a]| e_a."""
    m = np.empty((3, 3))
    for k in range(3):
        out[0, k] = np.inf
        out[1, k] = -np.inf
    for i in range(body_pos.shape[0]):
        _rotation(body_rot[i], m)
        for k in range(3):
            half = (abs(m[k, 0]) * body_extent[i, 0] + abs(m[k, 1]) * body_extent[i, 1]
                    + abs(m[k, 2]) * body_extent[i, 2])
            lo = body_pos[i, k] - half
            hi = body_pos[i, k] + half
            if lo < out[0, k]:
                out[0, k] = lo
            if hi > out[1, k]:
                out[1, k] = hi
    for k in range(3):
        out[0, k] = offset[k] + scale * out[0, k]
        out[1, k] = offset[k] + scale * out[1, k]
