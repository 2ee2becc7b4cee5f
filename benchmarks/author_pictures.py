"""Screenshots of the authoring tool (headless, the same window the animator sees).

    .venv/bin/python benchmarks/author_pictures.py [--out benchmarks/pictures]

Writes ``author_viewport.png`` (pick_fruit on six creatures: the hand channel's bodies
lit up, the active body's manipulator and its curve in 3-D, the fruit targets, the dog
declining in words), ``author_curves.png`` (the curve editor specialized onto the active
body, two keys selected), ``author_query.png`` (a channel selecting front feet, muted so
the creatures stand at rest: the spider's and the humanoid's light up; the query editor lists them per creature),
``author_modes.png`` (the Modes tab after a scale-mode change that kept the active
body's motion) and ``author_help.png`` (the help panel).
"""

from __future__ import annotations

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from authoring import render as rd  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "benchmarks", "pictures"))
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    rd.load_pyglet(headless=True)
    import engine
    from authoring.author import AuthorWindow
    from authoring.document import Document
    from authoring.editor import Editor
    from engine.channels.modes import PositionSpec

    def lib(n):
        return engine.load_creature(os.path.join(ROOT, "creatures", f"{n}.yaml"))

    six = [lib(n) for n in ("humanoid", "dog", "spider", "threearmed", "trex", "octopus")]
    out = []

    def shot(editor, name, setup=None, tab=None, help_panel=False):
        win = AuthorWindow.create(editor, width=1400, height=800, visible=False)
        try:
            win.show_help = help_panel
            if setup:
                setup(win)
            for _ in range(3):
                win.frame()
            if tab:
                _click(win, win.widgets[tab])
            path = os.path.join(args.out, name)
            win.snapshot(path, frames=3)
            out.append(path)
        finally:
            win.close()

    anim = os.path.join(ROOT, "animations", "pick_fruit.yaml")
    ed = Editor(Document.open(anim), six)
    ed.set_time(0.8)
    shot(ed, "author_viewport.png", tab="tab Query")

    ed = Editor(Document.open(anim), six)
    ed.set_time(0.8)
    ed.space = "specialized"
    ed.selected_keys = {("position", 1), ("position", 2)}
    shot(ed, "author_curves.png", tab="tab Modes")

    ed = Editor(Document.open(os.path.join(ROOT, "animations", "wave.yaml")), [lib("spider"), lib("humanoid")])
    ed.set_channel_fields("hand", variant_group=None)
    ed.set_query("hand", type="foot", x="front", y=None, extent=None)
    ed.set_mute("hand", True)          # the creatures at rest, the selection lit up
    ed.activate(0, int(ed.selected_bodies(0)[0]))
    shot(ed, "author_query.png", tab="tab Query")

    ed = Editor(Document.open(os.path.join(ROOT, "animations", "wave.yaml")), six[:4])
    ed.set_modes(position=PositionSpec("rest", scale="creature_size"))
    ed.space = "specialized"
    shot(ed, "author_modes.png", tab="tab Modes")

    ed = Editor(Document.open(anim), six[:3])
    shot(ed, "author_help.png", help_panel=True)
    for p in out:
        print(f"wrote {p}")
    return 0


def _click(win, xy):
    from pyglet.window import mouse

    x, y = xy[0], win.window.height - xy[1]
    for ev in (("on_mouse_motion", x, y, 0, 0), ("on_mouse_press", x, y, mouse.LEFT, 0),
               ("on_mouse_release", x, y, mouse.LEFT, 0)):
        win.window.dispatch_event(*ev)
        win.window.dispatch_events()
        win.frame()


if __name__ == "__main__":
    sys.exit(main())
