"""The ground: box corners below it, and standing feet that slide.

``below_ground`` (height): the deepest any corner of any body box goes below the terrain
(flat z = 0 in the grid), over the creature's height. A foot box resting on the ground
has its lowest corners at 0; a ground-relative channel at z_g = 1 rests a box on the
ground, not in it.

``standing_slide`` (leg length): while a foot stands (the standing stage holds it at its
rest spot: full weight, the goal's contact point exactly at rest; a pivot foot's goal turns
about that point), how far its contact point (the centre of the
foot box's lowest face at rest, carried by the foot's pose) moves from where that stance
began, over the leg's length. A planted foot must not skate.
"""

from __future__ import annotations

import numpy as np

from engine.validation import _kernels as K
from engine.validation.measure import Measure, worst


def ground(rec, ctx) -> list[Measure]:
    c = rec.creature
    n = rec.nframe
    if n == 0:
        return []
    low = K.box_min_z(rec.world_pos, rec.world_rot, c.body_extent)         # (n, nb)
    depth = np.maximum(-low, 0.0) / ctx.height
    m = worst("below_ground", depth, "height", c.body_names, rec.t)
    if m.frame is not None and m.value > 0.0:
        b = c.body(m.body)
        m.detail["driven"] = bool(rec.driven[m.frame, b])
        m.detail["goal"] = bool(rec.goal_pw[m.frame, b] > 0.0 or rec.goal_rw[m.frame, b] > 0.0)
        m.detail["rest_low"] = float(ctx.rest_low[b] / ctx.height)
    out = [m]
    feet = c.leg_foot
    if feet.size == 0:
        out.append(Measure("standing_slide", 0.0, "leg"))
        return out
    v = ctx.foot_contact_local[None, :, :]
    # where the goal puts the contact point: a pivot foot's goal turns about it (the
    # standing stage keeps a knee-less leg's joint on its segment), so the contact point
    # of the goal, not its origin, is what stands at its rest spot
    goal_contact = _carry(rec.goal_pos[:, feet], rec.goal_rot[:, feet], v)
    rest_contact = _carry(c.body_rest_pos[feet][None], c.body_rest_rot[feet][None], v)
    standing = (rec.goal_pw[:, feet] >= 1.0) & (np.linalg.norm(goal_contact - rest_contact, axis=-1) < 1e-9)
    contact = _carry(rec.world_pos[:, feet], rec.world_rot[:, feet], v)
    # each standing frame against the first frame of its stance (the latest frame where
    # standing began, carried forward)
    began = standing & ~np.vstack([np.zeros((1, feet.size), bool), standing[:-1]])
    first = np.maximum.accumulate(np.where(began, np.arange(n)[:, None], 0), axis=0)
    start = np.take_along_axis(contact, first[..., None], axis=0)
    slide = np.where(standing, np.linalg.norm(contact - start, axis=-1), 0.0) / ctx.leg_length[None, :]
    out.append(worst("standing_slide", slide, "leg", [c.body_names[f] for f in feet], rec.t))
    return out


def _carry(pos, rot, v):
    """pos + rot * v over broadcast leading axes (rot w-first)."""
    u = rot[..., 1:]
    tt = 2.0 * np.cross(u, v)
    return pos + v + rot[..., :1] * tt + np.cross(u, tt)
