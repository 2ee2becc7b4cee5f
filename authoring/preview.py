"""Preview creatures for the authoring tool: one animation played through the whole runtime
on several creatures at once (Hecker et al. 2008, section 3.4). No window here.

``Preview`` owns one ``engine.Character`` per creature, laid out side by side like the
zoo (each drawn at a common size, ``scene.layout_zoo``). ``show(animation, t)`` plays the
animation on every character from time ``t`` exactly as a game does (bind, sample,
specialize, blend, standing feet, IK, Jiggles): the tool never poses a body itself, so
what the animator sees is what the game gets. A creature the animation does not bind to
(a branch predicate, no variant) stands at rest and says why in words.

External targets (a fruit, a rock) are per creature, in its own character space: the
animation's preview default when it has one, else a point a little in front of the
creature at chest height. The tool drags them in the viewport (``set_target``).
"""

from __future__ import annotations

import numpy as np

import engine
from authoring import scene as sc
from engine.anim import Animation
from engine.anim.binding import BindError, bind, branch_failures
from engine.anim.evaluate import default_target
from engine.errors import MenagerieError

FPS = 60
#: Colour of bodies the active channel selects, and of the active body.
SELECTED_COLOR = np.array([0.20, 0.85, 0.95])
ACTIVE_COLOR = np.array([1.00, 0.95, 0.15])
#: Share of the highlight colour mixed into a selected body's palette colour.
SELECTED_MIX = 0.65
DECLINED_COLOR = np.array([0.78, 0.78, 0.80])


class PreviewCreature:
    """One creature of the preview: its character, actor, targets and what it plays."""

    def __init__(self, creature, actor: sc.Actor) -> None:
        self.creature = creature
        self.actor = actor
        self.character = engine.Character(creature)
        self.targets: dict[str, np.ndarray] = {}
        self.variant: str | int | None = None    # the variant the animator picked (None: the first)
        self.declined: str | None = None          # why the animation does not play here, in words
        self.handle = None
        self.base_colors = actor.colors.copy()

    @property
    def name(self) -> str:
        return self.creature.name

    def placed(self, p) -> np.ndarray:
        """Character-space points ((3,) or (n, 3)) in the runtime's world: the character's
        placement (it moves when the gait preview walks it) applied."""
        ch = self.character
        return np.asarray(p, float) @ sc.quat_to_matrix(ch.rotation).T + ch.position

    def to_world(self, p) -> np.ndarray:
        """Character-space points as drawn in the viewport (placement, then the actor's
        offset and scale)."""
        return self.actor.offset + self.actor.scale * self.placed(p)

    def to_character(self, w) -> np.ndarray:
        """The inverse of ``to_world``."""
        ch = self.character
        return ((np.asarray(w, float) - self.actor.offset) / self.actor.scale - ch.position) @ \
            sc.quat_to_matrix(ch.rotation)


class Preview:
    """Several creatures bound to one animation (see the module docstring)."""

    def __init__(self, creatures) -> None:
        creatures = list(creatures)
        if not creatures:
            raise MenagerieError("the preview needs at least one creature")
        self.scene = sc.layout_zoo(creatures, normalize_size=True, labels=True)
        self.items = [PreviewCreature(c, a) for c, a in zip(creatures, self.scene.actors, strict=True)]
        for item in self.items:
            item.actor.base_label = item.actor.label
        self.animation: Animation | None = None
        self.time = 0.0
        self.speed = 0.0
        self.loop = True

    def __len__(self) -> int:
        return len(self.items)

    # -- targets --------------------------------------------------------------------------

    def target_position(self, k: int, name: str) -> np.ndarray:
        """Where external target ``name`` is for creature ``k`` (character space)."""
        item = self.items[k]
        if name not in item.targets:
            c = item.creature
            try:
                item.targets[name] = np.array(default_target(self.animation, c, name), float)
            except MenagerieError:
                h = c.height
                item.targets[name] = np.array([0.7 * h, 0.25 * h, 0.7 * h])
        return item.targets[name]

    def set_target(self, k: int, name: str, position) -> None:
        p = np.asarray(position, float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise MenagerieError(f"target '{name}' must be 3 finite numbers, got {position!r}")
        self.items[k].targets[name] = p.copy()
        self.items[k].character.set_target(name, self.items[k].placed(p))

    # -- playing ------------------------------------------------------------------------------

    def show(self, animation: Animation, t: float, *, speed: float = 0.0, loop: bool = True,
             muted=()) -> None:
        """Play ``animation`` on every creature from time ``t`` at ``speed`` (0: hold the
        pose at ``t``). ``muted``: channel names to leave out (a preview choice, never
        saved: the animation is played without them)."""
        self.animation = animation
        self.time = float(min(max(t, 0.0), animation.length))
        self.speed = float(speed)
        self.loop = bool(loop)
        played = _without(animation, muted)
        for k, item in enumerate(self.items):
            ch = item.character
            failures = branch_failures(played, item.creature)
            item.declined = None
            if failures:
                item.declined = "declines: " + "; ".join(failures)
            else:
                try:
                    b = bind(played, item.creature)
                except MenagerieError as exc:
                    item.declined = "declines: " + getattr(exc, "reason", str(exc))
                else:
                    try:
                        b.variant(item.variant)
                    except BindError:
                        item.variant = None      # that variant is gone after the edit
            for name in played.target_names:
                ch.set_target(name, item.placed(self.target_position(k, name)))
            if item.declined is not None:
                ch.stop(fade=0.0)
                item.handle = None
            else:
                item.handle = ch.play(played, variant=item.variant, fade=0.0, loop=self.loop or played.loop,
                                      speed=self.speed, start_time=self.time)
            ch.tick(1.0 / FPS if self.speed == 0.0 else 1e-6)
            item.actor.set_pose(ch.world_positions, ch.world_rotations)
        self.played = played

    def advance(self, dt: float) -> float:
        """Tick every creature by ``dt`` seconds of wall time (the clip advances at the
        speed it was shown with); returns the animation time now."""
        for item in self.items:
            item.character.tick(dt)
            item.actor.set_pose(item.character.world_positions, item.character.world_rotations)
        t = None
        for item in self.items:
            if item.handle is not None and item.handle.playing:
                for h, local, _w in item.character.player.active():
                    if h is item.handle:
                        t = local
                        break
            if t is not None:
                break
        if t is None and self.animation is not None:
            t = self.time + dt * self.speed
            t = self.animation.local_time(t) if self.loop or self.animation.loop else \
                min(max(t, 0.0), self.animation.length)
        self.time = float(t)
        return self.time

    # -- what the tool asks -----------------------------------------------------------------

    def bound(self, k: int):
        """The bound variant creature ``k`` plays now (None when it declines)."""
        item = self.items[k]
        if item.handle is None or not item.handle.playing:
            return None
        return item.handle.payload

    def variants(self, k: int) -> list[tuple[str, bool]]:
        """(variant id, mirrored) of every variant creature ``k`` gets, the mirror images
        included (empty when it declines)."""
        if self.animation is None or self.items[k].declined is not None:
            return []
        try:
            b = bind(self.played, self.items[k].creature)
        except BindError:
            return []
        return [(v.id, v.mirrored) for v in b.variants]

    def highlight(self, selections: list[np.ndarray], active: tuple[int, int] | None) -> None:
        """Colour the bodies each creature's active channel selects, and the active body."""
        for k, item in enumerate(self.items):
            colors = item.base_colors.copy()
            if item.declined is not None:
                colors = 0.5 * colors + 0.5 * DECLINED_COLOR
            sel = selections[k] if k < len(selections) else ()
            if len(sel):
                colors[sel] = (1 - SELECTED_MIX) * colors[sel] + SELECTED_MIX * SELECTED_COLOR
            if active is not None and active[0] == k:
                colors[active[1]] = ACTIVE_COLOR
            item.actor.colors = colors


def _without(animation: Animation, muted) -> Animation:
    muted = set(muted)
    if not muted:
        return animation
    import dataclasses

    keep = tuple(c for c in animation.channels if c.name not in muted)
    if not keep:
        # Everything muted: play a channel with no effect so the creatures stand at rest.
        from engine.anim.animation import ChannelDef, Key
        from engine.channels.modes import RotationSpec
        from engine.query import Query
        keep = (ChannelDef(name="(muted)", query=Query(type="root"), rotation=RotationSpec(mode="rest"),
                           weight_keys=(Key(0.0, (0.0,)),)),)
    return dataclasses.replace(animation, channels=keep, branches=animation.branches)
