"""Animation files: YAML in and out (format 1), errors naming file, line, channel, field.

File format 1::

    format: 1
    name: wave
    description: Wave one grasper overhead (rest-relative position, absolute rotation).
    length: 2.0                 # seconds
    loop: true                  # optional, default false
    follows: wave_start         # optional: the clip this one continues (played after it, never
                                # from the rest pose: the validation grid plays that clip first)
    branches: {has_graspers: true}     # optional; absent predicates are "ignore"
    targets:                    # optional: external targets and a preview default from the
      fruit: [0.8, 0.3, 0.9]    # ground centre, x, y in largest sides, z in heights
    channels:
      - name: hand
        select: {type: grasper, y: left, extent: frontmost}     # the primary context query
        secondary: {type: mouth}     # or  target: fruit  (an external target)
        position: {mode: rest, ground: false, sagittal: false, directional_only: false,
                   contact: false, scale: limb_length}            # mode: absolute|rest|secondary;
                                                                  # contact (secondary): x = 1 where the boxes touch
        rotation: {mode: absolute, limits: [90, 180]}            # mode: absolute|rest|lookat;
                                                                  # lookat limits in degrees
        blend_group: arm        # optional (default: the channel's own group)
        priority: 0             # optional; higher owns first
        variant_group: hand     # optional, used by the bind phase
        side: same              # optional: same|opposite (needs variant_group)
        mirror: true            # optional: right-side bodies specialize mirrored (default true)
        keys:
          position:             # {t, v: [x, y, z], tin: [...], tout: [...]} tangents optional
            - {t: 0.0, v: [0, 0, 0]}
          rotation:             # v: [w, x, y, z], or aa: [axis x, y, z, degrees]
            - {t: 0.0, aa: [0, 1, 0, 30]}
          weight:               # v: a number (clamped to 0..1 when blending)
            - {t: 0.0, v: 1}
          events:
            - {t: 0.5, name: clap, data: loud}

Saving writes floats with ``repr`` (rotation keys as quaternions), so
``load(save(a)) == a`` exactly.
"""

from __future__ import annotations

import math
import os

from engine.anim.animation import FORMAT_VERSION, Animation, AnimationError, ChannelDef, Event, Key
from engine.channels.modes import LOOKAT_LIMITS, PositionSpec, RotationSpec
from engine.errors import DataError
from engine.model.fileio import read_yaml_located
from engine.query import Query

_TOP = ("format", "name", "description", "length", "loop", "follows", "branches", "targets", "channels")
_CHANNEL = ("name", "select", "secondary", "target", "position", "rotation", "blend_group", "priority",
            "variant_group", "side", "mirror", "keys")
_KEYS = ("position", "rotation", "weight", "events")


class _Ctx:
    def __init__(self, path):
        self.path = path
        self.channel = None

    def fail(self, msg, line=None, field=None):
        raise AnimationError(msg, path=self.path, line=line, subject=self.channel, field=field)


def _num(item, ctx, field):
    v = item.value
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        ctx.fail(f"expected a number, got {_describe(v)}", item.line, field)
    if not math.isfinite(float(v)):
        ctx.fail(f"non-finite number {v!r}", item.line, field)
    return float(v)


def _vec(item, n, ctx, field):
    if not isinstance(item.value, list) or len(item.value) != n:
        ctx.fail(f"expected a list of {n} numbers, got {_describe(item.value)}", item.line, field)
    return tuple(_num(e, ctx, field) for e in item.value)


def _str(item, ctx, field):
    if not isinstance(item.value, str) or not item.value:
        ctx.fail(f"expected a non-empty string, got {_describe(item.value)}", item.line, field)
    return item.value


def _count(item, ctx, field):
    v = item.value
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        ctx.fail(f"expected a whole number >= 0, got {_describe(v)}", item.line, field)
    return v


def _bool(item, ctx, field):
    if not isinstance(item.value, bool):
        ctx.fail(f"expected true or false, got {_describe(item.value)}", item.line, field)
    return item.value


def _mapping(item, ctx, field, known):
    if not isinstance(item.value, dict):
        ctx.fail(f"expected a mapping, got {_describe(item.value)}", item.line, field)
    for key, sub in item.value.items():
        if key not in known:
            ctx.fail(f"unknown field '{key}' (known: {', '.join(known)})", sub.line,
                     f"{field}.{key}" if field else key)
    return item.value


def _describe(v):
    if isinstance(v, list):
        return f"a list of {len(v)}"
    if isinstance(v, dict):
        return "a mapping"
    return f"{type(v).__name__} {v!r}"


def _plain(item):
    v = item.value
    if isinstance(v, dict):
        return {k: _plain(s) for k, s in v.items()}
    if isinstance(v, list):
        return [_plain(s) for s in v]
    return v


def _query(item, ctx, field):
    m = _mapping(item, ctx, field, ("type", "x", "y", "z", "x_space", "y_space", "z_space", "extent", "limb"))
    try:
        return Query.from_dict(_plain(item))
    except DataError as exc:
        sub = m.get(exc.field) if exc.field else None
        ctx.fail(exc.reason, sub.line if sub is not None else item.line,
                 f"{field}.{exc.field}" if exc.field else field)


def _spec(item, ctx, field, cls, known):
    m = _mapping(item, ctx, field, known)
    kw = {}
    for key, sub in m.items():
        if key in ("ground", "sagittal", "directional_only", "contact"):
            kw[key] = _bool(sub, ctx, f"{field}.{key}")
        elif key == "limits":
            kw[key] = _vec(sub, 2, ctx, f"{field}.limits")
        else:
            kw[key] = _str(sub, ctx, f"{field}.{key}")
    try:
        return cls(**kw)
    except DataError as exc:
        sub = m.get(exc.field) if exc.field else None
        ctx.fail(exc.reason, sub.line if sub is not None else item.line,
                 f"{field}.{exc.field}" if exc.field else field)


def _keys(item, ctx, kind):
    field = f"keys.{kind}"
    if not isinstance(item.value, list):
        ctx.fail(f"expected a list of keys, got {_describe(item.value)}", item.line, field)
    out = []
    for k in item.value:
        if kind == "events":
            m = _mapping(k, ctx, field, ("t", "name", "data"))
            if "t" not in m or "name" not in m:
                ctx.fail("an event needs 't' and 'name'", k.line, field)
            data = _str(m["data"], ctx, field) if "data" in m else None
            out.append(Event(_num(m["t"], ctx, field), _str(m["name"], ctx, field), data))
            continue
        known = ("t", "v", "aa", "tin", "tout") if kind == "rotation" else ("t", "v", "tin", "tout")
        m = _mapping(k, ctx, field, known)
        if "t" not in m:
            ctx.fail("a key needs a time 't'", k.line, field)
        t = _num(m["t"], ctx, field)
        twidth = 1 if kind == "weight" else 3
        if kind == "rotation":
            if ("v" in m) == ("aa" in m):
                ctx.fail("a rotation key needs exactly one of 'v' (quaternion w, x, y, z) or "
                         "'aa' (axis x, y, z, degrees)", k.line, field)
            if "v" in m:
                q = _vec(m["v"], 4, ctx, field)
            else:
                ax, ay, az, deg = _vec(m["aa"], 4, ctx, field)
                n = math.sqrt(ax * ax + ay * ay + az * az)
                if n == 0.0:
                    ctx.fail("axis-angle key with a zero axis", m["aa"].line, field)
                s = math.sin(0.5 * math.radians(deg)) / n
                q = (math.cos(0.5 * math.radians(deg)), ax * s, ay * s, az * s)
            n = math.sqrt(sum(v * v for v in q))
            if n == 0.0:
                ctx.fail("zero quaternion", k.line, field)
            if abs(n - 1.0) > 1e-12:  # keep exactly-unit keys bit for bit (round trips)
                q = tuple(v / n for v in q)
            value = q
        elif kind == "weight":
            if "v" not in m:
                ctx.fail("a weight key needs 'v'", k.line, field)
            value = (_num(m["v"], ctx, field),)
        else:
            if "v" not in m:
                ctx.fail("a position key needs 'v'", k.line, field)
            value = _vec(m["v"], 3, ctx, field)
        tin = _tangent(m.get("tin"), twidth, ctx, field)
        tout = _tangent(m.get("tout"), twidth, ctx, field)
        key = Key(t, value, tin, tout)
        object.__setattr__(key, "_line", k.line)
        out.append(key)
    return tuple(out)


def _tangent(item, width, ctx, field):
    if item is None:
        return None
    if width == 1 and not isinstance(item.value, list):
        return (_num(item, ctx, field),)
    return _vec(item, width, ctx, field)


def _channel(item, ctx):
    if not isinstance(item.value, dict):
        ctx.fail(f"each channel must be a mapping, got {_describe(item.value)}", item.line, "channels")
    m = item.value
    if "name" not in m:
        ctx.fail("a channel needs a 'name'", item.line, "name")
    ctx.channel = _str(m["name"], ctx, "name")
    _mapping(item, ctx, None, _CHANNEL)
    if "select" not in m:
        ctx.fail("a channel needs a primary query 'select'", item.line, "select")
    kw = dict(name=ctx.channel, query=_query(m["select"], ctx, "select"), line=item.line)
    if "secondary" in m:
        kw["secondary"] = _query(m["secondary"], ctx, "secondary")
    if "target" in m:
        kw["target"] = _str(m["target"], ctx, "target")
    if "position" in m:
        kw["position"] = _spec(m["position"], ctx, "position", PositionSpec,
                               ("mode", "ground", "sagittal", "directional_only", "scale", "contact"))
    if "rotation" in m:
        kw["rotation"] = _spec(m["rotation"], ctx, "rotation", RotationSpec, ("mode", "limits"))
    for key in ("blend_group", "variant_group", "side"):
        if key in m:
            kw[key] = _str(m[key], ctx, key)
    if "priority" in m:
        p = m["priority"].value
        if isinstance(p, bool) or not isinstance(p, int):
            ctx.fail(f"priority must be an integer, got {_describe(p)}", m["priority"].line, "priority")
        kw["priority"] = p
    if "mirror" in m:
        kw["mirror"] = _bool(m["mirror"], ctx, "mirror")
    if "keys" in m:
        keys = _mapping(m["keys"], ctx, "keys", _KEYS)
        for kind, sub in keys.items():
            kw["events" if kind == "events" else f"{kind}_keys"] = _keys(sub, ctx, kind)
    ctx.channel = None
    channel = ChannelDef(**kw)
    object.__setattr__(channel, "_field_lines", {key: sub.line for key, sub in m.items()})
    return channel


def parse_animation_text(text: str, path: str | None = None) -> Animation:
    """Parse and validate animation YAML text (``path`` names the file in errors)."""
    ctx = _Ctx(path)
    root = read_yaml_located(text, path, error=AnimationError)
    if isinstance(root.value, dict) and "bodies" in root.value and "channels" not in root.value:
        ctx.fail("this looks like a creature file (it has 'bodies'), not an animation (an animation file has "
                 "'channels'); pass it where a creature is wanted", root.line, None)
    top = _mapping(root, ctx, None, _TOP)
    if "format" not in top:
        ctx.fail(f"missing 'format: {FORMAT_VERSION}'", root.line, "format")
    if top["format"].value != FORMAT_VERSION:
        ctx.fail(f"unsupported animation format {top['format'].value!r}; this version reads format "
                 f"{FORMAT_VERSION}", top["format"].line, "format")
    for required in ("name", "length", "channels"):
        if required not in top:
            ctx.fail(f"missing '{required}'", root.line, required)
    kw = dict(name=_str(top["name"], ctx, "name"), length=_num(top["length"], ctx, "length"), path=path)
    if kw["length"] <= 0.0:
        ctx.fail(f"length must be > 0 seconds, got {kw['length']!r}", top["length"].line, "length")
    if "description" in top:
        d = top["description"].value
        if not isinstance(d, str):
            ctx.fail("expected a one-line string", top["description"].line, "description")
        kw["description"] = d
    if "loop" in top:
        kw["loop"] = _bool(top["loop"], ctx, "loop")
    if "follows" in top:
        kw["follows"] = _str(top["follows"], ctx, "follows")
    if "branches" in top:
        from engine.anim.animation import BRANCH_PREDICATES, COUNT_PREDICATES

        b = _mapping(top["branches"], ctx, "branches", BRANCH_PREDICATES + COUNT_PREDICATES)
        kw["branches"] = tuple((k, _count(v, ctx, f"branches.{k}") if k in COUNT_PREDICATES
                                else _bool(v, ctx, f"branches.{k}")) for k, v in b.items())
    if "targets" in top:
        t = top["targets"]
        if not isinstance(t.value, dict):
            ctx.fail("targets must map names to default positions (or null)", t.line, "targets")
        kw["targets"] = tuple((k, None if v.value is None else _vec(v, 3, ctx, f"targets.{k}"))
                              for k, v in t.value.items())
    chans = top["channels"]
    if not isinstance(chans.value, list) or not chans.value:
        ctx.fail("'channels' must be a non-empty list", chans.line, "channels")
    kw["channels"] = tuple(_channel(c, ctx) for c in chans.value)
    return Animation(**kw)


def load_animation(path: str | os.PathLike) -> Animation:
    """Load and validate an animation file; every error names the file and line."""
    p = os.fspath(path)
    try:
        with open(p, encoding="utf-8") as f:
            text = f.read()
    except OSError as exc:
        raise AnimationError(f"cannot read animation file: {exc.strerror}", path=p) from None
    except UnicodeDecodeError as exc:
        raise AnimationError(f"not a UTF-8 text file ({exc.reason})", path=p) from None
    return parse_animation_text(text, p)


def animation_from_text(text: str, path: str | None = None) -> Animation:
    """Build an animation from YAML text."""
    return parse_animation_text(text, path)


# -- save --------------------------------------------------------------------------------


def _f(v: float) -> str:
    return repr(float(v))


def _fv(vs) -> str:
    return "[" + ", ".join(_f(v) for v in vs) + "]"


def _s(s: str) -> str:
    from engine.model.fileio import _yaml_str

    return _yaml_str(s)


class _Raw(str):
    """Text written into YAML as is (a formatted list)."""


def _flow(d: dict) -> str:
    parts = []
    for k, v in d.items():
        if isinstance(v, _Raw):
            parts.append(f"{k}: {v}")
        elif isinstance(v, bool):
            parts.append(f"{k}: {'true' if v else 'false'}")
        elif isinstance(v, str):
            parts.append(f"{k}: {_s(v)}")
        else:
            parts.append(f"{k}: {v}")
    return "{" + ", ".join(parts) + "}"


def animation_to_text(a: Animation) -> str:
    """Animation YAML text; floats use ``repr`` so they read back exactly."""
    out = [f"format: {FORMAT_VERSION}", f"name: {_s(a.name)}"]
    if a.description:
        out.append(f"description: {_s(a.description)}")
    out.append(f"length: {_f(a.length)}")
    out.append(f"loop: {'true' if a.loop else 'false'}")
    if a.follows is not None:
        out.append(f"follows: {_s(a.follows)}")
    if a.branches:
        out.append("branches: " + _flow({k: v for k, v in a.branches}))
    if a.targets:
        out.append("targets:")
        for name, d in a.targets:
            out.append(f"  {_s(name)}: {'null' if d is None else _fv(d)}")
    out.append("channels:")
    for ch in a.channels:
        out.append(f"  - name: {_s(ch.name)}")
        out.append(f"    select: {_flow(ch.query.to_dict())}")
        if ch.secondary is not None:
            out.append(f"    secondary: {_flow(ch.secondary.to_dict())}")
        if ch.target is not None:
            out.append(f"    target: {_s(ch.target)}")
        if ch.position is not None:
            p = ch.position
            d = {"mode": p.mode}
            for flag in ("ground", "sagittal", "directional_only", "contact"):
                if getattr(p, flag):
                    d[flag] = True
            if p.scale != "none":
                d["scale"] = p.scale
            out.append(f"    position: {_flow(d)}")
        if ch.rotation is not None:
            r = ch.rotation
            d = {"mode": r.mode}
            if tuple(r.limits) != LOOKAT_LIMITS:
                d["limits"] = _Raw(_fv(r.limits))
            out.append(f"    rotation: {_flow(d)}")
        for key in ("blend_group", "variant_group", "side"):
            v = getattr(ch, key)
            if v is not None:
                out.append(f"    {key}: {_s(v)}")
        if ch.priority != 0:
            out.append(f"    priority: {ch.priority}")
        if not ch.mirror:
            out.append("    mirror: false")
        if ch.position_keys or ch.rotation_keys or ch.weight_keys or ch.events:
            out.append("    keys:")
            for kind, keys in (("position", ch.position_keys), ("rotation", ch.rotation_keys),
                               ("weight", ch.weight_keys)):
                if not keys:
                    continue
                out.append(f"      {kind}:")
                for k in keys:
                    v = _f(k.value[0]) if kind == "weight" else _fv(k.value)
                    s = f"t: {_f(k.t)}, v: {v}"
                    for tn in ("tin", "tout"):
                        tv = getattr(k, tn)
                        if tv is not None:
                            s += f", {tn}: " + (_f(tv[0]) if kind == "weight" else _fv(tv))
                    out.append(f"        - {{{s}}}")
            if ch.events:
                out.append("      events:")
                for e in ch.events:
                    s = f"t: {_f(e.t)}, name: {_s(e.name)}"
                    if e.data is not None:
                        s += f", data: {_s(e.data)}"
                    out.append(f"        - {{{s}}}")
    return "\n".join(out) + "\n"


def write_animation(a: Animation, path, *, overwrite: bool = False) -> None:
    """Write ``a`` to ``path``; refuses to replace a file unless asked."""
    p = os.fspath(path)
    if os.path.exists(p) and not overwrite:
        raise FileExistsError(f"{p} exists; pass overwrite=True to replace it")
    d = os.path.dirname(p)
    if d:
        os.makedirs(d, exist_ok=True)
    with open(p, "w", encoding="utf-8") as f:
        f.write(animation_to_text(a))
