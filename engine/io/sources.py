"""One loader for every kind of file a creature can come from.

``creature_from_file(path)`` reads a Menagerie creature file (``.yaml``/``.yml``) or turns a
skeleton into a creature through its importer (``.bvh``; glTF when that importer exists),
so tools that take "creatures" (the validation grid, the pose sheet, the viewer) accept
any of them. ``CREATURE_SUFFIXES`` lists what is understood; anything else is an error
naming the file and the suffixes.
"""

from __future__ import annotations

import os

from engine.errors import DataError
from engine.model.creature import Creature

#: File suffixes a creature can be read from, and the importer used for each.
CREATURE_SUFFIXES = {".yaml": "creature file", ".yml": "creature file", ".bvh": "BVH skeleton"}


def creature_from_file(path: str | os.PathLike) -> Creature:
    """The creature in ``path`` (see the module docstring)."""
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lower()
    if suffix in (".yaml", ".yml"):
        from engine.model import load_creature

        return load_creature(path)
    if suffix == ".bvh":
        from engine.io.bvh_creature import creature_from_bvh

        return creature_from_bvh(path)
    known = ", ".join(sorted(CREATURE_SUFFIXES))
    raise DataError(f"not a creature source (known kinds: {known})", path=path)


def is_creature_source(path: str | os.PathLike) -> bool:
    """Whether ``path`` has a suffix ``creature_from_file`` understands."""
    return os.path.splitext(os.fspath(path))[1].lower() in CREATURE_SUFFIXES
