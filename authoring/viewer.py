"""The Menagerie viewer: look at creatures in a window, or write pictures of them.

Entry points::

    view(scene_or_creatures)              # a window with an orbit camera; a PNG when no display
    view_file("creatures/spider.yaml")    # `menagerie view FILE.yaml`
    view_file(path, snapshot="out.png")   # `menagerie view FILE.yaml --snapshot out.png`
    snapshot_creatures(creatures, "zoo.png", normalize_size=True)   # the zoo picture

The window (``ViewerWindow``) shows "pages": for several actors, first all of them, then
each alone. Controls:

    left drag         orbit                 right drag / scroll   zoom
    left click        name the body under the cursor (capabilities, parent, size)
    middle drag       pan (or shift + left drag)
    left / right      previous / next page  (also page up / page down, n / p)
    a                 the page with everyone
    f                 frame the page again  j  joints and links   g  grid   e  edges
    l                 labels                s  save a PNG of the window in the current folder
    space             pause / run ``update``  .  one step of 1/60 s while paused
    h                 show or hide this help                      escape / q  close

The window logic is plain pyglet event handlers around a ``Renderer``; the test suite
drives it headless by dispatching events.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Sequence

from authoring import render as rd
from authoring import scene as sc
from engine.model.creature import Creature

HELP_TEXT = ("click: name a body   drag: orbit   right drag/scroll: zoom   middle or shift drag: pan   "
             "\u2190/\u2192: page   a: all   f: frame   j/g/e/l: joints/grid/edges/labels   "
             "space: pause   .: step   s: save PNG   h: help   q: quit")

#: Orbit speed (radians per pixel dragged) and zoom speed (per pixel dragged / per wheel notch).
ORBIT_PER_PIXEL = 0.008
ZOOM_PER_PIXEL = 0.01
ZOOM_PER_NOTCH = 0.88


def _free_path(path: str) -> str:
    """``path``, or ``stem_2.png``, ``stem_3.png``, ... if it exists: never overwrite a
    file the user did not name."""
    if not os.path.exists(path):
        return path
    stem, ext = os.path.splitext(path)
    n = 2
    while os.path.exists(f"{stem}_{n}{ext}"):
        n += 1
    return f"{stem}_{n}{ext}"


def _load_creatures(items) -> list[Creature]:
    """Creatures from Creature objects and/or creature file paths."""
    out = []
    for item in items:
        if isinstance(item, Creature):
            out.append(item)
        elif isinstance(item, (str, os.PathLike)):
            from engine.io.sources import creature_from_file

            out.append(creature_from_file(os.fspath(item)))   # creature files, .bvh, .glb/.gltf
        else:
            raise sc.SceneError(f"expected a Creature or a creature file path, got "
                                f"{type(item).__name__}", kind="creature")
    return out


# -- pictures ------------------------------------------------------------------------------------


def snapshot_creatures(creatures, path, width: int = 1280, height: int = 720, *,
                       normalize_size: bool = True, columns: int | None = None,
                       labels: bool = True, show_joints: bool = False) -> str:
    """A picture of many creatures at rest on a grid (``scene.layout_zoo``), written to
    ``path`` as PNG. ``creatures``: Creature objects or creature file paths.
    ``normalize_size`` draws every creature at the same size (its largest side 1 m) so
    giants and mites are all visible; labels then give each one's scale. Returns the path."""
    zoo = sc.layout_zoo(_load_creatures(creatures), columns=columns,
                        normalize_size=normalize_size, labels=labels)
    for a in zoo.actors:
        a.show_joints = show_joints
        a.show_links = show_joints
    return rd.render_png(zoo, path, width, height)


def view_file(path, snapshot=None, *, width: int = 1280, height: int = 720):
    """Show the creature file ``path``; with ``snapshot`` write that PNG instead (no
    window). Without a display a snapshot named after the file is written in the
    current folder instead (``NAME.png``, or ``NAME_2.png``... if that exists).
    Returns the PNG path, or None after an interactive session.
    A bad file raises ``engine.errors.CreatureError`` naming the file and line."""
    from engine.io.sources import creature_from_file

    creature = creature_from_file(path)  # a creature file, or a BVH/glTF skeleton through its importer
    scene = sc.Scene(actors=[sc.Actor(creature, label=creature.name)])
    if snapshot is not None:
        return rd.render_png(scene, snapshot, width, height)
    return view(scene, width=width, height=height,
                fallback_path=f"{os.path.splitext(os.path.basename(str(path)))[0]}.png")


def view(scene_or_creatures, *, width: int = 1280, height: int = 720,
         update: Callable[[float], None] | None = None, title: str = "Menagerie",
         fallback_path: str | None = None, instead: str = "menagerie view FILE --snapshot out.png"):
    """Open the interactive viewer on a Scene, an Actor, a Creature or a list of them.

    ``update(dt)`` is called before every frame (the demo moves its actors there);
    ``instead`` is the command a failed window suggests.
    Without a display (or with ``MENAGERIE_HEADLESS=1``) no window can open: a snapshot
    is written to ``fallback_path`` (default ``menagerie_view.png``; ``_2``, ``_3``... are
    added rather than overwrite a file) instead, the path is printed and returned.
    Returns None after the window is closed.
    """
    if isinstance(scene_or_creatures, (list, tuple)) and scene_or_creatures and all(
            isinstance(c, (Creature, str, os.PathLike)) for c in scene_or_creatures):
        pages = creature_pages(_load_creatures(scene_or_creatures))
    else:
        pages = scene_pages(sc.scene_for(scene_or_creatures))
    if rd.want_headless():
        out = _free_path(fallback_path or "menagerie_view.png")
        rd.render_png(pages[0], out, width, height)
        print(f"menagerie view: no display here (DISPLAY is not set), wrote {out} instead")
        return out
    pyglet = rd.load_pyglet(headless=False)
    try:
        window = ViewerWindow.create(pages, width=width, height=height, update=update,
                                     title=title)
    except rd.ViewerError:
        raise
    except Exception as exc:  # pyglet's display and context errors have no common base
        raise rd.ViewerError(
            f"cannot open a window on DISPLAY={os.environ.get('DISPLAY')!r} "
            f"({type(exc).__name__}: {exc}); write pictures instead ({instead}) or run with "
            "MENAGERIE_HEADLESS=1") from None
    try:
        pyglet.app.run()
    finally:
        window.close()
    return None


# -- pages -----------------------------------------------------------------------------------------


def scene_pages(scene: sc.Scene) -> list[sc.Scene]:
    """The whole scene, then (for more than one actor) each actor alone with the overlays."""
    pages = [scene]
    if len(scene.actors) > 1:
        # Same settings and overlays, one actor, framed automatically.
        pages += [dataclasses.replace(scene, actors=[a], camera=None) for a in scene.actors]
    return pages


def creature_pages(creatures: Sequence[Creature]) -> list[sc.Scene]:
    """A zoo of all creatures at a common size, then each creature alone at its true size."""
    if len(creatures) == 1:
        return [sc.Scene(actors=[sc.Actor(creatures[0], label=creatures[0].name)])]
    pages = [sc.layout_zoo(creatures, normalize_size=True)]
    for a in pages[0].actors:
        a.show_joints = a.show_links = False
    pages += [sc.Scene(actors=[sc.Actor(c, label=c.name)]) for c in creatures]
    return pages


# -- the window ------------------------------------------------------------------------------------


class ViewerWindow:
    """An interactive window over a list of pages (scenes). Build with ``create``; the
    pyglet window is ``self.window``, its renderer ``self.renderer``."""

    def __init__(self) -> None:  # use create()
        raise TypeError("use ViewerWindow.create(pages, ...)")

    @classmethod
    def create(cls, pages: Sequence[sc.Scene], *, width: int = 1280, height: int = 720,
               update: Callable[[float], None] | None = None, title: str = "Menagerie",
               visible: bool = True) -> ViewerWindow:
        """Open the window (pyglet must already be loaded, see ``render.load_pyglet``)."""
        import pyglet
        from pyglet.window import key, mouse

        self = object.__new__(cls)
        if not pages:
            raise sc.SceneError("nothing to view: no pages", kind="viewer")
        self.pages = list(pages)
        self.page = 0
        self.update = update
        self.show_help = True
        self.last_saved: str | None = None
        self.closed = False
        self.paused = False
        self.selected: tuple[int, int] | None = None  # (actor, body) last clicked
        self._press = None
        # A plain double-buffered window: the renderer antialiases in its own multisampled
        # framebuffer and copies the result in (a blit into a multisampled window
        # framebuffer is not allowed).
        config = pyglet.gl.Config(double_buffer=True, sample_buffers=0, samples=0)
        try:
            window = pyglet.window.Window(width, height, caption=title, resizable=True,
                                          config=config, visible=visible)
        except pyglet.window.NoSuchConfigException:
            window = pyglet.window.Window(width, height, caption=title, resizable=True,
                                          visible=visible)
        self.window = window
        fw, fh = window.get_framebuffer_size()
        self.renderer = rd.Renderer(fw, fh, window=window)
        self.camera = self.renderer.frame(self.pages[0])   # framed again below, once the overlays exist
        self._help = pyglet.text.Label(HELP_TEXT, x=8, y=8, anchor_y="bottom", font_size=10,
                                       multiline=True,
                                       width=max(window.width - 16, 100),
                                       color=(40, 42, 48, 255))
        self._title = pyglet.text.Label("", x=8, y=window.height - 8, anchor_y="top", font_size=12,
                                        multiline=True, width=max(window.width - 16, 100),
                                        color=(30, 32, 38, 255))
        self._key, self._mouse = key, mouse
        self.reframe()

        @window.event
        def on_draw():
            self.draw()

        @window.event
        def on_resize(w, h):
            fw, fh = window.get_framebuffer_size()
            self.renderer.resize(fw, fh)
            self._title.y = h - 8
            self._help.width = max(w - 16, 100)  # the help text wraps to the window
            self._title.width = max(w - 16, 100)
            # Not handled here: pyglet's own handler then sets the viewport and the 2-D
            # projection the help text is drawn with.

        @window.event
        def on_mouse_drag(x, y, dx, dy, buttons, modifiers):
            self.drag(dx, dy, buttons, modifiers)

        @window.event
        def on_mouse_press(x, y, button, modifiers):
            self._press = (x, y)

        @window.event
        def on_mouse_release(x, y, button, modifiers):
            # A click (no drag) on a body names it in the title line.
            px, py = self._press if self._press is not None else (x, y)
            if button == mouse.LEFT and abs(x - px) + abs(y - py) <= 3:
                self.click(x, y)

        @window.event
        def on_mouse_scroll(x, y, scroll_x, scroll_y):
            self.camera.zoom(ZOOM_PER_NOTCH ** scroll_y)

        @window.event
        def on_key_press(symbol, modifiers):
            return self.key(symbol, modifiers)

        @window.event
        def on_close():
            self.close()
            return pyglet.event.EVENT_HANDLED

        if update is not None:
            pyglet.clock.schedule_interval(self._tick, 1 / 60)
        return self

    def _tick(self, dt: float) -> None:
        if self.update is not None and not self.paused:
            self.update(dt)

    def step(self, dt: float = 1 / 60) -> None:
        """Advance ``update`` by one step of ``dt`` seconds (the '.' key, when paused)."""
        if self.update is not None:
            self.update(dt)

    # -- state changes (each one is a plain method so tests can call it) ---------------------

    @property
    def scene(self) -> sc.Scene:
        return self.pages[self.page]

    def go(self, page: int) -> None:
        """Show page ``page`` (wraps around) and frame it."""
        self.page = page % len(self.pages)
        self.selected = None
        self.reframe()

    def reframe(self) -> None:
        """Frame the page in the part of the window the text overlays leave free: below
        the caption and the title, above the help (so no label of a creature lands under
        them)."""
        r = self.renderer
        top, bottom = self.reserved()
        fh = r.height
        free = max(fh - top - bottom, fh * 0.3)
        cam = self.scene.auto_camera(r.width / free)
        cam.zoom(fh / free)
        cam.pan(0.0, -(0.5 * (top - bottom)), fh)
        self.camera = cam

    def reserved(self) -> tuple[float, float]:
        """Framebuffer pixels the overlays take at the top (caption and title lines) and
        at the bottom (the help), estimated from their font sizes and line counts."""
        fw, fh = self.window.get_framebuffer_size()
        k = fh / max(self.window.height, 1)
        top = 8.0 * k
        if self.scene.caption and self.scene.show_labels:
            lines = self.scene.caption.count("\n") + 1
            top += 10 * fh / 720.0 + lines * 1.45 * 1.2 * 11.0 * fh / 720.0 * 96 / 72
        title_lines = 2 if self.selected is not None else 1
        top += title_lines * 1.45 * 12 * 96 / 72 * k
        bottom = 0.0
        if self.show_help:
            lines = max(self._help.content_height / max(self._help.font_size * 96 / 72 * 1.2, 1), 1)
            bottom = (lines * self._help.font_size * 96 / 72 * 1.45 + 16) * k
        return top, bottom

    def click(self, x: float, y: float) -> tuple[int, int] | None:
        """Select the body under window point (x, y) (pyglet's coordinates: y up)."""
        fw, fh = self.window.get_framebuffer_size()
        sx, sy = fw / max(self.window.width, 1), fh / max(self.window.height, 1)
        self.selected = sc.pick(self.scene, self.camera, x * sx, fh - y * sy, fw, fh)
        return self.selected

    def drag(self, dx: float, dy: float, buttons: int, modifiers: int) -> None:
        mouse, key = self._mouse, self._key
        if buttons & mouse.MIDDLE or (buttons & mouse.LEFT and modifiers & key.MOD_SHIFT):
            self.camera.pan(dx, dy, self.window.height)  # mouse moves in window units
        elif buttons & mouse.LEFT:
            self.camera.orbit(-dx * ORBIT_PER_PIXEL, -dy * ORBIT_PER_PIXEL)
        elif buttons & mouse.RIGHT:
            self.camera.zoom(math.exp(-dy * ZOOM_PER_PIXEL))

    def key(self, symbol: int, modifiers: int):
        import pyglet

        k = self._key
        scene = self.scene
        if symbol in (k.RIGHT, k.PAGEDOWN, k.N):
            self.go(self.page + 1)
        elif symbol in (k.LEFT, k.PAGEUP, k.P):
            self.go(self.page - 1)
        elif symbol == k.A:
            self.go(0)
        elif symbol in (k.F, k.HOME):
            self.reframe()
        elif symbol == k.J:
            on = not any(a.show_joints or a.show_links for a in scene.actors)
            for a in scene.actors:
                a.show_joints = a.show_links = on
        elif symbol == k.G:
            scene.show_grid = not scene.show_grid
        elif symbol == k.E:
            scene.show_edges = not scene.show_edges
        elif symbol == k.L:
            scene.show_labels = not scene.show_labels
        elif symbol == k.H:
            self.show_help = not self.show_help
        elif symbol == k.S:
            self.save()
        elif symbol == k.SPACE:
            self.paused = not self.paused
        elif symbol == k.PERIOD:
            if self.paused:
                self.step()
        elif symbol in (k.ESCAPE, k.Q):
            self.close()
        else:
            return None
        return pyglet.event.EVENT_HANDLED

    def title_top(self) -> float:
        """Window y (up) of the top of the title text: 8 units below the top, or below the
        caption the renderer drew there."""
        fh = max(self.window.get_framebuffer_size()[1], 1)
        below = self.renderer.caption_height() * self.window.height / fh
        return self.window.height - 8 - below

    def overlay_boxes(self) -> dict[str, tuple[float, float, float, float]]:
        """(x0, y0, x1, y1) window boxes (y down from the top) of the text overlays of the
        last frame: caption, title and help (when shown). Tests check they never overlap."""
        h = self.window.height
        fh = max(self.window.get_framebuffer_size()[1], 1)
        k = h / fh
        out = {}
        cap_h = self.renderer.caption_height() * k
        if cap_h:
            cap = self.renderer._caption
            out["caption"] = (cap.x * k, 0.0, (cap.x + cap.content_width) * k, cap_h)
        t = self._title
        out["title"] = (t.x, h - t.y, t.x + t.content_width, h - t.y + t.content_height)
        if self.show_help:
            hp = self._help
            out["help"] = (hp.x, h - hp.y - hp.content_height, hp.x + hp.content_width, h - hp.y)
        return out

    def close(self) -> None:
        """Free the renderer's GL objects, close the window and end ``pyglet.app.run``."""
        import pyglet

        if self.closed:
            return
        self.closed = True
        if self.update is not None:
            pyglet.clock.unschedule(self._tick)
        self.renderer.close()  # while the window's context still exists
        self.window.close()
        pyglet.app.exit()

    def save(self, path: str | None = None) -> str:
        """Write the current picture (without the help text) as PNG; returns the path."""
        if path is None:
            path = _free_path("menagerie.png")
        self.renderer.draw(self.scene, self.camera)
        self.renderer.save_png(path)
        self.last_saved = path
        print(f"menagerie view: wrote {path}")
        return path

    def draw(self) -> None:
        """Draw the current page into the window."""
        from pyglet import gl

        self.renderer.draw(self.scene, self.camera)
        self.window.switch_to()
        self.renderer.present()
        fw, fh = self.window.get_framebuffer_size()
        gl.glViewport(0, 0, fw, fh)
        names = ", ".join(a.creature.name for a in self.scene.actors[:6])
        more = "" if len(self.scene.actors) <= 6 else f" and {len(self.scene.actors) - 6} more"
        info = ""
        if self.selected is not None and self.selected[0] < len(self.scene.actors):
            actor, body = self.selected
            info = "\n" + sc.describe_body(self.scene.actors[actor].creature, body)
        self._title.text = f"{self.page + 1}/{len(self.pages)}  {names}{more}{info}"
        # Below the scene's caption (a demo's title line), never on top of it.
        self._title.y = self.title_top()
        self._title.draw()
        if self.show_help:
            self._help.draw()


# -- measuring and a small command line -----------------------------------------------------------


def benchmark(creature: Creature, *, width: int = 1280, height: int = 720,
              frames: int = 60) -> dict[str, float]:
    """Frames per second drawing one creature, at rest, with the automatic camera, off
    screen: with 4x and without multisampling, with and without reading pixels back."""
    from authoring.render import Renderer, measure_fps

    out: dict[str, float] = {"bodies": float(creature.nbody), "width": width, "height": height}
    scene = sc.Scene(actors=[sc.Actor(creature, label=creature.name)])
    for samples in (4, 0):
        with Renderer(width, height, samples=samples, headless=True) as r:
            out[f"fps_draw_read_msaa{samples}"] = measure_fps(r, scene, frames, read=True)
            out[f"fps_draw_msaa{samples}"] = measure_fps(r, scene, frames, read=False)
            scene.camera = r.camera  # a fixed camera: what a demo with its own camera pays
            out[f"fps_draw_read_fixed_camera_msaa{samples}"] = measure_fps(r, scene, frames)
            scene.camera = None
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m authoring.viewer FILE.yaml [--snapshot out.png]``, ``--zoo FILES... --out
    zoo.png [--true-size]`` or ``--bench FILE.yaml``."""
    import argparse
    import json

    p = argparse.ArgumentParser(prog="python -m authoring.viewer", description=__doc__.split("\n")[0])
    p.add_argument("files", nargs="+", help="creature files")
    p.add_argument("--snapshot", help="write this PNG instead of opening a window")
    p.add_argument("--zoo", action="store_true", help="one picture of all the files")
    p.add_argument("--out", default="zoo.png", help="the zoo picture's path")
    p.add_argument("--true-size", action="store_true", help="zoo: keep true sizes")
    p.add_argument("--size", default="1280x720", help="picture size, WxH")
    p.add_argument("--bench", action="store_true", help="print frames per second")
    args = p.parse_args(argv)
    width, height = (int(v) for v in args.size.lower().split("x"))
    if args.bench:
        import engine

        figures = benchmark(engine.load_creature(args.files[0]), width=width, height=height)
        for k, v in figures.items():
            print(f"{k:40s} {v:10.1f}")
        print(json.dumps(figures))
        return 0
    if args.zoo:
        path = snapshot_creatures(args.files, args.out, width, height,
                                  normalize_size=not args.true_size)
        print(f"wrote {path}")
        return 0
    if len(args.files) == 1:
        result = view_file(args.files[0], snapshot=args.snapshot, width=width, height=height)
    elif args.snapshot:
        result = snapshot_creatures(args.files, args.snapshot, width, height)
    else:
        result = view(list(args.files), width=width, height=height)
    if result and args.snapshot:
        print(f"wrote {result}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
