"""IK stretch and compression against the solver's own limits.

``joint_stretch`` (bone): how far the IK pulled a limb joint apart (the distance between
the body's joint and where its parent's frame puts it), over the parent's bone length
(joint to joint at rest, floored at 1% of the creature's size). The limb phase stretches a
limb at most 2% uniformly to meet a goal at full reach (``engine/ik/NOTES.md``, knee pop).

``spine_gap`` (bone): the same for spine joints. The spine phase lets a chord between
spine particles shrink and stretch (below), and interior bodies follow a spline, so some
gap is by design; a gap of a third of the bone is a spine come apart.

``spine_chord`` (ratio): the distance between neighbouring spine joints over its rest
length; the spine phase holds it in [0.9, 1.2] (Hecker et al. 2008, section 4.3.2,
"10%/120%"). The measure is the largest departure from that range.
"""

from __future__ import annotations

import numpy as np

from engine.validation import _kernels as K
from engine.validation.measure import Measure, worst

#: The spine phase's chord limits (length ratio to rest).
SPINE_SHRINK = 0.9
SPINE_STRETCH = 1.2


def ik_limits(rec, ctx) -> list[Measure]:
    c = rec.creature
    n = rec.nframe
    if n == 0:
        return []
    sep = K.joint_separation(c.body_parent, c.body_local_joint, c.body_joint_offset, rec.world_pos, rec.world_rot)
    rel = sep / ctx.bone_length[None, :]
    spine = c.body_is_spine
    out = [worst("joint_stretch", np.where(spine[None, :], 0.0, rel), "bone", c.body_names, rec.t),
           worst("spine_gap", np.where(spine[None, :], rel, 0.0), "bone", c.body_names, rec.t)]
    chain = c.spine_chain
    if chain.size >= 2:
        u = rec.world_rot[:, chain, 1:]
        v = c.body_joint_offset[chain][None]
        tt = 2.0 * np.cross(u, v)
        joints = rec.world_pos[:, chain] - (v + rec.world_rot[:, chain, :1] * tt + np.cross(u, tt))
        length = np.linalg.norm(joints[:, 1:] - joints[:, :-1], axis=-1)
        ratio = length / ctx.spine_rest_chord[None, :]
        off = np.maximum(np.maximum(SPINE_SHRINK - ratio, ratio - SPINE_STRETCH), 0.0)
        m = worst("spine_chord", off, "ratio", [c.body_names[b] for b in chain[1:]], rec.t)
        m.detail["min_ratio"] = float(ratio.min())
        m.detail["max_ratio"] = float(ratio.max())
        out.append(m)
    return out
