"""Gait stage (issue 6): leg groups, harmonized ratios, styles, planted feet, crawl/float,
composition with animations, and invalid inputs. Small creatures, short walks."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pytest

import engine
from engine.gait import (
    GaitController,
    GaitError,
    GaitStyleError,
    analyze,
    cluster_lengths,
    harmonize,
    load_style,
    parse_style_text,
    style_names,
)
from engine.ik.testing import MINI_TEXT as MINI  # the shared seven-body test biped
from engine.mathx import quat_conj, quat_mul
from engine.model import build_creature, creature_from_text
from engine.model.random import random_creature_def
from engine.validation.gait import continuity_bound, rolling_terrain, run_scenario, scenario_commands


@pytest.fixture(scope="module")
def mini():
    return creature_from_text(MINI)


@pytest.fixture(scope="module")
def dog():
    return engine.load_creature("creatures/dog.yaml")


# -- static analysis -----------------------------------------------------------------------


def test_harmonize_small_rationals():
    # equal legs cycle together; legs about half as long cycle twice as fast
    assert harmonize([1.0, 1.0]) == [Fraction(1), Fraction(1)]
    assert harmonize([0.9, 0.4]) == [Fraction(1), Fraction(2)]
    r = harmonize([1.0, 0.66])
    assert r[1] == Fraction(3, 2)
    assert all(f.numerator <= 4 and f.denominator <= 4 for f in harmonize([1.0, 0.37, 0.52, 0.8]))


def test_cluster_lengths_by_hand():
    g = cluster_lengths([0.96, 0.96, 0.38, 0.38, 0.81, 0.81])
    assert g.tolist() == [0, 0, 1, 1, 0, 0]
    assert cluster_lengths([1.0, 0.5, 0.24]).tolist() == [0, 1, 2]


def test_rig_of_mixedlegs_and_forkstrider():
    mixed = analyze(engine.load_creature("creatures/mixedlegs.yaml"))
    assert mixed.mode == "walk" and mixed.ngroup == 2
    assert sorted(float(r) for r in mixed.group_ratio) == [1.0, 2.0]    # short legs cycle twice as fast
    fork = analyze(engine.load_creature("creatures/forkstrider.yaml"))
    # a branching limb is one stepper: its two feet step together
    assert fork.nfoot == 4 and fork.nstep == 2
    assert np.all(fork.step_foot_num == 2)


def test_stepper_order_front_to_back_left_first(dog):
    rig = analyze(dog)
    order = rig.group_steppers(0)
    xs = [rig.foot_neutral[rig.step_foot_adr[s], 0] for s in order]
    sides = [rig.step_side[s] for s in order]
    assert xs[0] >= xs[2] and sides[:2] == [1.0, -1.0]


def test_float_or_crawl_heuristic():
    assert analyze(engine.load_creature("creatures/fish.yaml")).mode == "float"
    assert analyze(engine.load_creature("creatures/jellyfish.yaml")).mode == "float"
    snake = analyze(engine.load_creature("creatures/snake.yaml"))
    assert snake.mode == "crawl" and snake.nfoot >= 3 and 0 not in snake.foot_body.tolist()


# -- styles ----------------------------------------------------------------------------------


def test_shipped_styles_load():
    names = style_names()
    for need in ("walk", "trot", "run", "gallop", "sneak", "limp", "heavy"):
        assert need in names
        s = load_style(need)
        assert s.table.shape[1] == 8 and s.path.shape[1] == 3
        assert abs(s.path[0, 1]) < 1e-9 and abs(s.path[-1, 1]) < 1e-9       # feet leave and meet the ground


def test_style_interpolates_by_speed():
    s = load_style("walk")
    a, b = s.table[0], s.table[1]
    mid = s.params_at(0.5 * (a[0] + b[0]))
    assert np.allclose(mid, 0.5 * (a + b))
    assert np.allclose(s.params_at(-1.0), a) and np.allclose(s.params_at(1e6), s.table[-1])


def test_procedural_wave_for_many_feet():
    s = load_style("walk")
    n = 24
    side = np.array([1.0, -1.0] * 12)
    rank = np.repeat(np.arange(12), 2)
    trig, dsc, lsc = s.stepper_pattern(side, rank, 12)
    assert trig.shape == (n,) and np.all((trig >= 0) & (trig < 1))
    # the two sides of a segment are half a cycle apart, neighbours along a side differ
    assert np.allclose((trig[1] - trig[0]) % 1.0, 0.5)
    assert len(set(np.round(trig[::2], 6))) > 6


GOOD = """format: 1
name: t
speeds:
  - {speed: 0.0, stride: 0.5, duty: 0.7}
triggers: [[0.0], [0.0, 0.5], [0, 0.3, 0.6], [0, 0.5, 0.5, 0], [0, 0.2, 0.4, 0.6, 0.8], [0, 0.5, 0.5, 0, 0, 0.5]]
"""

BAD_STYLES = [
    ("format: 2\nname: t\nspeeds: []\ntriggers: []\n", "format", "unsupported format"),
    (GOOD.replace("duty: 0.7", "duty: 1.0"), "speeds[0].duty", "outside"),
    (GOOD.replace("stride: 0.5, ", ""), "speeds[0].stride", "missing"),
    (GOOD.replace("[0.0, 0.5],", "[0.0],"), "triggers[1]", "must list 2"),
    (GOOD + "bogus: 1\n", "bogus", "unknown field"),
    (GOOD + "flight: {curve: [[0, 0, 0, 0], [1, 0.5, 0, 0]]}\n", "flight.curve", "forward must go"),
    (GOOD + "duty_scale: [[1], [1, 1.5], [1, 1, 1], [1, 1, 1, 1], [1, 1, 1, 1, 1], [1, 1, 1, 1, 1, 1]]\n",
     "duty_scale[1][1]", "no time"),
    (GOOD.replace("speeds:\n  - {speed: 0.0, stride: 0.5, duty: 0.7}",
                  "speeds:\n  - {speed: 1.0, stride: 0.5, duty: 0.7}\n  - {speed: 0.5, stride: 0.5, duty: 0.7}"),
     "speeds[1].speed", "ascend"),
]


@pytest.mark.parametrize("text,field,msg", BAD_STYLES)
def test_invalid_styles_name_field_and_line(text, field, msg):
    with pytest.raises(GaitStyleError) as e:
        parse_style_text(text, "bad.yaml")
    assert e.value.field == field and msg in str(e.value)
    assert e.value.path == "bad.yaml" and e.value.line is not None


def test_good_style_parses():
    s = parse_style_text(GOOD)
    assert s.name == "t" and s.triggers[2] == (0.0, 0.3, 0.6)


def test_invalid_controller_inputs(mini):
    g = GaitController(mini)
    with pytest.raises(GaitError):
        g.command(np.array([np.nan, 0.0]), 0.0)
    with pytest.raises(GaitError):
        g.command(np.zeros(3), 0.0)
    with pytest.raises(GaitError):
        g.set_terrain(3.0)
    with pytest.raises(GaitError):
        g.set_terrain(lambda x, y: np.full(np.shape(x), np.nan))
    with pytest.raises(GaitError):
        g.set_style("walk", group=5)
    with pytest.raises(GaitError):
        g.set_style("walk", weight=2.0)
    with pytest.raises(GaitStyleError):
        g.set_style("no_such_style")


# -- walking ---------------------------------------------------------------------------------


#: The benchmark's scenario (``engine.validation.gait.scenario_commands``, what
#: benchmarks/gait.py walks: curve, faster curve, sudden stop, reverse, sharp turn with a
#: sidestep, walk on), every segment at this share of its length: all of it, shorter.
SCENARIO_SHARE = 0.5


def _scenario(t, L):
    return scenario_commands(t / SCENARIO_SHARE, L)


# Knee-less bipeds through the sidestep turn: the swing stilt's hip hike (the pelvis rolled
# up to 0.35 rad so the stilt clears the ground) dropped to 0 in the frame its foot landed,
# and the hips re-solved 0.086 leg lengths higher in that frame: 306 leg lengths/s^2 on
# mini in the benchmark's scenario (321 here, minimal 261). The roll now eases out
# (engine/gait/_kernels.py, COMPASS_ROLL_STEP): mini 64 (73 here), minimal 55 (60 here).
@pytest.mark.parametrize("name", ["mini", "minimal", "dog", "hexapod", "tripod", "forkstrider", "centipede",
                                  "stilts"])
def test_planted_feet_do_not_slide(name, mini):
    c = {"mini": mini, "stilts": creature_from_text(STILTS)}.get(name) or engine.load_creature(
        f"creatures/{name}.yaml")
    for terrain in (False, True):
        m = run_scenario(c, seconds=8.0 * SCENARIO_SHARE, terrain=terrain, commands=_scenario)
        assert m["finite"]
        assert m["stances"] >= 3
        assert m["stance_slide_mm"] <= 1.0, m
        assert m["touchdown_error_mm"] <= 10.0, m
        assert m["below_ground_mm"] <= 1.0, m
        assert m["stretch_ratio"] <= 1.02, m
        # continuity through the sudden stop, reverse and sidestep turn: the bounds are a
        # one-frame hop a viewer does not see (engine.validation.gait.continuity_bound)
        foot_bound, root_bound = continuity_bound(analyze(c))
        assert m["foot_speed"] <= foot_bound and m["root_accel"] <= root_bound, m


def test_compass_hips_ride_at_leg_length_over_planted_feet(mini):
    """Knee-less legs: every planted foot's joint sits exactly one leg length from its hip
    (the highest asks, the others lift), checked on the gait's goals, not the IK."""
    from engine.gait._kernels import COMPASS_TOL

    ch = engine.Character(mini)
    g = ch._ensure_gait()
    rig = g.rig
    assert np.all(rig.foot_rigid == 1)
    s, r = ch._stack, ch._row
    held = 0
    for i in range(150):
        ch.locomote((0.5, 0.0) if i < 100 else (0.2, 0.1), 0.4)
        ch.tick(1 / 60)
        root_p, root_q = s.root_pos[r], s.root_rot[r]
        planted = 0
        for f in range(rig.nfoot):
            if g.step_state[rig.foot_stepper[f]] != 0:
                continue
            b = int(rig.foot_body[f])
            hip = root_p + _qrot(root_q, rig.foot_hip[f])
            # the goal is the planted spot less the IK's constant miss (foot_bias); the joint
            # is the origin less its offset from the joint, turned by the goal rotation
            joint = s.goal_pos[r, b] + g.foot_bias[f] - _qrot(s.goal_rot[r, b], mini.body_joint_offset[b])
            dist = np.linalg.norm(hip - joint)
            assert dist <= rig.foot_chain[f] * (1 + COMPASS_TOL) + 1e-9
            assert dist >= rig.foot_chain[f] - 1e-9
            planted += 1
        held += planted > 0
    assert held > 140          # a foot holds the hips nearly all the time


#: Four knee-less legs: a horizontal femur out to each side and a long vertical foot (a
#: stilt) down to the ground; the feet are pivot feet (``engine.gait.rig``).
STILTS = """\
format: 1
name: stilts
description: test quadruped on stilts, knee-less legs with long feet
bodies:
  - name: trunk
    caps: [spine]
    pos: [0, 0, 0.4]
    extents: [0.3, 0.12, 0.06]
""" + "".join(f"""\
  - name: femur_{n}
    parent: trunk
    caps: [limb]
    pos: [{x}, {0.22 * y}, 0.4]
    joint: [{x}, {0.12 * y}, 0.4]
    extents: [0.02, 0.1, 0.02]
  - name: stilt_{n}
    parent: femur_{n}
    caps: [foot]
    pos: [{x}, {0.32 * y}, 0.2]
    joint: [{x}, {0.32 * y}, 0.4]
    extents: [0.02, 0.02, 0.2]
""" for n, x, y in (("fl", 0.2, 1), ("fr", 0.2, -1), ("hl", -0.2, 1), ("hr", -0.2, -1)))


@pytest.mark.parametrize("name", ["centipede", "stilts"])
def test_pivot_feet_turn_about_their_contact_with_the_knee_on_the_hip_sphere(name):
    """A knee-less leg with a long foot: the gait plants the foot's contact point and turns
    the foot about it so the foot joint (the knee) stays exactly one segment from the hip;
    checked on the gait's goals through a walk with a turn (goal level, not the IK)."""
    c = creature_from_text(STILTS) if name == "stilts" else engine.load_creature(f"creatures/{name}.yaml")
    ch = engine.Character(c)
    g = ch._ensure_gait()
    rig = g.rig
    assert rig.nfoot >= 4 and np.all(rig.foot_knee[:, 3] > 0) and not np.any(rig.foot_rigid)
    s, r = ch._stack, ch._row
    start = {}
    turned = 0.0
    checked = 0
    for i in range(150):
        ch.locomote((0.3 * float(np.max(rig.group_length)), 0.0), 0.4 if i < 100 else -0.3)
        ch.tick(1 / 60)
        root_p, root_q = s.root_pos[r], s.root_rot[r]
        place_p, place_q = s.place_pos[r], s.place_rot[r]
        for f in range(rig.nfoot):
            b = int(rig.foot_body[f])
            if g.step_state[rig.foot_stepper[f]] != 0:
                start.pop(f, None)
                continue
            gq = s.goal_rot[r, b]
            rel = quat_mul(gq, quat_conj(rig.foot_rest_rot[f]))
            knee = s.goal_pos[r, b] + _qrot(rel, rig.foot_knee[f, :3])
            hip = root_p + _qrot(root_q, rig.foot_hip[f])
            assert abs(np.linalg.norm(knee - hip) - rig.foot_knee[f, 3]) < 1e-9
            contact = place_p + _qrot(place_q, s.goal_pos[r, b] + _qrot(rel, rig.foot_contact[f]))
            world_q = quat_mul(place_q, gq)
            if f not in start:
                start[f] = (contact, world_q)
                continue
            assert np.linalg.norm(contact - start[f][0]) < 1e-9      # the contact point stays put
            turned = max(turned, 2.0 * math.acos(min(abs(float(np.dot(world_q, start[f][1]))), 1.0)))
            checked += 1
    assert checked > 200
    assert turned > 0.05          # ... while the foot turns about it (the knee moves with the hip)


def test_planted_feet_keep_their_rotation_on_slopes(dog):
    """A planted foot never turns in the world (it keeps the slope it landed with while the
    body's slope and heading change under it), on rolling ground with a turn."""
    ch = engine.Character(dog)
    g = ch._ensure_gait()
    rig = g.rig
    ch.set_terrain(rolling_terrain(float(np.max(rig.group_length)), amplitude=0.15))
    start = {}
    checked = 0
    for _ in range(180):
        ch.locomote((0.8 * float(np.max(rig.group_length)), 0.0), 0.6)
        ch.tick(1 / 60)
        s, r = ch._stack, ch._row
        for f in range(rig.nfoot):
            if g.step_state[rig.foot_stepper[f]] != 0:
                start.pop(f, None)
                continue
            wq = quat_mul(s.place_rot[r], s.goal_rot[r, int(rig.foot_body[f])])
            if f not in start:
                start[f] = wq
                continue
            assert abs(abs(float(np.dot(wq, start[f]))) - 1.0) < 1e-12
            checked += 1
    assert checked > 200


def _qrot(q, v):
    u = np.asarray(q[1:], float)
    t = 2.0 * np.cross(u, v)
    return v + q[0] * t + np.cross(u, t)


def test_inchworm_pseudo_feet_and_crawl():
    c = engine.load_creature("creatures/inchworm.yaml")
    rig = analyze(c)
    spine = [int(b) for b in c.spine_chain]
    idx = sorted(spine.index(int(b)) for b in rig.foot_body)
    # pseudo-feet at least two bodies apart and two away from the root (neighbours share a
    # joint and cannot move apart)
    assert rig.mode == "crawl" and len(idx) >= 2
    assert all(b - a >= 2 for a, b in zip(idx, idx[1:], strict=False))
    assert all(abs(i - spine.index(0)) >= 2 for i in idx)
    m = run_scenario(c, seconds=3.0, terrain=True, commands=lambda t, L: (0.6 * L, 0.0, 0.1))
    assert m["finite"] and m["stances"] >= 3
    assert m["stance_slide_mm"] <= 1.0 and m["travel"] > 0.5, m


def test_character_moves_along_command():
    ch = engine.Character(engine.load_creature("creatures/humanoid.yaml"))
    for _ in range(120):
        ch.locomote((0.5, 0.0), 0.0)
        ch.tick(1 / 60)
    # accelerated toward 0.5 m/s within the style's limit, heading unchanged
    assert 0.3 < ch.position[0] < 1.0 and abs(ch.position[1]) < 1e-9
    v = ch.gait.velocity[0]
    assert 0.0 < v <= 0.5 + 1e-9
    for _ in range(60):
        ch.locomote((0.0, 0.0), 1.0)
        ch.tick(1 / 60)
    yaw = 2 * math.atan2(ch.rotation[3], ch.rotation[0])
    assert 0.3 < yaw < 1.0


def test_stop_reverse_turn_bounded(dog):
    """The root's velocity never jumps: commands are reached with bounded acceleration."""
    ch = engine.Character(dog)
    L = float(np.max(ch._ensure_gait().rig.group_length))
    acc = load_style("walk").accel * L
    prev = None
    for i in range(150):
        cmd = (1.2 * L, 0.0, 0.0) if i < 60 else ((0.0, 0.0, 0.0) if i < 61 else (-0.6 * L, 0.0, 2.0))
        ch.locomote(cmd[:2], cmd[2])
        before = ch.gait.velocity.copy()
        ch.tick(1 / 60)
        dv = np.linalg.norm(ch.gait.velocity - before)
        assert dv <= acc / 60 + 1e-9
        p = ch.world_positions[0].copy()
        if prev is not None:
            assert np.linalg.norm(p - prev) * 60 < 3.0 * L       # no popping of the hips
        prev = p


def test_mixed_groups_and_layered_styles():
    c = engine.load_creature("creatures/mixedlegs.yaml")
    ch = engine.Character(c)
    ch.locomote((0.3, 0.0), 0.0)
    g = ch.gait
    g.set_style("trot", group=0)
    g.set_style("run", group=1)
    g.set_style("limp", group=0, weight=0.5, layer=True)
    assert g.styles(0) == [("trot", 1.0), ("limp", 0.5)] and g.styles(1) == [("run", 1.0)]
    for _ in range(90):
        ch.tick(1 / 60)
    assert np.all(np.isfinite(ch.world_positions))
    # the short group cycles at twice the long group's rate (harmonized 2:1)
    short = int(np.argmin(g.rig.group_length))
    assert g.group_rate[short] == pytest.approx(2.0 * g.group_rate[1 - short])


def test_idle_feet_park_and_stay(dog):
    ch = engine.Character(dog)
    for i in range(200):
        ch.locomote((0.4, 0.0) if i < 60 else (0.0, 0.0), 0.0)
        ch.tick(1 / 60)
    g = ch.gait
    assert np.all(g.step_state == 0) and np.all(g.step_parked == 1)
    before = ch.world_positions[g.rig.foot_body].copy()
    for _ in range(30):
        ch.tick(1 / 60)
    assert np.allclose(ch.world_positions[g.rig.foot_body], before, atol=1e-6)


def test_terrain_scalar_function_and_slope_alignment(mini):
    ch = engine.Character(mini)
    ch.locomote((0.0, 0.0), 0.0)
    ch.set_terrain(lambda x, y: 0.2 * float(x))          # scalar only: sampled point by point
    for _ in range(60):
        ch.locomote((0.5, 0.0), 0.0)
        ch.tick(1 / 60)
    # the character rides up the slope; the torso pitches nose-up (rotation about -y)
    assert ch.position[2] == pytest.approx(0.2 * ch.position[0], abs=0.03)
    root_rot = ch.world_rotations[0]
    fwd = root_rot[0] ** 2 + root_rot[1] ** 2 - root_rot[2] ** 2 - root_rot[3] ** 2, 0, 2 * (root_rot[1] * root_rot[3] - root_rot[0] * root_rot[2])
    assert fwd[2] > 0.02


def test_animation_owned_foot_is_not_driven(dog):
    ch = engine.Character(dog)
    ch.locomote((0.3, 0.0), 0.0)
    g = ch.gait
    s, r = ch._stack, ch._row
    foot = int(g.rig.foot_body[0])
    held = dog.body_rest_pos[foot] + np.array([0.05, 0.0, 0.1])
    for _ in range(40):
        # what a playing clip's channel would leave after the blend
        ch.stages.blend = False
        s.goal_pw[r] = 0.0
        s.goal_rw[r] = 0.0
        s.root_pos[r] = dog.body_rest_pos[0]
        s.root_rot[r] = dog.body_rest_rot[0]
        s.goal_pos[r, foot] = held
        s.goal_pw[r, foot] = 1.0
        ch.tick(1 / 60)
        assert np.allclose(s.goal_pos[r, foot], held)
    stepper = g.rig.foot_stepper[list(g.rig.foot_body).index(foot)]
    assert g.step_state[stepper] == 3
    # released: the gait takes the foot back with a step from where the animation left it
    s.goal_pw[r] = 0.0
    ch.stages.blend = True
    ch.tick(1 / 60)
    assert g.step_state[stepper] == 1
    assert np.linalg.norm(s.goal_pos[r, foot] - held) < 0.05


def test_floater_hovers_and_crawler_crawls():
    fish = engine.load_creature("creatures/fish.yaml")
    ch = engine.Character(fish)
    zs = []
    for _ in range(120):
        ch.locomote((0.5, 0.0), 0.2)
        ch.tick(1 / 60)
        zs.append(ch.world_positions[0, 2])
    assert ch.gait.goal_bodies.size == 0 and ch.position[0] > 0.2
    assert np.ptp(zs) > 1e-3 and min(zs) >= fish.body_rest_pos[0, 2] - 1e-9   # a gentle bob above rest
    snake = engine.load_creature("creatures/snake.yaml")
    m = run_scenario(snake, seconds=2.0, terrain=False, commands=lambda t, L: (0.5 * L, 0.0, 0.2))
    assert m["finite"] and m["stances"] >= 3


@pytest.mark.parametrize("seed", [103, 111, 127])
def test_random_creatures_walk(seed):
    """Random creatures nobody tuned the gait on (seeds past 0-99) walk the benchmark's
    scenario on hills with the feet a user accepts: a planted foot skating less than 1% of
    the leg (the grid's standing_slide failure: a centimetre on a human), never 2% of the
    height into the ground (the grid's below_ground failure), no leg stretched past the
    IK's own 2% limit."""
    from engine.validation.thresholds import BY_METRIC

    c = build_creature(random_creature_def(seed))
    m = run_scenario(c, seconds=8.0 * SCENARIO_SHARE, terrain=True, commands=_scenario)
    assert m["finite"], m
    if m["mode"] == "walk":
        leg_mm = 1000.0 * float(np.max(analyze(c).group_length))
        assert m["stance_slide_mm"] <= BY_METRIC["standing_slide"].fail * leg_mm, m
        assert m["below_ground_mm"] <= BY_METRIC["below_ground"].fail * 1000.0 * float(c.height), m
        assert m["stretch_ratio"] <= 1.02 + 1e-6, m


def test_rolling_terrain_vectorised():
    h = rolling_terrain(1.0)
    x = np.linspace(-3, 3, 7)
    assert np.allclose(h(x, x), [h(float(a), float(a)) for a in x])


def test_path_follower_reaches_the_end():
    from engine.gait import PathFollower, heading_of

    c = engine.load_creature("creatures/dog.yaml")
    ch = engine.Character(c)
    path = [(0.0, 0.0), (1.0, 0.4), (2.0, 0.0)]
    fol = PathFollower(path, speed=0.4, lookahead=0.4)
    for _ in range(900):
        ch.locomote(*fol.command(ch.position, heading_of(ch.rotation)))
        ch.tick(1 / 60)
        if fol.done:
            break
    assert fol.done and np.hypot(ch.position[0] - 2.0, ch.position[1]) < 0.5
    with pytest.raises(GaitError):
        PathFollower([(0, 0)], 1.0, 1.0)


def test_crowd_members_walk_as_alone(dog):
    chars = [engine.Character(dog, position=(0.0, 2.0 * k, 0.0)) for k in range(3)]
    for ch in chars:
        ch.locomote((0.4, 0.0), 0.2)
    crowd = engine.Crowd(chars)
    alone = engine.Character(dog)
    alone.locomote((0.4, 0.0), 0.2)
    for _ in range(60):
        crowd.tick(1 / 60)
        alone.tick(1 / 60)
    assert np.allclose(chars[0].world_positions, alone.world_positions, atol=1e-12)
    assert chars[2].position[0] > 0.1


def _spine_length(c) -> float:
    j = c.body_joint[c.spine_chain]
    return float(np.sum(np.linalg.norm(np.diff(j, axis=0), axis=1)))


def _crawler_stands(figure):
    return pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
        f"a held-out crawler (seed outside the tuned 0-99) with several pseudo-feet barely moves: {figure} leg "
        "lengths of the ~7 the scenario asks; the crawl wave's sweep was calibrated on random43's four feet"))


@pytest.mark.parametrize("name, body_lengths, leg_lengths", [
    # the inch-worm covered 1.4 of its spine lengths (2.75 pseudo-foot spacings) when its
    # sweep was calibrated on the walkers' every-other-foot-opposite stances and its two
    # pseudo-feet lifted 0.55 of the cycle apart; now 2.5
    ("inchworm", 2.0, 4.0),
    # Random crawlers from seeds nobody tuned on (the gait was tuned on 0-99: random43,
    # random25). A user asking for a walk must see the crawler go somewhere: at least one
    # leg length (the benchmark's "immobile" line) and one spine length for a one-foot
    # crawler whose spine covers itself. Measured: 113 (one pseudo-foot) 1.48 spine
    # lengths; 120, 163, 178 and 276 (two to four) 0.30, 0.72, 0.0 and 0.75 leg lengths.
    ("random113", 1.0, 1.0),
    pytest.param("random120", 0.0, 1.0, marks=_crawler_stands(0.30)),
    pytest.param("random163", 0.0, 1.0, marks=_crawler_stands(0.72)),
    pytest.param("random178", 0.0, 1.0, marks=_crawler_stands(0.0)),
    pytest.param("random276", 0.0, 1.0, marks=_crawler_stands(0.75)),
])
def test_crawlers_travel_with_planted_pseudo_feet(name, body_lengths, leg_lengths):
    """A crawler's calibrated sweep is the one its inch-worm wave really uses, so it
    covers ground in the full benchmark scenario (flat ground) with pseudo-feet that do
    not slide."""
    c = (engine.load_creature(f"creatures/{name}.yaml") if not name.startswith("random")
         else build_creature(random_creature_def(int(name[6:]))))
    rig = analyze(c)
    assert rig.mode == "crawl"
    m = run_scenario(c, seconds=8.0, terrain=False)
    assert m["finite"], m
    assert m["travel"] >= leg_lengths, m
    assert m["stances"] >= 10, m
    assert m["stance_slide_mm"] <= 1.0, m
    travel_m = m["travel"] * float(rig.group_length[0])
    assert travel_m >= body_lengths * _spine_length(c), (travel_m, _spine_length(c))


def test_crawl_wave_keeps_a_pseudo_foot_planted():
    """Neighbouring pseudo-feet lift 1/(n-1) of the shortest flight apart: at every phase of
    the cycle at least one pseudo-foot is on the ground (the spine cannot stretch, so the
    wave is as tight as it can be without leaving the crawler with no anchor)."""
    c = engine.load_creature("creatures/snake.yaml")
    g = GaitController(c)
    r = g.rig
    assert r.mode == "crawl" and r.nfoot >= 3
    trig = g.step_trigger[r.foot_stepper]
    duty = max(float(np.max(st.table[:, 2])) for st, _ in g._layers[0])
    flight = 1.0 - duty
    assert np.isclose(np.ptp(trig), flight, atol=1e-9)
    for t in np.linspace(0.0, 1.0, 200, endpoint=False):
        # a pseudo-foot is in stance for the first ``duty`` of its cycle from its trigger
        assert np.any((t - trig) % 1.0 < duty), t
