"""The goals viewer builds its overlays from the animation's goals (no window needed)."""

from __future__ import annotations

import os

import numpy as np
from test_channels import MINI

from authoring.goals_view import TRAIL_SAMPLES, goals_scene
from engine.anim import evaluate_goals, load_animation
from engine.model import creature_from_text

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_goals_scene_places_markers_trails_and_targets_per_creature():
    c = creature_from_text(MINI)
    wide = creature_from_text(MINI.replace("0.4, 1.2]", "0.9, 1.2]"))
    a = load_animation(os.path.join(ROOT, "animations", "pick_fruit.yaml"))
    scene = goals_scene(a, [c, wide], 1.0, targets={"fruit": (0.8, 0.5, 1.0)})
    assert len(scene.actors) == 2
    goal_points = [p for p in scene.points if p.name.endswith("goals")]
    targets = [p for p in scene.points if p.name.endswith("targets")]
    assert len(goal_points) == 2 and len(targets) == 2
    for actor, pts, tgt in zip(scene.actors, goal_points, targets, strict=True):
        g = evaluate_goals(a, actor.creature, 1.0, targets={"fruit": (0.8, 0.5, 1.0)})
        posed = np.flatnonzero(g.goal_pos_weight > 0)
        np.testing.assert_allclose(pts.positions, actor.offset + actor.scale * g.goal_pos[posed])
        # at t = 1 the hand is at the fruit: marker on target
        np.testing.assert_allclose(pts.positions[0], tgt.positions[0], atol=1e-9)
    trails = [p for p in scene.polylines if p.name.endswith("trail")]
    assert len(trails) == 2 and all(t.points.shape == (TRAIL_SAMPLES, 3) for t in trails)
    axes = [s for s in scene.segments if s.name.endswith("forward axes")]
    assert len(axes) == 2  # the head's lookat rotation goal
