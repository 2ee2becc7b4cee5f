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
- goals on spine bodies, and on one-body limbs (jaws, eyes: their goal moves the spine,
  to which the IK delegates them), are compromises between every goal on the spine:
  ``spine_miss`` = miss / the creature's size, reported and warned about, never failed;
- ``rotation_miss``: the angle between a body's rotation and its full-weight rotation goal;
- ``lookat_miss``: the same for bodies of look-at channels (their goal aims at the target).

The root is forward-kinematic (its pose is its goal) and is skipped.
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
    n = rec.nframe
    if n == 0:
        return []
    pos, rot = rec.world_pos, rec.world_rot
    full = rec.goal_pw >= FULL
    full[:, 0] = False
    miss = np.linalg.norm(pos - rec.goal_pos, axis=-1)               # (n, nb) m
    reach_rel = np.zeros_like(miss)
    beyond_rel = np.zeros_like(miss)
    spine_rel = np.zeros_like(miss)
    limb = ctx.chain_bodies                                           # bodies on a limb of 2+ bodies
    if limb.size:
        roots = ctx.limb_root_of[limb]
        root_joint = pos[:, roots] - _rotate(rot[:, roots], c.body_joint_offset[roots])
        # with a full rotation goal the joint has a target of its own
        with_rot = rec.goal_rw[:, limb] >= FULL
        target = np.where(with_rot[..., None],
                          rec.goal_pos[:, limb] - _rotate(rec.goal_rot[:, limb], c.body_joint_offset[limb]),
                          rec.goal_pos[:, limb])
        dist = np.linalg.norm(target - root_joint, axis=-1)                   # (n, k)
        reach = np.where(with_rot, ctx.chain[limb][None, :], ctx.reach[limb][None, :])
        inside = dist <= REACH_SHARE * reach
        norm = np.maximum(ctx.reach[limb], REACH_FLOOR * ctx.scale)[None, :]
        f = full[:, limb]
        reach_rel[:, limb] = np.where(f & inside, miss[:, limb] / norm, 0.0)
        over = np.maximum(miss[:, limb] - np.maximum(dist - reach, 0.0), 0.0) / norm
        beyond_rel[:, limb] = np.where(f & ~inside, over, 0.0)
    spine = ctx.spine_goal_bodies
    if spine.size:
        spine_rel[:, spine] = np.where(full[:, spine], miss[:, spine] / ctx.scale, 0.0)
    out = [worst("reach_miss", reach_rel, "reach", names, rec.t),
           worst("beyond_reach", beyond_rel, "reach", names, rec.t),
           worst("spine_miss", spine_rel, "size", names, rec.t)]
    rfull = rec.goal_rw >= FULL
    rfull[:, 0] = False
    ang = np.zeros((n, c.nbody))
    if rfull.any():
        idx = np.nonzero(rfull)
        qa = np.ascontiguousarray(rot[idx])
        qb = np.ascontiguousarray(rec.goal_rot[idx])
        ang[idx] = _angles(qa, qb)
    look = np.zeros(c.nbody, bool)
    look[rec.meta.get("lookat_bodies", np.zeros(0, np.int64))] = True
    out.append(worst("rotation_miss", np.where(look[None, :], 0.0, ang), "rad", names, rec.t))
    out.append(worst("lookat_miss", np.where(look[None, :], ang, 0.0), "rad", names, rec.t))
    for m in out:
        m.detail["goal_frames"] = int(full.sum()) if m.name != "rotation_miss" else int(rfull.sum())
    return out


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + q[..., :1] * t + np.cross(u, t)


def _angles(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    """Angle between each pair of rotations qa[k], qb[k], rad."""
    return K.step_angles(np.ascontiguousarray(np.stack([qa, qb])))[0]
