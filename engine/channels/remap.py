"""Key remapping when a channel's movement mode changes (Hecker et al. 2008, section 3.3).

Each key is remapped by ``q_g_new = G_new(b, S_old(b, q_g_old, false), false)`` for the
active body b, so b's specialized curve does not change. Every mode's S is affine in the
position (``o + A q``) and of the form ``F q R`` in the rotation, for fixed targets; so
tangents map by the linear part (``A_new^-1 A_old``) and angular-velocity tangents
rotate by ``(R_old R_new^-1)^-1``, and b's specialized curve stays identical *between*
keys too, not only at them (automatic tangents are linear in the keys, see ``curves``).
"""

from __future__ import annotations

import numpy as np

from engine.channels import modes as M
from engine.mathx.quat import quat_rotate


def _single(creature, body, position, rotation):
    return M.build_slots(creature, [M.Slot(body, position, rotation, mirror=False, target=0)])


def remap_position_keys(creature, body: int, old: M.PositionSpec, new: M.PositionSpec, values,
                        tangents=(), target=None):
    """Remap position keys (k, 3) and any tangent arrays (k, 3) from mode ``old`` to ``new``
    for ``body``; ``target`` is the secondary target position (character space) if
    either mode needs one. Returns (values, [tangents...])."""
    targets = np.zeros((1, 3)) if target is None else np.asarray(target, float).reshape(1, 3)
    o_old, a_old, _, _ = M.frames(_single(creature, body, old, None), targets)
    o_new, a_new, _, _ = M.frames(_single(creature, body, new, None), targets)
    v = np.asarray(values, float).reshape(-1, 3)
    specialized = o_old[0] + v @ a_old[0].T
    new_values = np.linalg.solve(a_new[0], (specialized - o_new[0]).T).T
    linear = np.linalg.solve(a_new[0], a_old[0])
    new_tangents = [np.asarray(t, float).reshape(-1, 3) @ linear.T for t in tangents]
    return new_values, new_tangents


def remap_rotation_keys(creature, body: int, old: M.RotationSpec, new: M.RotationSpec, values,
                        tangents=(), target=None):
    """Remap rotation keys (k, 4) and angular-velocity tangent arrays (k, 3) from mode
    ``old`` to ``new`` for ``body``. Returns (values, [tangents...])."""
    targets = np.zeros((1, 3)) if target is None else np.asarray(target, float).reshape(1, 3)
    _, _, f_old, b_old = M.frames(_single(creature, body, None, old), targets)
    _, _, f_new, b_new = M.frames(_single(creature, body, None, new), targets)
    left = M._qmul(M._qconj(f_new[0]), f_old[0])
    right = M._qmul(b_old[0], M._qconj(b_new[0]))
    q = np.asarray(values, float).reshape(-1, 4)
    new_values = M._qmul(M._qmul(np.broadcast_to(left, q.shape), q), np.broadcast_to(right, q.shape))
    inv_right = np.ascontiguousarray(M._qconj(right))
    new_tangents = []
    for t in tangents:
        t = np.asarray(t, float).reshape(-1, 3)
        new_tangents.append(np.array([quat_rotate(inv_right, np.ascontiguousarray(w)) for w in t]).reshape(-1, 3))
    return new_values, new_tangents
