"""Context queries: describe which bodies a channel poses, without knowing the creature.

Hecker et al. 2008, section 3.1.1. A query is a filter over a creature's bodies, applied
in this order:

1. **type** - a capability name (``grasper``, ``mouth``, ``spine``...) or ``root``;
   selects every body with that capability (``root`` selects body 0).
2. **spatial constraints** - one per axis, each optional:
   ``x``: front / center / back, ``y``: left / center / right, ``z``: top / center /
   bottom. Each is measured against a box: the character's bounds (``character``,
   the default) or the *setspace*, the bounding box of every body with the query's
   type (``setspace``). The box's midplane splits the axis into two halfspaces; the
   *centre zone* is the band within ``CENTER_ZONE`` of the half-size around the
   midplane: the middle third of the box (so Front/Center/Back are the box's thirds,
   and an upright creature's hands hanging at its sides are "front" and "back" both,
   as the paper's inclusive side constraints intend). ``center`` keeps bodies in the
   centre zone; a side constraint keeps its
   halfspace *and* the centre zone ("the side constraints being inclusive of the
   center zone"), so a creature with one grasper on the sagittal plane still answers
   "the left grasper".
   Character-relative left/right splits at the sagittal plane y = 0 rather than at the
   middle of the bounds: character space is defined so the sagittal plane is y = 0 and
   bodies' sides (``Creature.body_side``) are measured from it, so a creature with one
   arm on its left still calls that arm "left". Setspace left/right uses the setspace
   box like the other axes.
3. **extent** - ``frontmost``, ``backmost``, ``leftmost``, ``rightmost``, ``topmost``,
   ``bottommost``: keeps zero or one body, the furthest in that direction. Ties (within
   ``TIE_TOLERANCE`` of the creature's size) go to the lowest body index, so the answer
   is deterministic.
4. **limb modifier** - ``spine_segment`` walks each selected body up to the spine body
   its limb hangs off (the clavicle/hip approximation); duplicates are merged.

Body coordinates are the rest positions of the body origins (``body_rest_pos``). The
result is an ``int32`` array of body indices in ascending order (deterministic), possibly
empty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.errors import DataError
from engine.model.caps import CAPABILITIES

#: Half-width of the centre zone as a fraction of the box's half-size along the axis
#: (1/3: the centre zone is the middle third of the box).
CENTER_ZONE = 1.0 / 3.0
#: Extent ties: positions closer than this fraction of the creature's largest size are equal.
TIE_TOLERANCE = 1e-9

QUERY_TYPES: tuple[str, ...] = ("root",) + CAPABILITIES
AXIS_ZONES: dict[str, tuple[str, str, str]] = {
    # axis: (positive side, centre, negative side)
    "x": ("front", "center", "back"),
    "y": ("left", "center", "right"),
    "z": ("top", "center", "bottom"),
}
SPACES: tuple[str, ...] = ("character", "setspace")
EXTENTS: dict[str, tuple[int, float]] = {
    # name: (axis, sign): keeps the body maximizing sign * coordinate
    "frontmost": (0, 1.0), "backmost": (0, -1.0),
    "leftmost": (1, 1.0), "rightmost": (1, -1.0),
    "topmost": (2, 1.0), "bottommost": (2, -1.0),
}
LIMB_MODIFIERS: tuple[str, ...] = ("spine_segment",)
_FIELDS = ("type", "x", "y", "z", "x_space", "y_space", "z_space", "extent", "limb")


@dataclass(frozen=True)
class Query:
    """A context query (section 3.1.1). Immutable and hashable.

    Attributes:
        type: a capability name or ``"root"``.
        x, y, z: ``None`` or a zone of that axis (``front|center|back``,
            ``left|center|right``, ``top|center|bottom``).
        x_space, y_space, z_space: ``"character"`` (default) or ``"setspace"``.
        extent: ``None`` or one of ``EXTENTS``.
        limb: ``None`` or ``"spine_segment"``.
    """

    type: str
    x: str | None = None
    y: str | None = None
    z: str | None = None
    x_space: str = "character"
    y_space: str = "character"
    z_space: str = "character"
    extent: str | None = None
    limb: str | None = None

    def __post_init__(self) -> None:
        problem = self.problem()
        if problem is not None:
            field, message = problem
            raise DataError(message, field=field)

    def problem(self) -> tuple[str, str] | None:
        """``(field, message)`` for the first invalid field, or None."""
        if self.type not in QUERY_TYPES:
            return "type", f"unknown query type {self.type!r} (known: {', '.join(QUERY_TYPES)})"
        for axis, zones in AXIS_ZONES.items():
            zone = getattr(self, axis)
            if zone is not None and zone not in zones:
                return axis, f"unknown {axis} zone {zone!r} (known: {', '.join(zones)})"
            space = getattr(self, f"{axis}_space")
            if space not in SPACES:
                return f"{axis}_space", f"unknown space {space!r} (known: {', '.join(SPACES)})"
        if self.extent is not None and self.extent not in EXTENTS:
            return "extent", f"unknown extent {self.extent!r} (known: {', '.join(EXTENTS)})"
        if self.limb is not None and self.limb not in LIMB_MODIFIERS:
            return "limb", f"unknown limb modifier {self.limb!r} (known: {', '.join(LIMB_MODIFIERS)})"
        return None

    # -- evaluation ---------------------------------------------------------------------

    def evaluate(self, creature) -> np.ndarray:
        """Indices (int32, ascending) of the bodies this query selects on ``creature``."""
        if self.type == "root":
            selected = np.zeros(1, np.int32)
            setspace = creature.bounds
        else:
            selected = creature.bodies_with(self.type)
            setspace = creature.cap_bounds[CAPABILITIES.index(self.type)]
        pos = creature.body_rest_pos
        for axis_index, axis in enumerate("xyz"):
            zone = getattr(self, axis)
            if zone is None or len(selected) == 0:
                continue
            space = getattr(self, f"{axis}_space")
            box = setspace if space == "setspace" else creature.bounds
            if axis == "y" and space == "character":
                mid = 0.0
                half = 0.5 * float(box[1, 1] - box[0, 1])
            else:
                mid = 0.5 * float(box[0, axis_index] + box[1, axis_index])
                half = 0.5 * float(box[1, axis_index] - box[0, axis_index])
            band = CENTER_ZONE * half
            d = pos[selected, axis_index] - mid
            positive, center, _negative = AXIS_ZONES[axis]
            if zone == center:
                keep = np.abs(d) <= band
            elif zone == positive:
                keep = d >= -band
            else:
                keep = d <= band
            selected = selected[keep]
        if self.extent is not None and len(selected) > 1:
            axis_index, sign = EXTENTS[self.extent]
            score = sign * pos[selected, axis_index]
            tol = TIE_TOLERANCE * max(float(np.max(creature.size)), 1e-12)
            best = float(score.max())
            selected = selected[np.flatnonzero(score >= best - tol)[:1]]
        if self.limb == "spine_segment" and len(selected):
            selected = np.unique(creature.body_spine_attach[selected])
        return np.ascontiguousarray(selected, dtype=np.int32)

    # -- plain data ---------------------------------------------------------------------

    def to_dict(self) -> dict:
        """The fields that differ from the defaults, as the animation file writes them."""
        out: dict = {"type": self.type}
        for name in _FIELDS[1:]:
            value = getattr(self, name)
            default = "character" if name.endswith("_space") else None
            if value != default:
                out[name] = value
        return out

    @classmethod
    def from_dict(cls, data: dict) -> Query:
        """Build from a mapping; unknown keys and bad values raise ``DataError`` naming the field."""
        if not isinstance(data, dict):
            raise DataError(f"a query must be a mapping, got {type(data).__name__}")
        for key in data:
            if key not in _FIELDS:
                raise DataError(f"unknown query field {key!r} (known: {', '.join(_FIELDS)})", field=key)
        if "type" not in data:
            raise DataError("a query needs a 'type'", field="type")
        return cls(**data)

    def __str__(self) -> str:
        parts = [self.type]
        for axis in "xyz":
            zone = getattr(self, axis)
            if zone is not None:
                space = getattr(self, f"{axis}_space")
                parts.append(zone + ("@setspace" if space == "setspace" else ""))
        if self.extent:
            parts.append(self.extent)
        if self.limb:
            parts.append(self.limb)
        return " ".join(parts)


# -- helpers for game code -----------------------------------------------------------------


def select(creature, type: str, *, front: bool = False, back: bool = False, left: bool = False,
           right: bool = False, top: bool = False, bottom: bool = False, setspace: bool = False,
           extent: str | None = None, limb: str | None = None) -> np.ndarray:
    """Bodies of ``creature`` matching a query built from keywords, e.g.
    ``select(creature, "foot", left=True)`` for "all feet on the left". ``setspace=True``
    measures every given side against the setspace instead of the character."""
    def zone(pos_flag, neg_flag, pos_name, neg_name, axis):
        if pos_flag and neg_flag:
            raise DataError(f"select: both {pos_name} and {neg_name} given", field=axis)
        return pos_name if pos_flag else neg_name if neg_flag else None

    space = "setspace" if setspace else "character"
    q = Query(type=type, x=zone(front, back, "front", "back", "x"),
              y=zone(left, right, "left", "right", "y"), z=zone(top, bottom, "top", "bottom", "z"),
              x_space=space, y_space=space, z_space=space, extent=extent, limb=limb)
    return q.evaluate(creature)


def nearest(creature, query: str | Query, point) -> int:
    """The selected body whose rest position is nearest ``point`` (character space), or -1
    when the query selects nothing; ties go to the lowest index.
    ``query`` is a Query or a type name, e.g. ``nearest(creature, "grasper", fruit)``."""
    q = query if isinstance(query, Query) else Query(type=query)
    bodies = q.evaluate(creature)
    if len(bodies) == 0:
        return -1
    p = np.asarray(point, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise DataError(f"nearest: point must be 3 finite numbers, got {point!r}", field="point")
    d = np.linalg.norm(creature.body_rest_pos[bodies] - p, axis=1)
    return int(bodies[int(np.argmin(d))])
