"""Editable creature definitions: what a creature file holds, before it is built.

A ``CreatureDef`` is plain data with defaults in one place. ``engine.model.builder``
validates it and turns it into the immutable ``Creature`` the runtime uses. Line numbers
from the file ride along so the builder's errors can point at the right line.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: The creature file format this version reads and writes.
FORMAT_VERSION = 1


@dataclass
class BodyDef:
    """One body as authored.

    Positions are in character space (metres, Z up, X forward, Y left).

    Attributes:
        name: unique body name.
        parent: name of the parent body, or None for the authored root. The builder
            re-roots the tree at the spine body the paper's heuristic picks.
        caps: capability names (see ``engine.model.caps.CAPABILITIES``).
        pos: rest position of the body's origin, the centre of its box.
        rot: rest rotation (w, x, y, z); identity by default.
        joint: the point where the body attaches to its parent; defaults to ``pos``.
        extents: box half-extents along the body's local axes, all > 0.
        line: 1-based line of the body's entry in its file (0 when built in code).
    """

    name: str
    parent: str | None = None
    caps: list[str] = field(default_factory=list)
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rot: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    joint: tuple[float, float, float] | None = None
    extents: tuple[float, float, float] = (0.05, 0.05, 0.05)
    line: int = 0


@dataclass
class CreatureDef:
    """A whole creature as authored: a name, a one-line description and its bodies."""

    name: str
    description: str = ""
    bodies: list[BodyDef] = field(default_factory=list)
    path: str | None = None
    format: int = FORMAT_VERSION
    #: The glTF rig the creature was made from (``menagerie creatures from-gltf``):
    #: ``{"file": ..., "skin": N, "scale": K}``, the file relative to the creature file's
    #: folder; an export then carries the rig's own mesh. None for any other creature.
    source: dict | None = None
