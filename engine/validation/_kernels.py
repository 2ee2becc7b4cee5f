"""Kernels of the validation metrics: whole recordings at once, (nframe, nbody, ...) arrays.

They run once per grid cell over every frame (not per game frame), so they may allocate
their outputs; what they must be is fast over a thousand creatures.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from engine.mathx.quat import quat_rotate_t


@njit(cache=True)
def _angle_between(a, b):
    """Angle of the rotation taking unit quaternion a to b, radians in [0, pi] (robust for
    small angles: 2 atan2(|v|, |w|) of b * conj(a))."""
    aw, ax, ay, az = a[0], -a[1], -a[2], -a[3]
    bw, bx, by, bz = b[0], b[1], b[2], b[3]
    w = bw * aw - bx * ax - by * ay - bz * az
    x = bw * ax + bx * aw + by * az - bz * ay
    y = bw * ay - bx * az + by * aw + bz * ax
    z = bw * az + bx * ay - by * ax + bz * aw
    return 2.0 * np.arctan2(np.sqrt(x * x + y * y + z * z), abs(w))


@njit(cache=True)
def _slerp_toward(a, b, t, out):
    """out = slerp(a, b, t) along the short arc (t in [0, 1])."""
    d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    s = 1.0
    if d < 0.0:
        d = -d
        s = -1.0
    if d > 0.9995:
        for k in range(4):
            out[k] = a[k] + t * (s * b[k] - a[k])
    else:
        th = np.arccos(d)
        sa = np.sin((1.0 - t) * th) / np.sin(th)
        sb = np.sin(t * th) / np.sin(th)
        for k in range(4):
            out[k] = sa * a[k] + sb * s * b[k]
    n = np.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3])
    for k in range(4):
        out[k] /= n


@njit(cache=True)
def step_angles(rot):
    """(nf - 1, nb) angle each body turns from frame i to i + 1, radians."""
    nf, nb = rot.shape[0], rot.shape[1]
    out = np.zeros((max(nf - 1, 0), nb))
    for i in range(nf - 1):
        for b in range(nb):
            out[i, b] = _angle_between(rot[i, b], rot[i + 1, b])
    return out


@njit(cache=True)
def effective_goals(goal_pos, goal_rot, goal_pw, goal_rw, root_pos, root_rot, rootrel_pos, rootrel_rot):
    """Where each body's goals ask it to be, weights folded in: position w p + (1 - w) r
    and rotation slerp(r, q, w), with r the body's rest pose carried by the root (where it
    goes with no goal). (nf, nb, 3) and (nf, nb, 4)."""
    nf, nb = goal_pos.shape[0], goal_pos.shape[1]
    eff_pos = np.empty((nf, nb, 3))
    eff_rot = np.empty((nf, nb, 4))
    rest_rot = np.empty(4)
    for i in range(nf):
        rq = root_rot[i]
        for b in range(nb):
            x, y, z = quat_rotate_t(rq, rootrel_pos[b])
            w = min(max(goal_pw[i, b], 0.0), 1.0)
            eff_pos[i, b, 0] = w * goal_pos[i, b, 0] + (1.0 - w) * (root_pos[i, 0] + x)
            eff_pos[i, b, 1] = w * goal_pos[i, b, 1] + (1.0 - w) * (root_pos[i, 1] + y)
            eff_pos[i, b, 2] = w * goal_pos[i, b, 2] + (1.0 - w) * (root_pos[i, 2] + z)
            # rest rotation carried by the root
            a = rq
            c = rootrel_rot[b]
            rest_rot[0] = a[0] * c[0] - a[1] * c[1] - a[2] * c[2] - a[3] * c[3]
            rest_rot[1] = a[0] * c[1] + a[1] * c[0] + a[2] * c[3] - a[3] * c[2]
            rest_rot[2] = a[0] * c[2] - a[1] * c[3] + a[2] * c[0] + a[3] * c[1]
            rest_rot[3] = a[0] * c[3] + a[1] * c[2] - a[2] * c[1] + a[3] * c[0]
            wr = min(max(goal_rw[i, b], 0.0), 1.0)
            _slerp_toward(rest_rot, goal_rot[i, b], wr, eff_rot[i, b])
    return eff_pos, eff_rot


@njit(cache=True)
def asked_motion(body_parent, body_subtree_end, body_joint_offset, world_pos, world_rot, eff_pos, eff_rot,
                 goal_pw, goal_rw, root_rot, floor):
    """What the goals ask each body to turn and move between frames i and i + 1.

    ``asked_angle (nf - 1, nb)``, radians: the largest of
    - the turn of the body's own effective rotation goal (when it has one);
    - for every goal below it in the tree (its sub-tree), the angle that goal's move
      subtends at the body's joint (|move| / distance, the distance floored at ``floor`` m),
      and the turn of that goal's rotation;
    - what its parent was asked (a parent's turn carries its children);
    - the root: its own turn (the root is forward-kinematic: its pose is its goal).
    ``asked_move (nf - 1, nb)``, m: the largest move of an effective position goal on the
    body or below it, plus the parent's asked move and the parent's asked turn times the
    body's distance from the parent's joint.
    """
    nf, nb = world_pos.shape[0], world_pos.shape[1]
    angle = np.zeros((max(nf - 1, 0), nb))
    move = np.zeros((max(nf - 1, 0), nb))
    joint = np.empty((nb, 3))
    own_turn = np.zeros(nb)
    own_move = np.zeros(nb)
    for i in range(nf - 1):
        for b in range(nb):
            x, y, z = quat_rotate_t(world_rot[i, b], body_joint_offset[b])
            joint[b, 0] = world_pos[i, b, 0] - x
            joint[b, 1] = world_pos[i, b, 1] - y
            joint[b, 2] = world_pos[i, b, 2] - z
            has_rot = goal_rw[i, b] > 0.0 or goal_rw[i + 1, b] > 0.0
            own_turn[b] = _angle_between(eff_rot[i, b], eff_rot[i + 1, b]) if has_rot else 0.0
            has_pos = goal_pw[i, b] > 0.0 or goal_pw[i + 1, b] > 0.0
            if has_pos:
                dx = eff_pos[i + 1, b, 0] - eff_pos[i, b, 0]
                dy = eff_pos[i + 1, b, 1] - eff_pos[i, b, 1]
                dz = eff_pos[i + 1, b, 2] - eff_pos[i, b, 2]
                own_move[b] = np.sqrt(dx * dx + dy * dy + dz * dz)
            else:
                own_move[b] = 0.0
        for b in range(nb):
            a = own_turn[b]
            m = own_move[b]
            for g in range(b + 1, body_subtree_end[b]):
                if own_turn[g] > a:
                    a = own_turn[g]
                if own_move[g] > 0.0:
                    dx = eff_pos[i, g, 0] - joint[b, 0]
                    dy = eff_pos[i, g, 1] - joint[b, 1]
                    dz = eff_pos[i, g, 2] - joint[b, 2]
                    d = max(np.sqrt(dx * dx + dy * dy + dz * dz), floor)
                    if own_move[g] / d > a:
                        a = own_move[g] / d
                    if own_move[g] > m:
                        m = own_move[g]
            p = body_parent[b]
            if p < 0:
                a = max(a, _angle_between(root_rot[i], root_rot[i + 1]))
            else:
                a = max(a, angle[i, p])
                dx = world_pos[i, b, 0] - joint[p, 0]
                dy = world_pos[i, b, 1] - joint[p, 1]
                dz = world_pos[i, b, 2] - joint[p, 2]
                m = max(m, move[i, p] + angle[i, p] * np.sqrt(dx * dx + dy * dy + dz * dz))
            angle[i, b] = a
            move[i, b] = m
    return angle, move


@njit(cache=True)
def box_min_z(world_pos, world_rot, extent):
    """(nf, nb) height of each body box's lowest corner."""
    nf, nb = world_pos.shape[0], world_pos.shape[1]
    out = np.empty((nf, nb))
    v = np.empty(3)
    for i in range(nf):
        for b in range(nb):
            lo = 1e300
            for sx in (-1.0, 1.0):
                for sy in (-1.0, 1.0):
                    for sz in (-1.0, 1.0):
                        v[0] = sx * extent[b, 0]
                        v[1] = sy * extent[b, 1]
                        v[2] = sz * extent[b, 2]
                        x, y, z = quat_rotate_t(world_rot[i, b], v)
                        z = z + world_pos[i, b, 2]
                        if z < lo:
                            lo = z
            out[i, b] = lo
    return out


@njit(cache=True)
def _axes(q, out):
    """The three unit axes of rotation q as rows of ``out`` (3, 3)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    out[0, 0] = 1 - 2 * (y * y + z * z)
    out[0, 1] = 2 * (x * y + w * z)
    out[0, 2] = 2 * (x * z - w * y)
    out[1, 0] = 2 * (x * y - w * z)
    out[1, 1] = 1 - 2 * (x * x + z * z)
    out[1, 2] = 2 * (y * z + w * x)
    out[2, 0] = 2 * (x * z + w * y)
    out[2, 1] = 2 * (y * z - w * x)
    out[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True)
def obb_depth(pa, qa, ea, pb, qb, eb, A, B):
    """Penetration depth of two oriented boxes (centres p, rotations q, half-extents e):
    the smallest overlap of their projections over the 15 separating axes of the
    separating-axis test (3 + 3 face normals, 9 edge cross products), 0 when they are
    apart. ``A``, ``B``: (3, 3) scratch for the axes."""
    _axes(qa, A)
    _axes(qb, B)
    tx = pb[0] - pa[0]
    ty = pb[1] - pa[1]
    tz = pb[2] - pa[2]
    best = 1e300
    for k in range(15):
        if k < 3:
            lx, ly, lz = A[k, 0], A[k, 1], A[k, 2]
        elif k < 6:
            lx, ly, lz = B[k - 3, 0], B[k - 3, 1], B[k - 3, 2]
        else:
            i = (k - 6) // 3
            j = (k - 6) % 3
            ux, uy, uz = A[i, 0], A[i, 1], A[i, 2]
            vx, vy, vz = B[j, 0], B[j, 1], B[j, 2]
            lx = uy * vz - uz * vy
            ly = uz * vx - ux * vz
            lz = ux * vy - uy * vx
            n = np.sqrt(lx * lx + ly * ly + lz * lz)
            if n < 1e-6:
                continue          # parallel edges: covered by the face normals
            lx /= n
            ly /= n
            lz /= n
        ra = 0.0
        rb = 0.0
        for m in range(3):
            ra += ea[m] * abs(A[m, 0] * lx + A[m, 1] * ly + A[m, 2] * lz)
            rb += eb[m] * abs(B[m, 0] * lx + B[m, 1] * ly + B[m, 2] * lz)
        overlap = ra + rb - abs(tx * lx + ty * ly + tz * lz)
        if overlap <= 0.0:
            return 0.0
        if overlap < best:
            best = overlap
    return best


@njit(cache=True)
def pair_depths(world_pos, world_rot, extent, pair_a, pair_b, frames):
    """(len(frames), npair) penetration depth of box pairs at the given frames; pairs whose
    bounding spheres are apart are 0 without the full test."""
    A = np.empty((3, 3))
    B = np.empty((3, 3))
    npair = pair_a.shape[0]
    out = np.zeros((frames.shape[0], npair))
    radius = np.empty(extent.shape[0])
    for b in range(extent.shape[0]):
        radius[b] = np.sqrt(extent[b, 0] ** 2 + extent[b, 1] ** 2 + extent[b, 2] ** 2)
    for fi in range(frames.shape[0]):
        i = frames[fi]
        for k in range(npair):
            a = pair_a[k]
            b = pair_b[k]
            dx = world_pos[i, b, 0] - world_pos[i, a, 0]
            dy = world_pos[i, b, 1] - world_pos[i, a, 1]
            dz = world_pos[i, b, 2] - world_pos[i, a, 2]
            r = radius[a] + radius[b]
            if dx * dx + dy * dy + dz * dz >= r * r:
                continue
            out[fi, k] = obb_depth(world_pos[i, a], world_rot[i, a], extent[a], world_pos[i, b], world_rot[i, b],
                                   extent[b], A, B)
    return out


@njit(cache=True)
def joint_separation(body_parent, body_local_joint, body_joint_offset, world_pos, world_rot):
    """(nf, nb) distance between where each body's joint is and where its parent's frame
    puts it (0 for the root): how far the IK pulled a joint apart, m."""
    nf, nb = world_pos.shape[0], world_pos.shape[1]
    out = np.zeros((nf, nb))
    for i in range(nf):
        for b in range(1, nb):
            p = body_parent[b]
            x, y, z = quat_rotate_t(world_rot[i, b], body_joint_offset[b])
            u, v, w = quat_rotate_t(world_rot[i, p], body_local_joint[b])
            dx = (world_pos[i, b, 0] - x) - (world_pos[i, p, 0] + u)
            dy = (world_pos[i, b, 1] - y) - (world_pos[i, p, 1] + v)
            dz = (world_pos[i, b, 2] - z) - (world_pos[i, p, 2] + w)
            out[i, b] = np.sqrt(dx * dx + dy * dy + dz * dz)
    return out


@njit(cache=True)
def goal_errors(world_pos, world_rot, goal_pos, goal_rot, goal_pw, goal_rw, body_joint_offset, limb_root_of,
                is_chain, is_spine_goal, chain, reach, inner_chain, inner_reach, norm, scale, full, reach_share):
    """Per frame and body (``engine.validation.goals``): ``reach_rel`` (a reachable
    full-weight goal's miss over the limb's reach), ``beyond_rel`` (an unreachable one's miss
    beyond what a straight limb leaves), ``spine_rel`` (a spine or one-body-limb goal's miss
    over the size), ``rot_miss`` (angle to a full-weight rotation goal). The root is skipped."""
    nf, nb = world_pos.shape[0], world_pos.shape[1]
    reach_rel = np.zeros((nf, nb))
    beyond_rel = np.zeros((nf, nb))
    spine_rel = np.zeros((nf, nb))
    rot_miss = np.zeros((nf, nb))
    for i in range(nf):
        for b in range(1, nb):
            if goal_rw[i, b] >= full:
                rot_miss[i, b] = _angle_between(world_rot[i, b], goal_rot[i, b])
            if goal_pw[i, b] < full:
                continue
            dx = world_pos[i, b, 0] - goal_pos[i, b, 0]
            dy = world_pos[i, b, 1] - goal_pos[i, b, 1]
            dz = world_pos[i, b, 2] - goal_pos[i, b, 2]
            miss = np.sqrt(dx * dx + dy * dy + dz * dz)
            if is_spine_goal[b]:
                spine_rel[i, b] = miss / scale
                continue
            if not is_chain[b]:
                continue
            r = limb_root_of[b]
            jx, jy, jz = quat_rotate_t(world_rot[i, r], body_joint_offset[r])
            rx = world_pos[i, r, 0] - jx
            ry = world_pos[i, r, 1] - jy
            rz = world_pos[i, r, 2] - jz
            tx, ty, tz = goal_pos[i, b, 0], goal_pos[i, b, 1], goal_pos[i, b, 2]
            limit = reach[b]
            inner = inner_reach[b]
            if goal_rw[i, b] >= full:
                # with its rotation fixed, the body's joint has a target of its own
                ox, oy, oz = quat_rotate_t(goal_rot[i, b], body_joint_offset[b])
                tx -= ox
                ty -= oy
                tz -= oz
                limit = chain[b]
                inner = inner_chain[b]
            d = np.sqrt((tx - rx) ** 2 + (ty - ry) ** 2 + (tz - rz) ** 2)
            if d <= reach_share * limit and (inner <= 0.0 or d >= inner + (1.0 - reach_share) * limit):
                reach_rel[i, b] = miss / norm[b]
            else:
                beyond_rel[i, b] = max(miss - max(d - limit, inner - d, 0.0), 0.0) / norm[b]
    return reach_rel, beyond_rel, spine_rel, rot_miss
