"""Creature files: YAML in, YAML out, with errors that name the file, line and body.

File format 1::

    format: 1
    name: humanoid
    description: A 25-body humanoid biped, the benchmark creature.
    bodies:
      - name: pelvis
        caps: [spine]
        pos: [0.0, 0.0, 1.0]        # rest position (box centre), metres, Z up, X forward
        rot: [1.0, 0.0, 0.0, 0.0]   # optional rest rotation (w, x, y, z)
        joint: [0.0, 0.0, 1.0]      # optional attachment point to the parent; default pos
        extents: [0.1, 0.15, 0.08]  # box half-extents in the body frame
      - name: spine1
        parent: pelvis
        ...

Loading never shows a raw yaml or numpy traceback: syntax errors, wrong types and
missing fields become ``CreatureError`` with the file and line. Saving writes every
float with ``repr`` so load(save(c)) rebuilds ``c`` bit for bit.
"""

from __future__ import annotations

import math
import os
from typing import Any

import yaml

from engine.errors import CreatureError
from engine.model.definition import FORMAT_VERSION, BodyDef, CreatureDef

_BODY_FIELDS = ("name", "parent", "caps", "pos", "rot", "joint", "extents")
_TOP_FIELDS = ("format", "name", "description", "source", "bodies")


# -- YAML with line numbers --------------------------------------------------------------


class _Located:
    """A plain Python value from YAML together with the 1-based line it started on."""

    __slots__ = ("value", "line")

    def __init__(self, value: Any, line: int) -> None:
        self.value = value
        self.line = line


def _to_located(node: yaml.Node, loader: yaml.SafeLoader) -> _Located:
    """Convert a composed YAML node into nested _Located values (mappings keep keys plain)."""
    line = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out: dict[str, _Located] = {}
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            if not isinstance(key, str):
                raise _LocatedError(f"keys must be strings, got {key!r}", key_node.start_mark.line + 1)
            if key in out:
                raise _LocatedError(f"duplicate key '{key}'", key_node.start_mark.line + 1)
            out[key] = _to_located(value_node, loader)
        return _Located(out, line)
    if isinstance(node, yaml.SequenceNode):
        return _Located([_to_located(n, loader) for n in node.value], line)
    return _Located(loader.construct_object(node, deep=True), line)


class _LocatedError(Exception):
    def __init__(self, message: str, line: int) -> None:
        super().__init__(message)
        self.line = line


#: libyaml's loader when PyYAML was built with it (ten times faster), else the pure one.
_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


def read_yaml_located(text: str, path: str | None, error: type = CreatureError) -> _Located:
    """Parse YAML text into _Located values; syntax errors become ``error`` with the line."""
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise error("the file is empty", path=path, line=1)
        return _to_located(node, loader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else None
        raise error(f"YAML syntax error: {exc.problem or exc}", path=path, line=line) from None
    except yaml.YAMLError as exc:
        raise error(f"YAML error: {exc}", path=path) from None
    except _LocatedError as exc:
        raise error(str(exc), path=path, line=exc.line) from None
    finally:
        loader.dispose()


# -- field readers -----------------------------------------------------------------------


def _vector(item: _Located, n: int, *, path, body, field_name) -> tuple[float, ...]:
    value = item.value
    if not isinstance(value, list) or len(value) != n:
        raise CreatureError(
            f"expected a list of {n} numbers, got {_describe(value)}",
            path=path, line=item.line, subject=body, field=field_name,
        )
    out = []
    for element in value:
        v = element.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise CreatureError(
                f"expected a number, got {_describe(v)}",
                path=path, line=element.line, subject=body, field=field_name,
            )
        if not math.isfinite(float(v)):
            raise CreatureError(
                f"non-finite number {v!r}", path=path, line=element.line, subject=body, field=field_name
            )
        out.append(float(v))
    return tuple(out)


def _string(item: _Located, *, path, body, field_name, allow_none=False) -> str | None:
    if item.value is None and allow_none:
        return None
    if not isinstance(item.value, str) or not item.value:
        raise CreatureError(
            f"expected a non-empty string, got {_describe(item.value)}",
            path=path, line=item.line, subject=body, field=field_name,
        )
    return item.value


def _describe(value: Any) -> str:
    if isinstance(value, _Located):
        value = value.value
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "a mapping"
    return f"{type(value).__name__} {value!r}"


# -- load --------------------------------------------------------------------------------


def parse_creature_text(text: str, path: str | None = None) -> CreatureDef:
    """Parse creature YAML text into a ``CreatureDef`` (types checked, not yet validated)."""
    root = read_yaml_located(text, path)
    if not isinstance(root.value, dict):
        raise CreatureError("the top level must be a mapping with 'format', 'name' and 'bodies'",
                            path=path, line=root.line)
    top = root.value
    if "bodies" not in top and ("channels" in top or "length" in top):
        raise CreatureError("this looks like an animation file (it has 'channels' or 'length'), not a creature "
                            "(a creature file has 'bodies'); pass it where an animation is wanted",
                            path=path, line=root.line)
    for key, item in top.items():
        if key not in _TOP_FIELDS:
            raise CreatureError(f"unknown top-level field '{key}' (known: {', '.join(_TOP_FIELDS)})",
                                path=path, line=item.line)
    if "format" not in top:
        raise CreatureError(f"missing 'format: {FORMAT_VERSION}'", path=path, line=root.line)
    fmt = top["format"].value
    if fmt != FORMAT_VERSION:
        raise CreatureError(f"unsupported creature format {fmt!r}; this version reads format {FORMAT_VERSION}",
                            path=path, line=top["format"].line, field="format")
    if "name" not in top:
        raise CreatureError("missing 'name'", path=path, line=root.line)
    name = _string(top["name"], path=path, body=None, field_name="name")
    description = ""
    if "description" in top and top["description"].value is not None:
        if not isinstance(top["description"].value, str):
            raise CreatureError("expected a string", path=path, line=top["description"].line,
                                field="description")
        description = top["description"].value
    if "bodies" not in top:
        raise CreatureError("missing 'bodies'", path=path, line=root.line)
    bodies_item = top["bodies"]
    if not isinstance(bodies_item.value, list) or not bodies_item.value:
        raise CreatureError("'bodies' must be a non-empty list", path=path, line=bodies_item.line,
                            field="bodies")
    bodies = [_parse_body(item, path) for item in bodies_item.value]
    source = _parse_source(top["source"], path) if "source" in top else None
    return CreatureDef(name=name, description=description, bodies=bodies, path=path, source=source)


def _parse_source(item: _Located, path: str | None) -> dict:
    """``source: {file: rig.glb, skin: 0, scale: 1.0}``: the glTF rig the creature came from."""
    if not isinstance(item.value, dict):
        raise CreatureError("'source' must be a mapping with 'file', 'skin' and 'scale'", path=path,
                            line=item.line, field="source")
    known = ("file", "skin", "scale")
    for key, sub in item.value.items():
        if key not in known:
            raise CreatureError(f"unknown field '{key}' in 'source' (known: {', '.join(known)})", path=path,
                                line=sub.line, field=f"source.{key}")
    out = {}
    f = item.value.get("file")
    if f is None or not isinstance(f.value, str) or not f.value:
        raise CreatureError("'source.file' must be the rig's file name", path=path,
                            line=(f or item).line, field="source.file")
    out["file"] = f.value
    skin = item.value.get("skin")
    if skin is not None:
        if not isinstance(skin.value, int) or isinstance(skin.value, bool) or skin.value < 0:
            raise CreatureError(f"'source.skin' must be a skin index (0 or more), got {skin.value!r}", path=path,
                                line=skin.line, field="source.skin")
        out["skin"] = skin.value
    scale = item.value.get("scale")
    if scale is not None:
        v = scale.value
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (v > 0 and v < float("inf")):
            raise CreatureError(f"'source.scale' must be a positive number, got {v!r}", path=path,
                                line=scale.line, field="source.scale")
        out["scale"] = float(v)
    return out


def _parse_body(item: _Located, path: str | None) -> BodyDef:
    if not isinstance(item.value, dict):
        raise CreatureError(f"each body must be a mapping, got {_describe(item.value)}",
                            path=path, line=item.line)
    entry = item.value
    if "name" not in entry:
        raise CreatureError("body without a 'name'", path=path, line=item.line)
    name = _string(entry["name"], path=path, body=None, field_name="name")
    for key, value in entry.items():
        if key not in _BODY_FIELDS:
            raise CreatureError(f"unknown field '{key}' (known: {', '.join(_BODY_FIELDS)})",
                                path=path, line=value.line, subject=name)
    for required in ("caps", "pos", "extents"):
        if required not in entry:
            raise CreatureError(f"missing '{required}'", path=path, line=item.line, subject=name)
    parent = None
    if "parent" in entry:
        parent = _string(entry["parent"], path=path, body=name, field_name="parent", allow_none=True)
    caps_item = entry["caps"]
    if not isinstance(caps_item.value, list):
        raise CreatureError(f"expected a list of capability names, got {_describe(caps_item.value)}",
                            path=path, line=caps_item.line, subject=name, field="caps")
    caps = [_string(c, path=path, body=name, field_name="caps") for c in caps_item.value]
    body = BodyDef(
        name=name,
        parent=parent,
        caps=caps,
        pos=_vector(entry["pos"], 3, path=path, body=name, field_name="pos"),
        extents=_vector(entry["extents"], 3, path=path, body=name, field_name="extents"),
        line=item.line,
    )
    if "rot" in entry:
        body.rot = _vector(entry["rot"], 4, path=path, body=name, field_name="rot")
    if "joint" in entry:
        body.joint = _vector(entry["joint"], 3, path=path, body=name, field_name="joint")
    # Remember the lines of individual fields for the builder's messages.
    body._field_lines = {key: value.line for key, value in entry.items()}  # type: ignore[attr-defined]
    return body


def read_creature_def(path: str | os.PathLike) -> CreatureDef:
    """Read a creature file into a ``CreatureDef``; I/O and parse errors name the file."""
    path_str = os.fspath(path)
    if path_str.lower().endswith(".bvh") and os.path.isfile(path_str):
        raise CreatureError("a BVH file, not a creature file: import it with 'menagerie creatures from-bvh "
                            f"{path_str} --out NAME.yaml' (view, play, author and grid also take BVH skeletons)",
                            path=path_str)
    try:
        with open(path_str, encoding="utf-8") as f:
            text = f.read()
    except OSError as exc:
        raise CreatureError(f"cannot read creature file: {exc.strerror}", path=path_str) from None
    except UnicodeDecodeError as exc:
        raise CreatureError(f"not a UTF-8 text file ({exc.reason})", path=path_str) from None
    return parse_creature_text(text, path_str)


# -- save --------------------------------------------------------------------------------


def _fmt_vec(values) -> str:
    return "[" + ", ".join(repr(float(v)) for v in values) + "]"


def creature_def_to_text(cdef: CreatureDef) -> str:
    """Creature YAML text for a definition; floats use ``repr`` so they read back exactly."""
    lines = [f"format: {FORMAT_VERSION}", f"name: {_yaml_str(cdef.name)}"]
    if cdef.description:
        lines.append(f"description: {_yaml_str(cdef.description)}")
    if cdef.source:
        lines.append("source:")
        lines.append(f"  file: {_yaml_str(str(cdef.source['file']))}")
        if "skin" in cdef.source:
            lines.append(f"  skin: {int(cdef.source['skin'])}")
        if "scale" in cdef.source:
            lines.append(f"  scale: {float(cdef.source['scale'])!r}")
    lines.append("bodies:")
    for b in cdef.bodies:
        lines.append(f"  - name: {_yaml_str(b.name)}")
        if b.parent is not None:
            lines.append(f"    parent: {_yaml_str(b.parent)}")
        lines.append("    caps: [" + ", ".join(b.caps) + "]")
        lines.append(f"    pos: {_fmt_vec(b.pos)}")
        if tuple(b.rot) != (1.0, 0.0, 0.0, 0.0):
            lines.append(f"    rot: {_fmt_vec(b.rot)}")
        if b.joint is not None and tuple(b.joint) != tuple(b.pos):
            lines.append(f"    joint: {_fmt_vec(b.joint)}")
        lines.append(f"    extents: {_fmt_vec(b.extents)}")
    return "\n".join(lines) + "\n"


def _yaml_str(s: str) -> str:
    """A YAML scalar for ``s`` that reads back as the same string."""
    dumped = yaml.safe_dump(s, default_flow_style=True, width=10_000).strip()
    if dumped.endswith("\n..."):
        dumped = dumped[: -len("\n...")]
    if dumped.endswith("..."):
        dumped = dumped[:-3].strip()
    return dumped


def write_creature_def(cdef: CreatureDef, path: str | os.PathLike, *, overwrite: bool = False) -> None:
    """Write a definition to ``path``. Refuses to replace an existing file unless asked."""
    path_str = os.fspath(path)
    if os.path.exists(path_str) and not overwrite:
        raise FileExistsError(f"{path_str} exists; pass overwrite=True (or --force) to replace it")
    directory = os.path.dirname(path_str)
    if directory:
        os.makedirs(directory, exist_ok=True)
    with open(path_str, "w", encoding="utf-8") as f:
        f.write(creature_def_to_text(cdef))
