"""Particle IK (engine.ik): invalid inputs first, then kernels against plain-numpy
references, then tiny creatures whose answers are worked out by hand, then the plan and
API contracts (rest pose reproduced, free bodies untouched, batch = single, no
allocation per solve). The paper's four objectives over random creatures are in
tests/test_ik_objectives.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.ik import (
    IKError,
    IKGoals,
    IKParams,
    IKSolver,
    fit_quintic,
    plan_for,
    rest_pose_world,
    solve_ik,
    solve_ik_batch,
)
from engine.ik import _kernels as K
from engine.ik.testing import MINI_TEXT as MINI  # the shared seven-body test biped
from engine.ik.testing import humanoid_creature, joint_world
from engine.model import creature_from_text

# A planar two-bone arm: shoulder S = (0.1, 0, 1), elbow E = (0.6, 0, 1.1), wrist
# W = (1.1, 0, 1.0); both bones 0.5099 m long, bent upward (+z) at rest.
ARM = """\
format: 1
name: arm2
description: two-bone arm
bodies:
  - name: base
    caps: [spine]
    pos: [0, 0, 1]
    extents: [0.1, 0.1, 0.1]
  - name: upper
    parent: base
    caps: [limb]
    pos: [0.35, 0, 1.05]
    joint: [0.1, 0, 1.0]
    extents: [0.25, 0.03, 0.03]
  - name: fore
    parent: upper
    caps: [limb]
    pos: [0.85, 0, 1.05]
    joint: [0.6, 0, 1.1]
    extents: [0.25, 0.03, 0.03]
  - name: hand
    parent: fore
    caps: [grasper]
    pos: [1.15, 0, 1.0]
    joint: [1.1, 0, 1.0]
    extents: [0.05, 0.03, 0.03]
"""


@pytest.fixture(scope="module")
def mini():
    return creature_from_text(MINI, "<mini>")


@pytest.fixture(scope="module")
def arm():
    return creature_from_text(ARM, "<arm2>")


@pytest.fixture(scope="module")
def human():
    return humanoid_creature()


def rest_root(c):
    return c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy()


def qangle(a, b):
    return 2.0 * math.acos(min(1.0, abs(float(np.dot(a, b)))))


# -- invalid inputs ---------------------------------------------------------------------


def test_invalid_goal_bodies(mini):
    with pytest.raises(IKError, match="root is forward-kinematically controlled"):
        plan_for(mini, [0])
    with pytest.raises(IKError, match="no body 'hnad'"):
        plan_for(mini, ["hnad"])
    with pytest.raises(IKError, match="outside 0..6"):
        plan_for(mini, [7])
    with pytest.raises(IKError, match="body index or name"):
        plan_for(mini, [1.5])


@pytest.mark.parametrize("field, value, message", [
    ("limb_outer", 0, "whole number >= 1"),
    ("soft_slope", 0.0, r"in \(0, 1\]"),
    ("spine_stretch", 0.9, "spine_shrink <= 1 <= spine_stretch"),
    ("limb_shrink", 1.1, "limb_shrink <= 1 <= limb_stretch"),
    ("buckle_full", 0.1, "buckle_full must be greater"),
    ("root_influence", float("nan"), "finite number"),
])
def test_invalid_params(mini, field, value, message):
    with pytest.raises(IKError, match=message):
        plan_for(mini, ["foot_l"], IKParams(**{field: value}))


def test_invalid_arrays_and_goals(mini):
    s = IKSolver(mini, ["foot_l", "head"])
    rp, rr = rest_root(mini)
    foot = mini.body("foot_l")
    with pytest.raises(IKError, match="field 'out_pos'.*shape \\(7, 3\\)"):
        solve_ik(s.plan, rp, rr, s.goals, np.zeros((6, 3)), s.out_rot, s.scratch)
    with pytest.raises(IKError, match="field 'root_rot'"):
        solve_ik(s.plan, rp, rr.astype(np.float32), s.goals, s.out_pos, s.out_rot, s.scratch)
    with pytest.raises(IKError, match="field 'scratch'"):
        solve_ik(s.plan, rp, rr, s.goals, s.out_pos, s.out_rot, np.zeros(3))
    frozen = s.out_pos.copy()
    frozen.flags.writeable = False
    with pytest.raises(IKError, match="field 'out_pos'.*read-only"):
        solve_ik(s.plan, rp, rr, s.goals, frozen, s.out_rot, s.scratch)
    before = s.out_pos.copy()
    s.goals.set(foot, pos=(np.nan, 0.0, 0.0))
    with pytest.raises(IKError, match="body 'foot_l'"):
        s.solve(rp, rr)
    assert np.array_equal(before, s.out_pos)  # nothing written on bad input
    s.goals.set(foot, pos=(0.0, 0.1, 0.1), pos_weight=1.5)
    with pytest.raises(IKError, match="body 'foot_l'.*weights must be in \\[0, 1\\]"):
        s.solve(rp, rr)
    s.goals.set(foot, pos=(0.0, 0.1, 0.1), rot=(0.0, 0.0, 0.0, 0.0))
    with pytest.raises(IKError, match="body 'foot_l'"):
        s.solve(rp, rr)
    s.goals.set(foot, pos=(0.0, 0.1, 0.1), rot=(1.0, 0.0, 0.0, 0.0))
    with pytest.raises(IKError, match="body 'pelvis'.*root pose"):
        s.solve(np.array([0.0, np.inf, 0.0]), rr)
    # A weight-0 goal is not read at all, so NaN there is fine.
    s.goals.clear()
    s.goals.goal_pos[foot] = np.nan
    s.solve(rp, rr)
    assert np.all(np.isfinite(s.out_pos[s.plan.ik_bodies]))


def test_invalid_batch_names_character(mini):
    plan = plan_for(mini, ["foot_l"])
    g = IKGoals(mini.nbody, 3)
    rp = np.tile(mini.body_rest_pos[0], (3, 1))
    rr = np.tile(mini.body_rest_rot[0], (3, 1))
    g.goal_pos_weight[1, mini.body("foot_l")] = 1.0
    g.goal_pos[1, mini.body("foot_l")] = np.nan
    out_p, out_r = np.zeros((3, 7, 3)), np.zeros((3, 7, 4))
    with pytest.raises(IKError, match="body .foot_l.*character 1: "):
        solve_ik_batch(plan, rp, rr, g, out_p, out_r, plan.make_scratch())
    bad = np.zeros(3, np.int64)
    solve_ik_batch(plan, rp, rr, g, out_p, out_r, plan.make_scratch(), bad)
    assert list(bad) == [-1, mini.body("foot_l"), -1]


# -- kernels against plain numpy --------------------------------------------------------


def soft_response_ref(e, slope, band, width):
    a = abs(e)
    if a <= band:
        c = slope * a
    elif a <= band + width:
        c = slope * a + (1 - slope) * (a - band) ** 2 / (2 * width)
    else:
        c = a - (1 - slope) * (band + width / 2)
    return math.copysign(c, e)


def test_soft_response_matches_reference_and_is_c1():
    slope, band, width = 0.5, 0.01, 0.04
    es = np.linspace(-0.2, 0.2, 4001)
    got = np.array([K.soft_response(e, slope, band, width) for e in es])
    ref = np.array([soft_response_ref(e, slope, band, width) for e in es])
    assert np.allclose(got, ref, atol=1e-15)
    # C1: the derivative has no jumps at the joins (slope -> 1 over the blend).
    d = np.diff(got) / np.diff(es)
    assert np.max(np.abs(np.diff(d))) < 0.02
    assert d.min() >= slope - 1e-9 and d.max() <= 1.0 + 1e-9
    assert np.allclose(got, -got[::-1])


def relax_ref(pa, pb, length, lo, hi, wa, wb, slope, band, width):
    d = pb - pa
        # length outside [lo, hi] * length is corrected by the soft response
    L = np.linalg.norm(d)
    target = min(max(L, lo * length), hi * length)
    e = (L - target) / length
    c = soft_response_ref(e, slope, band, width) * length
    return pa + wa / (wa + wb) * c * d / L, pb - wb / (wa + wb) * c * d / L


def test_relax_constraint_matches_reference():
    rng = np.random.default_rng(3)
    for _ in range(200):
        pos = rng.normal(size=(2, 3))
        inv = np.ones(2)
        length = rng.uniform(0.2, 2.0)
        lo, hi = sorted(rng.uniform(0.5, 1.5, 2))
        wa, wb = rng.uniform(0.1, 2.0, 2)
        ra, rb = relax_ref(pos[0].copy(), pos[1].copy(), length, lo, hi, wa, wb, 0.5, 0.01, 0.04)
        K.relax_constraint(pos, inv, 0, 1, length, lo, hi, wa, wb, 1.0, 0.5, 0.01, 0.04)
        assert np.allclose(pos[0], ra, atol=1e-12) and np.allclose(pos[1], rb, atol=1e-12)


def test_relax_constraint_heavy_end_does_not_move():
    pos = np.array([[0.0, 0, 0], [2.0, 0, 0]])
    K.relax_constraint(pos, np.ones(2), 0, 1, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 0.01, 0.04)
    assert np.array_equal(pos[0], [0, 0, 0])
    assert np.allclose(pos[1], [1.0, 0, 0])  # slope 1: the whole error in one step


def hermite5_ref(p0, v0, a0, p1, v1, a1, t):
    # The quintic with these end values, derivatives and second derivatives, solved as
    # a 6x6 linear system for its monomial coefficients.
    M = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 2, 0, 0, 0],
                  [1, 1, 1, 1, 1, 1], [0, 1, 2, 3, 4, 5], [0, 0, 2, 6, 12, 20]], float)
    coef = np.linalg.solve(M, np.array([p0, v0, a0, p1, v1, a1]))
    return sum(coef[k] * t ** k for k in range(6))


def test_hermite5_matches_monomial_reference():
    rng = np.random.default_rng(5)
    for _ in range(20):
        p0, v0, a0, p1, v1, a1 = (tuple(rng.normal(size=3)) for _ in range(6))
        for t in (0.0, 0.17, 0.5, 0.93, 1.0):
            assert np.allclose(K.hermite5_point(p0, v0, a0, p1, v1, a1, t), hermite5_ref(p0, v0, a0, p1, v1, a1, t))
            h = 1e-6
            num = (hermite5_ref(p0, v0, a0, p1, v1, a1, t + h) - hermite5_ref(p0, v0, a0, p1, v1, a1, t - h)) / (2 * h)
            assert np.allclose(K.hermite5_tangent(p0, v0, a0, p1, v1, a1, t), num, atol=1e-6)


def test_fit_quintic_recovers_a_quintic():
    rng = np.random.default_rng(6)
    p0, v0, a0, p1, v1, a1 = (rng.normal(size=3) for _ in range(6))
    ts = np.linspace(0, 1, 9)
    pts = np.array([hermite5_ref(p0, v0, a0, p1, v1, a1, t) for t in ts])
    fv0, fa0, fv1, fa1 = fit_quintic(pts, ts, regularization=1e-12)
    for got, want in ((fv0, v0), (fa0, a0), (fv1, v1), (fa1, a1)):
        assert np.allclose(got, want, atol=1e-5)
    # Two points only: the regularisation makes it the straight segment.
    fv0, fa0, fv1, fa1 = fit_quintic(pts[[0, -1]], np.array([0.0, 1.0]))
    assert np.allclose(fv0, p1 - p0) and np.allclose(fa0, 0) and np.allclose(fv1, p1 - p0)


def test_qbetween_is_minimal_and_defined_everywhere():
    rng = np.random.default_rng(7)
    for _ in range(100):
        u, v = rng.normal(size=3), rng.normal(size=3)
        q = np.array(K.qbetween(tuple(u), tuple(v)))
        assert np.allclose(np.array(K.qrot(tuple(q), tuple(u / np.linalg.norm(u)))), v / np.linalg.norm(v))
        # minimal: the axis is perpendicular to both
        assert abs(q[1:] @ u) < 1e-9 and abs(q[1:] @ v) < 1e-9
    q = np.array(K.qbetween((1.0, 0, 0), (-1.0, 0, 0)))
    assert np.isclose(np.linalg.norm(q), 1.0) and np.allclose(K.qrot(tuple(q), (1.0, 0, 0)), (-1, 0, 0))


def test_unpack_matches_python_views(human):
    """The numba unpack (written out by hand) and the Python views agree field by field:
    compare the size and a weighted checksum of every field, computed inside numba."""
    from numba import njit

    plan = plan_for(human, ["hand_l", "hand_r", "foot_l", "foot_r", "head"])
    names = K.PlanArrays._fields
    body = "\n".join(
        f"    out[{k}, 0] = P.{n}.size\n    out[{k}, 1] = np.sum(P.{n}.ravel() * np.arange(1, P.{n}.size + 1))"
        for k, n in enumerate(names))
    src = f"def checksums(pi, pf, pf3, pf4, out):\n    P = unpack(pi, pf, pf3, pf4)\n{body}\n"
    ns = {"np": np, "unpack": K.unpack}
    exec(src, ns)  # noqa: S102 - a generated test helper
    out = np.zeros((len(names), 2))
    njit(ns["checksums"])(*plan.blobs, out)
    for k, n in enumerate(names):
        a = np.asarray(getattr(plan.arrays, n)).ravel()
        assert out[k, 0] == a.size, n
        assert np.isclose(out[k, 1], np.sum(a * np.arange(1, a.size + 1)), rtol=1e-12, atol=1e-9), n


# -- hand-checkable creatures -----------------------------------------------------------


def test_rest_goals_reproduce_rest_pose(mini, human):
    for c, names in ((mini, ["foot_l", "foot_r", "head"]),
                     (human, ["hand_l", "hand_r", "foot_l", "foot_r", "head"])):
        rp = np.array([0.3, -0.2, 0.1]) + c.body_rest_pos[0]
        rr = np.array(K.qaxis_angle((0.0, 0.0, 1.0), 0.7))
        pos, rot = rest_pose_world(c, rp, rr)
        # Exactly, with the soft reach off (straight rest legs are at full reach) ...
        s = IKSolver(c, names, IKParams(soft_reach=1.0))
        for n in names:
            s.goals.set(c.body(n), pos=pos[c.body(n)], rot=rot[c.body(n)])
        s.solve(rp, rr)
        ik = s.plan.ik_bodies
        assert np.allclose(s.out_pos[ik], pos[ik], atol=1e-12)
        assert np.allclose(np.abs(np.sum(s.out_rot[ik] * rot[ik], axis=1)), 1.0, atol=1e-12)
        # ... and with it on: goals met, the knees eased forward (the way they bend at
        # rest) by under 1.5 cm on a 0.84 m leg.
        s = IKSolver(c, names)
        for n in names:
            s.goals.set(c.body(n), pos=pos[c.body(n)], rot=rot[c.body(n)])
        s.solve(rp, rr)
        goals = [c.body(n) for n in names]
        assert np.allclose(s.out_pos[goals], pos[goals], atol=1e-4)
        assert np.max(np.linalg.norm(s.out_pos[ik] - pos[ik], axis=1)) < 0.015


def test_two_bone_arm_elbow_by_hand(arm):
    """Wrist goal 0.7 m from the shoulder along x: the elbow sits above the midpoint at
    h = sqrt(l^2 - 0.35^2) (law of cosines), on the side it bends to at rest (+z)."""
    hand = arm.body("hand")
    s = IKSolver(arm, [hand])
    rp, rr = rest_root(arm)
    wrist_goal = np.array([0.8, 0.0, 1.0])
    s.goals.set(hand, pos=wrist_goal + [0.05, 0, 0], rot=(1.0, 0, 0, 0))
    s.solve(rp, rr)
    L = math.hypot(0.5, 0.1)
    h = math.sqrt(L * L - 0.35 ** 2)
    elbow = joint_world(arm, s.out_pos, s.out_rot, arm.body("fore"))
    assert np.allclose(elbow, [0.45, 0.0, 1.0 + h], atol=2e-3)
    assert np.allclose(joint_world(arm, s.out_pos, s.out_rot, hand), wrist_goal, atol=1e-4)
    # The upper arm turns about y only (minimal twist keeps the arm in its plane).
    q = s.out_rot[arm.body("upper")]
    assert abs(q[1]) < 1e-9 and abs(q[3]) < 1e-9


def test_two_bone_arm_out_of_reach_points_and_stretches_within_limit(arm):
    hand = arm.body("hand")
    s = IKSolver(arm, [hand])
    rp, rr = rest_root(arm)
    goal = np.array([0.1, 2.0, 2.0])  # far beyond the 1.02 m reach
    s.goals.set(hand, pos=goal)
    s.solve(rp, rr)
    S = arm.body_joint[1]
    elbow = joint_world(arm, s.out_pos, s.out_rot, arm.body("fore"))
    wrist = joint_world(arm, s.out_pos, s.out_rot, hand)
    L = math.hypot(0.5, 0.1)
    p = s.plan.params
    for a, b in ((S, elbow), (elbow, wrist)):
        assert p.limb_shrink * L - 1e-9 <= np.linalg.norm(b - a) <= p.limb_stretch * L + 1e-9
    d = (goal - S) / np.linalg.norm(goal - S)
    assert np.dot((wrist - S) / np.linalg.norm(wrist - S), d) > math.cos(math.radians(2.0))


def test_delegated_head_bends_the_spine(mini):
    """The head's goal is handed to the chest: turning the chest by 0.4 rad about y at its
    joint moves the head goal; the solver turns the chest by the same rotation."""
    s = IKSolver(mini, ["head"])
    assert s.plan.delegated == {mini.body("head"): mini.body("chest")}
    rp, rr = rest_root(mini)
    chest, head = mini.body("chest"), mini.body("head")
    q = np.array(K.qaxis_angle((0.0, 1.0, 0.0), 0.4))
    cj = mini.body_joint[chest]
    head_pos = cj + np.array(K.qrot(tuple(q), tuple(mini.body_rest_pos[head] - cj)))
    head_rot = np.array(K.qmul(tuple(q), tuple(mini.body_rest_rot[head])))
    s.goals.set(head, pos=head_pos, rot=head_rot)
    s.solve(rp, rr)
    assert np.allclose(s.out_pos[head], head_pos, atol=1e-6)
    assert qangle(s.out_rot[chest], K.qmul(tuple(q), tuple(mini.body_rest_rot[chest]))) < 1e-6
    # Position only: still met by bending (the rotation follows from the spine).
    s.goals.clear()
    s.goals.set(head, pos=head_pos)
    s.solve(rp, rr)
    assert np.linalg.norm(s.out_pos[head] - head_pos) < 0.01


def test_anti_buckling_blends_toward_rest(human):
    """A head goal far behind and below the back folds the spine; with anti-buckling the
    spine stays closer to the rest pose and the fold angle drops."""
    head = human.body("head")
    rp, rr = rest_root(human)
    goal = rp + np.array([-0.6, 0.0, -0.3])
    folds = {}
    for anti in (False, True):
        s = IKSolver(human, ["head"], IKParams(anti_buckling=anti))
        s.goals.set(head, pos=goal)
        s.solve(rp, rr)
        assert np.all(np.isfinite(s.out_pos[s.plan.ik_bodies]))
        spine = list(human.spine_chain)
        worst = 0.0
        for a, b in zip(spine[:-1], spine[1:], strict=True):
            rel = K.qmul(K.qconj(tuple(s.out_rot[a])), tuple(s.out_rot[b]))
            rel0 = K.qmul(K.qconj(tuple(human.body_rest_rot[a])), tuple(human.body_rest_rot[b]))
            worst = max(worst, qangle(np.array(rel), np.array(rel0)))
        folds[anti] = worst
        state = s.scratch[s.plan.arrays.scratch_layout[7], 0]
        assert (state > 0) == anti
    assert folds[True] < 0.7 * folds[False]


# -- plan and API contracts -------------------------------------------------------------


def test_plan_structure_of_mini(mini):
    plan = plan_for(mini, ["foot_l", "foot_r", "head"])
    a = plan.arrays
    # Spine particles: the root and the chest (branch point: the delegated head).
    assert list(a.sp_body[a.sp_kind == 1]) == [mini.body("chest")]
    # Simplified limbs from the root to each foot joint, rest chord and reach.
    limb = a.sc_kind == 1
    assert np.allclose(np.sort(a.sc_len[limb]), np.linalg.norm([0.1, 0.5]))
    assert np.allclose(a.sc_lo[limb], 0.1)
    # Limb phase: a particle at each leg joint, one constraint per leg body, and a tip
    # particle at each foot's origin (off its joint) tied rigidly to the ankle. The foot's
    # origin lies almost on the line of the leg (sin 0.11 < 0.3), so no brace: the foot
    # is aimed at its tip by minimal twist (mode 0).
    assert a.lp_body.shape[0] == 6 and a.lc_a.shape[0] == 4
    assert list(a.lp_mode) == [0, 0, 3, 0, 0, 3]
    tips = a.lp_mode == 3
    assert np.allclose(a.lc_len[a.lp_con[tips]], np.linalg.norm([0.05, 0.0, 0.45]))
    assert np.all(a.lc_plo[a.lp_con[tips]] == 1.0) and np.all(a.lc_phi[a.lp_con[tips]] == 1.0)
    assert np.all(a.lc_goal == -1)
    # A foot sticking forward (the humanoid's) is braced to the knee: carried by the shin
    # and swung at its tip (mode 4).
    h = humanoid_creature()
    hp = plan_for(h, ["foot_l"])
    foot = int(np.flatnonzero(hp.arrays.lp_body == h.body("foot_l"))[0])
    assert hp.arrays.lp_mode[foot] == 4 and np.sum(hp.arrays.lc_goal >= 0) == 1
    assert plan is plan_for(mini, ("head", "foot_r", "foot_l"))  # cached, order-free
    assert plan.free_bodies.size == 0


def test_free_bodies_untouched_and_documented(human):
    s = IKSolver(human, ["hand_l", "foot_l"])
    free = set(int(b) for b in s.plan.free_bodies)
    assert {human.body(n) for n in ("jaw", "hand_r", "foot_r", "head")} <= free
    s.out_pos[:] = 7.0
    s.out_rot[:] = 7.0
    s.goals.set(human.body("hand_l"), pos=(0.3, 0.4, 1.2))
    s.solve(*rest_root(human))
    for b in range(human.nbody):
        if b in free:
            assert np.all(s.out_pos[b] == 7.0) and np.all(s.out_rot[b] == 7.0)
        else:
            assert np.all(np.isfinite(s.out_pos[b])) and np.isclose(np.linalg.norm(s.out_rot[b]), 1.0)


def test_batch_equals_single_solves(human):
    names = ["hand_l", "hand_r", "foot_l", "foot_r", "head"]
    plan = plan_for(human, names)
    n = 5
    rng = np.random.default_rng(11)
    g = IKGoals(human.nbody, n)
    rp = np.ascontiguousarray(human.body_rest_pos[0] + rng.normal(scale=0.1, size=(n, 3)))
    rr = np.ascontiguousarray(np.tile(human.body_rest_rot[0], (n, 1)))
    for k in range(n):
        for name in names:
            b = human.body(name)
            g.set(b, pos=human.body_rest_pos[b] + rng.normal(scale=0.2, size=3), index=k)
    out_p, out_r = np.zeros((n, human.nbody, 3)), np.zeros((n, human.nbody, 4))
    solve_ik_batch(plan, rp, rr, g, out_p, out_r, plan.make_scratch())
    for k in range(n):
        one = IKGoals(human.nbody)
        one.goal_pos[:] = g.goal_pos[k]
        one.goal_rot[:] = g.goal_rot[k]
        one.goal_pos_weight[:] = g.goal_pos_weight[k]
        one.goal_rot_weight[:] = g.goal_rot_weight[k]
        p, r = np.zeros((human.nbody, 3)), np.zeros((human.nbody, 4))
        solve_ik(plan, rp[k].copy(), rr[k].copy(), one, p, r, plan.make_scratch())
        ik = plan.ik_bodies
        assert np.array_equal(p[ik], out_p[k][ik]) and np.array_equal(r[ik], out_r[k][ik])


def test_no_allocation_per_solve_in_the_kernel(human):
    """Numba allocates only the argument wrappers of a call from Python; the number of
    allocations per batched call does not grow with the number of solves in it."""
    import os
    import subprocess
    import sys
    code = (
        "import numpy as np\n"
        "from numba.core.runtime import rtsys\n"
        "from engine.ik import IKGoals, plan_for, solve_ik_batch\n"
        "from engine.ik.testing import humanoid_creature\n"
        "c = humanoid_creature()\n"
        "plan = plan_for(c, ['hand_l', 'foot_r', 'head'])\n"
        "def run(n):\n"
        "    g = IKGoals(c.nbody, n); g.goal_pos_weight[:, c.body('hand_l')] = 1\n"
        "    g.goal_pos[:, c.body('hand_l')] = (0.3, 0.3, 1.2)\n"
        "    rp = np.tile(c.body_rest_pos[0], (n, 1)); rr = np.tile(c.body_rest_rot[0], (n, 1))\n"
        "    op, orr = np.zeros((n, c.nbody, 3)), np.zeros((n, c.nbody, 4)); s = plan.make_scratch()\n"
        "    solve_ik_batch(plan, rp, rr, g, op, orr, s)\n"
        "    a = rtsys.get_allocation_stats().alloc\n"
        "    solve_ik_batch(plan, rp, rr, g, op, orr, s)\n"
        "    return rtsys.get_allocation_stats().alloc - a\n"
        "print(run(1), run(50))\n"
    )
    env = dict(os.environ, NUMBA_NRT_STATS="1")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    one, fifty = (int(x) for x in out.stdout.split())
    assert one == fifty


def test_knees_fold_the_way_they_bend_at_rest(human):
    """A raised foot folds the knee forward, as the library humanoid's knee bends at rest
    (the aim reads the bend from the joint chain, not from the foot's off-joint origin)."""
    from engine.mathx import quat_rotate

    s = IKSolver(human, ["foot_l"])
    foot, shin = human.body("foot_l"), human.body("shin_l")
    rest_knee = human.body_joint[shin]
    hip = human.body_joint[human.body("thigh_l")]
    assert rest_knee[0] > hip[0]                      # bends forward at rest
    for dz in (0.05, 0.15, 0.3):
        s.goals.set(foot, pos=human.body_rest_pos[foot] + np.array([0.0, 0.0, dz]))
        pos, rot = s.solve(human.body_rest_pos[0].copy(), human.body_rest_rot[0].copy())
        knee = pos[shin] - quat_rotate(rot[shin], human.body_joint_offset[shin])
        assert knee[0] > rest_knee[0], dz
        assert np.linalg.norm(pos[foot] - s.goals.goal_pos[foot]) < 2e-3


@pytest.mark.parametrize("splay", [IKParams().fork_splay, 0.0])
def test_branching_legs_meet_planted_toes_when_the_hips_crouch(splay):
    """Branching legs (a fork whose branches each end in a planted toe): with the hips
    crouched 4-12% of the leg over toes held at their rest spots, every toe is met
    exactly. Without the splay hint the fork point stays in the plane of its joint and
    toes, every segment compressed, and toes are missed (the second case, which must
    fail somewhere, shows the test can fail)."""
    from engine.model import build_creature
    from engine.model.random import random_creature_def

    worst = 0.0
    tested = 0
    for seed in range(60):
        c = build_creature(random_creature_def(seed))
        roots: dict[int, int] = {}
        for f in c.leg_foot:
            r = int(c.limb_root[c.body_limb[f]])
            roots[r] = roots.get(r, 0) + 1
        if max(roots.values(), default=0) < 2:
            continue
        tested += 1
        feet = [int(f) for f in c.leg_foot]
        # without self-collision: crouched hips bring a leg's first segment into the
        # spine (random creature 19), which self-collision rightly stops short of its
        # toe; this test is about the fork's geometry alone
        plan = plan_for(c, feet, IKParams(fork_splay=splay, self_collision=False))
        scratch = plan.make_scratch()
        goals = IKGoals(c.nbody)
        out_p, out_r = np.zeros((c.nbody, 3)), np.zeros((c.nbody, 4))
        L = float(np.max(c.leg_length))
        for drop in (0.04, 0.08, 0.12):
            goals.clear()
            for f in feet:
                goals.set(f, c.body_rest_pos[f], c.body_rest_rot[f], 1.0, 1.0)
            root = c.body_rest_pos[0] - np.array([0.0, 0.0, drop * L])
            solve_ik(plan, root, c.body_rest_rot[0], goals, out_p, out_r, scratch)
            assert np.all(np.isfinite(out_p))
            worst = max(worst, float(np.max(np.linalg.norm(out_p[feet] - c.body_rest_pos[feet], axis=1))) / L)
    assert tested >= 8
    if splay > 0:
        assert worst < 1e-6, worst
    else:
        assert worst > 1e-3, worst
