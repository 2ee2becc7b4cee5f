"""A scene as one vertex array and a list of draw ranges, ready for any renderer.

``SceneGeometry.build(scene)`` writes every vertex a frame needs into one float32 array
(layout in ``authoring._kernels``) and returns ``DrawRange`` records saying which rows are
drawn how. The array grows when a scene needs more rows and is reused otherwise, so a
renderer drawing the same kind of scene every frame allocates no vertex memory after the
first frame. No OpenGL here: tests read the arrays directly.

Order in the array (also the drawing order): ground grid, ground shadows, body faces,
body edges, parent links, overlay lines (one range per overlay, each has its own width),
joint markers, overlay points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from authoring import scene as sc
from authoring._kernels import (
    BOX_EDGE_VERTS,
    BOX_TRI_VERTS,
    VERTEX_SIZE,
    fill_boxes,
    fill_skeleton,
)

#: Kinds of draw ranges; the renderer picks GL state by kind.
GRID, SHADOWS, FACES, EDGES, LINKS, OVERLAY_LINES, JOINTS, OVERLAY_POINTS = (
    "grid", "shadows", "faces", "edges", "links", "overlay_lines", "joints", "overlay_points")

#: Ground shadows: each box's faces flattened onto z = 0 (light straight above), drawn in
#: this colour; the renderer darkens every pixel at most once however many overlap.
SHADOW_RGBA = (0.0, 0.0, 0.05, 0.16)

#: Joint marker size (pixels at 720 rows) and link width.
JOINT_SIZE = 6.0
LINK_WIDTH = 1.0
EDGE_WIDTH = 1.0
GRID_WIDTH = 1.0


@dataclass
class DrawRange:
    """Rows ``[first, first + count)`` of the vertex array, drawn as ``mode``
    ('triangles', 'lines' or 'points') with line ``width`` in pixels at 720 rows."""

    kind: str
    mode: str
    first: int
    count: int
    width: float = 1.0


class SceneGeometry:
    """Reusable vertex storage for drawing scenes (see the module docstring)."""

    def __init__(self) -> None:
        self.verts = np.zeros((1024, VERTEX_SIZE), dtype=np.float32)
        self.count = 0
        self.ranges: list[DrawRange] = []
        self._grid_key = None
        self._grid = np.zeros((0, VERTEX_SIZE), dtype=np.float32)  # cached grid rows
        self._link_rgba = np.array([*sc.LINK_COLOR, 0.85])
        self._joint_rgba = np.array([*sc.JOINT_COLOR, 1.0])
        self._root_rgba = np.array([*sc.ROOT_COLOR, 1.0])

    # -- sizes ---------------------------------------------------------------------------------

    def _reserve(self, rows: int) -> None:
        if rows > self.verts.shape[0]:
            cap = self.verts.shape[0]
            while cap < rows:
                cap *= 2
            self.verts = np.zeros((cap, VERTEX_SIZE), dtype=np.float32)

    def _add(self, kind: str, mode: str, first: int, count: int, width: float = 1.0) -> None:
        """Append a draw range, merged into the previous one when it continues it."""
        if count <= 0:
            return
        if self.ranges:
            last = self.ranges[-1]
            if (last.kind == kind and last.width == width
                    and last.first + last.count == first):
                last.count += count
                return
        self.ranges.append(DrawRange(kind, mode, first, count, width))

    # -- build ---------------------------------------------------------------------------------

    def build(self, scene: sc.Scene, bounds=None) -> list[DrawRange]:
        """Fill ``verts`` for ``scene`` and return the draw ranges. ``bounds`` (2, 3) is the
        scene's bounds if the caller already has them (the grid is sized from them)."""
        actors = scene.actors
        if bounds is None:
            bounds = scene.bounds()
        if scene.show_grid:
            centre, step, half = sc.grid_spec(bounds)
            key = (float(centre[0]), float(centre[1]), step, half)
            if key != self._grid_key:
                self._grid_key = key
                self._grid = grid_vertices(centre, step, half)
        grid_rows = self._grid.shape[0] if scene.show_grid else 0

        # Where each part goes (rows). Edges, links and joints are written for every
        # actor, shown or not; hidden ones are simply left out of the ranges.
        nbody = sum(a.creature.nbody for a in actors)
        nlink = sum(4 * (a.creature.nbody - 1) for a in actors)
        shadow_rows = nbody * BOX_TRI_VERTS if scene.show_shadows else 0
        face_first = grid_rows + shadow_rows
        edge_first = face_first + nbody * BOX_TRI_VERTS
        link_first = edge_first + nbody * BOX_EDGE_VERTS
        oline_first = link_first + nlink
        oline_rows = (sum(2 * s.starts.shape[0] for s in scene.segments)
                      + sum(2 * _polyline_segments(p) for p in scene.polylines))
        joint_first = oline_first + oline_rows
        opoint_first = joint_first + nbody
        total = opoint_first + sum(p.positions.shape[0] for p in scene.points)
        self._reserve(total)
        v = self.verts
        self.ranges.clear()

        if grid_rows:
            v[:grid_rows] = self._grid
            self._add(GRID, "lines", 0, grid_rows, GRID_WIDTH)

        # Boxes and skeletons, actor by actor.
        tri, edge, link, joint = face_first, edge_first, link_first, joint_first
        link_ranges, joint_ranges = [], []
        for a in actors:
            c = a.creature
            nb = c.nbody
            fill_boxes(a.world_positions, a.world_rotations, a.draw_extent, a.colors,
                       a.offset, a.scale, sc.EDGE_SHADE, v, tri, edge)
            fill_skeleton(a.world_positions, a.world_rotations, c.body_joint_offset,
                          c.body_parent, a.offset, a.scale, self._link_rgba, self._joint_rgba,
                          self._root_rgba, JOINT_SIZE, v, link, joint)
            if a.show_links:
                link_ranges.append((link, 4 * (nb - 1)))
            if a.show_joints:
                joint_ranges.append((joint, nb))
            tri += nb * BOX_TRI_VERTS
            edge += nb * BOX_EDGE_VERTS
            link += 4 * (nb - 1)
            joint += nb
        if shadow_rows:
            # Shadows: the face rows again, flattened to just above the ground (lifted by
            # a hair relative to the scene so they never fight the grid in depth).
            extent = 1.0 if bounds is None else float(np.max(bounds[1] - bounds[0]))
            lift = 1e-4 * max(extent, 1e-3)
            sh = v[grid_rows:grid_rows + shadow_rows]
            sh[:] = v[face_first:face_first + shadow_rows]
            sh[:, 2] = lift
            sh[:, 3:6] = 0.0
            sh[:, 6:10] = SHADOW_RGBA
            self._add(SHADOWS, "triangles", grid_rows, shadow_rows)
        self._add(FACES, "triangles", face_first, nbody * BOX_TRI_VERTS)
        if scene.show_edges:
            self._add(EDGES, "lines", edge_first, nbody * BOX_EDGE_VERTS, EDGE_WIDTH)
        for first, count in link_ranges:
            self._add(LINKS, "lines", first, count, LINK_WIDTH)

        # Overlay lines: segments, then polylines, one range each (each has its width).
        row = oline_first
        for s in scene.segments:
            k = s.starts.shape[0]
            block = v[row:row + 2 * k]
            block[0::2, 0:3] = s.starts
            block[1::2, 0:3] = s.ends
            block[0::2, 6:10] = s.colors
            block[1::2, 6:10] = s.colors
            block[:, 3:6] = 0.0
            block[:, 10] = 0.0
            self._add(OVERLAY_LINES, "lines", row, 2 * k, s.width)
            row += 2 * k
        for p in scene.polylines:
            k = _polyline_segments(p)
            n = p.points.shape[0]
            block = v[row:row + 2 * k]
            if k:
                block[0:2 * (n - 1):2, 0:3] = p.points[:-1]
                block[1:2 * (n - 1):2, 0:3] = p.points[1:]
                block[0:2 * (n - 1):2, 6:10] = p.colors[:-1]
                block[1:2 * (n - 1):2, 6:10] = p.colors[1:]
                if k > n - 1:  # closed: the last point back to the first
                    block[-2, 0:3], block[-1, 0:3] = p.points[-1], p.points[0]
                    block[-2, 6:10], block[-1, 6:10] = p.colors[-1], p.colors[0]
                block[:, 3:6] = 0.0
                block[:, 10] = 0.0
            self._add(OVERLAY_LINES, "lines", row, 2 * k, p.width)
            row += 2 * k

        for first, count in joint_ranges:
            self._add(JOINTS, "points", first, count)

        row = opoint_first
        for p in scene.points:
            k = p.positions.shape[0]
            block = v[row:row + k]
            block[:, 0:3] = p.positions
            block[:, 3:6] = 0.0
            block[:, 6:10] = p.colors
            block[:, 10] = p.size
            row += k
        self._add(OVERLAY_POINTS, "points", opoint_first, row - opoint_first)
        self.count = total
        return self.ranges


def _polyline_segments(p: sc.Polyline) -> int:
    n = p.points.shape[0]
    if n < 2:
        return 0
    return n - 1 + (1 if p.closed and n > 2 else 0)


def grid_vertices(centre, step: float, half: int) -> np.ndarray:
    """Lines of the ground grid at z = 0 (see ``scene.grid_spec``), fading out towards its
    rim: each line is two segments whose alpha is 0 at the ends and, at the middle,
    falls with the line's distance from the centre. Every fifth line (counted from the
    world origin) is darker; the lines through the origin are tinted red (X) and green (Y)."""
    cx, cy = float(centre[0]), float(centre[1])
    extent = half * step
    out = []
    for along in (0, 1):  # 0: lines parallel to X (constant y); 1: parallel to Y
        base = cy if along == 0 else cx
        for k in range(-half, half + 1):
            c = base + k * step
            index = int(round(c / step))
            if index == 0:
                color = sc.GRID_X_AXIS_COLOR if along == 0 else sc.GRID_Y_AXIS_COLOR
            elif index % 5 == 0:
                color = sc.GRID_MAJOR_COLOR
            else:
                color = sc.GRID_COLOR
            mid_alpha = (1.0 - abs(k) / (half + 1.0)) ** 0.8
            if along == 0:
                a, m, b = (cx - extent, c), (cx, c), (cx + extent, c)
            else:
                a, m, b = (c, cy - extent), (c, cy), (c, cy + extent)
            for p, q in ((a, m), (m, b)):
                for pt in (p, q):
                    alpha = mid_alpha if pt is m else 0.0
                    out.append([pt[0], pt[1], 0.0, 0.0, 0.0, 0.0, *color, alpha, 0.0])
    return np.asarray(out, dtype=np.float32).reshape(-1, VERTEX_SIZE)
