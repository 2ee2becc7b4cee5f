"""Goal error: how far the IK's output is from the goals it was given.

Only goals the blend gave full weight (>= ``FULL``) count: a goal of weight 0.4 asks the
IK to go 40% of the way and is soft by design. Per frame and goal body:

- a body on a limb is *reachable* when its goal lies within ``REACH_SHARE`` of the limb's
  reach from where the limb's root joint is in the solved pose (the spine has bent as it
  could; the soft-reach easing of the IK starts at 97%). With a full-weight rotation goal
  the body's joint must reach the joint target the rotation implies (goal minus the
  rotated joint offset), so reach and distance are measured to it. The miss is measured
  against the reach (floored at ``REACH_FLOOR`` of the creature's size, so a 2 cm jaw is
  not judged in units of 2 cm): ``reach_miss`` = miss / reach;
- an *unreachable* goal is met as well as it can be when the limb points straight at it:
  the miss beyond reach is what counts, ``beyond_reach`` = (miss - (distance - reach)) / reach;
  a goal closer to the limb's root than the folded limb can come (``CellContext.inner_reach``:
  the longest segment less the others; a one-bone palp cannot bring its tip to its own root)
  is out of reach the same way, ``beyond_reach`` = (miss - (inner - distance)) / reach, and a
  goal is reachable only ``1 - REACH_SHARE`` of the reach clear of both bounds;
- goals on spine bodies, and on one-body limbs (jaws, eyes: their goal moves the spine,
  to which the IK delegates them), are compromises between every goal on the spine:
  ``spine_miss`` = miss / the creature's size, reported and warned about, never failed;
- ``rotation_miss``: the angle between a body's rotation and its full-weight rotation goal;
- ``lookat_miss``: the same for bodies of look-at channels (their goal aims at the target).

The root is forward-kinematic (its pose is its goal) and is skipped.

Position goals are the ones the IK's limb phase was asked: with self-collision on, a limb
goal inside another of the creature's bodies is moved to that body's surface before the
limb phase (``engine.ik.selfcollision.settled_goals``; a goal inside the creature cannot
be met without passing through it, so stopping at the surface is not a miss). The frames
the recording's plans say so are measured against the settled goals, and ``reach_miss``
reports how far goals were moved (``settled_m``, ``settled_frames``).
"""

from __future__ import annotations

import numpy as np

from engine.validation import _kernels as K
from engine.validation.measure import Measure, worst

#: A goal counts at this weight or more (fades and soft channels below it are not misses).
FULL = 0.999
#: A limb goal within this share of the limb's reach is reachable.
REACH_SHARE = 0.97
#: Smallest reach a miss is measured against, as a share of the creature's size.
REACH_FLOOR = 0.1


def goal_error(rec, ctx) -> list[Measure]:
    c = rec.creature
    names = c.body_names
    if rec.nframe == 0:
        return []
    goal_pos, moved_max, moved_frames = settled_goal_positions(rec)
    reach_rel, beyond_rel, spine_rel, ang = K.goal_errors(
        rec.world_pos, rec.world_rot, goal_pos, rec.goal_rot, rec.goal_pw, rec.goal_rw, c.body_joint_offset,
        ctx.limb_root_of, ctx.is_chain, ctx.is_spine_goal, ctx.chain, ctx.reach, ctx.inner_chain, ctx.inner_reach,
        np.maximum(ctx.reach, REACH_FLOOR * ctx.scale), ctx.scale, FULL, REACH_SHARE)
    out = [worst("reach_miss", reach_rel, "reach", names, rec.t),
           worst("beyond_reach", beyond_rel, "reach", names, rec.t),
           worst("spine_miss", spine_rel, "size", names, rec.t)]
    look = np.zeros(c.nbody, bool)
    look[rec.meta.get("lookat_bodies", np.zeros(0, np.int64))] = True
    out.append(worst("rotation_miss", np.where(look[None, :], 0.0, ang), "rad", names, rec.t))
    out.append(worst("lookat_miss", np.where(look[None, :], ang, 0.0), "rad", names, rec.t))
    npos = int((rec.goal_pw[:, 1:] >= FULL).sum())
    nrot = int((rec.goal_rw[:, 1:] >= FULL).sum())
    for m in out:
        m.detail["goal_frames"] = nrot if m.name in ("rotation_miss", "lookat_miss") else npos
    out[0].detail["settled_m"] = round(moved_max, 6)
    out[0].detail["settled_frames"] = moved_frames
    return out


def settled_goal_positions(rec) -> tuple[np.ndarray, float, int]:
    """(goal positions the limb phase was asked per frame, the largest move of a
    full-weight goal, m, frames with a goal moved by more than 1e-6 m): the recording's
    goals settled out of the creature's own bodies by each frame's IK plan (unchanged
    where self-collision was off)."""
    from engine.ik.selfcollision import settled_goals

    plans = rec.meta.get("ik_plans", [])
    idx = rec.meta.get("ik_plan_of_frame")
    if not plans or idx is None or not any(int(p.arrays.cl_i[0]) > 0 for p in plans):
        return rec.goal_pos, 0.0, 0
    out = rec.goal_pos.copy()
    scratch = {}
    moved_max = 0.0
    frames = 0
    for f in range(rec.nframe):
        k = int(idx[f]) if f < idx.shape[0] else -1
        if k < 0 or int(plans[k].arrays.cl_i[0]) == 0:
            continue
        p = plans[k]
        if k not in scratch:
            scratch[k] = p.make_scratch()
        out[f] = settled_goals(p, rec.goal_pos[f], rec.goal_pw[f], rec.world_pos[f], rec.world_rot[f], scratch[k])
        full = rec.goal_pw[f] >= FULL
        if full.any():
            d = float(np.linalg.norm(out[f][full] - rec.goal_pos[f][full], axis=1).max())
            moved_max = max(moved_max, d)
            frames += d > 1e-6
    return out, moved_max, frames


