"""Self-intersection: boxes of one creature inside each other, beyond the rest pose's.

Pairs of bodies that are not neighbours in the tree (not parent and child) are tested
with the separating-axis test on their oriented boxes (``_kernels.obb_depth``: the
smallest overlap over the 15 axes, exact for boxes). Creatures are built with some boxes
overlapping at rest (siblings at a shoulder, a head in its neck); that overlap is theirs,
so each pair's rest depth is subtracted. ``self_intersection`` (height): the deepest
excess over the cell, every ``STRIDE``-th frame.

The IK ignores collisions between a creature's own bodies (Hecker et al. 2008, section
4.3: "clearly a flaw"), so failures here are known until self-collision-aware IK lands
(issue 16).
"""

from __future__ import annotations

import numpy as np

from engine.validation import _kernels as K
from engine.validation.measure import Measure

#: Test every STRIDE-th frame (a pass through a body lasts many frames).
STRIDE = 2
KNOWN = "issue 16: self-collision-aware IK"


def nonadjacent_pairs(creature) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) int64 arrays of the body pairs that are not parent and child."""
    n = creature.nbody
    a, b = np.triu_indices(n, 1)
    parent = creature.body_parent
    keep = (parent[b] != a) & (parent[a] != b)
    return a[keep].astype(np.int64), b[keep].astype(np.int64)


def rest_depths(creature, pair_a, pair_b) -> np.ndarray:
    pos = creature.body_rest_pos[None]
    rot = creature.body_rest_rot[None]
    return K.pair_depths(pos, rot, creature.body_extent, pair_a, pair_b, np.zeros(1, np.int64))[0]


def self_intersection(rec, ctx) -> list[Measure]:
    c = rec.creature
    n = rec.nframe
    if n == 0 or ctx.pair_a.size == 0:
        return [Measure("self_intersection", 0.0, "height")]
    frames = np.arange(0, n, STRIDE, dtype=np.int64)
    depth = K.pair_depths(rec.world_pos, rec.world_rot, c.body_extent, ctx.pair_a, ctx.pair_b, frames)
    excess = np.maximum(depth - ctx.pair_rest_depth[None, :], 0.0) / ctx.height
    # the per-frame series holds each tested frame's value until the next one
    series = np.repeat(excess.max(axis=1), STRIDE)[:n]
    fi, k = divmod(int(np.argmax(excess)), excess.shape[1])
    i = int(frames[fi])
    a, b = int(ctx.pair_a[k]), int(ctx.pair_b[k])
    value = float(excess[fi, k])
    return [Measure("self_intersection", value, "height", body=f"{c.body_names[a]}/{c.body_names[b]}", frame=i,
                    time=float(rec.t[i]), series=series, known=KNOWN if value > 0.0 else None)]
