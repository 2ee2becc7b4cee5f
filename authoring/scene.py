"""What the viewer draws, as plain data: actors, debug overlays, a camera. No pyglet here.

A ``Scene`` is a list of ``Actor`` (a Creature, its pose and where it stands in the world)
plus debug overlays (``Points``, ``Segments``, ``Polyline``, ``Label``). Tests, tools and
the demo build scenes; ``authoring.render`` turns one into pixels and ``authoring.viewer``
puts it in a window. Everything here works without an OpenGL context, so framing,
projection and layout are tested in plain numpy.

Conventions are Menagerie's: metres, Z up, X forward, Y left, quaternions (w, x, y, z).
An actor's world point is ``offset + scale * p`` for a point ``p`` of its pose, so a
creature can be moved and uniformly scaled (the zoo does both) without touching its pose.

Body colours (``CAP_COLORS``): a body takes the colour of the first of its capabilities
in ``CAP_PRIORITY``, most specific first, so a head that is also a mouth reads as a head,
a foot that is also a limb as a foot, a tail that is also spine as a tail:

    eye      yellow        head     purple        mouth    red
    ear      pink          grasper  orange        foot     brown
    wing     sky blue      spike    charcoal      tail     teal
    limb     sand          spine    slate blue    detail   sage
    (none)   grey

Faces are lit with a Lambert term from the fixed ``LIGHT_DIR`` (up, front and left of the
creature, so the top, left and front faces seen by the default 3/4 camera get three
distinct shades) over ``AMBIENT``; box edges are drawn in the face colour darkened by
``EDGE_SHADE``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np

from authoring._kernels import pose_bounds, pose_fault
from engine.errors import DataError
from engine.model.caps import CAP_BIT, CAPABILITIES
from engine.model.creature import Creature

# -- palette and lighting ------------------------------------------------------------------

#: Capabilities in the order that picks a body's colour: the first one the body has wins.
CAP_PRIORITY: tuple[str, ...] = (
    "eye", "head", "mouth", "ear", "grasper", "foot",
    "wing", "spike", "tail", "limb", "spine", "detail",
)

#: Body colour per capability, linear RGB in [0, 1].
CAP_COLORS: dict[str, tuple[float, float, float]] = {
    "eye": (0.98, 0.84, 0.12),
    "head": (0.58, 0.40, 0.78),
    "mouth": (0.86, 0.18, 0.20),
    "ear": (0.96, 0.58, 0.70),
    "grasper": (0.98, 0.54, 0.10),
    "foot": (0.52, 0.33, 0.18),
    "wing": (0.45, 0.76, 0.96),
    "spike": (0.30, 0.30, 0.34),
    "tail": (0.16, 0.62, 0.58),
    "limb": (0.84, 0.71, 0.50),
    "spine": (0.33, 0.46, 0.72),
    "detail": (0.62, 0.74, 0.52),
}
#: Colour of a body with no capability.
NO_CAP_COLOR: tuple[float, float, float] = (0.62, 0.62, 0.62)

#: Direction towards the light (unit; up, in front and to the left of the creatures).
LIGHT_DIR = np.array([0.35, 0.6, 1.0]) / np.linalg.norm([0.35, 0.6, 1.0])
#: Fraction of the colour a face turned away from the light still shows.
AMBIENT = 0.42
#: Relative shrink of the boxes of odd tree depth when drawn (see ``Actor.draw_extent``).
DRAW_INSET = 0.004
#: Box edges are the face colour times this.
EDGE_SHADE = 0.42

BACKGROUND_COLOR: tuple[float, float, float] = (0.90, 0.91, 0.93)
GRID_COLOR: tuple[float, float, float] = (0.70, 0.72, 0.76)
GRID_MAJOR_COLOR: tuple[float, float, float] = (0.56, 0.58, 0.63)
GRID_X_AXIS_COLOR: tuple[float, float, float] = (0.80, 0.45, 0.45)
GRID_Y_AXIS_COLOR: tuple[float, float, float] = (0.42, 0.68, 0.42)
JOINT_COLOR: tuple[float, float, float] = (0.10, 0.10, 0.12)
ROOT_COLOR: tuple[float, float, float] = (0.95, 0.95, 0.97)
LINK_COLOR: tuple[float, float, float] = (0.12, 0.12, 0.14)
LABEL_COLOR: tuple[float, float, float] = (0.12, 0.13, 0.16)

#: Default camera direction: azimuth from +X towards +Y and elevation above the ground,
#: radians. Creatures face +X, so this is a 3/4 view from front-left-above.
DEFAULT_AZIMUTH = math.radians(38.0)
DEFAULT_ELEVATION = math.radians(22.0)
DEFAULT_FOV_Y = math.radians(35.0)


class SceneError(DataError):
    """A scene that cannot be drawn: a pose of the wrong shape, a NaN, an unknown colour."""

    def __init__(self, message: str, *, subject: str | None = None, field: str | None = None,
                 kind: str = "actor") -> None:
        super().__init__(message, subject=subject, field=field, kind=kind)


def cap_color(caps_bits: int) -> tuple[float, float, float]:
    """Colour of a body with capability bits ``caps_bits`` (see ``CAP_PRIORITY``)."""
    for name in CAP_PRIORITY:
        if caps_bits & CAP_BIT[name]:
            return CAP_COLORS[name]
    return NO_CAP_COLOR


def body_colors(creature: Creature) -> np.ndarray:
    """Palette colour of each body, ``(nbody, 3)`` float64."""
    return np.array([cap_color(int(b)) for b in creature.body_caps], dtype=np.float64).reshape(-1, 3)


def shade(color, normal) -> np.ndarray:
    """The lit colour of a face with unit ``normal`` (what the renderer computes per vertex)."""
    lam = max(float(np.dot(np.asarray(normal, dtype=np.float64), LIGHT_DIR)), 0.0)
    return np.asarray(color, dtype=np.float64)[:3] * (AMBIENT + (1.0 - AMBIENT) * lam)


assert set(CAP_PRIORITY) == set(CAPABILITIES), "every capability needs a colour priority"


# -- small checks --------------------------------------------------------------------------


def _rgba(color, *, subject, field_name, kind) -> np.ndarray:
    """A colour as float64 RGBA; accepts 3 or 4 components in [0, 1]."""
    try:
        c = np.asarray(color, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise SceneError(f"a colour must be 3 or 4 numbers, got {color!r}",
                         subject=subject, field=field_name, kind=kind) from None
    if c.shape[0] not in (3, 4) or not np.all(np.isfinite(c)) or c.min() < 0.0 or c.max() > 1.0:
        raise SceneError(f"a colour must be 3 or 4 numbers in [0, 1], got {color!r}",
                         subject=subject, field=field_name, kind=kind)
    return np.append(c, 1.0) if c.shape[0] == 3 else c


def _points(value, *, subject, field_name, kind, shape_tail=(3,)) -> np.ndarray:
    """A finite float64 array of shape (n, *shape_tail), copied."""
    try:
        a = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise SceneError(f"expected numbers, got {type(value).__name__}",
                         subject=subject, field=field_name, kind=kind) from None
    if a.ndim == len(shape_tail):
        a = a.reshape((1, *shape_tail)) if a.shape == shape_tail else a
    if a.ndim != len(shape_tail) + 1 or a.shape[1:] != shape_tail:
        want = "(n, " + ", ".join(str(s) for s in shape_tail) + ")"
        raise SceneError(f"expected an array of shape {want}, got {a.shape}",
                         subject=subject, field=field_name, kind=kind)
    bad = np.flatnonzero(~np.all(np.isfinite(a.reshape(a.shape[0], -1)), axis=1))
    if bad.size:
        raise SceneError(f"row {int(bad[0])} is not finite: {a[bad[0]].tolist()}",
                         subject=subject, field=field_name, kind=kind)
    return np.ascontiguousarray(a)


# -- actors ----------------------------------------------------------------------------------


class Actor:
    """A creature in a pose, placed in the world.

    Attributes:
        creature: the ``Creature`` drawn.
        world_positions: ``(nbody, 3)`` float64, body origins (box centres) in the
            creature's own world frame, m; the rest pose by default.
        world_rotations: ``(nbody, 4)`` float64, w-first unit quaternions.
        offset: ``(3,)`` world translation added after scaling, m.
        scale: uniform scale about the world origin applied before ``offset``.
        label: text drawn above the actor (``None``: no label).
        colors: ``(nbody, 3)`` body colours, the capability palette by default.
        show_joints / show_links: draw joint markers and parent links.

    Update the pose every frame with ``set_pose`` (copies into the actor's own arrays,
    no allocation); ``world_positions`` and ``world_rotations`` stay the same objects.
    """

    def __init__(self, creature: Creature, world_positions=None, world_rotations=None, *,
                 offset=(0.0, 0.0, 0.0), scale: float = 1.0, label: str | None = None,
                 colors=None, show_joints: bool = True, show_links: bool = True) -> None:
        if not isinstance(creature, Creature):
            raise SceneError(f"an actor needs a Creature, got {type(creature).__name__}")
        self.creature = creature
        name = creature.name
        n = creature.nbody
        self.world_positions = np.array(creature.body_rest_pos, dtype=np.float64)
        self.world_rotations = np.array(creature.body_rest_rot, dtype=np.float64)
        if world_positions is not None or world_rotations is not None:
            self.set_pose(creature.body_rest_pos if world_positions is None else world_positions,
                          creature.body_rest_rot if world_rotations is None else world_rotations)
        off = _points(offset, subject=name, field_name="offset", kind="actor")
        if off.shape[0] != 1:
            raise SceneError("offset must be 3 numbers", subject=name, field="offset")
        self.offset = off[0]
        if not (isinstance(scale, numbers.Real) and math.isfinite(scale) and scale > 0):
            raise SceneError(f"scale must be a finite number > 0, got {scale!r}",
                             subject=name, field="scale")
        self.scale = float(scale)
        self.label = label
        if colors is None:
            self.colors = body_colors(creature)
        else:
            c = _points(colors, subject=name, field_name="colors", kind="actor")
            if c.shape[0] != n or c.min() < 0.0 or c.max() > 1.0:
                raise SceneError(f"colors must be ({n}, 3) numbers in [0, 1], got shape {c.shape}",
                                 subject=name, field="colors")
            self.colors = c
        self.show_joints = bool(show_joints)
        self.show_links = bool(show_links)
        # Boxes as drawn: every other tree level 0.4 % smaller, so the flush faces of a
        # parent and a child box (a thigh against the side of a pelvis) do not flicker
        # in the depth test. Invisible at any picture size; the pose is untouched.
        shrink = 1.0 - DRAW_INSET * (creature.body_depth % 2)
        self.draw_extent = np.ascontiguousarray(creature.body_extent * shrink[:, None])

    def set_pose(self, world_positions, world_rotations) -> None:
        """Copy a pose in: positions ``(nbody, 3)`` m and rotations ``(nbody, 4)`` (w, x, y, z).

        Raises ``SceneError`` naming the body on a wrong shape, a non-finite value or a
        rotation that is far from unit length (a small drift is normalised when drawn);
        the actor is then back at its rest pose.
        """
        c = self.creature
        n = c.nbody
        p = np.asarray(world_positions)
        r = np.asarray(world_rotations)
        if p.shape != (n, 3):
            raise SceneError(f"world_positions must have shape ({n}, 3), got {p.shape}",
                             subject=c.name, field="world_positions")
        if r.shape != (n, 4):
            raise SceneError(f"world_rotations must have shape ({n}, 4), got {r.shape}",
                             subject=c.name, field="world_rotations")
        np.copyto(self.world_positions, p)
        np.copyto(self.world_rotations, r)
        body, what = pose_fault(self.world_positions, self.world_rotations)
        if body >= 0:
            np.copyto(self.world_positions, c.body_rest_pos)  # never keep a pose we refused
            np.copyto(self.world_rotations, c.body_rest_rot)
            reason = ("position is not finite", "rotation is not finite",
                      "rotation is not unit length (|q| outside [0.9, 1.1])")[what]
            raise SceneError(f"body '{c.body_names[body]}': {reason}", subject=c.name,
                             field="world_positions" if what == 0 else "world_rotations")

    def world_bounds(self, out: np.ndarray | None = None) -> np.ndarray:
        """``(2, 3)`` [min, max] of every box corner in the current pose, in world space
        (into ``out`` when given: no allocation)."""
        if out is None:
            out = np.empty((2, 3))
        pose_bounds(self.world_positions, self.world_rotations, self.creature.body_extent,
                    self.offset, self.scale, out)
        return out

    def __repr__(self) -> str:
        return f"Actor({self.creature.name!r}, offset={self.offset.tolist()}, scale={self.scale:g})"


# -- debug overlays ----------------------------------------------------------------------------


@dataclass
class Points:
    """Markers (IK particles, goals): ``positions (n, 3)`` m, a colour (3 or 4 numbers, or
    ``(n, 3|4)`` per point) and a size in pixels."""

    positions: np.ndarray
    color: object = (0.9, 0.1, 0.1)
    size: float = 8.0
    name: str = "points"

    def __post_init__(self) -> None:
        self.positions = _points(self.positions, subject=self.name, field_name="positions",
                                 kind="overlay")
        self.colors = _colors(self.color, self.positions.shape[0], self.name)
        _check_pixels(self.size, self.name, "size")


@dataclass
class Segments:
    """Line segments (constraints, bones): ``starts (n, 3)`` and ``ends (n, 3)`` m, a colour
    and a width in pixels."""

    starts: np.ndarray
    ends: np.ndarray
    color: object = (0.1, 0.3, 0.9)
    width: float = 2.0
    name: str = "segments"

    def __post_init__(self) -> None:
        self.starts = _points(self.starts, subject=self.name, field_name="starts", kind="overlay")
        self.ends = _points(self.ends, subject=self.name, field_name="ends", kind="overlay")
        if self.starts.shape != self.ends.shape:
            raise SceneError(f"starts {self.starts.shape} and ends {self.ends.shape} differ",
                             subject=self.name, field="ends", kind="overlay")
        self.colors = _colors(self.color, self.starts.shape[0], self.name)
        _check_pixels(self.width, self.name, "width")


@dataclass
class Polyline:
    """A connected line through ``points (n, 3)`` m (a spine spline), a colour and width."""

    points: np.ndarray
    color: object = (0.1, 0.6, 0.2)
    width: float = 2.0
    closed: bool = False
    name: str = "polyline"

    def __post_init__(self) -> None:
        self.points = _points(self.points, subject=self.name, field_name="points", kind="overlay")
        self.colors = _colors(self.color, self.points.shape[0], self.name)
        _check_pixels(self.width, self.name, "width")


@dataclass
class Label:
    """Text drawn centred above the world point ``position`` (3,) m."""

    position: object
    text: str
    color: object = LABEL_COLOR
    name: str = "label"

    def __post_init__(self) -> None:
        p = _points(self.position, subject=self.name, field_name="position", kind="overlay")
        if p.shape[0] != 1:
            raise SceneError("a label has one position", subject=self.name, field="position",
                             kind="overlay")
        self.position = p[0]
        self.text = str(self.text)
        self.rgba = _rgba(self.color, subject=self.name, field_name="color", kind="overlay")


def _colors(color, n: int, name: str) -> np.ndarray:
    """``(n, 4)`` RGBA from one colour or one per item."""
    c = np.asarray(color, dtype=np.float64) if not isinstance(color, str) else None
    if c is not None and c.ndim == 2:
        if c.shape[0] != n or c.shape[1] not in (3, 4):
            raise SceneError(f"per-item colours must have shape ({n}, 3|4), got {c.shape}",
                             subject=name, field="color", kind="overlay")
        return np.stack([_rgba(row, subject=name, field_name="color", kind="overlay") for row in c]) \
            if n else np.zeros((0, 4))
    one = _rgba(color, subject=name, field_name="color", kind="overlay")
    return np.tile(one, (n, 1))


def _check_pixels(value, name: str, field_name: str) -> None:
    """A size or width in pixels: a finite number > 0."""
    if not (isinstance(value, numbers.Real) and math.isfinite(value) and value > 0):
        raise SceneError(f"{field_name} must be a number of pixels > 0, got {value!r}",
                         subject=name, field=field_name, kind="overlay")


# -- the scene -------------------------------------------------------------------------------


@dataclass
class Scene:
    """Everything one picture shows.

    ``camera`` None frames all actors and overlays automatically (``auto_camera``), from
    the direction ``view_azimuth``/``view_elevation`` with field of view ``view_fov``.
    ``caption``: text at the top left of the picture (a demo's "walk, 1.2 m/s"), drawn
    with the labels (``show_labels``).
    ``overlay_hidden_alpha``: skeleton and overlay lines/points hidden behind bodies are
    still drawn at this opacity (0 hides them), so IK particles inside a body stay visible.
    """

    actors: list[Actor] = field(default_factory=list)
    points: list[Points] = field(default_factory=list)
    segments: list[Segments] = field(default_factory=list)
    polylines: list[Polyline] = field(default_factory=list)
    labels: list[Label] = field(default_factory=list)
    camera: Camera | None = None
    show_grid: bool = True
    show_shadows: bool = True
    show_labels: bool = True
    show_edges: bool = True
    caption: str | None = None
    overlay_hidden_alpha: float = 0.3
    background: tuple[float, float, float] = BACKGROUND_COLOR
    view_azimuth: float = DEFAULT_AZIMUTH
    view_elevation: float = DEFAULT_ELEVATION
    view_fov: float = DEFAULT_FOV_Y
    _scratch: np.ndarray = field(default_factory=lambda: np.zeros((4, 3)), init=False,
                                 repr=False, compare=False)

    def auto_camera(self, aspect: float, bounds=None) -> Camera:
        """A camera framing everything (``bounds`` if the caller has them already)."""
        return frame_camera(self.bounds() if bounds is None else bounds, aspect,
                            points=self.frame_points(), azimuth=self.view_azimuth,
                            elevation=self.view_elevation, fov_y=self.view_fov)

    def frame_points(self) -> np.ndarray | None:
        """Points the automatic camera must show: the corners of each actor's world box
        and every overlay point. (Fitting these, not the corners of the whole scene's
        box, frames a diagonal row of creatures tightly.)"""
        parts = []
        for a in self.actors:
            b = a.world_bounds()
            if self.show_shadows and b[0, 2] > 0.0:  # a floating actor: show its shadow too
                b[0, 2] = 0.0
            parts.append(b[0] + BOX_CORNER_SIGNS_01 * (b[1] - b[0]))
        parts += [p.positions for p in self.points] + [s.starts for s in self.segments]
        parts += [s.ends for s in self.segments] + [p.points for p in self.polylines]
        parts += [lab.position[None] for lab in self.labels]
        parts = [p for p in parts if p.shape[0]]
        return np.concatenate(parts) if parts else None

    def add(self, item) -> Scene:
        """Add an actor, a creature (at rest, at the origin) or an overlay; returns self."""
        if isinstance(item, Creature):
            item = Actor(item)
        for kind, bucket in ((Actor, self.actors), (Points, self.points),
                             (Segments, self.segments), (Polyline, self.polylines),
                             (Label, self.labels)):
            if isinstance(item, kind):
                bucket.append(item)
                return self
        raise SceneError(f"cannot add a {type(item).__name__} to a scene", kind="scene")

    def bounds(self) -> np.ndarray | None:
        """``(2, 3)`` world bounds of actors and overlays, or None for an empty scene.

        The array is the scene's own scratch, rewritten by the next call (so a frame
        allocates nothing here); copy it to keep it."""
        out, box = self._scratch[0:2], self._scratch[2:4]
        out[0], out[1] = np.inf, -np.inf
        for a in self.actors:
            a.world_bounds(box)
            np.minimum(out[0], box[0], out=out[0])
            np.maximum(out[1], box[1], out=out[1])
        for group in (self.points, self.segments, self.polylines, self.labels):
            for item in group:
                for p in _overlay_arrays(item):
                    if p.shape[0]:
                        np.min(p, axis=0, out=box[0])
                        np.max(p, axis=0, out=box[1])
                        np.minimum(out[0], box[0], out=out[0])
                        np.maximum(out[1], box[1], out=out[1])
        if not np.isfinite(out[0, 0]):
            return None
        return out


def _overlay_arrays(item) -> tuple[np.ndarray, ...]:
    """The point arrays of an overlay, each (n, 3)."""
    if isinstance(item, Points):
        return (item.positions,)
    if isinstance(item, Segments):
        return (item.starts, item.ends)
    if isinstance(item, Polyline):
        return (item.points,)
    return (item.position.reshape(1, 3),)


# -- geometry helpers (numpy; the renderer's kernels do the same per frame) ----------------------


def quat_to_matrix(q) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of w-first quaternions ``(..., 4)`` (normalised)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1 - 2 * (y * y + z * z)
    m[..., 0, 1] = 2 * (x * y - w * z)
    m[..., 0, 2] = 2 * (x * z + w * y)
    m[..., 1, 0] = 2 * (x * y + w * z)
    m[..., 1, 1] = 1 - 2 * (x * x + z * z)
    m[..., 1, 2] = 2 * (y * z - w * x)
    m[..., 2, 0] = 2 * (x * z - w * y)
    m[..., 2, 1] = 2 * (y * z + w * x)
    m[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return m


#: Corner signs of a box, ``(8, 3)``, and the same as 0/1 (corner = lo + signs01 * size).
BOX_CORNER_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                            dtype=np.float64)
BOX_CORNER_SIGNS_01 = 0.5 * (BOX_CORNER_SIGNS + 1.0)


def box_corners(pos, rot, extent) -> np.ndarray:
    """World corners ``(n, 8, 3)`` of boxes centred at ``pos`` rotated by ``rot``."""
    m = quat_to_matrix(rot)
    local = BOX_CORNER_SIGNS[None, :, :] * np.asarray(extent)[:, None, :]
    return np.asarray(pos)[:, None, :] + np.einsum("nij,nkj->nki", m, local)


# -- camera ------------------------------------------------------------------------------------


@dataclass
class Camera:
    """An orbit camera: looks at ``target`` from ``distance`` m away, from the direction
    given by ``azimuth`` (radians from +X towards +Y) and ``elevation`` (above the ground).
    ``fov_y`` is the vertical field of view; ``near``/``far`` the clip distances (m)."""

    target: np.ndarray = field(default_factory=lambda: np.zeros(3))
    distance: float = 5.0
    azimuth: float = DEFAULT_AZIMUTH
    elevation: float = DEFAULT_ELEVATION
    fov_y: float = DEFAULT_FOV_Y
    near: float = 0.05
    far: float = 100.0

    def __post_init__(self) -> None:
        self.target = np.array(self.target, dtype=np.float64).reshape(3)

    # Camera frame: forward from the eye to the target, right and up on screen.
    def direction(self) -> np.ndarray:
        """Unit vector from the target towards the eye."""
        ce = math.cos(self.elevation)
        return np.array([ce * math.cos(self.azimuth), ce * math.sin(self.azimuth),
                         math.sin(self.elevation)])

    def eye(self) -> np.ndarray:
        return self.target + self.distance * self.direction()

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, back) unit vectors of the view; back points from target to eye."""
        back = self.direction()
        right = np.array([-math.sin(self.azimuth), math.cos(self.azimuth), 0.0])
        up = np.cross(back, right)
        return right, up, back

    def view_matrix(self) -> np.ndarray:
        """World to camera, ``(4, 4)`` row-major (OpenGL convention: camera looks down -z)."""
        right, up, back = self.basis()
        eye = self.eye()
        v = np.eye(4)
        v[0, :3], v[1, :3], v[2, :3] = right, up, back
        v[:3, 3] = -v[:3, :3] @ eye
        return v

    def projection_matrix(self, aspect: float) -> np.ndarray:
        """Perspective projection, ``(4, 4)`` row-major; ``aspect`` = width / height."""
        f = 1.0 / math.tan(self.fov_y / 2.0)
        n, fa = self.near, self.far
        p = np.zeros((4, 4))
        p[0, 0] = f / aspect
        p[1, 1] = f
        p[2, 2] = (fa + n) / (n - fa)
        p[2, 3] = 2.0 * fa * n / (n - fa)
        p[3, 2] = -1.0
        return p

    def view_proj(self, aspect: float) -> np.ndarray:
        return self.projection_matrix(aspect) @ self.view_matrix()

    def project(self, points, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates ``(n, 2)`` (x right, y down from the top row, as in an image
        array) and camera depth ``(n,)`` (m in front of the eye) of world ``points``."""
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        clip = np.c_[pts, np.ones(len(pts))] @ self.view_proj(width / height).T
        ndc = clip[:, :2] / clip[:, 3:4]
        px = np.empty((len(pts), 2))
        px[:, 0] = (ndc[:, 0] + 1.0) * 0.5 * width
        px[:, 1] = (1.0 - ndc[:, 1]) * 0.5 * height
        return px, clip[:, 3]

    def ray(self, x: float, y: float, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """World ray (origin at the eye, unit direction) through pixel (x right, y down from
        the top row) of a width x height picture: the inverse of ``project``."""
        right, up, back = self.basis()
        tan_v = math.tan(self.fov_y / 2.0)
        nx = 2.0 * x / width - 1.0
        ny = 1.0 - 2.0 * y / height
        d = -back + nx * tan_v * (width / height) * right + ny * tan_v * up
        return self.eye(), d / np.linalg.norm(d)

    # Interactive moves (the window maps mouse drags onto these).
    def orbit(self, d_azimuth: float, d_elevation: float) -> None:
        """Turn around the target; elevation stays within (-89, 89) degrees."""
        self.azimuth = (self.azimuth + d_azimuth) % (2.0 * math.pi)
        lim = math.radians(89.0)
        self.elevation = min(max(self.elevation + d_elevation, -lim), lim)

    def zoom(self, factor: float) -> None:
        """Move towards (factor < 1) or away from (> 1) the target; clip planes follow."""
        factor = min(max(float(factor), 0.05), 20.0)
        self.distance *= factor
        self.near *= factor
        self.far *= factor

    def pan(self, dx_pixels: float, dy_pixels: float, viewport_height: int) -> None:
        """Slide the target so the point under the cursor follows it (dy up is positive)."""
        right, up, _ = self.basis()
        metres_per_pixel = 2.0 * self.distance * math.tan(self.fov_y / 2.0) / max(viewport_height, 1)
        self.target = self.target - (dx_pixels * right + dy_pixels * up) * metres_per_pixel


def frame_camera(bounds, aspect: float, *, points=None, azimuth: float = DEFAULT_AZIMUTH,
                 elevation: float = DEFAULT_ELEVATION, fov_y: float = DEFAULT_FOV_Y,
                 margin: float = 0.08) -> Camera:
    """A camera that shows the whole box ``bounds (2, 3)`` (or, if given, all of
    ``points (n, 3)`` inside it) from the given direction.

    The distance is the smallest at which every point (default: the eight corners) falls
    inside the picture shrunk by ``margin`` (a fraction of each side); then the target is
    slid so the points' picture-space box is centred, and the distance solved again
    (three rounds: the slide is small). ``bounds`` None frames a 2 m box at the origin.
    """
    if bounds is None:
        bounds = np.array([[-1.0, -1.0, 0.0], [1.0, 1.0, 1.0]])
    b = np.asarray(bounds, dtype=np.float64)
    size = np.maximum(b[1] - b[0], 1e-3)
    b = np.stack([b[0], b[0] + size])
    corners = b[0] + BOX_CORNER_SIGNS_01 * size if points is None else \
        np.asarray(points, dtype=np.float64).reshape(-1, 3)
    cam = Camera(target=0.5 * (b[0] + b[1]), azimuth=azimuth, elevation=elevation, fov_y=fov_y)
    tan_v = math.tan(fov_y / 2.0) * (1.0 - 2.0 * margin)
    tan_h = math.tan(fov_y / 2.0) * aspect * (1.0 - 2.0 * margin)
    right, up, back = cam.basis()
    for _ in range(3):
        rel = corners - cam.target
        x, y, z = rel @ right, rel @ up, rel @ back
        # Corner at depth (d - z) in front of the eye: visible if |x| <= tan_h (d - z).
        cam.distance = float(max(np.max(z + np.abs(x) / tan_h), np.max(z + np.abs(y) / tan_v)))
        depth = cam.distance - z
        sx, sy = x / depth, y / depth
        # Shift the target so the projected extent is centred (solved at the mean depth).
        mean_depth = float(np.mean(depth))
        shift_x = 0.5 * (sx.max() + sx.min()) * mean_depth
        shift_y = 0.5 * (sy.max() + sy.min()) * mean_depth
        cam.target = cam.target + shift_x * right + shift_y * up
    rel = corners - cam.target
    z = rel @ back
    radius = float(np.linalg.norm(size)) * 0.5
    cam.near = max(cam.distance - float(z.max()) - radius, cam.distance * 0.01)
    cam.far = cam.distance + radius * 6.0 + cam.distance
    return cam


# -- picking -------------------------------------------------------------------------------------


def pick(scene: Scene, camera: Camera, x: float, y: float, width: int,
         height: int) -> tuple[int, int] | None:
    """(actor index, body index) of the nearest body box under pixel (x, y) (x right, y
    down from the top) of a width x height picture drawn with ``camera``, or None.

    The ray through the pixel is tested against every box in its own frame (the slab
    method: the ray is inside the box where it is inside all three pairs of planes)."""
    origin, direction = camera.ray(x, y, width, height)
    best, best_t = None, math.inf
    for k, a in enumerate(scene.actors):
        # Into the actor's pose frame: p = (world - offset) / scale.
        o = (origin - a.offset) / a.scale
        m = quat_to_matrix(a.world_rotations)  # (n, 3, 3), columns are the box axes
        rel = o[None, :] - a.world_positions
        o_local = np.einsum("nji,nj->ni", m, rel)
        d_local = np.einsum("nji,j->ni", m, direction)
        ext = a.draw_extent
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-ext - o_local) / d_local
            t2 = (ext - o_local) / d_local
        inside = np.abs(o_local) <= ext
        parallel = d_local == 0.0
        t1 = np.where(parallel, np.where(inside, -np.inf, np.inf), t1)
        t2 = np.where(parallel, np.where(inside, np.inf, -np.inf), t2)
        t_near = np.max(np.minimum(t1, t2), axis=1)
        t_far = np.min(np.maximum(t1, t2), axis=1)
        hit = (t_near <= t_far) & (t_far > 0.0)
        if not np.any(hit):
            continue
        t = np.where(hit, np.maximum(t_near, 0.0), np.inf)
        i = int(np.argmin(t))
        if t[i] * a.scale < best_t:  # distances along the world ray
            best, best_t = (k, i), float(t[i] * a.scale)
    return best


def describe_body(creature: Creature, body: int) -> str:
    """One line about a body for people: name, capabilities, parent and box size."""
    parent = int(creature.body_parent[body])
    caps = ", ".join(creature.caps_of(body)) or "no capabilities"
    size = " x ".join(f"{2 * e:.3g}" for e in creature.body_extent[body])
    up = f"child of {creature.body_names[parent]}" if parent >= 0 else "root"
    return f"{creature.name}: {creature.body_names[body]} ({caps}; {up}; box {size} m)"


# -- the ground grid -----------------------------------------------------------------------------


def nice_step(length: float) -> float:
    """The 1-2-5 number (..., 0.1, 0.2, 0.5, 1, 2, ...) nearest above ``length``."""
    length = max(float(length), 1e-9)
    exp = math.floor(math.log10(length))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10.0**exp >= length * 0.999:
            return m * 10.0**exp
    return 10.0 ** (exp + 1)


def grid_spec(bounds) -> tuple[np.ndarray, float, int]:
    """Where the ground grid goes for a scene with world ``bounds`` (or None):
    (centre xy (2,), cell step m, half-count of lines). The grid spans a little more than
    the bounds' footprint, about ten cells across it, centred on a multiple of the step so
    its lines sit at round coordinates (and through the origin when it is under the grid)."""
    if bounds is None:
        bounds = np.array([[-1.0, -1.0, 0.0], [1.0, 1.0, 1.0]])
    b = np.asarray(bounds, dtype=np.float64)
    extent = max(float(np.max(b[1, :2] - b[0, :2])), float(b[1, 2] - b[0, 2]), 1e-3)
    step = nice_step(extent / 10.0)
    half = int(math.ceil((0.5 * extent * 1.6 + step) / step))
    centre = np.round(0.5 * (b[0, :2] + b[1, :2]) / step) * step
    return centre, step, half


# -- many creatures at once ------------------------------------------------------------------------


#: The zoo's camera: higher and narrower than the default, so rows of creatures recede
#: without hiding each other and far rows are not much smaller than near ones.
ZOO_ELEVATION = math.radians(34.0)
ZOO_FOV_Y = math.radians(20.0)
#: Share of a 720-row picture's height two lines of label text take (with some room).
ZOO_LABEL_SHARE = 0.065


def layout_zoo(creatures, *, spacing: float | None = None, columns: int | None = None,
               normalize_size: bool = True, size: float = 1.0, labels: bool = True,
               aspect: float = 16.0 / 9.0) -> Scene:
    """A scene with the creatures at rest on a grid, for one picture of them all.

    Every creature keeps facing +X and is seen from the default 3/4 direction (azimuth
    ``DEFAULT_AZIMUTH``), from ``ZOO_ELEVATION`` above. The grid's rows run across the
    picture (along the camera's right vector) and recede away from it, the first creature
    at the back left, in reading order. Columns are spaced by the widest creature as seen
    on the picture, rows so that one row's creatures and labels clear the row behind;
    ``columns`` (default: what makes the grid about ``aspect`` wide/high on the picture).

    ``normalize_size=True`` scales each creature so the largest side of its rest bounding
    box (height for upright creatures, length for a snake or a centipede) is ``size`` m,
    so a 10 m giant and a 0.1 m mite are drawn the same size; the labels give the true
    size (largest side) under the name. ``normalize_size=False`` keeps true sizes (cells
    fit the largest creature).
    ``spacing`` overrides the column spacing, m (rows scale with it).
    """
    creatures = list(creatures)
    for c in creatures:
        if not isinstance(c, Creature):
            raise SceneError(f"layout_zoo takes Creatures, got {type(c).__name__}", kind="zoo")
    scene = Scene(view_elevation=ZOO_ELEVATION, view_fov=ZOO_FOV_Y)
    if not creatures:
        return scene
    if not (math.isfinite(size) and size > 0):
        raise SceneError(f"size must be > 0 m, got {size!r}", field="size", kind="zoo")
    az, el = scene.view_azimuth, scene.view_elevation
    right = np.array([-math.sin(az), math.cos(az), 0.0])
    away = -np.array([math.cos(az), math.sin(az), 0.0])
    scales = np.array([size / float(np.max(c.size)) if normalize_size else 1.0
                       for c in creatures])
    sizes = np.array([c.size for c in creatures]) * scales[:, None]
    # Extent of each creature across the picture, and its height on the picture (in m
    # at the creature): its vertical side foreshortened plus its depth seen from above.
    across = np.abs(sizes[:, 0] * right[0]) + np.abs(sizes[:, 1] * right[1])
    depth = np.abs(sizes[:, 0] * away[0]) + np.abs(sizes[:, 1] * away[1])
    tall = sizes[:, 2] * math.cos(el) + depth * math.sin(el)
    natural_col = 1.2 * max(float(across.max()), 0.6 * float(np.max(sizes)))
    col_step = spacing if spacing is not None else natural_col
    if not (math.isfinite(col_step) and col_step > 0):
        raise SceneError(f"spacing must be > 0 m, got {spacing!r}", field="spacing", kind="zoo")
    n = len(creatures)
    if columns is not None and (not isinstance(columns, numbers.Integral) or columns < 1):
        raise SceneError(f"columns must be an integer >= 1, got {columns!r}", field="columns",
                         kind="zoo")
    body_row = 1.1 * float(tall.max()) * (col_step / natural_col)

    def row_height(nrow: int) -> float:
        # Labels keep their pixel size while the picture shrinks to fit more rows, so
        # their share of a row grows with the row count: two lines of text take about
        # ZOO_LABEL_SHARE of the picture height per row (capped so rows stay visible).
        if not labels:
            return body_row
        share = min(ZOO_LABEL_SHARE * nrow, 0.7)
        return body_row / (1.0 - share)

    ncol = int(columns) if columns is not None else 1
    if columns is None:
        # Columns that make the grid about `aspect` wide for its height on the picture,
        # then as few as keep the same row count (no lonely last row).
        for _ in range(3):
            nrow = math.ceil(n / ncol)
            ncol = max(1, min(n, round(math.sqrt(n * aspect * row_height(nrow) / col_step))))
        ncol = math.ceil(n / math.ceil(n / ncol))
    nrow = math.ceil(n / ncol)
    row_step = row_height(nrow) / math.sin(el)
    for k, (c, s) in enumerate(zip(creatures, scales, strict=True)):
        row, col = divmod(k, ncol)
        cols_here = min(ncol, n - row * ncol)
        cell_centre = ((col - 0.5 * (cols_here - 1)) * col_step * right
                       + ((nrow - 1) * 0.5 - row) * row_step * away)
        # Stand the creature's footprint centre on the cell centre, feet where they were.
        foot = 0.5 * (c.bounds[0] + c.bounds[1])
        offset = cell_centre - s * np.array([foot[0], foot[1], 0.0])
        label = None
        if labels:
            label = f"{c.name}\n{_metres(float(np.max(c.size)))}" if normalize_size else c.name
        scene.actors.append(Actor(c, offset=offset, scale=float(s), label=label))
    return scene


def _metres(x: float) -> str:
    """A length for a label: 3 significant digits, in m (cm below 0.1 m)."""
    return f"{x * 100:.3g} cm" if x < 0.1 else f"{x:.3g} m"


def scene_for(item) -> Scene:
    """A scene from a Scene (returned as is), an Actor, a Creature or a list of Creatures
    (laid out with ``layout_zoo``, true sizes kept when there is just one)."""
    if isinstance(item, Scene):
        return item
    if isinstance(item, Actor):
        return Scene(actors=[item])
    if isinstance(item, Creature):
        return Scene(actors=[Actor(item)])
    if isinstance(item, (list, tuple)):
        if len(item) == 1 and isinstance(item[0], Creature):
            return Scene(actors=[Actor(item[0])])
        return layout_zoo(item)
    raise SceneError(f"cannot show a {type(item).__name__}: give a Scene, an Actor, a Creature "
                     "or a list of Creatures", kind="scene")
