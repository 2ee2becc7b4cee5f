"""Loading like a game runtime: a cache keyed by file, and loading in the background.

``load(path)`` returns the cached Creature or Animation for a file (reloaded when the
file changed on disk); ``load_async(path)`` returns a ``concurrent.futures.Future`` that
a background thread fulfils, so a game can ask for assets before it needs them and
keep ticking meanwhile. The kind of file is told from its top-level fields (``bodies``:
a creature, ``channels``: an animation) unless given.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor

from engine.errors import DataError

_lock = threading.Lock()
_cache: dict[tuple[str, str], tuple[float, int, object]] = {}
_executor: ThreadPoolExecutor | None = None


def _kind_of(path: str) -> str:
    try:
        with open(path, encoding="utf-8") as f:
            head = f.read(65536)
    except OSError as exc:
        raise DataError(f"cannot read file: {exc.strerror}", path=path) from None
    for line in head.splitlines():
        if line.startswith("bodies:"):
            return "creature"
        if line.startswith("channels:"):
            return "animation"
    raise DataError("neither a creature file (no 'bodies:') nor an animation file (no 'channels:')", path=path)


def load(path: str | os.PathLike, kind: str | None = None):
    """The Creature or Animation in ``path``, from the cache when the file is unchanged."""
    from engine.anim import load_animation
    from engine.model import load_creature

    p = os.path.abspath(os.fspath(path))
    kind = kind or _kind_of(p)
    if kind not in ("creature", "animation"):
        raise ValueError(f"kind must be 'creature' or 'animation', got {kind!r}")
    try:
        st = os.stat(p)
    except OSError as exc:
        raise DataError(f"cannot read file: {exc.strerror}", path=os.fspath(path)) from None
    key = (kind, p)
    with _lock:
        hit = _cache.get(key)
    if hit is not None and hit[0] == st.st_mtime and hit[1] == st.st_size:
        return hit[2]
    value = load_creature(p) if kind == "creature" else load_animation(p)
    with _lock:
        _cache[key] = (st.st_mtime, st.st_size, value)
    return value


def load_async(path: str | os.PathLike, kind: str | None = None) -> Future:
    """Load ``path`` in a background thread; the future's result is the asset (or the
    loading error, raised by ``future.result()``)."""
    global _executor
    with _lock:
        if _executor is None:
            _executor = ThreadPoolExecutor(max_workers=2, thread_name_prefix="menagerie-load")
        executor = _executor
    return executor.submit(load, path, kind)


def clear_cache() -> None:
    with _lock:
        _cache.clear()
