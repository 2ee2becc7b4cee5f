"""Play one grid cell through the runtime and record what a game would see, frame by frame.

A cell is one animation variant on one creature with one set of external targets, played
by ``engine.Character`` at 60 Hz exactly as a game plays it: ``play`` with the default
fade, the whole clip (a looping clip: two cycles, then ``stop`` with the default fade),
then ``settle`` seconds more so the fade-out and the pose the character returns to are
seen. A clip that continues others (``follows``: a fall's lying, then its getting up;
``engine.anim.chain``) starts where a game starts it, after them (played unrecorded from
the rest pose), and a clip that another continues hands over to it at its end instead of
stopping (the settle then shows the hand-over; ``meta['then']`` names it). Every tick's
output is copied into preallocated arrays (``Recording``):

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

``record_cell`` ticks one ``Character`` alone; ``record_cells`` plays many cells of one
creature as members of ``engine.Crowd``s (the batched path a game's crowd takes; its
members are bit-identical to characters ticked alone, ``tests/test_crowd.py``), which
is how the grid plays them: several times cheaper per cell. ``tick_s`` is then the
crowd's tick over its members. ``scrub_poses`` jumps fresh characters straight to given
clip times, for path independence.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from engine.anim.animation import Animation
from engine.anim.chain import lead_in, successor
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
    then = successor(animation)
    try:
        handle = _start(ch, animation, variant, looping, fade, dt)
    except Exception as exc:  # noqa: BLE001 - a failing cell is reported, never raised
        rec.error = f"{type(exc).__name__}: {exc}"
        rec.error_frame = 0
        _truncate(rec, 0)
        return rec
    rec.variant_id = handle.payload.bound.variant.id
    if then is not None:
        rec.meta["then"] = then.name
        if not looping:      # it takes over as this clip ends (a fall goes on lying)
            ch.queue(then, fade=fade, fade_out=fade, loop=False)
    s, r = ch._stack, ch._row
    a = s.player
    slot = handle.slot
    for i in range(n):
        if looping and i == n_play - 1 and then is not None:
            ch.queue(then, fade=fade, fade_out=fade, loop=False)   # at the end of this cycle
        elif looping and i == n_play and then is None:
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
        _note_plan(rec, i, ch)
    return rec


def _start(ch, animation: Animation, variant: int, looping: bool, fade: float, dt: float):
    """Start ``animation`` on ``ch`` as a game does: at once, or, for a clip that continues
    others (``follows``, ``engine.anim.chain``), after playing them from the rest pose,
    ticked unrecorded until it starts (fading in over the last one's end). Returns its
    handle."""
    chain = lead_in(animation)
    if not chain:
        return ch.play(animation, variant=variant, loop=looping, fade=fade)
    ch.play(chain[0], loop=False, fade=fade)
    for prev in chain[1:]:
        ch.queue(prev, fade=fade, fade_out=fade, loop=False)
    h = ch.queue(animation, variant=variant, fade=fade, fade_out=fade, loop=looping)
    most = int((sum(p.length for p in chain) + 1.0) / dt)
    for _ in range(most):
        if h.playing:
            return h
        ch.tick(dt)
    raise RuntimeError(f"{animation.name} did not start after {', '.join(p.name for p in chain)} "
                       f"({most * dt:.1f} s)")


def _note_plan(rec: Recording, i: int, ch) -> None:
    """Remember the IK plan frame ``i`` was solved with (``meta['ik_plans']``, and per
    frame its index in ``meta['ik_plan_of_frame']``): the goal metrics judge a frame
    against the goals that plan's limb phase was asked (goals settled out of the
    creature's own bodies, ``engine.ik.selfcollision.settled_goals``)."""
    plans = rec.meta.setdefault("ik_plans", [])
    idx = rec.meta.get("ik_plan_of_frame")
    if idx is None or idx.shape[0] != rec.t.shape[0]:
        idx = rec.meta["ik_plan_of_frame"] = np.full(rec.t.shape[0], -1, np.int64)
    p = ch.ik_plan
    if p is None:
        return
    for k, q in enumerate(plans):
        if q is p:
            idx[i] = k
            return
    plans.append(p)
    idx[i] = len(plans) - 1


@dataclass(frozen=True)
class PlaySpec:
    """One play of a cell: the animation, its variant index, the external targets."""

    animation: Animation
    variant: int
    targets: dict


#: Members per crowd in ``record_cells`` (recordings of a crowd are held at once).
CROWD = 16
#: Stack arrays a recording keeps (stack name -> Recording field).
_STACKED = {"world_pos": "world_pos", "world_rot": "world_rot", "goal_pos": "goal_pos", "goal_rot": "goal_rot",
            "goal_pw": "goal_pw", "goal_rw": "goal_rw", "root_pos": "root_pos", "root_rot": "root_rot",
            "driven": "driven"}


def record_cells(creature: Creature, specs: list[PlaySpec], *, fps: int = FPS, settle: float = SETTLE,
                 fade: float = FADE, crowd: int = CROWD) -> list[Recording]:
    """``record_cell`` for many plays of one creature, ticked as crowds of up to ``crowd``
    members of about the same length (see the module docstring). A crowd that raises is
    played again member by member, so a fault stays with the cell that has it."""
    from engine.runtime import Character, Crowd

    dt = 1.0 / fps
    # clips that continue others or are continued are played alone (``record_cell``): their
    # lead-in differs from member to member
    out: list[Recording | None] = [None] * len(specs)
    alone = [k for k, sp in enumerate(specs) if sp.animation.follows is not None or successor(sp.animation)]
    for k in alone:
        out[k] = record_cell(creature, specs[k].animation, specs[k].variant, specs[k].targets, fps=fps,
                             settle=settle, fade=fade)
    lengths = []
    for sp in specs:
        seconds, _ = play_seconds(sp.animation)
        lengths.append(max(int(round(seconds * fps)), 1) + int(round(settle * fps)))
    order = sorted((k for k in range(len(specs)) if out[k] is None), key=lambda k: lengths[k])
    for start in range(0, len(order), crowd):
        group = order[start:start + crowd]
        chars = [Character(creature) for _ in group]
        recs, handles = [], []
        for ch, k in zip(chars, group, strict=True):
            sp = specs[k]
            for name, p in sp.targets.items():
                ch.set_target(name, p)
        try:
            cr = Crowd(chars)
            for ch, k in zip(chars, group, strict=True):
                sp = specs[k]
                seconds, looping = play_seconds(sp.animation)
                n_play = max(int(round(seconds * fps)), 1)
                n = lengths[k]
                handles.append((ch.play(sp.animation, variant=sp.variant, loop=looping, fade=fade), n_play, looping))
                recs.append(_empty(creature, sp, dt, n_play, n, fade))
                recs[-1].variant_id = handles[-1][0].payload.bound.variant.id
            s = chars[0]._stack
            a = s.player
            m = len(group)
            n_max = max(lengths[k] for k in group)
            # the whole stack copied once per frame, split per member at the end
            frames = {name: np.zeros((n_max,) + getattr(s, name).shape, getattr(s, name).dtype) for name in _STACKED}
            clip_time = np.full((n_max, m), -1.0)
            weight = np.zeros((n_max, m))
            tick = np.zeros(n_max)
            slots = [h.slot for h, _, _ in handles]
            for i in range(n_max):
                for (h, n_play, looping), ch in zip(handles, chars, strict=True):
                    if looping and i == n_play:
                        ch.stop(h, fade=fade)
                t0 = time.perf_counter()
                cr.tick(dt)
                tick[i] = (time.perf_counter() - t0) / m
                for name in _STACKED:
                    frames[name][i] = getattr(s, name)
                for j, ch in enumerate(chars):
                    if i < recs[j].t.shape[0]:
                        _note_plan(recs[j], i, ch)
                for j, (h, _, _) in enumerate(handles):
                    if h.playing:
                        clip_time[i, j] = a.time[j, slots[j]]
                        weight[i, j] = a.effective[j, slots[j]]
            for j, rec in enumerate(recs):
                n = rec.t.shape[0]
                rec.t[:] = (np.arange(n) + 1) * dt
                rec.tick_s[:] = tick[:n]
                rec.clip_time[:] = clip_time[:n, j]
                rec.weight[:] = weight[:n, j]
                for name, field_name in _STACKED.items():
                    getattr(rec, field_name)[:] = frames[name][:n, j]
        except Exception:  # noqa: BLE001 - find the member at fault, alone
            recs = [record_cell(creature, specs[k].animation, specs[k].variant, specs[k].targets, fps=fps,
                                settle=settle, fade=fade) for k in group]
        for k, rec in zip(group, recs, strict=True):
            out[k] = rec
    return out  # type: ignore[return-value]


def _empty(creature: Creature, sp: PlaySpec, dt: float, n_play: int, n: int, fade: float) -> Recording:
    nb = creature.nbody
    return Recording(
        creature=creature, animation=sp.animation, variant=int(sp.variant), variant_id="",
        targets=dict(sp.targets), dt=dt, end_frame=n_play, t=np.zeros(n), clip_time=np.full(n, -1.0),
        weight=np.zeros(n), world_pos=np.zeros((n, nb, 3)), world_rot=np.zeros((n, nb, 4)),
        goal_pos=np.zeros((n, nb, 3)), goal_rot=np.zeros((n, nb, 4)), goal_pw=np.zeros((n, nb)),
        goal_rw=np.zeros((n, nb)), root_pos=np.zeros((n, 3)), root_rot=np.zeros((n, 4)),
        driven=np.zeros((n, nb), np.bool_), tick_s=np.zeros(n), fade=float(fade))


def scrub_poses(creature: Creature, requests: list[tuple[PlaySpec, float]], *, fps: int = FPS,
                crowd: int = 64) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """For each (play, clip time): the pose a fresh character has when it starts the clip
    one frame before that time at full weight and ticks one frame: world positions,
    rotations and the driven mask. Ticked as crowds (one tick each)."""
    from engine.runtime import Character, Crowd

    dt = 1.0 / fps
    out = []
    for start in range(0, len(requests), crowd):
        group = requests[start:start + crowd]
        chars = []
        for sp, _t in group:
            ch = Character(creature)
            for name, p in sp.targets.items():
                ch.set_target(name, p)
            chars.append(ch)
        cr = Crowd(chars)
        for ch, (sp, t) in zip(chars, group, strict=True):
            ch.play(sp.animation, variant=sp.variant, loop=sp.animation.loop, fade=0.0,
                    start_time=min(max(t - dt, 0.0), sp.animation.length))
        cr.tick(dt)
        s = chars[0]._stack
        for m in range(len(group)):
            out.append((s.world_pos[m].copy(), s.world_rot[m].copy(), s.driven[m].copy()))
    return out


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
