"""One loader for every kind of file a creature can come from.

``creature_from_file(path)`` reads a Menagerie creature file (``.yaml``/``.yml``) or turns a
skeleton into a creature through its importer (``.bvh``, ``.glb``/``.gltf``),
so tools that take "creatures" (the validation grid, the pose sheet, the viewer) accept
any of them. ``CREATURE_SUFFIXES`` lists what is understood; anything else is an error
naming the file and the suffixes.
"""

from __future__ import annotations

import os

from engine.errors import DataError
from engine.model.creature import Creature

#: File suffixes a creature can be read from, and the importer used for each.
CREATURE_SUFFIXES = {".yaml": "creature file", ".yml": "creature file", ".bvh": "BVH skeleton",
                     ".glb": "glTF rig", ".gltf": "glTF rig"}


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
    if suffix in (".glb", ".gltf"):
        from engine.io.gltf import creature_from_gltf

        return creature_from_gltf(path)
    known = ", ".join(sorted(CREATURE_SUFFIXES))
    raise DataError(f"not a creature source (known kinds: {known})", path=path)


def is_creature_source(path: str | os.PathLike) -> bool:
    """Whether ``path`` has a suffix ``creature_from_file`` understands."""
    return os.path.splitext(os.fspath(path))[1].lower() in CREATURE_SUFFIXES


def explain_creature_source(path: str | os.PathLike, caps_table: dict | None = None) -> str:
    """A text report of what an importer found in a skeleton file: counts, then each
    body's capabilities and the reason (``menagerie creatures explain``)."""
    from engine.model.builder import build_creature

    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lower()
    extra = []
    if suffix in (".glb", ".gltf"):
        from engine.io.gltf import import_gltf

        imp = import_gltf(path, caps_table=caps_table)
        cdef, reasons = imp.cdef, imp.reasons
        extra += [f"note: {n}" for n in imp.notes]
        if imp.helpers:
            extra.append(f"helper bones left out (deform nothing): {', '.join(imp.helpers)}")
        if imp.reattached:
            extra.append(f"detached chains re-attached: {', '.join(imp.reattached)}")
        if imp.relaxed:
            extra.append(f"arms swung down to a relaxed rest: {', '.join(imp.relaxed)}")
    elif suffix == ".bvh":
        from engine.io.bvh_creature import creature_def_from_bvh_explained

        cdef, reasons = creature_def_from_bvh_explained(path, caps_table=caps_table)
    else:
        raise DataError("explain reads skeleton files (.bvh, .glb, .gltf)", path=path)
    creature = build_creature(cdef)
    k = creature.counts()
    lines = [f"{path}: {creature!r}",
             "  " + ", ".join(f"{key} {value}" for key, value in k.items())]
    lines += ["  " + e for e in extra]
    width = max(len(b.name) for b in cdef.bodies)
    for b, why in zip(cdef.bodies, reasons, strict=True):
        lines.append(f"  {b.name:<{width}}  {','.join(b.caps):<18} {why}")
    return "\n".join(lines)
