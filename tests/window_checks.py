"""Checks of real windows, shared by the headless tests and the Xvfb run.

``python tests/window_checks.py OUT_DIR`` (run by ``tests/test_author_ui.py`` under
``xvfb-run``, a real X window with a GLX context) opens the demo's viewer window and the
authoring tool's window, checks that the text overlays never overlap (their boxes, and
the pixels each one inks when drawn alone), writes screenshots of both windows into
OUT_DIR and prints one JSON line. Exit status 0 when every check holds.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np


def window_pixels(window) -> np.ndarray:
    """The window's back buffer as (h, w, 3) uint8, top row first."""
    import ctypes

    from pyglet import gl

    fw, fh = window.get_framebuffer_size()
    buf = np.empty((fh, fw, 3), np.uint8)
    gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, 0)
    gl.glReadBuffer(gl.GL_BACK)
    gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
    gl.glReadPixels(0, 0, fw, fh, gl.GL_RGB, gl.GL_UNSIGNED_BYTE, ctypes.c_void_p(buf.ctypes.data))
    return buf[::-1].copy()


def disjoint(a, b) -> bool:
    return a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]


def _changed_rows(img: np.ndarray, base: np.ndarray) -> np.ndarray:
    """Rows where ``img`` differs from ``base`` (the ink of one overlay drawn alone)."""
    return np.flatnonzero((np.abs(img.astype(int) - base).max(axis=2) > 60).any(axis=1))


def check_viewer_overlays(win, present) -> dict:
    """Draw ``win`` (a ``ViewerWindow`` whose scene has a caption) with the caption alone,
    the title alone and both; the two never share a row of ink, and their boxes are apart.
    ``present(win)`` draws a frame and returns its pixels."""
    scene = win.scene
    caption = scene.caption
    both = present(win)
    boxes = win.overlay_boxes()
    assert "caption" in boxes and "title" in boxes, boxes
    for a in boxes:
        for b in boxes:
            if a < b:
                assert disjoint(boxes[a], boxes[b]), (a, boxes[a], b, boxes[b])
    title = win._title
    saved = title.draw
    top = win.title_top()
    win.title_top = lambda: top          # the title stays where the caption put it
    title.draw = lambda: None
    scene.caption = None
    base = present(win).astype(int)      # neither
    scene.caption = caption
    cap_rows = _changed_rows(present(win), base)       # caption only
    title.draw = saved
    scene.caption = None
    title_rows = _changed_rows(present(win), base)     # title only
    scene.caption = caption
    del win.title_top
    assert len(cap_rows) and len(title_rows), (len(cap_rows), len(title_rows))
    assert cap_rows.max() < title_rows.min(), (cap_rows.max(), title_rows.min())
    return {"caption_rows": [int(cap_rows.min()), int(cap_rows.max())],
            "title_rows": [int(title_rows.min()), int(title_rows.max())], "boxes": boxes, "image": both}


def main(out_dir: str) -> int:
    from authoring import render as rd

    pyglet = rd.load_pyglet(headless=False)
    from authoring import demo
    from authoring.render import write_png
    from authoring.viewer import ViewerWindow

    os.makedirs(out_dir, exist_ok=True)
    report = {"display": os.environ.get("DISPLAY")}
    zoo = demo.Zoo(demo.library_creatures(("humanoid", "spider", "dog")), demo.library_animations())
    zoo.step(1 / 30)
    win = ViewerWindow.create([zoo.zoo], width=900, height=560, update=zoo.step, title="Menagerie demo")

    def present(w):
        w.window.switch_to()
        w.window.dispatch_events()
        w.draw()
        return window_pixels(w.window)

    try:
        res = check_viewer_overlays(win, present)
        write_png(os.path.join(out_dir, "demo_window.png"), res.pop("image"))
        report["demo"] = res
        report["gl"] = win.renderer.gl_info()
    finally:
        win.close()

    import engine
    from authoring.author import AuthorWindow
    from authoring.document import Document
    from authoring.editor import Editor

    cs = [engine.load_creature(f"creatures/{n}.yaml") for n in ("humanoid", "spider")]
    ed = Editor(Document.open("animations/wave.yaml"), cs)
    aw = AuthorWindow.create(ed, width=1200, height=720, visible=True)
    try:
        for _ in range(3):
            aw.window.dispatch_events()
            aw.draw()
        img = window_pixels(aw.window)
        write_png(os.path.join(out_dir, "author_window.png"), img)
        # Panels and creatures are there: the panel background and the highlighted hand.
        report["author_distinct_colours"] = int(len(np.unique(img.reshape(-1, 3)[::97], axis=0)))
        assert report["author_distinct_colours"] > 50
    finally:
        aw.close()
    del pyglet
    print(json.dumps(report, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else "out/windows"))
