"""The motion library of a creature for impact response: every frame (30 Hz) of the
animations that play on it, posed through the normal runtime, in character space.

    lib = library_for(creature)                  # built once per creature, cached
    lib.pos (F, n, 3), lib.rot (F, n, 4)         # world = character space (placement at origin)
    lib.clip_of (F,), lib.time (F,)              # which clip, at which time (s)
    lib.starts                                   # unique window starts (culled)

Any creature: the clips are the library animations in ``animations/`` that bind to the
creature (generalized animations, played through the channel system), plus any extra
Animations a caller passes (a capture's BVH clips on its own skeleton).
"""

from __future__ import annotations

import glob
import os
import time
import weakref

import numpy as np

from engine.errors import MenagerieError

RATE = 30.0
WINDOW = 6           # frames per search window (0.2 s at 30 Hz)
UNIQUE_TOL = 0.01    # a window start is kept when its weighted pose differs this much from the last kept


def _animations_dir() -> str:
    return os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                        "animations")


class MotionLibrary:
    def __init__(self, creature, clips, *, rate: float = RATE, window: int = WINDOW, progress: bool = True) -> None:
        from engine.response.search import body_weights, frame_distance_rows, yaw_of
        from engine.runtime import Character

        t0 = time.perf_counter()
        self.creature = creature
        self.rate = rate
        self.window = window
        pos, rot, clip_of, tt, kept = [], [], [], [], []
        for anim in clips:
            try:
                ch = Character(creature)
                ch.stages.jiggle = False
                ch.play(anim, fade=0.0)
            except MenagerieError:
                continue
            nfr = max(int(anim.length * rate), window)
            ok = True
            fp = np.zeros((nfr, creature.nbody, 3))
            fr = np.zeros((nfr, creature.nbody, 4))
            ch.tick(1e-6)
            try:
                for k in range(nfr):
                    fp[k] = ch.world_positions
                    fr[k] = ch.world_rotations
                    ch.tick(1.0 / rate)
            except MenagerieError:
                ok = False
            if not ok or not np.all(np.isfinite(fp)):
                continue
            kept.append(anim)
            pos.append(fp)
            rot.append(fr)
            clip_of.append(np.full(nfr, len(kept) - 1, np.int64))
            tt.append(np.arange(nfr) / rate)
            if progress and time.perf_counter() - t0 > 1.0 and len(kept) % 5 == 0:
                print(f"  motion library of {creature.name}: {sum(len(c) for c in clip_of)} frames", flush=True)
        if not kept:
            raise MenagerieError(f"no animation plays on creature '{creature.name}': its motion library is empty")
        self.clips = kept
        self.pos = np.concatenate(pos)
        self.rot = np.concatenate(rot)
        self.clip_of = np.concatenate(clip_of)
        self.time = np.concatenate(tt)
        F = self.pos.shape[0]
        # a window may start at s when s .. s + window - 1 are frames of the same clip
        end_ok = np.zeros(F, bool)
        end_ok[: F - window + 1] = self.clip_of[: F - window + 1] == self.clip_of[window - 1:]
        self.valid = end_ok
        self.yaw, self.xy = yaw_of(creature, self.rot[:, 0], self.pos[:, 0])
        w = body_weights(creature)
        self.weights = w
        # unique-frame culling (paper section 3): consecutive near-identical starts dropped
        d = frame_distance_rows(creature, self.pos[1:], self.rot[1:], self.pos[:-1], self.rot[:-1], w)
        starts = []
        acc = np.inf
        for s in range(F):
            if s > 0:
                acc += d[s - 1]
                if self.clip_of[s] != self.clip_of[s - 1]:
                    acc = np.inf
            if self.valid[s] and acc >= UNIQUE_TOL:
                starts.append(s)
                acc = 0.0
        self.starts = np.array(starts, np.int64)
        from engine.response.search import library_windows

        self.win_pos, self.win_rot = library_windows(self, self.starts)
        self.build_seconds = time.perf_counter() - t0

    @property
    def frames(self) -> int:
        return int(self.pos.shape[0])


_LIBS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def default_clips():
    import engine

    out = []
    for path in sorted(glob.glob(os.path.join(_animations_dir(), "*.yaml"))):
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
