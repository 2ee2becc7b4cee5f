"""The standing controller of the response's simulations (numba, allocation-free).

A frozen pose held by soft PD servos sags under its own weight, and a sagging pose on its
feet is an inverted pendulum: unhit, the lookahead of a humanoid fell by 1 s and a bat's
collapsed in 0.2 s, so every tap read as a fall. Once per frame this kernel writes
joint torques (as equal and opposite body torques on each joint's two bodies) that:

* **compensate gravity** and **carry the weight to the supports**: for each joint j with
  distal subtree D_j, the static torque
      tau_j = -(c_D - p_j) x m_D g - sum_{supports i in D_j} [(p_i - p_j) x f_i + T_i]
  (Jacobian transpose: the supports push the ground with -f_i, -T_i). Subtrees with no
  support (arms, tails, heads) get plain gravity compensation; stance legs carry the body.
* **balance**: the ground forces f_i = w_i (M g_up + F_h) share the weight so their centre
  of pressure sits under the centre of mass (least squares over the supports, shares
  clipped at 0);
* **balance** with a wrench on the root, as the ground would give it through stiff legs:
  a horizontal force F_h = M (kp (s + c_ref - c) - kd v_c) toward where the centre of mass
  stood at the hit over the supports' centre s (c_ref taken relative to s then), and a
  torque I (kp_r rotvec(q_root -> q_ref) - kd_r w) back to the root's orientation then
  (I the whole body's inertia tensor about its centre of mass, I w its angular momentum
  there). Both are limited
  to what the supports could give (|F_h| <= 0.5 M g, |T| <= M g times the supports'
  reach from their centre), so a strong hit still topples the body: the controller
  answers taps, not knock-downs. (Realizing the balance through the legs as support
  moments T_i, Jacobian-transpose, was tried first: the feet's moments saturate at once
  and the humanoid still fell by 1 s.)

Supports are the foot bodies whose lowest contact feature is within ``tol`` of the ground
(every body with ground features when no foot touches: a snake, a creature lying down).
All arrays are float64 / int32, preallocated by the caller (``Stander``).
"""

from __future__ import annotations

import math

from numba import njit

from engine.physics._kernels import terrain_sample


@njit(cache=True)
def _rotate(q, b, vx, vy, vz):
    w, x, y, z = q[b, 0], q[b, 1], q[b, 2], q[b, 3]
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz), vz + w * tz + (x * ty - y * tx))


@njit(cache=True)
def stand_torques(pos, rot, linvel, angvel, force, torque, mass, inertia, body_parent, body_joint, joint_anchor_parent,
                  joint_locked, body_foot, body_press, feat_body, feat_local, feat_radius, terrain, tparams, gravity,
                  ref, gains, scratch, support, out):
    """Add the standing torques to ``torque`` (n, 3) in place.

    inertia (n, 3): each body's principal moments in its own frame (kg m^2).

    ref (7,): c_ref x, y (where the centre of mass stood at the hit, relative to the
        supports' centre then: the reference goes where the supports go),
        q_ref (4) the root's orientation to hold, and a flag (1: the reference is set;
        0: set it from this frame and store it).
    gains (8,): kp, kd of the centre of mass (1/s^2, 1/s), kp_r, kd_r of the root's
        orientation, the support tolerance (m), the fraction of full balance (0..1), and
        1 to write the weight-carrying joint torques (0: the root's balance wrench alone),
        the least reach (m) of the supports' moment (the rest stance's own lean).
    body_press (n,): how far (m) a support's pressure centre can move from its centre:
        its moment is limited to that times the weight it carries.
    scratch (n, 8): subtree mass, mass-weighted position, support force sums, moment sums.
    support (n, 4): per body: 1 if a support, its contact point (x, y, z).
    out (8,): written: number of supports, centre of mass xyz, shares' residual, root
        error (rad), the weight carried by the supports (fraction), 0.
    """
    n = pos.shape[0]
    tol = gains[4]
    gx, gy, gz = gravity[0], gravity[1], gravity[2]
    g = math.sqrt(gx * gx + gy * gy + gz * gz)
    # -- subtree masses and centres (bodies are in tree order: parent before child) --------
    for b in range(n):
        scratch[b, 0] = mass[b]
        scratch[b, 1] = mass[b] * pos[b, 0]
        scratch[b, 2] = mass[b] * pos[b, 1]
        scratch[b, 3] = mass[b] * pos[b, 2]
        for k in range(4):
            support[b, k] = 0.0
    M = 0.0
    cx = cy = cz = 0.0
    vx = vy = vz = 0.0
    for b in range(n):
        M += mass[b]
        cx += mass[b] * pos[b, 0]
        cy += mass[b] * pos[b, 1]
        cz += mass[b] * pos[b, 2]
        vx += mass[b] * linvel[b, 0]
        vy += mass[b] * linvel[b, 1]
        vz += mass[b] * linvel[b, 2]
    cx /= M
    cy /= M
    cz /= M
    vx /= M
    vy /= M
    vz /= M
    for b in range(n - 1, 0, -1):
        p = body_parent[b]
        if p >= 0:
            for k in range(4):
                scratch[p, k] += scratch[b, k]
    # -- supports: feet on the ground (else any body on it) --------------------------------
    ns = 0
    for pass_ in range(2):
        ns = 0
        for f in range(feat_body.shape[0]):
            b = feat_body[f]
            if pass_ == 0 and body_foot[b] == 0:
                continue
            rx, ry, rz = _rotate(rot, b, feat_local[f, 0], feat_local[f, 1], feat_local[f, 2])
            px, py, pz = pos[b, 0] + rx, pos[b, 1] + ry, pos[b, 2] + rz
            h, nx, ny, nz = terrain_sample(terrain, tparams[0], tparams[1], tparams[2], px, py)
            if pz - feat_radius[f] - h < tol:
                if support[b, 0] == 0.0:
                    ns += 1
                support[b, 0] += 1.0
                support[b, 1] += px
                support[b, 2] += py
                support[b, 3] += h
        if ns > 0:
            break
    out[0] = ns
    out[1], out[2], out[3] = cx, cy, cz
    if ns == 0:
        # nothing on the ground: gravity compensation would hold the body up in the air
        return
    sx = sy = 0.0
    for b in range(n):
        if support[b, 0] > 0.0:
            c = support[b, 0]
            support[b, 1] /= c
            support[b, 2] /= c
            support[b, 3] /= c
            support[b, 0] = 1.0
            sx += support[b, 1]
            sy += support[b, 2]
    sx /= ns
    sy /= ns
    # -- shares: least squares change from equal so the pressure centre is under the COM --
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    for b in range(n):
        if support[b, 0] > 0.0:
            x = support[b, 1] - sx
            y = support[b, 2] - sy
            a00 += 1.0
            a01 += x
            a02 += y
            a11 += x * x
            a12 += x * y
            a22 += y * y
    # rhs: sum w = 1 (already by equal shares), sum w x = cx - sx, sum w y = cy - sy
    r1 = cx - sx
    r2 = cy - sy
    # solve the 2x2 of the centred system (a01, a02 are 0 by centring), regularized so a
    # direction the supports do not span (two feet side by side) moves no share
    eps = 0.05 * (a11 + a22) + 1e-12
    d = (a11 + eps) * (a22 + eps) - a12 * a12
    l1 = ((a22 + eps) * r1 - a12 * r2) / d
    l2 = ((a11 + eps) * r2 - a12 * r1) / d
    wsum = 0.0
    for b in range(n):
        if support[b, 0] > 0.0:
            w = 1.0 / ns + l1 * (support[b, 1] - sx) + l2 * (support[b, 2] - sy)
            if w < 0.0:
                w = 0.0
            scratch[b, 4] = w
            wsum += w
        else:
            scratch[b, 4] = 0.0
    if wsum <= 0.0:
        for b in range(n):
            if support[b, 0] > 0.0:
                scratch[b, 4] = 1.0 / ns
        wsum = 1.0
    # pressure centre actually reached
    ex = ey = 0.0
    for b in range(n):
        scratch[b, 4] /= wsum
        if support[b, 0] > 0.0:
            ex += scratch[b, 4] * support[b, 1]
            ey += scratch[b, 4] * support[b, 2]
    out[4] = math.sqrt((ex - cx) ** 2 + (ey - cy) ** 2)
    # -- the reference: where the COM stood over the supports, the root's orientation ----
    # Relative to the supports' centre: until s40 c_ref was a fixed point in the world, and a
    # push that slid the feet 26% of the height along (random 20, 1.5 m/s) was pulled back by
    # the wrench past where it stood (9% of the height the other way at the hand-off), the feet
    # sliding back under a force no ground gives. The ground holds the centre of mass over the
    # feet wherever they are.
    if ref[6] == 0.0:
        ref[0] = cx - sx
        ref[1] = cy - sy
        for k in range(4):
            ref[2 + k] = rot[0, k]
        ref[6] = 1.0
    frac = gains[5]
    fhx = M * frac * (gains[0] * (sx + ref[0] - cx) - gains[1] * vx)
    fhy = M * frac * (gains[0] * (sy + ref[1] - cy) - gains[1] * vy)
    # friction cone of the whole support (mu ~ 0.5 of the weight)
    fh = math.sqrt(fhx * fhx + fhy * fhy)
    lim = 0.5 * M * g
    if fh > lim:
        fhx *= lim / fh
        fhy *= lim / fh
    # root orientation error: rotvec of q_ref q_root^-1 (world)
    qw, qx, qy, qz = rot[0, 0], rot[0, 1], rot[0, 2], rot[0, 3]
    rw, rx_, ry_, rz_ = ref[2], ref[3], ref[4], ref[5]
    # d = q_ref * conj(q_root)
    dw = rw * qw + rx_ * qx + ry_ * qy + rz_ * qz
    dx = -rw * qx + qw * rx_ - (ry_ * qz - rz_ * qy)
    dy = -rw * qy + qw * ry_ - (rz_ * qx - rx_ * qz)
    dz = -rw * qz + qw * rz_ - (rx_ * qy - ry_ * qx)
    if dw < 0.0:
        dw, dx, dy, dz = -dw, -dx, -dy, -dz
    sn = math.sqrt(dx * dx + dy * dy + dz * dz)
    ang = 2.0 * math.atan2(sn, dw)
    kk = ang / sn if sn > 1e-12 else 2.0
    ex, ey, ez = dx * kk, dy * kk, dz * kk
    out[5] = ang
    # The root's turn back, as a torque on the whole body: I (kp_r e - kd_r w) with I the whole
    # body's inertia tensor about its centre of mass and w = I^-1 L its angular velocity (L
    # its angular momentum about the COM), so the damping is simply -kd_r L.
    # Until s40: I was a scalar (the trace's mean) and w the mass-weighted mean of the bodies'
    # angular velocities. The scalar made the roll of a long low body 14 times stiffer than
    # its inertia (centipede: 1.2 m long, 6.5 cm high), and held for a frame that vibrated it
    # at 0.5-1 rad a frame after a 0.003 N s tap; the mean counted a 2 mm tail segment
    # spinning at 300 rad/s as if its share of the mass turned the whole body, and fed that
    # spin back (random 44, its tail from 9 to 300 rad/s in six frames).
    ixx = iyy = izz = ixy = ixz = iyz = 0.0
    lx = ly = lz = 0.0
    for b in range(n):
        ddx, ddy, ddz = pos[b, 0] - cx, pos[b, 1] - cy, pos[b, 2] - cz
        m_ = mass[b]
        ixx += m_ * (ddy * ddy + ddz * ddz)
        iyy += m_ * (ddx * ddx + ddz * ddz)
        izz += m_ * (ddx * ddx + ddy * ddy)
        ixy -= m_ * ddx * ddy
        ixz -= m_ * ddx * ddz
        iyz -= m_ * ddy * ddz
        ux, uy, uz = linvel[b, 0] - vx, linvel[b, 1] - vy, linvel[b, 2] - vz
        lx += m_ * (ddy * uz - ddz * uy)
        ly += m_ * (ddz * ux - ddx * uz)
        lz += m_ * (ddx * uy - ddy * ux)
        # the body's own inertia sum_k I_k a_k a_k^T (a_k its principal axes in the world) and
        # its own spin's momentum sum_k I_k a_k (a_k . w)
        ox, oy, oz = angvel[b, 0], angvel[b, 1], angvel[b, 2]
        for k in range(3):
            ax, ay, az = _rotate(rot, b, 1.0 if k == 0 else 0.0, 1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0)
            ik = inertia[b, k]
            ixx += ik * ax * ax
            iyy += ik * ay * ay
            izz += ik * az * az
            ixy += ik * ax * ay
            ixz += ik * ax * az
            iyz += ik * ay * az
            sp = ik * (ax * ox + ay * oy + az * oz)
            lx += sp * ax
            ly += sp * ay
            lz += sp * az
    tvx = frac * (gains[2] * (ixx * ex + ixy * ey + ixz * ez) - gains[3] * lx)
    tvy = frac * (gains[2] * (ixy * ex + iyy * ey + iyz * ez) - gains[3] * ly)
    tvz = frac * (gains[2] * (ixz * ex + iyz * ey + izz * ez) - gains[3] * lz)
    # ground forces f_i = w_i (M g_up + F_h); their moment about the COM
    mx = my = mz = 0.0
    for b in range(n):
        w = scratch[b, 4]
        if w > 0.0:
            fx = -w * M * gx
            fy = -w * M * gy
            fz = -w * M * gz
            scratch[b, 5] = fx
            scratch[b, 6] = fy
            scratch[b, 7] = fz
            ax, ay, az = support[b, 1] - cx, support[b, 2] - cy, support[b, 3] - cz
            mx += ay * fz - az * fy
            my += az * fx - ax * fz
            mz += ax * fy - ay * fx
        else:
            scratch[b, 5] = 0.0
            scratch[b, 6] = 0.0
            scratch[b, 7] = 0.0
    # the residual moment the supports' moments T_i supply, shared by w_i, limited per foot
    # (the moment of the weight's shares about the COM, mx, my, mz, is the ground's to
    # balance: its pressure centre moves within the supports by itself)
    resx, resy, resz = tvx, tvy, tvz
    # The balance wrench (F_h, and the moment the weight's shares leave unbalanced plus the
    # root's turn back) acts on the root, as the ground would through stiff legs: limited to
    # what the supports could give (friction 0.5 of the weight; the weight times the
    # supports' reach from their centre), so a strong hit still topples the body.
    reach = 0.0
    for b in range(n):
        if support[b, 0] > 0.0:
            rr = math.sqrt((support[b, 1] - sx) ** 2 + (support[b, 2] - sy) ** 2) + body_press[b]
            if rr > reach:
                reach = rr
    if reach < gains[7]:
        reach = gains[7]
    lim = M * g * reach
    tn = math.sqrt(resx * resx + resy * resy + resz * resz)
    if tn > lim:
        resx *= lim / tn
        resy *= lim / tn
        resz *= lim / tn
    torque[0, 0] += resx
    torque[0, 1] += resy
    torque[0, 2] += resz
    force[0, 0] += fhx
    force[0, 1] += fhy
    if gains[6] == 0.0:
        # the balance wrench alone: stance legs held stiff by anchored servos carry it
        out[6] = 1.0
        return
    # -- joint torques, distal to proximal ------------------------------------------------
    # scratch[b, 5:8] becomes the sum of f_i over the supports in b's subtree, support[b, 1:4]
    # the sum of p_i x f_i + T_i (moments about the world origin), so that
    # sum (p_i - p_j) x f_i + T_i = that sum - p_j x sum f_i.
    for b in range(n):
        w = scratch[b, 4]
        if w > 0.0:
            tx, ty, tz = 0.0, 0.0, 0.0
            px, py, pz = support[b, 1], support[b, 2], support[b, 3]
            fx, fy, fz = scratch[b, 5], scratch[b, 6], scratch[b, 7]
            support[b, 1] = py * fz - pz * fy + tx
            support[b, 2] = pz * fx - px * fz + ty
            support[b, 3] = px * fy - py * fx + tz
        else:
            support[b, 1] = 0.0
            support[b, 2] = 0.0
            support[b, 3] = 0.0
    for b in range(n - 1, 0, -1):
        p = body_parent[b]
        j = body_joint[b]
        # joint point (world) from the parent's side
        ox, oy, oz = _rotate(rot, p, joint_anchor_parent[j, 0], joint_anchor_parent[j, 1], joint_anchor_parent[j, 2])
        jx, jy, jz = pos[p, 0] + ox, pos[p, 1] + oy, pos[p, 2] + oz
        if joint_locked[j] == 0:
            md = scratch[b, 0]
            dcx = scratch[b, 1] / md - jx
            dcy = scratch[b, 2] / md - jy
            dcz = scratch[b, 3] / md - jz
            # -(c_D - p_j) x m_D g
            tx = -(dcy * md * gz - dcz * md * gy)
            ty = -(dcz * md * gx - dcx * md * gz)
            tz = -(dcx * md * gy - dcy * md * gx)
            # - [sum p_i x f_i + T_i - p_j x sum f_i]
            sfx, sfy, sfz = scratch[b, 5], scratch[b, 6], scratch[b, 7]
            tx -= support[b, 1] - (jy * sfz - jz * sfy)
            ty -= support[b, 2] - (jz * sfx - jx * sfz)
            tz -= support[b, 3] - (jx * sfy - jy * sfx)
            torque[b, 0] += tx
            torque[b, 1] += ty
            torque[b, 2] += tz
            torque[p, 0] -= tx
            torque[p, 1] -= ty
            torque[p, 2] -= tz
        for k in range(3):
            scratch[p, 5 + k] += scratch[b, 5 + k]
            support[p, 1 + k] += support[b, 1 + k]
    s = 0.0
    for b in range(n):
        s += scratch[b, 4]
    out[6] = s
