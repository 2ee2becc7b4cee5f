"""Play one grid cell through the runtime and record what a game would see, frame by frame.

A cell is one animation variant on one creature with one set of external targets, played
by ``engine.Character`` at 60 Hz exactly as a game plays it: ``play`` with the default
fade, the whole clip (a looping clip: two cycles, then ``stop`` with the default fade),
then ``settle`` seconds more so the fade-out and the pose the character returns to are
seen. Every tick's output is copied into preallocated arrays (``Recording``):

    t (nf,)                       time since play, s (after the tick)
    clip_time (nf,)               the clip's local time, s (-1 once it has ended)
    weight (nf,)                  the clip's effective weight (fades included)
    world_pos (nf, nb, 3)         every body's world position, m
    world_rot (nf, nb, 4)         world rotation, w-first
    goal_pos (nf, nb, 3)          the goals the IK got (after the blend and the gait or
    goal_rot (nf, nb, 4)          standing stage), character space
    goal_pw, goal_rw (nf, nb)     their weights (0: no goal)
    root_pos (nf, 3), root_rot (nf, 4)   the root's pose (forward-kinematic), character space
    driven (nf, nb) bool          posed by the IK this frame (else passive: Jiggles)
    tick_s (nf,)                  wall time of each tick, s

The character stands at the world origin facing +X on flat ground, so world space and
character space coincide (``place_pos`` is zero, ``place_rot`` the identity).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from engine.anim.animation import Animation
from engine.model.creature import Creature

#: Frame rate of every grid cell (a game's usual 60 Hz).
FPS = 60
#: Seconds played after the clip has ended (its fade-out, then the pose it returns to).
SETTLE = 1.0
#: Fade in and out, s: the runtime's default, what a game gets without asking.
FADE = 0.2


@dataclass
class Recording:
    """The frames of one played cell (see the module docstring for the arrays)."""

    creature: Creature
    animation: Animation
    variant: int
    variant_id: str
    targets: dict
    dt: float
    end_frame: int            # first frame after the clip's last (looping: after its stop)
    t: np.ndarray
    clip_time: np.ndarray
    weight: np.ndarray
    world_pos: np.ndarray
    world_rot: np.ndarray
    goal_pos: np.ndarray
    goal_rot: np.ndarray
    goal_pw: np.ndarray
    goal_rw: np.ndarray
    root_pos: np.ndarray
    root_rot: np.ndarray
    driven: np.ndarray
    tick_s: np.ndarray
    fade: float = FADE                # the fade in and out the clip played with, s
    error: str | None = None          # a raise mid-play: its one-line message
    error_frame: int = -1
    meta: dict = field(default_factory=dict)

    @property
    def nframe(self) -> int:
        return int(self.t.shape[0])


def play_seconds(animation: Animation) -> tuple[float, bool]:
    """(seconds of playing before the stop or end, looping) for ``animation`` in a cell."""
    if animation.loop:
        return 2.0 * float(animation.length), True
    return float(animation.length), False


def record_cell(creature: Creature, animation: Animation, variant: int = 0, targets: dict | None = None,
                *, fps: int = FPS, settle: float = SETTLE, fade: float = FADE, character=None) -> Recording:
    """Play ``animation`` (``variant``) on ``creature`` with ``targets`` (name -> world
    point; missing names take the file's defaults) and record every frame.

    A raise inside the runtime is not propagated: the frames before it are kept and the
    recording carries the message (the grid reports it as a failed cell)."""
    from engine.runtime import Character

    dt = 1.0 / fps
    seconds, looping = play_seconds(animation)
    n_play = max(int(round(seconds * fps)), 1)
    n = n_play + int(round(settle * fps))
    nb = creature.nbody
    rec = Recording(
        creature=creature, animation=animation, variant=int(variant), variant_id="", targets=dict(targets or {}),
        dt=dt, end_frame=n_play, t=np.zeros(n), clip_time=np.full(n, -1.0), weight=np.zeros(n),
        world_pos=np.zeros((n, nb, 3)), world_rot=np.zeros((n, nb, 4)), goal_pos=np.zeros((n, nb, 3)),
        goal_rot=np.zeros((n, nb, 4)), goal_pw=np.zeros((n, nb)), goal_rw=np.zeros((n, nb)),
        root_pos=np.zeros((n, 3)), root_rot=np.zeros((n, 4)), driven=np.zeros((n, nb), np.bool_),
        tick_s=np.zeros(n), fade=float(fade))
    ch = character if character is not None else Character(creature)
    for name, p in rec.targets.items():
        ch.set_target(name, p)
    handle = ch.play(animation, variant=variant, loop=looping, fade=fade)
    rec.variant_id = handle.payload.bound.variant.id
    s, r = ch._stack, ch._row
    a = s.player
    slot = handle.slot
    for i in range(n):
        if looping and i == n_play:
            ch.stop(handle, fade=fade)
        t0 = time.perf_counter()
        try:
            ch.tick(dt)
        except Exception as exc:  # noqa: BLE001 - a failing cell is reported, never raised
            rec.error = f"{type(exc).__name__}: {exc}"
            rec.error_frame = i
            _truncate(rec, i)
            return rec
        rec.tick_s[i] = time.perf_counter() - t0
        rec.t[i] = (i + 1) * dt
        if handle.playing:
            rec.clip_time[i] = a.time[r, slot]
            rec.weight[i] = a.effective[r, slot]
        rec.world_pos[i] = s.world_pos[r]
        rec.world_rot[i] = s.world_rot[r]
        rec.goal_pos[i] = s.goal_pos[r]
        rec.goal_rot[i] = s.goal_rot[r]
        rec.goal_pw[i] = s.goal_pw[r]
        rec.goal_rw[i] = s.goal_rw[r]
        rec.root_pos[i] = s.root_pos[r]
        rec.root_rot[i] = s.root_rot[r]
        rec.driven[i] = s.driven[r]
    return rec


def record_rest(creature: Creature, frames: int, *, fps: int = FPS) -> tuple[np.ndarray, np.ndarray]:
    """World positions and rotations (frames, nb, ...) of a character of ``creature`` that
    plays nothing: the standing pose every cell starts from and returns to."""
    from engine.runtime import Character

    ch = Character(creature)
    pos = np.zeros((frames, creature.nbody, 3))
    rot = np.zeros((frames, creature.nbody, 4))
    for i in range(frames):
        ch.tick(1.0 / fps)
        pos[i] = ch.world_positions
        rot[i] = ch.world_rotations
    return pos, rot


def scrub_pose(creature: Creature, animation: Animation, variant: int, targets: dict | None, t: float,
               *, fade: float = FADE) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pose at time ``t`` of a fresh character that jumps straight there (one tick of
    ``t`` seconds): world positions, rotations and the driven mask. For path independence."""
    from engine.runtime import Character

    ch = Character(creature)
    for name, p in (targets or {}).items():
        ch.set_target(name, p)
    ch.play(animation, variant=variant, loop=animation.loop, fade=fade)
    ch.tick(float(t))
    s, r = ch._stack, ch._row
    return s.world_pos[r].copy(), s.world_rot[r].copy(), s.driven[r].copy()


def _truncate(rec: Recording, n: int) -> None:
    for name in ("t", "clip_time", "weight", "world_pos", "world_rot", "goal_pos", "goal_rot", "goal_pw", "goal_rw",
                 "root_pos", "root_rot", "driven", "tick_s"):
        setattr(rec, name, getattr(rec, name)[:n])
    rec.end_frame = min(rec.end_frame, n)
