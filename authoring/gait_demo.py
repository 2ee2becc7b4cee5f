"""The gait demo: creatures of different leg counts walking, trotting and crawling along
curved paths on rolling ground (issue 6). ``run_gait_demo(headless, out_dir, seconds)``
renders one panel per gait into a contact sheet ``OUT/gait_contact_sheet.png`` (each
panel: the creature at the end of its walk, the terrain as a grid, its root's trail and
its footprints); with a display and ``headless=False`` it opens the viewer on them.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from engine.paths import LIBRARY_CREATURES

#: (creature, style per group or None for the default, label) of each panel.
DEMO_GAITS = (
    ("humanoid", "walk", "biped: walk"),
    ("dog", "trot", "quadruped: trot"),
    ("hexapod", "trot", "hexapod: alternating tripods"),
    ("spider", "walk", "octopod: walk"),
    ("centipede", "walk", "centipede: wave gait, knee-less legs on pivot feet"),
    ("tripod", "walk", "tripod: walk"),
    ("forkstrider", "walk", "forkstrider: branching legs"),
    ("snake", None, "snake: inch-worm crawl"),
    ("inchworm", None, "inchworm: arched crawl"),
    ("minimal", "walk", "minimal: compass gait (knee-less legs)"),
    ("mixedlegs", ("trot", "run"), "mixedlegs: long trot, short run"),
)


def _terrain_grid(height, center, half: float, n: int = 13, lift: float = 0.0):
    from authoring import scene as sc

    xs = np.linspace(center[0] - half, center[0] + half, 40)
    lines = []
    for k in np.linspace(-half, half, n):
        y = np.full_like(xs, center[1] + k)
        lines.append(sc.Polyline(np.stack([xs, y, height(xs, y) + lift], 1), color=(0.55, 0.6, 0.5), width=1.0,
                                 name="terrain"))
        x = np.full_like(xs, center[0] + k)
        ys = xs - center[0] + center[1]
        lines.append(sc.Polyline(np.stack([x, ys, height(x, ys) + lift], 1), color=(0.55, 0.6, 0.5), width=1.0,
                                 name="terrain"))
    return lines


def walk_one(name: str, style, seconds: float, dt: float = 1.0 / 60.0):
    """Walk one library creature along an S-curve on rolling ground; returns the
    character, the terrain, the root trail (k, 3) and footprints (m, 3)."""
    import engine
    from engine.gait.path import PathFollower, heading_of
    from engine.validation.gait import contact_points, rolling_terrain

    c = engine.load_creature(os.path.join(LIBRARY_CREATURES, f"{name}.yaml"))
    ch = engine.Character(c)
    ch.locomote((0.0, 0.0), 0.0)
    g = ch.gait
    rig = g.rig
    L = float(np.max(rig.group_length)) if rig.ngroup else max(float(c.size[0]), 0.1)
    if isinstance(style, tuple):
        long_first = np.argsort(-rig.group_length)
        for k, g_idx in enumerate(long_first):
            g.set_style(style[min(k, len(style) - 1)], group=int(g_idx))
    elif style is not None:
        g.set_style(style)
    height = rolling_terrain(L, amplitude=0.12)
    ch.set_terrain(height)
    speed = max(1.0 * L, 0.12 * float(max(c.size)))     # the gait caps it to what the legs allow
    length = speed * seconds
    s = np.linspace(0.0, 1.0, 60)
    path = np.stack([s * length, 0.18 * length * np.sin(2.0 * math.pi * s)], 1)
    follower = PathFollower(path, speed=speed, lookahead=max(1.5 * L, 0.4 * float(c.size[0])))
    trail, prints = [], []
    prev_state = g.step_state.copy()
    for _ in range(int(seconds / dt)):
        ch.locomote(*follower.command(ch.position, heading_of(ch.rotation)))
        ch.tick(dt)
        trail.append(ch.world_positions[0].copy())
        landed = (g.step_state == 0) & (prev_state != 0)
        if np.any(landed):
            contact = contact_points(rig, ch.world_positions, ch.world_rotations)
        for st in np.flatnonzero(landed):
            for f in range(rig.step_foot_adr[st], rig.step_foot_adr[st] + rig.step_foot_num[st]):
                prints.append(contact[f].copy())
        prev_state[:] = g.step_state
    return ch, height, np.array(trail), np.array(prints).reshape(-1, 3), L


def build_panels(seconds: float):
    from authoring import scene as sc

    panels = []
    for name, style, label in DEMO_GAITS:
        if not os.path.exists(os.path.join(LIBRARY_CREATURES, f"{name}.yaml")):
            continue
        ch, height, trail, prints, L = walk_one(name, style, seconds)
        c = ch.creature
        scene = sc.Scene()
        scene.add(sc.Actor(c, ch.world_positions, ch.world_rotations, label=None))
        size = float(max(c.size))
        center = ch.world_positions[0]
        scene.polylines.extend(_terrain_grid(height, center, 1.6 * size + 2 * L, lift=0.0))
        scene.add(sc.Polyline(trail, color=(0.85, 0.35, 0.1), width=2.0, name="trail"))
        if len(prints):
            scene.add(sc.Points(prints, color=(0.1, 0.2, 0.8), size=6.0, name="footprints"))
        scene.show_grid = False
        scene.show_shadows = False            # shadows fall on z = 0, not on the terrain
        scene.caption = f"{label}  ({c.nleg} legs, {ch.gait.rig.ngroup} group(s), mode {ch.gait.rig.mode})"
        cam = sc.Camera(target=np.array([center[0], center[1], center[2] * 0.6]), distance=2.6 * size + 3 * L,
                        azimuth=scene.view_azimuth, elevation=math.radians(28.0), fov_y=scene.view_fov)
        scene.camera = cam
        panels.append((scene, ch))
    return panels


def run_gait_demo(headless: bool = False, out_dir: str = "out/gait_demo", seconds: float = 5.0) -> int:
    """Walk the demo gaits and write ``OUT/gait_contact_sheet.png`` (see the module docstring)."""
    from authoring import render as rd
    from authoring.demo import _contact_sheet

    t0 = time.perf_counter()
    panels = build_panels(seconds)
    print(f"menagerie gait demo: {len(panels)} gaits walked {seconds:.1f} s each in {time.perf_counter() - t0:.1f} s")
    if not (headless or rd.want_headless()):
        from authoring.viewer import view

        view(panels[0][0], title="Menagerie gaits")
        return 0
    os.makedirs(out_dir, exist_ok=True)
    frames = []
    with rd.Renderer(800, 500) as renderer:
        for scene, _ in panels:
            renderer.draw(scene, scene.camera)
            frames.append(renderer.read_pixels().copy())
    sheet = _contact_sheet(frames, columns=3)
    path = os.path.join(out_dir, "gait_contact_sheet.png")
    rd.write_png(path, sheet)
    print(f"menagerie gait demo: wrote {path}")
    return 0


if __name__ == "__main__":
    import sys

    out = sys.argv[1] if len(sys.argv) > 1 else "out/gait_demo"
    raise SystemExit(run_gait_demo(headless=True, out_dir=out))
