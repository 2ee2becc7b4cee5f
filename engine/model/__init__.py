"""Creatures: the static morphology (``Creature``), its file format and its builder."""

from __future__ import annotations

import os

from engine.model.builder import CreatureWarning, build_creature
from engine.model.caps import CAP_BIT, CAPABILITIES
from engine.model.creature import Creature
from engine.model.definition import FORMAT_VERSION, BodyDef, CreatureDef
from engine.model.fileio import parse_creature_text, read_creature_def, write_creature_def
from engine.model.random import generate_creatures, random_creature_def


def load_creature(path: str | os.PathLike) -> Creature:
    """Load, validate and build a creature file. Errors name the file, line and body."""
    return build_creature(read_creature_def(path))


def creature_from_text(text: str, path: str | None = None) -> Creature:
    """Build a creature from YAML text (``path`` is only used in error messages)."""
    return build_creature(parse_creature_text(text, path))


__all__ = [
    "BodyDef", "CAPABILITIES", "CAP_BIT", "Creature", "CreatureDef", "CreatureWarning",
    "FORMAT_VERSION", "build_creature", "creature_from_text", "load_creature",
    "generate_creatures", "random_creature_def", "read_creature_def", "write_creature_def",
]
