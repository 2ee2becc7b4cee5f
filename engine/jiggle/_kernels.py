"""Jiggles kernels: passive, highly damped secondary motion (Hecker et al. 2008, sec. 4.4).

Each body that is not driven this frame (no IK, no animation) follows its parent rigidly
at its rest offset, plus a lag: a point at the body's *tip* (its lever, see
``engine.jiggle.rig``) is a damped spring toward where the rigid pose would put it. The
body is then turned by the minimal-twist rotation that takes the rigid lever to the
simulated one. Nothing feeds back: driven bodies are read, never written.

The spring, per tip, in error coordinates e = p - p* (p the simulated tip, p* the rigid
target), with target velocity u* and its change du* over the step:

    e'' = -w^2 e - 2 z w e'         (w = 2 pi f, z the damping ratio)

integrated by implicit (backward) Euler, which is unconditionally stable, so any dt from
1/240 s to 1/15 s (and beyond) is safe:

    e'_{n+1} = (e'_n - du* - dt w^2 e_n) / (1 + 2 z w dt + w^2 dt^2)
    e_{n+1}  = e_n + dt e'_{n+1}

The target's change of velocity du* enters as an impulse on the error velocity: when the
parent stops suddenly the tip swings on, then settles.

The rigid target p* of a body is where the *rigid* chain from its driven ancestor would put
its tip (every passive body between them at its rest offset), not where its jiggling parent
is: each spring is driven by the motion of the driven ancestor only. The exception is a
body much shorter than its parent (``JiggleRig.follow``: an eye, an ear or a jaw on a head):
it hangs from its posed parent, whose lag it shares, since a two-centimetre eye pointed
from where the swinging head puts its socket at where the rigid head would have it spins. Driving a link by its
parent's own swing makes a chain of springs a whip: on a 6-link, 4.5 m tail a 0.8 m drop of
the hips swung the tip 3 m and rang for seconds. The body is still attached to its posed
(jiggling) parent, so the chain stays connected, and its lever points from there to its
simulated tip (the rigid chain's tip plus its lag): the lag is a displacement of the tip,
not a turn the links further out inherit and add to. Once |e| and |e'| fall below a
sleep threshold they are set to exactly zero, so a body at rest is exactly at rest (no
endless twitching). The error is clamped to a fraction of the lever length so a teleport
or a huge dt cannot fold a body over; an error already beyond the clamp (a body handed
over from the IK far from its rigid pose, as a clip ends) may shrink but not grow, so the
hand-off is continuous and the body swings back.

The ground is a separate turn about the joint (``state_contact``): the turn that lifts the
body's box out of the plane (``_ground_contact``), kept from frame to frame, relaxed a
little every step and lifted again as far as the plane needs, so a tail lying on the
ground rests there while its spring keeps its own state.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from engine.mathx.quat import (
    quat_between_into,
    quat_between_t,
    quat_from_axis_angle_t,
    quat_mul_into,
    quat_mul_t,
    quat_rotate_into,
    quat_rotate_t,
    quat_twist_angle_t,
)

#: Largest share of a body's lever its parent's lag may push its tip by (see the kernel).
PARENT_SHARE = 0.3
#: Largest deflection, as a share of the lever, a body handed over from the IK keeps (it
#: then swings back).
HANDOFF_SHARE = 0.9
#: Largest deviation of a simulated lever from the rigid one, as a share of the lever.
DEVIATION = 0.9
#: Largest change of a body's deflection in a 60 Hz frame, as a share of its lever (about
#: 0.12 rad of turn). At 0.25 the fingers and hands of captured skeletons, hanging passive
#: off a wrist the IK swings into a clip, turned 0.5-0.8 rad in a frame as the clip faded in
#: (grid over ../shared/data: flips 40 -> 27 at 0.12, no cell worse by its verdict).
RATE = 0.12
#: Largest change of a hand-off twist in a 60 Hz frame, rad (under the validation grid's
#: 0.25 rad/frame warning).
TWIST_RATE = 0.15
#: Largest turn of the ground lift in one step, rad (a body meeting the ground fast is lifted
#: over a few frames; the hold, ``CONTACT_RELEASE``, keeps what was lifted), and the samples of
#: the turn it cuts back from (``_ground_contact``).
LIFT_MAX = 0.4
LIFT_SAMPLES = 8
#: A deep corner asks the ground lift for at most this many times its depth over the body's
#: reach, in radians, per step (``_ground_contact``).
LIFT_RATE = 3.0
#: Share of the ground's hold on a passive body (the turn it was lifted by) released each 60 Hz
#: frame: a body the ground no longer holds settles back to its spring in about a third of a
#: second (``jiggle_kernel``). Measured on the reaction grid (library + random 4242-4261):
#: 0.05 gives 43 cells with a flip, 0.2 and 0.5 more (and more bodies in the ground).
CONTACT_RELEASE = 0.05
#: A hand-off twist below this (rad, and rad per spring period for its rate) sleeps.
TWIST_SLEEP = 1e-4


@njit(cache=True)
def jiggle_kernel(
    body_parent,        # (n,) int32, global parent index (-1: a root, always driven)
    body_local_rot,     # (n, 4) rest rotation relative to the parent
    body_local_joint,   # (n, 3) joint point in the parent's frame
    body_joint_offset,  # (n, 3) body origin relative to its joint, in its own frame
    jig_lever,          # (n, 3) lever from the joint to the tip, body frame, m
    jig_omega,          # (n,) spring angular frequency, rad/s
    jig_zeta,           # (n,) damping ratio
    jig_max_err,        # (n,) largest tip deflection, m
    jig_sleep,          # (n,) sleep threshold on |e| (m) and |e'| (m/s)
    jig_follow,         # (n,) bool: the rigid chain restarts at the posed parent (short bodies)
    body_extent,        # (n, 3) box half-extents, body frame, m
    ground,             # (4,) the ground plane (nx, ny, nz, d): n . x = d, n up, unit
    driven,             # (n,) bool: written by IK/FK this frame, left alone here
    world_pos,          # (n, 3) in: driven bodies; out: the others
    world_rot,          # (n, 4) same
    state_err,          # (n, 3) tip error e
    state_err_vel,      # (n, 3) tip error velocity e'
    state_target,       # (n, 3) last rigid target tip
    state_target_vel,   # (n, 3) last rigid target tip velocity
    state_active,       # (n,) bool: simulated last frame
    state_twist,        # (n, 2) twist about the lever kept from a hand-off, rad, and its rate, rad/s
    state_contact,      # (n, 4) the turn about its joint the ground holds the body by (w-first), relaxed
                        #   toward none every step and lifted again as far as the ground needs
    chain_joint,        # (n, 3) scratch: rigid-chain joint position of each passive body
    chain_rot,          # (n, 4) scratch: rigid-chain rotation of each passive body
    dt,                 # step, s (> 0)
    simulate,           # False: rigid follow only (the stage switched off)
):
    n = body_parent.shape[0]
    rigid_rot = np.empty(4)
    joint_world = np.empty(3)
    lever_rigid = np.empty(3)
    lever_sim = np.empty(3)
    target = np.empty(3)
    turn = np.empty(4)
    final_rot = np.empty(4)
    offset = np.empty(3)
    tmp = np.empty(3)
    corners = np.empty((8, 3))
    # Rigid chain pose of every passive body (into the scratch ``chain_*``): joint position
    # and rotation it would have at its rest offsets below its driven ancestor (bodies are
    # ordered parents first).
    chain_origin = np.empty(3)
    for i in range(n):
        if driven[i]:
            state_active[i] = False
            continue
        p = body_parent[i]
        # Where the rigid chain puts the parent: the parent itself when it is driven, or
        # when this body follows its posed parent (a short body on a long one: an eye on
        # a swinging head moves with the head; its own spring adds only its own lag).
        if driven[p] or jig_follow[i]:
            quat_mul_into(world_rot[p], body_local_rot[i], chain_rot[i])
            quat_rotate_into(world_rot[p], body_local_joint[i], tmp)
            for k in range(3):
                chain_joint[i, k] = world_pos[p, k] + tmp[k]
        else:
            quat_mul_into(chain_rot[p], body_local_rot[i], chain_rot[i])
            quat_rotate_into(chain_rot[p], body_joint_offset[p], chain_origin)
            quat_rotate_into(chain_rot[p], body_local_joint[i], tmp)
            for k in range(3):
                chain_joint[i, k] = chain_joint[p, k] + chain_origin[k] + tmp[k]
        # The body hangs at its joint on the posed (possibly jiggling) parent; its
        # rotation is the rigid chain's turned by its own lag, so lags do not compound
        # down the chain; the spring's target tip is the rigid chain's (module note).
        quat_rotate_into(world_rot[p], body_local_joint[i], tmp)
        for k in range(3):
            joint_world[k] = world_pos[p, k] + tmp[k]
        for k in range(4):
            rigid_rot[k] = chain_rot[i, k]
        quat_rotate_into(rigid_rot, jig_lever[i], lever_rigid)
        for k in range(3):
            target[k] = chain_joint[i, k] + lever_rigid[k]

        if not simulate or jig_omega[i] <= 0.0:
            state_active[i] = False
            state_twist[i, 0] = 0.0
            state_twist[i, 1] = 0.0
            _clear_contact(state_contact, i)
            for k in range(4):
                final_rot[k] = rigid_rot[k]
        else:
            if not state_active[i]:
                # Becomes passive this frame: start from the turn it had last frame
                # (continuity with the driven pose: world_rot[i] still holds last frame's
                # output), at rest relative to the target. The error is set so that the
                # lever below points where the last pose pointed it (a rotation, not a tip
                # position: the joint has moved with the parent, and the parent's motion
                # must not turn a short body through its joint).
                quat_rotate_into(world_rot[i], jig_lever[i], tmp)
                lever_len = np.sqrt(lever_rigid[0] ** 2 + lever_rigid[1] ** 2 + lever_rigid[2] ** 2)
                dd = 0.0
                for k in range(3):
                    offset[k] = joint_world[k] - chain_joint[i, k]
                    dd += offset[k] * offset[k]
                cap = PARENT_SHARE * lever_len
                soft = 1.0 / np.sqrt(1.0 + dd / (cap * cap)) if cap > 0.0 else 0.0
                for k in range(3):
                    state_err[i, k] = tmp[k] - lever_rigid[k] + soft * offset[k]
                    state_err_vel[i, k] = 0.0
                    state_target[i, k] = target[k]
                    state_target_vel[i, k] = 0.0
                # The lever alone says nothing of the turn about it: the driven pose's twist
                # about its lever, over the shortest swing from the rigid lever, is kept
                # and springs back to zero like the deflection (else a body the IK twisted
                # turned back in one frame as a clip ended).
                state_twist[i, 0] = _handoff_twist(world_rot[i], rigid_rot, jig_lever[i], lever_rigid)
                state_twist[i, 1] = 0.0
                _clear_contact(state_contact, i)
                state_active[i] = True
            w = jig_omega[i]
            z = jig_zeta[i]
            denom = 1.0 + 2.0 * z * w * dt + w * w * dt * dt
            lever_len0 = np.sqrt(lever_rigid[0] ** 2 + lever_rigid[1] ** 2 + lever_rigid[2] ** 2)
            e_before = 0.0
            for k in range(3):
                e_before += state_err[i, k] * state_err[i, k]
            step2 = 0.0
            for k in range(3):
                u_new = (target[k] - state_target[i, k]) / dt
                du = u_new - state_target_vel[i, k]
                ev = (state_err_vel[i, k] - du - dt * w * w * state_err[i, k]) / denom
                offset[k] = dt * ev                      # this step's change of the deflection
                step2 += offset[k] * offset[k]
                state_target[i, k] = target[k]
                state_target_vel[i, k] = u_new
            # The deflection changes by at most RATE of the lever per 1/60 s: a short body
            # (a fingertip) kicked by its parent's stop would otherwise swing its whole
            # clamp in one frame, a flip; longer bodies never reach the limit.
            most = RATE * lever_len0 * dt * 60.0
            kick = most / np.sqrt(step2) if step2 > most * most else 1.0
            e2 = 0.0
            v2 = 0.0
            for k in range(3):
                state_err[i, k] += kick * offset[k]
                state_err_vel[i, k] = kick * offset[k] / dt
                e2 += state_err[i, k] * state_err[i, k]
                v2 += state_err_vel[i, k] * state_err_vel[i, k]
            # Clamp the deflection (a deflection beyond the limit may only shrink: a body
            # that just became passive far from its rigid target, at the end of a clip,
            # swings back from where it was instead of jumping to the limit); sleep when
            # settled.
            limit = max(jig_max_err[i], min(np.sqrt(e_before), HANDOFF_SHARE * lever_len0))
            if e2 > limit * limit:
                s = limit / np.sqrt(e2)
                for k in range(3):
                    state_err[i, k] *= s
            if e2 < jig_sleep[i] * jig_sleep[i] and v2 < jig_sleep[i] * jig_sleep[i]:
                for k in range(3):
                    state_err[i, k] = 0.0
                    state_err_vel[i, k] = 0.0
            # Point the lever from where the body hangs at its simulated tip (the rigid
            # chain's tip plus the lag), so a link's lag is a displacement of its own tip,
            # not a turn that every link further out would inherit. Where the body hangs
            # differs from the rigid chain's joint by its parent's lag d; a short body on a
            # long swinging parent (an eye on a head) would point its lever wherever d
            # says, even backwards through its joint, and spin. So d enters softly, at most
            # ``PARENT_SHARE`` of the lever (d / sqrt(1 + (|d| / (share |lever|))^2): about
            # d while small, never more).
            lever_len = np.sqrt(lever_rigid[0] ** 2 + lever_rigid[1] ** 2 + lever_rigid[2] ** 2)
            dd = 0.0
            for k in range(3):
                tmp[k] = joint_world[k] - chain_joint[i, k]
                dd += tmp[k] * tmp[k]
            cap = PARENT_SHARE * lever_len
            soft = 1.0 / np.sqrt(1.0 + dd / (cap * cap)) if cap > 0.0 else 0.0
            dev2 = 0.0
            for k in range(3):
                lever_sim[k] = state_err[i, k] - soft * tmp[k]
                dev2 += lever_sim[k] * lever_sim[k]
            # the tip's deviation from the rigid lever stays within DEVIATION of the lever
            # (a hand-off keeps up to HANDOFF_SHARE, the parent's lag adds PARENT_SHARE):
            # the lever never passes through the joint, the turn stays under 64 degrees
            cap = DEVIATION * lever_len
            dscale = cap / np.sqrt(dev2) if dev2 > cap * cap else 1.0
            for k in range(3):
                lever_sim[k] = lever_rigid[k] + dscale * lever_sim[k]
            quat_between_into(lever_rigid, lever_sim, turn)
            quat_mul_into(turn, rigid_rot, final_rot)
            tw = state_twist[i, 0]
            if tw != 0.0:
                twv = (state_twist[i, 1] - dt * w * w * tw) / denom
                # at most TWIST_RATE per 1/60 s, as the deflection's RATE: a stiff short
                # body (a jaw at 12 Hz) handed a whole radian would return it in 3 frames
                most = TWIST_RATE * dt * 60.0
                if abs(dt * twv) > most:
                    twv = most / dt if twv > 0.0 else -most / dt
                tw += dt * twv
                if abs(tw) < TWIST_SLEEP and abs(twv) < TWIST_SLEEP * w:
                    tw = 0.0
                    twv = 0.0
                state_twist[i, 0] = tw
                state_twist[i, 1] = twv
                if tw != 0.0:
                    tq = quat_from_axis_angle_t((lever_sim[0], lever_sim[1], lever_sim[2]), tw)
                    r4 = quat_mul_t(tq, final_rot)
                    for k in range(4):
                        final_rot[k] = r4[k]
            # The ground: a passive body does not swing into it (a tentacle or a tail lying
            # on the ground rests on it). The ground's own turn of the body about its joint
            # is kept from frame to frame (``state_contact``), relaxed toward none by
            # CONTACT_RELEASE each 60 Hz frame and lifted again as far as the ground needs
            # (``_ground_contact``). The spring goes on as if the ground were not there: it
            # holds a deflection of at most DEVIATION of its lever (it never folds through
            # its joint), so a body the ground holds further than that from its rigid pose
            # was lifted anew by up to a radian every frame when the spring carried the lift,
            # and a tail lying on the ground swept round its joint.
            gw = state_contact[i, 0]
            gx = state_contact[i, 1]
            gy = state_contact[i, 2]
            gz = state_contact[i, 3]
            gs = np.sqrt(gx * gx + gy * gy + gz * gz)
            if gs > 1e-12:
                ang = 2.0 * np.arctan2(gs, gw) * max(1.0 - CONTACT_RELEASE * dt * 60.0, 0.0)
                sh = np.sin(0.5 * ang) / gs
                gw, gx, gy, gz = np.cos(0.5 * ang), gx * sh, gy * sh, gz * sh
                if abs(ang) < 1e-9:
                    gw, gx, gy, gz = 1.0, 0.0, 0.0, 0.0
                r4 = quat_mul_t((gw, gx, gy, gz), (final_rot[0], final_rot[1], final_rot[2], final_rot[3]))
                for k in range(4):
                    final_rot[k] = r4[k]
            if _ground_contact(final_rot, joint_world, body_joint_offset[i], body_extent[i], ground, corners,
                               turn):
                r4 = quat_mul_t((turn[0], turn[1], turn[2], turn[3]), (gw, gx, gy, gz))
                gw, gx, gy, gz = r4[0], r4[1], r4[2], r4[3]
            gn = np.sqrt(gw * gw + gx * gx + gy * gy + gz * gz)
            state_contact[i, 0] = gw / gn
            state_contact[i, 1] = gx / gn
            state_contact[i, 2] = gy / gn
            state_contact[i, 3] = gz / gn

        # Body origin from its joint and final rotation.
        quat_rotate_into(final_rot, body_joint_offset[i], offset)
        for k in range(3):
            world_pos[i, k] = joint_world[k] + offset[k]
        for k in range(4):
            world_rot[i, k] = final_rot[k]


@njit(cache=True)
def _ground_contact(rot, joint, joint_offset, extent, ground, arms, dq):
    """Lift a box hanging at ``joint`` (its origin at ``joint + rot joint_offset``) out of
    the ground plane by turning ``rot`` in place about the joint. Returns whether it
    turned. A box far above the plane (origin higher than its half-diagonal) costs one
    dot product; ``arms`` (8, 3) and ``dq`` (4,) are scratch.

    The turn is about one horizontal axis k: the deep corners' own lift axes (a x n for a
    corner at arm a from the joint) summed by depth, so two far corners nearly level pull
    together and the body pitches without rolling between them. The rule this replaces
    lifted the lowest corner alone about its own arm: a flat body lying on the ground (a
    bat's tail membrane on its back) rolled one way in one frame and the other way in the
    next as its two far corners took turns being lowest (0.87 rad in a frame on a still
    pelvis), and a symmetric one lying flat (an inchworm's jaw) had a tie between its left
    and right. Under a turn t about k a corner's height is b + A cos t + B sin t, so each
    deep corner's smallest turn out is exact; the turn is the largest of them (continuous
    as corners change rank), each at most ``LIFT_RATE`` times its depth over the body's
    reach (a corner near the axis, beside the joint, whose depth is mostly its parent's,
    is lifted over frames, not in one jump), and at most ``LIFT_MAX``. It fades out where
    the deep corners' axes cancel (deep corners on both sides of the joint: no turn about
    the joint lifts the box as a whole) and where the joint itself is deeper than a
    quarter of the body's reach (the parent's depth: a snake's tongue under a jaw in the
    ground swung 1.8 rad a frame). Last, the turn is cut back to where the box's lowest
    point is highest (each corner asks for its own turn, and lifting one end of a box
    centred on its joint sinks the other: a snake's jaw rocked 0.5 rad a frame)."""
    ox, oy, oz = quat_rotate_t(rot, joint_offset)
    r = np.sqrt(extent[0] ** 2 + extent[1] ** 2 + extent[2] ** 2)
    hj = joint[0] * ground[0] + joint[1] * ground[1] + joint[2] * ground[2] - ground[3]
    if hj + ox * ground[0] + oy * ground[1] + oz * ground[2] >= r:
        return False
    # corners relative to the joint, the axis (deep corners' lift axes by depth), the reach
    reach = 0.0
    kx = ky = kz = 0.0
    tot = 0.0
    m = 0
    deep = False
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            for sz in (-1.0, 1.0):
                cx, cy, cz = quat_rotate_t4(rot, sx * extent[0], sy * extent[1], sz * extent[2])
                ax = cx + ox
                ay = cy + oy
                az = cz + oz
                arms[m, 0] = ax
                arms[m, 1] = ay
                arms[m, 2] = az
                m += 1
                reach = max(reach, np.sqrt(ax * ax + ay * ay + az * az))
                d = -(hj + ax * ground[0] + ay * ground[1] + az * ground[2])
                if d > 1e-9:
                    deep = True
                    ux = ay * ground[2] - az * ground[1]
                    uy = az * ground[0] - ax * ground[2]
                    uz = ax * ground[1] - ay * ground[0]
                    kx += d * ux
                    ky += d * uy
                    kz += d * uz
                    tot += d * np.sqrt(ux * ux + uy * uy + uz * uz)
    if not deep or reach < 1e-12:
        return False
    kn = np.sqrt(kx * kx + ky * ky + kz * kz)
    x = 0.0 if tot < 1e-18 else min(max((kn / tot - 0.2) / 0.3, 0.0), 1.0)
    confidence = x * x * (3.0 - 2.0 * x)
    x = min(max((hj + reach) / (0.75 * reach), 0.0), 1.0)
    confidence *= x * x * (3.0 - 2.0 * x)
    if confidence <= 0.0:
        return False
    kx /= kn
    ky /= kn
    kz /= kn
    k_n = kx * ground[0] + ky * ground[1] + kz * ground[2]
    angle = 0.0
    for c in range(8):
        base, A, B = _corner_wave(arms, c, hj, kx, ky, kz, k_n, ground)
        if base + A >= 0.0:
            continue      # above the plane
        R = np.sqrt(A * A + B * B)
        if R < 1e-12:
            continue
        phi = np.arctan2(B, A)          # the turn that raises it most
        if base + R <= 0.0:
            t = phi       # never out: as high as it goes
        else:             # R cos(t - phi) = -base
            t = phi - np.arccos(min(max(-base / R, -1.0), 1.0))
        t = min(t, LIFT_RATE * (-(base + A)) / reach)
        if t > angle:
            angle = t
    angle = min(angle * confidence, LIFT_MAX)
    if angle <= 1e-12:
        return False
    # The corners' turns are each their own: lifting one end of a box centred on its joint
    # sinks the other (a snake's jaw, its joint in the ground, rocked 0.5 rad a frame).
    # The turn is cut back to where the box's lowest point is highest over [0, angle]
    # (sampled, then a parabola through the best sample and its neighbours).
    best = 0
    f_best = -1e300
    for j in range(LIFT_SAMPLES + 1):
        f = _lowest_corner(arms, hj, kx, ky, kz, k_n, ground, angle * j / LIFT_SAMPLES)
        if f > f_best + 1e-12:
            f_best = f
            best = j
    if best < LIFT_SAMPLES:
        h = angle / LIFT_SAMPLES
        f0 = _lowest_corner(arms, hj, kx, ky, kz, k_n, ground, h * max(best - 1, 0))
        f2 = _lowest_corner(arms, hj, kx, ky, kz, k_n, ground, h * (best + 1))
        den = f0 - 2.0 * f_best + f2
        shift = 0.5 * (f0 - f2) / den if den < -1e-18 and best > 0 else 0.0
        angle = h * (best + min(max(shift, -0.5), 0.5))
        if angle <= 1e-12:
            return False
    s = np.sin(0.5 * angle)
    dq[0] = np.cos(0.5 * angle)
    dq[1] = kx * s
    dq[2] = ky * s
    dq[3] = kz * s
    w0, x0, y0, z0 = rot[0], rot[1], rot[2], rot[3]
    rot[0] = dq[0] * w0 - dq[1] * x0 - dq[2] * y0 - dq[3] * z0
    rot[1] = dq[0] * x0 + dq[1] * w0 + dq[2] * z0 - dq[3] * y0
    rot[2] = dq[0] * y0 - dq[1] * z0 + dq[2] * w0 + dq[3] * x0
    rot[3] = dq[0] * z0 + dq[1] * y0 - dq[2] * x0 + dq[3] * w0
    return True


@njit(cache=True, inline="always")
def _lowest_corner(arms, hj, kx, ky, kz, k_n, ground, t):
    """Height of the lowest of the corners ``arms`` (from a joint at height ``hj``) after
    a turn t about the horizontal unit axis k."""
    c = np.cos(t)
    s = np.sin(t)
    low = 1e300
    for i in range(arms.shape[0]):
        base, A, B = _corner_wave(arms, i, hj, kx, ky, kz, k_n, ground)
        h = base + A * c + B * s
        if h < low:
            low = h
    return low


@njit(cache=True, inline="always")
def _corner_wave(arms, i, hj, kx, ky, kz, k_n, ground):
    """(base, A, B): the height of corner ``arms[i]`` (from a joint at height ``hj``)
    after a turn t about the horizontal unit axis k is base + A cos t + B sin t."""
    ax, ay, az = arms[i, 0], arms[i, 1], arms[i, 2]
    along = ax * kx + ay * ky + az * kz
    A = ax * ground[0] + ay * ground[1] + az * ground[2] - along * k_n
    B = (ky * az - kz * ay) * ground[0] + (kz * ax - kx * az) * ground[1] + (kx * ay - ky * ax) * ground[2]
    return hj + along * k_n, A, B


@njit(cache=True, inline="always")
def _clear_contact(state_contact, i):
    """No ground hold on body ``i`` (the identity turn)."""
    state_contact[i, 0] = 1.0
    state_contact[i, 1] = 0.0
    state_contact[i, 2] = 0.0
    state_contact[i, 3] = 0.0


@njit(cache=True, inline="always")
def quat_rotate_t4(q, vx, vy, vz):
    """q rotating (vx, vy, vz), as a tuple."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz), vz + w * tz + (x * ty - y * tx))


@njit(cache=True)
def _handoff_twist(last_rot, rigid_rot, lever, lever_rigid):
    """The signed angle (rad, in (-pi, pi]) of ``last_rot`` about its own lever beyond the
    shortest swing that takes the rigid lever ``lever_rigid`` (world) there: what a
    lever-only spring would drop when a body turns passive."""
    lx, ly, lz = quat_rotate_t(last_rot, lever)
    nl = np.sqrt(lx * lx + ly * ly + lz * lz)
    if nl < 1e-12:
        return 0.0
    sr = quat_mul_t(quat_between_t(lever_rigid, (lx, ly, lz)), rigid_rot)
    # residual = last * conj(swing * rigid): a turn about the lever
    r = quat_mul_t(last_rot, (sr[0], -sr[1], -sr[2], -sr[3]))
    return quat_twist_angle_t(r, (lx / nl, ly / nl, lz / nl))
