"""``menagerie demo``: the creature zoo.

With a display it opens the viewer on every creature in the library (arrow keys step
through them one at a time). Without one (or with ``--headless``) it renders the zoo
offscreen to ``OUT/zoo.png`` and prints where it went and how long loading took.
"""

from __future__ import annotations

import glob
import os
import time

from engine.cli import LIBRARY_CREATURES


def library_creatures():
    """Every creature in the library, loaded and built, in file-name order."""
    import engine

    return [engine.load_creature(p) for p in sorted(glob.glob(os.path.join(LIBRARY_CREATURES, "*.yaml")))]


def run_demo(headless: bool = False, out_dir: str = "out/demo", seconds: float = 4.0) -> int:
    from authoring import render as rd
    from authoring.viewer import snapshot_creatures, view

    started = time.perf_counter()
    creatures = library_creatures()
    load_ms = (time.perf_counter() - started) * 1e3
    print(f"menagerie demo: {len(creatures)} creatures loaded in {load_ms:.0f} ms "
          f"({load_ms / max(len(creatures), 1):.2f} ms per creature)")
    if headless or rd.want_headless():
        os.makedirs(out_dir, exist_ok=True)
        path = os.path.join(out_dir, "zoo.png")
        started = time.perf_counter()
        snapshot_creatures(creatures, path, 1600, 1000, normalize_size=True)
        print(f"menagerie demo: no window (headless); wrote {path} in "
              f"{time.perf_counter() - started:.2f} s")
        return 0
    view(creatures, title="Menagerie zoo")
    return 0
