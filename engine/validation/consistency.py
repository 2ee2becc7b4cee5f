"""Consistency: path independence and mirror images.

``path_independence`` (size): the IK solves every frame from the rest pose, so the pose at
time t must depend only on the goals at t. A fresh character that starts the clip at t
(``record.scrub_poses``) is compared with the recording at t, at a few times; passive
(Jiggles) bodies carry their own state and are left out. The measure is the largest
position difference of a body posed by the IK in both, over the creature's size.

``mirror`` (size): a variant and its sagittal mirror image (``hand_l`` and ``hand_r``),
played with mirrored targets on a mirror-symmetric creature, must be mirror poses frame by
frame: body b of one at (x, y, z) is body mirror(b) of the other at (x, -y, z). The
measure is the largest position difference, over the creature's size (rotations follow
positions on rigid boxes; a difference of turn alone shows up at the box corners the
self-intersection and ground tests use, and in ``detail.rot``).
"""

from __future__ import annotations

import numpy as np

from engine.validation.measure import Measure

#: Shares of the clip at which the scrubbed pose is compared.
SCRUB_AT = (0.3, 0.55, 0.8)


def scrub_frames(rec) -> list[int]:
    """Frames of ``rec`` to compare with a scrub: at ``SCRUB_AT`` shares of the clip, moved
    to the nearest frame where the clip plays at full weight (a scrub jumps in at full
    weight; fades are compared by playing, not scrubbing)."""
    full = np.flatnonzero((rec.weight[: rec.end_frame] >= 1.0) & (rec.clip_time[: rec.end_frame] >= 0.0))
    if full.size == 0:
        return []
    out = []
    for share in SCRUB_AT:
        want = share * rec.end_frame
        i = int(full[np.argmin(np.abs(full - want))])
        if i not in out:
            out.append(i)
    return out


def path_independence(rec, ctx, scrubs) -> Measure:
    """Compare ``rec`` with its scrubbed poses ``[(frame, pos, rot, driven), ...]``."""
    c = rec.creature
    worst_d, worst_b, worst_i = 0.0, 0, 0
    for i, pos, _rot, driven in scrubs:
        both = driven & rec.driven[i]
        if not both.any():
            continue
        d = np.where(both, np.linalg.norm(pos - rec.world_pos[i], axis=-1), 0.0) / ctx.scale
        b = int(np.argmax(d))
        if d[b] >= worst_d:
            worst_d, worst_b, worst_i = float(d[b]), b, i
    return Measure("path_independence", worst_d, "size", body=str(c.body_names[worst_b]), frame=worst_i,
                   time=float(rec.t[worst_i]))


def mirror_difference(rec_a, rec_b, ctx) -> Measure:
    """How far ``rec_b`` is from the mirror image of ``rec_a`` (see the module docstring)."""
    c = rec_a.creature
    n = min(rec_a.nframe, rec_b.nframe)
    mirror = c.body_mirror
    img = rec_b.world_pos[:n][:, mirror] * np.array([1.0, -1.0, 1.0])
    d = np.linalg.norm(rec_a.world_pos[:n] - img, axis=-1) / ctx.scale
    qa = rec_a.world_rot[:n]
    qb = rec_b.world_rot[:n][:, mirror] * np.array([1.0, -1.0, 1.0, -1.0])
    rot = 2.0 * np.arccos(np.clip(np.abs(np.sum(qa * qb, axis=-1)), 0.0, 1.0))
    if d.size == 0:
        return Measure("mirror", 0.0, "size")
    i, b = divmod(int(np.argmax(d)), d.shape[1])
    return Measure("mirror", float(d[i, b]), "size", body=str(c.body_names[b]), frame=i, time=float(rec_a.t[i]),
                   detail={"rot": float(rot.max()), "with": rec_b.variant_id}, series=d.max(axis=1))
