"""The Particle IK solver's four objectives (Hecker et al. 2008, section 4.3), measured on
the library creatures and on random creatures (engine.model.random):

1. accuracy in the workspace: goals within 95% of a limb's reach are met within 1% of
   the limb's length;
2. graceful failure: out-of-reach goals point the limb at them within its stretch limit,
   conflicting goals settle between, implausible goals fold nothing;
3. path independence: the pose depends only on the current goals (to 1e-9);
4. continuity: a goal swept across and beyond the workspace gives a smooth pose, no
   elbow/knee flips and no pop as reach approaches 1.
"""

from __future__ import annotations

import glob
import math
import os
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import engine
from engine.ik import IKParams, IKSolver, selfcollision
from engine.ik import _kernels as K
from engine.ik.solver import pose_free_rigid
from engine.ik.testing import arm_chain_creature, humanoid_creature, joint_world, random_reachable_pose
from engine.model import build_creature
from engine.model.caps import FOOT, GRASPER, HEAD, MOUTH
from engine.model.random import random_creature_def
from engine.validation.thresholds import BY_METRIC

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LIBRARY = sorted(glob.glob(os.path.join(ROOT, "creatures", "*.yaml")))


def random_creature(seed):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return build_creature(random_creature_def(seed))


def goal_bodies(c):
    """The bodies animations pose: leaf graspers, feet, heads and mouths."""
    return [b for b in range(1, c.nbody)
            if not c.body_is_spine[b] and c.body_child_num[b] == 0
            and int(c.body_caps[b]) & (GRASPER | FOOT | HEAD | MOUTH)]


def limb_goals(c, s):
    return [g for g in goal_bodies(c) if c.body_limb_length[g] > 0 and g not in s.plan.delegated]


def rest_root(c):
    return c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy()


def colliding_limbs(c, plan, pos, rot):
    """Limbs with a body inside another body of the creature (deeper than at rest) in the
    pose, or within half a radius of it: self-collision (on by default, issue 16) stops
    their goals at the surface, so the accuracy and reach objectives do not apply to them
    (tests/test_ik_selfcollision.py tests what happens there)."""
    pos, rot = pos.copy(), rot.copy()
    pose_free_rigid(plan, pos, rot)    # as the solver sees the bodies it leaves to the caller
    excess = selfcollision.pose_excess(plan, pos, rot, margin=0.5)
    bodies = plan.self_collision_pairs[excess > 0.0].reshape(-1)
    return {int(c.body_limb[b]) for b in bodies if not c.body_is_spine[b]}


def kneeless(c, g):
    """Whether ``g``'s limb is one rigid segment from its root's joint to ``g``'s joint (a
    stilt: the goal's distance from the root joint is always the limb's length)."""
    return int(c.body_parent[g]) == int(c.limb_root[c.body_limb[g]])


def accuracy_worst(c, rng, trials):
    """Worst error / limb length over goals within 95% of reach (goals read back from a
    random forward-kinematic pose, so they are reachable together; limbs that pose puts
    inside the body are left out). A knee-less limb's goal is always at its full length,
    which the limb reaches by its shape (no knee to straighten, no soft-reach easing to ask
    for): it is checked at any reach."""
    gb = goal_bodies(c)
    if not gb:
        return 0.0, 0
    s = IKSolver(c, gb)
    worst, n, worst_at = 0.0, 0, ""
    t = -1
    # up to six more poses, bent more, for a creature none of whose goals came inside 95%
    while t + 1 < trials or (n == 0 and t + 1 < trials + 6):
        t += 1
        # every other pose bends the limbs more, so limbs that are straight at rest (their
        # goals past 95% of reach at a slight bend) get goals inside the workspace too
        pos, rot, _ = random_reachable_pose(c, rng, max_bend=0.6 if t % 2 == 0 else 1.2 if t < trials else 2.0,
                                            rigid=set(s.plan.delegated))
        s.goals.clear()
        for g in gb:
            s.goals.set(g, pos=pos[g], rot=rot[g], rot_weight=1.0 if t % 2 == 0 else 0.0)
        s.solve(*rest_root(c))
        assert np.all(np.isfinite(s.out_pos[s.plan.ik_bodies]))
        inside = colliding_limbs(c, s.plan, pos, rot)
        for g in limb_goals(c, s):
            if c.body_limb[g] in inside:
                continue
            L = c.body_limb_length[g]
            lr = c.limb_root[c.body_limb[g]]
            if not kneeless(c, g) and \
                    np.linalg.norm(joint_world(c, pos, rot, g) - joint_world(c, pos, rot, lr)) > 0.95 * L:
                continue
            err = float(np.linalg.norm(s.out_pos[g] - pos[g]) / L)
            if err > worst:
                worst, worst_at = err, f"{c.body_names[g]}{' (knee-less)' if kneeless(c, g) else ''}"
            n += 1
    accuracy_worst.at = worst_at
    return worst, n


# -- 1. accuracy ------------------------------------------------------------------------


KNEELESS_MISS = ("a knee-less limb's goal is met only if the body the limb hangs from is where the goal's pose "
                 "put it; the spine phase places that body as a compromise between all goals and the limb phase "
                 "can only turn a rigid limb, not shorten it: the IK should delegate a one-segment limb's goal "
                 "to the spine as it does one-body limbs' (engine/ik plan and kernels, the IK helpers')")
ACCURACY_KNOWN = {
    "centipede.yaml": f"foot8_l missed by 0.345 of its length: {KNEELESS_MISS}",
    "hopper.yaml": f"hand_r missed by 0.0149 of its length: {KNEELESS_MISS}",
    "spider.yaml": f"palptip_l missed by 0.202 of its length: {KNEELESS_MISS}",
    71: f"head0 missed by 0.0210 of its length: {KNEELESS_MISS}",
    131: "leg0_r_b_foot (a fork toe) missed by 0.0147 of its length in a pose bent 1.2 rad: fork siblings "
         "share a parent the IK places for both",
    148: "leg0_r_foot missed by 0.0203 of its length in a pose bent 1.2 rad, every goal read back from one "
         "forward-kinematic pose (reachable together)",
    122: "no goal checked: its only arm is nearly straight in every random pose tried (0.94-0.99 of its reach); "
         "the pose generator, not the IK",
}


def _accuracy_params(keys, ids):
    return [pytest.param(k, id=i, marks=[pytest.mark.xfail(strict=True, raises=AssertionError,
                                                           reason=ACCURACY_KNOWN[os.path.basename(str(k))
                                                                                 if isinstance(k, str) else k])]
                         if (os.path.basename(k) if isinstance(k, str) else k) in ACCURACY_KNOWN else [])
            for k, i in zip(keys, ids, strict=True)]


@pytest.mark.parametrize("path", _accuracy_params(LIBRARY, [os.path.basename(p) for p in LIBRARY]))
def test_accuracy_library(path):
    c = engine.load_creature(path)
    worst, n = accuracy_worst(c, np.random.default_rng(1), 6)
    _assert_checked(c, n, 6)
    assert worst <= 0.01, f"{c.name}: worst goal error {worst:.4f} of limb length at {accuracy_worst.at}"


def _assert_checked(c, n, trials):
    """A creature with limb goals must have had goals checked (none skipped them all)."""
    gb = goal_bodies(c)
    limbs = [g for g in gb if c.body_limb_length[g] > 0] if gb else []
    if limbs:
        assert n > 0, f"{c.name}: no goal checked over {trials} poses of {len(limbs)} limb goals"


@pytest.mark.parametrize("seed", _accuracy_params(list(range(200)), [str(k) for k in range(200)]))
def test_accuracy_200_random_creatures(seed):
    c = random_creature(seed)
    worst, n = accuracy_worst(c, np.random.default_rng(2000 + seed), 2)
    _assert_checked(c, n, 2)
    assert worst <= 0.01, f"random creature {seed}: worst goal error {worst:.4f} of limb length at {accuracy_worst.at}"


# -- 2. graceful failure ----------------------------------------------------------------


def limb_lengths_ok(c, s):
    """Every limb constraint of the plan within its projection range (no hyperextension,
    no collapse) and every spine particle within the spine's range."""
    a = s.plan.arrays
    p = s.plan.params
    for i in range(a.lp_body.shape[0]):
        con = a.lp_con[i]
        if con < 0:
            continue
        b, pb = a.lp_body[i], a.lp_body[a.lp_parent[i]]
        rest = a.lc_len[con]
        if a.lp_mode[i] == 3:  # a tip: the body's origin, rigid on its joint
            L = np.linalg.norm(s.out_pos[b] - joint_world(c, s.out_pos, s.out_rot, b))
            assert abs(L - rest) <= 1e-9 * max(1.0, rest)
            continue
        L = np.linalg.norm(joint_world(c, s.out_pos, s.out_rot, b) - joint_world(c, s.out_pos, s.out_rot, pb))
        assert p.limb_shrink * rest - 1e-9 <= L <= p.limb_stretch * rest + 1e-9


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 10_000), direction_seed=st.integers(0, 1000))
def test_out_of_reach_points_at_goal_within_stretch(seed, direction_seed):
    c = random_creature(seed)
    gb = goal_bodies(c)
    if not gb:
        return
    s = IKSolver(c, gb)
    rng = np.random.default_rng(direction_seed)
    rp, rr = rest_root(c)
    goals = {}
    for g in limb_goals(c, s):
        lr = c.limb_root[c.body_limb[g]]
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        goals[g] = c.body_joint[lr] + d * 3.0 * c.body_limb_length[g]
        s.goals.set(g, pos=goals[g])
    s.solve(rp, rr)
    assert np.all(np.isfinite(s.out_pos[s.plan.ik_bodies])) and np.all(np.isfinite(s.out_rot[s.plan.ik_bodies]))
    limb_lengths_ok(c, s)
    # a limb pointing through the body (as it would without self-collision) is stopped
    # at its surface instead: pointing is checked on the others
    off = IKSolver(c, gb, IKParams(self_collision=False))
    for g, goal in goals.items():
        off.goals.set(g, pos=goal)
    off.solve(rp, rr)
    inside = colliding_limbs(c, s.plan, off.out_pos, off.out_rot)
    p = s.plan.params
    for g, goal in goals.items():
        if sum(1 for h in goals if c.body_limb[h] == c.body_limb[g]) > 1:
            continue  # a branching limb whose goals pull its branches apart: a conflict instead
        if c.body_limb[g] in inside:
            continue
        lr = c.limb_root[c.body_limb[g]]
        attach = joint_world(c, s.out_pos, s.out_rot, lr)
        # Pointing: the body's origin lies on the line to the goal (within 15 degrees, the
        # end body keeping its rest angle to its parent) ...
        u, v = s.out_pos[g] - attach, goal - attach
        cosang = u @ v / (np.linalg.norm(u) * np.linalg.norm(v))
        assert cosang > math.cos(math.radians(15.0)), f"{c.body_names[g]} does not point at its goal"
        # ... and reaching: as close to the goal as the limb's stretched length allows.
        reach = (c.body_limb_length[g] + np.linalg.norm(c.body_joint_offset[g])) * p.limb_stretch
        assert np.linalg.norm(s.out_pos[g] - goal) >= np.linalg.norm(v) - reach - 1e-9
        # ... and extended: the body's origin (where the goal pulls) at least 95% of its
        # full reach from the limb's root, the whole chain straightened toward the goal.
        slot = s.plan.goal_bodies.index(g)
        full = s.plan.arrays.goal_reach[slot]
        extension = np.linalg.norm(s.out_pos[g] - attach)
        assert extension >= 0.95 * full, f"{c.body_names[g]} is not extended toward its goal"


def test_conflicting_goals_settle_between():
    """Both hands pulled 3 m apart sideways: the arms stretch within limits and the chest
    stays between them (the spine phase splits the pull)."""
    c = humanoid_creature()
    s = IKSolver(c, ["hand_l", "hand_r"])
    rp, rr = rest_root(c)
    s.goals.set(c.body("hand_l"), pos=(0.0, 1.5, 1.4))
    s.goals.set(c.body("hand_r"), pos=(0.0, -1.5, 1.4))
    s.solve(rp, rr)
    assert np.all(np.isfinite(s.out_pos[s.plan.ik_bodies]))
    limb_lengths_ok(c, s)
    chest = c.body("chest")
    assert abs(s.out_pos[chest][1]) < 0.02  # symmetric pull: no drift to one side
    # One-sided conflict: a hand goal and a foot goal far apart upward and downward.
    s = IKSolver(c, ["hand_l", "foot_l"])
    s.goals.set(c.body("hand_l"), pos=(0.0, 0.3, 3.5))
    s.goals.set(c.body("foot_l"), pos=(0.0, 0.1, -2.0))
    s.solve(rp, rr)
    assert np.all(np.isfinite(s.out_pos[s.plan.ik_bodies]))
    limb_lengths_ok(c, s)


def spine_fold(c, s):
    """Largest change, from rest, of the relative rotation between neighbouring spine bodies."""
    worst = 0.0
    chain = [b for b in c.spine_chain if s.plan.has_ik[b]]
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        rel = K.qmul(K.qconj(tuple(s.out_rot[a])), tuple(s.out_rot[b]))
        rel0 = K.qmul(K.qconj(tuple(c.body_rest_rot[a])), tuple(c.body_rest_rot[b]))
        d = abs(float(np.dot(rel, rel0)))
        worst = max(worst, 2.0 * math.acos(min(1.0, d)))
    return worst


@pytest.mark.parametrize("name", ["humanoid", "dog", "spider", "longspine", "snake"])
def test_implausible_goals_do_not_fold(name):
    """Goals inside the body and behind the back: finite, limbs within their stretch
    range, and no spine joint folded by more than 90 degrees over its rest bend."""
    c = engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))
    gb = goal_bodies(c)
    s = IKSolver(c, gb)
    rp, rr = rest_root(c)
    size = float(np.max(c.size))
    for case in ("inside", "behind"):
        s.goals.clear()
        for g in gb:
            if case == "inside":
                goal = c.body_rest_pos[c.body_spine_attach[g]]
            else:
                goal = c.body_rest_pos[g] + np.array([-0.8 * size, 0.0, -0.3 * size])
            s.goals.set(g, pos=goal)
        s.solve(rp, rr)
        assert np.all(np.isfinite(s.out_pos[s.plan.ik_bodies]))
        limb_lengths_ok(c, s)
        assert spine_fold(c, s) < math.radians(90.0), f"{name} folds its spine ({case})"


# -- 3. path independence ---------------------------------------------------------------


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_path_independence(seed):
    c = random_creature(seed)
    gb = goal_bodies(c)
    if not gb:
        return
    s = IKSolver(c, gb)
    rng = np.random.default_rng(seed)
    rp, rr = rest_root(c)

    def set_goals(pos, rot):
        s.goals.clear()
        for g in gb:
            s.goals.set(g, pos=pos[g], rot=rot[g], rot_weight=0.5)

    pos, rot, _ = random_reachable_pose(c, rng, max_bend=0.8)
    set_goals(pos, rot)
    s.solve(rp, rr)
    fresh = s.out_pos.copy(), s.out_rot.copy()
    size = float(np.max(c.size))
    for _ in range(1000):
        p2, r2, _ = random_reachable_pose(c, rng, max_bend=1.2)
        p2 = p2 + rng.normal(scale=0.3 * size, size=p2.shape)  # in and out of reach
        set_goals(p2, r2)
        s.solve(rp + rng.normal(scale=0.1, size=3), rr)
    set_goals(pos, rot)
    s.solve(rp, rr)
    ik = s.plan.ik_bodies
    assert np.max(np.abs(s.out_pos[ik] - fresh[0][ik])) <= 1e-9
    assert np.max(np.abs(s.out_rot[ik] - fresh[1][ik])) <= 1e-9


# -- 4. continuity ----------------------------------------------------------------------


def sweep(c, s, body, start, end, steps=400):
    """Solve along a straight goal path; per-step rotation change of every IK body and the
    bend normals of every 3-joint window of ``body``'s chain."""
    rp, rr = rest_root(c)
    chain = []
    b = body
    while not c.body_is_spine[b]:
        chain.append(b)
        b = c.body_parent[b]
    chain.reverse()  # limb root ... body
    prev_rot = None
    max_step = 0.0
    normals = []
    for k in range(steps + 1):
        goal = start + (end - start) * k / steps
        s.goals.set(body, pos=goal)
        s.solve(rp, rr)
        rot = s.out_rot[s.plan.ik_bodies].copy()
        if prev_rot is not None:
            d = np.clip(np.abs(np.sum(rot * prev_rot, axis=1)), 0.0, 1.0)
            max_step = max(max_step, float(np.max(2.0 * np.arccos(d))))
        prev_rot = rot
        joints = [joint_world(c, s.out_pos, s.out_rot, x) for x in chain]
        ns = []
        for a, m, e in zip(joints[:-2], joints[1:-1], joints[2:], strict=True):
            u, v = m - a, e - m
            n = np.cross(u, v)
            ns.append(n / (np.linalg.norm(u) * np.linalg.norm(v) + 1e-300))
        normals.append(ns)
    return max_step, normals


def assert_no_flip(normals, min_bend=0.05):
    for k in range(len(normals) - 1):
        for n0, n1 in zip(normals[k], normals[k + 1], strict=True):
            if np.linalg.norm(n0) > min_bend and np.linalg.norm(n1) > min_bend:
                assert n0 @ n1 > 0.0, f"bend side flipped at step {k}"


# Continuity with self-collision on as well as off: the hand's sweep starts inside the
# torso, so with it on the hand slides along the torso's surface as contacts come and go
# (each contact's push ramps in over a skin band, engine/ik/_collide.py).
@pytest.mark.parametrize("self_collision", [False, True], ids=["plain", "self_collision"])
@pytest.mark.parametrize("limb", ["hand_l", "foot_r"])
def test_sweep_humanoid_limb_is_smooth(limb, self_collision):
    c = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    s = IKSolver(c, [limb], IKParams(self_collision=self_collision))
    b = c.body(limb)
    lr = c.limb_root[c.body_limb[b]]
    attach = c.body_joint[lr]
    reach = c.body_limb_length[b]
    rest = c.body_rest_pos[b]
    d = (rest - attach) / np.linalg.norm(rest - attach)
    # From close to the attachment, through full reach, to 1.6x reach, with a sideways drift.
    side = np.cross(d, [1.0, 0.0, 0.0])
    start = attach + 0.3 * reach * d + 0.1 * reach * side
    end = attach + 1.6 * reach * d - 0.1 * reach * side
    max_step, normals = sweep(c, s, b, start, end)
    # 400 steps over ~1.3 reach: a smooth pose turns far less than 0.1 rad per step;
    # a knee pop near full reach would be a jump of several tenths.
    assert max_step < 0.1, f"largest rotation step {max_step:.3f} rad"
    assert_no_flip(normals)


# The profile decides the draws (tests/conftest.py): derandomized in CI, so a run does not
# pass or fail by the luck of its draw; fresh with --hypothesis-profile=explore.
# test_sweep_fresh_draws_report below draws 50 new cases a day and reports what it finds.
@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 10_000), direction_seed=st.integers(0, 1000))
def test_sweep_random_creature_is_smooth(seed, direction_seed):
    c = random_creature(seed)
    gb = [g for g in goal_bodies(c) if c.body_limb_length[g] > 0]
    if not gb:
        return
    rng = np.random.default_rng(direction_seed)
    body = gb[int(rng.integers(len(gb)))]
    _assert_smooth_sweep(c, body, rng)


def _assert_smooth_sweep(c, body, rng, params=None, bound=None):
    """Sweep a lone goal on ``body`` from near its limb's attachment to past full reach,
    with a sideways drift drawn from ``rng``: no pose jump, no bend flip."""
    s = IKSolver(c, [body], params or IKParams())
    if body in s.plan.delegated:
        return
    lr = c.limb_root[c.body_limb[body]]
    attach = c.body_joint[lr]
    reach = c.body_limb_length[body]
    d = c.body_joint[body] - attach
    d /= np.linalg.norm(d)
    side = rng.normal(size=3)
    side -= (side @ d) * d
    side /= np.linalg.norm(side)
    start = attach + 0.4 * reach * d + 0.2 * reach * side
    end = attach + 1.5 * reach * d - 0.2 * reach * side
    max_step, normals = sweep(c, s, body, start, end)
    assert max_step < (bound or SWEEP_STEP_BOUND), f"largest rotation step {max_step:.3f} rad"
    assert_no_flip(normals)


#: A sweep step is one 60 Hz frame of a goal moving about a sixth of the limb's reach per
#: second, which asks the limb to turn a few thousandths of a radian a step: a body turning
#: a quarter radian in one frame is the jerk a viewer notices on a limb (the grid's
#: rotation_pop warning, engine/validation/thresholds.py).
SWEEP_STEP_BOUND = BY_METRIC["rotation_pop"].warn


def test_sweep_fresh_draws_report(record_property):
    """Fifty fresh (creature, limb, drift) draws a day, from a seed made of the date: the
    random creatures' sweeps that are not smooth are reported (printed, and recorded as
    the ``fresh_sweep_failures`` property), never failed, so new cases surface in CI logs
    without a run passing or failing by the luck of its draw. Reproduce one with
    ``_assert_smooth_sweep(random_creature(seed), body, np.random.default_rng(direction_seed))``."""
    import datetime

    day = int(datetime.date.today().strftime("%Y%m%d"))
    draws = np.random.default_rng(day)
    found, ran = [], 0
    for _ in range(50):
        seed, direction_seed = int(draws.integers(0, 10_000)), int(draws.integers(0, 1000))
        c = random_creature(seed)
        gb = [g for g in goal_bodies(c) if c.body_limb_length[g] > 0]
        if not gb:
            continue
        rng = np.random.default_rng(direction_seed)
        body = gb[int(rng.integers(len(gb)))]
        if _on_fork(c, body):
            continue
        ran += 1
        try:
            _assert_smooth_sweep(c, body, rng)
        except AssertionError as exc:
            found.append(f"seed={seed} direction_seed={direction_seed} body={c.body_names[body]}: {exc}".splitlines()[0])
    record_property("fresh_sweep_failures", found)
    print(f"fresh sweep draws (day seed {day}): {ran} run, {len(found)} not smooth")
    for line in found:
        print("  " + line)
    assert ran > 0


def test_six_joint_chain_reaches_and_stays_smooth():
    c = arm_chain_creature(6)
    hand = c.nbody - 1
    s = IKSolver(c, [hand])
    attach = c.body_joint[1]
    reach = c.body_limb_length[hand]
    start = attach + np.array([0.3, 0.4, 0.2]) * reach / np.linalg.norm([0.3, 0.4, 0.2]) * 0.3
    end = attach + np.array([1.0, -0.2, 0.3]) / np.linalg.norm([1.0, -0.2, 0.3]) * 1.4 * reach
    max_step, normals = sweep(c, s, hand, start, end)
    assert max_step < 0.1
    assert_no_flip(normals)


def test_sweep_random_creature_with_self_collision_is_smooth():
    """Random creature 58's leg3_l_foot swept from near its hip past full reach with
    self-collision on turns a body 0.21 rad in its largest step (leg3_l_seg2, the contact
    switching on) with the paper's rebuild (``parent_twist=False``): under the sweep bound
    (the grid's flip warning), so smooth; without self-collision it is smoother still.
    With the default rebuild the same step is 0.38 rad: seg2 is carried by its parent,
    whose chord the contact swings in that step, and adds its own turn to it. That is under
    the grid's flip line (rotation_pop fail, 0.5) but over the warning: self-collision's
    contacts switching on in one step is what to smooth (it is off by default)."""
    c = random_creature(58)
    gb = [g for g in goal_bodies(c) if c.body_limb_length[g] > 0]
    rng = np.random.default_rng(70)
    body = gb[int(rng.integers(len(gb)))]
    assert not _on_fork(c, body)
    _assert_smooth_sweep(c, body, rng, IKParams(self_collision=True, parent_twist=False))
    rng = np.random.default_rng(70)
    rng.integers(len(gb))
    _assert_smooth_sweep(c, body, rng, IKParams(self_collision=True), bound=BY_METRIC["rotation_pop"].fail)


def _on_fork(c, body) -> bool:
    """Whether ``body`` hangs below a limb body with two or more children."""
    b = int(c.body_parent[body])
    while b >= 0 and not c.body_is_spine[b]:
        if c.body_child_num[b] >= 2:
            return True
        b = int(c.body_parent[b])
    return False


def test_sweep_branching_leg_foot_is_smooth():
    """A position-only goal on one foot of a branching leg (random creature 78,
    leg2_l_a_foot; hypothesis found it) used to spin the foot 5 rad over 3% of reach near
    0.58 reach: its free joint particle swung round the line from its parent's joint to
    the tip. ``_seat_free_joints`` now seats it where the rest shape puts it."""
    _known_sweep_case(78, on_fork=True)


# (random creature 2759's leg1_l_a_foot turns at most 0.236 rad in a step and 881's spine
# 0.209: under the bound, the grid's rotation_pop warning, so they left the known lists)


@pytest.mark.parametrize("seed", [7759])
def test_sweep_past_reach_keeps_the_spine_smooth(seed):
    """Was a known case: a serial leg's lone goal swept past full reach (1.04-1.17 reach;
    random creature 7759) turned a spine body 0.876 rad in one step (the chords dragged the
    spine's first particle about the root and the anti-buckling blend engaged abruptly).
    With the root's spine child held where the root's frame puts its joint, it is smooth."""
    _known_sweep_case(seed, on_fork=False)


def _known_sweep_case(seed: int, on_fork: bool) -> None:
    """The sweep of a pinned known case: random creature ``seed``, the limb goal body its
    first draw picks (on a fork or not, as the case says)."""
    c = random_creature(seed)
    gb = [g for g in goal_bodies(c) if c.body_limb_length[g] > 0]
    rng = np.random.default_rng(1)
    body = gb[int(rng.integers(len(gb)))]
    assert _on_fork(c, body) == on_fork
    _assert_smooth_sweep(c, body, rng)


@pytest.mark.parametrize("creature,animation", [("bat", "pound_ground"), ("trex", "dance")])
def test_position_goal_fading_in_keeps_braced_hand_steady(creature, animation):
    """Grid cells where a hand with a position goal and no rotation goal (the bat's
    thumb, the trex's hand: braced tips, bent at rest) fades in: its free joint particle
    used to swing round to the other side of the wrist-to-tip line in one frame (2.7 and
    0.9 rad in one 60 Hz frame). No IK body may turn more than the grid's rotation_pop
    bound, 0.5 rad per frame, anywhere in the clip."""
    from engine.anim import load_animation
    from engine.validation.record import record_cell

    c = engine.load_creature(os.path.join(ROOT, "creatures", f"{creature}.yaml"))
    a = load_animation(os.path.join(ROOT, "animations", f"{animation}.yaml"))
    rec = record_cell(c, a, 0)
    n = rec.end_frame
    rot = rec.world_rot[:n]
    d = np.clip(np.abs(np.sum(rot[1:] * rot[:-1], axis=-1)), 0.0, 1.0)
    step = 2.0 * np.arccos(d)
    driven = rec.driven[1:n] & rec.driven[:n - 1]
    driven[:, 0] = False
    worst = float(np.max(np.where(driven, step, 0.0)))
    assert worst < 0.5, f"an IK body turns {worst:.2f} rad in one frame"


@pytest.mark.parametrize("name", ["humanoid", "longspine"])
def test_a_buckled_spine_still_turns_its_head_to_its_goal(name):
    """Anti-buckling blends the spine's shape toward rest; a spine body's own rotation goal
    (a look-at) turns the body about its joint after that shape is made, so it is met
    whatever the buckling. It used to fade with the buckling too: a head told to look at a
    fruit while the arm's reach folded the spine looked 1.9 rad away from it (random 4246
    pick_fruit; the grid's lookat_miss failing on 16 cells)."""
    c = engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))
    size = float(np.max(c.size))
    head = next(b for b in range(c.nbody) if c.has_cap(b, "head"))
    ends = [b for b in range(c.nbody) if c.has_cap(b, "grasper") or c.has_cap(b, "foot")]
    s = IKSolver(c, ends + [head])
    for g in ends:   # every hand and foot far behind and below: the spine buckles
        s.goals.set(g, pos=c.body_rest_pos[g] + np.array([-0.8 * size, 0.0, -0.3 * size]))
    a = math.radians(20.0)
    q = np.array(K.qmul((math.cos(a), 0.0, 0.0, math.sin(a)), tuple(c.body_rest_rot[head])))
    s.goals.set(head, rot=q, pos_weight=0.0)
    rp, rr = rest_root(c)
    s.solve(rp, rr)
    assert s.scratch[s.plan.arrays.scratch_layout[7], 0] > 0.3          # buckled
    miss = 2.0 * math.acos(min(1.0, abs(float(np.dot(s.out_rot[head], q)))))
    assert miss < 1e-6
