"""Particle IK benchmark: solve time, batch time, accuracy, and a 6-joint chain against ikpy.

    .venv/bin/python benchmarks/ik.py [--solves 4000] [--batch 256] [--ikpy 40]

Prints a table and ends with one JSON line. Figures (all measured in this run):
- ``solve_us_median``: one ``solve_ik`` call (the public entry, input checks included) on
  the library humanoid (25 bodies) with 5 goals (hands, feet, head; position + rotation),
  random reachable goals, median over many calls;
- ``batch_us_per_solve``: ``solve_ik_batch`` over a crowd of independent characters;
- ``reach_error_rel_max``: worst goal error / limb length over goals within 95% of reach;
- ``chain_solve_us_median``: our solver on a 6-joint arm (``arm_chain_creature(6)``: six
  *ball* joints, 18 degrees of freedom), ``ikpy_solve_us_median``: ikpy on six *revolute*
  joints (6 degrees of freedom: not equal terms) and the same targets, and their ratio;
  ``ikpy_ball_*``: ikpy on the same 18 degrees of freedom (three revolute joints per ball
  joint), the comparison on equal terms; ``pybullet_*``: PyBullet's
  ``calculateInverseKinematics`` (C++, damped least squares) on the 6 revolute joints at
  its default 20 iterations, ``pybullet_100_*`` at 100, ``pybullet_ball_*`` on the 18;
  time and worst tip error side by side (``--ikpy 0`` skips the chain);
- ``ground_us``: what the ground constraint (``IKParams.ground``, off by default) adds to one
  solve: median of the same solves (root at rest, plane z = 0) with it on minus off,
  interleaved goal set by goal set (``solve_us_median_ground_on`` / ``_off``);
- ``self_collision_us``: what the limb phase's self-collision (``IKParams.self_collision``,
  off by default until the IK tests pass with it) adds to one solve: median of the same solves with it on minus off,
  interleaved goal set by goal set; ``reach_error_rel_max_no_self_collision``: the
  accuracy figure with it off (random reachable poses are drawn without regard to the
  body, so some put a hand inside the torso, where it now stops at the surface);
- ``parent_twist_us``: what the limb rebuild's reference through the parent's frame
  (``IKParams.parent_twist``, on by default) costs over the paper's, the same way;
- ``pull_cap_us``: what easing the goals' pulls on spine particles (``IKParams.spine_pull_cap``,
  on by default) costs over pulls applied whole, the same way;
- a per-stage profile of one solve (each stage timed alone in a loop inside numba).
Requires the ``bench`` extra for ikpy and pybullet (``pip install -e .[bench]``); without
them their figures are null.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from numba import njit  # noqa: E402

import engine  # noqa: E402
from engine.ik import IKGoals, IKParams, IKSolver, plan_for, solve_ik, solve_ik_batch  # noqa: E402
from engine.ik import _kernels as K  # noqa: E402
from engine.ik.solver import GROUND_Z0  # noqa: E402
from engine.ik.testing import arm_chain_creature, joint_world, random_reachable_pose  # noqa: E402

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GOAL_NAMES = ("hand_l", "hand_r", "foot_l", "foot_r", "head")


def humanoid():
    path = os.path.join(HERE, "creatures", "humanoid.yaml")
    if os.path.exists(path):
        return engine.load_creature(path)
    from engine.ik.testing import humanoid_creature
    return humanoid_creature()


def make_goal_sets(c, goal_bodies, rigid, n, rng, rot_weight=1.0):
    sets = []
    for _ in range(n):
        pos, rot, _ = random_reachable_pose(c, rng, max_bend=0.6, rigid=rigid)
        sets.append((pos, rot))
    return sets


def fill(goals, goal_bodies, pos, rot, rot_weight=1.0, index=None):
    goals.clear() if index is None else None
    for g in goal_bodies:
        goals.set(g, pos=pos[g], rot=rot[g], rot_weight=rot_weight, index=index)


def time_calls(fn, reps, inner=10):
    ts = np.empty(reps)
    for r in range(reps):
        t = time.perf_counter()
        for _ in range(inner):
            fn()
        ts[r] = (time.perf_counter() - t) / inner * 1e6
    return ts


@njit(_nrt=False)   # compiled as the solve is (engine/ik/_kernels.py: no reference counts)
def _stage_loop(pi, pf, pf3, pf4, root_pos, root_rot, goal_pos, goal_rot, gpw, grw, out_pos, out_rot, scratch,
                stage, n):
    P = K.unpack(pi, pf, pf3, pf4)
    (sp_pos, sp_inv, lp_pos, lp_rest, lp_inv, goal_joint, ch_tan, state, dg_target, sp_acc, lg_target,
     lg_jtarget, segbody_tp, segbody_lift) = K._scratch_views(P, scratch)
    rp = (root_pos[0], root_pos[1], root_pos[2])
    rr = (root_rot[0], root_rot[1], root_rot[2], root_rot[3])
    acc = 0
    for _ in range(n):
        if stage == 0:
            P2 = K.unpack(pi, pf, pf3, pf4)
            acc += P2.sp_kind.shape[0]
        elif stage == 1:
            acc += K.check_inputs(P, root_pos, root_rot, goal_pos, goal_rot, gpw, grw)
        elif stage == 2:
            K._goal_targets(P, rp, rr, goal_pos, goal_rot, gpw, grw, goal_joint)
            K._delegated_targets(P, goal_rot, grw, goal_joint, dg_target)
        elif stage == 3:
            K._spine_phase(P, rp, rr, gpw, grw, goal_joint, dg_target, sp_pos, sp_inv, state, sp_acc, True,
                           (0.0, 0.0, 1.0), 0.0)
        elif stage == 4:
            K._spine_reconstruct(P, rp, rr, gpw, goal_rot, grw, sp_pos, ch_tan, segbody_tp, out_pos, out_rot,
                                  state[0], True, (0.0, 0.0, 1.0), 0.0, segbody_lift)
            K._place_rigid(P, out_pos, out_rot)
        elif stage == 5:
            K._limb_phase(P, goal_pos, gpw, goal_rot, grw, goal_joint, lp_pos, lp_rest, lp_inv, out_pos, out_rot,
                          lg_target, lg_jtarget, scratch, True, (0.0, 0.0, 1.0), 0.0)
    return acc


STAGES = ("unpack plan", "check inputs", "goal targets", "spine phase", "spine reconstruct", "limb phase")


def stage_profile(solver, root_pos, root_rot):
    g = solver.goals
    args = (*solver.plan.blobs, root_pos, root_rot, g.goal_pos, g.goal_rot, g.goal_pos_weight, g.goal_rot_weight,
            solver.out_pos, solver.out_rot, solver.scratch)
    # Run the whole solve first so every stage sees the state it sees in a real solve.
    K.solve_packed(*args, GROUND_Z0)
    out = {}
    for k, name in enumerate(STAGES):
        _stage_loop(*args, k, 5)
        best = []
        for _ in range(7):
            K.solve_packed(*args, GROUND_Z0)
            t = time.perf_counter()
            _stage_loop(*args, k, 500)
            best.append((time.perf_counter() - t) / 500 * 1e6)
        out[name] = float(np.median(best))
    return out


AXES = (np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))


def chain_joints(c, ball: bool):
    """The joints of the arm of ``arm_chain_creature`` for the peers: (translation from
    the previous joint, axis) per revolute joint, and the tip's offset from the last joint.
    ``ball=False``: one revolute joint per body joint, axes alternating z, y, x so the arm
    can reach in 3-D (6 degrees of freedom); ``ball=True``: three (z, y, x) at each body
    joint, the same 18 degrees of freedom as our ball-jointed chain."""
    out = []
    prev = np.zeros(3)
    for b in range(1, c.nbody):
        j = c.body_joint[b]
        axes = AXES if ball else (AXES[(b - 1) % 3],)
        for k, axis in enumerate(axes):
            out.append((j - prev if k == 0 else np.zeros(3), axis))
        prev = j
    return out, c.body_rest_pos[c.nbody - 1] - prev


def ikpy_chain(c, ball: bool = False):
    """The arm as an ikpy chain (``chain_joints``), a fixed tip at the hand's origin."""
    from ikpy.chain import Chain
    from ikpy.link import OriginLink, URDFLink

    joints, tip = chain_joints(c, ball)
    links = [OriginLink()]
    for k, (t, axis) in enumerate(joints):
        links.append(URDFLink(name=f"j{k}", origin_translation=t, origin_orientation=np.zeros(3), rotation=axis,
                              bounds=(-np.pi, np.pi)))
    links.append(URDFLink(name="tip", origin_translation=tip, origin_orientation=np.zeros(3), rotation=None,
                          joint_type="fixed"))
    mask = [False] + [True] * len(joints) + [False]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Chain(links, active_links_mask=mask)


def chain_urdf(c, ball: bool) -> str:
    """The arm as URDF text for PyBullet (``chain_joints``; massless-looking links: IK
    only reads the kinematics)."""
    joints, tip = chain_joints(c, ball)
    inertial = ('<inertial><mass value="0.1"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" '
                'izz="1e-4"/></inertial>')
    parts = ['<?xml version="1.0"?>', '<robot name="arm">', f'<link name="l0">{inertial}</link>']
    for k, (t, axis) in enumerate(joints):
        parts.append(f'<link name="l{k + 1}">{inertial}</link>')
        parts.append(f'<joint name="j{k}" type="revolute"><parent link="l{k}"/><child link="l{k + 1}"/>'
                     f'<origin xyz="{t[0]:.9g} {t[1]:.9g} {t[2]:.9g}" rpy="0 0 0"/>'
                     f'<axis xyz="{axis[0]:g} {axis[1]:g} {axis[2]:g}"/>'
                     f'<limit lower="-3.14159" upper="3.14159" effort="10" velocity="10"/></joint>')
    n = len(joints)
    parts.append(f'<link name="tip">{inertial}</link>')
    parts.append(f'<joint name="tip" type="fixed"><parent link="l{n}"/><child link="tip"/>'
                 f'<origin xyz="{tip[0]:.9g} {tip[1]:.9g} {tip[2]:.9g}" rpy="0 0 0"/></joint>')
    parts.append("</robot>")
    return "\n".join(parts)


def pybullet_benchmark(c, targets, ball: bool, iterations: int):
    """PyBullet's ``calculateInverseKinematics`` (C++, damped least squares) on the arm:
    median time per call and the tip's error (m) after setting the joints it returns;
    each call starts from the zero pose, as ours and ikpy's do. None without pybullet."""
    try:
        import pybullet as pb
    except ImportError:
        return None
    import tempfile

    cid = pb.connect(pb.DIRECT)
    try:
        with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
            f.write(chain_urdf(c, ball))
            path = f.name
        base = np.asarray(c.body_rest_pos[0]) * 0.0      # the chain's origin is the world origin
        body = pb.loadURDF(path, basePosition=base.tolist(), useFixedBase=True, physicsClientId=cid)
        os.unlink(path)
        nj = pb.getNumJoints(body, physicsClientId=cid)
        tip = nj - 1
        movable = [j for j in range(nj) if pb.getJointInfo(body, j, physicsClientId=cid)[2] == pb.JOINT_REVOLUTE]
        times, errs = [], []
        for t in targets:
            for j in movable:
                pb.resetJointState(body, j, 0.0, physicsClientId=cid)
            t0 = time.perf_counter()
            q = pb.calculateInverseKinematics(body, tip, t.tolist(), maxNumIterations=iterations,
                                              residualThreshold=1e-6, physicsClientId=cid)
            times.append((time.perf_counter() - t0) * 1e6)
            for j, v in zip(movable, q, strict=True):
                pb.resetJointState(body, j, v, physicsClientId=cid)
            got = np.array(pb.getLinkState(body, tip, computeForwardKinematics=1, physicsClientId=cid)[4])
            errs.append(float(np.linalg.norm(got - t)))
        return dict(us=float(np.median(times)), error_median_m=float(np.median(errs)), error_max_m=float(max(errs)))
    finally:
        pb.disconnect(cid)


def _ikpy_run(chain, targets):
    times, errs = [], []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for t in targets:
            t0 = time.perf_counter()
            q = chain.inverse_kinematics(t)
            times.append((time.perf_counter() - t0) * 1e6)
            errs.append(float(np.linalg.norm(chain.forward_kinematics(q)[:3, 3] - t)))
    return float(np.median(times)), float(max(errs))


def chain_benchmark(n_targets, rng, with_ikpy):
    """Ours, ikpy and PyBullet on a 6-body arm. Ours is always the ball-jointed chain (18
    degrees of freedom); the peers run on the same 18 (``*_ball_*``: three revolute joints
    per body joint) and on 6 revolute joints (ikpy's usual model; the targets are drawn
    from it, so every target is reachable by both)."""
    c = arm_chain_creature(6)
    hand = c.nbody - 1
    none = dict(chain_solve_us_median=None, chain_error_max_m=None, chain_reach_m=None, chain_targets=0,
                ikpy_solve_us_median=None, ikpy_error_max_m=None, speedup_vs_ikpy=None,
                ikpy_ball_solve_us_median=None, ikpy_ball_error_max_m=None, speedup_vs_ikpy_ball=None,
                pybullet_solve_us_median=None, pybullet_error_median_m=None, pybullet_error_max_m=None,
                pybullet_100_solve_us_median=None, pybullet_100_error_max_m=None,
                pybullet_ball_solve_us_median=None, pybullet_ball_error_max_m=None)
    if n_targets <= 0:
        return none
    solver = IKSolver(c, [hand])
    reach = c.body_limb_length[hand] + np.linalg.norm(c.body_rest_pos[hand] - c.body_joint[hand])
    attach = c.body_joint[1]
    chain = ikpy_chain(c) if with_ikpy else None
    targets = []
    while len(targets) < n_targets:
        if chain is not None:
            q = np.zeros(len(chain.links))
            q[1:c.nbody] = rng.uniform(-0.6, 0.6, c.nbody - 1)
            t = chain.forward_kinematics(q)[:3, 3]
        else:
            pos, rot, _ = random_reachable_pose(c, rng, max_bend=0.6)
            t = pos[hand]
        if np.linalg.norm(t - attach) <= 0.95 * reach:
            targets.append(t)
    root_pos = c.body_rest_pos[0].copy()
    root_rot = c.body_rest_rot[0].copy()
    ours_err, ours_t = [], []
    for t in targets:
        solver.goals.clear()
        solver.goals.set(hand, pos=t)
        solver.solve(root_pos, root_rot)
        ours_err.append(float(np.linalg.norm(solver.out_pos[hand] - t)))
        ts = time_calls(lambda: solve_ik(solver.plan, root_pos, root_rot, solver.goals, solver.out_pos,
                                         solver.out_rot, solver.scratch), 20, 10)
        ours_t.append(float(np.median(ts)))
    res = dict(none, chain_solve_us_median=float(np.median(ours_t)), chain_error_max_m=float(max(ours_err)),
               chain_reach_m=float(reach), chain_targets=len(targets))
    ours_us = res["chain_solve_us_median"]
    if chain is not None:
        us, err = _ikpy_run(chain, targets)
        res.update(ikpy_solve_us_median=us, ikpy_error_max_m=err, speedup_vs_ikpy=us / ours_us)
        us, err = _ikpy_run(ikpy_chain(c, ball=True), targets)
        res.update(ikpy_ball_solve_us_median=us, ikpy_ball_error_max_m=err, speedup_vs_ikpy_ball=us / ours_us)
    for ball, iters, key in ((False, 20, "pybullet"), (False, 100, "pybullet_100"), (True, 20, "pybullet_ball")):
        pb = pybullet_benchmark(c, targets, ball, iters)
        if pb is not None:
            res[f"{key}_solve_us_median"] = pb["us"]
            res[f"{key}_error_max_m"] = pb["error_max_m"]
            if key == "pybullet":
                res["pybullet_error_median_m"] = pb["error_median_m"]
    return res


def _worst_reach_error(c, solver, goal_bodies, rigid, sets, root_pos, root_rot) -> float:
    """Largest position miss over the goal sets, relative to the limb's length, of the
    goals within 95% of their limb's reach."""
    worst = 0.0
    for pos, rot in sets:
        fill(solver.goals, goal_bodies, pos, rot)
        solver.solve(root_pos, root_rot)
        for g in goal_bodies:
            L = c.body_limb_length[g]
            if g in rigid or L <= 0:
                continue
            lr = c.limb_root[c.body_limb[g]]
            if np.linalg.norm(joint_world(c, pos, rot, g) - joint_world(c, pos, rot, lr)) > 0.95 * L:
                continue
            worst = max(worst, float(np.linalg.norm(solver.out_pos[g] - pos[g]) / L))
    return worst


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solves", type=int, default=4000, help="timed single solves")
    ap.add_argument("--batch", type=int, default=256, help="characters in the batched solve")
    ap.add_argument("--ikpy", type=int, default=40, help="chain targets (ikpy is slow)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)

    c = humanoid()
    goal_bodies = [c.body(n) for n in GOAL_NAMES]
    params = IKParams()
    plan = plan_for(c, goal_bodies, params)
    rigid = set(plan.delegated)
    root_pos = c.body_rest_pos[0].copy()
    root_rot = c.body_rest_rot[0].copy()
    solver = IKSolver(c, goal_bodies, params)

    # Accuracy over random reachable goal sets (goals within 95% of their limb's reach).
    t0 = time.perf_counter()
    sets = make_goal_sets(c, goal_bodies, rigid, 300, rng)
    worst = _worst_reach_error(c, solver, goal_bodies, rigid, sets, root_pos, root_rot)
    compile_and_accuracy_s = time.perf_counter() - t0
    solver_off = IKSolver(c, goal_bodies, IKParams(self_collision=False))
    plan_on = plan_for(c, goal_bodies, IKParams(self_collision=True))
    worst_off = _worst_reach_error(c, solver_off, goal_bodies, rigid, sets, root_pos, root_rot)

    # One solve, public entry point, goals varying between calls.
    per_set = max(1, args.solves // len(sets))
    samples = []
    for pos, rot in sets:
        fill(solver.goals, goal_bodies, pos, rot)
        samples.extend(time_calls(lambda: solve_ik(plan, root_pos, root_rot, solver.goals, solver.out_pos,
                                                   solver.out_rot, solver.scratch), per_set, 1))
    samples = np.array(samples)

    def paired_cost(on: IKParams, off: IKParams) -> tuple[float, np.ndarray, np.ndarray]:
        """What ``on`` adds to one solve over ``off``: the same goal sets solved with each,
        interleaved set by set (so load on the machine falls on both), median minus median."""
        runs = []
        for prm in (on, off):
            pl = plan_for(c, goal_bodies, prm)
            runs.append((pl, IKSolver(c, goal_bodies, prm), []))
        for pos, rot in sets:
            for _, sv, _ in runs:
                fill(sv.goals, goal_bodies, pos, rot)
            for _ in range(max(1, per_set // 2)):
                for pl, sv, out in runs:
                    out.extend(time_calls(lambda pl=pl, sv=sv: solve_ik(pl, root_pos, root_rot, sv.goals, sv.out_pos,
                                                                        sv.out_rot, sv.scratch), 1, 5))
        t_on, t_off = np.asarray(runs[0][2]), np.asarray(runs[1][2])
        return float(np.median(t_on) - np.median(t_off)), t_on, t_off

    self_collision_us, _, off_t = paired_cost(IKParams(self_collision=True), IKParams(self_collision=False))
    ground_us, g_on, g_off = paired_cost(IKParams(ground=True), IKParams(ground=False))
    # the rebuild's reference through the parent's frame (on by default) against the paper's
    parent_twist_us, _, _ = paired_cost(IKParams(parent_twist=True), IKParams(parent_twist=False))
    pull_cap_us, _, _ = paired_cost(IKParams(), IKParams(spine_pull_cap=0.0))
    ncl = plan_on.arrays.cl_i

    # Batched: a crowd sharing the plan.
    nb = args.batch
    bgoals = IKGoals(c.nbody, nb)
    for k in range(nb):
        pos, rot = sets[k % len(sets)]
        fill(bgoals, goal_bodies, pos, rot, index=k)
    broot_pos = np.ascontiguousarray(np.tile(root_pos, (nb, 1)))
    broot_rot = np.ascontiguousarray(np.tile(root_rot, (nb, 1)))
    bout_pos = np.zeros((nb, c.nbody, 3))
    bout_rot = np.zeros((nb, c.nbody, 4))
    scratch = plan.make_scratch()
    solve_ik_batch(plan, broot_pos, broot_rot, bgoals, bout_pos, bout_rot, scratch)
    bt = time_calls(lambda: solve_ik_batch(plan, broot_pos, broot_rot, bgoals, bout_pos, bout_rot, scratch), 30, 1)
    batch_us = float(np.median(bt)) / nb

    fill(solver.goals, goal_bodies, *sets[0])
    stages = stage_profile(solver, root_pos, root_rot)

    try:
        import ikpy  # noqa: F401
        have_ikpy = True
    except ImportError:
        have_ikpy = False
    chain = chain_benchmark(args.ikpy, rng, have_ikpy)

    res = dict(
        bodies=c.nbody, goals=len(goal_bodies), creature=c.name, ik_bodies=int(plan.ik_bodies.shape[0]),
        solve_us_median=float(np.median(samples)), solve_us_p10=float(np.percentile(samples, 10)),
        solve_us_p90=float(np.percentile(samples, 90)), batch_us_per_solve=batch_us, batch_size=nb,
        reach_error_rel_max=worst, reach_error_rel_max_no_self_collision=worst_off,
        self_collision_us=self_collision_us, solve_us_median_no_self_collision=float(np.median(off_t)),
        ground_us=ground_us, solve_us_median_ground_on=float(np.median(g_on)), parent_twist_us=parent_twist_us,
        pull_cap_us=pull_cap_us,
        solve_us_median_ground_off=float(np.median(g_off)),
        self_collision_proxies=int(ncl[0]), self_collision_pairs=int(ncl[2]), **chain,
        stage_us={k: round(v, 3) for k, v in stages.items()},
        first_run_s=round(compile_and_accuracy_s, 2), load_average=os.getloadavg()[0],
    )
    print(f"Particle IK on '{c.name}' ({c.nbody} bodies, {len(goal_bodies)} goals: {', '.join(GOAL_NAMES)})")
    print(f"{'figure':<40}{'value':>14}")
    rows = [("solve_us_median", res["solve_us_median"]), ("solve_us_p10", res["solve_us_p10"]),
            ("solve_us_p90", res["solve_us_p90"]), ("batch_us_per_solve", batch_us),
            ("reach_error_rel_max", worst), ("reach_error_rel_max_no_self_collision", worst_off),
            ("self_collision_us", self_collision_us), ("self_collision_pairs", int(ncl[2])),
            ("ground_us", ground_us), ("solve_us_median_ground_off", res["solve_us_median_ground_off"]),
            ("parent_twist_us", parent_twist_us), ("pull_cap_us", pull_cap_us),
            ("chain_solve_us_median", chain["chain_solve_us_median"]),
            ("chain_error_max_m", chain["chain_error_max_m"]),
            ("ikpy_solve_us_median", chain["ikpy_solve_us_median"]),
            ("ikpy_error_max_m", chain["ikpy_error_max_m"]), ("speedup_vs_ikpy", chain["speedup_vs_ikpy"]),
            ("ikpy_ball_solve_us_median", chain["ikpy_ball_solve_us_median"]),
            ("ikpy_ball_error_max_m", chain["ikpy_ball_error_max_m"]),
            ("speedup_vs_ikpy_ball", chain["speedup_vs_ikpy_ball"]),
            ("pybullet_solve_us_median", chain["pybullet_solve_us_median"]),
            ("pybullet_error_median_m", chain["pybullet_error_median_m"]),
            ("pybullet_error_max_m", chain["pybullet_error_max_m"]),
            ("pybullet_100_solve_us_median", chain["pybullet_100_solve_us_median"]),
            ("pybullet_100_error_max_m", chain["pybullet_100_error_max_m"]),
            ("pybullet_ball_solve_us_median", chain["pybullet_ball_solve_us_median"]),
            ("pybullet_ball_error_max_m", chain["pybullet_ball_error_max_m"])]
    for name, v in rows:
        print(f"{name:<40}{'n/a' if v is None else f'{v:14.4g}':>14}")
    print("chain: ours is 6 ball joints (18 degrees of freedom); ikpy_* and pybullet_* run 6 revolute joints "
          "(6 DoF),\n       ikpy_ball_* and pybullet_ball_* the same 18 DoF (3 revolute joints per ball joint); "
          "pybullet_* at its default 20 iterations, pybullet_100_* at 100")
    print("stage profile (us, each stage alone):")
    for k, v in stages.items():
        print(f"  {k:<26}{v:14.3f}")
    print(json.dumps(res))
    return res


if __name__ == "__main__":
    main()
