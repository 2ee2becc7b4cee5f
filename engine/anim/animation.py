"""The Animation asset: generalized channels, curves, branch predicates (immutable).

Hecker et al. 2008, sections 3.1-3.3 and 4.1. An ``Animation`` is plain data (frozen
dataclasses of tuples) plus its curves packed once into read-only arrays for the
sampling kernel (``Animation.curves``). It knows nothing of any creature: binding it to
one (queries, variants, ownership, slot constants) is the binding's job.

Fields carried for the binding stage (issue "bind phase"): each channel's
``variant_group`` (channels in one group co-vary; a channel with a group plays on one
selected body per variant), ``side`` (``same`` / ``opposite`` side constraint between the
varying channels), ``mirror`` (whether right-side bodies specialize with the sagittal
mirror m = true, Fig. 5a, or not, Fig. 5b) and the animation's ``branches`` (three-valued
predicates: a predicate absent is *ignore*).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from engine.channels.curves import auto_tangents, rotation_auto_tangents
from engine.channels.modes import PositionSpec, RotationSpec
from engine.errors import DataError
from engine.query import Query

FORMAT_VERSION = 1
#: Branch predicates the binding evaluates (Hecker 2008 sec 4.1.1). true / false; absent = ignore.
#: Count predicates take a whole number: the creature must have at least (min_) or at most
#: (max_) that many legs, graspers, heads or mouths.
COUNT_PREDICATES = ("min_legs", "max_legs", "min_graspers", "max_graspers", "min_heads", "max_heads",
                    "min_mouths", "max_mouths")
BRANCH_PREDICATES = ("upright_spine", "has_graspers", "has_feet", "has_mouth", "has_head", "has_eyes",
                     "has_tail", "has_wings")
SIDE_CONSTRAINTS = ("same", "opposite")


class AnimationError(DataError):
    """An animation file or definition that cannot be used; names file, line, channel, field."""

    def __init__(self, message: str, **kw) -> None:
        kw.setdefault("kind", "channel")
        super().__init__(message, **kw)


@dataclass(frozen=True)
class Key:
    """One key: time t (s), value (3 position, 4 rotation quaternion w-first, 1 weight),
    optional incoming/outgoing tangents per second (None = automatic)."""

    t: float
    value: tuple[float, ...]
    tin: tuple[float, ...] | None = None
    tout: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Event:
    """A discrete keyed event (sound, effect, game data) at time t."""

    t: float
    name: str
    data: str | None = None


@dataclass(frozen=True)
class ChannelDef:
    """One channel: which bodies (``query``), relative to what (``secondary`` query or
    external ``target`` name), how (``position`` / ``rotation`` modes, None = the channel
    does not pose that DOF), and its keys."""

    name: str
    query: Query
    secondary: Query | None = None
    target: str | None = None
    position: PositionSpec | None = None
    rotation: RotationSpec | None = None
    position_keys: tuple[Key, ...] = ()
    rotation_keys: tuple[Key, ...] = ()
    weight_keys: tuple[Key, ...] = ()
    events: tuple[Event, ...] = ()
    blend_group: str | None = None
    priority: int = 0
    variant_group: str | None = None
    side: str | None = None
    mirror: bool = True
    line: int = field(default=0, compare=False)

    @property
    def group(self) -> str:
        """The blend group (a channel without one is alone in a group of its own name)."""
        return self.blend_group if self.blend_group is not None else f"channel:{self.name}"

    @property
    def needs_target(self) -> bool:
        return bool((self.position is not None and self.position.needs_target)
                    or (self.rotation is not None and self.rotation.needs_target))


class Curves(NamedTuple):
    """All curves of an animation packed for the sampling kernel (n = channels).

    ch_pos_adr, ch_pos_num (n,) int32   position keys of channel c: [adr, adr + num)
    pos_time (k,), pos_value (k, 3), pos_tout (k, 3), pos_tin (k, 3)
    ch_rot_adr, ch_rot_num (n,) int32   rotation keys
    rot_time (k,), rot_value (k, 4), rot_tout (k, 3), rot_tin (k, 3)   angular velocity
    ch_w_adr, ch_w_num (n,) int32       weight keys (num 0: weight 1)
    w_time (k,), w_value (k, 1), w_tout (k, 1), w_tin (k, 1)
    A channel with a mode and no keys holds the generalized origin (0 / identity).
    """

    ch_pos_adr: np.ndarray
    ch_pos_num: np.ndarray
    pos_time: np.ndarray
    pos_value: np.ndarray
    pos_tout: np.ndarray
    pos_tin: np.ndarray
    ch_rot_adr: np.ndarray
    ch_rot_num: np.ndarray
    rot_time: np.ndarray
    rot_value: np.ndarray
    rot_tout: np.ndarray
    rot_tin: np.ndarray
    ch_w_adr: np.ndarray
    ch_w_num: np.ndarray
    w_time: np.ndarray
    w_value: np.ndarray
    w_tout: np.ndarray
    w_tin: np.ndarray


@dataclass(frozen=True)
class Animation:
    """A generalized animation. Build with ``engine.load_animation`` or
    ``engine.anim.animation_from_text``; equality compares content, not the path."""

    name: str
    length: float
    channels: tuple[ChannelDef, ...]
    description: str = ""
    loop: bool = False
    branches: tuple[tuple[str, bool | int], ...] = ()
    targets: tuple[tuple[str, tuple[float, float, float] | None], ...] = ()
    follows: str | None = None   # the clip this one continues (a fall's lying, then getting up): it
                                 # starts from that clip's end, never from the rest pose
    path: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        validate_animation(self)

    # -- lookups -----------------------------------------------------------------------

    @property
    def nchannel(self) -> int:
        return len(self.channels)

    def channel(self, name: str) -> ChannelDef:
        for c in self.channels:
            if c.name == name:
                return c
        raise KeyError(f"animation '{self.name}' has no channel '{name}'")

    def channel_index(self, name: str) -> int:
        for i, c in enumerate(self.channels):
            if c.name == name:
                return i
        raise KeyError(f"animation '{self.name}' has no channel '{name}'")

    @property
    def target_names(self) -> tuple[str, ...]:
        """External targets the channels use, in order of first use (then declared ones)."""
        names: list[str] = []
        for c in self.channels:
            if c.target is not None and c.target not in names:
                names.append(c.target)
        for n, _ in self.targets:
            if n not in names:
                names.append(n)
        return tuple(names)

    def target_default(self, name: str):
        for n, d in self.targets:
            if n == name:
                return d
        return None

    def events_between(self, t0: float, t1: float) -> list[tuple[str, Event]]:
        """(channel name, event) with t0 <= event.t < t1 (animation-local times), by time."""
        out = [(c.name, e) for c in self.channels for e in c.events if t0 <= e.t < t1]
        return sorted(out, key=lambda ce: ce[1].t)

    def local_time(self, t: float) -> float:
        """Animation time for a play time: wrapped when looping, else clamped to [0, length]."""
        if self.loop:
            return math.fmod(t, self.length) if t >= 0 else self.length + math.fmod(t, self.length)
        return min(max(t, 0.0), self.length)

    # -- packed curves -----------------------------------------------------------------

    @cached_property
    def curves(self) -> Curves:
        """The curves packed into read-only arrays, with automatic tangents filled in."""
        loop_length = self.length if self.loop else None
        parts = {"pos": ([], 3), "rot": ([], 4), "w": ([], 1)}
        adr = {k: np.zeros(self.nchannel, np.int32) for k in parts}
        num = {k: np.zeros(self.nchannel, np.int32) for k in parts}
        packed = {k: {"time": [], "value": [], "tout": [], "tin": []} for k in parts}
        for ci, ch in enumerate(self.channels):
            for kind, keys in (("pos", ch.position_keys), ("rot", ch.rotation_keys), ("w", ch.weight_keys)):
                if kind == "pos" and ch.position is None or kind == "rot" and ch.rotation is None:
                    keys = ()
                if kind == "pos" and ch.position is not None and not keys:
                    keys = (Key(0.0, (0.0, 0.0, 0.0)),)
                if kind == "rot" and ch.rotation is not None and not keys:
                    keys = (Key(0.0, (1.0, 0.0, 0.0, 0.0)),)
                adr[kind][ci] = len(packed[kind]["time"])
                num[kind][ci] = len(keys)
                if not keys:
                    continue
                times = np.array([k.t for k in keys], float)
                values = np.array([k.value for k in keys], float)
                if kind == "rot":
                    auto = rotation_auto_tangents(times, values, loop_length=loop_length)
                else:
                    auto = auto_tangents(times, values, loop_length=loop_length)
                for j, k in enumerate(keys):
                    packed[kind]["time"].append(k.t)
                    packed[kind]["value"].append(values[j])
                    packed[kind]["tout"].append(np.array(k.tout, float) if k.tout is not None else auto[j])
                    packed[kind]["tin"].append(np.array(k.tin, float) if k.tin is not None else auto[j])

        def arr(kind, name, width):
            data = packed[kind][name]
            if name == "time":
                a = np.array(data, float).reshape(len(data))
            else:
                a = np.array(data, float).reshape(len(data), width)
            a = np.ascontiguousarray(a)
            a.flags.writeable = False
            return a

        for d in (adr, num):
            for a in d.values():
                a.flags.writeable = False
        tw = {"pos": 3, "rot": 3, "w": 1}
        vw = {"pos": 3, "rot": 4, "w": 1}
        return Curves(
            adr["pos"], num["pos"], arr("pos", "time", 1), arr("pos", "value", 3), arr("pos", "tout", 3),
            arr("pos", "tin", 3),
            adr["rot"], num["rot"], arr("rot", "time", 1), arr("rot", "value", vw["rot"]),
            arr("rot", "tout", tw["rot"]), arr("rot", "tin", tw["rot"]),
            adr["w"], num["w"], arr("w", "time", 1), arr("w", "value", 1), arr("w", "tout", 1), arr("w", "tin", 1),
        )

    # -- files -------------------------------------------------------------------------

    def save(self, path, *, overwrite: bool = False) -> None:
        """Write the animation file (format 1); load(save(a)) == a exactly."""
        from engine.anim.fileio import write_animation

        write_animation(self, path, overwrite=overwrite)

    def to_text(self) -> str:
        from engine.anim.fileio import animation_to_text

        return animation_to_text(self)


# -- validation (shared by the loader and code that builds animations directly) -----------


def validate_animation(a: Animation) -> None:
    """Raise ``AnimationError`` naming the file, line, channel and field of the first problem."""
    path = a.path

    def fail(msg, ch: ChannelDef | None = None, fld: str | None = None, line: int | None = None):
        if line is None and ch is not None:
            # the line of the field itself when the loader recorded it, else the channel's
            lines = getattr(ch, "_field_lines", {})
            line = lines.get(fld.split(".")[0]) if fld else None
            line = line or ch.line or None
        raise AnimationError(msg, path=path, line=line, subject=ch.name if ch is not None else None, field=fld)

    if not isinstance(a.name, str) or not a.name:
        fail("an animation needs a non-empty name", fld="name")
    if not (isinstance(a.length, float) and math.isfinite(a.length) and a.length > 0.0):
        fail(f"length must be a positive number of seconds, got {a.length!r}", fld="length")
    for pred, value in a.branches:
        if pred in COUNT_PREDICATES:
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                fail(f"branch predicate {pred!r} must be a whole number >= 0, got {value!r}", fld="branches")
            continue
        if pred not in BRANCH_PREDICATES:
            fail(f"unknown branch predicate {pred!r} (known: {', '.join(BRANCH_PREDICATES + COUNT_PREDICATES)})",
                 fld="branches")
        if not isinstance(value, bool):
            fail(f"branch predicate {pred!r} must be true or false (leave it out to ignore it)", fld="branches")
    seen_targets = set()
    for name, default in a.targets:
        if name in seen_targets:
            fail(f"target {name!r} declared twice", fld="targets")
        seen_targets.add(name)
        if default is not None and (len(default) != 3 or not all(math.isfinite(v) for v in default)):
            fail(f"target {name!r}: default must be 3 finite numbers", fld="targets")
    if a.follows is not None and (not isinstance(a.follows, str) or not a.follows or a.follows == a.name):
        fail(f"follows must name another animation (the clip this one continues), got {a.follows!r}",
             fld="follows")
    if not a.channels:
        fail("an animation needs at least one channel", fld="channels")
    names = set()
    for ch in a.channels:
        if not isinstance(ch.name, str) or not ch.name:
            fail("a channel needs a non-empty name", ch, "name")
        if ch.name in names:
            fail("duplicate channel name", ch, "name")
        names.add(ch.name)
        if not isinstance(ch.query, Query):
            fail("a channel needs a primary query ('select')", ch, "select")
        if ch.secondary is not None and ch.target is not None:
            fail("a channel has either a secondary query or an external target, not both", ch, "target")
        if ch.needs_target and ch.secondary is None and ch.target is None:
            fail("secondary and lookat modes need a 'secondary' query or an external 'target'", ch,
                 "position" if ch.position is not None and ch.position.needs_target else "rotation")
        if ch.position is None and ch.rotation is None:
            fail("a channel must pose its position, its rotation or both", ch, "position")
        if ch.position is None and ch.position_keys:
            fail("position keys without a position mode", ch, "keys.position")
        if ch.rotation is None and ch.rotation_keys:
            fail("rotation keys without a rotation mode", ch, "keys.rotation")
        if ch.side is not None and ch.side not in SIDE_CONSTRAINTS:
            fail(f"unknown side constraint {ch.side!r} (known: {', '.join(SIDE_CONSTRAINTS)})", ch, "side")
        if ch.side is not None and ch.variant_group is None:
            fail("a side constraint needs a variant_group", ch, "side")
        if not isinstance(ch.priority, int) or isinstance(ch.priority, bool):
            fail(f"priority must be an integer, got {ch.priority!r}", ch, "priority")
        for kind, keys, width, twidth in (("position", ch.position_keys, 3, 3), ("rotation", ch.rotation_keys, 4, 3),
                                          ("weight", ch.weight_keys, 1, 1)):
            _validate_keys(a, ch, kind, keys, width, twidth, fail)
        for e in ch.events:
            if not (math.isfinite(e.t) and 0.0 <= e.t <= a.length):
                fail(f"event {e.name!r} at t={e.t!r} is outside 0..{a.length}", ch, "keys.events")


def _validate_keys(a, ch, kind, keys, width, twidth, fail):
    prev = None
    for k in keys:
        fld = f"keys.{kind}"
        line = getattr(k, "_line", None)
        if not (math.isfinite(k.t) and 0.0 <= k.t <= a.length):
            fail(f"key time {k.t!r} is outside 0..{a.length}", ch, fld, line)
        if prev is not None and not k.t > prev.t:
            fail(f"key times must increase strictly ({prev.t!r} then {k.t!r})", ch, fld, line)
        if len(k.value) != width or not all(math.isfinite(v) for v in k.value):
            fail(f"a {kind} key needs {width} finite number(s), got {list(k.value)}", ch, fld, line)
        for tname in ("tin", "tout"):
            tv = getattr(k, tname)
            if tv is not None and (len(tv) != twidth or not all(math.isfinite(v) for v in tv)):
                fail(f"tangent '{tname}' needs {twidth} finite number(s), got {list(tv)}", ch, fld, line)
        if kind == "rotation":
            n = math.sqrt(sum(v * v for v in k.value))
            if abs(n - 1.0) > 1e-9:
                fail(f"rotation key is not a unit quaternion (norm {n:.12g})", ch, fld, line)
            if prev is not None:
                d = abs(sum(x * y for x, y in zip(prev.value, k.value, strict=True)))
                if 2.0 * math.acos(min(1.0, d)) > math.pi - 1e-3:
                    fail("consecutive rotation keys turn by 180 degrees or more; add a key between", ch,
                         fld, line)
        prev = k
