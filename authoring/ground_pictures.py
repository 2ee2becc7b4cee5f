"""Before/after pictures of the IK's ground constraint (``IKParams.ground``): one creature
playing one animation at one time, solved with the constraint off (left, the solver from
before) and on (right), seen from the side just above the ground. Offscreen:

    python -m authoring.ground_pictures [CREATURE ANIM.yaml TIME] [--out OUT.png] [--force]

Default: the snake's look_around at t = 3.5 s (the grid's worst below_ground cell), into
out/ground/snake_look_around.png.
"""

from __future__ import annotations

import argparse
import math
import os

import numpy as np

import engine
from authoring import render as rd
from authoring import scene as sc
from engine.ik import IKParams

FPS = 60


def poses_at(creature, animation, t: float):
    """(off, on): world (pos, rot) at time ``t`` with the ground constraint off and on."""
    out = []
    for on in (False, True):
        ch = engine.Character(creature, ik_params=IKParams(ground=on))
        for name in animation.target_names:
            h = creature.height
            ch.set_target(name, (0.7 * h, 0.25 * h, 0.7 * h))
        ch.play(animation, fade=0.0, loop=True)
        for _ in range(max(int(round(t * FPS)), 1)):
            ch.tick(1.0 / FPS)
        out.append((ch.world_positions.copy(), ch.world_rotations.copy()))
    return out


def render(creature, animation, t: float, path: str, width: int = 1400, height: int = 560) -> str:
    (p0, q0), (p1, q1) = poses_at(creature, animation, t)
    span = float(np.ptp(creature.body_rest_pos[:, 0])) + 2.0 * float(np.max(creature.body_extent))
    gap = 1.3 * max(span, creature.height)
    left = sc.Actor(creature, label="ground off (before)")
    right = sc.Actor(creature, offset=(gap, 0.0, 0.0), label="ground on")
    left.set_pose(p0, q0)
    right.set_pose(p1, q1)
    scene = sc.Scene(actors=[left, right], view_azimuth=math.radians(-90.0), view_elevation=math.radians(6.0),
                     caption=f"{animation.name} on {creature.name}, t = {t:.2f} s: IKParams(ground=False) | "
                             f"IKParams(ground=True)")
    with rd.Renderer(width, height) as r:
        r.draw(scene)
        r.save_png(path)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("creature", nargs="?", default="creatures/snake.yaml")
    ap.add_argument("animation", nargs="?", default="animations/look_around.yaml")
    ap.add_argument("time", nargs="?", type=float, default=3.5)
    ap.add_argument("--out", default=None)
    ap.add_argument("--force", action="store_true")
    a = ap.parse_args(argv)
    creature = engine.load_creature(a.creature)
    anim = engine.load_animation(a.animation)
    out = a.out or os.path.join("out", "ground", f"{creature.name}_{anim.name}.png")
    if os.path.exists(out) and not a.force:
        raise SystemExit(f"{out} exists (--force to overwrite)")
    os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
    print("wrote", render(creature, anim, a.time, out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
