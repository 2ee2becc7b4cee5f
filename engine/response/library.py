"""The motion library of a creature for impact response: every frame (30 Hz) of what the
creature can play, posed through the normal runtime, in world space.

    lib = library_for(creature)                  # built once per creature, cached
    lib.pos (F, n, 3), lib.rot (F, n, 4)         # world poses
    lib.clip_of (F,), lib.time (F,)              # which entry, at which clip time (s)
    lib.entries[i]                               # LibraryEntry: animation, variant, speed, gait
    lib.starts                                   # unique window starts (culled)

What it holds, for any creature (generalized animations played through the channel
system, so a spider's library is a spider's):

* every animation in ``animations/`` and ``animations/reactions/`` (the generalized
  staggers, brace, falls, lying and getting up) that binds to the creature, in **every
  variant** (a wave with each hand, and each mirror image), each at seven playback speeds
  (0.6 to 1.25: the same poses at other velocities, which the window distance sees);
* **gait cycles** of the creature's own gait system (``GAIT_COMMANDS``: walking forward,
  backward, sideways both ways and turning both ways, sneaking, running straight and
  turning; speeds in leg lengths per second), recorded after half a second of warm-up.
  A gait entry is matched only while the character itself
  locomotes (``ImpactResponse`` passes ``allow_gait``): a response cannot start a walk the
  game did not ask for;
* extra Animations a caller passes (a capture's clips on its own skeleton).

The frames are made by a ``Crowd`` of characters (one per entry, jiggle off) ticked
together, so the batched kernels do the work.

Cached on disk: the recorded frames are kept in ``$MENAGERIE_CACHE/motion_library/``
(default ``~/.cache/menagerie``), keyed by the creature's arrays, the content of every
clip, this module's settings and the source of the engine that posed them, so any change
to any of those builds afresh. ``cache=False`` skips it; an unwritable cache is ignored.
"""

from __future__ import annotations

import glob
import hashlib
import os
import time
import weakref
from dataclasses import dataclass

import numpy as np

from engine.errors import MenagerieError

RATE = 30.0
WINDOW = 6           # frames per search window (0.2 s at 30 Hz)
UNIQUE_TOL = 0.02    # a window start is kept when its weighted pose differs this much from the last kept
SPEEDS = (0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.25)   # playback speeds of every clip (faster falls turned feet 0.7 rad/frame)
GAIT_SECONDS = 2.5   # recorded per gait command, after GAIT_WARMUP (the gait controller is Python:
GAIT_WARMUP = 0.5    # about 0.6 ms a step, the most expensive frames of the library)
#: gait commands: style, (forward, left) in leg lengths per second, turn rate rad/s
GAIT_COMMANDS = (("walk", 0.5, 0.0, 0.0), ("walk", 1.0, 0.0, 0.0), ("walk", -0.5, 0.0, 0.0),
                 ("walk", 0.0, 0.5, 0.0), ("walk", 0.0, -0.5, 0.0), ("walk", 0.8, 0.0, 1.0),
                 ("walk", 0.8, 0.0, -1.0), ("sneak", 0.5, 0.0, 0.0), ("run", 1.5, 0.0, 0.0),
                 ("run", 2.0, 0.0, 0.0), ("run", 1.5, 0.0, 0.8), ("run", 1.5, 0.0, -0.8))
CROWD = 48           # characters ticked together
FLIP_TURN = 0.7      # rad a body turns between two library frames (1/30 s, 21 rad/s): a flip, not motion


@dataclass(frozen=True)
class LibraryEntry:
    name: str
    animation: object = None      # Animation (None for a gait entry)
    variant: int = 0
    speed: float = 1.0
    gait: tuple | None = None     # (forward, left, turn) in m/s and rad/s for a gait entry
    frames: int = 0
    style: str | None = None      # the gait style

    @property
    def loop(self) -> bool:
        return self.animation is not None and self.animation.loop


def _animations_dir() -> str:
    return os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                        "animations")


def _jobs(creature, clips, rate, window, speeds, gaits):
    from engine.anim.binding import bind

    jobs = []
    for anim in clips:
        try:
            b = bind(anim, creature)
        except MenagerieError:
            continue
        for v in range(b.nvariant):
            for sp in speeds:
                nfr = max(int(anim.length / sp * rate), window)
                vid = b.variants[v].id
                jobs.append(LibraryEntry(f"{anim.name}[{vid}]x{sp:.2f}", anim, v, sp, None, nfr))
    if gaits and creature.nleg:
        leg = float(np.mean(creature.leg_length))
        for style, f, lft, turn in GAIT_COMMANDS:
            jobs.append(LibraryEntry(f"gait:{style}({f:g},{lft:g},{turn:g})", None, 0, 1.0,
                                     (f * leg, lft * leg, turn), int(GAIT_SECONDS * rate), style))
    return jobs


def _cache_dir() -> str:
    return os.path.join(os.environ.get("MENAGERIE_CACHE") or os.path.join(os.path.expanduser("~"), ".cache",
                                                                          "menagerie"), "motion_library")


_ENGINE_HASH: list = []


def _engine_hash() -> str:
    if not _ENGINE_HASH:
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        h = hashlib.sha1()
        for path in sorted(glob.glob(os.path.join(root, "**", "*.py"), recursive=True)):
            with open(path, "rb") as f:
                h.update(f.read())
        _ENGINE_HASH.append(h.hexdigest())
    return _ENGINE_HASH[0]


def _cache_key(creature, jobs, rate) -> str:
    h = hashlib.sha1()
    for name in ("body_parent", "body_caps", "body_rest_pos", "body_rest_rot", "body_joint", "body_extent"):
        h.update(np.ascontiguousarray(getattr(creature, name)).tobytes())
    h.update("\n".join(creature.body_names).encode())
    seen = set()
    for e in jobs:
        h.update(repr((e.name, e.variant, e.speed, e.gait, e.frames, e.style)).encode())
        if e.animation is not None and id(e.animation) not in seen:
            seen.add(id(e.animation))
            h.update(repr(e.animation).encode())
    h.update(repr((rate, GAIT_WARMUP, CROWD)).encode())
    h.update(_engine_hash().encode())
    return h.hexdigest()


def _record(creature, jobs, rate, progress_t0, progress):
    """Frames (F, n, 3), (F, n, 4) of every job, in job order, and the jobs that played."""
    from engine.runtime import Character, Crowd

    n = creature.nbody
    out = {}
    order = sorted(range(len(jobs)), key=lambda i: jobs[i].frames + (GAIT_WARMUP * rate if jobs[i].gait else 0))
    done = 0
    shown = False
    for c0 in range(0, len(order), CROWD):
        idx = order[c0:c0 + CROWD]
        chars, live = [], []
        for i in idx:
            e = jobs[i]
            ch = Character(creature)
            ch.stages.jiggle = False
            try:
                if e.animation is not None:
                    ch.play(e.animation, variant=e.variant, fade=0.0, speed=e.speed)
                else:
                    ch.locomote(e.gait[:2], e.gait[2])
                    ch.gait.set_style(e.style)
            except (MenagerieError, ValueError, KeyError):
                continue
            chars.append(ch)
            live.append(i)
        if not chars:
            continue
        crowd = Crowd(chars)
        warm = [int(GAIT_WARMUP * rate) if jobs[i].gait else 0 for i in live]
        length = [jobs[i].frames for i in live]
        buf = [(np.zeros((length[j], n, 3)), np.zeros((length[j], n, 4))) for j in range(len(live))]
        total = max(w + m for w, m in zip(warm, length, strict=True))
        ok = [True] * len(live)
        crowd.tick(1e-6)
        for k in range(total):
            for j, ch in enumerate(chars):
                f = k - warm[j]
                if 0 <= f < length[j]:
                    buf[j][0][f] = ch.world_positions
                    buf[j][1][f] = ch.world_rotations
            for j, i in enumerate(live):
                if jobs[i].gait:
                    chars[j].locomote(jobs[i].gait[:2], jobs[i].gait[2])
            try:
                crowd.tick(1.0 / rate)
            except MenagerieError:
                ok = [False] * len(live)
                break
        for j, i in enumerate(live):
            if ok[j] and np.all(np.isfinite(buf[j][0])):
                out[i] = buf[j]
        done += len(idx)
        if progress and time.perf_counter() - progress_t0 > 1.0:
            frames = sum(b[0].shape[0] for b in out.values())
            print(f"\r  motion library of {creature.name}: {done}/{len(jobs)} entries, {frames} frames",
                  end="", flush=True)
            shown = True
    if shown:
        print(flush=True)
    return out


class MotionLibrary:
    def __init__(self, creature, clips, *, rate: float = RATE, window: int = WINDOW, progress: bool = True,
                 speeds=SPEEDS, gaits: bool = True, cache: bool = True) -> None:
        from engine.response.search import body_weights, build_prefilter, frame_distance_rows, library_windows, yaw_of

        t0 = time.perf_counter()
        self.creature = creature
        self.rate = rate
        self.window = window
        jobs = _jobs(creature, clips, rate, window, speeds, gaits)
        rec = None
        path = None
        self.from_cache = False
        if cache:
            path = os.path.join(_cache_dir(), _cache_key(creature, jobs, rate) + ".npz")
            try:
                with np.load(path) as z:
                    kept, lens = z["kept"], z["lens"]
                    pos, rot = z["pos"], z["rot"]
                at = np.r_[0, np.cumsum(lens)]
                rec = {int(i): (pos[at[j]:at[j + 1]], rot[at[j]:at[j + 1]]) for j, i in enumerate(kept)}
                self.from_cache = True
            except (OSError, KeyError, ValueError):
                rec = None
        if rec is None:
            import numba

            # one thread: the crowd's parallel IK kernel spent 20 ms a call against a loaded
            # machine's other work (2 ms alone); the build is meant for one core
            threads = numba.get_num_threads()
            numba.set_num_threads(1)
            try:
                rec = _record(creature, jobs, rate, t0, progress)
            finally:
                numba.set_num_threads(threads)
            if path is not None and rec:
                kept = sorted(rec)
                try:
                    os.makedirs(os.path.dirname(path), exist_ok=True)
                    tmp = f"{path}.{os.getpid()}.tmp.npz"
                    np.savez(tmp, kept=np.array(kept, np.int64), lens=np.array([rec[i][0].shape[0] for i in kept]),
                             pos=np.concatenate([rec[i][0] for i in kept]),
                             rot=np.concatenate([rec[i][1] for i in kept]))
                    os.replace(tmp, path)
                except OSError:
                    pass
        if not rec:
            raise MenagerieError(f"no animation plays on creature '{creature.name}': its motion library is empty")
        keep = sorted(rec)
        self.entries = [jobs[i] for i in keep]
        self.clips = [e.animation for e in self.entries]
        self.by_name = {e.animation.name: e.animation for e in self.entries if e.animation is not None}
        # what continues each clip (``Animation.follows``: a fall's lying, then getting up)
        self.followed_by = {a.follows: a for a in self.by_name.values() if a.follows is not None}
        self.pos = np.concatenate([rec[i][0] for i in keep])
        self.rot = np.concatenate([rec[i][1] for i in keep])
        self.clip_of = np.concatenate([np.full(rec[i][0].shape[0], j, np.int64) for j, i in enumerate(keep)])
        self.time = np.concatenate([np.arange(rec[i][0].shape[0]) * (jobs[i].speed / rate) for i in keep])
        self.is_gait = np.array([e.gait is not None for e in self.entries], bool)
        F = self.pos.shape[0]
        # a window may start at s when s .. s + window - 1 are frames of the same entry
        end_ok = np.zeros(F, bool)
        end_ok[: F - window + 1] = self.clip_of[: F - window + 1] == self.clip_of[window - 1:]
        # An entry that flips anywhere on this creature (a body turning more than FLIP_TURN
        # between two library frames) is never re-entered: playing it would show the flip (the
        # centipede's stagger_right swings a leg past full reach and turns it 2.8 rad in one
        # frame). The whole entry, not only its starts before the flip: played live from a
        # later start, the IK took the other branch again 0.3 s on (s31).
        turn = _step_turns(self.rot)
        flip = np.zeros(F, bool)
        flip[1:] = (turn > FLIP_TURN) & (self.clip_of[1:] == self.clip_of[:-1])
        self.flipped = np.zeros(len(keep), bool)   #: per entry: it flips somewhere on this creature
        self.flipped[self.clip_of[flip]] = True
        end_ok &= ~self.flipped[self.clip_of]
        self.valid = end_ok
        self.yaw, self.xy = yaw_of(creature, self.rot[:, 0], self.pos[:, 0])
        self.travel = entry_travel(self.clip_of, self.xy, self.yaw)
        w = body_weights(creature)
        self.weights = w
        # unique-frame culling (paper section 3): consecutive near-identical starts dropped
        d = frame_distance_rows(creature, self.pos[1:], self.rot[1:], self.pos[:-1], self.rot[:-1], w)
        starts = []
        acc = np.inf
        new_entry = np.r_[True, self.clip_of[1:] != self.clip_of[:-1]]
        valid = self.valid
        for s in range(F):
            if new_entry[s]:
                acc = np.inf
            elif s > 0:
                acc += d[s - 1]
            if valid[s] and acc >= UNIQUE_TOL:
                starts.append(s)
                acc = 0.0
        self.starts = np.array(starts, np.int64)
        self.win_pos, self.win_rot = library_windows(self, self.starts)
        self.prefilter = build_prefilter(self)
        self.build_seconds = time.perf_counter() - t0

    def goes_down(self, frame: int) -> bool:
        """The entry of library frame ``frame`` takes the root more than half the way from its
        rest height down to where its box would lie on the ground, from there on (a fall,
        lying; a low creature's collapse too): the response lets the standing controller go.
        A brace (a fifth of the way) and a stagger do not."""
        from engine.channels.modes import ground_height

        end = int(np.searchsorted(self.clip_of, self.clip_of[frame], side="right"))
        rest = float(self.creature.body_rest_pos[0, 2])
        low = ground_height(self.creature, 0)
        return bool(self.pos[frame:end, 0, 2].min() < rest - 0.5 * (rest - low))

    @property
    def frames(self) -> int:
        return int(self.pos.shape[0])


def entry_travel(clip_of: np.ndarray, xy: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """(F, 2): per library frame, how far its entry still carries the root in the ground
    plane (to the entry's last frame), in the frame's own heading: a stagger's remaining
    steps, a fall's remaining slide; about zero for a clip played in place."""
    last = np.searchsorted(clip_of, clip_of, side="right") - 1
    d = xy[last] - xy
    c, s = np.cos(-yaw), np.sin(-yaw)
    return np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], axis=1)


def _step_turns(rot: np.ndarray) -> np.ndarray:
    """(F - 1,) the largest angle any body turns between consecutive frames, rad."""
    d = np.abs(np.einsum("fbk,fbk->fb", rot[1:], rot[:-1]))
    return 2.0 * np.arccos(np.minimum(d.min(axis=1), 1.0))


_LIBS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def default_clips():
    import engine

    out = []
    d = _animations_dir()
    paths = sorted(glob.glob(os.path.join(d, "*.yaml"))) + sorted(glob.glob(os.path.join(d, "reactions", "*.yaml")))
    for path in paths:
        try:
            out.append(engine.load_animation(path))
        except MenagerieError:
            continue
    return out


def library_for(creature, extra=()) -> MotionLibrary:
    """The creature's library (built on first use, kept while the creature lives)."""
    key = tuple(id(a) for a in extra)
    per = _LIBS.setdefault(creature, {})
    hit = per.get(key)
    if hit is None:
        hit = per[key] = MotionLibrary(creature, default_clips() + list(extra))
    return hit
