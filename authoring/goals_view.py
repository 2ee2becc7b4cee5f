"""Show an animation's goals specialized onto one or several creatures side by side.

Hecker et al. 2008, section 3.4 (multi-character preview): every creature is bound to
the same generalized curves, so one picture shows how a q_g curve generalizes. Until the
IK runs, the creatures stand in their rest pose and the goals are overlays:

- a marker per posed body at its goal position at time ``t`` (orange: position goal,
  its size by the goal weight), a thin line from the body's rest position to it;
- the goal's trail over the animation's whole length (a polyline per posed body);
- a short line along the goal rotation's forward axis (local +X) for rotation goals;
- external targets (green) and secondary bodies' targets as the creature sees them.

Each creature is scaled like ``layout_zoo`` (its largest side to 1 m), its overlays with
it. ``python -m authoring.goals_view ANIM.yaml CREATURE.yaml ... --t 1.0 --out x.png``
renders a PNG; without ``--out`` the interactive viewer opens (or, with no display, the
snapshot is written).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from authoring import scene as sc
from engine.anim import Goals, bind_all, default_target, evaluate_goals
from engine.mathx.quat import quat_rotate

TRAIL_SAMPLES = 48
GOAL_COLOR = (0.95, 0.35, 0.05)
TRAIL_COLOR = (0.85, 0.25, 0.55)
ROT_COLOR = (0.15, 0.25, 0.85)
TARGET_COLOR = (0.10, 0.70, 0.20)


def goals_scene(animation, creatures, t: float, *, targets: dict | None = None, trails: bool = True,
                normalize_size: bool = True) -> sc.Scene:
    """A scene with ``creatures`` side by side at rest and ``animation``'s goals at time
    ``t`` as overlays (see the module docstring). ``targets`` are in each creature's own
    character space; unset external targets use the animation's defaults."""
    creatures = list(creatures)
    scene = sc.layout_zoo(creatures, normalize_size=normalize_size)
    for actor in scene.actors:
        c = actor.creature
        place = lambda p, a=actor: a.offset + a.scale * np.asarray(p)  # noqa: E731
        g = evaluate_goals(animation, c, t, targets=targets, out=Goals.empty(c.nbody))
        posed = np.flatnonzero(g.goal_pos_weight > 0)
        if len(posed):
            scene.add(sc.Points(place(g.goal_pos[posed]), color=GOAL_COLOR, size=9.0, name=f"{c.name} goals"))
            scene.add(sc.Segments(place(c.body_rest_pos[posed]), place(g.goal_pos[posed]), color=GOAL_COLOR,
                                  width=1.5, name=f"{c.name} goal offsets"))
        rotated = np.flatnonzero(g.goal_rot_weight > 0)
        if len(rotated):
            length = 0.3 * float(np.max(c.size))
            tips = np.array([g.goal_pos[b] + length * quat_rotate(np.ascontiguousarray(g.goal_rot[b]),
                                                                    np.array([1.0, 0.0, 0.0])) for b in rotated])
            scene.add(sc.Segments(place(g.goal_pos[rotated]), place(tips), color=ROT_COLOR, width=2.5,
                                  name=f"{c.name} goal forward axes"))
        if trails and len(posed):
            times = np.linspace(0.0, animation.length, TRAIL_SAMPLES)
            path = np.zeros((TRAIL_SAMPLES, c.nbody, 3))
            out = Goals.empty(c.nbody)
            for k, tk in enumerate(times):
                evaluate_goals(animation, c, tk, targets=targets, out=out)
                path[k] = out.goal_pos
            for b in posed:
                scene.add(sc.Polyline(place(path[:, b]), color=TRAIL_COLOR, width=1.5,
                                      name=f"{c.name} {c.body_names[b]} trail"))
        binding = bind_all(animation, c)
        ext = [targets[n] if targets and n in targets else default_target(animation, c, n)
               for n in binding.target_names]
        if ext:
            scene.add(sc.Points(place(np.array(ext, float)), color=TARGET_COLOR, size=14.0,
                                name=f"{c.name} targets"))
    return scene


def render_goals_png(animation, creatures, path, t: float, *, width: int = 1600, height: int = 900,
                     targets: dict | None = None, trails: bool = True) -> str:
    """Render ``goals_scene`` to a PNG at ``path``; returns the path."""
    from authoring.render import render_png

    return render_png(goals_scene(animation, creatures, t, targets=targets, trails=trails), path, width, height)


def main(argv=None) -> int:
    import engine
    from engine.anim import load_animation

    ap = argparse.ArgumentParser(prog="python -m authoring.goals_view",
                                 description="Show an animation's goals on creatures side by side.")
    ap.add_argument("animation")
    ap.add_argument("creatures", nargs="+")
    ap.add_argument("--t", type=float, default=None, help="time, s (default: the middle of the animation)")
    ap.add_argument("--out", default=None, help="write a PNG here instead of opening a window")
    ap.add_argument("--no-trails", action="store_true")
    args = ap.parse_args(argv)
    anim = load_animation(args.animation)
    creatures = [engine.load_creature(p) for p in args.creatures]
    t = anim.length / 2 if args.t is None else args.t
    if args.out:
        print(render_goals_png(anim, creatures, args.out, t, trails=not args.no_trails))
        return 0
    from authoring.viewer import view

    view(goals_scene(anim, creatures, t, trails=not args.no_trails))
    return 0


if __name__ == "__main__":
    sys.exit(main())
