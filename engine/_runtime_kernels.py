"""Kernels of the per-frame runtime (``engine.runtime``): every array has a leading axis
over the characters of one creature stack, so a character alone (a stack of one) and a
crowd of a thousand run the same code, one call per stage.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from engine.anim._kernels import goals_kernel, goals_kernel_body_targets
from engine.anim.evaluate import EvalScratch
from engine.gait._kernels import pivot_goal
from engine.ik._kernels import borrow, solve_row, unpack
from engine.jiggle._kernels import jiggle_kernel
from engine.mathx.quat import (
    quat_conj_t,
    quat_from_rotvec_t,
    quat_mul_into,
    quat_mul_t,
    quat_normalize_t,
    quat_rotate_into,
    quat_rotate_t,
    quat_slerp_into,
    quat_slerp_t,
    quat_to_rotvec_t,
)


@njit(cache=True)
def goals_pairs(cv, consts, pos_on, rot_on, tables, times, pair_char, pair_slot, rest_pos, rest_rot, scratch,
                sg_pos, sg_rot, sg_pw, sg_rw, n_ext, body_parent, local_pos, local_rot, body_targets):
    """Sample, specialize and blend one bound variant for each (character, slot) pair
    playing it, into that slot's goal buffers ``sg_* (nchar, nslot, nbody, ...)``. With
    ``body_targets`` (some slot is secondary-relative to the creature's own bodies) the
    body rows of each pair's target table, after its ``n_ext`` external rows, are where
    this frame's goals put those bodies (``goals_kernel_body_targets``), never last
    frame's pose: the pose at time t depends on the goals at t alone."""
    _goals_chunk(cv, consts, pos_on, rot_on, tables, times, pair_char, pair_slot, rest_pos, rest_rot, scratch,
                 sg_pos, sg_rot, sg_pw, sg_rw, n_ext, body_parent, local_pos, local_rot, body_targets, 0,
                 times.shape[0])


@njit(cache=True, parallel=True)
def goals_pairs_parallel(cv, consts, pos_on, rot_on, tables, times, pair_char, pair_slot, rest_pos, rest_rot,
                         scratches, sg_pos, sg_rot, sg_pw, sg_rw, n_ext, body_parent, local_pos, local_rot,
                         body_targets):
    """``goals_pairs`` on all cores: the pairs split into ``scratches.work33.shape[0]``
    contiguous chunks, each sampled in turn by one thread with its own scratch (every
    field of ``scratches`` has a leading chunk axis). Pairs write disjoint rows."""
    nchunk = scratches.work33.shape[0]
    n = times.shape[0]
    for t in prange(nchunk):
        sc = EvalScratch(scratches.ch_pos[t], scratches.ch_rot[t], scratches.ch_weight[t], scratches.slot_pos[t],
                         scratches.slot_rot[t], scratches.slot_weight[t], scratches.work33[t], scratches.work34[t],
                         scratches.body_rot[t])
        _goals_chunk(cv, consts, pos_on, rot_on, tables, times, pair_char, pair_slot, rest_pos, rest_rot, sc,
                     sg_pos, sg_rot, sg_pw, sg_rw, n_ext, body_parent, local_pos, local_rot, body_targets,
                     t * n // nchunk, (t + 1) * n // nchunk)


@njit(cache=True)
def _goals_chunk(cv, consts, pos_on, rot_on, tables, times, pair_char, pair_slot, rest_pos, rest_rot, scratch,
                 sg_pos, sg_rot, sg_pw, sg_rw, n_ext, body_parent, local_pos, local_rot, body_targets, lo, hi):
    """Pairs ``lo..hi`` of ``goals_pairs`` with one scratch. Everything is borrowed (see
    engine.ik._kernels.borrow): no reference counts per array read, none shared between
    threads."""
    cvb = borrow(cv)
    cb = borrow(consts)
    po = borrow(pos_on)
    ro = borrow(rot_on)
    rp = borrow(rest_pos)
    rr = borrow(rest_rot)
    sc = borrow(scratch)
    for k in range(lo, hi):
        c = pair_char[k]
        s = pair_slot[k]
        table = borrow(tables[k])
        if body_targets:
            goals_kernel_body_targets(cvb, cb, po, ro, table, times[k], rp, rr, sc, borrow(sg_pos[c, s]),
                                      borrow(sg_rot[c, s]), borrow(sg_pw[c, s]), borrow(sg_rw[c, s]), body_parent,
                                      local_pos, local_rot, n_ext)
        else:
            goals_kernel(cvb, cb, po, ro, table, times[k], rp, rr, sc, borrow(sg_pos[c, s]), borrow(sg_rot[c, s]),
                         borrow(sg_pw[c, s]), borrow(sg_rw[c, s]))


@njit(cache=True)
def blend_layers(active, effective, layer, nlayer, sg_pos, sg_rot, sg_pw, sg_rw, rest_pos, rest_rot,
                 lay_pos, lay_rot, lay_pw, lay_rw, goal_pos, goal_rot, goal_pw, goal_rw, root_pos, root_rot):
    """Blend the playing clips of every character into one set of goals.

    Within a layer clips share by weight: for each body and DOF the goal is the mean of
    the clips' goals weighted by (effective clip weight x the clip's own goal weight), and
    the layer's goal weight is that sum, capped at 1. Layers then stack bottom to top:
    a layer with goal weight a moves the goal a of the way to its own (lerp / slerp) and
    the weight becomes w + a (1 - w). The root's goal is taken out and applied to the
    root pose (``root_pos``/``root_rot``, character space; rest where nothing poses it):
    the root is forward-kinematically controlled, never an IK goal.
    """
    nchar, nslot = active.shape
    nbody = rest_pos.shape[0]
    tmp = np.empty(4)
    for c in range(nchar):
        for b in range(nbody):
            goal_pw[c, b] = 0.0
            goal_rw[c, b] = 0.0
            for j in range(3):
                goal_pos[c, b, j] = rest_pos[b, j]
            for j in range(4):
                goal_rot[c, b, j] = rest_rot[b, j]
        for L in range(nlayer):
            used = False
            for s in range(nslot):
                if not active[c, s] or layer[c, s] != L or not (effective[c, s] > 0.0):
                    continue
                if not used:
                    for b in range(nbody):
                        lay_pw[b] = 0.0
                        lay_rw[b] = 0.0
                        for j in range(3):
                            lay_pos[b, j] = 0.0
                    used = True
                e = effective[c, s]
                for b in range(nbody):
                    wp = e * sg_pw[c, s, b]
                    if wp > 0.0:
                        for j in range(3):
                            lay_pos[b, j] += wp * sg_pos[c, s, b, j]
                        lay_pw[b] += wp
                    wr = e * sg_rw[c, s, b]
                    if wr > 0.0:
                        if lay_rw[b] == 0.0:
                            for j in range(4):
                                lay_rot[b, j] = sg_rot[c, s, b, j]
                        else:
                            quat_slerp_into(lay_rot[b], sg_rot[c, s, b], wr / (lay_rw[b] + wr), tmp)
                            for j in range(4):
                                lay_rot[b, j] = tmp[j]
                        lay_rw[b] += wr
            if not used:
                continue
            for b in range(nbody):
                wp = lay_pw[b]
                if wp > 0.0:
                    a = min(wp, 1.0)
                    g = goal_pw[c, b]
                    for j in range(3):
                        p = lay_pos[b, j] / wp
                        goal_pos[c, b, j] = p if g == 0.0 else goal_pos[c, b, j] + a * (p - goal_pos[c, b, j])
                    goal_pw[c, b] = a if g == 0.0 else g + a * (1.0 - g)
                wr = lay_rw[b]
                if wr > 0.0:
                    a = min(wr, 1.0)
                    g = goal_rw[c, b]
                    if g == 0.0:
                        for j in range(4):
                            goal_rot[c, b, j] = lay_rot[b, j]
                        goal_rw[c, b] = a
                    else:
                        quat_slerp_into(goal_rot[c, b], lay_rot[b], a, tmp)
                        for j in range(4):
                            goal_rot[c, b, j] = tmp[j]
                        goal_rw[c, b] = g + a * (1.0 - g)
        # The root: blend from rest toward its goal, then take it out of the IK goals.
        wp = goal_pw[c, 0]
        for j in range(3):
            root_pos[c, j] = rest_pos[0, j] + wp * (goal_pos[c, 0, j] - rest_pos[0, j])
        quat_slerp_into(rest_rot[0], goal_rot[c, 0], goal_rw[c, 0], tmp)
        for j in range(4):
            root_rot[c, j] = tmp[j]
        goal_pw[c, 0] = 0.0
        goal_rw[c, 0] = 0.0


@njit(cache=True)
def solve_indexed(plan_i, plan_f, plan_f3, plan_f4, idx, root_pos, root_rot, goal_pos, goal_rot, goal_pw, goal_rw,
                  out_pos, out_rot, scratch, bad, ground_set):
    """IK for the characters ``idx`` of a stack that share one plan. ``bad[c]`` gets the
    input check code (-1 solved); a bad character keeps last frame's pose. Returns how
    many were bad. The IK's ground (``IKParams.ground``) is ``ik_ground``'s plane."""
    P = unpack(plan_i, plan_f, plan_f3, plan_f4)
    nbad = 0
    for k in range(idx.shape[0]):
        r = idx[k]
        nbad += solve_row(P, r, root_pos, root_rot, goal_pos, goal_rot, goal_pw, goal_rw, out_pos, out_rot,
                          scratch, bad, ik_ground(ground_set, r))
    return nbad


@njit(cache=True)
def ik_ground(ground_set, r):
    """The plane (nx, ny, nz, d) the IK keeps row ``r``'s bodies above, character space: a
    standing character stands on z = 0 there (``goals_above_ground``, the rest pose); a row
    whose gait set the ground (``ground_set``) is left to its gait (a zero normal: off), so
    a walker on rolling terrain is never pushed to a plane that is not its ground."""
    if ground_set[r]:
        return (0.0, 0.0, 0.0, 0.0)
    return (0.0, 0.0, 1.0, 0.0)


@njit(cache=True, parallel=True)
def solve_indexed_parallel(plan_i, plan_f, plan_f3, plan_f4, idx, root_pos, root_rot, goal_pos, goal_rot, goal_pw,
                           goal_rw, out_pos, out_rot, scratches, bad, ground_set):
    """``solve_indexed`` on all cores: the rows ``idx`` split into ``scratches.shape[0]``
    contiguous chunks, each solved in turn by one thread with its own scratch
    ``scratches[chunk] (rows, 3)`` (solves share nothing else, and each starts from the
    rest pose, so the poses are the serial ones, bit for bit, whatever the threads)."""
    nchunk = scratches.shape[0]
    n = idx.shape[0]
    for t in prange(nchunk):
        P = unpack(plan_i, plan_f, plan_f3, plan_f4)
        sc = scratches[t]
        for k in range(t * n // nchunk, (t + 1) * n // nchunk):
            r = idx[k]
            solve_row(P, r, root_pos, root_rot, goal_pos, goal_rot, goal_pw, goal_rw, out_pos, out_rot, sc, bad,
                      ik_ground(ground_set, r))
    nbad = 0
    for k in range(n):
        if bad[idx[k]] != -1:
            nbad += 1
    return nbad


@njit(cache=True)
def _joint_in_parent(pos, rot, b, pb, joint_offset):
    """Body ``b``'s joint (its origin less its rotated joint offset) in its parent's frame."""
    jx, jy, jz = quat_rotate_t(rot[b], joint_offset[b])
    d = (pos[b, 0] - jx - pos[pb, 0], pos[b, 1] - jy - pos[pb, 1], pos[b, 2] - jz - pos[pb, 2])
    return quat_rotate_t(quat_conj_t(rot[pb]), d)


@njit(cache=True)
def switch_blend(rows, pending, t, off_pos, off_rot, prev_pos, prev_rot, world_pos, world_rot, parent, joint_offset,
                 limb, foot, goal_pw, local_rot, local_joint, hold, dt, omega):
    """The IK plan's hand-over (``engine.runtime``, ``_blend_switches``). A row whose plan
    changed this frame (``pending``) keeps the pose it showed last frame, as offsets in
    each body's parent frame (its rotation relative to its parent, as a rotation vector,
    and its joint's place on the parent; the root's in the world). They decay as a
    critically damped spring, (1 + omega t) exp(-omega t), t counted from the frame
    before, and the pose is rebuilt parents first, so the chain stays joined whatever the
    offsets. Except a planted foot (``foot`` and a full position goal this frame) and the
    bodies of its leg above it: they show this frame's pose, so a foot that stands does
    not slide while the offsets above it decay (0.3-1.2% of the leg with the whole chain
    in parent frames, and a foot landing during the hand-over skated on with its offset).
    ``t`` < 0: no hand-over running. Only ``rows`` are looked at; ``local_rot`` (nbody,
    4), ``local_joint`` (nbody, 3) and ``hold`` (nbody,) are scratch. Returns whether a
    hand-over still runs among the rows. Poses are body origins and rotations (world); a
    body's joint is its origin less its rotated ``joint_offset``."""
    live = False
    nb = world_pos.shape[1]
    for i in range(rows.shape[0]):
        r = rows[i]
        if pending[r]:
            pending[r] = False
            t[r] = 0.0
            for b in range(nb):
                pb = parent[b]
                if pb < 0:
                    for k in range(3):
                        off_pos[r, b, k] = prev_pos[r, b, k] - world_pos[r, b, k]
                    v = quat_to_rotvec_t(quat_mul_t(prev_rot[r, b], quat_conj_t(world_rot[r, b])))
                else:
                    up = _joint_in_parent(prev_pos[r], prev_rot[r], b, pb, joint_offset)
                    un = _joint_in_parent(world_pos[r], world_rot[r], b, pb, joint_offset)
                    for k in range(3):
                        off_pos[r, b, k] = up[k] - un[k]
                    lp = quat_mul_t(quat_conj_t(prev_rot[r, pb]), prev_rot[r, b])
                    ln = quat_mul_t(quat_conj_t(world_rot[r, pb]), world_rot[r, b])
                    v = quat_to_rotvec_t(quat_mul_t(lp, quat_conj_t(ln)))
                off_rot[r, b, 0] = v[0]
                off_rot[r, b, 1] = v[1]
                off_rot[r, b, 2] = v[2]
        if t[r] < 0.0:
            continue
        t[r] += dt
        x = omega * t[r]
        kx = (1.0 + x) * np.exp(-x)
        if kx < 1e-4:
            t[r] = -1.0
            continue
        live = True
        # planted feet and their legs (children come after their parents: walk back)
        for b in range(nb - 1, -1, -1):
            hold[b] = foot[b] and limb[b] >= 0 and goal_pw[r, b] >= 0.999
        for b in range(nb - 1, 0, -1):
            if hold[b] and limb[parent[b]] == limb[b]:
                hold[parent[b]] = True
        # this frame's pose in parent frames, before any body is moved
        for b in range(nb):
            pb = parent[b]
            if pb < 0 or hold[b]:
                continue
            ln = quat_mul_t(quat_conj_t(world_rot[r, pb]), world_rot[r, b])
            u = _joint_in_parent(world_pos[r], world_rot[r], b, pb, joint_offset)
            for k in range(4):
                local_rot[b, k] = ln[k]
            for k in range(3):
                local_joint[b, k] = u[k] + kx * off_pos[r, b, k]
        # the offsets on it, parents first
        for b in range(nb):
            pb = parent[b]
            if hold[b]:
                continue
            q = quat_from_rotvec_t((kx * off_rot[r, b, 0], kx * off_rot[r, b, 1], kx * off_rot[r, b, 2]))
            if pb < 0:
                w = quat_normalize_t(quat_mul_t(q, world_rot[r, b]))
                for k in range(3):
                    world_pos[r, b, k] += kx * off_pos[r, b, k]
                for k in range(4):
                    world_rot[r, b, k] = w[k]
                continue
            w = quat_normalize_t(quat_mul_t(world_rot[r, pb], quat_mul_t(q, local_rot[b])))
            jx, jy, jz = quat_rotate_t(world_rot[r, pb], local_joint[b])
            ox, oy, oz = quat_rotate_t(w, joint_offset[b])
            world_pos[r, b, 0] = world_pos[r, pb, 0] + jx + ox
            world_pos[r, b, 1] = world_pos[r, pb, 1] + jy + oy
            world_pos[r, b, 2] = world_pos[r, pb, 2] + jz + oz
            for k in range(4):
                world_rot[r, b, k] = w[k]
    return live


@njit(cache=True)
def output_and_jiggle(driven, place_pos, place_rot, char_pos, char_rot, world_pos, world_rot,
                      body_parent, body_local_rot, body_local_joint, body_joint_offset,
                      jig_lever, jig_omega, jig_zeta, jig_max_err, jig_sleep, jig_follow, body_extent,
                      ground, ground_set, jig_err, jig_err_vel, jig_target, jig_target_vel, jig_active,
                      jig_twist, jig_contact, jig_chain_joint, jig_chain_rot, dt, simulate):
    """World pose of every body: the driven (IK) bodies carried by the character's world
    placement, then the others by Jiggles in world space (so walking makes ears bounce).
    The ground the passive bodies rest on is ``ground[c]`` (n . x = d) where the gait set
    it (``ground_set[c]``), else the plane the character stands on (through its placement,
    normal its up axis)."""
    nchar, nbody = driven.shape
    v = np.empty(3)
    plane = np.empty(4)
    up = np.zeros(3)
    up[2] = 1.0
    for c in range(nchar):
        if ground_set[c]:
            for j in range(4):
                plane[j] = ground[c, j]
        else:
            quat_rotate_into(place_rot[c], up, v)
            for j in range(3):
                plane[j] = v[j]
            plane[3] = v[0] * place_pos[c, 0] + v[1] * place_pos[c, 1] + v[2] * place_pos[c, 2]
        for b in range(nbody):
            if driven[c, b]:
                quat_rotate_into(place_rot[c], char_pos[c, b], v)
                for j in range(3):
                    world_pos[c, b, j] = place_pos[c, j] + v[j]
                quat_mul_into(place_rot[c], char_rot[c, b], world_rot[c, b])
        jiggle_kernel(body_parent, body_local_rot, body_local_joint, body_joint_offset, jig_lever, jig_omega,
                      jig_zeta, jig_max_err, jig_sleep, jig_follow, body_extent, plane, driven[c], world_pos[c],
                      world_rot[c], jig_err[c], jig_err_vel[c], jig_target[c], jig_target_vel[c], jig_active[c],
                      jig_twist[c], jig_contact[c], jig_chain_joint, jig_chain_rot, dt, simulate)


#: A standing foot the clip moves this far from its rest spot (a fraction of its leg's
#: chain) no longer holds the body (``stand_feet``).
LIFT_FREE = 0.25


@njit(cache=True)
def _lowest_corner(q, extent, v):
    """Height, over its centre, of the lowest corner of a box of half extents ``extent``
    turned by ``q`` (``v`` (3,) is scratch)."""
    lo = 1e300
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            for sz in (-1.0, 1.0):
                v[0] = sx * extent[0]
                v[1] = sy * extent[1]
                v[2] = sz * extent[2]
                x, y, z = quat_rotate_t(q, v)
                if z < lo:
                    lo = z
    return lo


@njit(cache=True)
def _root_above_ground(root_pos, root_rot, root_extent, root_floor, v):
    """The root's own box kept out of the ground a standing character stands on, as
    ``goals_above_ground`` keeps the goals (the root is posed by the clip, not the IK, so no
    goal of it reaches that stage): a crouch or a jump's wind-up that lowers the root of a
    creature lying on its belly (a legless crawler's root rests on the ground) raised until
    its box's lowest corner, turned by the root's rotation, is at ``root_floor`` (the lower
    of 0 and that corner at rest). Continuous in the root's pose (a max). ``stand_feet``
    runs it first, so the feet are placed under the root where it ends; ``v`` (3,) is
    scratch."""
    below = root_floor - (root_pos[2] + _lowest_corner(root_rot, root_extent, v))
    if below > 0.0:
        root_pos[2] += below


@njit(cache=True)
def stand_feet(rows, stand, feet, rest_pos, rest_rot, goal_pos, goal_rot, goal_pw, goal_rw, root_pos, root_rot,
               leg_rigid, leg_hip, leg_ankle, leg_reach, leg_chain, leg_knee, leg_contact, leg_contact_local,
               leg_attach, leg_hip_local, carry, scratch, ground_set, root_extent, root_floor):
    """Standing (the gait stage of a character that does not locomote): every foot of
    each row in ``rows`` with ``stand[row]`` is held at its rest spot on the ground, under whatever the
    animations ask of it: the blended goal is laid over the rest spot by its own weight,
    and the foot's goal weight becomes 1. So a crouch or a sway bends the legs instead of
    pushing the feet through the ground, and a clip that lifts a foot (a kick, a jump)
    still lifts it, fading in and out without a pop.

    The root (which the clip poses) is then moved, translation only, to where the legs
    can hold it (the paper's ground contact: a standing foot stays planted, section 4.2):
    a leg's hip joint (``leg_hip``: in the root frame at rest, carried by the root) must
    be within its chain's length (``leg_chain``) of its foot joint (``leg_ankle``: in the
    foot's frame from its origin, carried by the foot's goal), or the IK stretches the
    leg straight and the foot leaves its goal (a roar's lunge, a dance's bounce on
    straight legs). A knee-less leg (``leg_rigid``: one segment from hip to ankle) cannot
    bend at all: its hip must stay on the sphere of the segment's length (``leg_reach``)
    around its ankle, so a crouch on stilts is no crouch. Each leg asks for the shortest
    move of its hip onto its allowed set (every leg: a foot the clip holds at its rest
    spot stands as well as one it leaves free, and one it lifts asks the body to follow
    only when it lifts it out of reach); the root moves by the mean of the asks weighted by their
    lengths (continuous as a leg starts or stops asking) and turns, about the asking hips'
    centre, by the least-squares small turn that meets what the mean leaves (a sway or a
    yaw the planted legs cannot follow: a centipede's 24 knee-less legs), four rounds.

    A *pivot* foot (``leg_knee[k, 3] > 0``: the lower leg of a knee-less limb, a
    centipede's tibia; see ``engine.gait.rig``) bends at its joint instead: its contact
    point (``leg_contact``: from the foot's origin at rest, character space;
    ``leg_contact_local`` the same in the foot's frame) is what stands, within the
    segment plus the foot's reach of the hip, and once the root is placed the foot's goal
    turns about its contact point so its joint sits on the segment's sphere around the
    hip (``engine.gait._kernels.pivot_goal``, what the gait does with such feet).

    A hip whose spine body has a goal of its own (a roar bending the trunk) is where that
    goal puts it, as far as the goal's weight goes (``leg_attach``, ``leg_hip_local``:
    the spine body and the hip in its frame; ``_stand_hip``): the root cannot move it so
    far alone, so the spine goals (``carry``: spine bodies but the root) move with the
    root, and the pivot feet aim at it. A foot the clip lifts holds the body less the
    higher it goes (free at ``LIFT_FREE`` of its chain: a jump still jumps).
    ``scratch`` (nleg, 8) is scratch.

    First, for every row whose ground is the flat z = 0 (not ``ground_set``: a walker's
    terrain is its gait's), legged or not, the root's own box is kept out of the ground
    (``_root_above_ground``: ``root_extent``, ``root_floor``)."""
    nleg = feet.shape[0]
    v = np.empty(3)
    for i in range(rows.shape[0]):
        r = rows[i]
        if not ground_set[r]:
            _root_above_ground(root_pos[r], root_rot[r], root_extent, root_floor, v)
        if not stand[r]:
            continue
        for k in range(nleg):
            f = feet[k]
            w = min(max(goal_pw[r, f], 0.0), 1.0)
            for j in range(3):
                goal_pos[r, f, j] = rest_pos[f, j] + w * (goal_pos[r, f, j] - rest_pos[f, j])
            goal_pw[r, f] = 1.0
            # how far the foot stands: a clip that lifts it by a quarter of its chain
            # (a jump, a kick) leaves the body free of it; nearer, it holds the body
            # in proportion
            dx = goal_pos[r, f, 0] - rest_pos[f, 0]
            dy = goal_pos[r, f, 1] - rest_pos[f, 1]
            dz = goal_pos[r, f, 2] - rest_pos[f, 2]
            lift = np.sqrt(dx * dx + dy * dy + dz * dz) / max(LIFT_FREE * leg_chain[k], 1e-12)
            scratch[k, 7] = 1.0 - min(lift, 1.0)
            wr = min(max(goal_rw[r, f], 0.0), 1.0)
            if wr <= 0.0:
                for j in range(4):
                    goal_rot[r, f, j] = rest_rot[f, j]
            elif wr < 1.0:
                q0, q1, q2, q3 = quat_slerp_t(rest_rot[f], goal_rot[r, f], wr)
                goal_rot[r, f, 0] = q0
                goal_rot[r, f, 1] = q1
                goal_rot[r, f, 2] = q2
                goal_rot[r, f, 3] = q3
            goal_rw[r, f] = 1.0
        # the root where the standing legs can hold it
        for _ in range(4):
            wsum = 0.0
            hbx, hby, hbz, tx, ty, tz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            for k in range(nleg):
                scratch[k, 0] = 0.0
                pivot = leg_knee[k, 3] > 0.0
                rigid = leg_rigid[k] and not pivot
                f = feet[k]
                hx, hy, hz, lam = _stand_hip(root_pos[r], root_rot[r], goal_pos[r], goal_rot[r], goal_pw[r],
                                             goal_rw[r], leg_hip[k], leg_attach[k], leg_hip_local[k])
                if pivot:
                    ax, ay, az = quat_rotate_t(goal_rot[r, f], leg_contact_local[k])
                else:
                    ax, ay, az = quat_rotate_t(goal_rot[r, f], leg_ankle[k])
                ax += goal_pos[r, f, 0]
                ay += goal_pos[r, f, 1]
                az += goal_pos[r, f, 2]
                vx, vy, vz = hx - ax, hy - ay, hz - az
                d = np.sqrt(vx * vx + vy * vy + vz * vz)
                if d < 1e-12:
                    continue
                lim = leg_reach[k] if rigid else min(d, leg_chain[k])
                if lim == d:
                    continue
                m = lim / d - 1.0
                ux, uy, uz = vx * m, vy * m, vz * m
                a = np.sqrt(ux * ux + uy * uy + uz * uz)
                st = 1.0 if rigid else scratch[k, 7]
                if a <= 0.0 or st <= 0.0:
                    continue
                # each ask weighs its length in the mean, and counts by how far its foot
                # stands (a lone ask of a foot that hardly stands moves the root hardly)
                ux, uy, uz = ux * st, uy * st, uz * st
                scratch[k, 0] = a
                scratch[k, 1] = hx
                scratch[k, 2] = hy
                scratch[k, 3] = hz
                scratch[k, 4] = ux
                scratch[k, 5] = uy
                scratch[k, 6] = uz
                wsum += a
                hbx += a * hx
                hby += a * hy
                hbz += a * hz
                tx += a * ux
                ty += a * uy
                tz += a * uz
            if wsum <= 1e-15:
                break
            hbx, hby, hbz, tx, ty, tz = hbx / wsum, hby / wsum, hbz / wsum, tx / wsum, ty / wsum, tz / wsum
            # the turn about the asking hips' centre that best meets what translation leaves
            nx, ny, nz, den = 0.0, 0.0, 0.0, 0.0
            for k in range(nleg):
                a = scratch[k, 0]
                if a <= 0.0:
                    continue
                rx, ry, rz = scratch[k, 1] - hbx, scratch[k, 2] - hby, scratch[k, 3] - hbz
                ex, ey, ez = scratch[k, 4] - tx, scratch[k, 5] - ty, scratch[k, 6] - tz
                nx += a * (ry * ez - rz * ey)
                ny += a * (rz * ex - rx * ez)
                nz += a * (rx * ey - ry * ex)
                den += a * (rx * rx + ry * ry + rz * rz)
            q = (1.0, 0.0, 0.0, 0.0)
            if den > 1e-15:
                q = quat_from_rotvec_t((nx / den, ny / den, nz / den))
            # the root and the spine goals move together (the clip's posture of the trunk
            # kept relative to its root): a breath or a rise the legs cannot follow
            # lowers the whole trunk, not the root alone
            _move_about(q, hbx, hby, hbz, tx, ty, tz, root_pos[r], root_rot[r])
            for b in range(1, carry.shape[0]):
                if carry[b] and (goal_pw[r, b] > 0.0 or goal_rw[r, b] > 0.0):
                    _move_about(q, hbx, hby, hbz, tx, ty, tz, goal_pos[r, b], goal_rot[r, b])
        # pivot feet turn about their contact points to keep their joints on the segment
        for k in range(nleg):
            if leg_knee[k, 3] <= 0.0:
                continue
            f = feet[k]
            hx, hy, hz, lam = _stand_hip(root_pos[r], root_rot[r], goal_pos[r], goal_rot[r], goal_pw[r], goal_rw[r],
                                         leg_hip[k], leg_attach[k], leg_hip_local[k])
            pivot_goal(goal_pos[r, f], goal_rot[r, f], rest_rot[f], (hx, hy, hz), leg_knee[k], leg_contact[k])


@njit(cache=True)
def _move_about(q, cx, cy, cz, tx, ty, tz, pos, rot):
    """pos <- c + q (pos - c) + t, rot <- q rot (in place)."""
    px, py, pz = quat_rotate_t(q, (pos[0] - cx, pos[1] - cy, pos[2] - cz))
    pos[0] = cx + px + tx
    pos[1] = cy + py + ty
    pos[2] = cz + pz + tz
    q0, q1, q2, q3 = quat_normalize_t(quat_mul_t(q, rot))
    rot[0] = q0
    rot[1] = q1
    rot[2] = q2
    rot[3] = q3


@njit(cache=True)
def _stand_hip(root_pos, root_rot, goal_pos, goal_rot, goal_pw, goal_rw, hip, attach, hip_local):
    """Where a standing leg's hip joint will be (``stand_feet``): carried by the root
    (``hip``: in the root's frame at rest), or by the goal of the spine body it hangs from
    (``attach``, ``hip_local``: the hip in that body's frame) as far as that goal holds the
    body (the lesser of its position and rotation weights, ``lam``, returned last)."""
    hx, hy, hz = quat_rotate_t(root_rot, hip)
    hx += root_pos[0]
    hy += root_pos[1]
    hz += root_pos[2]
    lam = 0.0
    if attach > 0:
        lam = min(max(min(goal_pw[attach], goal_rw[attach]), 0.0), 1.0)
    if lam > 0.0:
        gx, gy, gz = quat_rotate_t(goal_rot[attach], hip_local)
        hx += lam * (goal_pos[attach, 0] + gx - hx)
        hy += lam * (goal_pos[attach, 1] + gy - hy)
        hz += lam * (goal_pos[attach, 2] + gz - hz)
    return hx, hy, hz, lam


@njit(cache=True)
def goals_above_ground(rows, ground_set, goal_pos, goal_rot, goal_pw, goal_rw, rest_rot, body_extent, body_floor):
    """Goals kept out of the ground a standing character stands on (character space z = 0;
    rows whose gait set a terrain, ``ground_set``, are the gait's to place): a position goal
    whose box, turned by its rotation goal (the rest rotation without one), would have its
    lowest corner below ``body_floor[b]`` (the lower of 0 and that corner at rest, so the
    rest pose is untouched) is raised until the corner is there. A clip authored on a
    creature whose hands hang at the hips moves them down in the same way on a knuckle
    walker whose hands rest on the ground: the goal would be in the ground, and the IK
    meets goals exactly, so the hand went in with it. Lifting is continuous in the goal
    (a max), so fades and sweeps stay smooth."""
    nbody = goal_pos.shape[1]
    v = np.empty(3)
    for i in range(rows.shape[0]):
        r = rows[i]
        if ground_set[r]:
            continue
        for b in range(1, nbody):
            if goal_pw[r, b] <= 0.0:
                continue
            q = goal_rot[r, b] if goal_rw[r, b] > 0.0 else rest_rot[b]
            below = body_floor[b] - (goal_pos[r, b, 2] + _lowest_corner(q, body_extent[b], v))
            if below > 0.0:
                goal_pos[r, b, 2] += below


@njit(cache=True)
def skinning_into(world_pos, world_rot, inv_bind, out):
    """Skinning matrices (nbody, 4, 4): world transform times the inverse rest (bind)
    transform, so a vertex at rest maps to where its body is now."""
    m = np.empty((4, 4))
    for b in range(world_pos.shape[0]):
        w, x, y, z = world_rot[b, 0], world_rot[b, 1], world_rot[b, 2], world_rot[b, 3]
        m[0, 0] = 1 - 2 * (y * y + z * z)
        m[0, 1] = 2 * (x * y - w * z)
        m[0, 2] = 2 * (x * z + w * y)
        m[1, 0] = 2 * (x * y + w * z)
        m[1, 1] = 1 - 2 * (x * x + z * z)
        m[1, 2] = 2 * (y * z - w * x)
        m[2, 0] = 2 * (x * z - w * y)
        m[2, 1] = 2 * (y * z + w * x)
        m[2, 2] = 1 - 2 * (x * x + y * y)
        for i in range(3):
            m[i, 3] = world_pos[b, i]
            m[3, i] = 0.0
        m[3, 3] = 1.0
        for i in range(4):
            for j in range(4):
                acc = 0.0
                for k in range(4):
                    acc += m[i, k] * inv_bind[b, k, j]
                out[b, i, j] = acc


@njit(cache=True)
def gather_times(slot_time, pair_char, pair_slot, out):
    """Local clip time of each (character, slot) pair."""
    for k in range(pair_char.shape[0]):
        out[k] = slot_time[pair_char[k], pair_slot[k]]
