"""Say, once per process, that numba is compiling Menagerie's kernels, and for how long.

On a fresh clone (or after a kernel source changed, see ``engine._cache``) the first call
of each numba kernel compiles it: a minute or more of silence before the first frame. The
compiled code is cached on disk, so later runs load it in a few seconds. Whoever is about
to run kernels for the first time in a process calls ``notice(area)``; when the cache of
that area's kernels is cold, one line goes to stderr, once per process::

    menagerie: compiling the runtime's numba kernels (first run; about 60 s, cached for later runs) ...... done in 58 s

The line is written when numba starts compiling and then grows: a dot every 5 s while it compiles
(``Progress``: a numba compile-event listener and a small watcher thread), and "done in
N s" at the end of the first tick (``end_line``), or once no kernel has compiled for a
moment. ``MENAGERIE_QUIET=1`` silences it. ``cold_sources`` says which kernel files have
nothing cached; ``estimate_seconds`` the rough time it would take (figures measured on the
project's 2-core machine with an empty cache, scaled by the share of cold files; numba
compiles on one core, so more cores do not shorten it). The speed work on cold starts
(issue 17) changes the figures in ``AREAS``, not the callers.

Rates a command reports (the motion-capture real-time factor, the demo's ms per
character) must not count the compile: callers warm their kernels before they start a
clock (``engine.response.tracking.track`` steps a scratch state first).
"""

from __future__ import annotations

import atexit
import glob
import os
import sys
import threading
import time

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: Per area: (what the line calls it, the kernel files its first use always compiles,
#: seconds on the project's 2-core machine with an empty cache: benchmarks/startup.py and a first
#: hit, stop 33). Only files every use of the area compiles are listed, so a file no command
#: of the area ever calls cannot keep the line coming back on warm runs.
_RUNTIME = ("engine/_runtime_kernels.py", "engine/anim/_kernels.py", "engine/anim/_player_kernels.py",
            "engine/channels/_kernels.py", "engine/ik/_kernels.py", "engine/jiggle/_kernels.py")
AREAS: dict[str, tuple[str, tuple[str, ...], float]] = {
    "runtime": ("the runtime's", _RUNTIME, 65.0),
    "physics": ("the physics and motion-capture", ("engine/physics/_kernels.py", "engine/response/_kernels.py"),
                50.0),
    "view": ("the viewer's", ("authoring/_kernels.py",), 15.0),
    "viewer": ("the runtime's and the viewer's", (*_RUNTIME, "authoring/_kernels.py"), 80.0),
}

_announced = False
_checked: set[str] = set()
#: True while the compiling line is open (its progress still being written).
line_open = False
_progress = None


def _kernel_files(files) -> list[str]:
    return [p for p in (os.path.join(_ROOT, f) for f in files) if os.path.isfile(p)]


def _cache_dir_of(source: str) -> str:
    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    if cache_dir:
        try:
            from numba.core.caching import UserProvidedCacheLocator

            return os.path.join(cache_dir, UserProvidedCacheLocator.get_suitable_cache_subpath(source))
        except Exception:
            return cache_dir
    return os.path.join(os.path.dirname(source), "__pycache__")


def cold_sources(area: str = "runtime") -> list[str]:
    """The kernel source files of ``area`` with no kernel of theirs in numba's cache."""
    _, files, _ = AREAS[area]
    cold = []
    for src in _kernel_files(files):
        stem = os.path.splitext(os.path.basename(src))[0]
        if not glob.glob(os.path.join(_cache_dir_of(src), f"{stem}.*.nbi")):
            cold.append(src)
    return cold


def estimate_seconds(area: str = "runtime") -> float:
    """Rough seconds the first use of ``area`` spends compiling (0 when all is cached)."""
    _, files, seconds = AREAS[area]
    total = len(_kernel_files(files))
    if total == 0:
        return 0.0
    return seconds * len(cold_sources(area)) / total


def end_line() -> None:
    """End the compiling line now (" done in N s"): the runtime calls it after a tick
    while ``line_open``, so what a program prints next starts on a line of its own."""
    if _progress is not None:
        _progress.close()


def notice(area: str = "runtime", stream=None) -> bool:
    """Announce, once per process, that ``area``'s kernels are not cached: the compiling
    line and its progress are written when numba starts compiling (``Progress``).
    Returns whether it announced. Each area is looked at once per process (a few globs)."""
    global _announced, _progress, line_open
    if _announced or area in _checked or os.environ.get("MENAGERIE_QUIET"):
        return False
    _checked.add(area)
    try:
        seconds = estimate_seconds(area)
    except Exception:   # never let the notice break a command
        return False
    if seconds < 3.0:
        return False
    _announced = True
    what = AREAS[area][0]
    rough = f"about {round(seconds / 10) * 10:.0f} s" if seconds >= 15 else f"about {seconds:.0f} s"
    out = stream or sys.stderr
    header = f"menagerie: compiling {what} numba kernels (first run; {rough}, cached for later runs) "
    try:
        _progress = Progress(out, header)
        line_open = True
        _progress.start()
    except Exception:   # no progress then: the line alone
        line_open = False
        out.write(header + "\n")
        out.flush()
    return True


class Progress:
    """The compiling line and its progress. The line is written when numba starts its
    first compile (so what a program prints between ``notice`` and its first tick keeps
    its own lines), then a dot every ``DOT_S`` seconds while it compiles, then " done in
    N s" and the line's end: at the end of the first tick (``end_line``), or once no
    kernel has compiled for ``QUIET_S`` seconds (numba compiles in the caller's thread; a
    daemon thread watches the compile events), or at exit. Nothing is written when
    nothing compiles."""

    DOT_S = 5.0
    QUIET_S = 1.5

    def __init__(self, out, header: str):
        self.out = out
        self.header = header
        self.t0 = None             # when the first compile started (the line was written)
        self.depth = 0             # compiles in progress (nested: a kernel's callees)
        self.compiled = 0          # outermost compiles finished
        self.last = 0.0            # when the last one finished
        self.open = True
        self.lock = threading.Lock()
        self.listener = None

    def start(self) -> None:
        from numba.core import event

        progress = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                with progress.lock:
                    progress.depth += 1
                    first = progress.t0 is None and progress.open
                    if first:
                        progress.t0 = time.perf_counter()
                if first:
                    progress._write(progress.header)

            def on_end(self, ev):
                with progress.lock:
                    progress.depth -= 1
                    if progress.depth == 0:
                        progress.compiled += 1
                        progress.last = time.perf_counter()

        self.listener = _Listener()
        event.register("numba:compile", self.listener)
        atexit.register(self.close)
        threading.Thread(target=self._watch, name="menagerie-compile-progress", daemon=True).start()

    def _watch(self) -> None:
        next_dot = None
        while self.open:
            time.sleep(0.25)
            now = time.perf_counter()
            with self.lock:
                begun = self.t0 is not None
                idle = self.depth == 0 and self.compiled > 0 and now - self.last >= self.QUIET_S
            if not begun:
                continue
            if idle:
                self.close()
                return
            if next_dot is None:
                next_dot = self.t0 + self.DOT_S
            if now >= next_dot:
                next_dot = now + self.DOT_S
                self._write(".")

    def _write(self, text: str) -> None:
        try:
            self.out.write(text)
            self.out.flush()
        except (OSError, ValueError):   # a closed stream at exit
            pass

    def close(self) -> None:
        """End the line (once): " done in N s" when kernels were compiled."""
        global line_open
        line_open = False
        with self.lock:
            if not self.open:
                return
            self.open = False
            t0, compiled, last = self.t0, self.compiled, self.last
        if self.listener is not None:
            try:
                from numba.core import event

                event.unregister("numba:compile", self.listener)
            except Exception:
                pass
        if t0 is not None:
            self._write(f" done in {max(last, t0) - t0:.0f} s\n" if compiled else "\n")
