"""Gait styles: how fast legs cycle, how long feet stay down, how high they lift, and the
torso motion that goes with them (Hecker et al. 2008, section 4.2, "Gait Styles").

A style maps the *relative speed* of a leg group (m/s per metre of leg length, so one
file serves a mouse and an elephant) to gait parameters, interpolated linearly between
the authored speeds and held at the ends. Step triggers (the offset of each foot's cycle
in the group's cycle) are authored for groups of 1 to 6 steppers; for 7 or more the
style's ``wave`` block generates a metachronal wave (a centipede's gait) procedurally.

File format (``animations/gaits/<name>.yaml``)::

    format: 1
    name: walk
    description: free text
    max_cadence: 2.2     # highest cycle rate, cycles/s for a 1 m leg (scaled by 1/sqrt(leg length))
    accel: 3.0           # how fast the body may change speed, leg lengths per s^2
    turn_accel: 8.0      # how fast the turn rate may change, rad/s^2
    slope_align: 0.6     # share of the ground slope the torso follows (0 upright .. 1 fully)
    speeds:              # at least one entry, speeds ascending
      - {speed: 0.0, stride: 0.5, duty: 0.75, lift: 0.10, bob: 0.01, sway: 0.01, lean: 0.02, crouch: 0.0}
    triggers:            # six lists: the step triggers for 1, 2, ... 6 steppers in [0, 1)
      - [0.0]
      - [0.0, 0.5]
      ...
    duty_scale:          # optional, same shape as triggers: per-stepper duty factor scale (a limp)
    lift_scale:          # optional, same shape: per-stepper lift scale
    wave: {waves: 1.0, side_offset: 0.5}   # 7+ steppers: trigger = frac(waves * rank / pairs + side * side_offset)
    flight:              # the foot's path in flight, normalized (forward 0..1, up 0..1 of lift, pitch rad)
      arc: {peak: 0.45, lead: 0.15, pitch: 0.25}
      # or: curve: [[s, forward, up, pitch], ...]  s from 0 to 1, forward 0 -> 1, up 0 at both ends

Speed entry fields: ``stride`` (distance the body travels per cycle, leg lengths),
``duty`` (duty factor, share of the cycle a foot is on the ground, (0, 1)), ``lift``
(peak foot lift, leg lengths), ``bob`` (vertical hip motion, leg lengths), ``sway``
(sideways hip motion, leg lengths), ``lean`` (torso pitch per unit of relative
acceleration and roll per unit of centripetal acceleration, rad per (leg lengths/s^2)),
``crouch`` (how much lower the hips ride, leg lengths).

Steppers are ordered front to back (by the x of their rest feet), left before right at
equal x; a branching limb is one stepper (its feet keep their relative positions).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from engine.errors import DataError
from engine.model.fileio import read_yaml_located

FORMAT_VERSION = 1
#: Numeric fields of a speed entry, in the column order of ``GaitStyle.table``.
SPEED_FIELDS = ("speed", "stride", "duty", "lift", "bob", "sway", "lean", "crouch")
_TOP = ("format", "name", "description", "max_cadence", "accel", "turn_accel", "slope_align", "speeds",
        "triggers", "duty_scale", "lift_scale", "wave", "flight")
#: Samples of the normalized flight path table (uniform in flight progress s).
PATH_SAMPLES = 33
MAX_AUTHORED = 6


class GaitStyleError(DataError):
    """A gait style file or definition that cannot be used."""


@dataclass(frozen=True)
class GaitStyle:
    """An immutable gait style (see the module docstring for the fields).

    table (nspeed, 8) float64         rows of SPEED_FIELDS, speeds ascending
    triggers tuple of 6 tuples         step triggers for 1..6 steppers
    duty_scale, lift_scale             same shape, per-stepper scales
    wave_waves, wave_side_offset       procedural triggers for 7+ steppers
    path (PATH_SAMPLES, 3) float64     normalized flight path: forward, up, pitch at s = i/(n-1)
    """

    name: str
    description: str
    max_cadence: float
    accel: float
    turn_accel: float
    slope_align: float
    table: np.ndarray
    triggers: tuple
    duty_scale: tuple
    lift_scale: tuple
    wave_waves: float
    wave_side_offset: float
    path: np.ndarray
    source: str | None = None

    def params_at(self, rel_speed: float) -> np.ndarray:
        """The speed-entry row (SPEED_FIELDS order) at ``rel_speed``, linear between rows."""
        return _interp_rows(self.table, rel_speed)

    def stepper_pattern(self, side: np.ndarray, rank: np.ndarray, npair: int) -> tuple:
        """(trigger, duty_scale, lift_scale) arrays for n steppers in front-to-back order;
        ``side`` (+1 left, -1 right, 0 middle) and ``rank`` (row from the front) are used
        by the procedural wave for 7 or more steppers."""
        n = len(side)
        if n <= MAX_AUTHORED:
            return (np.array(self.triggers[n - 1], float), np.array(self.duty_scale[n - 1], float),
                    np.array(self.lift_scale[n - 1], float))
        # procedural wave (section 4.2: parameters generated for 7+ feet): each side runs a
        # wave from the back to the front; the sides are offset by side_offset
        trig = np.zeros(n)
        for i in range(n):
            s = 1.0 if side[i] < 0 else 0.0
            trig[i] = (-self.wave_waves * rank[i] / max(npair, 1) + s * self.wave_side_offset) % 1.0
        return trig, np.ones(n), np.ones(n)


def _interp_rows(table: np.ndarray, x: float) -> np.ndarray:
    speeds = table[:, 0]
    if x <= speeds[0] or len(speeds) == 1:
        return table[0].copy()
    if x >= speeds[-1]:
        return table[-1].copy()
    k = int(np.searchsorted(speeds, x, side="right")) - 1
    t = (x - speeds[k]) / (speeds[k + 1] - speeds[k])
    return table[k] * (1.0 - t) + table[k + 1] * t


# -- reading -------------------------------------------------------------------------------


class _Ctx:
    def __init__(self, path):
        self.path = path

    def fail(self, msg, line=None, field=None):
        raise GaitStyleError(msg, path=self.path, line=line, field=field)


def _describe(v):
    if isinstance(v, list):
        return f"a list of {len(v)}"
    if isinstance(v, dict):
        return "a mapping"
    return f"{type(v).__name__} {v!r}"


def _num(item, ctx, field, lo=-math.inf, hi=math.inf, lo_open=False, hi_open=False):
    v = item.value
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        ctx.fail(f"expected a number, got {_describe(v)}", item.line, field)
    v = float(v)
    if not math.isfinite(v):
        ctx.fail(f"non-finite number {v!r}", item.line, field)
    if v < lo or v > hi or (lo_open and v == lo) or (hi_open and v == hi):
        a = "(" if lo_open else "["
        b = ")" if hi_open else "]"
        ctx.fail(f"{v!r} is outside {a}{lo}, {hi}{b}", item.line, field)
    return v


def _mapping(item, ctx, field, known):
    if not isinstance(item.value, dict):
        ctx.fail(f"expected a mapping, got {_describe(item.value)}", item.line, field)
    for key, sub in item.value.items():
        if key not in known:
            ctx.fail(f"unknown field '{key}' (known: {', '.join(known)})", sub.line,
                     f"{field}.{key}" if field else key)
    return item.value


def _per_count(item, ctx, field, lo, hi):
    """Six lists, the k-th with k numbers in [lo, hi]."""
    if not isinstance(item.value, list) or len(item.value) != MAX_AUTHORED:
        ctx.fail(f"expected {MAX_AUTHORED} lists (for 1 to {MAX_AUTHORED} steppers), got "
                 f"{_describe(item.value)}", item.line, field)
    out = []
    for k, sub in enumerate(item.value):
        if not isinstance(sub.value, list) or len(sub.value) != k + 1:
            ctx.fail(f"entry {k + 1} must list {k + 1} number{'s' if k else ''}, got {_describe(sub.value)}",
                     sub.line, f"{field}[{k}]")
        out.append(tuple(_num(e, ctx, f"{field}[{k}]", lo, hi) for e in sub.value))
    return tuple(out)


def _arc_path(peak: float, lead: float, pitch: float) -> np.ndarray:
    """Normalized flight path from arc parameters: the foot rises on a smooth bump peaking
    at ``peak`` of the flight, moves forward on a smoothstep eased ``lead`` toward the start
    (the foot reaches forward early), and pitches toe-up by ``pitch`` mid-flight."""
    s = np.linspace(0.0, 1.0, PATH_SAMPLES)
    # up: a bump 0 -> 1 -> 0 with its maximum at `peak` (warped sine), zero slope at both ends
    warp = np.where(s < peak, 0.5 * s / peak, 0.5 + 0.5 * (s - peak) / (1.0 - peak))
    up = np.sin(np.pi * warp) ** 2
    # forward: smoothstep of a time warped by `lead` (forward motion front-loaded)
    u = s + lead * s * (1.0 - s)
    fwd = u * u * (3.0 - 2.0 * u)
    pitch_curve = pitch * np.sin(np.pi * s) * np.cos(np.pi * s * 0.5) ** 2
    return np.stack([fwd, up, pitch_curve], axis=1)


def _curve_path(item, ctx) -> np.ndarray:
    field = "flight.curve"
    if not isinstance(item.value, list) or len(item.value) < 2:
        ctx.fail(f"expected a list of at least 2 [s, forward, up, pitch] points, got {_describe(item.value)}",
                 item.line, field)
    pts = []
    for e in item.value:
        if not isinstance(e.value, list) or len(e.value) != 4:
            ctx.fail(f"expected [s, forward, up, pitch], got {_describe(e.value)}", e.line, field)
        pts.append(tuple(_num(x, ctx, field) for x in e.value))
    pts = np.array(pts)
    if pts[0, 0] != 0.0 or pts[-1, 0] != 1.0 or np.any(np.diff(pts[:, 0]) <= 0):
        ctx.fail("s must rise strictly from 0 to 1", item.line, field)
    if abs(pts[0, 1]) > 1e-9 or abs(pts[-1, 1] - 1.0) > 1e-9:
        ctx.fail("forward must go from 0 (lift-off) to 1 (touchdown)", item.line, field)
    if abs(pts[0, 2]) > 1e-9 or abs(pts[-1, 2]) > 1e-9:
        ctx.fail("up must be 0 at lift-off and touchdown (feet leave and meet the ground)", item.line, field)
    if np.any(pts[:, 2] < 0):
        ctx.fail("up must not be negative (a foot never dips below the ground)", item.line, field)
    s = np.linspace(0.0, 1.0, PATH_SAMPLES)
    return np.stack([np.interp(s, pts[:, 0], pts[:, c]) for c in (1, 2, 3)], axis=1)


def parse_style_text(text: str, path: str | None = None) -> GaitStyle:
    """Read a gait style from YAML text (``path`` only names the file in errors)."""
    ctx = _Ctx(path)
    root = read_yaml_located(text, path, error=GaitStyleError)
    top = _mapping(root, ctx, None, _TOP)
    for req in ("format", "name", "speeds", "triggers"):
        if req not in top:
            ctx.fail(f"missing required field '{req}'", root.line, req)
    fmt = top["format"]
    if fmt.value != FORMAT_VERSION:
        ctx.fail(f"unsupported format {fmt.value!r} (this Menagerie reads format {FORMAT_VERSION})", fmt.line,
                 "format")
    name = top["name"].value
    if not isinstance(name, str) or not name:
        ctx.fail(f"expected a non-empty string, got {_describe(name)}", top["name"].line, "name")
    desc = top["description"].value if "description" in top else ""
    if not isinstance(desc, str):
        ctx.fail(f"expected a string, got {_describe(desc)}", top["description"].line, "description")

    def scalar(key, default, lo, hi, lo_open=False):
        return _num(top[key], ctx, key, lo, hi, lo_open) if key in top else default

    max_cadence = scalar("max_cadence", 2.5, 0.0, 20.0, True)
    accel = scalar("accel", 3.0, 0.0, 100.0, True)
    turn_accel = scalar("turn_accel", 8.0, 0.0, 200.0, True)
    slope_align = scalar("slope_align", 0.6, 0.0, 1.0)

    sp = top["speeds"]
    if not isinstance(sp.value, list) or not sp.value:
        ctx.fail(f"expected a non-empty list of speed entries, got {_describe(sp.value)}", sp.line, "speeds")
    limits = {"speed": (0.0, 100.0, False), "stride": (0.0, 4.0, True), "duty": (0.0, 1.0, True),
              "lift": (0.0, 1.0, False), "bob": (0.0, 0.3, False), "sway": (0.0, 0.3, False),
              "lean": (0.0, 1.0, False), "crouch": (0.0, 0.4, False)}
    defaults = {"lift": 0.1, "bob": 0.0, "sway": 0.0, "lean": 0.0, "crouch": 0.0}
    rows = []
    for k, e in enumerate(sp.value):
        f = f"speeds[{k}]"
        m = _mapping(e, ctx, f, SPEED_FIELDS)
        row = []
        for key in SPEED_FIELDS:
            lo, hi, lo_open = limits[key]
            if key in m:
                v = _num(m[key], ctx, f"{f}.{key}", lo, hi, lo_open, hi_open=(key == "duty"))
            elif key in defaults:
                v = defaults[key]
            else:
                ctx.fail(f"missing required field '{key}'", e.line, f"{f}.{key}")
            row.append(v)
        if rows and row[0] <= rows[-1][0]:
            ctx.fail(f"speeds must ascend ({row[0]} after {rows[-1][0]})", m["speed"].line, f"{f}.speed")
        rows.append(row)
    table = np.array(rows, float)

    triggers = _per_count(top["triggers"], ctx, "triggers", 0.0, 1.0)
    triggers = tuple(tuple(t % 1.0 for t in tr) for tr in triggers)
    ones = tuple(tuple(1.0 for _ in range(k + 1)) for k in range(MAX_AUTHORED))
    duty_scale = _per_count(top["duty_scale"], ctx, "duty_scale", 0.2, 1.5) if "duty_scale" in top else ones
    lift_scale = _per_count(top["lift_scale"], ctx, "lift_scale", 0.0, 3.0) if "lift_scale" in top else ones
    # a scaled duty factor must stay inside (0, 1) at every authored speed
    for k in range(MAX_AUTHORED):
        for j, sc in enumerate(duty_scale[k]):
            worst = float(np.max(table[:, 2])) * sc
            if worst >= 0.97:
                ctx.fail(f"duty {float(np.max(table[:, 2]))} x duty_scale {sc} leaves no time for the foot's "
                         f"flight (must stay below 0.97)", top["duty_scale"].line, f"duty_scale[{k}][{j}]")

    waves, side_offset = 1.0, 0.5
    if "wave" in top:
        w = _mapping(top["wave"], ctx, "wave", ("waves", "side_offset"))
        if "waves" in w:
            waves = _num(w["waves"], ctx, "wave.waves", 0.0, 8.0, True)
        if "side_offset" in w:
            side_offset = _num(w["side_offset"], ctx, "wave.side_offset", 0.0, 1.0)

    path_arr = _arc_path(0.45, 0.15, 0.2)
    if "flight" in top:
        fl = _mapping(top["flight"], ctx, "flight", ("arc", "curve"))
        if "arc" in fl and "curve" in fl:
            ctx.fail("give either an arc or a curve, not both", top["flight"].line, "flight")
        if "arc" in fl:
            a = _mapping(fl["arc"], ctx, "flight.arc", ("peak", "lead", "pitch"))
            peak = _num(a["peak"], ctx, "flight.arc.peak", 0.05, 0.95) if "peak" in a else 0.45
            lead = _num(a["lead"], ctx, "flight.arc.lead", -0.9, 0.9) if "lead" in a else 0.15
            pitch = _num(a["pitch"], ctx, "flight.arc.pitch", -1.0, 1.0) if "pitch" in a else 0.2
            path_arr = _arc_path(peak, lead, pitch)
        elif "curve" in fl:
            path_arr = _curve_path(fl["curve"], ctx)
    return GaitStyle(name=name, description=desc, max_cadence=max_cadence, accel=accel, turn_accel=turn_accel,
                     slope_align=slope_align, table=_frozen(table), triggers=triggers, duty_scale=duty_scale,
                     lift_scale=lift_scale, wave_waves=waves, wave_side_offset=side_offset,
                     path=_frozen(np.ascontiguousarray(path_arr)), source=path)


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float64)
    a.flags.writeable = False
    return a


STYLE_DIR = os.path.normpath(os.path.join(os.path.dirname(__file__), "..", "..", "animations", "gaits"))
_CACHE: dict[str, GaitStyle] = {}


def load_style(name_or_path: str | os.PathLike) -> GaitStyle:
    """A style by name (``"walk"`` -> ``animations/gaits/walk.yaml``) or by file path; cached."""
    key = os.fspath(name_or_path)
    if key in _CACHE:
        return _CACHE[key]
    path = key if (key.endswith((".yaml", ".yml")) or os.sep in key) else os.path.join(STYLE_DIR, key + ".yaml")
    try:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
    except FileNotFoundError:
        known = ", ".join(style_names()) or "none"
        raise GaitStyleError(f"no gait style file (known styles: {known})", path=path) from None
    except OSError as exc:
        raise GaitStyleError(f"cannot read gait style file: {exc.strerror}", path=path) from None
    except UnicodeDecodeError as exc:
        raise GaitStyleError(f"not a UTF-8 text file ({exc.reason})", path=path) from None
    style = parse_style_text(text, path)
    _CACHE[key] = style
    return style


def style_names() -> list[str]:
    """Names of the shipped styles (files in ``animations/gaits``)."""
    if not os.path.isdir(STYLE_DIR):
        return []
    return sorted(f[:-5] for f in os.listdir(STYLE_DIR) if f.endswith(".yaml"))
