"""Particle IK benchmark: solve time, batch time, accuracy, and a 6-joint chain against ikpy.

    .venv/bin/python benchmarks/ik.py [--solves 4000] [--batch 256] [--ikpy 40]

Prints a table and ends with one JSON line. Figures (all measured in this run):
- ``solve_us_median``: one ``solve_ik`` call (the public entry, input checks included) on
  the library humanoid (25 bodies) with 5 goals (hands, feet, head; position + rotation),
  random reachable goals, median over many calls;
- ``batch_us_per_solve``: ``solve_ik_batch`` over a crowd of independent characters;
- ``reach_error_rel_max``: worst goal error / limb length over goals within 95% of reach;
- ``chain_solve_us_median``: our solver on a 6-joint arm (``arm_chain_creature(6)``),
  ``ikpy_solve_us_median``: ikpy on the same chain and targets, and their ratio;
- ``self_collision_us``: what the limb phase's self-collision (``IKParams.self_collision``,
  off by default until the IK tests pass with it) adds to one solve: median of the same solves with it on minus off,
  interleaved goal set by goal set; ``reach_error_rel_max_no_self_collision``: the
  accuracy figure with it off (random reachable poses are drawn without regard to the
  body, so some put a hand inside the torso, where it now stops at the surface);
- a per-stage profile of one solve (each stage timed alone in a loop inside numba).
Requires the ``bench`` extra for ikpy (``pip install ikpy``); without it the ikpy figures
are null.
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
     lg_jtarget) = K._scratch_views(P, scratch)
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
            K._spine_phase(P, rp, rr, gpw, grw, goal_joint, dg_target, sp_pos, sp_inv, state, sp_acc)
        elif stage == 4:
            K._spine_reconstruct(P, rp, rr, gpw, goal_rot, grw, sp_pos, ch_tan, out_pos, out_rot, state[0])
            K._place_rigid(P, out_pos, out_rot)
        elif stage == 5:
            K._limb_phase(P, goal_pos, gpw, goal_rot, grw, goal_joint, lp_pos, lp_rest, lp_inv, out_pos, out_rot,
                          lg_target, lg_jtarget, scratch)
    return acc


STAGES = ("unpack plan", "check inputs", "goal targets", "spine phase", "spine reconstruct", "limb phase")


def stage_profile(solver, root_pos, root_rot):
    g = solver.goals
    args = (*solver.plan.blobs, root_pos, root_rot, g.goal_pos, g.goal_rot, g.goal_pos_weight, g.goal_rot_weight,
            solver.out_pos, solver.out_rot, solver.scratch)
    # Run the whole solve first so every stage sees the state it sees in a real solve.
    K.solve_packed(*args)
    out = {}
    for k, name in enumerate(STAGES):
        _stage_loop(*args, k, 5)
        best = []
        for _ in range(7):
            K.solve_packed(*args)
            t = time.perf_counter()
            _stage_loop(*args, k, 500)
            best.append((time.perf_counter() - t) / 500 * 1e6)
        out[name] = float(np.median(best))
    return out


def ikpy_chain(c):
    """The arm of ``arm_chain_creature`` as an ikpy chain: a revolute joint at every body
    joint (axes alternating z, y, x so the arm can reach in 3-D), a fixed tip at the hand's
    origin."""
    from ikpy.chain import Chain
    from ikpy.link import OriginLink, URDFLink

    axes = (np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    links = [OriginLink()]
    prev = np.zeros(3)
    for b in range(1, c.nbody):
        j = c.body_joint[b]
        links.append(URDFLink(name=f"j{b}", origin_translation=j - prev, origin_orientation=np.zeros(3),
                              rotation=axes[(b - 1) % 3], bounds=(-np.pi, np.pi)))
        prev = j
    hand = c.nbody - 1
    links.append(URDFLink(name="tip", origin_translation=c.body_rest_pos[hand] - prev,
                          origin_orientation=np.zeros(3), rotation=None, joint_type="fixed"))
    mask = [False] + [True] * (c.nbody - 1) + [False]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return Chain(links, active_links_mask=mask)


def chain_benchmark(n_targets, rng, with_ikpy):
    c = arm_chain_creature(6)
    hand = c.nbody - 1
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
    res = dict(chain_solve_us_median=float(np.median(ours_t)), chain_error_max_m=float(max(ours_err)),
               chain_reach_m=float(reach))
    if chain is not None:
        ik_t, ik_err = [], []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for t in targets:
                t0 = time.perf_counter()
                q = chain.inverse_kinematics(t)
                ik_t.append((time.perf_counter() - t0) * 1e6)
                ik_err.append(float(np.linalg.norm(chain.forward_kinematics(q)[:3, 3] - t)))
        res.update(ikpy_solve_us_median=float(np.median(ik_t)), ikpy_error_max_m=float(max(ik_err)))
        res["speedup_vs_ikpy"] = res["ikpy_solve_us_median"] / res["chain_solve_us_median"]
    else:
        res.update(ikpy_solve_us_median=None, ikpy_error_max_m=None, speedup_vs_ikpy=None)
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
    plan_off = plan_for(c, goal_bodies, IKParams(self_collision=False))
    solver_off = IKSolver(c, goal_bodies, IKParams(self_collision=False))
    plan_on = plan_for(c, goal_bodies, IKParams(self_collision=True))
    solver_on = IKSolver(c, goal_bodies, IKParams(self_collision=True))
    worst_off = _worst_reach_error(c, solver_off, goal_bodies, rigid, sets, root_pos, root_rot)

    # One solve, public entry point, goals varying between calls.
    per_set = max(1, args.solves // len(sets))
    samples = []
    for pos, rot in sets:
        fill(solver.goals, goal_bodies, pos, rot)
        samples.extend(time_calls(lambda: solve_ik(plan, root_pos, root_rot, solver.goals, solver.out_pos,
                                                   solver.out_rot, solver.scratch), per_set, 1))
    samples = np.array(samples)

    # The self-collision's cost: the same solves with it on and off, interleaved.
    on_t, off_t = [], []
    for pos, rot in sets:
        fill(solver_on.goals, goal_bodies, pos, rot)
        fill(solver_off.goals, goal_bodies, pos, rot)
        for _ in range(max(1, per_set // 2)):
            on_t.extend(time_calls(lambda: solve_ik(plan_on, root_pos, root_rot, solver_on.goals, solver_on.out_pos,
                                                    solver_on.out_rot, solver_on.scratch), 1, 5))
            off_t.extend(time_calls(lambda: solve_ik(plan_off, root_pos, root_rot, solver_off.goals,
                                                     solver_off.out_pos, solver_off.out_rot, solver_off.scratch),
                                    1, 5))
    self_collision_us = float(np.median(on_t) - np.median(off_t))
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
            ("chain_solve_us_median", chain["chain_solve_us_median"]),
            ("chain_error_max_m", chain["chain_error_max_m"]),
            ("ikpy_solve_us_median", chain["ikpy_solve_us_median"]),
            ("ikpy_error_max_m", chain["ikpy_error_max_m"]), ("speedup_vs_ikpy", chain["speedup_vs_ikpy"])]
    for name, v in rows:
        print(f"{name:<40}{'n/a' if v is None else f'{v:14.4g}':>14}")
    print("stage profile (us, each stage alone):")
    for k, v in stages.items():
        print(f"  {k:<26}{v:14.3f}")
    print(json.dumps(res))
    return res


if __name__ == "__main__":
    main()
