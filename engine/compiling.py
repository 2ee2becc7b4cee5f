"""Say, once per process, that numba is compiling Menagerie's kernels, and for how long.

On a fresh clone (or after a kernel source changed, see ``engine._cache``) the first call
of each numba kernel compiles it: a minute or more of silence before the first frame. The
compiled code is cached on disk, so later runs load it in a few seconds. Whoever is about
to run kernels for the first time in a process calls ``notice(area)``; when the cache of
that area's kernels is cold it prints one line to stderr, once per process::

    menagerie: compiling the runtime's numba kernels (first run; about 60 s, cached for later runs)

``MENAGERIE_QUIET=1`` silences it. ``cold_sources`` says which kernel files have nothing
cached; ``estimate_seconds`` the rough time it would take (figures measured on the
project's 2-core machine with an empty cache, scaled by the share of cold files; numba
compiles on one core, so more cores do not shorten it). The speed work on cold starts
(issue 17) changes the figures in ``AREAS``, not the callers.

Rates a command reports (the motion-capture real-time factor, the demo's ms per
character) must not count the compile: callers warm their kernels before they start a
clock (``engine.response.tracking.track`` steps a scratch state first).
"""

from __future__ import annotations

import glob
import os
import sys

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


def notice(area: str = "runtime", stream=None) -> bool:
    """Print the compiling line once per process when ``area``'s kernels are not cached.
    Returns whether it printed. Each area is looked at once per process (a few globs)."""
    global _announced
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
    print(f"menagerie: compiling {what} numba kernels (first run; {rough}, cached for later runs)",
          file=stream or sys.stderr, flush=True)
    return True
