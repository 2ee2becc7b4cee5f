"""Before-and-after pictures of the IK's self-collision (issue 16): for each creature, each
animation is played with ``IKParams(self_collision=False)`` and with it on (``True``);
both are shown at the frame where the off run's boxes go deepest into each other beyond
the rest pose (the validation grid's ``self_intersection``), off on the left, on on the
right, with the depth in the label.

    .venv/bin/python -m authoring.selfcollision_pictures [--out DIR] [--creatures ...] [--animations ...]
"""

from __future__ import annotations

import argparse
import math
import os

import numpy as np

from authoring import scene as sc


def _play(engine, c, a, params):
    from engine.validation import _kernels as VK
    from engine.validation.cell import CellContext

    ctx = CellContext.for_creature(c)
    ch = engine.Character(c, ik_params=params)
    ch.play(a)
    n = int(round(a.length * 60))
    pos = np.empty((n, c.nbody, 3))
    rot = np.empty((n, c.nbody, 4))
    for f in range(n):
        ch.tick(1 / 60)
        pos[f], rot[f] = ch.world_positions, ch.world_rotations
    d = VK.pair_depths(pos, rot, c.body_extent, ctx.pair_a, ctx.pair_b, np.arange(n, dtype=np.int64))
    excess = np.maximum(d - ctx.pair_rest_depth[None], 0.0) / ctx.height
    return pos, rot, excess


def picture(engine, c, animations, path, width=1600, height=900):
    from authoring.render import render_png
    from engine.anim.binding import BindError, bind
    from engine.ik import IKParams

    scene = sc.Scene()
    size = float(np.ptp(c.body_rest_pos[:, :2], axis=0).max() + 2 * c.body_extent.max())
    step = max(size * 1.6, 1.0)
    row = 0
    for name in animations:
        a = engine.load_animation(os.path.join("animations", f"{name}.yaml"))
        try:
            bind(a, c)
        except BindError:
            continue
        p0, r0, e0 = _play(engine, c, a, IKParams(self_collision=False))
        p1, r1, e1 = _play(engine, c, a, IKParams(self_collision=True))
        f = int(np.argmax(e0.max(axis=1)))
        for k, (pos, rot, ex, tag) in enumerate(((p0, r0, e0, "off"), (p1, r1, e1, "on"))):
            scene.actors.append(sc.Actor(c, pos[f], rot[f], offset=(-step * row, step * k, 0.0),
                                         label=f"{name} {tag}: {ex[f].max():.3f} h (worst {ex.max():.3f})",
                                         show_joints=False))
        row += 1
    scene.caption = f"{c.name}: self-collision off (left) and on (right), at the off run's deepest frame"
    scene.view_azimuth = math.radians(-20.0)
    render_png(scene, path, width, height)
    return path


def main(argv=None) -> int:
    import engine

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=".notes/selfcollision")
    ap.add_argument("--creatures", nargs="+", default=["humanoid", "threearmed", "octopus"])
    ap.add_argument("--animations", nargs="+", default=["clap", "hug", "hand_to_mouth"])
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    for name in args.creatures:
        c = engine.load_creature(os.path.join("creatures", f"{name}.yaml"))
        print(picture(engine, c, args.animations, os.path.join(args.out, f"selfcol_{name}.png")))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
