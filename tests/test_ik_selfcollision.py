"""Self-collision-aware IK (issue 16, item 1): limbs pushed out of the creature's other
bodies in the limb phase (engine/ik/_collide.py, engine/ik/selfcollision.py).

Depths are measured the way the validation grid's ``self_intersection`` does (boxes,
separating-axis test, each pair's rest depth subtracted, relative to the creature's
height), on library and random creatures playing the library's animations."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine.anim.binding import BindError, bind
from engine.ik import IKParams, IKSolver, plan_for
from engine.ik import _collide as C
from engine.ik.plan import IKError
from engine.ik.solver import rest_pose_world
from engine.model import build_creature
from engine.model.random import random_creature_def
from engine.validation import _kernels as VK
from engine.validation.cell import CellContext
from engine.validation.thresholds import THRESHOLDS

OFF = IKParams(self_collision=False)
ON = IKParams(self_collision=True)
FAIL = next(t for t in THRESHOLDS if t.metric == "self_intersection").fail


def creature(name):
    return engine.load_creature(f"creatures/{name}.yaml")


def anim(name):
    return engine.load_animation(f"animations/{name}.yaml")


def play(c, a, params=ON, seconds=None):
    """Per-frame box depth beyond rest / height: (frames, pairs) and the pair list."""
    ctx = CellContext.for_creature(c)
    ch = engine.Character(c, ik_params=params)
    ch.play(a)
    n = int(round((seconds or a.length) * 60))
    pos = np.empty((n, c.nbody, 3))
    rot = np.empty((n, c.nbody, 4))
    for f in range(n):
        ch.tick(1 / 60)
        pos[f] = ch.world_positions
        rot[f] = ch.world_rotations
    d = VK.pair_depths(pos, rot, c.body_extent, ctx.pair_a, ctx.pair_b, np.arange(n, dtype=np.int64))
    return np.maximum(d - ctx.pair_rest_depth[None], 0.0) / ctx.height, ctx, pos


def worst(excess, ctx, c, bodies_a=None, bodies_b=None):
    """Deepest excess over the pairs with one body among ``bodies_a`` and the other among
    ``bodies_b`` (names; None = any)."""
    keep = np.ones(ctx.pair_a.shape[0], bool)
    if bodies_a is not None:
        na = np.array([c.body_names[i] for i in ctx.pair_a])
        nb = np.array([c.body_names[i] for i in ctx.pair_b])
        ia, ib = np.isin(na, bodies_a), np.isin(nb, bodies_a)
        ja, jb = np.isin(na, bodies_b), np.isin(nb, bodies_b)
        keep = (ia & jb) | (ib & ja)
    return float(excess[:, keep].max()) if keep.any() else 0.0


# -- the kernel's geometry against plain references ---------------------------------


def closest_ref(p1, q1, p2, q2, n=801):
    s = np.linspace(0, 1, n)
    a = p1[None] + s[:, None] * (q1 - p1)[None]
    b = p2[None] + s[:, None] * (q2 - p2)[None]
    d = np.linalg.norm(a[:, None] - b[None], axis=2)
    return float(d.min())


def test_segment_distance_matches_a_dense_reference():
    rng = np.random.default_rng(3)
    for _ in range(200):
        p1, q1, p2, q2 = rng.normal(size=(4, 3))
        if rng.random() < 0.3:   # near-parallel pairs, where the closest pair is not unique
            q2 = p2 + (q1 - p1) * rng.uniform(0.5, 1.5) + rng.normal(scale=1e-3, size=3)
        s, t = C.closest_params(tuple(p1), tuple(q1), tuple(p2), tuple(q2))
        assert 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0
        d = float(np.linalg.norm(p1 + s * (q1 - p1) - (p2 + t * (q2 - p2))))
        ref = closest_ref(p1, q1, p2, q2)
        # the parallel fade may pick a pair slightly off the minimum (never closer than it)
        assert d >= ref - 1e-3
        assert d <= ref + 0.02 * np.linalg.norm(q1 - p1) + 1e-3


def test_closest_parameters_are_continuous_as_segments_turn_parallel():
    p1, q1 = np.zeros(3), np.array([1.0, 0, 0])
    prev = None
    for ang in np.linspace(-0.2, 0.2, 401):   # second segment swings through parallel
        d = np.array([np.cos(ang), np.sin(ang), 0.0])
        p2 = np.array([0.2, 0.0, 0.1])
        s, t = C.closest_params(tuple(p1), tuple(q1), tuple(p2), tuple(p2 + d))
        if prev is not None:
            assert abs(s - prev[0]) < 0.05 and abs(t - prev[1]) < 0.05
        prev = (s, t)


# -- the static part -----------------------------------------------------------------


def test_pairs_are_built_with_the_plan_and_exempt_the_rest_pose():
    c = creature("humanoid")
    goals = [c.body(n) for n in ("hand_l", "hand_r", "foot_l", "foot_r")]
    plan = plan_for(c, goals, ON)
    cl_i = plan.arrays.cl_i
    nprox, nmove, npair = int(cl_i[0]), int(cl_i[1]), int(cl_i[2])
    assert nprox == c.nbody and 0 < nmove < nprox and npair > 0
    assert plan_for(c, goals, OFF).arrays.cl_i[0] == 0
    # a rest-pose solve is the rest pose whether collisions are on or off
    rp, rr = c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy()
    rest_pos, _ = rest_pose_world(c, rp, rr)
    outs = []
    for prm in (ON, OFF):
        s = IKSolver(c, goals, prm)
        for g in goals:
            s.goals.set(g, pos=rest_pos[g], rot=c.body_rest_rot[g])
        outs.append(s.solve(rp, rr)[0].copy())
    np.testing.assert_allclose(outs[0][plan.ik_bodies], outs[1][plan.ik_bodies], atol=1e-12)


def test_bad_rounds_are_refused():
    c = creature("minimal")
    with pytest.raises(IKError, match="self_collision_rounds"):
        plan_for(c, [c.nbody - 1], IKParams(self_collision_rounds=0))


# -- behaviour on library creatures --------------------------------------------------


def test_clap_stops_the_hands_at_each_other():
    c = creature("humanoid")
    on, ctx, _ = play(c, anim("clap"))
    off, _, _ = play(c, anim("clap"), OFF)
    hands = ["hand_l", "hand_r"]
    w_on, w_off = worst(on, ctx, c, hands[:1], hands[1:]), worst(off, ctx, c, hands[:1], hands[1:])
    assert w_off > 0.03            # the goals put the hands through each other
    # The hands stop where ``settle_goals`` put their goals, a capsule apart; their flat
    # boxes still overlap there (0.036 h, 0.041 h without self-collision). Until stop 37
    # the pushes after the iterations moved both held hands further apart (0.030 h), and
    # arms turned over where they did (the grid with self-collision on: 44 flip cells
    # against 25).
    assert w_on < 0.95 * w_off and w_on < FAIL


def test_hug_goes_around_the_torso():
    c = creature("humanoid")
    on, ctx, _ = play(c, anim("hug"))
    torso = ["pelvis", "spine1", "spine2", "spine3", "neck"]
    arms = [f"{p}_{s}" for p in ("upperarm", "forearm", "hand") for s in "lr"]
    # measured 0.025 h (the forearms' flat boxes graze the chest's corners: the capsules
    # are round); without self-collision the forearms cross through each other
    assert worst(on, ctx, c, arms, torso) < 0.03
    assert on.max() < FAIL


def test_hand_to_mouth_does_not_enter_the_head():
    c = creature("humanoid")
    a = anim("hand_to_mouth")
    # With the limb aim through forward (the default) the raised arm keeps further out of the
    # head on its own (0.048 h deep, a warn); the shortest-arc aim takes it through the head,
    # and that is where self-collision must show.
    on, ctx, _ = play(c, a, IKParams(self_collision=True, aim_via=False))
    off, _, _ = play(c, a, IKParams(self_collision=False, aim_via=False))
    via, _, _ = play(c, a, OFF)
    head = ["head", "jaw", "eye_l", "eye_r", "ear_l", "ear_r", "neck"]
    arms = [f"{p}_{s}" for p in ("upperarm", "forearm", "hand") for s in "lr"]
    w_on, w_off = worst(on, ctx, c, arms, head), worst(off, ctx, c, arms, head)
    assert worst(via, ctx, c, arms, head) < w_off
    assert w_off > FAIL             # without it the upper arm goes into the head
    # two rounds (the cost floor) leave the raised upper arm about 0.06 h in the head's
    # box (capsule proxies are round; the head's box is not)
    assert w_on < 0.8 * w_off


@pytest.mark.parametrize("name", ["threearmed", "gorilla", "giant"])
def test_library_creatures_with_arms_stay_out_of_themselves(name):
    """Never deeper than without self-collision, and below the grid's fail line except
    where a flat box's round proxy leaves it short: gorilla clap (the hands stop at each
    other, the forearms' flat boxes then overlap 0.063 h; 0.064 h without) and giant
    hand_to_mouth (forearm into the chest's box, 0.073 h with its goals settled in front of
    the face and the held hand kept there; 0.0665 h when the pushes moved the held hand,
    0.064 h before the settle). Capsules are round: box proxies would close the rest."""
    short = {("gorilla", "clap"): 0.065, ("giant", "hand_to_mouth"): 0.074}
    c = creature(name)
    for a in ("clap", "hug", "hand_to_mouth"):
        try:
            bind(anim(a), c)
        except BindError:
            continue
        on, _, _ = play(c, anim(a))
        off, _, _ = play(c, anim(a), OFF)
        assert on.max() <= off.max() + 1e-3, (name, a, on.max(), off.max())
        assert on.max() < short.get((name, a), FAIL), (name, a, on.max())


def test_random_creatures_clap_without_passing_through_themselves():
    found = 0
    for seed in range(40):
        c = build_creature(random_creature_def(seed))
        try:
            bind(anim("clap"), c)
        except BindError:
            continue
        on, ctx, pos_on = play(c, anim("clap"), seconds=0.8)
        off, _, pos_off = play(c, anim("clap"), OFF, seconds=0.8)
        # Two rounds resolve the deep contact but may leave another pair a little deeper
        # than without: seed 3's arm against its wing, a free body the runtime swings by
        # secondary motion while the solver sees it rigid at rest on its spine body
        # (0.0430 -> 0.0455 h; 0.0476 -> 0.0508 h since held hands stay on their goals).
        assert on.max() <= off.max() + 4e-3, (seed, on.max(), off.max())
        if off.max() > FAIL:        # seed 4: 0.0725 -> 0.0654 h
            # (the skin band that keeps sweeps smooth leaves up to 3/8 of the thinner
            # radius of a deep contact after two rounds: 0.060 h before it)
            assert on.max() < 0.92 * off.max(), (seed, on.max(), off.max())
        found += 1
        if found == 4:
            break
    assert found == 4


# -- goals settled out of the creature's own bodies -----------------------------------


def _settle_case(name, prm):
    c = creature(name)
    goals = [c.body(n) for n in ("hand_l", "hand_r", "foot_l", "foot_r")]
    rp, rr = c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy()
    rest_pos, _ = rest_pose_world(c, rp, rr)
    return c, goals, rp, rr, rest_pos


def _solve(c, goals, prm, rp, rr, gp):
    s = IKSolver(c, goals, prm)
    for g in goals:
        s.goals.set(g, pos=gp[g])
    pos, rot = s.solve(rp, rr)
    return pos.copy(), rot.copy()


def _solve_settled(name, place):
    """Solve the humanoid-like ``_settle_case`` with its four goals at rest except those
    ``place(c, rest_pos, gp)`` moves: (creature, goal bodies, root pose, rest positions,
    goal positions, goal weights, solved positions, settled goals)."""
    from engine.ik.selfcollision import settled_goals

    c, goals, rp, rr, rest_pos = _settle_case(name, ON)
    gp = rest_pos.copy()
    place(c, rest_pos, gp)
    gw = np.zeros(c.nbody)
    gw[goals] = 1.0
    pos, rot = _solve(c, goals, ON, rp, rr, gp)
    return c, goals, (rp, rr), rest_pos, gp, gw, pos, settled_goals(plan_for(c, goals, ON), gp, gw, pos, rot)


def test_a_goal_inside_the_chest_is_settled_on_its_surface_and_met_there():
    """A hand goal at the middle of the chest cannot be met without entering it: the limb
    phase is asked for the chest's surface in front (plus the hand's radius), the other
    hand's goal next to it is kept a hand's width away, and both hands get there."""
    from engine.ik.selfcollision import capsule_of_box, settled_goals

    def place(c, rest_pos, gp):
        chest = c.body("spine3")
        gp[c.body("hand_l")] = rest_pos[chest]
        gp[c.body("hand_r")] = rest_pos[chest] + np.array([0.0, 0.0, 0.02])

    c, goals, (rp, rr), rest_pos, gp, gw, pos, sg = _solve_settled("humanoid", place)
    chest, hl, hr = c.body("spine3"), c.body("hand_l"), c.body("hand_r")
    r_chest = capsule_of_box(c.body_extent[chest])[2]
    r_hand = capsule_of_box(c.body_extent[hl])[2]
    for b in (hl, hr):
        out = sg[b] - rest_pos[chest]
        # in front of the chest (its capsule lies across, along y), on its surface
        assert out[0] > 0.0 and np.hypot(out[0], out[2]) > 0.95 * (r_chest + r_hand), (c.body_names[b], out)
        assert np.linalg.norm(pos[b] - sg[b]) < 0.03 * 0.7, c.body_names[b]   # met (3% of an arm)
    assert np.linalg.norm(sg[hl] - sg[hr]) >= 0.95 * 2 * r_hand
    # the off solve is asked (and meets) the goals as given
    pos_off, rot_off = _solve(c, goals, OFF, rp, rr, gp)
    np.testing.assert_array_equal(settled_goals(plan_for(c, goals, OFF), gp, gw, pos_off, rot_off), gp)


def test_settled_goal_is_continuous_as_it_crosses_the_surface():
    """A hand goal swept from in front of the chest into its middle moves the settled goal
    without a jump (the band), and it is never inside the chest. (A goal passing right
    through a body must turn over somewhere: no continuous map takes a ball onto its
    surface. Ours fades its move out about a point SETTLE_LEAN of the radius behind the
    axis, on the side away from the exit, over SETTLE_CORE of the radius: see
    ``test_a_hand_goal_swept_through_the_chest_moves_the_arm_round_it_continuously``.)"""
    from engine.ik.selfcollision import capsule_of_box, settled_goals

    c, goals, rp, rr, rest_pos = _settle_case("humanoid", ON)
    chest, hl = c.body("spine3"), c.body("hand_l")
    plan = plan_for(c, goals, ON)
    gw = np.zeros(c.nbody)
    gw[goals] = 1.0
    gp = rest_pos.copy()
    gp[hl] = rest_pos[chest] + [0.4, 0.05, 0.0]
    pos, rot = _solve(c, goals, ON, rp, rr, gp)   # the chest's pose (the spine has no goal)
    r = capsule_of_box(c.body_extent[chest])[2] + capsule_of_box(c.body_extent[hl])[2]
    prev = None
    steps = []
    for x in np.linspace(0.4, 0.0, 401):
        gp[hl] = rest_pos[chest] + [x, 0.05, 0.0]
        s = settled_goals(plan, gp, gw, pos, rot)[hl]
        d = s - rest_pos[chest]
        assert np.hypot(d[0], d[2]) > 0.7 * r
        if prev is not None:
            steps.append(np.linalg.norm(s - prev))
        prev = s
    # the goal moves 1 mm per step; its settled copy never more than a few
    assert max(steps) < 0.006, max(steps)


def test_crossing_hand_goals_keep_their_sides_and_move_continuously():
    """Two hand goals swept through each other in front of the chest (a hug's hands
    passing behind a back) stop at each other, each on its own side, and their settled
    copies never jump: they are kept apart along the line between the hands' rest
    places, not along their difference (which turns over as they cross: the hug's
    forearm turned 0.64 rad in one 60 Hz frame that way)."""
    from engine.ik.selfcollision import capsule_of_box, settled_goals

    c, goals, rp, rr, rest_pos = _settle_case("humanoid", ON)
    chest, hl, hr = c.body("spine3"), c.body("hand_l"), c.body("hand_r")
    plan = plan_for(c, goals, ON)
    gw = np.zeros(c.nbody)
    gw[goals] = 1.0
    gp = rest_pos.copy()
    front = rest_pos[chest] + [0.35, 0.0, 0.0]
    pos, rot = _solve(c, goals, ON, rp, rr, gp)
    r = 2 * capsule_of_box(c.body_extent[hl])[2]
    prev, steps = None, []
    for y in np.linspace(0.1, -0.1, 401):     # hand_l from its own side (+y) across
        gp[hl] = front + [0.0, y, 0.0]
        gp[hr] = front + [0.0, -y, 0.0]
        s = settled_goals(plan, gp, gw, pos, rot)
        assert s[hl][1] > s[hr][1], y           # left stays left
        if prev is not None:
            steps.append(max(np.linalg.norm(s[hl] - prev[0]), np.linalg.norm(s[hr] - prev[1])))
        prev = (s[hl].copy(), s[hr].copy())
        if abs(y) < 0.01:                       # level: a hand's width apart (the band)
            assert s[hl][1] - s[hr][1] > 0.9 * r
    # the goals move 0.5 mm per step each; the settled copies as little
    assert max(steps) < 0.003, max(steps)


@pytest.mark.parametrize("name", ["humanoid", "hexapod", "spider", "crab", "octopus", "random:7", "random:4246"])
def test_a_rest_pose_is_hardly_settled(name):
    """Goals at the rest places of their bodies are where the creature's own shape puts
    them: the settling leaves them where they are (an insect's feet cross the line between
    their legs' roots at rest; that is theirs, like the boxes' rest overlaps), but for the
    smooth band at a surface, which moves a goal lying on it (or a little inside, where a
    body's origin is off its box's middle) out by a fraction of its radius: the spider's
    spinneret on its abdomen, 1.3 mm, a quarter of its radius; nothing else moves."""
    from engine.ik.selfcollision import capsule_of_box, settled_goals

    if name.startswith("random:"):
        c = build_creature(random_creature_def(int(name[7:])))
    else:
        c = creature(name)
    goals = sorted(int(b) for b in np.flatnonzero(c.body_limb >= 0) if c.children(int(b)).size == 0)
    rp, rr = c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy()
    rest_pos, rest_rot = rest_pose_world(c, rp, rr)
    plan = plan_for(c, goals, ON)
    gw = np.zeros(c.nbody)
    gw[goals] = 1.0
    s = settled_goals(plan, rest_pos, gw, rest_pos, rest_rot)
    moved = np.linalg.norm(s[goals] - rest_pos[goals], axis=1)
    bound = np.array([capsule_of_box(c.body_extent[g])[2] for g in goals]) / 2.0 + 1e-12
    assert np.all(moved <= bound), [(c.body_names[g], m) for g, m, b in zip(goals, moved, bound, strict=True) if m > b]
    assert np.mean(moved == 0.0) > 0.9


@pytest.mark.parametrize("name", ["humanoid", "giant", "twoheaded"])
def test_a_hug_with_self_collision_turns_nothing_fast(name):
    """The hug's hand goals cross each other behind the hugged back. Kept apart along
    their difference, the settled goals swapped sides as it turned over and the arms
    followed (the grid's rotation_pop, the turn in one 60 Hz frame beyond what the goals
    ask: humanoid 0.161 rad, giant 0.219, twoheaded 0.164; 0.64 with the pushes inside the
    iterations); kept apart along the line between the hands' rest places, 0.017, 0.019 and
    0.015. Here the whole turn per frame, the arms' own motion included: 0.062-0.063."""
    from engine.validation.record import record_cell

    c = creature(name)
    rec = record_cell(c, anim("hug"), 0, settle=0.3, character=engine.Character(c, ik_params=ON))
    r = rec.world_rot
    turn = 2.0 * np.arccos(np.abs(np.sum(r[1:] * r[:-1], axis=-1)).clip(0.0, 1.0))
    assert turn.max() < 0.12, (c.body_names[int(np.argmax(turn.max(axis=0)))], turn.max())


def test_a_held_limb_turns_round_the_belly_and_keeps_its_goal():
    """The pushes after the limb iterations turn a limb whose end is held about the line
    from its root to that end (``_collide._swivel_runs``): the elbow goes round the belly,
    the hand stays at its goal. The grid's humanoid point_at_target cell with one of its
    random targets in front of the belly (reach_miss, share of the arm's reach): before
    the swivel, the pushes took the hand off its goal (0.092, measured in stop 30; 0.070
    with ``self_collision_iterate``); now nearer with either, and the arm less deep in the
    body than without self-collision (where the hand meets its goal exactly)."""
    from engine.validation.cell import CellContext, cell_target_sets
    from engine.validation.goals import goal_error
    from engine.validation.record import record_cell
    from engine.validation.selfcollision import self_intersection

    c = creature("humanoid")
    a = anim("point_at_target")
    b = bind(a, c)
    v = b.variants[0]
    targets = cell_target_sets(a, c, b, v)[1]
    ctx = CellContext.for_creature(c)
    miss, depth = {}, {}
    for key, prm in (("off", OFF), ("on", ON), ("iterate", IKParams(self_collision=True,
                                                                      self_collision_iterate=True))):
        rec = record_cell(c, a, v.index, targets, character=engine.Character(c, ik_params=prm))
        miss[key] = next(m.value for m in goal_error(rec, ctx) if m.name == "reach_miss")
        depth[key] = self_intersection(rec, ctx)[0].value
    # measured: off 0 / 0.074 h deep; on 0.044 / 0.064 h; with iterate 0.042 / 0.048 h
    assert miss["on"] < 0.06 and miss["iterate"] < 0.06, miss
    assert depth["on"] < 0.9 * depth["off"] and depth["iterate"] < 0.9 * depth["off"], depth


def test_a_planted_foot_is_never_settled():
    """A foot's goal is its place on the ground, chosen by the standing or gait stage:
    settling it out of a body would slide a planted foot (random creature 4246's crowded
    legs slid 7 mm in four grid cells). A foot goal inside the pelvis stays where it is; a
    hand goal at the same place is moved out."""
    def place(c, rest_pos, gp):
        pelvis = c.body("pelvis")
        gp[c.body("foot_l")] = rest_pos[pelvis]
        gp[c.body("hand_l")] = rest_pos[pelvis] + np.array([0.0, 0.01, 0.0])

    c, _, _, _, gp, _, _, sg = _solve_settled("humanoid", place)
    hl, fl = c.body("hand_l"), c.body("foot_l")
    assert np.array_equal(sg[fl], gp[fl])
    assert np.linalg.norm(sg[hl] - gp[hl]) > 0.05

    from engine.ik.selfcollision import _planted
    assert _planted(c, fl) and not _planted(c, hl)


def test_an_arm_reaching_past_a_neck_does_not_turn_the_head():
    """A neck and its head are aimed by the animation: in a contact with an arm the arm
    moves alone (the proxies' yield). The twoheaded's left neck turned 0.72 rad between
    two frames in point_at_target when the raised shoulder and upper arm pushed it."""
    from engine.validation.cell import cell_target_sets
    from engine.validation.record import record_cell

    c = creature("twoheaded")
    a = anim("point_at_target")
    b = bind(a, c)
    v = next(v for v in b.variants if v.id == "hand_l")
    neck = c.body("neck_l")
    for targets in cell_target_sets(a, c, b, v):
        rec = record_cell(c, a, v.index, targets, character=engine.Character(c, ik_params=ON))
        q = rec.world_rot[:, neck]
        turn = 2.0 * np.arccos(np.clip(np.abs(np.sum(q[1:] * q[:-1], axis=-1)), 0.0, 1.0))
        assert turn.max() < 0.3, turn.max()


@pytest.mark.parametrize("name,through", [("humanoid", "spine2"), ("giant", "chest"), ("twoheaded", "chest")])
def test_a_hand_goal_swept_through_the_chest_moves_the_arm_round_it_continuously(name, through):
    """A hand's goal swept straight through the chest, back to front, in steps of 0.33% of
    the height (0.6 m/s at 60 Hz on the humanoid): the goal is settled on the chest's
    surface, behind it, then in front, and the arm goes round. The settled goal used to
    jump 10 cm for 0.4 mm of goal (set at its own distance along a direction that turned
    over; ``settle_goals`` fades the move now, over the proxy's whole radius): the arm
    turned 1.73 rad (humanoid), 2.85 (giant) and 2.46 (twoheaded) in one step; measured
    now 0.37, 0.59 and 0.50."""
    c = creature(name)
    rp, rr = c.body_rest_pos, c.body_rest_rot
    feet = [c.body("foot_l"), c.body("foot_r")]
    hand = c.body("hand_l")
    s = IKSolver(c, feet + [hand], ON)
    ik = s.plan.ik_bodies
    p0 = rp[c.body(through)] + np.array([-0.35, 0.05, 0.0]) * c.height / 1.75
    p1 = rp[c.body(through)] + np.array([0.35, -0.05, 0.0]) * c.height / 1.75
    prev, worst = None, 0.0
    for a in np.linspace(0.0, 1.0, 121):
        s.goals.clear()
        for f in feet:
            s.goals.set(f, pos=rp[f], rot=rr[f], pos_weight=1.0, rot_weight=1.0)
        s.goals.set(hand, pos=p0 + a * (p1 - p0), pos_weight=1.0)
        _, rot = s.solve(rp[0], rr[0])
        if prev is not None:
            worst = max(worst, float((2.0 * np.arccos(np.abs(np.sum(rot[ik] * prev, -1)).clip(0.0, 1.0))).max()))
        prev = rot[ik].copy()
    assert worst < 0.6, worst
    # and the hand ends in front of the chest, out of it
    assert s.out_pos[hand, 0] > rp[c.body(through), 0]
