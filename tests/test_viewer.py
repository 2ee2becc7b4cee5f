"""The viewer: scene model, vertex kernels, offscreen pictures and the window's controls.

Opens with the invalid inputs and the error each must raise, then checks the geometry
kernels against plain numpy, the camera and the zoo layout without OpenGL, and finally
real pictures drawn headless (one GL context for the whole module) compared with
tolerances: the colours the palette promises appear where the boxes project, the grid is
drawn, an empty scene is only background and grid, overlays land where they should.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from authoring import geometry as geo
from authoring import scene as sc
from authoring._kernels import VERTEX_SIZE, fill_boxes, fill_skeleton
from engine.errors import CreatureError, DataError
from engine.ik.testing import MINI_TEXT as MINI  # the shared seven-body test biped
from engine.model import creature_from_text

# A rotated two-body creature: the arm is turned 90 degrees about Z.
TWIST = """\
format: 1
name: twist
bodies:
  - name: body
    caps: [spine]
    pos: [0, 0, 0.5]
    extents: [0.3, 0.1, 0.1]
  - name: arm
    parent: body
    caps: [limb, grasper]
    pos: [0.3, 0.3, 0.5]
    rot: [0.7071067811865476, 0, 0, 0.7071067811865476]
    joint: [0.3, 0.1, 0.5]
    extents: [0.2, 0.05, 0.04]
"""

W, H = 480, 360


@pytest.fixture(scope="module")
def mini():
    return creature_from_text(MINI)


@pytest.fixture(scope="module")
def twist():
    return creature_from_text(TWIST)


# -- invalid inputs -------------------------------------------------------------------------------


def _bad_inputs(c):
    n = c.nbody
    rest_p, rest_r = c.body_rest_pos, c.body_rest_rot
    nan_p = np.array(rest_p)
    nan_p[c.body("foot_l"), 2] = np.nan
    zero_r = np.array(rest_r)
    zero_r[c.body("head")] = 0.0
    return [
        # (what, callable, error type, words the message must contain)
        ("positions of the wrong shape", lambda: sc.Actor(c, np.zeros((n - 1, 3))),
         sc.SceneError, ["world_positions", f"({n}, 3)"]),
        ("rotations of the wrong shape", lambda: sc.Actor(c, rest_p, np.zeros((n, 3))),
         sc.SceneError, ["world_rotations", f"({n}, 4)"]),
        ("a NaN position names the body", lambda: sc.Actor(c, nan_p, rest_r),
         sc.SceneError, ["foot_l", "not finite", "world_positions"]),
        ("a zero rotation names the body", lambda: sc.Actor(c, rest_p, zero_r),
         sc.SceneError, ["head", "unit length"]),
        ("a negative scale", lambda: sc.Actor(c, scale=-1.0), sc.SceneError, ["scale"]),
        ("a NaN offset", lambda: sc.Actor(c, offset=(0, np.nan, 0)), sc.SceneError,
         ["offset", "not finite"]),
        ("body colours of the wrong count", lambda: sc.Actor(c, colors=np.ones((2, 3))),
         sc.SceneError, ["colors"]),
        ("a colour above 1", lambda: sc.Points([[0, 0, 0]], color=(2, 0, 0)),
         sc.SceneError, ["colour", "[0, 1]"]),
        ("points in 2-D", lambda: sc.Points(np.zeros((4, 2))), sc.SceneError, ["(n, 3)"]),
        ("a zero point size", lambda: sc.Points([[0, 0, 0]], size=0.0), sc.SceneError, ["size"]),
        ("a text line width", lambda: sc.Segments([[0, 0, 0]], [[1, 0, 0]], width="2"),
         sc.SceneError, ["width", "pixels"]),
        ("segments with different counts",
         lambda: sc.Segments(np.zeros((3, 3)), np.zeros((2, 3))), sc.SceneError, ["differ"]),
        ("a NaN in a polyline", lambda: sc.Polyline([[0, 0, 0], [np.inf, 0, 0]]),
         sc.SceneError, ["row 1", "not finite"]),
        ("per-point colours of the wrong count",
         lambda: sc.Points(np.zeros((3, 3)), color=np.ones((2, 3))), sc.SceneError, ["(3, 3|4)"]),
        ("the zoo given a string", lambda: sc.layout_zoo(["spider.yaml"]), sc.SceneError,
         ["Creatures", "str"]),
        ("the zoo with zero columns", lambda: sc.layout_zoo([c, c], columns=0), sc.SceneError,
         ["columns"]),
        ("a scene given a number", lambda: sc.scene_for(3), sc.SceneError, ["int"]),
        ("adding a string to a scene", lambda: sc.Scene().add("x"), sc.SceneError, ["str"]),
    ]


def test_invalid_inputs_raise_located_errors(mini):
    for what, call, err, words in _bad_inputs(mini):
        with pytest.raises(err) as info:
            call()
        assert isinstance(info.value, DataError), what
        for w in words:
            assert w in str(info.value), f"{what}: {w!r} not in {info.value}"


def test_refused_pose_leaves_the_actor_at_rest(mini):
    a = sc.Actor(mini)
    bad = np.array(mini.body_rest_pos) + 1.0
    bad[2, 0] = np.nan
    with pytest.raises(sc.SceneError):
        a.set_pose(bad, mini.body_rest_rot)
    np.testing.assert_array_equal(a.world_positions, mini.body_rest_pos)


def test_snapshot_of_a_bad_creature_file_names_the_file(tmp_path):
    from authoring.viewer import snapshot_creatures, view_file

    bad = tmp_path / "bad.yaml"
    bad.write_text("format: 1\nname: bad\nbodies:\n  - name: a\n    extents: [1, 1]\n")
    with pytest.raises(CreatureError, match="bad.yaml"):
        view_file(bad, snapshot=tmp_path / "x.png")
    with pytest.raises(CreatureError, match="bad.yaml"):
        snapshot_creatures([bad], tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


# -- kernels against plain numpy -------------------------------------------------------------------


def _filled(c, pos=None, rot=None, offset=(0.0, 0.0, 0.0), scale=1.0):
    n = c.nbody
    pos = np.array(c.body_rest_pos if pos is None else pos)
    rot = np.array(c.body_rest_rot if rot is None else rot)
    verts = np.zeros((n * 60, VERTEX_SIZE), dtype=np.float32)
    colors = sc.body_colors(c)
    fill_boxes(pos, rot, np.ascontiguousarray(c.body_extent), colors, np.array(offset, float),
               scale, 0.5, verts, 0, n * 36)
    return verts, pos, rot, colors


def test_box_faces_and_edges_match_numpy_corners(twist):
    rng = np.random.default_rng(3)
    n = twist.nbody
    pos = rng.normal(size=(n, 3))
    rot = rng.normal(size=(n, 4))
    rot /= np.linalg.norm(rot, axis=1, keepdims=True)
    offset, scale = (1.0, -2.0, 0.5), 1.7
    verts, pos, rot, colors = _filled(twist, pos, rot, offset, scale)
    corners = np.asarray(offset) + scale * sc.box_corners(pos, rot, twist.body_extent)
    actor = sc.Actor(twist, pos, rot, offset=offset, scale=scale)
    flat = corners.reshape(-1, 3)
    np.testing.assert_allclose(actor.world_bounds(), [flat.min(axis=0), flat.max(axis=0)],
                               atol=1e-12)
    for i in range(n):
        tri = verts[i * 36:(i + 1) * 36].astype(float)
        edge = verts[n * 36 + i * 24:n * 36 + (i + 1) * 24].astype(float)
        # Every face and edge vertex is a corner, and every corner is used.
        for block in (tri, edge):
            d = np.linalg.norm(block[:, None, :3] - corners[i][None], axis=2)
            assert d.min(axis=1).max() < 1e-5
            assert set(d.argmin(axis=1)) == set(range(8))
        # Normals are unit, point away from the centre, and are normal to their triangle.
        centre = np.asarray(offset) + scale * pos[i]
        for t in range(12):
            p = tri[3 * t:3 * t + 3, :3]
            normal = tri[3 * t, 3:6]
            assert abs(np.linalg.norm(normal) - 1.0) < 1e-5
            assert np.dot(normal, p.mean(axis=0) - centre) > 0
            assert abs(np.dot(normal, p[1] - p[0])) < 1e-4 and abs(np.dot(normal, p[2] - p[0])) < 1e-4
        np.testing.assert_allclose(tri[:, 6:9], np.tile(colors[i], (36, 1)), atol=1e-6)
        np.testing.assert_allclose(edge[:, 6:9], np.tile(0.5 * colors[i], (24, 1)), atol=1e-6)
        # Edges have the lengths of the box sides.
        lengths = np.sort(np.linalg.norm(edge[1::2, :3] - edge[0::2, :3], axis=1))
        want = np.sort(np.repeat(2 * scale * twist.body_extent[i], 4))
        np.testing.assert_allclose(lengths, want, rtol=1e-5)


def test_skeleton_joints_at_rest_are_the_creature_joints(mini):
    n = mini.nbody
    verts = np.zeros((5 * n, VERTEX_SIZE), dtype=np.float32)
    fill_skeleton(np.array(mini.body_rest_pos), np.array(mini.body_rest_rot),
                  np.array(mini.body_joint_offset), np.array(mini.body_parent),
                  np.zeros(3), 1.0, np.ones(4), np.ones(4), np.ones(4), 6.0, verts, 0, 4 * (n - 1))
    markers = verts[4 * (n - 1):4 * (n - 1) + n, :3]
    np.testing.assert_allclose(markers[1:], mini.body_joint[1:], atol=1e-6)
    np.testing.assert_allclose(markers[0], mini.body_rest_pos[0], atol=1e-6)
    # Links: parent centre -> joint -> own centre, for each non-root body in order.
    links = verts[:4 * (n - 1), :3].reshape(n - 1, 4, 3)
    for k, i in enumerate(range(1, n)):
        np.testing.assert_allclose(links[k, 0], mini.body_rest_pos[mini.body_parent[i]], atol=1e-6)
        np.testing.assert_allclose(links[k, 1], mini.body_joint[i], atol=1e-6)
        np.testing.assert_allclose(links[k, 3], mini.body_rest_pos[i], atol=1e-6)


def test_geometry_reuses_its_buffer_and_lists_every_part(mini):
    g = geo.SceneGeometry()
    scene = sc.Scene(actors=[sc.Actor(mini)],
                     points=[sc.Points(np.zeros((3, 3)))],
                     segments=[sc.Segments(np.zeros((2, 3)), np.ones((2, 3)), width=3.0)],
                     polylines=[sc.Polyline(np.eye(3), closed=True)])
    ranges = g.build(scene)
    kinds = {r.kind: r for r in ranges}
    n = mini.nbody
    assert kinds[geo.FACES].count == 36 * n and kinds[geo.EDGES].count == 24 * n
    assert kinds[geo.LINKS].count == 4 * (n - 1) and kinds[geo.JOINTS].count == n
    assert kinds[geo.OVERLAY_POINTS].count == 3
    assert sorted(r.count for r in ranges if r.kind == geo.OVERLAY_LINES) == [4, 6]
    assert g.count == max(r.first + r.count for r in ranges)
    # Ranges do not overlap.
    spans = sorted((r.first, r.first + r.count) for r in ranges)
    assert all(a[1] <= b[0] for a, b in zip(spans, spans[1:], strict=False))
    buf = g.verts
    scene.actors[0].set_pose(np.array(mini.body_rest_pos) + 0.1, mini.body_rest_rot)
    g.build(scene)
    assert g.verts is buf  # same scene size: nothing reallocated
    scene.actors[0].show_joints = False
    assert geo.JOINTS not in {r.kind for r in g.build(scene)}


# -- camera and layout, without OpenGL --------------------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(lo=st.tuples(*[st.floats(-50, 50)] * 3),
       size=st.tuples(*[st.floats(0.01, 30)] * 3),
       aspect=st.floats(0.5, 3.0))
def test_frame_camera_keeps_every_corner_in_the_picture(lo, size, aspect):
    b = np.array([lo, np.add(lo, size)])
    cam = sc.frame_camera(b, aspect)
    w, h = 1000 * aspect, 1000
    corners = b[0] + sc.BOX_CORNER_SIGNS_01 * (b[1] - b[0])
    px, depth = cam.project(corners, w, h)
    assert np.all(depth > cam.near) and np.all(depth < cam.far)
    assert px[:, 0].min() >= 0.07 * w - 1 and px[:, 0].max() <= 0.93 * w + 1
    assert px[:, 1].min() >= 0.07 * h - 1 and px[:, 1].max() <= 0.93 * h + 1
    # Tight: the picture-space box touches the margin on one axis, and is centred.
    touch = max((px[:, 0].max() - px[:, 0].min()) / (0.84 * w),
                (px[:, 1].max() - px[:, 1].min()) / (0.84 * h))
    assert touch > 0.9
    assert abs(px[:, 0].max() + px[:, 0].min() - w) < 0.05 * w
    assert abs(px[:, 1].max() + px[:, 1].min() - h) < 0.05 * h


def test_camera_looks_from_front_left_above_and_moves():
    cam = sc.frame_camera(np.array([[-0.5, -0.5, 0.0], [0.5, 0.5, 1.8]]), 16 / 9)
    eye = cam.eye() - cam.target
    assert eye[0] > 0 and eye[1] > 0 and eye[2] > 0  # front (+X), left (+Y), above
    px, _ = cam.project(cam.target, 1600, 900)
    np.testing.assert_allclose(px[0], [800, 450], atol=1e-6)
    # +X points towards the lower left on the picture, +Y to the right, +Z up.
    o, x, y, z = cam.project(np.array([cam.target, cam.target + [1, 0, 0], cam.target + [0, 1, 0],
                                       cam.target + [0, 0, 1]]), 1600, 900)[0]
    assert x[0] < o[0] and x[1] > o[1]
    assert y[0] > o[0]
    assert z[1] < o[1]
    # Pan there and back; zoom in and out; orbit keeps the distance.
    t0, d0 = cam.target.copy(), cam.distance
    cam.pan(30, -12, 900)
    cam.pan(-30, 12, 900)
    np.testing.assert_allclose(cam.target, t0, atol=1e-12)
    cam.zoom(0.5)
    cam.zoom(2.0)
    assert math.isclose(cam.distance, d0)
    cam.orbit(0.3, 5.0)
    assert cam.elevation <= math.radians(89.0) and math.isclose(cam.distance, d0)


def test_ray_inverts_project_and_pick_finds_the_body(mini, twist):
    cam = sc.frame_camera(np.array([[-0.5, -0.5, 0.0], [0.5, 0.5, 1.8]]), 4 / 3)
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1, 2, size=(20, 3))
    px, depth = cam.project(pts, 400, 300)
    _, _, back = cam.basis()
    for p, (x, y), depth_p in zip(pts, px, depth, strict=True):
        origin, direction = cam.ray(x, y, 400, 300)
        # The point lies on the ray, in front of the eye at its camera depth.
        along = np.dot(p - origin, direction)
        np.testing.assert_allclose(origin + along * direction, p, atol=1e-9)
        assert math.isclose(along * np.dot(direction, -back), depth_p, rel_tol=1e-9)
    # Picking: the pixel of an unoccluded body's centre picks that body, in either actor
    # (the second one moved and scaled); empty sky picks nothing.
    scene = sc.Scene(actors=[sc.Actor(mini), sc.Actor(twist, offset=(0, 1.5, 0.2), scale=2.0)])
    cam = scene.auto_camera(4 / 3)
    for k, (a, name) in enumerate([(scene.actors[0], "head"), (scene.actors[0], "foot_l"),
                                   (scene.actors[1], "arm")]):
        i = a.creature.body(name)
        (x, y), = cam.project(a.offset + a.scale * a.world_positions[i], 400, 300)[0]
        assert sc.pick(scene, cam, x, y, 400, 300) == (0 if k < 2 else 1, i)
    assert sc.pick(scene, cam, 2, 2, 400, 300) is None
    text = sc.describe_body(mini, mini.body("head"))
    assert text.startswith("mini: head (mouth, head; child of chest; box 0.2 x 0.2 x 0.24 m")


def test_zoo_normalizes_sizes_and_keeps_creatures_apart(mini, twist):
    big = creature_from_text(MINI.replace("name: mini", "name: big").replace(
        "description: tiny test biped", "description: big"))
    zoo = sc.layout_zoo([mini, twist, big, twist, mini], normalize_size=True, size=1.0)
    assert len(zoo.actors) == 5
    boxes = [a.world_bounds() for a in zoo.actors]
    for b in boxes:
        assert math.isclose(float(np.max(b[1] - b[0])), 1.0, rel_tol=1e-9)
    for a, b in zip(zoo.actors, boxes, strict=True):  # feet as high as before, scaled
        assert math.isclose(b[0, 2], a.scale * a.creature.bounds[0, 2], abs_tol=1e-12)
    for i in range(5):
        for j in range(i + 1, 5):
            bi, bj = boxes[i], boxes[j]
            overlap = np.all(bi[0, :2] < bj[1, :2]) and np.all(bj[0, :2] < bi[1, :2])
            assert not overlap, (i, j)
    assert zoo.actors[0].label.startswith("mini\n") and "m" in zoo.actors[0].label
    # True sizes: scale 1, plain names.
    plain = sc.layout_zoo([mini, twist], normalize_size=False)
    assert [a.scale for a in plain.actors] == [1.0, 1.0]
    assert [a.label for a in plain.actors] == ["mini", "twist"]
    # First creature at the back left of the picture.
    cam = zoo.auto_camera(16 / 9)
    px, _ = cam.project(np.array([b.mean(axis=0) for b in boxes]), 1600, 900)
    assert px[0, 1] < px[-1, 1]
    assert sc.layout_zoo([]).actors == []


def test_palette_priority():
    assert sc.cap_color(sc.CAP_BIT["head"] | sc.CAP_BIT["mouth"]) == sc.CAP_COLORS["head"]
    assert sc.cap_color(sc.CAP_BIT["foot"] | sc.CAP_BIT["limb"]) == sc.CAP_COLORS["foot"]
    assert sc.cap_color(sc.CAP_BIT["tail"] | sc.CAP_BIT["spine"]) == sc.CAP_COLORS["tail"]
    assert sc.cap_color(0) == sc.NO_CAP_COLOR
    # Distinct colours, all at least 0.15 apart.
    cols = np.array(list(sc.CAP_COLORS.values()))
    d = np.linalg.norm(cols[:, None] - cols[None], axis=2) + np.eye(len(cols))
    assert d.min() > 0.15


# -- pictures (one headless GL context for the module) -----------------------------------------------


@pytest.fixture(scope="module")
def renderer():
    from authoring.render import Renderer, ViewerError

    try:
        r = Renderer(W, H, headless=True)
    except ViewerError as exc:
        pytest.skip(f"no OpenGL context on this machine: {exc}")
    yield r
    r.close()


def _unit(rgb):
    return np.asarray(rgb, float) / 255.0


def _patch(img, xy, r=2):
    x, y = int(round(xy[0])), int(round(xy[1]))
    return np.median(img[y - r:y + r + 1, x - r:x + r + 1].reshape(-1, 3), axis=0) / 255.0


def _visible_face_colors(color, rot):
    """The three lit colours of a box's faces seen by the default camera (+X, +Y, +Z)."""
    m = sc.quat_to_matrix(rot)
    out = []
    for a in range(3):
        for s in (-1, 1):
            out.append(sc.shade(color, s * m[:, a]))
    return out


def _matches_a_face(pixel, color, rot, tol=0.06):
    return min(np.abs(pixel - c).max() for c in _visible_face_colors(color, rot)) < tol


def test_snapshot_shows_the_palette_where_bodies_project(renderer, mini, tmp_path):
    from PIL import Image

    from authoring.render import render_png

    scene = sc.Scene(actors=[sc.Actor(mini, show_joints=False, show_links=False)])
    path = render_png(scene, tmp_path / "mini.png", renderer=renderer)
    img = np.asarray(Image.open(path).convert("RGB"))
    assert img.shape == (H, W, 3)
    cam = renderer.camera
    for name in ("head", "chest", "thigh_l", "foot_l", "foot_r"):
        i = mini.body(name)
        px, _ = cam.project(mini.body_rest_pos[i], W, H)
        pixel = _patch(img, px[0])
        color = sc.cap_color(int(mini.body_caps[i]))
        assert _matches_a_face(pixel, color, mini.body_rest_rot[i]), (name, pixel, color)
    # The head is purple (head beats mouth), the feet brown.
    assert sc.cap_color(int(mini.body_caps[mini.body("head")])) == sc.CAP_COLORS["head"]
    # Box edges: darker lines of the face colour along the head's silhouette.
    head = mini.body("head")
    corners = sc.box_corners(mini.body_rest_pos[head:head + 1], mini.body_rest_rot[head:head + 1],
                             mini.body_extent[head:head + 1])[0]
    top = corners[corners[:, 2] > mini.body_rest_pos[head, 2]]
    pts, _ = cam.project(top, W, H)
    xs = np.clip(np.round(pts[:, 0]).astype(int), 0, W - 1)
    ys = np.clip(np.round(pts[:, 1]).astype(int), 0, H - 1)
    dark = [img[max(y - 2, 0):y + 3, max(x - 2, 0):x + 3].reshape(-1, 3).sum(axis=1).min()
            for x, y in zip(xs, ys, strict=True)]
    head_lit = 255 * sc.shade(sc.CAP_COLORS["head"], (0, 0, 1)).sum()
    assert max(dark) < 0.7 * head_lit
    # The grid is drawn below the creature: grid-coloured pixels in the bottom band.
    band = img[int(0.85 * H):].reshape(-1, 3) / 255.0
    assert np.sum(_on_grid_colours(band)[1]) > 200


def _on_grid_colours(pixels, tol=0.035):
    """(is background, is a blend of background and a grid colour but not background)."""
    bg = np.array(sc.BACKGROUND_COLOR)
    is_bg = np.abs(pixels - bg).max(axis=1) < 0.012
    on = np.zeros(len(pixels), bool)
    for g in (sc.GRID_COLOR, sc.GRID_MAJOR_COLOR, sc.GRID_X_AXIS_COLOR, sc.GRID_Y_AXIS_COLOR):
        d = np.asarray(g) - bg
        t = np.clip((pixels - bg) @ d / (d @ d), 0, 1)
        on |= np.linalg.norm(pixels - (bg + t[:, None] * d), axis=1) < tol
    return is_bg, on & ~is_bg


def test_empty_scene_draws_only_background_and_grid(renderer):
    empty = sc.Scene()
    renderer.draw(empty)
    img = renderer.read_pixels().reshape(-1, 3) / 255.0
    is_bg, on_grid = _on_grid_colours(img)
    assert on_grid.sum() > 0.01 * len(img)  # the grid is there
    # Everything else is background; crossings of two lines may blend a little more.
    assert (is_bg | on_grid).mean() > 0.998
    empty.show_grid = False
    renderer.draw(empty)
    img = renderer.read_pixels().astype(int)
    bg = np.round(255 * np.array(sc.BACKGROUND_COLOR)).astype(int)
    assert np.abs(img - bg).max() <= 2


def test_two_actors_both_drawn_and_renderer_reused(renderer, mini, twist):
    green, magenta = (0.1, 0.8, 0.1), (0.85, 0.1, 0.85)
    a = sc.Actor(mini, colors=np.tile(green, (mini.nbody, 1)), offset=(0, -1.0, 0))
    b = sc.Actor(twist, colors=np.tile(magenta, (twist.nbody, 1)), offset=(0, 1.0, 0))
    scene = sc.Scene(actors=[a, b])
    out = np.zeros((H, W, 3), np.uint8)
    renderer.draw(scene)
    renderer.read_pixels(out)

    def count(img, color):
        px = img.reshape(-1, 3) / 255.0
        unit = np.asarray(color) / np.linalg.norm(color)
        norm = np.linalg.norm(px, axis=1) + 1e-9
        return int(np.sum((px @ unit) / norm > 0.995))

    n_green, n_magenta = count(out, green), count(out, magenta)
    assert n_green > 500 and n_magenta > 300
    # Mini stands at y = -1 (picture left), twist at y = +1 (picture right).
    cols = np.nonzero((out.reshape(-1, 3) / 255.0 @ (np.asarray(green) / np.linalg.norm(green)))
                      / (np.linalg.norm(out.reshape(-1, 3) / 255.0, axis=1) + 1e-9) > 0.995)[0] % W
    assert np.median(cols) < W / 2
    # Same renderer, new pose: the picture changes, the output array is reused.
    buf = renderer.geometry.verts
    b.set_pose(np.array(twist.body_rest_pos) + [0, 0, 0.5], twist.body_rest_rot)
    renderer.draw(scene, camera=renderer.camera)
    before = out.copy()
    assert renderer.read_pixels(out) is out
    assert np.abs(out.astype(int) - before).sum() > 0
    assert renderer.geometry.verts is buf


def test_overlays_points_segments_labels(renderer, mini):
    actor = sc.Actor(mini, show_joints=False, show_links=False)
    chest = mini.body_rest_pos[mini.body("chest")]
    goal = chest + [0.0, 0.0, 0.9]  # above the head, in the open
    hidden = chest  # inside the chest box: drawn faded through it
    red = (0.95, 0.05, 0.05)
    scene = sc.Scene(actors=[actor],
                     points=[sc.Points([goal, hidden], color=red, size=14)],
                     segments=[sc.Segments([goal + [0, -0.6, 0]], [goal + [0, -0.2, 0]],
                                           color=(0.0, 0.2, 0.9), width=4)])
    renderer.draw(scene)
    img = renderer.read_pixels()
    cam = renderer.camera
    (g, h, s), _ = cam.project(np.array([goal, hidden, goal + [0, -0.4, 0]]), W, H)
    np.testing.assert_allclose(_patch(img, g, 1), red, atol=0.05)
    # Hidden behind the chest's front face: a blend of red and the chest colour.
    px = _patch(img, h, 1)
    chest_faces = _visible_face_colors(sc.CAP_COLORS["spine"], mini.body_rest_rot[0])
    assert min(np.abs(px - c).max() for c in chest_faces) > 0.1
    assert px[0] > max(c[0] for c in chest_faces) + 0.1
    np.testing.assert_allclose(_patch(img, s, 0), (0.0, 0.2, 0.9), atol=0.08)
    # With the x-ray off, the hidden point is gone.
    scene.overlay_hidden_alpha = 0.0
    renderer.draw(scene, camera=cam)
    px = _patch(renderer.read_pixels(), h, 1)
    assert min(np.abs(px - c).max() for c in chest_faces) < 0.05
    # A label draws dark text above its anchor.
    scene.labels.append(sc.Label(goal + [0, 0, 0.1], "goal"))
    renderer.draw(scene, camera=cam)
    img = renderer.read_pixels()
    (lx, ly), = cam.project(goal + [0, 0, 0.1], W, H)[0]
    region = img[max(int(ly) - 30, 0):int(ly), int(lx) - 25:int(lx) + 25].reshape(-1, 3)
    assert region.sum(axis=1).min() < 250
    # A caption draws dark text in the top left corner, which is background without it.
    corner = (slice(0, H // 10), slice(0, W // 4))
    assert img[corner].reshape(-1, 3).sum(axis=1).min() > 600
    scene.caption = "walk, 1.2 m/s"
    renderer.draw(scene, camera=cam)
    assert renderer.read_pixels()[corner].reshape(-1, 3).sum(axis=1).min() < 250


def test_window_controls_headless(renderer, mini, twist, tmp_path, monkeypatch):
    import pyglet
    from pyglet.window import key, mouse

    from authoring.viewer import ViewerWindow, creature_pages

    monkeypatch.chdir(tmp_path)
    pages = creature_pages([mini, twist])
    assert len(pages) == 3 and len(pages[0].actors) == 2
    steps = []
    win = ViewerWindow.create(pages, width=320, height=200, visible=False,
                              update=steps.append)
    try:
        w = win.window

        def send(*event):  # through pyglet's event queue, as the app loop does
            w.dispatch_event(*event)
            w.dispatch_events()

        az = win.camera.azimuth
        send("on_mouse_drag", 10, 10, 40, 0, mouse.LEFT, 0)
        assert win.camera.azimuth != az
        d = win.camera.distance
        send("on_mouse_scroll", 10, 10, 0, 2)
        assert win.camera.distance < d
        t = win.camera.target.copy()
        send("on_mouse_drag", 10, 10, 5, 5, mouse.MIDDLE, 0)
        assert np.linalg.norm(win.camera.target - t) > 0
        send("on_key_press", key.RIGHT, 0)
        assert win.page == 1 and win.scene.actors[0].creature.name == "mini"
        send("on_key_press", key.LEFT, 0)
        send("on_key_press", key.LEFT, 0)
        assert win.page == 2
        send("on_key_press", key.G, 0)
        assert not win.scene.show_grid
        # A click on the creature's middle names a body; a click on the sky clears it.
        fw, fh = w.get_framebuffer_size()
        (x, y), = win.camera.project(win.scene.actors[0].world_bounds().mean(axis=0), fw, fh)[0]
        wx, wy = x * w.width / fw, (fh - y) * w.height / fh
        send("on_mouse_press", wx, wy, mouse.LEFT, 0)
        send("on_mouse_release", wx, wy, mouse.LEFT, 0)
        assert win.selected is not None and win.selected[0] == 0
        win.draw()
        assert "twist:" in win._title.text
        send("on_mouse_press", 1, w.height - 1, mouse.LEFT, 0)
        send("on_mouse_release", 1, w.height - 1, mouse.LEFT, 0)
        assert win.selected is None
        win._tick(0.5)
        send("on_key_press", key.SPACE, 0)
        win._tick(0.5)  # paused: not passed on
        send("on_key_press", key.PERIOD, 0)
        assert steps == [0.5, 1 / 60]
        win.draw()
        saved = win.save()
        from PIL import Image

        assert Image.open(saved).size == win.renderer.read_pixels().shape[1::-1]
    finally:
        win.close()
    assert win.closed
    assert pyglet.options["headless"]


def test_view_without_display_writes_a_snapshot(renderer, mini, tmp_path, monkeypatch, capsys):
    from PIL import Image

    from authoring.viewer import view, view_file

    monkeypatch.setenv("MENAGERIE_HEADLESS", "1")
    out = view(mini, width=200, height=120, fallback_path=str(tmp_path / "v.png"))
    assert Image.open(out).size == (200, 120)
    assert "no display" in capsys.readouterr().out
    again = view(mini, width=200, height=120, fallback_path=str(tmp_path / "v.png"))
    assert again == str(tmp_path / "v_2.png")  # the first picture is not overwritten
    yaml_path = tmp_path / "mini.yaml"
    yaml_path.write_text(MINI)
    snap = view_file(yaml_path, snapshot=tmp_path / "s.png", width=160, height=100)
    img = np.asarray(Image.open(snap).convert("RGB"))
    assert img.shape == (100, 160, 3)
    bg = np.round(255 * np.array(sc.BACKGROUND_COLOR))
    assert np.mean(np.abs(img - bg).max(axis=2) > 40) > 0.02  # a creature was drawn


def test_write_png_round_trip(tmp_path):
    from PIL import Image

    from authoring.render import write_png

    img = np.random.default_rng(0).integers(0, 256, size=(7, 5, 3), dtype=np.uint8)
    write_png(tmp_path / "r.png", img)
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "r.png")), img)


FLOATING = """\
format: 1
name: floating
bodies:
  - name: a
    caps: [spine]
    pos: [0, 0, 1.0]
    extents: [0.3, 0.3, 0.1]
  - name: b
    parent: a
    caps: [limb]
    pos: [0.2, 0, 1.12]
    joint: [0.2, 0, 1.08]
    extents: [0.3, 0.2, 0.04]
"""


def test_ground_shadows_darken_once_where_boxes_overlap(renderer):
    c = creature_from_text(FLOATING)
    scene = sc.Scene(actors=[sc.Actor(c, show_joints=False, show_links=False)], show_grid=False)
    renderer.draw(scene)
    img = renderer.read_pixels()
    cam = renderer.camera
    # Under a only, under both, under b only; and open ground.
    ground = np.array([[-0.2, 0.1, 0.0], [0.1, 0.1, 0.0], [0.45, 0.0, 0.0], [-0.2, -1.0, 0.0]])
    px, _ = cam.project(ground, W, H)
    only_a, both, only_b, open_ground = (_patch(img, p, 1) for p in px)
    bg = np.array(sc.BACKGROUND_COLOR)
    np.testing.assert_allclose(open_ground, bg, atol=0.01)
    want = bg * (1.0 - geo.SHADOW_RGBA[3]) + np.array(geo.SHADOW_RGBA[:3]) * geo.SHADOW_RGBA[3]
    for p in (only_a, both, only_b):
        np.testing.assert_allclose(p, want, atol=0.015)
    # Without shadows the ground there is plain background.
    scene.show_shadows = False
    renderer.draw(scene, camera=cam)
    np.testing.assert_allclose(_patch(renderer.read_pixels(), px[1], 1), bg, atol=0.01)


def test_scene_pages_keep_settings_and_overlays(mini, twist):
    from authoring.viewer import scene_pages

    pts = sc.Points([[0, 0, 2.0]])
    scene = sc.Scene(actors=[sc.Actor(mini), sc.Actor(twist, offset=(0, 2, 0))], points=[pts],
                     camera=sc.Camera(), show_grid=False, view_elevation=0.5)
    pages = scene_pages(scene)
    assert len(pages) == 3 and pages[0] is scene
    for page, actor in zip(pages[1:], scene.actors, strict=True):
        assert page.actors == [actor] and page.points == [pts]
        assert page.camera is None and not page.show_grid and page.view_elevation == 0.5
    assert scene_pages(sc.Scene(actors=[sc.Actor(mini)]))[0].actors[0].creature is mini


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_random_creatures_draw_inside_their_bounds(seed):
    from engine.model import build_creature
    from engine.model.random import random_creature_def

    c = build_creature(random_creature_def(seed))
    a = sc.Actor(c)
    np.testing.assert_allclose(a.world_bounds(), c.bounds, atol=1e-9)
    g = geo.SceneGeometry()
    ranges = g.build(sc.Scene(actors=[a], show_shadows=False, show_grid=False))
    faces = next(r for r in ranges if r.kind == geo.FACES)
    pts = g.verts[faces.first:faces.first + faces.count, :3].astype(float)
    size = float(np.max(c.size))
    # Drawn boxes are at most DRAW_INSET smaller than the real ones.
    assert np.all(pts.min(axis=0) >= c.bounds[0] - 1e-5 * size)
    assert np.all(pts.max(axis=0) <= c.bounds[1] + 1e-5 * size)
    slack = sc.DRAW_INSET * float(np.max(c.body_extent)) * 2 + 1e-5 * size
    np.testing.assert_allclose(pts.min(axis=0), c.bounds[0], atol=slack)
    np.testing.assert_allclose(pts.max(axis=0), c.bounds[1], atol=slack)
