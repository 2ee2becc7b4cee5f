"""Draw a ``Scene`` with OpenGL through pyglet, on screen or off screen.

``Renderer`` owns one GL context (a hidden pyglet window, or the window it is given),
one shader program, one vertex buffer and a multisampled framebuffer of the picture's
size. ``draw(scene)`` fills the vertex array (``authoring.geometry``), uploads it and
draws; ``read_pixels()`` returns the picture as ``(height, width, 3) uint8``, top row
first. Both can be called every frame: nothing is recreated, and vertex memory is only
reallocated when a scene outgrows it.

Headless: with no ``DISPLAY`` (Linux), or when asked (``headless=True``, or
``MENAGERIE_HEADLESS=1``), pyglet is started in its headless EGL mode before
``pyglet.window`` is imported; Mesa's llvmpipe gives an OpenGL 4.5 core context with no
X server. pyglet picks its mode once per process, at that import.

Drawing order and state, per frame:
1. clear to the scene background;
2. ground grid: depth-tested, blended (its lines fade out), not writing depth, then
   ground shadows (boxes flattened onto z = 0) darkening each pixel once (stencil);
3. body faces: Lambert-lit (``scene.LIGHT_DIR``, ``scene.AMBIENT``), polygon offset so
   4. the box edges drawn next sit cleanly on top of them;
5. links, overlay lines, joint markers, overlay points: once where visible, and once
   more where hidden behind bodies at ``scene.overlay_hidden_alpha`` (an x-ray);
6. text labels (pyglet.text), at the projected anchor points, and the scene's caption
   at the top left.
Line widths and point sizes are in pixels of a 720-row picture and scale with height.

No pillow needed: ``write_png`` encodes with zlib.
"""

from __future__ import annotations

import ctypes
import math
import os
import struct
import sys
import time
import zlib

import numpy as np

from authoring import geometry as geo
from authoring import scene as sc
from authoring._kernels import VERTEX_SIZE
from engine.errors import MenagerieError


class ViewerError(MenagerieError, RuntimeError):
    """The viewer cannot do what was asked here (no OpenGL context, no display, ...)."""


# -- pyglet, started once in the right mode ---------------------------------------------------


def want_headless(snapshot: bool = False) -> bool:
    """Whether to start pyglet headless: ``MENAGERIE_HEADLESS`` (1/0) decides if set;
    otherwise yes for a snapshot, and on Linux when there is no ``DISPLAY``."""
    env = os.environ.get("MENAGERIE_HEADLESS", "").strip().lower()
    if env in ("1", "true", "yes", "on"):
        return True
    if env in ("0", "false", "no", "off"):
        return False
    if snapshot:
        return True
    return sys.platform.startswith("linux") and not os.environ.get("DISPLAY")


def load_pyglet(headless: bool):
    """Import pyglet in the requested mode (only the first call in a process chooses).

    Raises ``ViewerError`` when a window is wanted but pyglet already started headless.
    """
    import pyglet

    started = any(m in sys.modules for m in ("pyglet.window", "pyglet.gl", "pyglet.text"))
    if not started:
        pyglet.options["headless"] = bool(headless)
        pyglet.options["shadow_window"] = False
    elif not headless and pyglet.options["headless"]:
        raise ViewerError("pyglet already runs headless in this process, so no window can be "
                          "opened; start a new process to view interactively")
    import pyglet.gl
    import pyglet.window

    return pyglet


def pyglet_is_headless() -> bool:
    """True when pyglet has been started in headless mode in this process."""
    import pyglet

    return bool(pyglet.options["headless"]) and "pyglet.window" in sys.modules


# -- PNG without pillow ----------------------------------------------------------------------


def write_png(path, rgb: np.ndarray) -> None:
    """Write an ``(h, w, 3) uint8`` image (top row first) as an 8-bit RGB PNG."""
    data = png_bytes(rgb)
    with open(path, "wb") as f:
        f.write(data)


def png_bytes(rgb: np.ndarray) -> bytes:
    """An ``(h, w, 3) uint8`` image (top row first) encoded as an 8-bit RGB PNG."""
    img = np.ascontiguousarray(rgb, dtype=np.uint8)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ValueError(f"write_png needs an (h, w, 3) uint8 image, got shape {img.shape}")
    h, w = img.shape[:2]
    raw = np.empty((h, 1 + 3 * w), dtype=np.uint8)
    raw[:, 0] = 0  # filter type 0 (none) on every row
    raw[:, 1:] = img.reshape(h, 3 * w)

    def chunk(tag: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b""))


# -- shaders -----------------------------------------------------------------------------------

_VERTEX_SHADER = """
#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_color;
layout(location = 3) in float a_size;
uniform mat4 u_view_proj;
uniform vec3 u_light;       // unit vector towards the light, world
uniform float u_ambient;    // share of the colour a face turned away still shows
uniform int u_lit;          // 1: Lambert-shade by the normal (faces); 0: flat colour
uniform float u_alpha;      // opacity multiplier (hidden-behind pass)
uniform float u_point_scale;
out vec4 v_color;
void main() {
    gl_Position = u_view_proj * vec4(a_position, 1.0);
    float k = 1.0;
    if (u_lit == 1) {
        k = u_ambient + (1.0 - u_ambient) * max(dot(a_normal, u_light), 0.0);
    }
    v_color = vec4(a_color.rgb * k, a_color.a * u_alpha);
    gl_PointSize = a_size * u_point_scale;
}
"""

_FRAGMENT_SHADER = """
#version 330 core
in vec4 v_color;
uniform int u_round;        // 1: points are round markers with a dark rim
out vec4 f_color;
void main() {
    if (u_round == 1) {
        vec2 d = gl_PointCoord * 2.0 - 1.0;
        float r2 = dot(d, d);
        if (r2 > 1.0) discard;
        f_color = r2 > 0.5 ? vec4(v_color.rgb * 0.3, v_color.a) : v_color;
        return;
    }
    f_color = v_color;
}
"""


def _mat_gl(m: np.ndarray) -> tuple[float, ...]:
    """A row-major numpy 4x4 as the column-major 16 floats GL wants."""
    return tuple(float(x) for x in m.T.ravel())


# -- the renderer --------------------------------------------------------------------------------


class _Picture:
    """Reading out a finished picture, shared by ``Renderer`` and ``Compositor``: the
    subclass gives ``_gl``, ``window``, ``width``, ``height``, ``_raw`` (h, w, 3) uint8 with
    its pointer ``_raw_ptr``, and ``_picture_fbo()`` (the single-sampled framebuffer
    holding the picture)."""

    def read_pixels(self, out: np.ndarray | None = None) -> np.ndarray:
        """The last drawn picture as ``(height, width, 3) uint8``, top row first.

        Pass ``out`` (that shape and dtype) to have it filled instead of a new array.
        """
        gl = self._gl
        self.window.switch_to()
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, self._picture_fbo())
        gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
        gl.glReadPixels(0, 0, self.width, self.height, gl.GL_RGB, gl.GL_UNSIGNED_BYTE,
                        self._raw_ptr)
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, 0)
        if out is None:
            return self._raw[::-1].copy()
        if out.shape != self._raw.shape or out.dtype != np.uint8:
            raise ValueError(f"out must be {self._raw.shape} uint8, got {out.shape} {out.dtype}")
        np.copyto(out, self._raw[::-1])
        return out

    def save_png(self, path) -> None:
        """Write the last drawn picture to ``path`` as PNG."""
        write_png(path, self.read_pixels())

    def present(self) -> None:
        """Copy the picture into the window's own framebuffer (interactive use)."""
        gl = self._gl
        fbo = self._picture_fbo()
        fw, fh = self.window.get_framebuffer_size()
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, fbo)
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, 0)
        gl.glBlitFramebuffer(0, 0, self.width, self.height, 0, 0, fw, fh,
                             gl.GL_COLOR_BUFFER_BIT, gl.GL_LINEAR)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)

    def gl_info(self) -> str:
        """Renderer and version strings of the GL context (for reports)."""
        from pyglet.gl import gl_info

        return f"{gl_info.get_renderer()} / OpenGL {gl_info.get_version_string()}"


class Renderer(_Picture):
    """Draws scenes into a ``width`` x ``height`` picture (see the module docstring).

    Args:
        width, height: picture size in pixels.
        samples: multisampling (antialiasing) per pixel, lowered to what the driver offers.
        headless: start pyglet headless; None decides with ``want_headless``.
        window: draw for this pyglet window (interactive viewer) instead of a hidden one;
            ``present()`` then copies the picture to it.
    """

    def __init__(self, width: int = 1280, height: int = 720, *, samples: int = 4,
                 headless: bool | None = None, window=None) -> None:
        if int(width) < 1 or int(height) < 1:
            raise ValueError(f"picture size must be at least 1 x 1, got {width} x {height}")
        if window is None:
            pyglet = load_pyglet(want_headless(snapshot=True) if headless is None else headless)
            try:
                window = pyglet.window.Window(width=16, height=16, visible=False)
            except Exception as exc:  # pyglet raises several kinds; say what to install
                raise ViewerError(
                    f"cannot create an OpenGL context ({type(exc).__name__}: {exc}); offscreen "
                    "rendering needs EGL and Mesa (Debian: apt-get install libegl1 "
                    "libegl-mesa0 libgl1-mesa-dri)") from None
            self._own_window = True
        else:
            import pyglet
            self._own_window = False
        self._pyglet = pyglet
        self.window = window
        from pyglet import gl
        from pyglet.graphics.shader import Shader, ShaderProgram

        self._gl = gl
        window.switch_to()
        self.program = ShaderProgram(Shader(_VERTEX_SHADER, "vertex"),
                                     Shader(_FRAGMENT_SHADER, "fragment"))
        max_samples = gl.GLint(0)
        gl.glGetIntegerv(gl.GL_MAX_SAMPLES, ctypes.byref(max_samples))
        self.samples = max(0, min(int(samples), int(max_samples.value)))
        rng = (gl.GLfloat * 2)()
        gl.glGetFloatv(gl.GL_ALIASED_LINE_WIDTH_RANGE, rng)
        self._max_line_width = float(rng[1])
        self.geometry = geo.SceneGeometry()
        self.camera: sc.Camera | None = None  # the camera of the last draw
        self._labels: list = []
        self._caption = None
        self._label_batch = None
        self._label_keys: list = []
        self._fbo_size = (0, 0)
        self._make_vertex_buffer()
        self.resize(int(width), int(height))

    # -- GL objects ------------------------------------------------------------------------------

    def _make_vertex_buffer(self) -> None:
        gl = self._gl
        self._vao = gl.GLuint(0)
        gl.glGenVertexArrays(1, ctypes.byref(self._vao))
        self._vbo = gl.GLuint(0)
        gl.glGenBuffers(1, ctypes.byref(self._vbo))
        gl.glBindVertexArray(self._vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._vbo)
        stride = VERTEX_SIZE * 4
        for location, size, offset in ((0, 3, 0), (1, 3, 12), (2, 4, 24), (3, 1, 40)):
            gl.glEnableVertexAttribArray(location)
            gl.glVertexAttribPointer(location, size, gl.GL_FLOAT, gl.GL_FALSE, stride,
                                     ctypes.c_void_p(offset))
        gl.glBindVertexArray(0)
        self._vbo_bytes = 0

    def resize(self, width: int, height: int) -> None:
        """Change the picture size (the interactive window calls this when resized)."""
        gl = self._gl
        self.width, self.height = max(int(width), 1), max(int(height), 1)
        if (self.width, self.height) == self._fbo_size:
            return
        self.window.switch_to()
        if self._fbo_size != (0, 0):
            self._delete_framebuffers()
        w, h = self.width, self.height

        def renderbuffer(fmt, samples):
            rb = gl.GLuint(0)
            gl.glGenRenderbuffers(1, ctypes.byref(rb))
            gl.glBindRenderbuffer(gl.GL_RENDERBUFFER, rb)
            if samples:
                gl.glRenderbufferStorageMultisample(gl.GL_RENDERBUFFER, samples, fmt, w, h)
            else:
                gl.glRenderbufferStorage(gl.GL_RENDERBUFFER, fmt, w, h)
            return rb

        def framebuffer(color, depth):
            fb = gl.GLuint(0)
            gl.glGenFramebuffers(1, ctypes.byref(fb))
            gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, fb)
            gl.glFramebufferRenderbuffer(gl.GL_FRAMEBUFFER, gl.GL_COLOR_ATTACHMENT0,
                                         gl.GL_RENDERBUFFER, color)
            if depth is not None:
                gl.glFramebufferRenderbuffer(gl.GL_FRAMEBUFFER, gl.GL_DEPTH_STENCIL_ATTACHMENT,
                                             gl.GL_RENDERBUFFER, depth)
            status = gl.glCheckFramebufferStatus(gl.GL_FRAMEBUFFER)
            if status != gl.GL_FRAMEBUFFER_COMPLETE:
                raise ViewerError(f"the offscreen framebuffer is incomplete (status {status:#x}) "
                                  f"at {w} x {h} with {self.samples} samples")
            return fb

        self._color_rb = renderbuffer(gl.GL_RGBA8, self.samples)
        self._depth_rb = renderbuffer(gl.GL_DEPTH24_STENCIL8, self.samples)
        self._fbo = framebuffer(self._color_rb, self._depth_rb)
        self._resolve_rb = renderbuffer(gl.GL_RGBA8, 0)
        self._resolve_fbo = framebuffer(self._resolve_rb, None)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)
        self._fbo_size = (w, h)
        self._raw = np.empty((h, w, 3), dtype=np.uint8)  # bottom row first, as GL reads
        self._raw_ptr = ctypes.c_void_p(self._raw.ctypes.data)
        self._resolved = False

    def _delete_framebuffers(self) -> None:
        gl = self._gl
        for fb in (self._fbo, self._resolve_fbo):
            gl.glDeleteFramebuffers(1, ctypes.byref(fb))
        for rb in (self._color_rb, self._depth_rb, self._resolve_rb):
            gl.glDeleteRenderbuffers(1, ctypes.byref(rb))

    def close(self) -> None:
        """Free the GL objects (and the hidden window this renderer made)."""
        if getattr(self, "_closed", False):
            return
        self._closed = True
        gl = self._gl
        self.window.switch_to()
        self._delete_framebuffers()
        gl.glDeleteBuffers(1, ctypes.byref(self._vbo))
        gl.glDeleteVertexArrays(1, ctypes.byref(self._vao))
        self.program.delete()
        self._labels.clear()
        self._caption = None
        self._label_batch = None
        if self._own_window:
            self.window.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- drawing ---------------------------------------------------------------------------------

    def frame(self, scene: sc.Scene) -> sc.Camera:
        """The camera a scene is drawn with: its own, or one framing everything."""
        if scene.camera is not None:
            return scene.camera
        return scene.auto_camera(self.width / self.height)

    def draw(self, scene: sc.Scene, camera: sc.Camera | None = None) -> sc.Camera:
        """Draw ``scene`` (with ``camera``, else the scene's, else an automatic framing)
        into the offscreen picture. Returns the camera used."""
        if not isinstance(scene, sc.Scene):
            raise sc.SceneError(f"draw needs a Scene, got {type(scene).__name__}", kind="scene")
        gl = self._gl
        self.window.switch_to()
        bounds = scene.bounds()
        if camera is None:
            camera = scene.camera if scene.camera is not None else \
                scene.auto_camera(self.width / self.height, bounds)
        self.camera = camera
        ranges = self.geometry.build(scene, bounds)
        count = self.geometry.count

        # Upload: orphan and refill the buffer (the driver double-buffers it for us).
        gl.glBindVertexArray(self._vao)
        gl.glBindBuffer(gl.GL_ARRAY_BUFFER, self._vbo)
        verts = self.geometry.verts
        nbytes = verts.shape[0] * VERTEX_SIZE * 4
        if nbytes != self._vbo_bytes:
            gl.glBufferData(gl.GL_ARRAY_BUFFER, nbytes, None, gl.GL_DYNAMIC_DRAW)
            self._vbo_bytes = nbytes
        if count:
            gl.glBufferSubData(gl.GL_ARRAY_BUFFER, 0, count * VERTEX_SIZE * 4,
                               ctypes.c_void_p(verts.ctypes.data))

        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self._fbo)
        gl.glViewport(0, 0, self.width, self.height)
        bg = scene.background
        gl.glClearColor(float(bg[0]), float(bg[1]), float(bg[2]), 1.0)
        gl.glClearStencil(0)
        gl.glClear(gl.GL_COLOR_BUFFER_BIT | gl.GL_DEPTH_BUFFER_BIT | gl.GL_STENCIL_BUFFER_BIT)
        gl.glEnable(gl.GL_DEPTH_TEST)
        gl.glDepthFunc(gl.GL_LEQUAL)
        gl.glEnable(gl.GL_BLEND)
        gl.glBlendFunc(gl.GL_SRC_ALPHA, gl.GL_ONE_MINUS_SRC_ALPHA)
        gl.glEnable(gl.GL_PROGRAM_POINT_SIZE)
        gl.glDisable(gl.GL_CULL_FACE)
        if self.samples:
            gl.glEnable(gl.GL_MULTISAMPLE)

        p = self.program
        p.use()
        pixel_scale = self.height / 720.0
        p["u_view_proj"] = _mat_gl(camera.view_proj(self.width / self.height))
        p["u_light"] = tuple(float(x) for x in sc.LIGHT_DIR)
        p["u_ambient"] = sc.AMBIENT
        p["u_point_scale"] = pixel_scale
        p["u_alpha"] = 1.0
        p["u_lit"] = 0
        p["u_round"] = 0

        modes = {"triangles": gl.GL_TRIANGLES, "lines": gl.GL_LINES, "points": gl.GL_POINTS}
        hidden_alpha = float(scene.overlay_hidden_alpha)
        overlay_kinds = (geo.LINKS, geo.OVERLAY_LINES, geo.JOINTS, geo.OVERLAY_POINTS)

        def run(r, alpha=1.0):
            if r.mode == "lines":
                gl.glLineWidth(min(max(r.width * pixel_scale, 1.0), self._max_line_width))
            p["u_round"] = 1 if r.mode == "points" else 0
            p["u_alpha"] = alpha
            gl.glDrawArrays(modes[r.mode], r.first, r.count)

        for r in ranges:
            if r.kind == geo.GRID:
                gl.glDepthMask(gl.GL_FALSE)
                run(r)
                gl.glDepthMask(gl.GL_TRUE)
            elif r.kind == geo.SHADOWS:
                # Stencil: a pixel (sample) is darkened by the first flattened face
                # only, however many overlap there.
                gl.glEnable(gl.GL_STENCIL_TEST)
                gl.glStencilFunc(gl.GL_EQUAL, 0, 0xFF)
                gl.glStencilOp(gl.GL_KEEP, gl.GL_KEEP, gl.GL_INCR)
                gl.glDepthMask(gl.GL_FALSE)
                run(r)
                gl.glDepthMask(gl.GL_TRUE)
                gl.glDisable(gl.GL_STENCIL_TEST)
            elif r.kind == geo.FACES:
                p["u_lit"] = 1
                gl.glEnable(gl.GL_POLYGON_OFFSET_FILL)
                gl.glPolygonOffset(1.0, 1.0)
                run(r)
                gl.glDisable(gl.GL_POLYGON_OFFSET_FILL)
                p["u_lit"] = 0
            elif r.kind == geo.EDGES:
                run(r)
        # Skeleton and overlays: visible parts, then the parts behind bodies, faded.
        gl.glDepthMask(gl.GL_FALSE)
        for r in ranges:
            if r.kind in overlay_kinds:
                run(r)
        if hidden_alpha > 0.0:
            gl.glDepthFunc(gl.GL_GREATER)
            for r in ranges:
                if r.kind in overlay_kinds:
                    run(r, hidden_alpha)
            gl.glDepthFunc(gl.GL_LEQUAL)
        gl.glDepthMask(gl.GL_TRUE)
        gl.glBindVertexArray(0)
        p.stop()

        if scene.show_labels:
            self._draw_labels(scene, camera)
        self._resolved = False
        return camera

    def _label_items(self, scene: sc.Scene, camera: sc.Camera):
        """(text, pixel x, pixel y from the bottom, rgba 0-1) of every label to draw. An
        actor's label sits above the highest picture point of its box, centred on the
        box; all anchors are projected in one go."""
        w, h = self.width, self.height
        labelled = [a for a in scene.actors if a.label]
        n = len(labelled)
        anchors = np.empty((9 * n + len(scene.labels), 3))
        box = np.empty((2, 3))
        for k, a in enumerate(labelled):
            a.world_bounds(box)
            anchors[9 * k:9 * k + 8] = box[0] + sc.BOX_CORNER_SIGNS_01 * (box[1] - box[0])
            anchors[9 * k + 8] = 0.5 * (box[0] + box[1])
        for k, lab in enumerate(scene.labels):
            anchors[9 * n + k] = lab.position
        if anchors.shape[0] == 0:
            return []
        px, depth = camera.project(anchors, w, h)
        items = []
        lift = 6.0 * h / 720.0
        for k, a in enumerate(labelled):
            if np.any(depth[9 * k:9 * k + 9] <= camera.near):
                continue
            top = float(px[9 * k:9 * k + 8, 1].min())
            items.append((a.label, float(px[9 * k + 8, 0]), h - top + lift,
                          (*sc.LABEL_COLOR, 1.0)))
        for k, lab in enumerate(scene.labels):
            i = 9 * n + k
            if depth[i] <= camera.near:
                continue
            items.append((lab.text, float(px[i, 0]), h - float(px[i, 1]) + 4.0 * h / 720.0,
                          tuple(lab.rgba)))
        return items

    def _draw_labels(self, scene: sc.Scene, camera: sc.Camera) -> None:
        items = self._label_items(scene, camera)
        if not items and not scene.caption:
            return
        pyglet = self._pyglet
        from pyglet.math import Mat4

        if self._label_batch is None:
            self._label_batch = pyglet.graphics.Batch()
        font_size = 11.0 * self.height / 720.0
        # The caption: top left, a little larger, wrapped to the picture width.
        if self._caption is None:
            self._caption = pyglet.text.Label(
                "", x=0, y=0, anchor_x="left", anchor_y="top", multiline=True, width=100,
                color=tuple(int(round(255 * c)) for c in (*sc.LABEL_COLOR, 1.0)),
                batch=self._label_batch)
        cap = self._caption
        cap.visible = bool(scene.caption)
        if scene.caption:
            margin = round(10 * self.height / 720.0)
            if cap.text != scene.caption:
                cap.text = scene.caption
            if cap.font_size != 1.2 * font_size:
                cap.font_size = 1.2 * font_size
            cap.width = max(self.width - 2 * margin, 1)
            cap.position = (margin, self.height - margin, 0)
        # Reuse Label objects frame to frame; only changed text or places are updated.
        while len(self._labels) < len(items):
            self._labels.append(pyglet.text.Label(
                "", x=0, y=0, anchor_x="center", anchor_y="bottom", font_size=font_size,
                multiline=True, width=max(int(24 * font_size), 1), align="center",
                batch=self._label_batch))
        for i, label in enumerate(self._labels):
            if i < len(items):
                text, x, y, rgba = items[i]
                color = tuple(int(round(255 * c)) for c in rgba)
                if label.text != text:
                    label.text = text
                if label.font_size != font_size:
                    label.font_size = font_size
                    label.width = max(int(24 * font_size), 1)
                if label.color != color:
                    label.color = color
                label.position = (round(x), round(y), 0)
                label.visible = True
            else:
                label.visible = False
        win = self.window
        saved_projection, saved_view = win.projection, win.view
        win.projection = Mat4.orthogonal_projection(0, self.width, 0, self.height, -255, 255)
        win.view = Mat4()
        gl = self._gl
        gl.glDisable(gl.GL_DEPTH_TEST)
        self._label_batch.draw()
        gl.glEnable(gl.GL_DEPTH_TEST)
        win.projection, win.view = saved_projection, saved_view

    # -- reading the picture ---------------------------------------------------------------------

    def _resolve(self) -> None:
        if self._resolved:
            return
        gl = self._gl
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, self._fbo)
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, self._resolve_fbo)
        gl.glBlitFramebuffer(0, 0, self.width, self.height, 0, 0, self.width, self.height,
                             gl.GL_COLOR_BUFFER_BIT, gl.GL_NEAREST)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)
        self._resolved = True

    def label_boxes(self) -> list[tuple[float, float, float, float]]:
        """(x0, y0, x1, y1) picture boxes (y down from the top) of the labels of the last
        frame (the creatures' names), for tests that check overlays do not overlap."""
        out = []
        for lab in self._labels:
            if not lab.visible or not lab.text:
                continue
            x, y = lab.x, self.height - lab.y
            w, h = lab.content_width, lab.content_height
            out.append((x - 0.5 * w, y - h, x + 0.5 * w, y))
        return out

    def caption_height(self) -> int:
        """Pixels from the top of the picture that the last drawn caption takes (its
        margin included), 0 without one: other overlays start below it."""
        cap = self._caption
        if cap is None or not cap.visible or not cap.text:
            return 0
        margin = round(10 * self.height / 720.0)
        return int(margin + math.ceil(cap.content_height))

    def begin_overlay(self) -> None:
        """Make the last drawn picture (antialiased, resolved) the target of 2-D drawing
        on top of it: the authoring tool's panels are drawn here, so ``read_pixels``,
        ``save_png`` and ``present`` show them. End with ``end_overlay``."""
        gl = self._gl
        self.window.switch_to()
        self._resolve()
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self._resolve_fbo)
        gl.glViewport(0, 0, self.width, self.height)

    def end_overlay(self) -> None:
        self._gl.glBindFramebuffer(self._gl.GL_FRAMEBUFFER, 0)

    def _picture_fbo(self):
        self._resolve()
        return self._resolve_fbo


# -- one-shot pictures -------------------------------------------------------------------------------


def render_png(scene, path, width: int = 1280, height: int = 720, *,
               renderer: Renderer | None = None) -> str:
    """Draw ``scene`` (or anything ``scene.scene_for`` accepts) off screen into a PNG at
    ``path``. Uses ``renderer`` if given (its size then wins), else a temporary one.
    Returns the path."""
    scene = sc.scene_for(scene)
    own = renderer is None
    r = Renderer(width, height, headless=want_headless(snapshot=True)) if own else renderer
    try:
        r.draw(scene)
        r.save_png(path)
    finally:
        if own:
            r.close()
    return str(path)


def measure_fps(renderer: Renderer, scene: sc.Scene, frames: int = 60,
                read: bool = True) -> float:
    """Frames per second drawing ``scene`` (and reading the pixels back if ``read``)."""
    renderer.draw(scene)
    renderer.read_pixels()
    out = np.empty((renderer.height, renderer.width, 3), dtype=np.uint8)
    t0 = time.perf_counter()
    for _ in range(frames):
        renderer.draw(scene)
        if read:
            renderer.read_pixels(out)
        else:
            renderer._gl.glFinish()
    return frames / (time.perf_counter() - t0)


# -- composing a window from a picture and 2-D panels ---------------------------------------------------


class Compositor(_Picture):
    """A window-sized picture made of a ``Renderer``'s 3-D picture placed in a rectangle
    and 2-D panels drawn over everything (the authoring tool): the 3-D renderer then only
    shades the pixels the panels leave free, which is most of a software renderer's cost.

    Same reading interface as ``Renderer``: ``read_pixels``, ``save_png``, ``present``,
    ``gl_info``, ``width``/``height``."""

    def __init__(self, width: int, height: int, *, window) -> None:
        from pyglet import gl

        self._gl = gl
        self.window = window
        self._size = (0, 0)
        self.resize(width, height)

    def resize(self, width: int, height: int) -> None:
        gl = self._gl
        w, h = max(int(width), 1), max(int(height), 1)
        if (w, h) == self._size:
            return
        self.window.switch_to()
        if self._size != (0, 0):
            self._delete()
        self.width, self.height = w, h
        self._rb = gl.GLuint(0)
        gl.glGenRenderbuffers(1, ctypes.byref(self._rb))
        gl.glBindRenderbuffer(gl.GL_RENDERBUFFER, self._rb)
        gl.glRenderbufferStorage(gl.GL_RENDERBUFFER, gl.GL_RGBA8, w, h)
        self._fbo = gl.GLuint(0)
        gl.glGenFramebuffers(1, ctypes.byref(self._fbo))
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self._fbo)
        gl.glFramebufferRenderbuffer(gl.GL_FRAMEBUFFER, gl.GL_COLOR_ATTACHMENT0, gl.GL_RENDERBUFFER, self._rb)
        status = gl.glCheckFramebufferStatus(gl.GL_FRAMEBUFFER)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)
        if status != gl.GL_FRAMEBUFFER_COMPLETE:
            raise ViewerError(f"the window's framebuffer is incomplete (status {status:#x}) at {w} x {h}")
        self._size = (w, h)
        self._raw = np.empty((h, w, 3), dtype=np.uint8)
        self._raw_ptr = ctypes.c_void_p(self._raw.ctypes.data)

    def _delete(self) -> None:
        gl = self._gl
        gl.glDeleteFramebuffers(1, ctypes.byref(self._fbo))
        gl.glDeleteRenderbuffers(1, ctypes.byref(self._rb))

    def compose(self, picture: Renderer, x: int, y: int, background) -> None:
        """Clear to ``background`` and copy ``picture`` (drawn already) with its lower left
        corner at pixel (x, y) from the bottom left."""
        gl = self._gl
        self.window.switch_to()
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self._fbo)
        gl.glViewport(0, 0, self.width, self.height)
        gl.glClearColor(float(background[0]), float(background[1]), float(background[2]), 1.0)
        gl.glClear(gl.GL_COLOR_BUFFER_BIT)
        picture._resolve()
        gl.glBindFramebuffer(gl.GL_READ_FRAMEBUFFER, picture._resolve_fbo)
        gl.glBindFramebuffer(gl.GL_DRAW_FRAMEBUFFER, self._fbo)
        gl.glBlitFramebuffer(0, 0, picture.width, picture.height, int(x), int(y), int(x) + picture.width,
                             int(y) + picture.height, gl.GL_COLOR_BUFFER_BIT, gl.GL_NEAREST)
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, 0)

    def begin_overlay(self) -> None:
        gl = self._gl
        self.window.switch_to()
        gl.glBindFramebuffer(gl.GL_FRAMEBUFFER, self._fbo)
        gl.glViewport(0, 0, self.width, self.height)

    def end_overlay(self) -> None:
        self._gl.glBindFramebuffer(self._gl.GL_FRAMEBUFFER, 0)

    def _picture_fbo(self):
        return self._fbo

    def close(self) -> None:
        if getattr(self, "_closed", False):
            return
        self._closed = True
        self.window.switch_to()
        self._delete()
