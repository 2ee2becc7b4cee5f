"""The animation player of one character: clips in slots, layers, fades, a queue, events.

The paper's playback API (Hecker et al. 2008, section 4): play with a weight, fade in
and out, loop, speed; a queue; layers with weights; stop; per-key event callbacks. The
per-frame part is one kernel (``_player_kernels.advance_slots``) over slot arrays shaped
(nchar, nslot): a character's player normally owns a (1, nslot) stack, and a ``Crowd``
rebinds every player to rows of one shared stack so a thousand players advance in one
call. Python runs per frame only for the rare things: a clip ending, a queued clip
starting, an event firing.

Layers: clips on a higher layer override lower layers by their weight (per body and DOF,
in the blend stage); clips on one layer share by weight. Playing a clip on a layer fades
out the clips already playing there (a cross-fade); to mix two clips by weight on one
layer, pass ``crossfade=False``.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from engine.anim._player_kernels import FLAG_ENDING, FLAG_FREED, FLAG_WRAPPED, advance_slots

#: Default capacity: clips playing at once per character, and layers.
DEFAULT_SLOTS = 8
DEFAULT_LAYERS = 4

EventCallback = Callable[["PlayHandle", str, Any], None]


@dataclass(eq=False)
class PlayHandle:
    """What ``play`` returns: identifies a playing (or queued) clip."""

    animation: Any                 # engine.anim.Animation
    payload: Any = None            # what the runtime attached (the bound variant)
    layer: int = 0
    slot: int = -1                 # -1 while queued or after it ended
    serial: int = 0
    on_event: EventCallback | None = None
    finished: bool = False

    @property
    def playing(self) -> bool:
        return self.slot >= 0

    def __repr__(self) -> str:
        state = "playing" if self.playing else ("finished" if self.finished else "queued")
        name = getattr(self.animation, "name", type(self.animation).__name__)
        return f"<PlayHandle {name!r} layer {self.layer} {state}>"


@dataclass
class _Queued:
    handle: PlayHandle
    weight: float
    fade: float
    fade_out: float
    loop: bool
    speed: float


@dataclass
class PlayerArrays:
    """Slot and layer arrays, shapes (nchar, nslot) and (nchar, nlayer)."""

    active: np.ndarray
    time: np.ndarray
    prev_time: np.ndarray
    speed: np.ndarray
    length: np.ndarray
    loop: np.ndarray
    weight: np.ndarray
    fade: np.ndarray
    fade_in_rate: np.ndarray
    fade_out_rate: np.ndarray
    stopping: np.ndarray
    layer: np.ndarray
    layer_weight: np.ndarray
    effective: np.ndarray
    flags: np.ndarray

    @classmethod
    def allocate(cls, nchar: int, nslot: int, nlayer: int) -> PlayerArrays:
        f = lambda: np.zeros((nchar, nslot))  # noqa: E731
        return cls(active=np.zeros((nchar, nslot), np.bool_), time=f(), prev_time=f(), speed=f(),
                   length=f(), loop=np.zeros((nchar, nslot), np.bool_), weight=f(), fade=f(),
                   fade_in_rate=f(), fade_out_rate=f(), stopping=np.zeros((nchar, nslot), np.bool_),
                   layer=np.zeros((nchar, nslot), np.int32), layer_weight=np.ones((nchar, nlayer)),
                   effective=f(), flags=np.zeros((nchar, nslot), np.int32))

    def rows(self, start: int, stop: int) -> PlayerArrays:
        """Views of rows [start, stop) (a character's share of a crowd stack)."""
        return PlayerArrays(**{k: getattr(self, k)[start:stop] for k in self.__dataclass_fields__})

    def copy_from(self, other: PlayerArrays) -> None:
        for k in self.__dataclass_fields__:
            getattr(self, k)[...] = getattr(other, k)


def bound_advance(a: PlayerArrays):
    """The advance kernel bound to ``a`` (see ``engine._fastcall``); call it with ``dt``."""
    from engine._fastcall import BoundKernel

    return BoundKernel(advance_slots, (0.0, a.active, a.time, a.prev_time, a.speed, a.length, a.loop, a.weight,
                                       a.fade, a.fade_in_rate, a.fade_out_rate, a.stopping, a.layer, a.layer_weight,
                                       a.effective, a.flags), slots=(0,))


def advance_arrays(a: PlayerArrays, dt: float) -> None:
    """Advance every slot in ``a`` by ``dt`` seconds (one kernel call)."""
    advance_slots(dt, a.active, a.time, a.prev_time, a.speed, a.length, a.loop, a.weight, a.fade,
                  a.fade_in_rate, a.fade_out_rate, a.stopping, a.layer, a.layer_weight, a.effective, a.flags)


#: Bumped with every ``Player.version`` change (any player): a crowd skips its per-member
#: version sums while it has not moved (``engine.runtime._Group``).
CHANGES = [0]


@dataclass
class Player:
    """Clips playing on one character (see the module docstring)."""

    nslot: int = DEFAULT_SLOTS
    nlayer: int = DEFAULT_LAYERS
    arrays: PlayerArrays = field(init=False)
    handles: list[PlayHandle | None] = field(init=False)
    queues: list[deque] = field(init=False)
    on_event: EventCallback | None = None
    _serial: int = 0
    #: Bumped whenever the set of playing clips changes (the runtime re-plans on change).
    version: int = 0
    #: Whether a playing clip has events (after_advance must look at it every frame).
    has_event_clips: bool = False
    _advance_call: object = None

    def __post_init__(self) -> None:
        if self.nslot < 1 or self.nlayer < 1:
            raise ValueError("a player needs at least one slot and one layer")
        self.arrays = PlayerArrays.allocate(1, self.nslot, self.nlayer)
        self.handles = [None] * self.nslot
        self.queues = [deque() for _ in range(self.nlayer)]

    # -- control -----------------------------------------------------------------------

    def play(self, animation, *, payload=None, weight: float = 1.0, fade: float = 0.2,
             fade_out: float | None = None, loop: bool | None = None, speed: float = 1.0,
             layer: int = 0, crossfade: bool = True, on_event: EventCallback | None = None,
             start_time: float = 0.0) -> PlayHandle:
        """Start ``animation`` now. ``fade``: fade-in seconds (and, with ``crossfade``, the
        fade-out of what plays on the layer); ``fade_out``: seconds this clip fades out
        over when it ends or stops (default ``fade``); ``loop`` defaults to the
        animation's own; ``speed`` may be negative (plays backwards)."""
        self._check(weight, fade, fade_out, speed, layer)
        handle = PlayHandle(animation, payload, layer, -1, self._next_serial(), on_event)
        if crossfade:
            self.stop_layer(layer, fade=fade)
        self._start(handle, weight, fade, fade if fade_out is None else fade_out,
                    animation.loop if loop is None else bool(loop), speed, start_time)
        return handle

    def queue(self, animation, *, payload=None, weight: float = 1.0, fade: float = 0.2,
              fade_out: float | None = None, loop: bool | None = None, speed: float = 1.0,
              layer: int = 0, on_event: EventCallback | None = None) -> PlayHandle:
        """Play ``animation`` on ``layer`` when what plays there now ends (at once if
        nothing plays); it fades in over ``fade`` while the ending clip fades out. Behind
        a looping clip it starts at the end of the loop's current cycle."""
        self._check(weight, fade, fade_out, speed, layer)
        handle = PlayHandle(animation, payload, layer, -1, self._next_serial(), on_event)
        q = _Queued(handle, weight, fade, fade if fade_out is None else fade_out,
                    animation.loop if loop is None else bool(loop), speed)
        if not any(h is not None and h.layer == layer and not self.arrays.stopping[0, h.slot]
                   for h in self.handles):
            self._start_queued(q)
        else:
            self.queues[layer].append(q)
            self._cover_queue_fade(layer)
        return handle

    def stop(self, handle: PlayHandle, fade: float = 0.2) -> None:
        """Fade ``handle`` out over ``fade`` seconds (0: at once). Queued: drop it."""
        if handle.slot < 0:
            for q in self.queues[handle.layer]:
                if q.handle is handle:
                    self.queues[handle.layer].remove(q)
                    handle.finished = True
                    return
            return
        self._stop_slot(handle.slot, fade)

    def stop_layer(self, layer: int, fade: float = 0.2) -> None:
        for s, h in enumerate(self.handles):
            if h is not None and h.layer == layer:
                self._stop_slot(s, fade)

    def stop_all(self, fade: float = 0.2) -> None:
        for q in self.queues:
            q.clear()
        for s, h in enumerate(self.handles):
            if h is not None:
                self._stop_slot(s, fade)

    def set_layer_weight(self, layer: int, weight: float) -> None:
        if not 0 <= layer < self.nlayer:
            raise ValueError(f"layer {layer} out of range 0..{self.nlayer - 1}")
        if not (0.0 <= weight <= 1.0):
            raise ValueError(f"layer weight must be in [0, 1], got {weight!r}")
        self.arrays.layer_weight[0, layer] = weight

    def set_weight(self, handle: PlayHandle, weight: float) -> None:
        if not (0.0 <= weight <= 1.0):
            raise ValueError(f"weight must be in [0, 1], got {weight!r}")
        if handle.slot >= 0:
            self.arrays.weight[0, handle.slot] = weight

    # -- per frame ---------------------------------------------------------------------

    def advance(self, dt: float) -> None:
        """Advance this player alone (a crowd advances all players' arrays in one call,
        then calls ``after_advance`` on each)."""
        bound = self._advance_call
        if bound is None or bound.args[1] is not self.arrays.active:
            bound = self._advance_call = bound_advance(self.arrays)
        if bound.call(float(dt)) or self.has_event_clips:
            self.after_advance()

    def after_advance(self) -> None:
        """Events, clip ends and the queue: Python work only when something happened."""
        a = self.arrays
        if not self.has_event_clips and not a.flags.any():
            return
        for s in range(self.nslot):
            h = self.handles[s]
            if h is None:
                continue
            flags = int(a.flags[0, s])
            if _has_events(h.animation):
                self._fire_events(h, float(a.prev_time[0, s]), float(a.time[0, s]), bool(flags & FLAG_WRAPPED),
                                  float(a.speed[0, s]), float(a.length[0, s]))
            if flags & FLAG_ENDING and self.queues[h.layer]:
                q = self.queues[h.layer].popleft()
                self._start_queued(q)
                if q.fade > 0.0 and q.handle.slot >= 0:
                    # the ending clip already took this frame's step of its fade-out: the
                    # queued one takes the complement, so the weights sum to 1 from now on
                    n = q.handle.slot
                    f = min(max(1.0 - float(a.fade[0, s]), 0.0), 1.0)
                    a.fade[0, n] = f
                    a.effective[0, n] = (a.layer_weight[0, h.layer] * a.weight[0, n] * f * f * (3.0 - 2.0 * f))
                self._cover_queue_fade(h.layer)
            elif flags & FLAG_WRAPPED and self.queues[h.layer] and not a.stopping[0, s]:
                # A looping clip never ends: what is queued behind it takes over at the
                # end of its current cycle, cross-fading over the queued clip's fade-in
                # (the loop fades out while the queued clip fades in: their weights sum to 1).
                q = self.queues[h.layer].popleft()
                self._stop_slot(s, q.fade)
                self._start_queued(q)
                self._cover_queue_fade(h.layer)
            if flags & FLAG_FREED:
                h.slot = -1
                h.finished = True
                self.handles[s] = None
                self._changed()
                if self.queues[h.layer] and not any(
                        o is not None and o.layer == h.layer for o in self.handles):
                    self._start_queued(self.queues[h.layer].popleft())

    def active(self) -> list[tuple[PlayHandle, float, float]]:
        """(handle, local time, effective weight) of every playing clip, by slot."""
        a = self.arrays
        return [(h, float(a.time[0, s]), float(a.effective[0, s]))
                for s, h in enumerate(self.handles) if h is not None]

    # -- internals ---------------------------------------------------------------------

    def _changed(self) -> None:
        self.version += 1
        CHANGES[0] += 1
        self.has_event_clips = any(h is not None and _has_events(h.animation) for h in self.handles)

    def _next_serial(self) -> int:
        self._serial += 1
        return self._serial

    def _check(self, weight, fade, fade_out, speed, layer):
        if not (0.0 <= weight <= 1.0):
            raise ValueError(f"weight must be in [0, 1], got {weight!r}")
        for name, v in (("fade", fade), ("fade_out", fade_out)):
            if v is not None and not (v >= 0.0 and np.isfinite(v)):
                raise ValueError(f"{name} must be a finite number of seconds >= 0, got {v!r}")
        if not np.isfinite(speed):
            raise ValueError(f"speed must be finite, got {speed!r}")
        if not 0 <= layer < self.nlayer:
            raise ValueError(f"layer {layer} out of range 0..{self.nlayer - 1}")

    def _free_slot(self) -> int:
        for s, h in enumerate(self.handles):
            if h is None:
                return s
        # Full: reuse the faintest stopping slot, else the faintest slot.
        a = self.arrays
        order = sorted(range(self.nslot), key=lambda s: (not a.stopping[0, s], a.effective[0, s]))
        s = order[0]
        old = self.handles[s]
        old.slot, old.finished = -1, True
        self.handles[s] = None
        self._changed()
        return s

    def _start(self, handle, weight, fade, fade_out, loop, speed, start_time):
        s = self._free_slot()
        a = self.arrays
        length = float(handle.animation.length)
        a.active[0, s] = True
        t = start_time if speed >= 0 else length - start_time
        a.time[0, s] = t
        a.prev_time[0, s] = t
        a.speed[0, s] = speed
        a.length[0, s] = length
        a.loop[0, s] = loop
        a.weight[0, s] = weight
        a.fade[0, s] = 0.0 if fade > 0.0 else 1.0
        a.fade_in_rate[0, s] = 0.0 if fade <= 0.0 else 1.0 / fade
        a.fade_out_rate[0, s] = 0.0 if fade_out <= 0.0 else 1.0 / fade_out
        a.stopping[0, s] = False
        a.layer[0, s] = handle.layer
        a.effective[0, s] = 0.0
        a.flags[0, s] = 0
        handle.slot = s
        self.handles[s] = handle
        self._changed()
        # Events keyed at the very start fire on the first frame.
        handle._events_from_start = start_time == 0.0  # type: ignore[attr-defined]

    def _cover_queue_fade(self, layer: int) -> None:
        """A one-shot clip with a clip queued behind it fades out over at least the queued
        clip's fade-in, so the two cross-fade (weights summing to 1). Without it a clip
        played with ``fade=0`` (whose fade-out defaults to 0) was cut at its end while the
        queued clip faded in from no weight: a frame with almost no clip weight on the
        layer, the rest pose's goals, and a knee flipped 2 rad (issue 13, the dog after a
        fall)."""
        if not self.queues[layer]:
            return
        fade = self.queues[layer][0].fade
        if fade <= 0.0:
            return
        a = self.arrays
        for s, h in enumerate(self.handles):
            if h is None or h.layer != layer or a.stopping[0, s] or a.loop[0, s]:
                continue
            rate = float(a.fade_out_rate[0, s])
            if rate <= 0.0 or rate > 1.0 / fade:
                a.fade_out_rate[0, s] = 1.0 / fade

    def _start_queued(self, q: _Queued) -> None:
        self._start(q.handle, q.weight, q.fade, q.fade_out, q.loop, q.speed, 0.0)

    def _stop_slot(self, s: int, fade: float) -> None:
        a = self.arrays
        if not a.active[0, s]:
            return
        if not a.stopping[0, s] or fade <= 0.0:
            a.stopping[0, s] = True
            a.fade_out_rate[0, s] = 0.0 if fade <= 0.0 else 1.0 / fade
        if fade <= 0.0:
            h = self.handles[s]
            a.active[0, s] = False
            a.fade[0, s] = 0.0
            a.effective[0, s] = 0.0
            h.slot, h.finished = -1, True
            self.handles[s] = None
            self._changed()

    def _fire_events(self, h: PlayHandle, t0: float, t1: float, wrapped: bool, speed: float,
                     length: float) -> None:
        anim = h.animation
        first = getattr(h, "_events_from_start", False)
        h._events_from_start = False  # type: ignore[attr-defined]
        # Intervals partition the timeline, so no event fires twice: forward (t0, t1],
        # backward [t1, t0); a wrap splits the step at the loop seam.
        if speed >= 0.0:
            spans = [(t0, length, False, True), (0.0, t1, True, True)] if wrapped else [(t0, t1, first, True)]
        else:
            spans = [(0.0, t0, True, False), (t1, length, True, True)] if wrapped else [(t1, t0, True, False)]
        fired = []
        for k, (lo, hi, lo_in, hi_in) in enumerate(spans):
            for channel in anim.channels:
                for event in channel.events:
                    if (event.t > lo or (lo_in and event.t == lo)) and (event.t < hi or (hi_in and event.t == hi)):
                        fired.append(((k, event.t if speed >= 0.0 else -event.t), channel.name, event))
        fired.sort(key=lambda f: f[0])
        for _, channel, event in fired:
            for callback in (h.on_event, self.on_event):
                if callback is not None:
                    callback(h, channel, event)


def _has_events(animation) -> bool:
    cached = getattr(animation, "_menagerie_has_events", None)
    if cached is None:
        cached = any(c.events for c in animation.channels)
        try:
            object.__setattr__(animation, "_menagerie_has_events", cached)
        except (AttributeError, TypeError):
            pass
    return cached
