"""The authoring tool's editing model: everything an animator does, without a window.

Hecker et al. 2008, section 3 (Spasm): select (a channel's context query, then an
*active* body clicked on any creature), pose (the active body's specialized pose is
generalized with G and specialized with S onto every selected body of every creature),
key, preview. ``Editor`` holds a ``Document`` (the animation, undo/redo, save) and a
``Preview`` (the creatures, played through ``engine.Character``); the window
(``authoring.author``) is a thin layer that turns mouse and keys into these calls, and
the tests make the same calls directly.

Every edit goes through ``Document.apply``: one undoable step, or one per gesture when
a ``coalesce`` tag is given (a drag of a body, a key or a slider is one step however many
values it passes through; ``end_gesture`` closes it).

Keys are stored generalized (q_g). ``curve(kind, space)`` gives a channel's curve in
generalized units or specialized onto the active body (the paper offers both, 3.3), and
``set_key_value(..., space="specialized")`` generalizes an edited specialized value back.
Changing a movement mode remaps the keys with ``engine.anim.remap_channel`` so the active
body's motion does not change (3.3, "Key Remapping").

Mute and solo are preview choices: they decide what the creatures play, never what is
saved.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os

import numpy as np

from authoring.document import Document
from authoring.preview import Preview
from engine.anim import Animation, AnimationError, remap_channel
from engine.anim._kernels import sample_channels_kernel
from engine.anim.animation import BRANCH_PREDICATES, COUNT_PREDICATES, ChannelDef, Event, Key
from engine.anim.fileio import animation_to_text, parse_animation_text
from engine.channels import modes as M
from engine.channels.modes import PositionSpec, RotationSpec, SlotConstants
from engine.errors import MenagerieError
from engine.query import Query

KINDS = ("position", "rotation", "weight")
SPACES = ("generalized", "specialized")
#: Key times closer than this (s) are the same key.
TIME_EPS = 1e-6
#: Where the channel library lives unless ``MENAGERIE_CHANNEL_LIBRARY`` says otherwise.
DEFAULT_LIBRARY = os.path.join(os.path.expanduser("~"), ".config", "menagerie", "channels.yaml")


class EditError(MenagerieError):
    """An edit that cannot be made (names the channel and what is wrong)."""


def library_path() -> str:
    return os.environ.get("MENAGERIE_CHANNEL_LIBRARY") or DEFAULT_LIBRARY


def _keys_field(kind: str) -> str:
    if kind not in KINDS:
        raise EditError(f"unknown key kind {kind!r} (known: {', '.join(KINDS)})")
    return f"{kind}_keys"


def _quat_exp(v) -> np.ndarray:
    v = np.asarray(v, float)
    a = float(np.linalg.norm(v))
    if a < 1e-12:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[math.cos(a / 2)], math.sin(a / 2) * v / a])


def _quat_log(q) -> np.ndarray:
    q = np.asarray(q, float)
    if q[0] < 0:
        q = -q
    s = float(np.linalg.norm(q[1:]))
    if s < 1e-12:
        return np.zeros(3)
    return 2.0 * math.atan2(s, q[0]) * q[1:] / s


def _qmul(a, b):
    return M._qmul(np.asarray(a, float), np.asarray(b, float))


class Editor:
    """The editing model (see the module docstring)."""

    def __init__(self, document: Document, creatures) -> None:
        self.doc = document
        self.preview = Preview(creatures)
        self.channel: str | None = document.animation.channels[0].name if document.animation.channels else None
        self.creature = 0                  # the active creature (index into the preview)
        self.body: int | None = None       # the active body on the active creature
        self.time = 0.0
        self.playing = False
        self.speed = 1.0
        self.loop = True
        self.muted: set[str] = set()
        self.solo: str | None = None
        self.space = "generalized"
        self.selected_keys: set[tuple[str, int]] = set()
        self._gesture = itertools.count(1)
        self._pose: dict | None = None
        self.message = document.load_error or ""
        self._shown = None
        self.refresh()
        self.activate_first()

    def activate_first(self) -> None:
        """Make the active channel's first selected body, on the first creature it poses
        anything on, the active body (what the tool starts with)."""
        for k in range(len(self.preview)):
            bodies = self.selected_bodies(k)
            if len(bodies) and not self.preview.items[k].declined:
                self.creature, self.body = k, int(bodies[0])
                self._highlight()
                return

    # -- state ---------------------------------------------------------------------------------

    @property
    def animation(self) -> Animation:
        return self.doc.animation

    def active_channel(self) -> ChannelDef | None:
        if self.channel is None:
            return None
        try:
            return self.animation.channel(self.channel)
        except KeyError:
            return None

    def _channel(self, name: str | None) -> ChannelDef:
        name = self.channel if name is None else name
        if name is None:
            raise EditError("no channel is selected")
        try:
            return self.animation.channel(name)
        except KeyError:
            raise EditError(f"animation '{self.animation.name}' has no channel '{name}'") from None

    def muted_channels(self) -> set[str]:
        """Channels the preview leaves out: the muted ones, or all but the solo one."""
        names = {c.name for c in self.animation.channels}
        if self.solo is not None and self.solo in names:
            return names - {self.solo}
        return self.muted & names

    def refresh(self) -> None:
        """Play the current animation on the preview creatures at the current time."""
        self.time = min(max(self.time, 0.0), self.animation.length)
        self.preview.show(self.animation, self.time, speed=self.speed if self.playing else 0.0,
                          loop=self.loop, muted=self.muted_channels())
        if self.body is not None and self.body not in set(self.selected_bodies(self.creature).tolist()):
            self.body = None
        self._highlight()
        self._shown = (self.animation, self.time, self.playing, frozenset(self.muted_channels()))

    def _highlight(self) -> None:
        sels = [self.selected_bodies(k) for k in range(len(self.preview))]
        active = (self.creature, self.body) if self.body is not None else None
        self.preview.highlight(sels, active)
        name = self.channel
        for k, item in enumerate(self.preview.items):
            lines = [item.actor.base_label]
            if item.declined:
                lines.append(item.declined)
            elif name is not None and self.active_channel() is not None and not len(sels[k]):
                lines.append(f"'{name}' selects no body")
            item.actor.label = "\n".join(lines)

    def _apply(self, animation: Animation, label: str, coalesce=None) -> None:
        self.doc.apply(animation, label, coalesce=coalesce)
        self.selected_keys = {k for k in self.selected_keys if k[1] < len(self._keys(k[0]))}
        self.refresh()

    def _replace_channel(self, ch: ChannelDef, label: str, coalesce=None, old_name: str | None = None) -> None:
        name = ch.name if old_name is None else old_name
        chans = tuple(ch if c.name == name else c for c in self.animation.channels)
        try:
            anim = dataclasses.replace(self.animation, channels=chans)
        except AnimationError as exc:
            raise EditError(exc.reason) from None
        self._apply(anim, label, coalesce)

    def _replace_animation(self, label: str, coalesce=None, **changes) -> None:
        try:
            anim = dataclasses.replace(self.animation, **changes)
        except AnimationError as exc:
            raise EditError(exc.reason) from None
        self._apply(anim, label, coalesce)

    def end_gesture(self) -> None:
        self.doc.end_gesture()
        self._pose = None

    def new_gesture(self) -> int:
        """A fresh coalesce tag for one drag (the window asks one per mouse press)."""
        return next(self._gesture)

    # -- undo, redo, save ------------------------------------------------------------------------

    def undo(self) -> bool:
        ok = self.doc.undo()
        self._after_history()
        return ok

    def redo(self) -> bool:
        ok = self.doc.redo()
        self._after_history()
        return ok

    def _after_history(self) -> None:
        if self.active_channel() is None:
            self.channel = self.animation.channels[0].name if self.animation.channels else None
        self.selected_keys = {k for k in self.selected_keys if k[1] < len(self._keys(k[0]))}
        self.refresh()

    def save(self, path: str | None = None, *, overwrite: bool = False, force: bool = False) -> str:
        self.end_gesture()
        out = self.doc.save(force=force) if path is None else self.doc.save_as(path, overwrite=overwrite)
        self.message = f"saved {out}"
        return out

    # -- selection -------------------------------------------------------------------------------

    def select_channel(self, name: str | None) -> None:
        if name is not None:
            self._channel(name)
        self.channel = name
        self.selected_keys.clear()
        if self.body is not None and self.body not in set(self.selected_bodies(self.creature).tolist()):
            self.body = None
            sel = self.selected_bodies(self.creature)
            if len(sel):
                self.body = int(sel[0])
        self._highlight()

    def selected_bodies(self, k: int, channel: str | None = None) -> np.ndarray:
        """Bodies the channel (default: the active one) poses on creature ``k`` (in the
        variant it plays there), else all its query selects; empty when none."""
        name = self.channel if channel is None else channel
        if name is None:
            return np.zeros(0, np.int32)
        try:
            idx = self.animation.channel_index(name)
        except KeyError:
            return np.zeros(0, np.int32)
        clip = self.preview.bound(k)
        if clip is not None and clip.animation.channels and name in [c.name for c in clip.animation.channels]:
            return np.asarray(clip.bound.channel_bodies[clip.animation.channel_index(name)], np.int32)
        return self.animation.channels[idx].query.evaluate(self.preview.items[k].creature)

    def query_bodies(self, k: int, channel: str | None = None) -> np.ndarray:
        """Every body the channel's primary query selects on creature ``k`` (before variants)."""
        ch = self._channel(channel)
        return ch.query.evaluate(self.preview.items[k].creature)

    def activate(self, k: int, body: int | None) -> bool:
        """Make ``body`` of creature ``k`` the active body (a click in the viewport). A body
        the active channel does not pose there cannot be active: False, and only the
        active creature changes. A click on a body no channel poses leaves the channel."""
        if not 0 <= k < len(self.preview):
            raise EditError(f"no preview creature {k}")
        self.creature = k
        if body is None:
            self.body = None
            self._highlight()
            return False
        if body in set(self.selected_bodies(k).tolist()):
            self.body = int(body)
            self._highlight()
            return True
        # Pick the first channel that poses the clicked body.
        for ch in self.animation.channels:
            if body in set(self.selected_bodies(k, ch.name).tolist()):
                self.channel = ch.name
                self.selected_keys.clear()
                self.body = int(body)
                self._highlight()
                return True
        self.body = None
        self._highlight()
        return False

    def decline_reason(self, k: int) -> str | None:
        return self.preview.items[k].declined

    def variants(self, k: int) -> list[tuple[str, bool]]:
        return self.preview.variants(k)

    def set_variant(self, k: int, variant: str | None) -> None:
        ids = [v for v, _ in self.variants(k)]
        if variant is not None and variant not in ids:
            raise EditError(f"creature '{self.preview.items[k].name}' has no variant '{variant}' "
                            f"(variants: {', '.join(ids) or 'none'})")
        self.preview.items[k].variant = variant
        self.refresh()

    # -- time ------------------------------------------------------------------------------------

    def set_time(self, t: float) -> None:
        if not math.isfinite(t):
            raise EditError(f"time must be finite, got {t!r}")
        self.time = min(max(float(t), 0.0), self.animation.length)
        self.end_gesture()
        self.refresh()

    def step(self, frames: int = 1, fps: float = 30.0) -> None:
        """Move the time by whole frames (arrow keys), wrapping when the preview loops."""
        t = self.time + frames / fps
        L = self.animation.length
        if self.loop or self.animation.loop:
            t = t % L if t != L else L
        self.set_time(t)

    def play(self, on: bool | None = None) -> None:
        self.playing = (not self.playing) if on is None else bool(on)
        self.refresh()

    def set_speed(self, speed: float) -> None:
        if not (math.isfinite(speed) and speed != 0.0 and abs(speed) <= 10.0):
            raise EditError(f"speed must be non-zero and within -10..10, got {speed!r}")
        self.speed = float(speed)
        self.refresh()

    def set_loop(self, on: bool) -> None:
        self.loop = bool(on)
        self.refresh()

    def tick(self, dt: float) -> None:
        """One frame of the tool: advance the preview when playing, and re-show it when the
        animation changed (an edit, an undo) or the time was moved."""
        shown = (self.animation, self.time, self.playing, frozenset(self.muted_channels()))
        if shown != self._shown:
            self.refresh()
        if self.playing:
            self.time = self.preview.advance(dt)
            L = self.animation.length
            if not (self.loop or self.animation.loop) and self.time >= L - 1e-9:
                self.playing = False
                self.time = L
                self.refresh()
            self._shown = (self.animation, self.time, self.playing, frozenset(self.muted_channels()))

    # -- channels ---------------------------------------------------------------------------------

    def _free_name(self, base: str) -> str:
        names = {c.name for c in self.animation.channels}
        if base not in names:
            return base
        for n in itertools.count(2):
            if f"{base}_{n}" not in names:
                return f"{base}_{n}"
        raise AssertionError

    def add_channel(self, name: str | None = None, query: Query | None = None, *,
                    position: PositionSpec | None | str = "rest", rotation: RotationSpec | None | str = "rest",
                    **fields) -> str:
        """Add a channel (default: graspers, rest-relative position and rotation)."""
        q = query or Query(type="grasper")
        position = PositionSpec(position) if isinstance(position, str) else position
        rotation = RotationSpec(rotation) if isinstance(rotation, str) else rotation
        name = self._free_name(name or q.type)
        ch = ChannelDef(name=name, query=q, position=position, rotation=rotation, **fields)
        self._replace_animation(f"add channel {name}", channels=self.animation.channels + (ch,))
        self.select_channel(name)
        return name

    def remove_channel(self, name: str | None = None) -> None:
        ch = self._channel(name)
        if len(self.animation.channels) == 1:
            raise EditError("an animation needs at least one channel")
        chans = tuple(c for c in self.animation.channels if c.name != ch.name)
        self._replace_animation(f"remove channel {ch.name}", channels=chans)
        self.muted.discard(ch.name)
        if self.solo == ch.name:
            self.solo = None
        if self.channel == ch.name:
            self.select_channel(chans[0].name)

    def rename_channel(self, old: str, new: str) -> None:
        ch = self._channel(old)
        new = str(new).strip()
        if not new:
            raise EditError("a channel needs a non-empty name")
        if new != old and new in {c.name for c in self.animation.channels}:
            raise EditError(f"there is already a channel '{new}'")
        self._replace_channel(dataclasses.replace(ch, name=new), f"rename {old} to {new}", old_name=old)
        if old in self.muted:
            self.muted.discard(old)
            self.muted.add(new)
        if self.solo == old:
            self.solo = new
        if self.channel == old:
            self.channel = new

    def duplicate_channel(self, name: str | None = None) -> str:
        ch = self._channel(name)
        new = self._free_name(f"{ch.name}_copy")
        chans = list(self.animation.channels)
        chans.insert(chans.index(ch) + 1, dataclasses.replace(ch, name=new))
        self._replace_animation(f"duplicate {ch.name}", channels=tuple(chans))
        self.select_channel(new)
        return new

    def move_channel(self, name: str, offset: int) -> None:
        """Move a channel up (-1) or down (+1) the list (first owns first at equal priority)."""
        chans = list(self.animation.channels)
        i = chans.index(self._channel(name))
        j = min(max(i + offset, 0), len(chans) - 1)
        if i == j:
            return
        chans.insert(j, chans.pop(i))
        self._replace_animation(f"move {name}", channels=tuple(chans))

    def set_mute(self, name: str, on: bool) -> None:
        self._channel(name)
        (self.muted.add if on else self.muted.discard)(name)
        self.refresh()

    def set_solo(self, name: str | None) -> None:
        if name is not None:
            self._channel(name)
        self.solo = name
        self.refresh()

    # -- context queries -------------------------------------------------------------------------

    def set_query(self, name: str | None = None, *, secondary: bool = False, coalesce=None, **fields) -> Query:
        """Change fields of a channel's primary (or ``secondary``) query, e.g.
        ``set_query("hand", y="left", extent=None)``. Returns the new query."""
        ch = self._channel(name)
        base = ch.secondary if secondary else ch.query
        d = base.to_dict() if base is not None else {"type": "head"}
        for k, v in fields.items():
            if v is None:
                d.pop(k, None)
            else:
                d[k] = v
        try:
            q = Query.from_dict(d)
        except MenagerieError as exc:
            raise EditError(f"channel '{ch.name}': {exc.reason}") from None
        change = {"secondary": q} if secondary else {"query": q}
        if secondary:
            change["target"] = None
        self._replace_channel(dataclasses.replace(ch, **change), f"query of {ch.name}", coalesce)
        return q

    def set_relative_to(self, name: str | None = None, *, secondary: Query | None = None,
                        target: str | None = None) -> None:
        """What a secondary or lookat mode is relative to: another query's bodies or a
        named external target (or neither)."""
        ch = self._channel(name)
        if secondary is not None and target is not None:
            raise EditError(f"channel '{ch.name}': relative to a secondary query or a target, not both")
        self._replace_channel(dataclasses.replace(ch, secondary=secondary, target=target),
                              f"relative target of {ch.name}")

    # -- movement modes (with exact key remapping) ------------------------------------------------

    def remap_body(self, name: str | None = None) -> tuple[int, int]:
        """(creature, body) whose motion a mode change keeps: the active body, else the
        first body the channel poses on the active creature, else on any creature."""
        ch = self._channel(name)
        order = [self.creature] + [k for k in range(len(self.preview)) if k != self.creature]
        if self.body is not None and ch.name == self.channel:
            if self.body in set(ch.query.evaluate(self.preview.items[self.creature].creature).tolist()):
                return self.creature, self.body
        for k in order:
            bodies = ch.query.evaluate(self.preview.items[k].creature)
            if len(bodies):
                return k, int(bodies[0])
        raise EditError(f"channel '{ch.name}' selects no body on any preview creature: a mode change "
                        "cannot keep anyone's motion (change the query first)")

    def set_modes(self, name: str | None = None, *, position: PositionSpec | None | str = "keep",
                  rotation: RotationSpec | None | str = "keep") -> None:
        """New position and/or rotation modes for a channel. Keys are remapped so the
        active body's specialized motion stays exactly the same (``remap_channel``);
        turning a DOF on starts it at its generalized origin, turning it off drops its keys."""
        ch = self._channel(name)
        new_pos = ch.position if isinstance(position, str) else position
        new_rot = ch.rotation if isinstance(rotation, str) else rotation
        if new_pos is None and new_rot is None:
            raise EditError(f"channel '{ch.name}' must pose its position, its rotation or both")
        needs = (new_pos is not None and new_pos.needs_target) or (new_rot is not None and new_rot.needs_target)
        out = ch
        if needs and ch.secondary is None and ch.target is None:
            target = self.animation.target_names[0] if self.animation.target_names else "target"
            out = dataclasses.replace(out, target=target)
        remap_pos = ch.position is not None and new_pos is not None and new_pos != ch.position
        remap_rot = ch.rotation is not None and new_rot is not None and new_rot != ch.rotation
        if remap_pos or remap_rot:
            k, body = self.remap_body(ch.name)
            target = self._remap_target(out, k, body)
            if (remap_pos and new_pos.needs_target) or (remap_rot and new_rot.needs_target) or \
                    (ch.position is not None and ch.position.needs_target) or \
                    (ch.rotation is not None and ch.rotation.needs_target):
                if target is None:
                    raise EditError(f"channel '{ch.name}': the target of its secondary mode is not on "
                                    f"'{self.preview.items[k].name}'")
            try:
                out = remap_channel(out, self.preview.items[k].creature, body,
                                    position=new_pos if remap_pos else None,
                                    rotation=new_rot if remap_rot else None, target=target,
                                    loop_length=self.animation.length if self.animation.loop else None)
            except MenagerieError as exc:
                raise EditError(f"channel '{ch.name}': {exc.reason}") from None
        if new_pos is None:
            out = dataclasses.replace(out, position=None, position_keys=())
        elif ch.position is None:
            out = dataclasses.replace(out, position=new_pos)
        if new_rot is None:
            out = dataclasses.replace(out, rotation=None, rotation_keys=())
        elif ch.rotation is None:
            out = dataclasses.replace(out, rotation=new_rot)
        anim_targets = self.animation.targets
        if out.target is not None and out.target not in self.animation.target_names:
            anim_targets = anim_targets + ((out.target, (0.9, 0.3, 0.85)),)
        chans = tuple(out if c.name == ch.name else c for c in self.animation.channels)
        try:
            anim = dataclasses.replace(self.animation, channels=chans, targets=anim_targets)
        except AnimationError as exc:
            raise EditError(exc.reason) from None
        self._apply(anim, f"modes of {ch.name}")

    def _remap_target(self, ch: ChannelDef, k: int, body: int):
        """The secondary target position of ``body`` on creature ``k`` (character space)."""
        c = self.preview.items[k].creature
        if ch.target is not None:
            return self.preview.target_position(k, ch.target)
        if ch.secondary is not None:
            sec = ch.secondary.evaluate(c)
            if not len(sec):
                return None
            choice = sec[sec != body] if len(sec) > 1 else sec
            d = np.linalg.norm(c.body_rest_pos[choice] - c.body_rest_pos[body], axis=1)
            return c.body_rest_pos[int(choice[int(np.argmin(d))])]
        return None

    # -- the rest of a channel --------------------------------------------------------------------

    def set_channel_fields(self, name: str | None = None, **fields) -> None:
        """blend_group, priority, variant_group, side, mirror (None clears a group)."""
        ch = self._channel(name)
        allowed = {"blend_group", "priority", "variant_group", "side", "mirror"}
        bad = set(fields) - allowed
        if bad:
            raise EditError(f"unknown channel field(s) {', '.join(sorted(bad))} (known: {', '.join(sorted(allowed))})")
        if "priority" in fields:
            fields["priority"] = int(fields["priority"])
        if fields.get("variant_group", ch.variant_group) is None:
            fields["side"] = None
        self._replace_channel(dataclasses.replace(ch, **fields), f"{', '.join(fields)} of {ch.name}")

    # -- the rest of the asset --------------------------------------------------------------------

    def set_length(self, length: float) -> None:
        """A new length: keys and events past it are dropped (the file keeps them all inside)."""
        if not (math.isfinite(length) and length > 0):
            raise EditError(f"length must be > 0 seconds, got {length!r}")
        chans = tuple(dataclasses.replace(
            c, position_keys=tuple(k for k in c.position_keys if k.t <= length),
            rotation_keys=tuple(k for k in c.rotation_keys if k.t <= length),
            weight_keys=tuple(k for k in c.weight_keys if k.t <= length),
            events=tuple(e for e in c.events if e.t <= length)) for c in self.animation.channels)
        self._replace_animation("length", length=float(length), channels=chans)

    def set_asset_fields(self, **fields) -> None:
        """name, description, loop."""
        allowed = {"name", "description", "loop"}
        bad = set(fields) - allowed
        if bad:
            raise EditError(f"unknown field(s) {', '.join(sorted(bad))} (known: {', '.join(sorted(allowed))})")
        self._replace_animation(", ".join(fields), **fields)

    def set_branch(self, predicate: str, value) -> None:
        """A branch predicate: True/False (or a count for ``min_``/``max_``); None = ignore."""
        if predicate not in BRANCH_PREDICATES + COUNT_PREDICATES:
            raise EditError(f"unknown branch predicate {predicate!r} "
                            f"(known: {', '.join(BRANCH_PREDICATES + COUNT_PREDICATES)})")
        b = [(k, v) for k, v in self.animation.branches if k != predicate]
        if value is not None:
            b.append((predicate, value))
        self._replace_animation(f"branch {predicate}", branches=tuple(b))

    def set_target_default(self, name: str, default) -> None:
        """The preview default of external target ``name`` (x, y in largest sides, z in heights)."""
        t = [(k, v) for k, v in self.animation.targets if k != name]
        t.append((name, None if default is None else tuple(float(x) for x in default)))
        self._replace_animation(f"target {name}", targets=tuple(t))
        for item in self.preview.items:
            item.targets.pop(name, None)
        self.refresh()

    def drag_target(self, k: int, name: str, position, coalesce=None) -> None:
        """Move external target ``name`` of creature ``k`` (character space): a preview
        choice (the game sets targets), the animation is unchanged."""
        if name not in self.animation.target_names:
            raise EditError(f"animation '{self.animation.name}' has no external target '{name}'")
        self.preview.set_target(k, name, position)
        self.refresh()

    # -- keys -------------------------------------------------------------------------------------

    def _keys(self, kind: str, name: str | None = None) -> tuple[Key, ...]:
        try:
            ch = self._channel(name)
        except EditError:
            return ()
        return getattr(ch, _keys_field(kind))

    def keys(self, kind: str, name: str | None = None) -> tuple[Key, ...]:
        return self._keys(kind, name)

    def _set_keys(self, ch: ChannelDef, kind: str, keys, label: str, coalesce=None) -> None:
        keys = tuple(sorted(keys, key=lambda k: k.t))
        self._replace_channel(dataclasses.replace(ch, **{_keys_field(kind): keys}), label, coalesce)

    def _check_kind(self, ch: ChannelDef, kind: str) -> None:
        if kind == "position" and ch.position is None:
            raise EditError(f"channel '{ch.name}' does not pose a position (give it a position mode)")
        if kind == "rotation" and ch.rotation is None:
            raise EditError(f"channel '{ch.name}' does not pose a rotation (give it a rotation mode)")

    def set_key(self, kind: str, t: float, value, *, name: str | None = None, tin=None, tout=None,
                coalesce=None) -> int:
        """Insert (or replace) a key at time ``t`` with generalized ``value``; returns its index."""
        ch = self._channel(name)
        self._check_kind(ch, kind)
        t = float(t)
        if not (0.0 <= t <= self.animation.length):
            raise EditError(f"key time {t:g} s is outside 0..{self.animation.length:g}")
        value = tuple(float(v) for v in np.atleast_1d(value))
        if kind == "rotation":
            n = math.sqrt(sum(v * v for v in value))
            value = tuple(v / n for v in value)
        keys = [k for k in getattr(ch, _keys_field(kind)) if abs(k.t - t) > TIME_EPS]
        keys.append(Key(t, value, tin, tout))
        self._set_keys(ch, kind, keys, f"key {kind} of {ch.name} at {t:.3g} s", coalesce)
        return [k.t for k in self._keys(kind, ch.name)].index(t)

    def key_now(self, kinds=None, name: str | None = None) -> list[str]:
        """The I key: key what the channel plays now (its curves' values at the current
        time) on every curve it has; returns the kinds keyed."""
        ch = self._channel(name)
        kinds = kinds or [k for k in ("position", "rotation") if getattr(ch, k) is not None]
        pos, rot, w = self.sample(ch.name, self.time)
        anim = self.animation
        done = []
        for kind in kinds:
            value = {"position": pos, "rotation": rot, "weight": (w,)}[kind]
            keys = [k for k in getattr(ch, _keys_field(kind)) if abs(k.t - self.time) > TIME_EPS]
            keys.append(Key(self.time, tuple(float(v) for v in value)))
            ch = dataclasses.replace(ch, **{_keys_field(kind): tuple(sorted(keys, key=lambda k: k.t))})
            done.append(kind)
        chans = tuple(ch if c.name == ch.name else c for c in anim.channels)
        self._apply(dataclasses.replace(anim, channels=chans), f"key {', '.join(done)} of {ch.name}")
        return done

    def delete_keys(self, kind: str, indices, name: str | None = None) -> None:
        ch = self._channel(name)
        keys = getattr(ch, _keys_field(kind))
        drop = set(int(i) for i in indices)
        if any(not 0 <= i < len(keys) for i in drop):
            raise EditError(f"channel '{ch.name}' has {len(keys)} {kind} keys")
        self._set_keys(ch, kind, [k for i, k in enumerate(keys) if i not in drop],
                       f"delete {len(drop)} {kind} key(s) of {ch.name}")
        self.selected_keys = {s for s in self.selected_keys if s[0] != kind}

    def move_keys(self, kind: str, indices, dt: float = 0.0, dvalue=None, *, name: str | None = None,
                  coalesce=None, base: tuple[Key, ...] | None = None) -> list[int]:
        """Move keys in time by ``dt`` and (position/weight) in value by ``dvalue``, from
        ``base`` (the keys as they were when the drag began; default now). Keys never pass
        each other or leave 0..length. Returns the moved keys' new indices."""
        ch = self._channel(name)
        keys = list(base if base is not None else getattr(ch, _keys_field(kind)))
        sel = sorted(set(int(i) for i in indices))
        if not sel:
            return []
        L = self.animation.length
        times = [k.t for k in keys]
        # Clamp dt so no moved key reaches an unmoved neighbour or leaves 0..length.
        for i in sel:
            left = [times[j] for j in range(i) if j not in sel]
            right = [times[j] for j in range(i + 1, len(keys)) if j not in sel]
            lo = left[-1] + TIME_EPS * 10 if left else 0.0
            hi = right[0] - TIME_EPS * 10 if right else L
            dt = min(max(dt, lo - times[i]), hi - times[i])
        moved = []
        for i in sel:
            k = keys[i]
            v = k.value
            if dvalue is not None:
                if kind == "rotation":
                    dq = _quat_exp(np.asarray(dvalue, float))
                    v = tuple(float(x) for x in _qmul(dq, np.asarray(k.value)))
                else:
                    v = tuple(float(a + b) for a, b in zip(k.value, np.atleast_1d(dvalue), strict=True))
            keys[i] = Key(float(k.t + dt), v, k.tin, k.tout)
            moved.append(keys[i].t)
        self._set_keys(ch, kind, keys, f"move {len(sel)} {kind} key(s) of {ch.name}", coalesce)
        new_times = [k.t for k in self._keys(kind, ch.name)]
        return [new_times.index(t) for t in moved]

    def set_key_value(self, kind: str, index: int, value, *, name: str | None = None,
                      space: str = "generalized", t: float | None = None, coalesce=None) -> None:
        """Set one key's value (and time ``t``), in generalized units or ``specialized``
        onto the active body (generalized back with G before it is stored)."""
        ch = self._channel(name)
        keys = list(getattr(ch, _keys_field(kind)))
        if not 0 <= index < len(keys):
            raise EditError(f"channel '{ch.name}' has no {kind} key {index}")
        k = keys[index]
        v = np.atleast_1d(np.asarray(value, float))
        if kind == "rotation" and v.shape == (3,):   # a rotation vector in degrees (the curve editor's)
            v = _quat_exp(np.radians(v))
        if space == "specialized" and kind != "weight":
            v = self._generalize_value(ch, kind, v, k.t if t is None else t)
        if kind == "rotation":
            v = v / np.linalg.norm(v)
        keys[index] = Key(k.t if t is None else float(t), tuple(float(x) for x in v), k.tin, k.tout)
        self._set_keys(ch, kind, keys, f"edit {kind} key of {ch.name}", coalesce)

    def set_tangents(self, kind: str, index: int, tin="keep", tout="keep", *, name: str | None = None,
                     coalesce=None) -> None:
        """A key's incoming/outgoing tangent (per second; rotation: angular velocity);
        None makes it automatic again."""
        ch = self._channel(name)
        keys = list(getattr(ch, _keys_field(kind)))
        k = keys[index]
        width = 1 if kind == "weight" else 3

        def tangent(v, old):
            if isinstance(v, str):
                return old
            if v is None:
                return None
            v = tuple(float(x) for x in np.atleast_1d(v))
            if len(v) != width:
                raise EditError(f"a {kind} tangent has {width} number(s)")
            return v

        keys[index] = Key(k.t, k.value, tangent(tin, k.tin), tangent(tout, k.tout))
        self._set_keys(ch, kind, keys, f"tangents of {ch.name}", coalesce)

    def flatten_tangents(self, kind: str, indices, name: str | None = None) -> None:
        """Zero tangents (a hold) on the given keys: one step."""
        ch = self._channel(name)
        keys = list(getattr(ch, _keys_field(kind)))
        zero = (0.0,) if kind == "weight" else (0.0, 0.0, 0.0)
        for i in indices:
            keys[i] = Key(keys[i].t, keys[i].value, zero, zero)
        self._set_keys(ch, kind, keys, f"flatten tangents of {ch.name}")

    # -- events -----------------------------------------------------------------------------------

    def add_event(self, t: float, name: str, data: str | None = None, *, channel: str | None = None) -> None:
        ch = self._channel(channel)
        if not name:
            raise EditError("an event needs a name")
        ev = tuple(sorted(ch.events + (Event(float(t), str(name), data or None),), key=lambda e: e.t))
        self._replace_channel(dataclasses.replace(ch, events=ev), f"event {name}")

    def edit_event(self, index: int, *, t: float | None = None, name: str | None = None, data="keep",
                   channel: str | None = None, coalesce=None) -> None:
        ch = self._channel(channel)
        ev = list(ch.events)
        e = ev[index]
        ev[index] = Event(e.t if t is None else float(t), e.name if name is None else str(name),
                          e.data if isinstance(data, str) and data == "keep" else (data or None))
        self._replace_channel(dataclasses.replace(ch, events=tuple(sorted(ev, key=lambda e: e.t))),
                              f"event {ev[index].name}", coalesce)

    def remove_event(self, index: int, channel: str | None = None) -> None:
        ch = self._channel(channel)
        ev = list(ch.events)
        gone = ev.pop(index)
        self._replace_channel(dataclasses.replace(ch, events=tuple(ev)), f"remove event {gone.name}")

    # -- sampling, G and S on the active body ------------------------------------------------------

    def sample(self, name: str | None = None, t: float | None = None):
        """(q_g position (3,), rotation (4,), weight) of a channel at time ``t``."""
        anim = self.animation
        ci = anim.channel_index(self._channel(name).name)
        n = anim.nchannel
        pos, rot, w = np.zeros((n, 3)), np.zeros((n, 4)), np.zeros(n)
        t = self.time if t is None else t
        sample_channels_kernel(anim.curves, float(anim.local_time(t)), pos, rot, w, np.zeros((3, 3)))
        return pos[ci].copy(), rot[ci].copy(), float(w[ci])

    def slot(self, k: int | None = None, body: int | None = None, name: str | None = None):
        """(single-slot constants, target table) of ``body`` of creature ``k`` in the
        channel's current binding there (default: the active creature and body)."""
        k = self.creature if k is None else k
        body = self.body if body is None else body
        ch = self._channel(name)
        if body is None:
            raise EditError("no active body: click one of the channel's selected bodies first")
        clip = self.preview.bound(k)
        if clip is None:
            raise EditError(f"'{self.preview.items[k].name}' {self.preview.items[k].declined or 'plays nothing'}")
        played = clip.animation
        if ch.name not in [c.name for c in played.channels]:
            raise EditError(f"channel '{ch.name}' is muted in the preview")
        ci = played.channel_index(ch.name)
        sl = clip.bound.slots
        hit = np.flatnonzero((sl.slot_channel == ci) & (sl.slot_body == body))
        if not len(hit):
            raise EditError(f"channel '{ch.name}' does not pose body "
                            f"'{self.preview.items[k].creature.body_names[body]}' on '{self.preview.items[k].name}'")
        i = int(hit[0])
        single = SlotConstants(*(np.ascontiguousarray(a[i:i + 1]) for a in sl))
        return single, np.array(clip.table[0], float)

    def specialize_now(self, name: str | None = None, t: float | None = None):
        """The active body's specialized goal (position (3,), rotation (4,)) at time ``t``."""
        single, table = self.slot(name=name)
        pos, rot, _ = self.sample(name, t)
        p, r = M.specialize(single, pos[None], rot[None], table)
        return p[0], r[0]

    def _generalize_value(self, ch: ChannelDef, kind: str, v, t: float) -> np.ndarray:
        single, table = self.slot(name=ch.name)
        pos, rot, _ = self.sample(ch.name, t)
        if kind == "position":
            qs_p, qs_r = M.specialize(single, pos[None], rot[None], table)
            g_p, _ = M.generalize(single, v.reshape(1, 3), qs_r, table)
            return g_p[0]
        qs = v
        qs_p, _ = M.specialize(single, pos[None], rot[None], table)
        _, g_r = M.generalize(single, qs_p, qs.reshape(1, 4), table)
        return g_r[0]

    def _cached(self, what: str, fn, *key):
        """``fn()`` memoized on the animation (immutable: edits make new ones), the active
        creature, body and channel, and ``key``: the panels ask for the same curves every
        frame while nothing changes."""
        table = None
        if self.body is not None and self.preview.bound(self.creature) is not None:
            try:
                single, tab = self.slot()
            except EditError:
                pass
            else:
                row = int(single.slot_target[0])
                table = tab[row].tobytes() if row >= 0 else b""
        full = (what, self.channel, self.creature, self.body, table, *key)
        cache = self.__dict__.setdefault("_cache", {})
        hit = cache.get(full)
        if hit is not None and hit[0] is self.animation:
            return hit[1]
        value = fn()
        if len(cache) > 64:
            cache.clear()
        cache[full] = (self.animation, value)
        return value

    def curve(self, kind: str, space: str | None = None, samples: int = 121, name: str | None = None):
        space = self.space if space is None else space
        return self._cached("curve", lambda: self._curve(kind, space, samples, name), kind, space, samples, name)

    def _curve(self, kind: str, space: str | None = None, samples: int = 121, name: str | None = None):
        """(times (n,), values (n, d)) of a channel's curve: generalized, or specialized onto
        the active body (positions in m, character space; rotations as a rotation vector in
        degrees; weights are the same in both)."""
        space = self.space if space is None else space
        if space not in SPACES:
            raise EditError(f"unknown curve space {space!r} (known: {', '.join(SPACES)})")
        ch = self._channel(name)
        anim = self.animation
        times = np.linspace(0.0, anim.length, samples)
        n = anim.nchannel
        ci = anim.channel_index(ch.name)
        pos, rot, w = np.zeros((n, 3)), np.zeros((n, 4)), np.zeros(n)
        P, R, W = np.zeros((samples, 3)), np.zeros((samples, 4)), np.zeros(samples)
        work = np.zeros((3, 3))
        for j, t in enumerate(times):
            sample_channels_kernel(anim.curves, float(t), pos, rot, w, work)
            P[j], R[j], W[j] = pos[ci], rot[ci], w[ci]
        if kind == "weight":
            return times, W[:, None]
        if space == "specialized":
            single, table = self.slot(name=ch.name)
            tab = np.tile(table, (1, 1))
            sp, sr = np.zeros((samples, 3)), np.zeros((samples, 4))
            for j in range(samples):
                p, r = M.specialize(single, P[j:j + 1], R[j:j + 1], tab)
                sp[j], sr[j] = p[0], r[0]
            P, R = sp, sr
        if kind == "position":
            return times, P
        if kind == "rotation":
            out = np.array([_quat_log(q) for q in R])
            return times, np.degrees(out)
        raise EditError(f"unknown key kind {kind!r}")

    def key_values(self, kind: str, space: str | None = None, name: str | None = None) -> np.ndarray:
        space = self.space if space is None else space
        return self._cached("keys", lambda: self._key_values(kind, space, name), kind, space, name)

    def _key_values(self, kind: str, space: str | None = None, name: str | None = None) -> np.ndarray:
        """The keys' values as the curve editor plots them (see ``curve``)."""
        space = self.space if space is None else space
        ch = self._channel(name)
        keys = getattr(ch, _keys_field(kind))
        out = []
        for k in keys:
            v = np.asarray(k.value, float)
            if space == "specialized" and kind != "weight":
                single, table = self.slot(name=ch.name)
                pos, rot, _ = self.sample(ch.name, k.t)
                pos = v if kind == "position" else pos
                rot = v if kind == "rotation" else rot
                p, r = M.specialize(single, pos[None], rot[None], table)
                v = p[0] if kind == "position" else r[0]
            if kind == "rotation":
                v = np.degrees(_quat_log(v))
            out.append(v)
        width = {"position": 3, "rotation": 3, "weight": 1}[kind]
        return np.array(out, float).reshape(-1, width)

    def goal_path(self, samples: int = 64) -> np.ndarray | None:
        return self._cached("path", lambda: self._goal_path(samples), samples)

    def _goal_path(self, samples: int = 64) -> np.ndarray | None:
        """The active body's specialized goal positions over the whole animation
        (character space, (samples, 3)): the channel's curve drawn in 3D (P Fig. 2)."""
        ch = self.active_channel()
        if ch is None or ch.position is None or self.body is None:
            return None
        try:
            single, table = self.slot()
        except EditError:
            return None
        times = np.linspace(0.0, self.animation.length, samples)
        out = np.zeros((samples, 3))
        for j, t in enumerate(times):
            pos, rot, _ = self.sample(ch.name, float(t))
            p, _ = M.specialize(single, pos[None], rot[None], table)
            out[j] = p[0]
        return out

    # -- posing ----------------------------------------------------------------------------------

    def begin_pose(self, k: int | None = None, body: int | None = None) -> dict:
        """Start posing the active body (a drag of a manipulator): returns its goal now,
        ``{"position": (3,), "rotation": (4,)}`` in character space."""
        if k is not None or body is not None:
            if not self.activate(self.creature if k is None else k, body if body is not None else self.body):
                raise EditError("that body is not posed by any channel here")
        ch = self._channel(None)
        p, r = self.specialize_now()
        self._pose = {"tag": self.new_gesture(), "channel": ch.name, "position": p.copy(), "rotation": r.copy(),
                      "time": self.time}
        return {"position": p, "rotation": r}

    def pose(self, position=None, rotation=None) -> None:
        """Move the active body's goal to ``position`` (3,) and/or turn it to ``rotation``
        (4,), character space: generalized with G and keyed at the current time, so every
        other selected body on every creature follows through S. One undo step per drag."""
        if self._pose is None:
            self.begin_pose()
        ch = self._channel(self._pose["channel"])
        single, table = self.slot(name=ch.name)
        p = self._pose["position"] if position is None else np.asarray(position, float)
        r = self._pose["rotation"] if rotation is None else np.asarray(rotation, float)
        r = r / np.linalg.norm(r)
        g_p, g_r = M.generalize(single, p[None], r[None], table)
        anim = self.animation
        t = self._pose["time"]
        out = ch
        for kind, value, has in (("position", g_p[0], ch.position is not None and position is not None),
                                 ("rotation", g_r[0], ch.rotation is not None and rotation is not None)):
            if not has:
                continue
            keys = [k for k in getattr(out, _keys_field(kind)) if abs(k.t - t) > TIME_EPS]
            keys.append(Key(t, tuple(float(x) for x in value)))
            out = dataclasses.replace(out, **{_keys_field(kind): tuple(sorted(keys, key=lambda k: k.t))})
        if position is not None:
            self._pose["position"] = p.copy()
        if rotation is not None:
            self._pose["rotation"] = r.copy()
        chans = tuple(out if c.name == ch.name else c for c in anim.channels)
        self._apply(dataclasses.replace(anim, channels=chans), f"pose {ch.name} at {t:.3g} s",
                    coalesce=("pose", self._pose["tag"]))

    def end_pose(self) -> None:
        self.end_gesture()

    # -- the channel library (presets) ------------------------------------------------------------

    def presets(self, path: str | None = None) -> list[ChannelDef]:
        """The channels in the library file (an animation file whose channels have no keys)."""
        p = path or library_path()
        if not os.path.exists(p):
            return []
        with open(p, encoding="utf-8") as f:
            return list(parse_animation_text(f.read(), p).channels)

    def save_preset(self, name: str | None = None, path: str | None = None) -> str:
        """Add the channel's setup (queries, modes, groups; no keys) to the library,
        replacing a preset of the same name. Returns the library path."""
        ch = self._channel(name)
        p = path or library_path()
        setup = dataclasses.replace(ch, position_keys=(), rotation_keys=(), weight_keys=(), events=())
        chans = [c for c in self.presets(p) if c.name != ch.name] + [setup]
        targets = tuple((t, (0.9, 0.3, 0.85)) for t in sorted({c.target for c in chans if c.target}))
        lib = Animation(name="channel_library", length=1.0, channels=tuple(chans), targets=targets,
                        description="Channel presets of the Menagerie authoring tool")
        d = os.path.dirname(p)
        if d:
            os.makedirs(d, exist_ok=True)
        tmp = p + ".saving"
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(animation_to_text(lib))
        os.replace(tmp, p)
        self.message = f"saved preset '{ch.name}' to {p}"
        return p

    def add_preset(self, preset: str, path: str | None = None) -> str:
        """Add a channel from the library to the animation (it starts with no keys)."""
        for c in self.presets(path):
            if c.name == preset:
                new = dataclasses.replace(c, name=self._free_name(c.name))
                targets = self.animation.targets
                if new.target and new.target not in self.animation.target_names:
                    targets = targets + ((new.target, (0.9, 0.3, 0.85)),)
                self._replace_animation(f"add preset {preset}", channels=self.animation.channels + (new,),
                                        targets=targets)
                self.select_channel(new.name)
                return new.name
        raise EditError(f"no preset '{preset}' in {path or library_path()}")
