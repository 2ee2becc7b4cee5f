"""The authoring tool's window, headless: pyglet mouse and key events injected into the
window (through pyglet's event dispatch, as the app loop does), the picture read back.

Dragging a key in the curve editor changes the saved curve; choosing a scale mode in the
Modes tab keeps the active body's motion; Ctrl-Z then Ctrl-S gives the file back byte for
byte; a channel's query chosen in the Query tab lights up the right bodies on a spider and
a humanoid; the keyboard does what the help panel says. Then the command line
(``menagerie author --headless --snapshot``, ``menagerie play``) and real windows under
Xvfb (the demo's title lines never overlap; the tool opens with a GLX context).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import engine
from authoring.document import Document
from authoring.editor import Editor

pytest.importorskip("imgui_bundle")

W, H = 1200, 720


@pytest.fixture(scope="module")
def gl():
    from authoring import render as rd

    rd.load_pyglet(headless=True)
    try:
        with rd.Renderer(32, 32, headless=True):
            pass
    except rd.ViewerError as exc:
        pytest.skip(f"no OpenGL context on this machine: {exc}")
    return rd


@pytest.fixture(scope="module")
def two():
    return [engine.load_creature("creatures/humanoid.yaml"), engine.load_creature("creatures/spider.yaml")]


class Tool:
    """An AuthorWindow with helpers that inject events at widget and curve positions."""

    def __init__(self, editor):
        from authoring.author import AuthorWindow

        self.win = AuthorWindow.create(editor, width=W, height=H, visible=False)
        self.w = self.win.window
        self.frames(3)

    def frames(self, n=1):
        for _ in range(n):
            self.win.frame(1 / 60)

    def send(self, *event):
        self.w.dispatch_event(*event)
        self.w.dispatch_events()

    def up(self, xy):
        return xy[0], self.w.height - xy[1]

    def click(self, xy):
        from pyglet.window import mouse

        x, y = self.up(xy)
        self.send("on_mouse_motion", x, y, 0, 0)
        self.frames()
        self.send("on_mouse_press", x, y, mouse.LEFT, 0)
        self.frames()
        self.send("on_mouse_release", x, y, mouse.LEFT, 0)
        self.frames(2)

    def drag(self, a, b, steps=5):
        from pyglet.window import mouse

        x0, y0 = self.up(a)
        x1, y1 = self.up(b)
        self.send("on_mouse_motion", x0, y0, 0, 0)
        self.frames()
        self.send("on_mouse_press", x0, y0, mouse.LEFT, 0)
        self.frames()
        for s in range(1, steps + 1):
            x = x0 + (x1 - x0) * s / steps
            y = y0 + (y1 - y0) * s / steps
            self.send("on_mouse_drag", x, y, (x1 - x0) / steps, (y1 - y0) / steps, mouse.LEFT, 0)
            self.frames()
        self.send("on_mouse_release", x1, y1, mouse.LEFT, 0)
        self.frames(2)

    def key(self, symbol, modifiers=0):
        self.send("on_key_press", symbol, modifiers)
        self.send("on_key_release", symbol, modifiers)
        self.frames()

    def pixels(self):
        return self.win.renderer.read_pixels()

    def close(self):
        self.win.close()


@pytest.fixture
def wave(tmp_path):
    p = tmp_path / "wave.yaml"
    shutil.copy("animations/wave.yaml", p)
    return p


def test_dragging_a_key_changes_the_saved_curve_and_undo_gives_the_file_back(gl, two, wave):
    from pyglet.window import key

    original = wave.read_bytes()
    ed = Editor(Document.open(wave), two)
    tool = Tool(ed)
    try:
        before = ed.keys("position")[1]
        k = ("position", 1, 1)                       # the y value of the second key
        x, y = tool.win.key_pixels[k]
        tool.drag((x, y), (x + 30, y - 40))
        after = ed.keys("position")[1]
        assert after.value[1] > before.value[1] + 0.05      # dragged up: a larger y
        assert after.t > before.t                           # and later
        assert ed.doc.history() == ["open", "move 1 position key(s) of hand"]   # one step
        tool.key(key.S, key.MOD_CTRL)
        saved = engine.load_animation(wave)
        assert saved.channel("hand").position_keys[1] == after
        assert os.path.exists(str(wave) + ".bak")
        tool.key(key.Z, key.MOD_CTRL)
        tool.key(key.S, key.MOD_CTRL)
        assert wave.read_bytes() == original
        tool.key(key.Z, key.MOD_CTRL | key.MOD_SHIFT)       # redo
        assert ed.keys("position")[1] == after
    finally:
        tool.close()


def test_a_scale_mode_chosen_in_the_modes_tab_keeps_the_active_body_motion(gl, two, wave):
    ed = Editor(Document.open(wave), two)
    tool = Tool(ed)
    try:
        human = two[0]
        assert (ed.creature, ed.body) == (0, human.body("hand_l"))
        _, before = ed.curve("position", "specialized")
        spider_before = ed.curve("position", "generalized")[1]
        tool.click(tool.win.widgets["tab Modes"])
        tool.click(tool.win.widgets["scale"])
        tool.click(tool.win.widgets["scale/creature_size"])
        assert ed.animation.channel("hand").position.scale == "creature_size"
        _, after = ed.curve("position", "specialized")
        assert np.abs(after - before).max() < 1e-9              # the active body's motion is kept
        assert np.abs(ed.curve("position", "generalized")[1] - spider_before).max() > 1e-3  # q_g remapped
        # the humanoid's hand is where it was, in the picture too
        img = tool.pixels()
        assert img.shape == (H, W, 3)
    finally:
        tool.close()


def _colour_at(tool, k, body):
    item = tool.win.editor.preview.items[k]
    x, y = tool.win.project(item.to_world(item.character.world_positions[body]))   # headless: 1 unit = 1 px
    img = tool.pixels()
    patch = img[int(y) - 1:int(y) + 2, int(x) - 1:int(x) + 2].reshape(-1, 3) / 255.0
    return np.median(patch, axis=0)


def _visible_pixels(tool, k, body, n=9):
    """Window pixels (x, y) where ``body`` of creature ``k`` is the front-most body: a grid
    over its projected box, each pixel checked by picking."""
    from authoring import scene as sc

    win = tool.win
    item = win.editor.preview.items[k]
    corners = sc.box_corners(item.character.world_positions[body][None], item.character.world_rotations[body][None],
                             item.creature.body_extent[body][None])[0]
    v = win.view
    px, _ = win.camera.project(item.to_world(corners), v.width, v.height)
    x0, y0, _, _ = win._free_rect()
    scene = win._scene()
    out = []
    for x in np.linspace(px[:, 0].min(), px[:, 0].max(), n):
        for y in np.linspace(px[:, 1].min(), px[:, 1].max(), n):
            if sc.pick(scene, win.camera, x, y, v.width, v.height) == (k, body):
                out.append((int(round(x + x0)), int(round(y + y0))))
    return out


def test_a_query_chosen_in_the_query_tab_lights_up_the_right_bodies(gl, two, wave):

    ed = Editor(Document.open(wave), two)
    tool = Tool(ed)
    human, spider = two

    def cyanness(rgb):  # the highlight is cyan: more green and blue than red
        return float(rgb[1] + rgb[2] - 2 * rgb[0])

    try:
        # Muted, the channel poses nothing: the creatures stand at rest in both pictures and
        # only the colours of what the query selects change.
        ed.set_mute("hand", True)
        tool.frames(2)
        heads = {0: [human.body("head")], 1: spider.bodies_with("head").tolist()}
        spots = {(k, b): _visible_pixels(tool, k, b) for k in heads for b in heads[k]}
        img0 = tool.pixels() / 255.0
        foot = _visible_pixels(tool, 0, human.body("foot_l"))
        tool.click(tool.win.widgets["tab Query"])
        tool.click(tool.win.widgets["type"])
        tool.click(tool.win.widgets["type/head"])
        assert ed.animation.channel("hand").query.type == "head"
        assert ed.query_bodies(0).tolist() == heads[0]
        assert set(ed.query_bodies(1).tolist()) == set(heads[1])
        tool.frames(2)
        img1 = tool.pixels() / 255.0
        for k, creature in enumerate(two):
            posed = ed.selected_bodies(k).tolist()
            assert posed and set(posed) <= set(heads[k])
            for b in posed:
                if (k, b) == (ed.creature, ed.body):
                    continue          # the active body turns yellow instead
                pts = spots[(k, b)]
                assert len(pts) >= 3, creature.body_names[b]       # the head is in view
                gain = np.median([cyanness(img1[y, x]) - cyanness(img0[y, x]) for x, y in pts])
                assert gain > 0.15, (creature.body_names[b], gain)   # lit up
        # a body the query does not select keeps its palette colour (a humanoid's foot)
        assert foot and max(np.abs(img1[y, x] - img0[y, x]).max() for x, y in foot) < 0.05
    finally:
        tool.close()


def test_keyboard_shortcuts_and_picking_in_the_viewport(gl, two, wave):
    from pyglet.window import key

    ed = Editor(Document.open(wave), two)
    tool = Tool(ed)
    try:
        tool.key(key.RIGHT)
        assert abs(ed.time - 1 / 30) < 1e-9
        tool.key(key.UP)
        assert abs(ed.time - 11 / 30) < 1e-9
        tool.key(key.END)
        assert ed.time == ed.animation.length
        tool.key(key.HOME)
        tool.key(key.SPACE)
        assert ed.playing
        tool.frames(10)
        assert ed.time > 0.05
        tool.key(key.SPACE)
        assert not ed.playing
        n = len(ed.keys("rotation"))
        ed.set_time(0.25)
        tool.key(key.I)
        assert len(ed.keys("rotation")) == n + 1
        tool.key(key.F1)
        assert tool.win.show_help
        tool.frames(2)
        tool.key(key.E)
        assert tool.win.gizmo == "rotate"
        tool.key(key.X)
        assert tool.win.axis == 0
        # click the spider's body: it becomes the active creature
        spider = two[1]
        item = ed.preview.items[1]
        tool.click(tool.win.project(item.to_world(item.character.world_positions[0])))
        assert ed.creature == 1
        assert spider.name in ed.message
    finally:
        tool.close()


def test_posing_by_dragging_the_active_body_is_one_step(gl, two, wave):
    ed = Editor(Document.open(wave), two)
    tool = Tool(ed)
    try:
        ed.set_time(0.5)
        tool.frames(2)
        goal = tool.win._goal_world()
        x, y = tool.win.project(goal[0])
        p0, _ = ed.specialize_now()
        tool.drag((x, y), (x, y - 30))       # up the screen
        p1, _ = ed.specialize_now()
        assert p1[2] > p0[2] + 0.01
        assert ed.doc.history()[-1].startswith("pose hand") and len(ed.doc.history()) == 2
    finally:
        tool.close()


def test_a_broken_file_opens_with_its_error_shown(gl, two, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: 1\nname: bad\nlength: -1\nchannels: []\n")
    ed = Editor(Document.open(bad), two[:1])
    tool = Tool(ed)
    try:
        assert "length" in ed.doc.load_error
        img = tool.pixels()
        assert img.std() > 10        # the tool drew, with its message window
    finally:
        tool.close()


# -- the command line -----------------------------------------------------------------------------


def _menagerie(*args, cwd=None, env=None):
    e = dict(os.environ)
    e.pop("DISPLAY", None)
    e.update(env or {})
    return subprocess.run([sys.executable, "-m", "authoring.cli", *args], capture_output=True, text=True,
                          cwd=cwd, env=e, timeout=300)


def test_author_headless_snapshot_and_play(gl, tmp_path, capsys):
    from PIL import Image

    from authoring.cli import main

    out = tmp_path / "tool.png"
    # once as a process, as a user runs it ...
    r = _menagerie("author", "animations/wave.yaml", "humanoid", "spider", "--random", "1", "--headless",
                   "--snapshot", str(out), "--time", "0.5", "--width", "900", "--height", "560")
    assert r.returncode == 0, r.stderr
    assert Image.open(out).size == (900, 560)
    # ... the rest in this process (each new process pays the engine's start-up)
    assert main(["author", "animations/wave.yaml", "--snapshot", str(out)]) == 2
    assert "exists" in capsys.readouterr().err
    assert main(["author", "animations/wave.yaml", "no_such_creature", "--snapshot", str(tmp_path / "x.png")]) == 2
    assert "no_such_creature" in capsys.readouterr().err
    # the validation grid's cell pages print this command: the cell's creature, variant and worst time
    from authoring.author import author_command

    cell = {"animation_path": "animations/wave.yaml", "creature_args": "--random 1 --first-seed 4",
            "variant_id": "", "worst": {"time": 0.75}}
    cmd = author_command(cell)
    assert cmd == "menagerie author animations/wave.yaml --random 1 --first-seed 4 --time 0.750"
    assert main([*cmd.split()[1:], "--creatures", "creatures/humanoid.yaml", "--variant", "hand_r",
                 "--snapshot", str(tmp_path / "cell.png"), "--width", "700", "--height", "420"]) == 0
    assert Image.open(tmp_path / "cell.png").size == (700, 420)
    png, gif = tmp_path / "p.png", tmp_path / "p.gif"
    assert main(["play", "spider", "animations/wave.yaml", "--snapshot", str(png), "--gif", str(gif)]) == 0
    assert Image.open(png).size == (960, 540) and Image.open(gif).n_frames > 10
    assert main(["play", "dog", "animations/wave.yaml", "--snapshot", str(tmp_path / "d.png")]) == 2
    assert "has_graspers is false" in capsys.readouterr().err


def test_engine_never_imports_authoring():
    import pathlib

    for p in pathlib.Path("engine").rglob("*.py"):
        text = p.read_text()
        assert "import authoring" not in text and "from authoring" not in text, p
    import tomllib

    with open("pyproject.toml", "rb") as f:
        assert tomllib.load(f)["project"]["scripts"]["menagerie"] == "authoring.cli:main"


# -- real windows (Xvfb) and the demo's overlays ----------------------------------------------------


def test_demo_overlays_never_overlap_headless(gl):
    from window_checks import check_viewer_overlays

    from authoring import demo
    from authoring.viewer import ViewerWindow

    zoo = demo.Zoo(demo.library_creatures(("humanoid", "spider", "dog")), demo.library_animations())
    zoo.step(1 / 30)
    win = ViewerWindow.create([zoo.zoo], width=900, height=560, visible=False)

    def present(w):
        w.draw()
        w.renderer.draw(w.scene, w.camera)   # the picture with its caption, then the title on top
        w.renderer.begin_overlay()
        w._title.y = w.title_top()
        w._title.draw()
        w.renderer.end_overlay()
        return w.renderer.read_pixels()

    try:
        res = check_viewer_overlays(win, present)
        assert res["caption_rows"][1] < res["title_rows"][0]
    finally:
        win.close()


@pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="xvfb-run is not installed (setup.sh dev installs it)")
def test_real_windows_under_xvfb(tmp_path):
    env = dict(os.environ)
    env.pop("MENAGERIE_HEADLESS", None)
    env.pop("PYOPENGL_PLATFORM", None)
    r = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", sys.executable, "tests/window_checks.py",
                        str(tmp_path)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-3000:]
    report = json.loads(r.stdout.strip().splitlines()[-1])
    assert report["demo"]["caption_rows"][1] < report["demo"]["title_rows"][0]
    for name in ("demo_window.png", "author_window.png"):
        assert (tmp_path / name).stat().st_size > 10_000


def test_closing_with_unsaved_changes_asks_first(gl, two, wave):
    ed = Editor(Document.open(wave), two[:1])
    tool = Tool(ed)
    tool.win.on_close()                          # nothing unsaved: it closes
    assert tool.win.closed
    ed = Editor(Document.open(wave), two[:1])
    tool = Tool(ed)
    try:
        ed.set_key("position", 0.25, (0.0, 0.0, 0.5))
        tool.win.on_close()
        tool.frames(2)
        assert not tool.win.closed and tool.win._ask_close          # asked, still open
        assert "Discard and close" in tool.win.widgets
        tool.click(tool.win.widgets["Discard and close"])
        assert tool.win.closed
    finally:
        tool.close()
    assert wave.read_text() == open("animations/wave.yaml").read()   # nothing was written


def test_tangents_of_a_selected_key_from_the_panel(gl, two, wave):
    ed = Editor(Document.open(wave), two[:1])
    tool = Tool(ed)
    try:
        x, y = tool.win.key_pixels[("position", 2, 0)]
        tool.click((x, y))
        assert ed.selected_keys == {("position", 2)}
        tool.click(tool.win.widgets["Flat"])
        k = ed.keys("position")[2]
        assert k.tin == (0.0, 0.0, 0.0) and k.tout == (0.0, 0.0, 0.0)
        tool.click(tool.win.widgets["Auto tangents"])
        assert ed.keys("position")[2].tin is None
    finally:
        tool.close()
