"""Blend-group ownership (Hecker et al. 2008, section 3.2.3, footnote 5).

The first channel (in priority order: higher ``priority`` first, then file order) to
pose a degree of freedom of a body - its position or its rotation, separately - owns it
for that channel's blend group. Later channels pose the same DOF of that body only when
their blend group matches the owner's; their poses are then blended by weight
(``_kernels.blend_kernel``). Ownership depends only on the animation and the creature, so
it is computed once at bind.
"""

from __future__ import annotations

import numpy as np


def channel_order(priorities) -> np.ndarray:
    """Channel indices in ownership order: higher priority first, file order on ties."""
    p = np.asarray(priorities)
    return np.array(sorted(range(len(p)), key=lambda i: (-p[i], i)), np.int32)


def ownership(slot_body, slot_group, slot_has_pos, slot_has_rot):
    """Which slots may pose their body's position / rotation.

    Slots must already be in ownership order. ``slot_group`` holds an integer id per slot
    (its channel's blend group). Returns (pos_on, rot_on), int8 arrays (nslot,).
    """
    n = len(slot_body)
    pos_on = np.zeros(n, np.int8)
    rot_on = np.zeros(n, np.int8)
    pos_owner: dict[int, int] = {}
    rot_owner: dict[int, int] = {}
    for i in range(n):
        b = int(slot_body[i])
        g = int(slot_group[i])
        if slot_has_pos[i]:
            owner = pos_owner.setdefault(b, g)
            pos_on[i] = owner == g
        if slot_has_rot[i]:
            owner = rot_owner.setdefault(b, g)
            rot_on[i] = owner == g
    return pos_on, rot_on
