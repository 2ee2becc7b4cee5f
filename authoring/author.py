"""``menagerie author``: the authoring tool's window (Dear ImGui over the viewer's renderer).

A thin layer over ``authoring.editor.Editor`` (the editing model, tested without a
window): panels are Dear ImGui through ``imgui-bundle`` and its pure-Python pyglet
backend, drawn in the same pyglet window and OpenGL context as ``authoring.render``'s
3-D picture, on top of it (``Renderer.begin_overlay``), so a screenshot or
``read_pixels`` shows exactly what the animator sees. The preview creatures are
``engine.Character`` objects played by the runtime (``authoring.preview``).

Layout: the channel list and the channel's query, modes and groups on the left; the
animation's own fields, the creatures (variants, why one declines) and the gait styles on
the right; the timeline and the curve editor along the bottom; the viewport in between.

Keyboard and mouse (also in the help panel, F1)::

    Space            play / pause             Left / Right     one frame back / on
    Up / Down        ten frames on / back     Home / End       first / last frame
    I                key the active channel   Alt-I, Delete    delete the selected keys
    Ctrl-Z           undo                     Ctrl-Shift-Z, Ctrl-Y   redo
    Ctrl-S           save                     F                frame all (viewport or curves)
    W / E            move / rotate manipulator     X / Y / Z   constrain the drag to an axis
    click a body     activate it (its channel's bodies light up on every creature)
    drag the active body (or its manipulator)   pose it: keys at the current time, one undo step
    drag a green ball    move an external target (per creature)
    left drag        orbit    middle or Shift-left drag   pan    right drag / scroll   zoom
    Ctrl-click keys  select several keys in the curve editor; drag one to move them all

``--headless --snapshot OUT.png`` renders one frame of the tool without a display.
"""

from __future__ import annotations

import math
import os

import numpy as np

from authoring import render as rd
from authoring import scene as sc
from authoring.editor import Editor
from engine.anim.animation import BRANCH_PREDICATES, COUNT_PREDICATES, SIDE_CONSTRAINTS
from engine.channels.modes import POSITION_MODES, ROTATION_MODES, SCALE_MODES, PositionSpec, RotationSpec
from engine.errors import MenagerieError
from engine.query.query import AXIS_ZONES, EXTENTS, LIMB_MODIFIERS, QUERY_TYPES

HELP = (
    ("Space", "play / pause"),
    ("Left / Right", "one frame back / on"),
    ("Up / Down", "ten frames on / back"),
    ("Home / End", "first / last frame"),
    ("I", "key the active channel at the current time"),
    ("Alt-I, Delete", "delete the selected keys"),
    ("Ctrl-Z", "undo"),
    ("Ctrl-Shift-Z, Ctrl-Y", "redo"),
    ("Ctrl-S", "save (a backup of the old file is kept)"),
    ("F", "frame all (the curve editor when the mouse is over it)"),
    ("W / E", "move / rotate manipulator"),
    ("X / Y / Z", "constrain the manipulator to an axis (again: free)"),
    ("click a body", "activate it; its channel's bodies light up on every creature"),
    ("drag the active body", "pose it (keys at the current time; one undo step)"),
    ("drag a green ball", "move that creature's external target"),
    ("left drag", "orbit"),
    ("middle drag, Shift-left drag", "pan"),
    ("right drag, scroll", "zoom"),
    ("Ctrl-click keys", "select several keys; drag one to move them all"),
    ("F1, H", "show / hide this help"),
)

LEFT_W, RIGHT_W, BOTTOM_H, MENU_H = 340, 310, 270, 22
ORBIT_PER_PIXEL = 0.008
ZOOM_PER_PIXEL = 0.01
ZOOM_PER_NOTCH = 0.88
ROTATE_PER_PIXEL = 0.01
AXIS_COLORS = ((0.9, 0.2, 0.2), (0.2, 0.75, 0.25), (0.2, 0.4, 0.95))
CURVE_COLORS = ((0.9, 0.25, 0.25, 1.0), (0.25, 0.7, 0.3, 1.0), (0.3, 0.45, 0.95, 1.0))
TARGET_COLOR = (0.10, 0.75, 0.25)
PATH_COLOR = (0.90, 0.15, 0.15)
#: Pixels within which a press grabs a manipulator axis or a target.
GRAB_PIXELS = 10.0


def _axis_quat(axis, angle) -> np.ndarray:
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * a])


def _qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _seg_distance(p, a, b) -> float:
    ab = b - a
    t = float(np.clip(np.dot(p - a, ab) / max(float(np.dot(ab, ab)), 1e-12), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


class AuthorWindow:
    """The tool's window over an ``Editor``. Build with ``create``; ``frame(dt)`` runs one
    frame (the app loop calls it; tests call it after injecting events)."""

    def __init__(self) -> None:  # use create()
        raise TypeError("use AuthorWindow.create(editor, ...)")

    @classmethod
    def create(cls, editor: Editor, *, width: int = 1400, height: int = 800, visible: bool = True,
               title: str = "Menagerie author", samples: int = 4) -> AuthorWindow:
        """Open the window over ``editor``; ``samples``: multisampling of the 3-D view."""
        import pyglet

        if pyglet.options["headless"]:
            os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
        from imgui_bundle import imgui, implot
        from imgui_bundle.python_backends import pyglet_backend

        self = object.__new__(cls)
        self.editor = editor
        self.imgui, self.implot = imgui, implot
        self.closed = False
        self.show_help = False
        self.want_close = False
        self.gizmo = "move"
        self.axis: int | None = None
        self.fit_curves = True
        self._drag = None
        self._press = None
        self._curve_drag = None
        self._rename = {}
        self._frames = 0
        self.widgets: dict[str, tuple[float, float]] = {}
        self.key_pixels: dict[tuple[str, int, int], tuple[float, float]] = {}
        config = pyglet.gl.Config(double_buffer=True, sample_buffers=0, samples=0)
        try:
            window = pyglet.window.Window(width, height, caption=title, resizable=True, config=config,
                                          visible=visible)
        except pyglet.window.NoSuchConfigException:
            window = pyglet.window.Window(width, height, caption=title, resizable=True, visible=visible)
        self.window = window
        fw, fh = window.get_framebuffer_size()
        # The 3-D picture is drawn only where the panels leave the window free, then
        # composed with the panels into a window-sized picture (``renderer``).
        x0, y0, x1, y1 = self._free_rect()
        self.view = rd.Renderer(max(int(x1 - x0), 16), max(int(y1 - y0), 16), window=window, samples=samples)
        self.renderer = rd.Compositor(fw, fh, window=window)
        self.ctx = imgui.create_context()
        self.plot_ctx = implot.create_context()
        imgui.get_io().set_ini_filename(None)      # no imgui.ini in the user's folder
        imgui.style_colors_light()
        implot.get_style().fit_padding = (0.02, 0.08)   # keys at the top and bottom stay inside
        self.impl = pyglet_backend.create_renderer(window)
        window.push_handlers(self)                 # after the backend: we see events first
        self.reframe()
        return self

    # -- camera -------------------------------------------------------------------------------

    def _free_rect(self) -> tuple[float, float, float, float]:
        """(x0, y0, x1, y1) of the viewport left free by the panels, framebuffer pixels
        from the top left."""
        w, h = self.window.width, self.window.height
        fw, fh = self.window.get_framebuffer_size()
        sx, sy = fw / max(w, 1), fh / max(h, 1)
        return LEFT_W * sx, MENU_H * sy, fw - RIGHT_W * sx, fh - BOTTOM_H * sy

    def reframe(self) -> None:
        """Frame every preview creature in the viewport the panels leave free."""
        v = self.view
        cam = self.editor.preview.scene.auto_camera(v.width / v.height)
        cam.zoom(1.06)   # room for the labels above the back row
        self.camera = cam

    def project(self, world) -> tuple[float, float]:
        """Window point (x right, y down from the top, window units) of a world point."""
        x0, y0, _, _ = self._free_rect()
        (px, py), = self.camera.project(np.asarray(world, float), self.view.width, self.view.height)[0]
        fw, fh = self.window.get_framebuffer_size()
        return (x0 + px) * self.window.width / fw, (y0 + py) * self.window.height / fh

    # -- pyglet events (handlers return None: the imgui backend sees them too) -------------------

    def _pixel(self, x, y) -> tuple[float, float]:
        """Pixel of the 3-D view (y down from its top) under window point (x, y), y up."""
        fw, fh = self.window.get_framebuffer_size()
        x0, y0, _, _ = self._free_rect()
        return x * fw / max(self.window.width, 1) - x0, fh - y * fh / max(self.window.height, 1) - y0

    def on_mouse_press(self, x, y, button, modifiers):
        from pyglet.window import key, mouse

        if self.imgui.get_io().want_capture_mouse or self._over_panel(x, y):
            return None
        px = self._pixel(x, y)
        self._press = (x, y, button, modifiers)
        if button == mouse.LEFT and not modifiers & (key.MOD_SHIFT | key.MOD_ALT):
            self._drag = self._grab(px)
        return None

    def _over_panel(self, x, y) -> bool:
        w, h = self.window.width, self.window.height
        top = h - y
        return x < LEFT_W or x > w - RIGHT_W or top > h - BOTTOM_H or top < MENU_H

    def on_mouse_drag(self, x, y, dx, dy, buttons, modifiers):
        from pyglet.window import key, mouse

        if self._press is None:
            return None
        if self._drag is not None:
            self._update_drag(self._pixel(x, y))
            return None
        if buttons & mouse.MIDDLE or (buttons & mouse.LEFT and modifiers & key.MOD_SHIFT):
            self.camera.pan(dx, dy, self.window.height)
        elif buttons & mouse.LEFT:
            self.camera.orbit(-dx * ORBIT_PER_PIXEL, -dy * ORBIT_PER_PIXEL)
        elif buttons & mouse.RIGHT:
            self.camera.zoom(math.exp(-dy * ZOOM_PER_PIXEL))
        return None

    def on_mouse_release(self, x, y, button, modifiers):
        from pyglet.window import mouse

        press = self._press
        self._press = None
        if self._drag is not None:
            moved = self._drag.get("moved", False)
            self._drag = None
            self.editor.end_gesture()
            if moved:
                return None
        if press is None:
            return None
        if button == mouse.LEFT and abs(x - press[0]) + abs(y - press[1]) <= 3:
            self.click(x, y)
        return None

    def on_mouse_scroll(self, x, y, scroll_x, scroll_y):
        if self.imgui.get_io().want_capture_mouse or self._over_panel(x, y):
            return None
        self.camera.zoom(ZOOM_PER_NOTCH ** scroll_y)
        return None

    def on_key_press(self, symbol, modifiers):
        from pyglet.window import key

        io = self.imgui.get_io()
        if io.want_text_input:
            return None
        ed = self.editor
        ctrl = modifiers & (key.MOD_CTRL | key.MOD_COMMAND)
        shift = modifiers & key.MOD_SHIFT
        try:
            if ctrl and symbol == key.Z:
                ed.redo() if shift else ed.undo()
            elif ctrl and symbol == key.Y:
                ed.redo()
            elif ctrl and symbol == key.S:
                ed.save()
            elif ctrl:
                return None
            elif symbol == key.SPACE:
                ed.play()
            elif symbol == key.LEFT:
                ed.step(-1)
            elif symbol == key.RIGHT:
                ed.step(1)
            elif symbol == key.UP:
                ed.step(10)
            elif symbol == key.DOWN:
                ed.step(-10)
            elif symbol == key.HOME:
                ed.set_time(0.0)
            elif symbol == key.END:
                ed.set_time(ed.animation.length)
            elif symbol == key.I and modifiers & key.MOD_ALT or symbol == key.DELETE:
                self.delete_selected_keys()
            elif symbol == key.I:
                ed.key_now()
            elif symbol == key.F:
                if self._mouse_over_curves:
                    self.fit_curves = True
                else:
                    self.reframe()
            elif symbol == key.W:
                self.gizmo = "move"
            elif symbol == key.E:
                self.gizmo = "rotate"
            elif symbol in (key.X, key.Y, key.Z):
                a = {key.X: 0, key.Y: 1, key.Z: 2}[symbol]
                self.axis = None if self.axis == a else a
            elif symbol in (key.F1, key.H):
                self.show_help = not self.show_help
            else:
                return None
        except MenagerieError as exc:
            ed.message = str(exc)
        return None

    def on_close(self):
        import pyglet

        if self.editor.doc.dirty and not self.want_close:
            self._ask_close = True
            return pyglet.event.EVENT_HANDLED
        self.close()
        return pyglet.event.EVENT_HANDLED

    def on_resize(self, w, h):
        fw, fh = self.window.get_framebuffer_size()
        self.renderer.resize(fw, fh)
        x0, y0, x1, y1 = self._free_rect()
        self.view.resize(max(int(x1 - x0), 16), max(int(y1 - y0), 16))
        return None

    _mouse_over_curves = False
    _ask_close = False

    # -- viewport actions ---------------------------------------------------------------------------

    def click(self, x, y):
        """Activate the body under window point (x, y) (pyglet coordinates, y up)."""
        px, py = self._pixel(x, y)
        r = self.view
        hit = sc.pick(self._scene(), self.camera, px, py, r.width, r.height)
        if hit is None:
            self.editor.activate(self.editor.creature, None)
            return None
        k, body = hit
        ok = self.editor.activate(k, body)
        c = self.editor.preview.items[k].creature
        self.editor.message = (sc.describe_body(c, body) if ok else
                               f"{sc.describe_body(c, body)}: no channel poses it")
        return hit

    def _goal_world(self):
        """(world position, character rotation, preview item) of the active body's goal."""
        ed = self.editor
        if ed.body is None or ed.active_channel() is None:
            return None
        try:
            p, r = ed.specialize_now()
        except MenagerieError:
            return None
        item = ed.preview.items[ed.creature]
        return item.to_world(p), r, item

    def _gizmo_segments(self, goal):
        w, _, item = goal
        length = 0.25 * item.actor.scale * float(np.max(item.creature.size))
        return [(w, w + length * np.eye(3)[a]) for a in range(3)], length

    def _grab(self, px):
        """What a left press at pixel ``px`` grabs: an external target, a manipulator
        axis, the active body, or nothing (orbit)."""
        ed = self.editor
        r = self.view
        p = np.asarray(px, float)
        for k, item in enumerate(ed.preview.items):
            if item.declined:
                continue
            for name in ed.preview.played.target_names if hasattr(ed.preview, "played") else ():
                wpos = item.to_world(ed.preview.target_position(k, name))
                (sx, sy), = self.camera.project(wpos, r.width, r.height)[0]
                if math.hypot(sx - p[0], sy - p[1]) <= GRAB_PIXELS * r.height / 720.0 * 1.5:
                    return {"what": "target", "k": k, "name": name, "start": p, "world": wpos,
                            "char": ed.preview.target_position(k, name).copy(), "tag": ed.new_gesture()}
        goal = self._goal_world()
        if goal is None:
            return None
        segs, _ = self._gizmo_segments(goal)
        axis = self.axis
        (gx, gy), = self.camera.project(goal[0], r.width, r.height)[0]
        near_centre = math.hypot(gx - p[0], gy - p[1]) <= GRAB_PIXELS * r.height / 720.0
        # An axis handle is the outer part of its line (the centre is the free move).
        proj = [self.camera.project(np.array([a + 0.3 * (b - a), b]), r.width, r.height)[0] for a, b in segs]
        for a, ab in enumerate(proj):
            if not near_centre and _seg_distance(p, ab[0], ab[1]) <= GRAB_PIXELS * r.height / 720.0:
                axis = a
                break
        else:
            (gx, gy), = self.camera.project(goal[0], r.width, r.height)[0]
            hit = sc.pick(self._scene(), self.camera, p[0], p[1], r.width, r.height)
            on_body = hit == (ed.creature, ed.body)
            if not on_body and math.hypot(gx - p[0], gy - p[1]) > 2 * GRAB_PIXELS:
                return None
        start = ed.begin_pose()
        return {"what": "pose", "axis": axis, "start": p, "world": goal[0], "item": goal[2],
                "position": start["position"].copy(), "rotation": start["rotation"].copy()}

    def _update_drag(self, px):
        d = self._drag
        ed = self.editor
        r = self.view
        cam = self.camera
        p = np.asarray(px, float)
        delta = p - d["start"]
        d["moved"] = d.get("moved", False) or float(np.abs(delta).sum()) > 1.0
        right, up, back = cam.basis()
        depth = float(np.dot(d["world"] - cam.eye(), -back))
        mpp = 2.0 * max(depth, 1e-6) * math.tan(cam.fov_y / 2.0) / r.height
        try:
            if d["what"] == "target":
                move = (delta[0] * right - delta[1] * up) * mpp
                item = ed.preview.items[d["k"]]
                ed.drag_target(d["k"], d["name"], d["char"] + move / item.actor.scale)
                return
            item = d["item"]
            axis = d["axis"]
            if self.gizmo == "rotate":
                about = np.eye(3)[axis] if axis is not None else -back
                q = _axis_quat(about, delta[0] * ROTATE_PER_PIXEL)
                ed.pose(rotation=_qmul(q, d["rotation"]))
                return
            if axis is None:
                move = (delta[0] * right - delta[1] * up) * mpp
            else:
                a = np.eye(3)[axis]
                (s0, s1) = cam.project(np.array([d["world"], d["world"] + a]), r.width, r.height)[0]
                s = s1 - s0
                n2 = float(np.dot(s, s))
                move = a * (float(np.dot(delta, s)) / n2 if n2 > 1e-9 else 0.0)
            ed.pose(position=d["position"] + move / item.actor.scale)
        except MenagerieError as exc:
            ed.message = str(exc)

    def delete_selected_keys(self) -> None:
        ed = self.editor
        by_kind: dict[str, list[int]] = {}
        for kind, i in ed.selected_keys:
            by_kind.setdefault(kind, []).append(i)
        for kind, idx in by_kind.items():
            ed.delete_keys(kind, idx)
        ed.selected_keys.clear()

    # -- the 3-D picture ------------------------------------------------------------------------------

    def _scene(self) -> sc.Scene:
        import dataclasses

        ed = self.editor
        base = ed.preview.scene
        points, segments, polylines = [], [], []
        played = getattr(ed.preview, "played", None)
        if played is not None and played.target_names:
            tp = [item.to_world(ed.preview.target_position(k, n)) for k, item in enumerate(ed.preview.items)
                  if not item.declined for n in played.target_names]
            if tp:
                points.append(sc.Points(np.array(tp), color=TARGET_COLOR, size=14.0, name="targets"))
        goal = self._goal_world()
        if goal is not None:
            item = goal[2]
            path = ed.goal_path()
            if path is not None:
                polylines.append(sc.Polyline(item.to_world(path), color=PATH_COLOR, width=2.0,
                                             closed=False, name="channel curve"))
            segs, _ = self._gizmo_segments(goal)
            for a, (s0, s1) in enumerate(segs):
                width = 4.0 if self.axis == a else 2.5
                segments.append(sc.Segments(s0[None], s1[None], color=AXIS_COLORS[a], width=width,
                                            name=f"axis {a}"))
            points.append(sc.Points(goal[0][None], color=(1.0, 0.9, 0.1), size=12.0, name="goal"))
        return dataclasses.replace(base, points=points, segments=segments, polylines=polylines,
                                   camera=self.camera, caption=None)

    # -- one frame --------------------------------------------------------------------------------------

    def frame(self, dt: float = 1 / 60) -> None:
        """Advance the editor, build the panels, draw the picture and the panels."""
        imgui = self.imgui
        if self.closed:
            return
        self.window.switch_to()
        try:
            self.editor.tick(dt)
            gait = getattr(self, "gait_editor", None)
            if gait is not None and gait.walking:
                gait.update(dt)
                if not self.editor.playing:
                    self.editor.preview.advance(dt)
        except MenagerieError as exc:
            self.editor.message = str(exc)
        self.impl.process_inputs()
        imgui.new_frame()
        self._panels()
        imgui.render()
        scene = self._scene()
        self.view.draw(scene, self.camera)
        x0, _, _, y1 = self._free_rect()
        self.renderer.compose(self.view, int(x0), int(self.renderer.height - y1), scene.background)
        self.renderer.begin_overlay()
        self.impl.render(imgui.get_draw_data())
        self.renderer.end_overlay()
        self._frames += 1
        if self._close_after_frame:
            self.close()

    def draw(self) -> None:
        """A frame, shown in the window."""
        self.frame(1 / 60)
        if not self.closed:
            self.window.switch_to()
            self.renderer.present()

    def on_draw(self):
        # pyglet's app loop draws through ``_tick``; a redraw request just presents.
        return None

    def _tick(self, dt):
        if self.closed:
            return
        self.frame(dt)
        if not self.closed:
            self.renderer.present()
            self.window.flip()

    def snapshot(self, path: str, frames: int = 2) -> str:
        """Render ``frames`` frames (ImGui lays windows out over two) and save the last."""
        for _ in range(max(frames, 1)):
            self.frame(1 / 60)
        self.renderer.save_png(path)
        return path

    def close(self) -> None:
        import pyglet

        if self.closed:
            return
        self.closed = True
        pyglet.clock.unschedule(self._tick)
        self.window.switch_to()
        try:
            self.impl.shutdown()
        except Exception:  # noqa: BLE001 - GL objects may already be gone with the context
            pass
        self.implot.destroy_context(self.plot_ctx)
        self.imgui.destroy_context(self.ctx)
        self.renderer.close()
        self.view.close()
        self.window.close()
        pyglet.app.exit()

    # -- panels ---------------------------------------------------------------------------------------

    def _try(self, fn, *args, **kw):
        try:
            return fn(*args, **kw)
        except MenagerieError as exc:
            self.editor.message = str(exc)
        except (ValueError, KeyError) as exc:
            self.editor.message = str(exc)
        return None

    def _panels(self) -> None:
        imgui = self.imgui
        w, h = self.window.width, self.window.height
        self._menu()
        fixed = (imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_collapse)
        imgui.set_next_window_pos((0, MENU_H))
        imgui.set_next_window_size((LEFT_W, h - MENU_H - BOTTOM_H))
        imgui.begin("Channels", None, fixed)
        self._channels_panel()
        imgui.end()
        imgui.set_next_window_pos((w - RIGHT_W, MENU_H))
        imgui.set_next_window_size((RIGHT_W, h - MENU_H - BOTTOM_H))
        imgui.begin("Animation", None, fixed)
        self._asset_panel()
        imgui.end()
        imgui.set_next_window_pos((0, h - BOTTOM_H))
        imgui.set_next_window_size((w, BOTTOM_H))
        imgui.begin("Timeline and curves", None, fixed)
        self._timeline_panel()
        imgui.end()
        if self.show_help:
            self._help_panel()
        if self.editor.doc.load_error:
            imgui.set_next_window_pos((LEFT_W + 10, MENU_H + 10))
            imgui.set_next_window_size((max(w - LEFT_W - RIGHT_W - 20, 200), 0))
            imgui.begin("The file did not load", None, imgui.WindowFlags_.no_collapse)
            imgui.text_colored((0.75, 0.05, 0.05, 1.0), "This file could not be opened:")
            imgui.text_wrapped(self.editor.doc.load_error)
            imgui.text_wrapped("A new animation is shown instead. Saving will not replace the file "
                               "(use File > Save anyway to do so); fix it in a text editor and reopen.")
            imgui.end()
        if self._ask_close:
            imgui.open_popup("Unsaved changes")
        opened, _ = imgui.begin_popup_modal("Unsaved changes", None, imgui.WindowFlags_.always_auto_resize)
        if opened:
            imgui.text(f"{self.editor.animation.name} has unsaved changes.")
            if imgui.button("Save and close"):
                if self._try(self.editor.save) is not None:
                    self._close_now()
            self._rec("Save and close")
            imgui.same_line()
            if imgui.button("Discard and close"):
                self._close_now()
            self._rec("Discard and close")
            imgui.same_line()
            if imgui.button("Cancel"):
                self._ask_close = False
                imgui.close_current_popup()
            imgui.end_popup()

    def _close_now(self):
        """Close after this frame (never inside it: the panels still use the context)."""
        self._ask_close = False
        self.want_close = True
        self.imgui.close_current_popup()
        self._close_after_frame = True

    _close_after_frame = False

    def _menu(self) -> None:
        imgui = self.imgui
        ed = self.editor
        if imgui.begin_main_menu_bar():
            if imgui.begin_menu("File"):
                if imgui.menu_item("Save", "Ctrl-S", False)[0]:
                    self._try(ed.save)
                if ed.doc.load_error and imgui.menu_item("Save anyway (replace the broken file)", "", False)[0]:
                    self._try(ed.save, force=True)
                if imgui.menu_item("Quit", "", False)[0]:
                    if self.editor.doc.dirty:
                        self._ask_close = True
                    else:
                        self._close_after_frame = True
                imgui.end_menu()
            if imgui.begin_menu("Edit"):
                if imgui.menu_item("Undo", "Ctrl-Z", False, ed.doc.can_undo)[0]:
                    ed.undo()
                if imgui.menu_item("Redo", "Ctrl-Shift-Z", False, ed.doc.can_redo)[0]:
                    ed.redo()
                imgui.end_menu()
            if imgui.begin_menu("View"):
                if imgui.menu_item("Frame all", "F", False)[0]:
                    self.reframe()
                if imgui.menu_item("Help", "F1", self.show_help)[0]:
                    self.show_help = not self.show_help
                imgui.end_menu()
            dirty = "*" if ed.doc.dirty else ""
            imgui.text(f"   {ed.doc.path or '(new)'}{dirty}   {ed.message}")
            imgui.end_main_menu_bar()

    def _help_panel(self) -> None:
        imgui = self.imgui
        w, _ = self.window.width, self.window.height
        imgui.set_next_window_pos((LEFT_W + 12, MENU_H + 12))
        imgui.set_next_window_size((min(520, w - LEFT_W - RIGHT_W - 24), 0))
        _, keep = imgui.begin("Help", True, imgui.WindowFlags_.no_collapse)
        if imgui.begin_table("keys", 2):
            for k, what in HELP:
                imgui.table_next_column()
                imgui.text(k)
                imgui.table_next_column()
                imgui.text_wrapped(what)
            imgui.end_table()
        imgui.end()
        if keep is False:
            self.show_help = False

    # ... channels ...

    def _channels_panel(self) -> None:
        imgui = self.imgui
        ed = self.editor
        anim = ed.animation
        if imgui.begin_table("channel list", 3, imgui.TableFlags_.sizing_stretch_prop):
            imgui.table_setup_column("channel", imgui.TableColumnFlags_.width_stretch)
            imgui.table_setup_column("M", imgui.TableColumnFlags_.width_fixed)
            imgui.table_setup_column("S", imgui.TableColumnFlags_.width_fixed)
            imgui.table_headers_row()
            for ch in anim.channels:
                imgui.push_id(ch.name)
                imgui.table_next_column()
                if imgui.selectable(ch.name, ed.channel == ch.name)[0]:
                    ed.select_channel(ch.name)
                imgui.table_next_column()
                changed, on = imgui.checkbox("##mute", ch.name in ed.muted)
                if changed:
                    ed.set_mute(ch.name, on)
                if imgui.is_item_hovered():
                    imgui.set_tooltip("mute (preview only)")
                imgui.table_next_column()
                changed, on = imgui.checkbox("##solo", ed.solo == ch.name)
                if changed:
                    ed.set_solo(ch.name if on else None)
                if imgui.is_item_hovered():
                    imgui.set_tooltip("solo (preview only)")
                imgui.pop_id()
            imgui.end_table()
        if imgui.button("Add"):
            self._try(ed.add_channel)
        imgui.same_line()
        if imgui.button("Duplicate"):
            self._try(ed.duplicate_channel)
        imgui.same_line()
        if imgui.button("Remove"):
            self._try(ed.remove_channel)
        imgui.same_line()
        if imgui.button("Up") and ed.channel:
            self._try(ed.move_channel, ed.channel, -1)
        imgui.same_line()
        if imgui.button("Down") and ed.channel:
            self._try(ed.move_channel, ed.channel, 1)
        presets = self._try(ed.presets) or []
        if presets:
            names = [p.name for p in presets]
            imgui.set_next_item_width(150)
            changed, i = imgui.combo("##preset", self._rename.get("preset", 0), names)
            self._rename["preset"] = i
            imgui.same_line()
            if imgui.button("Add preset"):
                self._try(ed.add_preset, names[min(i, len(names) - 1)])
        ch = ed.active_channel()
        if ch is None:
            return
        if imgui.button("Save channel as preset"):
            self._try(ed.save_preset)
        imgui.separator_text(f"channel '{ch.name}'")
        text = self._rename.get(ch.name, ch.name)
        changed, text = imgui.input_text("name", text)
        self._rename[ch.name] = text
        if imgui.is_item_deactivated_after_edit() and text != ch.name:
            self._try(ed.rename_channel, ch.name, text)
            self._rename.pop(ch.name, None)
        if imgui.begin_tab_bar("channel tabs"):
            opened = imgui.begin_tab_item("Query")[0]
            self._rec("tab Query")
            if opened:
                self._query_editor(ch)
                imgui.end_tab_item()
            opened = imgui.begin_tab_item("Modes")[0]
            self._rec("tab Modes")
            if opened:
                self._modes_editor(ch)
                imgui.end_tab_item()
            opened = imgui.begin_tab_item("Groups")[0]
            self._rec("tab Groups")
            if opened:
                self._groups_editor(ch)
                imgui.end_tab_item()
            opened = imgui.begin_tab_item("Events")[0]
            self._rec("tab Events")
            if opened:
                self._events_editor(ch)
                imgui.end_tab_item()
            imgui.end_tab_bar()

    def _rec(self, name: str) -> None:
        """Remember where the last widget is (window units, y down): tests click there."""
        a, b = self.imgui.get_item_rect_min(), self.imgui.get_item_rect_max()
        self.widgets[name] = (0.5 * (a.x + b.x), 0.5 * (a.y + b.y))

    def _combo(self, label, value, options, none_label=None):
        """A combo over ``options`` (plus a first 'none' entry when given); returns
        (changed, value). Its box and, while open, its items are recorded in ``widgets``."""
        imgui = self.imgui
        items = ([none_label] if none_label is not None else []) + list(options)
        shown = none_label if value is None else value
        changed, out = False, value
        opened = imgui.begin_combo(label, str(shown))
        self._rec(label)
        if opened:
            for item in items:
                if imgui.selectable(str(item), item == shown)[0]:
                    changed = item != shown
                    out = None if (none_label is not None and item == none_label) else item
                self._rec(f"{label}/{item}")
            imgui.end_combo()
        return changed, out

    def _query_fields(self, q, *, secondary=False):
        imgui = self.imgui
        ed = self.editor
        tag = "secondary " if secondary else ""
        changed, v = self._combo(f"{tag}type", q.type, QUERY_TYPES)
        if changed:
            self._try(ed.set_query, secondary=secondary, type=v)
        for axis, zones in AXIS_ZONES.items():
            imgui.set_next_item_width(110)
            changed, v = self._combo(f"{tag}{axis}: {'/'.join(zones)}", getattr(q, axis), zones, "any")
            if changed:
                self._try(ed.set_query, secondary=secondary, **{axis: v})
            if getattr(q, axis) is not None:
                imgui.same_line()
                changed, on = imgui.checkbox(f"setspace##{tag}{axis}", getattr(q, f"{axis}_space") == "setspace")
                if changed:
                    self._try(ed.set_query, secondary=secondary,
                              **{f"{axis}_space": "setspace" if on else "character"})
        changed, v = self._combo(f"{tag}extent", q.extent, list(EXTENTS), "none")
        if changed:
            self._try(ed.set_query, secondary=secondary, extent=v)
        changed, v = self._combo(f"{tag}limb modifier", q.limb, LIMB_MODIFIERS, "none")
        if changed:
            self._try(ed.set_query, secondary=secondary, limb=v)

    def _query_editor(self, ch) -> None:
        imgui = self.imgui
        ed = self.editor
        imgui.text_wrapped(f"selects: {ch.query}")
        self._query_fields(ch.query)
        imgui.separator_text("selected bodies")
        for k, item in enumerate(ed.preview.items):
            bodies = ed.selected_bodies(k)
            names = ", ".join(item.creature.body_names[b] for b in bodies)
            if item.declined:
                imgui.push_style_color(imgui.Col_.text, (0.45, 0.45, 0.45, 1.0))
                imgui.text_wrapped(f"{item.name}: {item.declined}")
                imgui.pop_style_color()
            elif len(bodies):
                imgui.text_wrapped(f"{item.name}: {names}")
            else:
                imgui.text_colored((0.8, 0.1, 0.1, 1.0), f"{item.name}: selects no body")

    def _modes_editor(self, ch) -> None:
        imgui = self.imgui
        ed = self.editor
        pos = ch.position
        changed, mode = self._combo("position", pos.mode if pos else None, list(POSITION_MODES), "none")
        if changed:
            self._try(ed.set_modes, position=None if mode is None else PositionSpec(mode))
        if pos is not None:
            flags = {}
            for flag, ok in (("ground", pos.mode == "rest"), ("sagittal", pos.mode == "rest"),
                             ("directional_only", pos.mode == "secondary" and not pos.contact),
                             ("contact", pos.mode == "secondary" and not pos.directional_only)):
                if ok:
                    c, v = imgui.checkbox(flag, getattr(pos, flag))
                    if c:
                        flags[flag] = v
                    imgui.same_line()
            imgui.new_line()
            c, scale = self._combo("scale", pos.scale, SCALE_MODES)
            if c:
                flags["scale"] = scale
            if flags:
                import dataclasses

                self._try(ed.set_modes, position=dataclasses.replace(pos, **flags))
        rot = ch.rotation
        changed, mode = self._combo("rotation", rot.mode if rot else None, list(ROTATION_MODES), "none")
        if changed:
            self._try(ed.set_modes, rotation=None if mode is None else RotationSpec(mode))
        if rot is not None and rot.mode == "lookat":
            c, lim = imgui.drag_float2("lookat limits (deg)", list(rot.limits), 1.0, 0.0, 180.0)
            if imgui.is_item_deactivated_after_edit() or (c and not imgui.is_item_active()):
                self._try(ed.set_modes, rotation=RotationSpec("lookat", tuple(float(x) for x in lim)))
        if ch.needs_target or ch.target is not None or ch.secondary is not None:
            imgui.separator_text("relative to")
            kind = "target" if ch.target is not None else "secondary" if ch.secondary is not None else None
            c, kind2 = self._combo("relative to", kind, ["target", "secondary"], "nothing")
            if c and kind2 != kind:
                from engine.query import Query

                if kind2 == "target":
                    self._try(ed.set_relative_to, target=(ed.animation.target_names or ("target",))[0])
                elif kind2 == "secondary":
                    self._try(ed.set_relative_to, secondary=Query(type="mouth"))
                else:
                    self._try(ed.set_relative_to)
            if ch.target is not None:
                text = self._rename.get(("target", ch.name), ch.target)
                _, text = imgui.input_text("target name", text)
                self._rename[("target", ch.name)] = text
                if imgui.is_item_deactivated_after_edit() and text and text != ch.target:
                    self._try(ed.set_relative_to, target=text)
            if ch.secondary is not None:
                self._query_fields(ch.secondary, secondary=True)
        try:
            k, body = ed.remap_body()
            item = ed.preview.items[k]
            imgui.text_wrapped(f"A mode change keeps the motion of {item.name} / {item.creature.body_names[body]}"
                               " exactly (the keys are remapped).")
        except MenagerieError:
            pass

    def _groups_editor(self, ch) -> None:
        imgui = self.imgui
        ed = self.editor
        for field in ("blend_group", "variant_group"):
            text = self._rename.get((field, ch.name), getattr(ch, field) or "")
            _, text = imgui.input_text(field.replace("_", " "), text)
            self._rename[(field, ch.name)] = text
            if imgui.is_item_deactivated_after_edit():
                self._try(ed.set_channel_fields, **{field: text or None})
                self._rename.pop((field, ch.name), None)
        c, p = imgui.input_int("priority", ch.priority)
        if c:
            self._try(ed.set_channel_fields, priority=p)
        if ch.variant_group is not None:
            c, side = self._combo("side", ch.side, SIDE_CONSTRAINTS, "any")
            if c:
                self._try(ed.set_channel_fields, side=side)
        c, m = imgui.checkbox("mirror (right-side bodies specialize mirrored)", ch.mirror)
        if c:
            self._try(ed.set_channel_fields, mirror=m)

    def _events_editor(self, ch) -> None:
        imgui = self.imgui
        ed = self.editor
        for i, e in enumerate(ch.events):
            imgui.push_id(f"ev{i}")
            imgui.set_next_item_width(60)
            c, t = imgui.drag_float("##t", e.t, 0.01, 0.0, ed.animation.length, "%.2f s")
            if c:
                self._try(ed.edit_event, i, t=t, coalesce=("event", ch.name, i))
            if imgui.is_item_deactivated():
                ed.end_gesture()
            imgui.same_line()
            imgui.set_next_item_width(90)
            text = self._rename.get(("ev", ch.name, i), e.name)
            _, text = imgui.input_text("##name", text)
            self._rename[("ev", ch.name, i)] = text
            if imgui.is_item_deactivated_after_edit() and text:
                self._try(ed.edit_event, i, name=text)
            imgui.same_line()
            imgui.set_next_item_width(80)
            data = self._rename.get(("evd", ch.name, i), e.data or "")
            _, data = imgui.input_text("##data", data)
            self._rename[("evd", ch.name, i)] = data
            if imgui.is_item_deactivated_after_edit():
                self._try(ed.edit_event, i, data=data or None)
            imgui.same_line()
            if imgui.small_button("x"):
                self._try(ed.remove_event, i)
            imgui.pop_id()
        if imgui.button("Add event at the current time"):
            self._try(ed.add_event, ed.time, "event")

    # ... the asset, creatures, gaits ...

    def _asset_panel(self) -> None:
        imgui = self.imgui
        ed = self.editor
        anim = ed.animation
        if imgui.begin_tab_bar("asset tabs"):
            opened = imgui.begin_tab_item("Animation")[0]
            self._rec("tab Animation")
            if opened:
                text = self._rename.get("anim name", anim.name)
                _, text = imgui.input_text("name", text)
                self._rename["anim name"] = text
                if imgui.is_item_deactivated_after_edit() and text:
                    self._try(ed.set_asset_fields, name=text)
                length = self._rename.get("length", anim.length)
                c, length = imgui.drag_float("length (s)", length, 0.01, 0.05, 60.0, "%.2f")
                self._rename["length"] = length
                if imgui.is_item_deactivated_after_edit():
                    self._try(ed.set_length, length)
                    self._rename.pop("length", None)
                c, loop = imgui.checkbox("loop", anim.loop)
                if c:
                    self._try(ed.set_asset_fields, loop=loop)
                imgui.separator_text("branch predicates")
                branches = dict(anim.branches)
                for pred in BRANCH_PREDICATES:
                    v = branches.get(pred)
                    cur = "ignore" if v is None else ("true" if v else "false")
                    imgui.set_next_item_width(80)
                    c, choice = self._combo(pred, cur, ["ignore", "true", "false"])
                    if c:
                        self._try(ed.set_branch, pred, None if choice == "ignore" else choice == "true")
                for pred in COUNT_PREDICATES:
                    v = branches.get(pred)
                    c, on = imgui.checkbox(f"##{pred}", v is not None)
                    if c:
                        self._try(ed.set_branch, pred, 0 if on else None)
                    imgui.same_line()
                    imgui.set_next_item_width(80)
                    imgui.begin_disabled(v is None)
                    c, n = imgui.input_int(pred, v or 0)
                    if c and v is not None:
                        self._try(ed.set_branch, pred, max(int(n), 0))
                    imgui.end_disabled()
                if anim.target_names:
                    imgui.separator_text("external targets (preview defaults)")
                    for name in anim.target_names:
                        d = anim.target_default(name) or (0.9, 0.3, 0.85)
                        c, v = imgui.drag_float3(name, list(d), 0.01)
                        if imgui.is_item_deactivated_after_edit() or (c and not imgui.is_item_active()):
                            self._try(ed.set_target_default, name, v)
                imgui.end_tab_item()
            opened = imgui.begin_tab_item("Creatures")[0]
            self._rec("tab Creatures")
            if opened:
                self._creatures_panel()
                imgui.end_tab_item()
            opened = imgui.begin_tab_item("Gaits")[0]
            self._rec("tab Gaits")
            if opened:
                self._gait_panel()
                imgui.end_tab_item()
            imgui.end_tab_bar()

    def _creatures_panel(self) -> None:
        imgui = self.imgui
        ed = self.editor
        for k, item in enumerate(ed.preview.items):
            imgui.push_id(f"cr{k}")
            active = "> " if k == ed.creature else ""
            if imgui.selectable(f"{active}{item.name} ({item.creature.nbody} bodies)", k == ed.creature)[0]:
                ed.activate(k, None)
            if item.declined:
                imgui.text_colored((0.75, 0.1, 0.1, 1.0), item.declined)
            else:
                variants = ed.variants(k)
                labels = [f"{v}{' (mirror)' if m else ''}" for v, m in variants]
                ids = [v for v, _ in variants]
                cur = ids.index(item.variant) if item.variant in ids else 0
                c, i = imgui.combo("variant", cur, labels)
                if c:
                    self._try(ed.set_variant, k, ids[i])
                imgui.text(f"{len(variants)} variant(s)")
            imgui.pop_id()
            imgui.separator()

    def _gait_panel(self) -> None:
        imgui = self.imgui
        gait = getattr(self, "gait_editor", None)
        if gait is None:
            from authoring.gait_edit import GaitEditor

            self.gait_editor = gait = GaitEditor(self.editor.preview)
        from engine.gait.style import SPEED_FIELDS, style_names

        names = style_names()
        c, name = self._combo("style", gait.name, names)
        if c:
            self._try(gait.open_style, name)
        c, on = imgui.checkbox("preview walking", gait.walking)
        if c:
            self._try(gait.set_walking, on)
        if gait.walking:
            c, v = imgui.slider_float("speed (leg lengths/s)", gait.speed, 0.0, 3.0)
            if c:
                gait.speed = v
        imgui.separator_text("speeds")
        rows = gait.rows()
        if imgui.begin_table("speeds", len(SPEED_FIELDS), imgui.TableFlags_.borders):
            for f in SPEED_FIELDS:
                imgui.table_setup_column(f)
            imgui.table_headers_row()
            for r, row in enumerate(rows):
                for j, f in enumerate(SPEED_FIELDS):
                    imgui.table_next_column()
                    imgui.set_next_item_width(-1)
                    c, v = imgui.drag_float(f"##{r}{f}", row[j], 0.005, 0.0, 4.0, "%.3f")
                    if c:
                        self._try(gait.set_cell, r, f, v)
            imgui.end_table()
        imgui.separator_text("flight arc")
        arc = gait.arc()
        if arc is not None:
            for f, lo, hi in (("peak", 0.05, 0.95), ("lead", -0.9, 0.9), ("pitch", -1.0, 1.0)):
                c, v = imgui.slider_float(f, arc[f], lo, hi)
                if c:
                    self._try(gait.set_arc, f, v)
        else:
            imgui.text_wrapped("this style's flight path is a curve of points (edit it in its file)")
        imgui.text_wrapped(gait.message)
        if imgui.button("Save style"):
            self._try(gait.save)
        imgui.same_line()
        if imgui.button("Undo##gait"):
            gait.undo()

    # ... timeline and curves ...

    def _timeline_panel(self) -> None:
        imgui = self.imgui
        implot = self.implot
        ed = self.editor
        anim = ed.animation
        if imgui.button("|<"):
            ed.set_time(0.0)
        imgui.same_line()
        if imgui.button("<"):
            ed.step(-1)
        imgui.same_line()
        if imgui.button("Pause" if ed.playing else "Play"):
            ed.play()
        imgui.same_line()
        if imgui.button(">"):
            ed.step(1)
        imgui.same_line()
        if imgui.button(">|"):
            ed.set_time(anim.length)
        imgui.same_line()
        c, loop = imgui.checkbox("loop", ed.loop)
        if c:
            ed.set_loop(loop)
        imgui.same_line()
        imgui.set_next_item_width(90)
        c, sp = imgui.drag_float("speed", ed.speed, 0.01, -4.0, 4.0, "%.2fx")
        if c and sp != 0.0:
            self._try(ed.set_speed, sp)
        imgui.same_line()
        imgui.set_next_item_width(max(self.window.width - 760, 120))
        c, t = imgui.slider_float("##time", ed.time, 0.0, anim.length, "t = %.3f s")
        if c:
            ed.set_time(t)
        ch = ed.active_channel()
        imgui.same_line()
        kinds = [k for k in ("position", "rotation", "weight")
                 if ch is not None and (k == "weight" or getattr(ch, k) is not None)]
        self._kind = getattr(self, "_kind", "position")
        if kinds and self._kind not in kinds:
            self._kind = kinds[0]
        imgui.set_next_item_width(90)
        c, self._kind = self._combo("##kind", self._kind, kinds or ["position"])
        imgui.same_line()
        c, spec = imgui.checkbox("specialized", ed.space == "specialized")
        if c:
            ed.space = "specialized" if spec else "generalized"
            self.fit_curves = True
        imgui.same_line()
        if imgui.button("Frame all"):
            self.fit_curves = True
        if ch is None:
            return
        self._tangent_row(ch)
        self._curve_editor(ch)
        del implot

    def _tangent_row(self, ch) -> None:
        """The selected key's tangents (per second; rotations: angular velocity, rad/s):
        automatic, flat, or typed in."""
        imgui = self.imgui
        ed = self.editor
        sel = sorted(i for k, i in ed.selected_keys if k == self._kind)
        keys = ed.keys(self._kind)
        if not sel or sel[-1] >= len(keys):
            imgui.text_disabled("click a key to edit its tangents; Ctrl-click for several")
            return
        if imgui.button("Auto tangents"):
            for i in sel:
                self._try(ed.set_tangents, self._kind, i, tin=None, tout=None)
        self._rec("Auto tangents")
        imgui.same_line()
        if imgui.button("Flat"):
            self._try(ed.flatten_tangents, self._kind, sel)
        self._rec("Flat")
        if len(sel) != 1:
            imgui.same_line()
            imgui.text(f"{len(sel)} keys selected")
            return
        i = sel[0]
        k = keys[i]
        width = 1 if self._kind == "weight" else 3
        for name, value in (("in", k.tin), ("out", k.tout)):
            imgui.same_line()
            imgui.set_next_item_width(200 if width == 3 else 70)
            shown = list(value) if value is not None else [0.0] * width
            label = f"{name}{'' if value is not None else ' (auto)'}###{name}"
            if width == 3:
                c, v = imgui.drag_float3(label, shown, 0.01)
            else:
                c, v0 = imgui.drag_float(label, shown[0], 0.01)
                v = [v0]
            if c:
                self._try(ed.set_tangents, self._kind, i, **{f"t{name}": v}, coalesce=("tangent", ch.name, i))
            if imgui.is_item_deactivated():
                ed.end_gesture()
        imgui.same_line()
        imgui.text(f"key {i + 1}/{len(keys)} at {k.t:.3f} s")

    def _curve_editor(self, ch) -> None:
        imgui = self.imgui
        implot = self.implot
        ed = self.editor
        kind = self._kind
        space = ed.space
        try:
            times, values = ed.curve(kind, space)
            kv = ed.key_values(kind, space)
        except MenagerieError as exc:
            imgui.text_colored((0.7, 0.1, 0.1, 1.0), f"{exc} (curves shown generalized)")
            space = "generalized"
            times, values = ed.curve(kind, space)
            kv = ed.key_values(kind, space)
        keys = ed.keys(kind)
        if self.fit_curves:
            implot.set_next_axes_to_fit()
            self.fit_curves = False
        unit = {"position": "m" if space == "specialized" else "q_g", "rotation": "deg",
                "weight": "0..1"}[kind]
        self.key_pixels.clear()
        if implot.begin_plot(f"##curves {ch.name}", (-1, -1)):
            implot.setup_axes("time (s)", unit if space == "generalized" else f"{unit} on the body")
            labels = ("x", "y", "z") if kind != "weight" else ("w",)
            for c in range(values.shape[1]):
                spec = implot.Spec()
                spec.line_color = CURVE_COLORS[c % 3] if kind != "weight" else (0.3, 0.3, 0.3, 1.0)
                spec.line_weight = 2.0
                implot.plot_line(labels[c], np.ascontiguousarray(times), np.ascontiguousarray(values[:, c]), spec)
            events = [e.t for e in ch.events]
            if events:
                spec = implot.Spec()
                spec.line_color = (0.6, 0.2, 0.8, 1.0)
                implot.plot_inf_lines("events", np.array(events, float), spec)
                for e in ch.events:
                    implot.tag_x(e.t, (0.6, 0.2, 0.8, 1.0), e.name)
            # playhead
            c, t, _, _, held = implot.drag_line_x(1, ed.time, (0.1, 0.1, 0.1, 1.0), 1.5, 0, False, False, False)
            if c:
                ed.set_time(min(max(t, 0.0), ed.animation.length))
            # keys
            released = imgui.is_mouse_released(0)
            ctrl = imgui.get_io().key_ctrl
            for i, k in enumerate(keys):
                for c in range(kv.shape[1]):
                    sel = (kind, i) in ed.selected_keys
                    col = (1.0, 0.75, 0.0, 1.0) if sel else (CURVE_COLORS[c % 3] if kind != "weight"
                                                             else (0.2, 0.2, 0.2, 1.0))
                    ident = 100 + i * 4 + c
                    moved, x, y, clicked, _hov, held = implot.drag_point(ident, float(k.t), float(kv[i, c]), col,
                                                                         7.0 if sel else 5.0, 0, False, False,
                                                                         False)
                    pix = implot.plot_to_pixels(float(k.t), float(kv[i, c]))
                    self.key_pixels[(kind, i, c)] = (pix.x, pix.y)
                    if clicked:
                        if ctrl:
                            ed.selected_keys ^= {(kind, i)}
                        elif (kind, i) not in ed.selected_keys:
                            ed.selected_keys = {(kind, i)}
                    if moved:
                        self._drag_key(kind, space, i, c, x, y, kv)
            if released and self._curve_drag is not None:
                self._curve_drag = None
                ed.end_gesture()
            self._mouse_over_curves = implot.is_plot_hovered()
            lim = implot.get_plot_limits()
            self.plot_limits = (lim.x.min, lim.x.max, lim.y.min, lim.y.max)
            a, b = implot.get_plot_pos(), implot.get_plot_size()
            self.plot_rect = (a.x, a.y, a.x + b.x, a.y + b.y)
            implot.end_plot()

    def curve_pixel(self, t: float, v: float) -> tuple[float, float]:
        """Where (time, value) is in the curve editor of the last frame (window units, y down)."""
        tmin, tmax, vmin, vmax = self.plot_limits
        x0, y0, x1, y1 = self.plot_rect
        return (x0 + (t - tmin) / (tmax - tmin) * (x1 - x0), y1 - (v - vmin) / (vmax - vmin) * (y1 - y0))

    def _drag_key(self, kind, space, i, c, x, y, kv) -> None:
        """A key point dragged to (x time, y value of component c)."""
        ed = self.editor
        d = self._curve_drag
        if d is None or d["key"] != (kind, i, c):
            if (kind, i) not in ed.selected_keys:
                ed.selected_keys = {(kind, i)}
            d = self._curve_drag = {"key": (kind, i, c), "tag": ed.new_gesture(), "base": ed.keys(kind),
                                    "t0": ed.keys(kind)[i].t, "v0": kv[i].copy(),
                                    "sel": sorted(j for kk, j in ed.selected_keys if kk == kind)}
        dt = float(x) - d["t0"]
        if space == "generalized" and kind != "rotation":
            dv = np.zeros(kv.shape[1])
            dv[c] = float(y) - d["v0"][c]
            new = self._try(ed.move_keys, kind, d["sel"], dt, dv, coalesce=("curve", d["tag"]), base=d["base"])
        else:
            value = d["v0"].copy()
            value[c] = float(y)
            # one key at a time: its time, and its value through G when specialized
            import dataclasses

            base = d["base"]
            ed_ch = ed.active_channel()
            if ed_ch is None:
                return
            # start from the keys as they were, then set this key's time and value
            ch0 = dataclasses.replace(ed_ch, **{f"{kind}_keys": base})
            del ch0
            new = self._try(ed.set_key_value, kind, i, value, space=space,
                            t=min(max(d["t0"] + dt, 0.0), ed.animation.length), coalesce=("curve", d["tag"]))
            new = [i] if new is None else new
        if new:
            ed.selected_keys = {(kind, j) for j in new}


# -- entry points ------------------------------------------------------------------------------------


def default_creatures():
    """The default preview: a humanoid, a quadruped, a spider, a snake and a random creature."""
    import engine
    from engine.model import build_creature
    from engine.model.random import random_creature_def
    from engine.paths import LIBRARY_CREATURES

    out = [engine.load_creature(os.path.join(LIBRARY_CREATURES, f"{n}.yaml"))
           for n in ("humanoid", "dog", "spider", "snake")]
    out.append(build_creature(random_creature_def(7)))
    return out


def load_creatures(specs, random_count: int = 0, seed: int = 1):
    """Creatures from library names, creature files or skeletons (BVH), and ``random_count``
    random creatures (seeds ``seed``, ``seed + 1``, ...)."""
    from engine.io.sources import creature_from_file
    from engine.model import build_creature
    from engine.model.random import random_creature_def
    from engine.paths import LIBRARY_CREATURES

    out = []
    for s in specs:
        s = os.fspath(s)
        if not os.path.splitext(s)[1]:
            path = os.path.join(LIBRARY_CREATURES, f"{s}.yaml")
            if not os.path.exists(path):
                raise MenagerieError(f"{s}: no such library creature (creatures/{s}.yaml) and no such file")
            s = path
        if not os.path.exists(s):
            raise MenagerieError(f"{s}: no such file")
        out.append(creature_from_file(s))
    for k in range(random_count):
        out.append(build_creature(random_creature_def(seed + k)))
    return out


def author_command(cell: dict) -> str | None:
    """The ``menagerie author`` command that opens a validation-grid cell (its animation,
    its creature, its variant) at the time of its worst frame; None when the cell has no
    animation file or creature to name."""
    anim = cell.get("animation_path")
    creature = cell.get("creature_args")
    if not anim or not creature:
        return None
    parts = ["menagerie author", anim, creature]
    if cell.get("variant_id"):
        parts.append(f"--variant {cell['variant_id']}")
    worst = cell.get("worst") or {}
    if worst.get("time") is not None:
        parts.append(f"--time {float(worst['time']):.3f}")
    return " ".join(parts)


def run_author(animation_path: str, creatures=(), *, random_count: int = 0, first_seed: int = 1,
               headless: bool = False, snapshot: str | None = None, width: int = 1400, height: int = 800,
               time: float | None = None, channel: str | None = None, variant: str | None = None,
               help_panel: bool = False, overwrite: bool = False, samples: int = 4) -> int:
    """``menagerie author``: open the tool (or, headless, write one frame to ``snapshot``)."""
    from authoring.document import Document

    if snapshot is not None and os.path.exists(snapshot) and not overwrite:
        raise MenagerieError(f"{snapshot} exists (pass --force to overwrite it)")
    cs = load_creatures(creatures, random_count, first_seed) if (creatures or random_count) \
        else default_creatures()
    doc = Document.open(animation_path)
    editor = Editor(doc, cs)
    if channel is not None:
        editor.select_channel(channel)
    if variant is not None:
        named = [k for k in range(len(editor.preview)) if variant in [v for v, _ in editor.variants(k)]]
        if not named:
            raise MenagerieError(f"no preview creature has a variant '{variant}' of {doc.animation.name}")
        for k in named:
            editor.set_variant(k, variant)
    if time is not None:
        editor.set_time(time)
    if headless or snapshot is not None:
        rd.load_pyglet(headless=True)
        win = AuthorWindow.create(editor, width=width, height=height, visible=False, samples=samples)
        try:
            win.show_help = help_panel
            out = snapshot or _free_png(os.path.splitext(os.path.basename(animation_path))[0] + "_author.png")
            win.snapshot(out)
        finally:
            win.close()
        print(f"wrote {out}")
        if doc.load_error:
            print(f"menagerie author: the file did not load: {doc.load_error}")
        return 0
    pyglet = rd.load_pyglet(headless=False)
    try:
        win = AuthorWindow.create(editor, width=width, height=height, visible=True, samples=samples)
    except rd.ViewerError:
        raise
    except Exception as exc:  # noqa: BLE001 - pyglet's display errors have no common base
        raise rd.ViewerError(f"cannot open a window on DISPLAY={os.environ.get('DISPLAY')!r} "
                             f"({type(exc).__name__}: {exc}); use --headless --snapshot OUT.png") from None
    win.show_help = help_panel
    pyglet.clock.schedule_interval(win._tick, 1 / 60)
    try:
        pyglet.app.run()
    finally:
        win.close()
    return 0


def _free_png(path: str) -> str:
    from authoring.viewer import _free_path

    return _free_path(path)


def measure_fps(editor: Editor, *, width: int = 1400, height: int = 800, frames: int = 60,
                playing: bool = True, read: bool = False, samples: int = 4) -> dict:
    """Frames per second of the whole tool off screen: every creature ticked by the
    runtime, the panels built, the 3-D view drawn, composed with the panels and copied to
    the window (``present``, what the window does each frame), finished (``glFinish``);
    with ``read`` the pixels are read back too (what a snapshot or a test does). For
    ``benchmarks/author.py``."""
    import time as _time

    rd.load_pyglet(headless=True)
    win = AuthorWindow.create(editor, width=width, height=height, visible=False, samples=samples)
    from pyglet import gl

    try:
        editor.play(playing)
        for _ in range(5):
            win.frame(1 / 60)
        out = np.empty((win.renderer.height, win.renderer.width, 3), np.uint8)
        per = []
        for _ in range(frames):
            t0 = _time.perf_counter()
            win.frame(1 / 60)
            win.renderer.present()
            if read:
                win.renderer.read_pixels(out)
            gl.glFinish()
            per.append(_time.perf_counter() - t0)
        info = win.renderer.gl_info()
        samples = win.view.samples
    finally:
        win.close()
    ms = float(np.median(per)) * 1e3
    return {"creatures": len(editor.preview), "width": width, "height": height, "frames": frames,
            "median_ms": ms, "fps": 1000.0 / ms, "p90_ms": float(np.percentile(per, 90)) * 1e3, "gl": info,
            "samples": samples}
