"""The canned IK scene of ``tests/test_ik_ground.py``: library creatures solved with goals
that take bodies into the ground (the root lowered, limbs bent at random). Run as a script
on a checkout from before the ground constraint to write the reference poses it must
reproduce with ``IKParams(ground=False)``:

    PYTHONPATH=$PWD python tests/ik_ground_scene.py tests/data/ik_ground_off_reference.npz
"""

from __future__ import annotations

import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

#: (creature file, root height as a share of its rest height, goal bodies (None: every leaf))
CASES = (("humanoid.yaml", 0.55, ("hand_l", "hand_r", "foot_l", "foot_r", "head")),
         ("octopus.yaml", 0.8, None), ("gorilla.yaml", 0.6, None))
NSET = 4


def _low(q, ext):
    """Lowest corner height of a box of half extents ``ext`` turned by ``q``, from its centre."""
    w, x, y, z = q
    row = np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])   # z row of R(q)
    return -float(np.abs(row) @ ext)


def _floor(c):
    """min(0, rest lowest corner) per body (``engine.ik.plan.body_floor``, written out here
    so the scene runs on a checkout from before it)."""
    return np.minimum([c.body_rest_pos[b, 2] + _low(c.body_rest_rot[b], c.body_extent[b]) for b in range(c.nbody)],
                      0.0)


def scene(params=None):
    """Yield (name, k, plan, root_pos, root_rot, goals) for every case and goal set."""
    import engine
    from engine.ik import IKGoals, IKParams, plan_for
    from engine.ik.testing import random_reachable_pose

    for fname, drop, names in CASES:
        c = engine.load_creature(os.path.join(HERE, "creatures", fname))
        if names is None:
            leaves = [b for b in range(1, c.nbody) if int(c.body_subtree_end[b]) == b + 1]
            goal_bodies = [b for b in leaves if not c.body_is_spine[b]] or leaves
        else:
            goal_bodies = [c.body(n) for n in names]
        plan = plan_for(c, goal_bodies, IKParams(ground=True) if params is None else params)
        rng = np.random.default_rng(7)
        root_rot = np.ascontiguousarray(c.body_rest_rot[0], np.float64)
        root_pos = np.ascontiguousarray(c.body_rest_pos[0] * np.array([1.0, 1.0, drop]), np.float64)
        for k in range(NSET):
            pos, rot, _ = random_reachable_pose(c, rng, root_pos=root_pos, root_rot=root_rot, max_bend=0.7,
                                                rigid=set(plan.delegated))
            goals = IKGoals(c.nbody)
            floor = _floor(c)
            for g in goal_bodies:
                # goals out of the ground as a standing character's are (goals_above_ground)
                p = pos[g].copy()
                p[2] += max(0.0, floor[g] - (p[2] + _low(rot[g], c.body_extent[g])))
                goals.set(g, pos=p, rot=rot[g])
            yield c.name, k, plan, root_pos, root_rot, goals


def solve_scene(params=None):
    """{"name/k/pos": (nbody, 3), "name/k/rot": (nbody, 4)} of every solve of the scene."""
    from engine.ik import solve_ik

    out = {}
    for name, k, plan, root_pos, root_rot, goals in scene(params):
        n = plan.creature.nbody
        p = np.zeros((n, 3))
        r = np.zeros((n, 4))
        r[:, 0] = 1.0
        solve_ik(plan, root_pos, root_rot, goals, p, r, plan.make_scratch())
        out[f"{name}/{k}/pos"] = p
        out[f"{name}/{k}/rot"] = r
    return out


if __name__ == "__main__":
    np.savez_compressed(sys.argv[1], **solve_scene())
    print("wrote", sys.argv[1])
