"""``menagerie play CREATURE ANIM``: one animation on one creature, for people who only
want to look. In a window (the viewer, playing and looping), or headless: ``--snapshot
OUT.png`` (the pose at ``--time``) or ``--gif OUT.gif`` (the whole animation). The
creature is an ``engine.Character`` ticked by the runtime at 60 Hz, as a game plays it.
"""

from __future__ import annotations

import os

import numpy as np

import engine
from authoring import render as rd
from authoring import scene as sc
from engine.anim import load_animation
from engine.errors import MenagerieError

FPS = 60


def _setup(creature_spec: str, animation_path: str):
    from authoring.author import load_creatures

    creature = load_creatures([creature_spec])[0]
    anim = load_animation(animation_path)
    ch = engine.Character(creature)
    for name in anim.target_names:
        h = creature.height
        ch.set_target(name, (0.7 * h, 0.25 * h, 0.7 * h))
    ch.play(anim, fade=0.0, loop=True)   # BindError (a declining creature) says why in words
    actor = sc.Actor(creature, label=creature.name)
    scene = sc.Scene(actors=[actor])
    return creature, anim, ch, actor, scene


def _check_out(path: str, force: bool, flag: str, suffix: str) -> None:
    from engine.outputs import output_file

    output_file(path, force, flag=flag, suffixes=(suffix,))


def run_play(creature_spec: str, animation_path: str, *, snapshot: str | None = None, gif: str | None = None,
             time: float | None = None, width: int = 960, height: int = 540, force: bool = False) -> int:
    creature, anim, ch, actor, scene = _setup(creature_spec, animation_path)
    scene.caption = f"{anim.name} on {creature.name}"
    if snapshot is None and gif is None and not rd.want_headless():
        from authoring.viewer import view

        def update(dt):
            ch.tick(dt)
            actor.set_pose(ch.world_positions, ch.world_rotations)

        update(1 / FPS)
        view(scene, update=update, title=f"Menagerie: {anim.name} on {creature.name}")
        return 0
    if snapshot is None and gif is None:
        from authoring.viewer import _free_path

        os.makedirs("out", exist_ok=True)
        snapshot = _free_path(os.path.join("out", f"{anim.name}_{creature.name}.png"))
        print(f"menagerie play: no display here, writing {snapshot} instead")
    for out, flag, suffix in ((snapshot, "--snapshot", ".png"), (gif, "--gif", ".gif")):
        if out is not None:
            _check_out(out, force, flag, suffix)
    t = anim.length / 2 if time is None else float(time)
    if not 0.0 <= t <= anim.length:
        raise MenagerieError(f"--time must be within 0..{anim.length:g} s, got {t:g}")
    # Frame the whole animation once so the camera does not jump.
    nframe = max(int(round(anim.length * FPS)), 1)
    poses = []
    for _ in range(nframe):
        ch.tick(1.0 / FPS)
        poses.append((ch.world_positions.copy(), ch.world_rotations.copy()))
    with rd.Renderer(width, height) as r:
        boxes = []
        for p, q in poses:
            actor.set_pose(p, q)
            boxes.append(actor.world_bounds().copy())
        b = np.array([np.min([x[0] for x in boxes], axis=0), np.max([x[1] for x in boxes], axis=0)])
        scene.camera = sc.frame_camera(b, width / height)
        if snapshot is not None:
            k = min(max(int(round(t * FPS)) - 1, 0), nframe - 1)
            actor.set_pose(*poses[k])
            scene.caption = f"{anim.name} on {creature.name}  t = {t:.2f} s"
            r.draw(scene)
            r.save_png(snapshot)
            print(f"wrote {snapshot}")
        if gif is not None:
            try:
                from PIL import Image
            except ImportError:
                raise MenagerieError("--gif needs pillow (pip install -e '.[media]')") from None
            frames = []
            for k in range(0, nframe, 2):
                actor.set_pose(*poses[k])
                scene.caption = f"{anim.name} on {creature.name}  t = {(k + 1) / FPS:.2f} s"
                r.draw(scene)
                frames.append(Image.fromarray(r.read_pixels()))
            frames[0].save(gif, save_all=True, append_images=frames[1:], duration=int(2000 / FPS), loop=0)
            print(f"wrote {gif} ({len(frames)} frames)")
    return 0
