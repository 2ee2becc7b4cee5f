"""Clips that continue one another: an animation's ``follows`` names the clip it starts
from the end of (a fall's lying, then its getting up: ``animations/reactions``).

A game plays such a clip after the one it follows, never from the rest pose (the impact
response queues a fall's lying and getting up behind it), so the validation grid plays the
chain before it (``lead_in``) and hands it on to what follows it (``successor``) instead of
judging a jump from standing to lying and back. Both look for the clips in the directory of
the animation's file, ``<name>.yaml`` by name; what they load is cached by file and
modification time.
"""

from __future__ import annotations

import os

from engine.anim.animation import Animation, AnimationError

#: Longest chain of ``follows`` followed before it is called a cycle.
MAX_CHAIN = 8

_cache: dict[str, tuple[int, Animation]] = {}


def _load(path: str) -> Animation:
    from engine.anim.fileio import load_animation

    mtime = os.stat(path).st_mtime_ns
    hit = _cache.get(path)
    if hit is not None and hit[0] == mtime:
        return hit[1]
    a = load_animation(path)
    _cache[path] = (mtime, a)
    return a


def lead_in(animation: Animation) -> tuple[Animation, ...]:
    """The clips played before ``animation``, the first first (empty when it follows none).

    Raises ``AnimationError`` naming the file and the ``follows`` field when a clip it
    follows is not next to it, or the chain loops."""
    chain: list[Animation] = []
    a = animation
    seen = {animation.name}
    while a.follows is not None:
        if a.path is None:
            raise AnimationError(f"follows {a.follows!r}, but the animation has no file to find it next to",
                                 subject=a.name, field="follows")
        path = os.path.join(os.path.dirname(os.path.abspath(a.path)), a.follows + ".yaml")
        if not os.path.isfile(path):
            raise AnimationError(f"follows {a.follows!r}, but there is no {a.follows}.yaml next to it",
                                 path=a.path, field="follows")
        prev = _load(path)
        if prev.name != a.follows:
            raise AnimationError(f"follows {a.follows!r}, but {path} names itself {prev.name!r}", path=a.path,
                                 field="follows")
        if prev.name in seen or len(chain) >= MAX_CHAIN:
            raise AnimationError(f"follows {a.follows!r}, which leads back to {prev.name!r}: a cycle",
                                 path=a.path, field="follows")
        seen.add(prev.name)
        chain.append(prev)
        a = prev
    return tuple(reversed(chain))


def successor(animation: Animation) -> Animation | None:
    """The clip in ``animation``'s directory that follows it (the first by file name), or
    None."""
    if animation.path is None:
        return None
    d = os.path.dirname(os.path.abspath(animation.path))
    for name in sorted(os.listdir(d)):
        if not name.endswith(".yaml") or name.startswith("_"):
            continue
        path = os.path.join(d, name)
        if os.path.abspath(path) == os.path.abspath(animation.path):
            continue
        try:
            a = _load(path)
        except AnimationError:
            continue                    # not this clip's concern: the grid reports that file itself
        if a.follows == animation.name:
            return a
    return None
