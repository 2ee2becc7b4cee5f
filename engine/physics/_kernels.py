"""Numba kernels of the rigid-body integrator (see ``engine.physics.world`` for the API).

Formulation: substepped sequential impulses with soft constraints ("soft step", Catto,
Box2D v3 ``solver.c``), in 3-D. Each substep of length h:

    1. prepare      world inverse inertia, joint anchors and 3x3 effective masses,
                    contact detection (ground features vs terrain, capsule pairs across
                    characters) and contact effective masses
    2. velocities   gravity, user forces, the proportional velocity controller
                    (implicit), gyroscopic term (implicit, one Newton step in the body
                    frame), so thin fast-spinning limbs do not gain energy
    3. warm start   last substep's accumulated impulses (slots are persistent: ground
                    features and body pairs have fixed indices)
    4. solve        PD servos, contacts (sequential impulses), then the ball and locked
                    joints solved exactly on the body-joint tree (Baraff 1996, linear
                    time; or sequential impulses with solver 'gauss-seidel'); with bias:
                    position error is fed back at a soft rate
    5. positions    x += h v, q += h/2 (0, w) q
    6. relax        the same constraints without position bias, so the bias velocity
                    that pushed drift out does not stay in the bodies as energy

Why this formulation (issue 7): a ragdoll of a creature has mass ratios of 100:1 and
more (the library's spider 5500:1, a CMU thumb against the hips). Plain penalty joints
need stiffness that explodes with the mass ratio. Sequential impulses with substeps
(Box2D v3) handle one joint exactly and converge across a chain as O(h^2) per substep,
but a light body carrying heavy ones (a 20 g pelvis between two 2 kg legs, a heavy
weight on a light rope) still opens its joints by millimetres. So the joints are solved
directly: the saddle-point system [[M, J^T], [J, 0]] of a tree factors in linear time
with no fill-in (Baraff, "Linear-Time Dynamics using Lagrange Multipliers", 1996), which
makes every ball joint exact after each pass whatever the masses; contacts and servos,
which are inequalities or soft, stay sequential impulses around it. Soft constraints (b2MakeSoft)
are implicit springs, so the PD servos and the contact penalty are stable for any h and
any gain, and every stiffness is a frequency in Hz with a damping ratio, mass-normalized
by the constraint's effective mass: one setting works for a mouse and for a giant.

Soft constraint (b2MakeSoft, derived): a unit-mass spring-damper x'' = -w^2 x - 2 z w x'
integrated with implicit Euler over h gives the impulse
    lambda = -m_eff * mass_scale * (Cdot + bias_rate * C) - impulse_scale * lambda_acc
with w = 2 pi hz, a1 = 2 z + h w, a2 = h w a1, a3 = 1 / (1 + a2),
bias_rate = w / a1, mass_scale = a2 a3, impulse_scale = a3. hz = 0 means rigid.

Contacts (Zordan et al. 2005, section 5): feet use the paper's custom handler, a
penalty spring-damper (here integrated implicitly as a soft contact) with Coulomb
friction and a rotational friction about the normal that stops free spinning; other
ground contacts and contacts between bodies of two characters have their own frequency,
damping ratio and friction. Contacts are speculative (a body approaching the ground or
another body is stopped exactly at the surface within one substep: bias = sep / h), so
nothing tunnels at the speeds a heavy kick gives.

All arrays are float64 / int32, C order. Kernels take two NamedTuples of arrays (the
model ``m`` and the state ``s``) and scalars; they allocate nothing.
"""

from __future__ import annotations

import math

from numba import njit

# -- indices into ModelArrays.params (float64) -------------------------------------------
P_GRAVITY_X, P_GRAVITY_Y, P_GRAVITY_Z = 0, 1, 2
P_FOOT_HZ, P_FOOT_ZETA, P_FOOT_MU, P_FOOT_SPIN_MU = 3, 4, 5, 6
P_GROUND_HZ, P_GROUND_ZETA, P_GROUND_MU, P_GROUND_SPIN_MU = 7, 8, 9, 10
P_PAIR_HZ, P_PAIR_ZETA, P_PAIR_MU = 11, 12, 13
P_JOINT_HZ, P_JOINT_ZETA = 14, 15
P_MAX_PUSH, P_MARGIN = 16, 17
P_TERRAIN_X0, P_TERRAIN_Y0, P_TERRAIN_CELL = 18, 19, 20
P_SOLVER = 21          # 0: Gauss-Seidel ball joints, 1: direct tree solve
P_SERVO_ANCHOR = 22    # 1: a loaded foot anchors its side of a servo (WorldSettings.servo_anchor)
NPARAM = 23

# contact kinds per body
KIND_NONE, KIND_GROUND, KIND_FOOT = 0, 1, 2

# bodies whose ground contacts are solved through the articulated tree, at most (feet
# first; bodies past this many in contact at once keep the body-only contact rows)
MAX_CONTACT_BODIES = 16
# Gauss-Seidel sweeps over those contacts per pass, in contact space (no tree solve). 16, not 4:
# two planted feet are coupled sideways through the legs and their friction rows converge slowly;
# with 4 the standing humanoid's feet crept sideways (79 / 99 mm in 1 s at 1 iteration, 8 substeps,
# growing) and it fell sideways early, with 16 they move 1 / 4 mm (the converged solve's figure).
# Cost: a body lying on many contacts (16 slots) 235-264 -> 454 us per substep; standing, unchanged.
CONTACT_SWEEPS = 16


# ---------------------------------------------------------------------------------------
# Small scalar helpers (tuples, no arrays: numba keeps them in registers)
# ---------------------------------------------------------------------------------------


@njit(cache=True)
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(cache=True)
def _qrot(w, x, y, z, vx, vy, vz):
    """Rotate v by the unit quaternion (w, x, y, z): v + w t + q_v x t, t = 2 q_v x v."""
    tx, ty, tz = _cross(x, y, z, vx, vy, vz)
    tx *= 2.0
    ty *= 2.0
    tz *= 2.0
    cx, cy, cz = _cross(x, y, z, tx, ty, tz)
    return vx + w * tx + cx, vy + w * ty + cy, vz + w * tz + cz


@njit(cache=True)
def _qmul(aw, ax, ay, az, bw, bx, by, bz):
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(cache=True)
def _qrotvec(w, x, y, z):
    """Rotation vector (axis * angle, shortest way) of a unit quaternion."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    if s < 1e-12:
        return 2.0 * x, 2.0 * y, 2.0 * z
    angle = 2.0 * math.atan2(s, w)
    k = angle / s
    return k * x, k * y, k * z


@njit(cache=True)
def _mat3_vec(M, i, vx, vy, vz):
    """M[i] @ v for a stack of 3x3 matrices."""
    return (M[i, 0, 0] * vx + M[i, 0, 1] * vy + M[i, 0, 2] * vz,
            M[i, 1, 0] * vx + M[i, 1, 1] * vy + M[i, 1, 2] * vz,
            M[i, 2, 0] * vx + M[i, 2, 1] * vy + M[i, 2, 2] * vz)


@njit(cache=True)
def _soft(hz, zeta, h):
    """b2MakeSoft: (bias_rate, mass_scale, impulse_scale); hz <= 0 is rigid."""
    if hz <= 0.0:
        return 0.0, 1.0, 0.0
    omega = 2.0 * math.pi * hz
    a1 = 2.0 * zeta + h * omega
    a2 = h * omega * a1
    a3 = 1.0 / (1.0 + a2)
    return omega / a1, a2 * a3, a3


@njit(cache=True)
def _inv3_sym_into(a00, a01, a02, a11, a12, a22, out, i):
    """Inverse of a symmetric 3x3 matrix into out[i]; a singular matrix gives zeros
    (a constraint between two static bodies, which then does nothing)."""
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    det = a00 * c00 + a01 * c01 + a02 * c02
    if abs(det) < 1e-300:
        for r in range(3):
            for c in range(3):
                out[i, r, c] = 0.0
        return
    inv = 1.0 / det
    out[i, 0, 0] = c00 * inv
    out[i, 0, 1] = c01 * inv
    out[i, 0, 2] = c02 * inv
    out[i, 1, 0] = c01 * inv
    out[i, 1, 1] = (a00 * a22 - a02 * a02) * inv
    out[i, 1, 2] = (a02 * a01 - a00 * a12) * inv
    out[i, 2, 0] = c02 * inv
    out[i, 2, 1] = out[i, 1, 2]
    out[i, 2, 2] = (a00 * a11 - a01 * a01) * inv


# ---------------------------------------------------------------------------------------
# Applying impulses
# ---------------------------------------------------------------------------------------


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _apply(m, s, b, rx, ry, rz, px, py, pz, sign):
    """Linear impulse sign*P at offset r (world, from the COM) on body b (-1: ground)."""
    if b < 0:
        return
    im = m.body_inv_mass[b] * sign
    s.body_linvel[b, 0] += im * px
    s.body_linvel[b, 1] += im * py
    s.body_linvel[b, 2] += im * pz
    tx, ty, tz = _cross(rx, ry, rz, px, py, pz)
    dx, dy, dz = _mat3_vec(s.body_iinv_world, b, tx, ty, tz)
    s.body_angvel[b, 0] += sign * dx
    s.body_angvel[b, 1] += sign * dy
    s.body_angvel[b, 2] += sign * dz


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _apply_ang(s, b, lx, ly, lz, sign):
    """Angular impulse sign*L on body b (-1: ground)."""
    if b < 0:
        return
    dx, dy, dz = _mat3_vec(s.body_iinv_world, b, lx, ly, lz)
    s.body_angvel[b, 0] += sign * dx
    s.body_angvel[b, 1] += sign * dy
    s.body_angvel[b, 2] += sign * dz


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _point_vel(s, b, rx, ry, rz):
    if b < 0:
        return 0.0, 0.0, 0.0
    wx, wy, wz = s.body_angvel[b, 0], s.body_angvel[b, 1], s.body_angvel[b, 2]
    cx, cy, cz = _cross(wx, wy, wz, rx, ry, rz)
    return s.body_linvel[b, 0] + cx, s.body_linvel[b, 1] + cy, s.body_linvel[b, 2] + cz


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _inv_mass_dir(m, s, b, rx, ry, rz, dx, dy, dz):
    """Inverse effective mass of body b at r along unit direction d: 1/m + (r x d).I^-1(r x d)."""
    if b < 0:
        return 0.0
    cx, cy, cz = _cross(rx, ry, rz, dx, dy, dz)
    ix, iy, iz = _mat3_vec(s.body_iinv_world, b, cx, cy, cz)
    return m.body_inv_mass[b] + cx * ix + cy * iy + cz * iz


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _world_point(m, s, b, lx, ly, lz):
    q = s.body_rot
    rx, ry, rz = _qrot(q[b, 0], q[b, 1], q[b, 2], q[b, 3], lx, ly, lz)
    return s.body_pos[b, 0] + rx, s.body_pos[b, 1] + ry, s.body_pos[b, 2] + rz


# ---------------------------------------------------------------------------------------
# Terrain: a height grid, bilinear, clamped at its edges; the normal from its gradient
# ---------------------------------------------------------------------------------------


@njit(cache=True)
def terrain_sample(height, x0, y0, cell, x, y):
    """(height, nx, ny, nz) of the terrain at (x, y). A 1x1 grid is a flat plane."""
    nxg, nyg = height.shape[0], height.shape[1]
    if nxg < 2 or nyg < 2:
        return height[0, 0], 0.0, 0.0, 1.0
    u = (x - x0) / cell
    v = (y - y0) / cell
    u = min(max(u, 0.0), nxg - 1.000000001)
    v = min(max(v, 0.0), nyg - 1.000000001)
    i = int(u)
    j = int(v)
    fu = u - i
    fv = v - j
    h00 = height[i, j]
    h10 = height[i + 1, j]
    h01 = height[i, j + 1]
    h11 = height[i + 1, j + 1]
    hz = (h00 * (1 - fu) * (1 - fv) + h10 * fu * (1 - fv) + h01 * (1 - fu) * fv + h11 * fu * fv)
    dhdx = ((h10 - h00) * (1 - fv) + (h11 - h01) * fv) / cell
    dhdy = ((h01 - h00) * (1 - fu) + (h11 - h10) * fu) / cell
    inv = 1.0 / math.sqrt(dhdx * dhdx + dhdy * dhdy + 1.0)
    return hz, -dhdx * inv, -dhdy * inv, inv


@njit(cache=True)
def _tangents(nx, ny, nz):
    """Two unit tangents of unit normal n, chosen deterministically."""
    if abs(nx) < 0.57735:
        ax, ay, az = 1.0, 0.0, 0.0
    else:
        ax, ay, az = 0.0, 1.0, 0.0
    t1x, t1y, t1z = _cross(nx, ny, nz, ax, ay, az)
    inv = 1.0 / math.sqrt(t1x * t1x + t1y * t1y + t1z * t1z)
    t1x *= inv
    t1y *= inv
    t1z *= inv
    t2x, t2y, t2z = _cross(nx, ny, nz, t1x, t1y, t1z)
    return t1x, t1y, t1z, t2x, t2y, t2z


@njit(cache=True)
def _closest_segments(p1x, p1y, p1z, q1x, q1y, q1z, p2x, p2y, p2z, q2x, q2y, q2z):
    """Parameters (s, t) of the closest points of segments p1q1 and p2q2 (Ericson 5.1.9)."""
    d1x, d1y, d1z = q1x - p1x, q1y - p1y, q1z - p1z
    d2x, d2y, d2z = q2x - p2x, q2y - p2y, q2z - p2z
    rx, ry, rz = p1x - p2x, p1y - p2y, p1z - p2z
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    f = d2x * rx + d2y * ry + d2z * rz
    eps = 1e-12
    if a <= eps and e <= eps:
        return 0.0, 0.0
    if a <= eps:
        return 0.0, min(max(f / e, 0.0), 1.0)
    c = d1x * rx + d1y * ry + d1z * rz
    if e <= eps:
        return min(max(-c / a, 0.0), 1.0), 0.0
    b = d1x * d2x + d1y * d2y + d1z * d2z
    denom = a * e - b * b
    sp = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > eps else 0.0
    t = (b * sp + f) / e
    if t < 0.0:
        t = 0.0
        sp = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        sp = min(max((b - c) / a, 0.0), 1.0)
    return sp, t


# ---------------------------------------------------------------------------------------
# 1. prepare
# ---------------------------------------------------------------------------------------


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _servo_inertia_local(m, s):
    """PD servo inertia for the Gauss-Seidel solver: the child body alone about the joint,
    reduced with the parent body alone. Sequential impulses need the pair's own effective
    inertia (a sub-tree's would overshoot a light child and diverge); the cost is that a
    joint carrying a heavy sub-tree is softer and less damped than its setting."""
    for j in range(m.joint_parent.shape[0]):
        if m.joint_locked[j] != 0:
            continue
        a = m.joint_parent[j]
        b = m.joint_child[j]
        u00 = u01 = u02 = u11 = u12 = u22 = 0.0
        for side in range(2):
            bb = a if side == 0 else b
            if m.body_inv_mass[bb] == 0.0:
                continue
            r = s.joint_ra if side == 0 else s.joint_rb
            rx, ry, rz = r[j, 0], r[j, 1], r[j, 2]
            q = s.body_rot[bb]
            mass = 1.0 / m.body_inv_mass[bb]
            r2 = rx * rx + ry * ry + rz * rz
            e00 = e01 = e02 = e11 = e12 = e22 = 0.0
            for ax in range(3):
                cx, cy, cz = _qrot(q[0], q[1], q[2], q[3], 1.0 if ax == 0 else 0.0, 1.0 if ax == 1 else 0.0,
                                   1.0 if ax == 2 else 0.0)
                mom = m.body_inertia[bb, ax]
                e00 += mom * cx * cx
                e01 += mom * cx * cy
                e02 += mom * cx * cz
                e11 += mom * cy * cy
                e12 += mom * cy * cz
                e22 += mom * cz * cz
            e00 += mass * (r2 - rx * rx)
            e11 += mass * (r2 - ry * ry)
            e22 += mass * (r2 - rz * rz)
            e01 -= mass * rx * ry
            e02 -= mass * rx * rz
            e12 -= mass * ry * rz
            _inv3_sym_into(e00, e01, e02, e11, e12, e22, s.joint_pd_mass, j)
            P = s.joint_pd_mass
            u00 += P[j, 0, 0]
            u01 += P[j, 0, 1]
            u02 += P[j, 0, 2]
            u11 += P[j, 1, 1]
            u12 += P[j, 1, 2]
            u22 += P[j, 2, 2]
        P = s.joint_pd_invmass
        P[j, 0, 0], P[j, 0, 1], P[j, 0, 2] = u00, u01, u02
        P[j, 1, 0], P[j, 1, 1], P[j, 1, 2] = u01, u11, u12
        P[j, 2, 0], P[j, 2, 1], P[j, 2, 2] = u02, u12, u22
        _inv3_sym_into(u00, u01, u02, u11, u12, u22, s.joint_pd_mass, j)


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _servo_inertia(m, s):
    """PD servo inertia per joint (Zordan et al. 2005 section 4: "I is the inertial matrix
    of the outboard body"), taken as the whole outboard sub-tree about the joint point,
    reduced with the rest of the tree about the same point: I = (I_out^-1 + I_in^-1)^-1.
    About the joint, so a hanging rod set to f Hz swings at f Hz; the whole sub-tree, so
    a neck servo carrying a heavy head is as stiff, in Hz, as a finger's (the outboard
    body alone would leave the head's mode at a tenth of the damping asked for).

    Composite rigid bodies, one backward pass (children before parents): mass, first
    moment and second moment about a reference point (the first body's centre, against
    cancellation far from the origin); a fixed body makes its side immovable."""
    n = s.body_pos.shape[0]
    ox, oy, oz = s.body_pos[0, 0], s.body_pos[0, 1], s.body_pos[0, 2]
    sm = s.sub_mass
    sc = s.sub_moment
    sj = s.sub_second
    for b in range(n):
        sm[b] = 0.0
        s.sub_fixed[b] = 0
        for c in range(3):
            sc[b, c] = 0.0
            for d in range(3):
                sj[b, c, d] = 0.0
    anchor = m.params[P_SERVO_ANCHOR]
    if anchor != 0.0:
        # a foot (1) or any body (2) the ground pushed last substep anchors its side (see
        # WorldSettings.servo_anchor)
        for f in range(m.feat_body.shape[0]):
            b = m.feat_body[f]
            if (anchor > 1.5 or m.body_contact_kind[b] == KIND_FOOT) and s.feat_active[f] != 0 \
                    and s.feat_imp[f, 0] > 0.0:
                s.sub_fixed[b] = 2
    for b in range(n - 1, -1, -1):
        if m.body_inv_mass[b] == 0.0 or s.sub_fixed[b] == 2:
            s.sub_fixed[b] = 1
        else:
            mass = 1.0 / m.body_inv_mass[b]
            x = s.body_pos[b, 0] - ox
            y = s.body_pos[b, 1] - oy
            z = s.body_pos[b, 2] - oz
            q = s.body_rot[b]
            sm[b] += mass
            sc[b, 0] += mass * x
            sc[b, 1] += mass * y
            sc[b, 2] += mass * z
            # I_com (world) + m (|x|^2 E - x x^T)
            for ax in range(3):
                cx, cy, cz = _qrot(q[0], q[1], q[2], q[3], 1.0 if ax == 0 else 0.0, 1.0 if ax == 1 else 0.0,
                                   1.0 if ax == 2 else 0.0)
                mom = m.body_inertia[b, ax]
                sj[b, 0, 0] += mom * cx * cx
                sj[b, 0, 1] += mom * cx * cy
                sj[b, 0, 2] += mom * cx * cz
                sj[b, 1, 1] += mom * cy * cy
                sj[b, 1, 2] += mom * cy * cz
                sj[b, 2, 2] += mom * cz * cz
            r2 = x * x + y * y + z * z
            sj[b, 0, 0] += mass * (r2 - x * x)
            sj[b, 1, 1] += mass * (r2 - y * y)
            sj[b, 2, 2] += mass * (r2 - z * z)
            sj[b, 0, 1] -= mass * x * y
            sj[b, 0, 2] -= mass * x * z
            sj[b, 1, 2] -= mass * y * z
        j = m.body_joint[b]
        if j >= 0:
            p = m.joint_parent[j]
            sm[p] += sm[b]
            if s.sub_fixed[b]:
                s.sub_fixed[p] = 1
            for c in range(3):
                sc[p, c] += sc[b, c]
                for d in range(c, 3):
                    sj[p, c, d] += sj[b, c, d]
    # tree totals live at each tree's root; walk up once per joint to find it
    for j in range(m.joint_parent.shape[0]):
        if m.joint_locked[j] != 0:
            continue
        child = m.joint_child[j]
        root = child
        while m.body_joint[root] >= 0:
            root = m.joint_parent[m.body_joint[root]]
        # the joint point (from the parent side), relative to the reference
        px = s.body_pos[m.joint_parent[j], 0] + s.joint_ra[j, 0] - ox
        py = s.body_pos[m.joint_parent[j], 1] + s.joint_ra[j, 1] - oy
        pz = s.body_pos[m.joint_parent[j], 2] + s.joint_ra[j, 2] - oz
        u00 = u01 = u02 = u11 = u12 = u22 = 0.0
        for side in range(2):
            if side == 0:
                if s.sub_fixed[child]:
                    continue
                mass = sm[child]
                cx, cy, cz = sc[child, 0], sc[child, 1], sc[child, 2]
                j00, j01, j02 = sj[child, 0, 0], sj[child, 0, 1], sj[child, 0, 2]
                j11, j12, j22 = sj[child, 1, 1], sj[child, 1, 2], sj[child, 2, 2]
            else:
                if s.sub_fixed[root] and not s.sub_fixed[child]:
                    continue
                mass = sm[root] - sm[child]
                cx, cy, cz = sc[root, 0] - sc[child, 0], sc[root, 1] - sc[child, 1], sc[root, 2] - sc[child, 2]
                j00, j01, j02 = sj[root, 0, 0] - sj[child, 0, 0], sj[root, 0, 1] - sj[child, 0, 1], \
                    sj[root, 0, 2] - sj[child, 0, 2]
                j11, j12, j22 = sj[root, 1, 1] - sj[child, 1, 1], sj[root, 1, 2] - sj[child, 1, 2], \
                    sj[root, 2, 2] - sj[child, 2, 2]
            if mass <= 0.0:
                continue
            # second moment about the joint point p, from the one about the reference:
            # J_p = J_ref - 2 (c.p) E + (c p^T + p c^T) + m (|p|^2 E - p p^T), c the first moment
            cp = cx * px + cy * py + cz * pz
            pp = px * px + py * py + pz * pz
            e00 = j00 - 2 * cp + 2 * cx * px + mass * (pp - px * px)
            e11 = j11 - 2 * cp + 2 * cy * py + mass * (pp - py * py)
            e22 = j22 - 2 * cp + 2 * cz * pz + mass * (pp - pz * pz)
            e01 = j01 + (cx * py + px * cy) - mass * px * py
            e02 = j02 + (cx * pz + px * cz) - mass * px * pz
            e12 = j12 + (cy * pz + py * cz) - mass * py * pz
            _inv3_sym_into(e00, e01, e02, e11, e12, e22, s.joint_pd_mass, j)
            P = s.joint_pd_mass
            u00 += P[j, 0, 0]
            u01 += P[j, 0, 1]
            u02 += P[j, 0, 2]
            u11 += P[j, 1, 1]
            u12 += P[j, 1, 2]
            u22 += P[j, 2, 2]
        P = s.joint_pd_invmass
        P[j, 0, 0], P[j, 0, 1], P[j, 0, 2] = u00, u01, u02
        P[j, 1, 0], P[j, 1, 1], P[j, 1, 2] = u01, u11, u12
        P[j, 2, 0], P[j, 2, 1], P[j, 2, 2] = u02, u12, u22
        _inv3_sym_into(u00, u01, u02, u11, u12, u22, s.joint_pd_mass, j)


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _prepare(m, s, h):
    n = s.body_pos.shape[0]
    # World inverse inertia R diag(I^-1) R^T (zero for fixed bodies).
    for b in range(n):
        w, x, y, z = s.body_rot[b, 0], s.body_rot[b, 1], s.body_rot[b, 2], s.body_rot[b, 3]
        r00 = 1 - 2 * (y * y + z * z)
        r01 = 2 * (x * y - w * z)
        r02 = 2 * (x * z + w * y)
        r10 = 2 * (x * y + w * z)
        r11 = 1 - 2 * (x * x + z * z)
        r12 = 2 * (y * z - w * x)
        r20 = 2 * (x * z - w * y)
        r21 = 2 * (y * z + w * x)
        r22 = 1 - 2 * (x * x + y * y)
        i0, i1, i2 = m.body_inv_inertia[b, 0], m.body_inv_inertia[b, 1], m.body_inv_inertia[b, 2]
        M = s.body_iinv_world
        M[b, 0, 0] = r00 * r00 * i0 + r01 * r01 * i1 + r02 * r02 * i2
        M[b, 0, 1] = r00 * r10 * i0 + r01 * r11 * i1 + r02 * r12 * i2
        M[b, 0, 2] = r00 * r20 * i0 + r01 * r21 * i1 + r02 * r22 * i2
        M[b, 1, 1] = r10 * r10 * i0 + r11 * r11 * i1 + r12 * r12 * i2
        M[b, 1, 2] = r10 * r20 * i0 + r11 * r21 * i1 + r12 * r22 * i2
        M[b, 2, 2] = r20 * r20 * i0 + r21 * r21 * i1 + r22 * r22 * i2
        M[b, 1, 0] = M[b, 0, 1]
        M[b, 2, 0] = M[b, 0, 2]
        M[b, 2, 1] = M[b, 1, 2]

    # Joints: world anchors (from each COM) and the inverse 3x3 effective masses
    # K = (1/ma + 1/mb) E - [ra]x Ia^-1 [ra]x - [rb]x Ib^-1 [rb]x (point constraint) and
    # K = Ia^-1 + Ib^-1 (angular constraints: locks and PD servos).
    M = s.body_iinv_world
    for j in range(m.joint_parent.shape[0]):
        a = m.joint_parent[j]
        b = m.joint_child[j]
        qa = s.body_rot[a]
        qb = s.body_rot[b]
        rax, ray, raz = _qrot(qa[0], qa[1], qa[2], qa[3], m.joint_anchor_parent[j, 0],
                              m.joint_anchor_parent[j, 1], m.joint_anchor_parent[j, 2])
        rbx, rby, rbz = _qrot(qb[0], qb[1], qb[2], qb[3], m.joint_anchor_child[j, 0],
                              m.joint_anchor_child[j, 1], m.joint_anchor_child[j, 2])
        s.joint_ra[j, 0], s.joint_ra[j, 1], s.joint_ra[j, 2] = rax, ray, raz
        s.joint_rb[j, 0], s.joint_rb[j, 1], s.joint_rb[j, 2] = rbx, rby, rbz
        k00 = k01 = k02 = k11 = k12 = k22 = 0.0
        l00 = l01 = l02 = l11 = l12 = l22 = 0.0
        ims = m.body_inv_mass[a] + m.body_inv_mass[b]
        k00 = k11 = k22 = ims
        for side in range(2):
            bb = a if side == 0 else b
            rx, ry, rz = (rax, ray, raz) if side == 0 else (rbx, rby, rbz)
            # -[r]x I^-1 [r]x, written out: for S = [r]x, (S I S^T) since S^T = -S.
            i00, i01, i02 = M[bb, 0, 0], M[bb, 0, 1], M[bb, 0, 2]
            i11, i12, i22 = M[bb, 1, 1], M[bb, 1, 2], M[bb, 2, 2]
            l00 += i00
            l01 += i01
            l02 += i02
            l11 += i11
            l12 += i12
            l22 += i22
            # S = [[0,-rz,ry],[rz,0,-rx],[-ry,rx,0]]; T = S I (row-wise), K += T S^T
            t00 = -rz * i01 + ry * i02
            t01 = -rz * i11 + ry * i12
            t02 = -rz * i12 + ry * i22
            t10 = rz * i00 - rx * i02
            t11 = rz * i01 - rx * i12
            t12 = rz * i02 - rx * i22
            t20 = -ry * i00 + rx * i01
            t21 = -ry * i01 + rx * i11
            # (T S^T)[r][c] = sum_k T[r][k] S[c][k]
            k00 += -t01 * rz + t02 * ry
            k01 += t00 * rz - t02 * rx
            k02 += -t00 * ry + t01 * rx
            k11 += t10 * rz - t12 * rx
            k12 += -t10 * ry + t11 * rx
            k22 += -t20 * ry + t21 * rx
        _inv3_sym_into(k00, k01, k02, k11, k12, k22, s.joint_kinv, j)
        _inv3_sym_into(l00, l01, l02, l11, l12, l22, s.joint_ang_kinv, j)

    # servo inertias, only when a servo is on (most ragdolls and all tracking run without)
    any_servo = False
    for j in range(m.joint_parent.shape[0]):
        if s.joint_pd_hz[j] > 0.0 and m.joint_locked[j] == 0:
            any_servo = True
            break
    if any_servo:
        if m.params[P_SOLVER] != 0.0:
            _servo_inertia(m, s)
        else:
            _servo_inertia_local(m, s)

    if m.params[P_SOLVER] != 0.0:
        _update_node_dims(m, s)
        # servo impulses are re-accumulated every substep by the direct solve
        for j in range(m.joint_parent.shape[0]):
            if s.joint_servo_direct[j] != 0:
                s.joint_pd_imp[j, 0] = 0.0
                s.joint_pd_imp[j, 1] = 0.0
                s.joint_pd_imp[j, 2] = 0.0
        _factor_tree(m, s, h)

    # Ground contacts: each feature (capsule end sphere, box corner) against the terrain.
    x0 = m.params[P_TERRAIN_X0]
    y0 = m.params[P_TERRAIN_Y0]
    cell = m.params[P_TERRAIN_CELL]
    margin = m.params[P_MARGIN]
    for f in range(m.feat_body.shape[0]):
        b = m.feat_body[f]
        px, py, pz = _world_point(m, s, b, m.feat_local[f, 0], m.feat_local[f, 1], m.feat_local[f, 2])
        hz, nx, ny, nz = terrain_sample(m.terrain_height, x0, y0, cell, px, py)
        rad = m.feat_radius[f]
        sep = (pz - hz) * nz - rad
        # speculative distance: what the body can travel towards the ground this substep
        vx, vy, vz = s.body_linvel[b, 0], s.body_linvel[b, 1], s.body_linvel[b, 2]
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        wx, wy, wz = s.body_angvel[b, 0], s.body_angvel[b, 1], s.body_angvel[b, 2]
        speed += math.sqrt(wx * wx + wy * wy + wz * wz) * m.body_bound_radius[b]
        if sep > margin + 2.0 * h * speed:
            s.feat_active[f] = 0
            s.feat_imp[f, 0] = 0.0
            s.feat_imp[f, 1] = 0.0
            s.feat_imp[f, 2] = 0.0
            s.feat_imp[f, 3] = 0.0
            continue
        s.feat_active[f] = 1
        # contact point on the body surface, anchored relative to the COM
        cx, cy, cz = px - rad * nx, py - rad * ny, pz - rad * nz
        s.feat_point[f, 0], s.feat_point[f, 1], s.feat_point[f, 2] = cx, cy, cz
        rx, ry, rz = cx - s.body_pos[b, 0], cy - s.body_pos[b, 1], cz - s.body_pos[b, 2]
        s.feat_r[f, 0], s.feat_r[f, 1], s.feat_r[f, 2] = rx, ry, rz
        s.feat_normal[f, 0], s.feat_normal[f, 1], s.feat_normal[f, 2] = nx, ny, nz
        s.feat_sep[f] = sep
        t1x, t1y, t1z, t2x, t2y, t2z = _tangents(nx, ny, nz)
        s.feat_t1[f, 0], s.feat_t1[f, 1], s.feat_t1[f, 2] = t1x, t1y, t1z
        s.feat_t2[f, 0], s.feat_t2[f, 1], s.feat_t2[f, 2] = t2x, t2y, t2z
        wn = _inv_mass_dir(m, s, b, rx, ry, rz, nx, ny, nz)
        w1 = _inv_mass_dir(m, s, b, rx, ry, rz, t1x, t1y, t1z)
        w2 = _inv_mass_dir(m, s, b, rx, ry, rz, t2x, t2y, t2z)
        ix, iy, iz = _mat3_vec(s.body_iinv_world, b, nx, ny, nz)
        ws = nx * ix + ny * iy + nz * iz
        s.feat_mass[f, 0] = 1.0 / wn if wn > 0.0 else 0.0
        s.feat_mass[f, 1] = 1.0 / w1 if w1 > 0.0 else 0.0
        s.feat_mass[f, 2] = 1.0 / w2 if w2 > 0.0 else 0.0
        s.feat_mass[f, 3] = 1.0 / ws if ws > 0.0 else 0.0

    # Contacts between bodies of different characters: capsule against capsule.
    for k in range(m.pair_a.shape[0]):
        a = m.pair_a[k]
        b = m.pair_b[k]
        p1x, p1y, p1z = _world_point(m, s, a, m.body_seg_a[a, 0], m.body_seg_a[a, 1], m.body_seg_a[a, 2])
        q1x, q1y, q1z = _world_point(m, s, a, m.body_seg_b[a, 0], m.body_seg_b[a, 1], m.body_seg_b[a, 2])
        p2x, p2y, p2z = _world_point(m, s, b, m.body_seg_a[b, 0], m.body_seg_a[b, 1], m.body_seg_a[b, 2])
        q2x, q2y, q2z = _world_point(m, s, b, m.body_seg_b[b, 0], m.body_seg_b[b, 1], m.body_seg_b[b, 2])
        sa, tb = _closest_segments(p1x, p1y, p1z, q1x, q1y, q1z, p2x, p2y, p2z, q2x, q2y, q2z)
        cax = p1x + sa * (q1x - p1x)
        cay = p1y + sa * (q1y - p1y)
        caz = p1z + sa * (q1z - p1z)
        cbx = p2x + tb * (q2x - p2x)
        cby = p2y + tb * (q2y - p2y)
        cbz = p2z + tb * (q2z - p2z)
        dx, dy, dz = cbx - cax, cby - cay, cbz - caz
        dist = math.sqrt(dx * dx + dy * dy + dz * dz)
        ra_, rb_ = m.body_seg_radius[a], m.body_seg_radius[b]
        sep = dist - ra_ - rb_
        vax, vay, vaz = s.body_linvel[a, 0], s.body_linvel[a, 1], s.body_linvel[a, 2]
        vbx, vby, vbz = s.body_linvel[b, 0], s.body_linvel[b, 1], s.body_linvel[b, 2]
        speed = math.sqrt((vbx - vax) ** 2 + (vby - vay) ** 2 + (vbz - vaz) ** 2)
        wa = math.sqrt(s.body_angvel[a, 0] ** 2 + s.body_angvel[a, 1] ** 2 + s.body_angvel[a, 2] ** 2)
        wb = math.sqrt(s.body_angvel[b, 0] ** 2 + s.body_angvel[b, 1] ** 2 + s.body_angvel[b, 2] ** 2)
        speed += wa * m.body_bound_radius[a] + wb * m.body_bound_radius[b]
        if sep > margin + 2.0 * h * speed:
            s.pair_active[k] = 0
            s.pair_imp[k, 0] = 0.0
            s.pair_imp[k, 1] = 0.0
            s.pair_imp[k, 2] = 0.0
            continue
        if dist > 1e-9:
            nx, ny, nz = dx / dist, dy / dist, dz / dist
        else:
            # coincident axes: push along the line between the centres (or up)
            ex = s.body_pos[b, 0] - s.body_pos[a, 0]
            ey = s.body_pos[b, 1] - s.body_pos[a, 1]
            ez = s.body_pos[b, 2] - s.body_pos[a, 2]
            el = math.sqrt(ex * ex + ey * ey + ez * ez)
            if el > 1e-9:
                nx, ny, nz = ex / el, ey / el, ez / el
            else:
                nx, ny, nz = 0.0, 0.0, 1.0
        s.pair_active[k] = 1
        # contact point halfway between the two surfaces
        px = 0.5 * (cax + ra_ * nx + cbx - rb_ * nx)
        py = 0.5 * (cay + ra_ * ny + cby - rb_ * ny)
        pz = 0.5 * (caz + ra_ * nz + cbz - rb_ * nz)
        s.pair_point[k, 0], s.pair_point[k, 1], s.pair_point[k, 2] = px, py, pz
        rax, ray, raz = px - s.body_pos[a, 0], py - s.body_pos[a, 1], pz - s.body_pos[a, 2]
        rbx, rby, rbz = px - s.body_pos[b, 0], py - s.body_pos[b, 1], pz - s.body_pos[b, 2]
        s.pair_ra[k, 0], s.pair_ra[k, 1], s.pair_ra[k, 2] = rax, ray, raz
        s.pair_rb[k, 0], s.pair_rb[k, 1], s.pair_rb[k, 2] = rbx, rby, rbz
        s.pair_normal[k, 0], s.pair_normal[k, 1], s.pair_normal[k, 2] = nx, ny, nz
        s.pair_sep[k] = sep
        t1x, t1y, t1z, t2x, t2y, t2z = _tangents(nx, ny, nz)
        s.pair_t1[k, 0], s.pair_t1[k, 1], s.pair_t1[k, 2] = t1x, t1y, t1z
        s.pair_t2[k, 0], s.pair_t2[k, 1], s.pair_t2[k, 2] = t2x, t2y, t2z
        wn = (_inv_mass_dir(m, s, a, rax, ray, raz, nx, ny, nz)
              + _inv_mass_dir(m, s, b, rbx, rby, rbz, nx, ny, nz))
        w1 = (_inv_mass_dir(m, s, a, rax, ray, raz, t1x, t1y, t1z)
              + _inv_mass_dir(m, s, b, rbx, rby, rbz, t1x, t1y, t1z))
        w2 = (_inv_mass_dir(m, s, a, rax, ray, raz, t2x, t2y, t2z)
              + _inv_mass_dir(m, s, b, rbx, rby, rbz, t2x, t2y, t2z))
        s.pair_mass[k, 0] = 1.0 / wn if wn > 0.0 else 0.0
        s.pair_mass[k, 1] = 1.0 / w1 if w1 > 0.0 else 0.0
        s.pair_mass[k, 2] = 1.0 / w2 if w2 > 0.0 else 0.0
        # the contact point in both body frames: the current separation is tracked from them
        la = s.pair_local
        qa = s.body_rot[a]
        qb = s.body_rot[b]
        lax, lay, laz = _qrot(qa[0], -qa[1], -qa[2], -qa[3], rax, ray, raz)
        lbx, lby, lbz = _qrot(qb[0], -qb[1], -qb[2], -qb[3], rbx, rby, rbz)
        la[k, 0], la[k, 1], la[k, 2] = lax, lay, laz
        la[k, 3], la[k, 4], la[k, 5] = lbx, lby, lbz

    # Foot contacts through the tree: their articulated effective masses (direct solver)
    s.cbody_n[0] = 0
    if m.params[P_SOLVER] != 0.0 and s.cbody.shape[0] > 0:
        _contact_bodies(m, s)


# ---------------------------------------------------------------------------------------
# 2. velocities
# ---------------------------------------------------------------------------------------


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _integrate_velocities(m, s, h):
    gx, gy, gz = m.params[P_GRAVITY_X], m.params[P_GRAVITY_Y], m.params[P_GRAVITY_Z]
    for b in range(s.body_pos.shape[0]):
        im = m.body_inv_mass[b]
        if im == 0.0:
            continue
        # Linear: gravity and user force, then the proportional velocity controller of
        # Wilke & Semwal eq. 2, F = K_f m (v_target - v), integrated implicitly:
        # v' = (v + h (g + F_ext/m) + h K_f v_t) / (1 + h K_f), stable for any K_f.
        kf = s.body_track_gain[b]
        for c in range(3):
            g = gx if c == 0 else (gy if c == 1 else gz)
            v = s.body_linvel[b, c] + h * (g + im * s.body_force[b, c])
            s.body_linvel[b, c] = (v + h * kf * s.body_track_vel[b, c]) / (1.0 + h * kf)
        # Angular: external torque, then the gyroscopic term w x I w integrated
        # implicitly with one Newton step in the body frame (Catto, GDC 2015): explicit
        # integration of it makes long thin bodies spin up and gain energy.
        dx, dy, dz = _mat3_vec(s.body_iinv_world, b, s.body_torque[b, 0], s.body_torque[b, 1],
                               s.body_torque[b, 2])
        wx = s.body_angvel[b, 0] + h * dx
        wy = s.body_angvel[b, 1] + h * dy
        wz = s.body_angvel[b, 2] + h * dz
        q = s.body_rot[b]
        bx, by, bz = _qrot(q[0], -q[1], -q[2], -q[3], wx, wy, wz)
        I0, I1, I2 = m.body_inertia[b, 0], m.body_inertia[b, 1], m.body_inertia[b, 2]
        Lx, Ly, Lz = I0 * bx, I1 * by, I2 * bz
        fx, fy, fz = _cross(bx, by, bz, Lx, Ly, Lz)
        fx *= h
        fy *= h
        fz *= h
        # J = I + h ([w]x I - [I w]x)
        j00 = I0
        j01 = h * (-bz * I1 + Lz)
        j02 = h * (by * I2 - Ly)
        j10 = h * (bz * I0 - Lz)
        j11 = I1
        j12 = h * (-bx * I2 + Lx)
        j20 = h * (-by * I0 + Ly)
        j21 = h * (bx * I1 - Lx)
        j22 = I2
        c00 = j11 * j22 - j12 * j21
        c01 = j02 * j21 - j01 * j22
        c02 = j01 * j12 - j02 * j11
        det = j00 * c00 + j10 * c01 + j20 * c02
        if abs(det) > 1e-300:
            inv = 1.0 / det
            c10 = j12 * j20 - j10 * j22
            c11 = j00 * j22 - j02 * j20
            c12 = j02 * j10 - j00 * j12
            c20 = j10 * j21 - j11 * j20
            c21 = j01 * j20 - j00 * j21
            c22 = j00 * j11 - j01 * j10
            bx -= inv * (c00 * fx + c01 * fy + c02 * fz)
            by -= inv * (c10 * fx + c11 * fy + c12 * fz)
            bz -= inv * (c20 * fx + c21 * fy + c22 * fz)
        wx, wy, wz = _qrot(q[0], q[1], q[2], q[3], bx, by, bz)
        s.body_angvel[b, 0] = wx
        s.body_angvel[b, 1] = wy
        s.body_angvel[b, 2] = wz


# ---------------------------------------------------------------------------------------
# 3. warm start
# ---------------------------------------------------------------------------------------


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _warm_start(m, s):
    for j in range(m.joint_parent.shape[0]):
        a = m.joint_parent[j]
        b = m.joint_child[j]
        if m.params[P_SOLVER] == 0.0:
            px, py, pz = s.joint_imp[j, 0], s.joint_imp[j, 1], s.joint_imp[j, 2]
            _apply(m, s, a, s.joint_ra[j, 0], s.joint_ra[j, 1], s.joint_ra[j, 2], px, py, pz, -1.0)
            _apply(m, s, b, s.joint_rb[j, 0], s.joint_rb[j, 1], s.joint_rb[j, 2], px, py, pz, 1.0)
        gs = 1.0 if m.params[P_SOLVER] == 0.0 else 0.0
        pd = 1.0 if (gs == 1.0 or not s.joint_servo_direct[j] != 0) else 0.0
        lx = gs * s.joint_lock_imp[j, 0] + pd * s.joint_pd_imp[j, 0]
        ly = gs * s.joint_lock_imp[j, 1] + pd * s.joint_pd_imp[j, 1]
        lz = gs * s.joint_lock_imp[j, 2] + pd * s.joint_pd_imp[j, 2]
        _apply_ang(s, a, lx, ly, lz, -1.0)
        _apply_ang(s, b, lx, ly, lz, 1.0)
    for f in range(m.feat_body.shape[0]):
        if s.feat_active[f] == 0:
            continue
        b = m.feat_body[f]
        i0, i1, i2 = s.feat_imp[f, 0], s.feat_imp[f, 1], s.feat_imp[f, 2]
        px = i0 * s.feat_normal[f, 0] + i1 * s.feat_t1[f, 0] + i2 * s.feat_t2[f, 0]
        py = i0 * s.feat_normal[f, 1] + i1 * s.feat_t1[f, 1] + i2 * s.feat_t2[f, 1]
        pz = i0 * s.feat_normal[f, 2] + i1 * s.feat_t1[f, 2] + i2 * s.feat_t2[f, 2]
        _apply(m, s, b, s.feat_r[f, 0], s.feat_r[f, 1], s.feat_r[f, 2], px, py, pz, 1.0)
        i3 = s.feat_imp[f, 3]
        _apply_ang(s, b, i3 * s.feat_normal[f, 0], i3 * s.feat_normal[f, 1], i3 * s.feat_normal[f, 2], 1.0)
    for k in range(m.pair_a.shape[0]):
        if s.pair_active[k] == 0:
            continue
        a = m.pair_a[k]
        b = m.pair_b[k]
        i0, i1, i2 = s.pair_imp[k, 0], s.pair_imp[k, 1], s.pair_imp[k, 2]
        px = i0 * s.pair_normal[k, 0] + i1 * s.pair_t1[k, 0] + i2 * s.pair_t2[k, 0]
        py = i0 * s.pair_normal[k, 1] + i1 * s.pair_t1[k, 1] + i2 * s.pair_t2[k, 1]
        pz = i0 * s.pair_normal[k, 2] + i1 * s.pair_t1[k, 2] + i2 * s.pair_t2[k, 2]
        _apply(m, s, a, s.pair_ra[k, 0], s.pair_ra[k, 1], s.pair_ra[k, 2], px, py, pz, -1.0)
        _apply(m, s, b, s.pair_rb[k, 0], s.pair_rb[k, 1], s.pair_rb[k, 2], px, py, pz, 1.0)


# ---------------------------------------------------------------------------------------
# Foot contacts through the articulated tree
# ---------------------------------------------------------------------------------------
#
# Why: a contact row whose effective mass is its own body's (1/m + r x d . I^-1 r x d) stops
# the foot, then the exact tree joint solve that follows shares that stop with the whole
# body (the foot is held by the leg, the leg by the trunk), so one pass removes only a part
# of a planted foot's slip (0.42 m/s mean on the humanoid's lookahead, issue 13), and a
# light body landing with a heavy one sinks. Here the ground contacts of up to
# MAX_CONTACT_BODIES bodies ("slots", feet first) are solved against the whole body's
# response instead:
#   Phi_kl (6x6) = the velocity (linear, angular) of slot body k for a unit impulse (force
#   at the centre of mass, torque) on slot body l, through the tree with every joint held:
#   the body rows of [[M, J^T], [J, C]]^-1, C the servo compliance; read from the
#   factorization the direct joint solve already made, one solve per unit impulse, each
#   restricted to the path up from l and back down to the slot bodies (the "needed" nodes).
# A contact at r on body l with impulse p is the spatial impulse G p, G = [E; [r]x], so the
# contact-space inverse mass between contacts f (on k) and g (on l) is G_f^T Phi_kl G_g. The
# contacts are then solved by Gauss-Seidel in contact space (normal, friction cone, spin
# friction, as the body-only rows), every impulse moving every slot body by Phi, and the
# pass's impulses are put on the slot bodies; the direct joint solve after them spreads
# them through the tree to exactly the velocities Phi predicted, provided the velocities
# the contacts read were joint-consistent: so a direct solve runs before the contacts too.


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _contact_bodies(m, s):
    """Slots (bodies with an active ground contact: feet first, then the others, up to the
    slot count), the needed nodes and Phi."""
    nb = m.body_inv_mass.shape[0]
    kmax = s.cbody.shape[0]
    for b in range(nb):
        s.body_cslot[b] = -1
    K = 0
    for kind in (KIND_FOOT, KIND_GROUND):
        for f in range(m.feat_body.shape[0]):
            if s.feat_active[f] == 0:
                continue
            b = m.feat_body[f]
            if m.body_contact_kind[b] != kind or m.body_inv_mass[b] == 0.0 or s.body_cslot[b] >= 0:
                continue
            if K >= kmax:
                break
            s.body_cslot[b] = K
            s.cbody[K] = b
            K += 1
    s.cbody_n[0] = K
    if K == 0:
        return
    # need[i] = 1 + the highest slot in node i's subtree (0: none): Phi is symmetric,
    # Phi_lk = Phi_kl^T, so column l needs only the nodes above slots k >= l
    nnode = m.node_parent.shape[0]
    need = s.node_need
    for i in range(nnode):
        need[i] = 0
    for k in range(K):
        i = s.cbody[k]
        while i >= 0 and need[i] < k + 1:
            need[i] = k + 1
            i = m.node_parent[i]
    cnt = 0
    for q in range(m.node_order.shape[0]):
        i = m.node_order[q]
        if need[i] != 0:
            s.need_order[cnt] = i
            cnt += 1
    s.need_n[0] = cnt
    # Phi, column by column: a unit impulse e on slot body l
    x = s.node_x
    z = s.node_z
    phi = s.cbody_phi
    for l in range(K):
        c = s.cbody[l]
        for e in range(6):
            for q in range(cnt):
                i = s.need_order[q]
                if need[i] <= l:
                    continue
                for r in range(6):
                    x[i, r] = 0.0
                    z[i, r] = 0.0
            x[c, e] = 1.0
            # forward elimination, only along the path up from c (elsewhere x stays 0)
            i = c
            while True:
                d = s.node_dim[i]
                Di = s.node_Dinv[i]
                for r in range(d):
                    acc = 0.0
                    for t in range(d):
                        acc += Di[r, t] * x[i, t]
                    z[i, r] = acc
                p = m.node_parent[i]
                if p < 0:
                    break
                dp = s.node_dim[p]
                L = s.node_L[i]
                for cc in range(dp):
                    acc = 0.0
                    for t in range(d):
                        acc += L[t, cc] * x[i, t]
                    x[p, cc] -= acc
                i = p
            # back substitution, root first, over the nodes above slots l..K-1
            for q in range(cnt):
                i = s.need_order[q]
                if need[i] <= l:
                    continue
                d = s.node_dim[i]
                p = m.node_parent[i]
                if p >= 0:
                    dp = s.node_dim[p]
                    L = s.node_L[i]
                    for r in range(d):
                        acc = 0.0
                        for t in range(dp):
                            acc += L[r, t] * x[p, t]
                        x[i, r] = z[i, r] - acc
                else:
                    for r in range(d):
                        x[i, r] = z[i, r]
            for k in range(l, K):
                b = s.cbody[k]
                for r in range(6):
                    phi[k, l, r, e] = x[b, r]
                    phi[l, k, e, r] = x[b, r]
    # each contact's own articulated masses: normal, the tangent plane's 2x2 (inverted), spin
    for f in range(m.feat_body.shape[0]):
        if s.feat_active[f] == 0:
            continue
        k = s.body_cslot[m.feat_body[f]]
        if k < 0:
            continue
        rx, ry, rz = s.feat_r[f, 0], s.feat_r[f, 1], s.feat_r[f, 2]
        nx, ny, nz = s.feat_normal[f, 0], s.feat_normal[f, 1], s.feat_normal[f, 2]
        t1x, t1y, t1z = s.feat_t1[f, 0], s.feat_t1[f, 1], s.feat_t1[f, 2]
        t2x, t2y, t2z = s.feat_t2[f, 0], s.feat_t2[f, 1], s.feat_t2[f, 2]
        P = phi[k, k]
        ann = _phi_form(P, rx, ry, rz, nx, ny, nz, nx, ny, nz)
        a11 = _phi_form(P, rx, ry, rz, t1x, t1y, t1z, t1x, t1y, t1z)
        a12 = _phi_form(P, rx, ry, rz, t1x, t1y, t1z, t2x, t2y, t2z)
        a22 = _phi_form(P, rx, ry, rz, t2x, t2y, t2z, t2x, t2y, t2z)
        ass = 0.0
        for r in range(3):
            nr = nx if r == 0 else (ny if r == 1 else nz)
            for c in range(3):
                nc = nx if c == 0 else (ny if c == 1 else nz)
                ass += nr * P[3 + r, 3 + c] * nc
        s.feat_amass[f, 0] = 1.0 / ann if ann > 1e-300 else 0.0
        det = a11 * a22 - a12 * a12
        if det > 1e-300 * (a11 * a22 + 1e-300):
            s.feat_amass[f, 1] = a22 / det
            s.feat_amass[f, 2] = -a12 / det
            s.feat_amass[f, 3] = a11 / det
        else:
            s.feat_amass[f, 1] = 1.0 / a11 if a11 > 1e-300 else 0.0
            s.feat_amass[f, 2] = 0.0
            s.feat_amass[f, 3] = 1.0 / a22 if a22 > 1e-300 else 0.0
        s.feat_amass[f, 4] = 1.0 / ass if ass > 1e-300 else 0.0


@njit(cache=True)
def _phi_form(P, rx, ry, rz, ax, ay, az, bx, by, bz):
    """(G a)^T P (G b) with G d = (d, r x d): the contact-space inverse mass along a, b."""
    cax, cay, caz = _cross(rx, ry, rz, ax, ay, az)
    cbx, cby, cbz = _cross(rx, ry, rz, bx, by, bz)
    out = 0.0
    for r in range(6):
        ga = ax if r == 0 else (ay if r == 1 else (az if r == 2 else (cax if r == 3 else (cay if r == 4 else caz))))
        row = 0.0
        for c in range(6):
            gb = bx if c == 0 else (by if c == 1 else (bz if c == 2 else (cbx if c == 3 else (cby if c == 4 else cbz))))
            row += P[r, c] * gb
        out += ga * row
    return out


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _slot_impulse(s, K, l, px, py, pz, lx, ly, lz):
    """Every slot body's velocity after a spatial impulse (p, L) on slot body l."""
    phi = s.cbody_phi
    u = s.cbody_vel
    for k in range(K):
        P = phi[k, l]
        for r in range(6):
            u[k, r] += (P[r, 0] * px + P[r, 1] * py + P[r, 2] * pz + P[r, 3] * lx + P[r, 4] * ly
                        + P[r, 5] * lz)


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _slot_point_vel(s, k, rx, ry, rz):
    u = s.cbody_vel
    cx, cy, cz = _cross(u[k, 3], u[k, 4], u[k, 5], rx, ry, rz)
    return u[k, 0] + cx, u[k, 1] + cy, u[k, 2] + cz


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _solve_slot_contacts(m, s, h, use_bias):
    """The slot bodies' ground contacts, Gauss-Seidel in contact space (see above), then the
    pass's impulses on the foot bodies (the direct joint solve after spreads them)."""
    K = s.cbody_n[0]
    max_push = m.params[P_MAX_PUSH]
    for k in range(K):
        b = s.cbody[k]
        for c in range(3):
            s.cbody_vel[k, c] = s.body_linvel[b, c]
            s.cbody_vel[k, 3 + c] = s.body_angvel[b, c]
    for f in range(m.feat_body.shape[0]):
        for c in range(4):
            s.feat_imp0[f, c] = s.feat_imp[f, c]
    for _sweep in range(CONTACT_SWEEPS):
        for f in range(m.feat_body.shape[0]):
            if s.feat_active[f] == 0:
                continue
            b = m.feat_body[f]
            k = s.body_cslot[b]
            if k < 0:
                continue
            if m.body_contact_kind[b] == KIND_FOOT:
                hz, zeta, mu, spin_mu = (m.params[P_FOOT_HZ], m.params[P_FOOT_ZETA], m.params[P_FOOT_MU],
                                         m.params[P_FOOT_SPIN_MU])
            else:
                hz, zeta, mu, spin_mu = (m.params[P_GROUND_HZ], m.params[P_GROUND_ZETA], m.params[P_GROUND_MU],
                                         m.params[P_GROUND_SPIN_MU])
            rx, ry, rz = s.feat_r[f, 0], s.feat_r[f, 1], s.feat_r[f, 2]
            nx, ny, nz = s.feat_normal[f, 0], s.feat_normal[f, 1], s.feat_normal[f, 2]
            px, py, pz = _world_point(m, s, b, m.feat_local[f, 0], m.feat_local[f, 1], m.feat_local[f, 2])
            rad = m.feat_radius[f]
            sep = s.feat_sep[f] + ((px - rad * nx - s.feat_point[f, 0]) * nx
                                   + (py - rad * ny - s.feat_point[f, 1]) * ny
                                   + (pz - rad * nz - s.feat_point[f, 2]) * nz)
            vx, vy, vz = _slot_point_vel(s, k, rx, ry, rz)
            vn = vx * nx + vy * ny + vz * nz
            new, dn = _contact_normal_impulse(s.feat_amass[f, 0], vn, sep, s.feat_imp[f, 0], h, use_bias, hz,
                                              zeta, max_push)
            s.feat_imp[f, 0] = new
            qx, qy, qz = dn * nx, dn * ny, dn * nz
            tx, ty, tz = _cross(rx, ry, rz, qx, qy, qz)
            _slot_impulse(s, K, k, qx, qy, qz, tx, ty, tz)
            # Coulomb friction: the tangent 2x2 solved together, clamped to the cone
            vx, vy, vz = _slot_point_vel(s, k, rx, ry, rz)
            t1x, t1y, t1z = s.feat_t1[f, 0], s.feat_t1[f, 1], s.feat_t1[f, 2]
            t2x, t2y, t2z = s.feat_t2[f, 0], s.feat_t2[f, 1], s.feat_t2[f, 2]
            v1 = vx * t1x + vy * t1y + vz * t1z
            v2 = vx * t2x + vy * t2y + vz * t2z
            o1, o2 = s.feat_imp[f, 1], s.feat_imp[f, 2]
            i11, i12, i22 = s.feat_amass[f, 1], s.feat_amass[f, 2], s.feat_amass[f, 3]
            n1 = o1 - (i11 * v1 + i12 * v2)
            n2 = o2 - (i12 * v1 + i22 * v2)
            lim = mu * new
            nrm = math.sqrt(n1 * n1 + n2 * n2)
            if nrm > lim:
                # sliding: the impulse opposes the slip (maximum dissipation), so the update
                # takes the tangent plane's mean mass, not the 2x2 that turns it off the slip
                # (measured: a box sliding at 2 m/s went 4% too far with the 2x2 clamped)
                iso = 2.0 * (i11 * i22 - i12 * i12) / (i11 + i22) if i11 + i22 > 0.0 else 0.0
                n1 = o1 - iso * v1
                n2 = o2 - iso * v2
                nrm = math.sqrt(n1 * n1 + n2 * n2)
            if nrm > lim:
                sc = lim / nrm if nrm > 0.0 else 0.0
                n1 *= sc
                n2 *= sc
            s.feat_imp[f, 1] = n1
            s.feat_imp[f, 2] = n2
            d1, d2 = n1 - o1, n2 - o2
            qx, qy, qz = d1 * t1x + d2 * t2x, d1 * t1y + d2 * t2y, d1 * t1z + d2 * t2z
            tx, ty, tz = _cross(rx, ry, rz, qx, qy, qz)
            _slot_impulse(s, K, k, qx, qy, qz, tx, ty, tz)
            # rotational friction about the normal
            if spin_mu > 0.0:
                u = s.cbody_vel
                wn = u[k, 3] * nx + u[k, 4] * ny + u[k, 5] * nz
                o3 = s.feat_imp[f, 3]
                n3 = o3 - s.feat_amass[f, 4] * wn
                lim3 = spin_mu * m.feat_spin_radius[f] * new
                n3 = min(max(n3, -lim3), lim3)
                s.feat_imp[f, 3] = n3
                d3 = n3 - o3
                _slot_impulse(s, K, k, 0.0, 0.0, 0.0, d3 * nx, d3 * ny, d3 * nz)
    # the pass's impulses, on the slot bodies alone
    for f in range(m.feat_body.shape[0]):
        if s.feat_active[f] == 0:
            continue
        b = m.feat_body[f]
        if s.body_cslot[b] < 0:
            continue
        d0 = s.feat_imp[f, 0] - s.feat_imp0[f, 0]
        d1 = s.feat_imp[f, 1] - s.feat_imp0[f, 1]
        d2 = s.feat_imp[f, 2] - s.feat_imp0[f, 2]
        d3 = s.feat_imp[f, 3] - s.feat_imp0[f, 3]
        px = d0 * s.feat_normal[f, 0] + d1 * s.feat_t1[f, 0] + d2 * s.feat_t2[f, 0]
        py = d0 * s.feat_normal[f, 1] + d1 * s.feat_t1[f, 1] + d2 * s.feat_t2[f, 1]
        pz = d0 * s.feat_normal[f, 2] + d1 * s.feat_t1[f, 2] + d2 * s.feat_t2[f, 2]
        _apply(m, s, b, s.feat_r[f, 0], s.feat_r[f, 1], s.feat_r[f, 2], px, py, pz, 1.0)
        _apply_ang(s, b, d3 * s.feat_normal[f, 0], d3 * s.feat_normal[f, 1], d3 * s.feat_normal[f, 2], 1.0)


# ---------------------------------------------------------------------------------------
# 4./6. solve and relax
# ---------------------------------------------------------------------------------------


@njit(cache=True)
def _invert_sym_into(A, d, out, work):
    """out[:d, :d] = A[:d, :d]^-1 for a symmetric definite block (positive for bodies,
    negative for joints: the tree's blocks are one or the other, so LDL^T needs no
    pivoting). A = L D L^T, then A^-1 = L^-T D^-1 L^-1, about a sixth of Gauss-Jordan's
    work. work: (6, 12): L in [:, :6], L^-1 in [:, 6:]. A (near) zero pivot gives zeros
    (a joint between two fixed bodies does nothing)."""
    for j in range(d):
        dj = A[j, j]
        for k in range(j):
            dj -= work[j, k] * work[j, k] * work[k, k]
        if abs(dj) < 1e-300:
            for r in range(d):
                for c in range(d):
                    out[r, c] = 0.0
            return
        work[j, j] = dj                       # D on the diagonal of the L block
        for i in range(j + 1, d):
            v = A[i, j]
            for k in range(j):
                v -= work[i, k] * work[j, k] * work[k, k]
            work[i, j] = v / dj
    # L^-1 (unit lower triangular)
    for c in range(d):
        for r in range(d):
            if r < c:
                work[r, 6 + c] = 0.0
            elif r == c:
                work[r, 6 + c] = 1.0
            else:
                v = 0.0
                for k in range(c, r):
                    v -= work[r, k] * work[k, 6 + c]
                work[r, 6 + c] = v
    # A^-1[i, j] = sum_k L^-1[k, i] L^-1[k, j] / D_k
    for i in range(d):
        for j in range(i, d):
            v = 0.0
            for k in range(j, d):
                v += work[k, 6 + i] * work[k, 6 + j] / work[k, k]
            out[i, j] = v
            out[j, i] = v


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _update_node_dims(m, s):
    """node_dim: 6 for a body, 3 for a ball joint, 6 for a locked joint or a joint with a
    servo (point rows + rotation rows); joint_servo_direct: servo solved in the tree.
    Computed once per substep (servos can be switched between steps)."""
    nb = m.body_inv_mass.shape[0]
    for b in range(nb):
        s.node_dim[b] = 6
    for j in range(m.joint_parent.shape[0]):
        direct = m.joint_locked[j] == 0 and s.joint_pd_hz[j] > 0.0 and s.joint_pd_max_torque[j] <= 0.0
        s.joint_servo_direct[j] = 1 if direct else 0
        s.node_dim[nb + j] = 6 if (m.joint_locked[j] != 0 or direct) else 3


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _lock_error(m, s, j, a, b, target):
    """Rotation vector (world) taking the target orientation q_a * target[j] to q_b."""
    qa = s.body_rot[a]
    qb = s.body_rot[b]
    r = target[j]
    gw, gx, gy, gz = _qmul(qa[0], qa[1], qa[2], qa[3], r[0], r[1], r[2], r[3])
    dw, dx, dy, dz = _qmul(qb[0], qb[1], qb[2], qb[3], gw, -gx, -gy, -gz)
    return _qrotvec(dw, dx, dy, dz)


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _factor_tree(m, s, h):
    """Baraff's linear-time factorization ("Linear-Time Dynamics using Lagrange
    Multipliers", SIGGRAPH 1996) of [[M, J^T], [J, 0]] over the tree whose nodes are the
    dynamic bodies (6x6 mass blocks) and the ball joints (3x3 zero blocks). Eliminating
    leaves first creates no fill-in: D_i = H_ii - sum over children c of H_ci^T D_c^-1
    H_ci, L_c = D_c^-1 H_c,parent. The joints are then solved exactly, whatever the mass
    ratio, in O(bodies) per solve."""
    nb = m.body_inv_mass.shape[0]
    D = s.node_D
    # diagonal blocks: body mass matrices, zero for joints
    for k in range(m.node_order.shape[0]):
        i = m.node_order[k]
        for r in range(6):
            for c in range(6):
                D[i, r, c] = 0.0
        if i < nb:
            mass = 1.0 / m.body_inv_mass[i]
            D[i, 0, 0] = D[i, 1, 1] = D[i, 2, 2] = mass
            q = s.body_rot[i]
            for ax in range(3):
                cx, cy, cz = _qrot(q[0], q[1], q[2], q[3], 1.0 if ax == 0 else 0.0, 1.0 if ax == 1 else 0.0,
                                   1.0 if ax == 2 else 0.0)
                mom = m.body_inertia[i, ax]
                D[i, 3, 3] += mom * cx * cx
                D[i, 3, 4] += mom * cx * cy
                D[i, 3, 5] += mom * cx * cz
                D[i, 4, 4] += mom * cy * cy
                D[i, 4, 5] += mom * cy * cz
                D[i, 5, 5] += mom * cz * cz
            D[i, 4, 3] = D[i, 3, 4]
            D[i, 5, 3] = D[i, 3, 5]
            D[i, 5, 4] = D[i, 4, 5]
        else:
            j = i - nb
            if s.joint_servo_direct[j] != 0:
                # soft rotation rows (Catto, "Soft Constraints", GDC 2011):
                # J v' + (beta/h) C + gamma lambda = 0, gamma = 1 / (h (c + h k)) with the
                # spring k = I w^2 and damper c = 2 zeta w I of the servo's joint inertia I:
                # gamma = I^-1 / (h w (2 zeta + h w)); beta/h is b2MakeSoft's bias rate
                omega = 2.0 * math.pi * s.joint_pd_hz[j]
                g = 1.0 / (h * omega * (2.0 * s.joint_pd_zeta[j] + h * omega))
                for r in range(3):
                    for c in range(3):
                        D[i, 3 + r, 3 + c] = -g * s.joint_pd_invmass[j, r, c]
    # leaves first: invert, then pass the Schur complement up to the parent
    for k in range(m.node_order.shape[0] - 1, -1, -1):
        i = m.node_order[k]
        d = s.node_dim[i]
        _invert_sym_into(D[i], d, s.node_Dinv[i], s.node_work)
        p = m.node_parent[i]
        if p < 0:
            continue
        _schur_up(m, s, i, d, p, s.node_dim[p], s.node_Dinv[i], s.node_L[i], D[p])


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _schur_up(m, s, i, d, p, dp, Di, L, Dp):
    """L = Di H and Dp -= H^T L for the off-diagonal block H[:d, :dp] between node i and
    its parent p in the body-joint tree. A body's parent is its joint j: J_jb^T = [E;
    [r_b]x] (6x3; with E in the rotation rows too for a locked joint or a servo, 6x6). A
    joint's parent is its parent body a: J_ja = [-E, [r_a]x] (3x6; with -E in the rotation
    rows of a locked joint or a servo, 6x6). Written out for those few non-zeros, each
    entry of L and of the update costs at most three products instead of six (the dense
    products were a third of the factorization, and it a sixth of a ragdoll substep);
    ``tests/test_physics.py`` checks it against the dense blocks."""
    nb = m.body_inv_mass.shape[0]
    if i < nb:
        # a body below its joint: H = [[E, 0], [[r_b]x^T-like rows, E (locked or servo)]]
        j = m.body_joint[i]
        rx, ry, rz = s.joint_rb[j, 0], s.joint_rb[j, 1], s.joint_rb[j, 2]
        for r in range(d):
            L[r, 0] = Di[r, 0] + rz * Di[r, 4] - ry * Di[r, 5]
            L[r, 1] = Di[r, 1] - rz * Di[r, 3] + rx * Di[r, 5]
            L[r, 2] = Di[r, 2] + ry * Di[r, 3] - rx * Di[r, 4]
            for c in range(3, dp):
                L[r, c] = Di[r, c]
        for c in range(dp):
            Dp[0, c] -= L[0, c] + rz * L[4, c] - ry * L[5, c]
            Dp[1, c] -= L[1, c] - rz * L[3, c] + rx * L[5, c]
            Dp[2, c] -= L[2, c] + ry * L[3, c] - rx * L[4, c]
            for r in range(3, dp):
                Dp[r, c] -= L[r, c]
    else:
        # a joint below its parent body: H = [[-E, -[r_a]x], [0, -E (locked or servo)]]
        j = i - nb
        rx, ry, rz = s.joint_ra[j, 0], s.joint_ra[j, 1], s.joint_ra[j, 2]
        six = d == 6
        for r in range(d):
            a0, a1, a2 = Di[r, 0], Di[r, 1], Di[r, 2]
            L[r, 0] = -a0
            L[r, 1] = -a1
            L[r, 2] = -a2
            L[r, 3] = rz * a1 - ry * a2
            L[r, 4] = -rz * a0 + rx * a2
            L[r, 5] = ry * a0 - rx * a1
            if six:
                L[r, 3] -= Di[r, 3]
                L[r, 4] -= Di[r, 4]
                L[r, 5] -= Di[r, 5]
        for c in range(dp):
            l0, l1, l2 = L[0, c], L[1, c], L[2, c]
            Dp[0, c] += l0
            Dp[1, c] += l1
            Dp[2, c] += l2
            u3 = rz * l1 - ry * l2
            u4 = -rz * l0 + rx * l2
            u5 = ry * l0 - rx * l1
            if six:
                u3 -= L[3, c]
                u4 -= L[4, c]
                u5 -= L[5, c]
            Dp[3, c] -= u3
            Dp[4, c] -= u4
            Dp[5, c] -= u5


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _solve_points_direct(m, s, h, use_bias):
    """Velocity update making every ball joint exact: J (v + dv) = -bias, with
    dv = -M^-1 J^T mu from [[M, J^T], [J, 0]] [dv; mu] = [0; -(J v + bias)], solved on
    the factored tree (forward, diagonal, back substitution). With ``use_bias`` the
    position error C is fed back at the soft rate of the joint spring (b2MakeSoft's
    bias rate), else the solve is rigid (the relax pass)."""
    nb = m.body_inv_mass.shape[0]
    jbias = 0.0
    if use_bias:
        jhz = m.params[P_JOINT_HZ]
        jhz = 0.25 / h if jhz <= 0.0 else min(jhz, 0.25 / h)
        jbias, _ms, _is = _soft(jhz, m.params[P_JOINT_ZETA], h)
    x = s.node_x
    # right-hand side: zero for bodies, -(J v + bias C) for joints
    for k in range(m.node_order.shape[0]):
        i = m.node_order[k]
        for r in range(6):
            x[i, r] = 0.0
        if i >= nb:
            j = i - nb
            a = m.joint_parent[j]
            b = m.joint_child[j]
            vax, vay, vaz = _point_vel(s, a, s.joint_ra[j, 0], s.joint_ra[j, 1], s.joint_ra[j, 2])
            vbx, vby, vbz = _point_vel(s, b, s.joint_rb[j, 0], s.joint_rb[j, 1], s.joint_rb[j, 2])
            cx = cy = cz = 0.0
            if use_bias:
                pax, pay, paz = _world_point(m, s, a, m.joint_anchor_parent[j, 0], m.joint_anchor_parent[j, 1],
                                             m.joint_anchor_parent[j, 2])
                pbx, pby, pbz = _world_point(m, s, b, m.joint_anchor_child[j, 0], m.joint_anchor_child[j, 1],
                                             m.joint_anchor_child[j, 2])
                cx, cy, cz = jbias * (pbx - pax), jbias * (pby - pay), jbias * (pbz - paz)
            x[i, 0] = -(vbx - vax + cx)
            x[i, 1] = -(vby - vay + cy)
            x[i, 2] = -(vbz - vaz + cz)
            if m.joint_locked[j] != 0:
                ex = ey = ez = 0.0
                if use_bias:
                    ex, ey, ez = _lock_error(m, s, j, a, b, m.joint_rest_rot)
                x[i, 3] = -(s.body_angvel[b, 0] - s.body_angvel[a, 0] + jbias * ex)
                x[i, 4] = -(s.body_angvel[b, 1] - s.body_angvel[a, 1] + jbias * ey)
                x[i, 5] = -(s.body_angvel[b, 2] - s.body_angvel[a, 2] + jbias * ez)
            elif s.joint_servo_direct[j] != 0:
                # the servo spring acts in both passes: the relax pass solves for the
                # increment on top of this substep's impulse so far (gamma lambda_acc)
                omega = 2.0 * math.pi * s.joint_pd_hz[j]
                br = omega / (2.0 * s.joint_pd_zeta[j] + h * omega)
                g = 1.0 / (h * omega * (2.0 * s.joint_pd_zeta[j] + h * omega))
                ex, ey, ez = _lock_error(m, s, j, a, b, s.joint_target_rot)
                qa = s.body_rot[a]
                twx, twy, twz = _qrot(qa[0], qa[1], qa[2], qa[3], s.joint_target_angvel[j, 0],
                                      s.joint_target_angvel[j, 1], s.joint_target_angvel[j, 2])
                lx, ly, lz = _mat3_vec(s.joint_pd_invmass, j, s.joint_pd_imp[j, 0], s.joint_pd_imp[j, 1],
                                       s.joint_pd_imp[j, 2])
                x[i, 3] = -(s.body_angvel[b, 0] - s.body_angvel[a, 0] - twx + br * ex + g * lx)
                x[i, 4] = -(s.body_angvel[b, 1] - s.body_angvel[a, 1] - twy + br * ey + g * ly)
                x[i, 5] = -(s.body_angvel[b, 2] - s.body_angvel[a, 2] - twz + br * ez + g * lz)
    # forward (leaves first): x_parent -= L_i^T x_i; keep z_i = D_i^-1 x_i
    z = s.node_z
    for k in range(m.node_order.shape[0] - 1, -1, -1):
        i = m.node_order[k]
        d = s.node_dim[i]
        Di = s.node_Dinv[i]
        for r in range(d):
            acc = 0.0
            for t in range(d):
                acc += Di[r, t] * x[i, t]
            z[i, r] = acc
        p = m.node_parent[i]
        if p >= 0:
            dp = s.node_dim[p]
            L = s.node_L[i]
            for c in range(dp):
                acc = 0.0
                for t in range(d):
                    acc += L[t, c] * x[i, t]
                x[p, c] -= acc
    # back substitution (root first): x_i = z_i - L_i x_parent
    for k in range(m.node_order.shape[0]):
        i = m.node_order[k]
        d = s.node_dim[i]
        p = m.node_parent[i]
        if p >= 0:
            dp = s.node_dim[p]
            L = s.node_L[i]
            for r in range(d):
                acc = 0.0
                for t in range(dp):
                    acc += L[r, t] * x[p, t]
                x[i, r] = z[i, r] - acc
        else:
            for r in range(d):
                x[i, r] = z[i, r]
    # apply: body velocity changes; joint impulses lambda = -mu kept for reports
    for k in range(m.node_order.shape[0]):
        i = m.node_order[k]
        if i < nb:
            for c in range(3):
                s.body_linvel[i, c] += x[i, c]
                s.body_angvel[i, c] += x[i, 3 + c]
        else:
            j = i - nb
            servo = s.joint_servo_direct[j] != 0
            for c in range(3):
                s.joint_imp[j, c] = -x[i, c]
                if m.joint_locked[j] != 0:
                    s.joint_lock_imp[j, c] = -x[i, 3 + c]
                elif servo:
                    s.joint_pd_imp[j, c] += -x[i, 3 + c]


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _solve_point_gs(m, s, j, a, b, rax, ray, raz, rbx, rby, rbz, use_bias, jbias, jmass, jimp):
    """One sequential-impulse update of ball joint j (3x3 effective mass, soft bias)."""
    vax, vay, vaz = _point_vel(s, a, rax, ray, raz)
    vbx, vby, vbz = _point_vel(s, b, rbx, rby, rbz)
    cdx, cdy, cdz = vbx - vax, vby - vay, vbz - vaz
    bx = by = bz = 0.0
    if use_bias:
        pax, pay, paz = _world_point(m, s, a, m.joint_anchor_parent[j, 0], m.joint_anchor_parent[j, 1],
                                     m.joint_anchor_parent[j, 2])
        pbx, pby, pbz = _world_point(m, s, b, m.joint_anchor_child[j, 0], m.joint_anchor_child[j, 1],
                                     m.joint_anchor_child[j, 2])
        bx, by, bz = jbias * (pbx - pax), jbias * (pby - pay), jbias * (pbz - paz)
    ex, ey, ez = _mat3_vec(s.joint_kinv, j, cdx + bx, cdy + by, cdz + bz)
    px = -jmass * ex - jimp * s.joint_imp[j, 0]
    py = -jmass * ey - jimp * s.joint_imp[j, 1]
    pz = -jmass * ez - jimp * s.joint_imp[j, 2]
    s.joint_imp[j, 0] += px
    s.joint_imp[j, 1] += py
    s.joint_imp[j, 2] += pz
    _apply(m, s, a, rax, ray, raz, px, py, pz, -1.0)
    _apply(m, s, b, rbx, rby, rbz, px, py, pz, 1.0)


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _solve_joints(m, s, h, use_bias, do_points):
    jbias, jmass, jimp = 0.0, 1.0, 0.0
    if use_bias:
        # joint softness: hz <= 0 asks for the stiffest stable spring, a quarter of the
        # substep rate (Box2D v3's rule); it only pushes drift out, the relax pass is rigid
        jhz = m.params[P_JOINT_HZ]
        jhz = 0.25 / h if jhz <= 0.0 else min(jhz, 0.25 / h)
        jbias, jmass, jimp = _soft(jhz, m.params[P_JOINT_ZETA], h)
    for j in range(m.joint_parent.shape[0]):
        a = m.joint_parent[j]
        b = m.joint_child[j]
        rax, ray, raz = s.joint_ra[j, 0], s.joint_ra[j, 1], s.joint_ra[j, 2]
        rbx, rby, rbz = s.joint_rb[j, 0], s.joint_rb[j, 1], s.joint_rb[j, 2]
        # -- ball and socket: the two anchors coincide (Gauss-Seidel variant; the direct
        #    tree solve below replaces it when the model asks for it) ------------------
        if do_points:
            _solve_point_gs(m, s, j, a, b, rax, ray, raz, rbx, rby, rbz, use_bias, jbias, jmass, jimp)

        # -- angular: a locked joint holds its rest relative rotation (rigid, soft like
        #    the ball joint); otherwise the PD servo (Zordan et al. 2005 section 4):
        #    tau = I (kp (theta_d - theta) - kv theta_dot) with kp = w^2, kv = 2 z w,
        #    I the joint inertia from prepare (the outboard body's about the joint,
        #    reduced with the parent's). Integrated implicitly as a soft angular
        #    constraint, so any gain is stable.
        locked = m.joint_locked[j] != 0
        if locked and not do_points:
            continue          # the direct tree solve holds locked joints exactly
        pd_hz = s.joint_pd_hz[j]
        if not locked and pd_hz <= 0.0:
            continue
        if not do_points and s.joint_servo_direct[j] != 0:
            continue          # solved in the tree with the joints
        qa = s.body_rot[a]
        qb = s.body_rot[b]
        if locked:
            tw, tx, ty, tz = m.joint_rest_rot[j, 0], m.joint_rest_rot[j, 1], m.joint_rest_rot[j, 2], \
                m.joint_rest_rot[j, 3]
            bias_rate, mass_scale, imp_scale = jbias, jmass, jimp
            acc = s.joint_lock_imp
            twx = twy = twz = 0.0
        else:
            tw, tx, ty, tz = s.joint_target_rot[j, 0], s.joint_target_rot[j, 1], s.joint_target_rot[j, 2], \
                s.joint_target_rot[j, 3]
            bias_rate, mass_scale, imp_scale = _soft(pd_hz, s.joint_pd_zeta[j], h)
            acc = s.joint_pd_imp
            # target relative angular velocity, given in the parent frame
            twx, twy, twz = _qrot(qa[0], qa[1], qa[2], qa[3], s.joint_target_angvel[j, 0],
                                  s.joint_target_angvel[j, 1], s.joint_target_angvel[j, 2])
        # error: rotation taking the target child orientation qa*t to the current qb
        gw, gx, gy, gz = _qmul(qa[0], qa[1], qa[2], qa[3], tw, tx, ty, tz)
        dw, dx, dy, dz = _qmul(qb[0], qb[1], qb[2], qb[3], gw, -gx, -gy, -gz)
        cx, cy, cz = _qrotvec(dw, dx, dy, dz)
        wrx = s.body_angvel[b, 0] - s.body_angvel[a, 0] - twx
        wry = s.body_angvel[b, 1] - s.body_angvel[a, 1] - twy
        wrz = s.body_angvel[b, 2] - s.body_angvel[a, 2] - twz
        ex, ey, ez = _mat3_vec(s.joint_ang_kinv if locked else s.joint_pd_mass, j, wrx + bias_rate * cx,
                               wry + bias_rate * cy, wrz + bias_rate * cz)
        lx = -mass_scale * ex - imp_scale * acc[j, 0]
        ly = -mass_scale * ey - imp_scale * acc[j, 1]
        lz = -mass_scale * ez - imp_scale * acc[j, 2]
        if not locked:
            # torque limit: |tau| <= max_torque
            lim = s.joint_pd_max_torque[j] * h
            if lim > 0.0:
                nx_, ny_, nz_ = acc[j, 0] + lx, acc[j, 1] + ly, acc[j, 2] + lz
                nrm = math.sqrt(nx_ * nx_ + ny_ * ny_ + nz_ * nz_)
                if nrm > lim:
                    sc = lim / nrm
                    nx_ *= sc
                    ny_ *= sc
                    nz_ *= sc
                lx, ly, lz = nx_ - acc[j, 0], ny_ - acc[j, 1], nz_ - acc[j, 2]
        acc[j, 0] += lx
        acc[j, 1] += ly
        acc[j, 2] += lz
        _apply_ang(s, a, lx, ly, lz, -1.0)
        _apply_ang(s, b, lx, ly, lz, 1.0)


@njit(cache=True)
def _contact_normal_impulse(mass_n, vn, sep, acc, h, use_bias, hz, zeta, max_push):
    """Accumulated-impulse update of one contact normal (Box2D v3 b2SolveContact)."""
    if sep > 0.0:
        # speculative: the gap may close by at most sep this substep
        bias, ms, isc = sep / h, 1.0, 0.0
    elif use_bias:
        # a contact spring stiffer than a quarter of the substep rate is as good as rigid
        br, ms, isc = _soft(min(hz, 0.25 / h), zeta, h)
        bias = max(br * sep, -max_push)
    else:
        bias, ms, isc = 0.0, 1.0, 0.0
    imp = -mass_n * ms * (vn + bias) - isc * acc
    new = max(acc + imp, 0.0)
    return new, new - acc


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _solve_contacts(m, s, h, use_bias):
    max_push = m.params[P_MAX_PUSH]
    articulated = s.cbody_n[0] > 0
    if articulated:
        _solve_slot_contacts(m, s, h, use_bias)
    for f in range(m.feat_body.shape[0]):
        if s.feat_active[f] == 0:
            continue
        b = m.feat_body[f]
        if articulated and s.body_cslot[b] >= 0:
            continue          # solved through the tree above
        foot = m.body_contact_kind[b] == KIND_FOOT
        if foot:
            hz, zeta, mu, spin_mu = (m.params[P_FOOT_HZ], m.params[P_FOOT_ZETA], m.params[P_FOOT_MU],
                                     m.params[P_FOOT_SPIN_MU])
        else:
            hz, zeta, mu, spin_mu = (m.params[P_GROUND_HZ], m.params[P_GROUND_ZETA], m.params[P_GROUND_MU],
                                     m.params[P_GROUND_SPIN_MU])
        rx, ry, rz = s.feat_r[f, 0], s.feat_r[f, 1], s.feat_r[f, 2]
        nx, ny, nz = s.feat_normal[f, 0], s.feat_normal[f, 1], s.feat_normal[f, 2]
        # current separation: the one at prepare plus how far the anchor moved along n
        px, py, pz = _world_point(m, s, b, m.feat_local[f, 0], m.feat_local[f, 1], m.feat_local[f, 2])
        rad = m.feat_radius[f]
        sep = s.feat_sep[f] + ((px - rad * nx - s.feat_point[f, 0]) * nx + (py - rad * ny - s.feat_point[f, 1]) * ny
                               + (pz - rad * nz - s.feat_point[f, 2]) * nz)
        vx, vy, vz = _point_vel(s, b, rx, ry, rz)
        vn = vx * nx + vy * ny + vz * nz
        new, dn = _contact_normal_impulse(s.feat_mass[f, 0], vn, sep, s.feat_imp[f, 0], h, use_bias, hz, zeta,
                                          max_push)
        s.feat_imp[f, 0] = new
        _apply(m, s, b, rx, ry, rz, dn * nx, dn * ny, dn * nz, 1.0)
        # Coulomb friction, the two tangents clamped together to the cone mu * lambda_n
        vx, vy, vz = _point_vel(s, b, rx, ry, rz)
        t1x, t1y, t1z = s.feat_t1[f, 0], s.feat_t1[f, 1], s.feat_t1[f, 2]
        t2x, t2y, t2z = s.feat_t2[f, 0], s.feat_t2[f, 1], s.feat_t2[f, 2]
        v1 = vx * t1x + vy * t1y + vz * t1z
        v2 = vx * t2x + vy * t2y + vz * t2z
        o1, o2 = s.feat_imp[f, 1], s.feat_imp[f, 2]
        n1 = o1 - s.feat_mass[f, 1] * v1
        n2 = o2 - s.feat_mass[f, 2] * v2
        lim = mu * new
        nrm = math.sqrt(n1 * n1 + n2 * n2)
        if nrm > lim:
            sc = lim / nrm if nrm > 0.0 else 0.0
            n1 *= sc
            n2 *= sc
        s.feat_imp[f, 1] = n1
        s.feat_imp[f, 2] = n2
        d1, d2 = n1 - o1, n2 - o2
        _apply(m, s, b, rx, ry, rz, d1 * t1x + d2 * t2x, d1 * t1y + d2 * t2y, d1 * t1z + d2 * t2z, 1.0)
        # rotational friction about the normal (the paper's foot handler): the torque
        # is bounded by spin_mu * contact radius * normal force
        if spin_mu > 0.0:
            wn = s.body_angvel[b, 0] * nx + s.body_angvel[b, 1] * ny + s.body_angvel[b, 2] * nz
            o3 = s.feat_imp[f, 3]
            n3 = o3 - s.feat_mass[f, 3] * wn
            lim3 = spin_mu * m.feat_spin_radius[f] * new
            n3 = min(max(n3, -lim3), lim3)
            s.feat_imp[f, 3] = n3
            d3 = n3 - o3
            _apply_ang(s, b, d3 * nx, d3 * ny, d3 * nz, 1.0)

    hz, zeta, mu = m.params[P_PAIR_HZ], m.params[P_PAIR_ZETA], m.params[P_PAIR_MU]
    for k in range(m.pair_a.shape[0]):
        if s.pair_active[k] == 0:
            continue
        a = m.pair_a[k]
        b = m.pair_b[k]
        rax, ray, raz = s.pair_ra[k, 0], s.pair_ra[k, 1], s.pair_ra[k, 2]
        rbx, rby, rbz = s.pair_rb[k, 0], s.pair_rb[k, 1], s.pair_rb[k, 2]
        nx, ny, nz = s.pair_normal[k, 0], s.pair_normal[k, 1], s.pair_normal[k, 2]
        la = s.pair_local
        pax, pay, paz = _world_point(m, s, a, la[k, 0], la[k, 1], la[k, 2])
        pbx, pby, pbz = _world_point(m, s, b, la[k, 3], la[k, 4], la[k, 5])
        # both anchors sat on one point at prepare: the gap grows by their split along n
        sep = s.pair_sep[k] + (pbx - pax) * nx + (pby - pay) * ny + (pbz - paz) * nz
        vax, vay, vaz = _point_vel(s, a, rax, ray, raz)
        vbx, vby, vbz = _point_vel(s, b, rbx, rby, rbz)
        vn = (vbx - vax) * nx + (vby - vay) * ny + (vbz - vaz) * nz
        new, dn = _contact_normal_impulse(s.pair_mass[k, 0], vn, sep, s.pair_imp[k, 0], h, use_bias, hz, zeta,
                                          max_push)
        s.pair_imp[k, 0] = new
        _apply(m, s, a, rax, ray, raz, dn * nx, dn * ny, dn * nz, -1.0)
        _apply(m, s, b, rbx, rby, rbz, dn * nx, dn * ny, dn * nz, 1.0)
        vax, vay, vaz = _point_vel(s, a, rax, ray, raz)
        vbx, vby, vbz = _point_vel(s, b, rbx, rby, rbz)
        t1x, t1y, t1z = s.pair_t1[k, 0], s.pair_t1[k, 1], s.pair_t1[k, 2]
        t2x, t2y, t2z = s.pair_t2[k, 0], s.pair_t2[k, 1], s.pair_t2[k, 2]
        rvx, rvy, rvz = vbx - vax, vby - vay, vbz - vaz
        v1 = rvx * t1x + rvy * t1y + rvz * t1z
        v2 = rvx * t2x + rvy * t2y + rvz * t2z
        o1, o2 = s.pair_imp[k, 1], s.pair_imp[k, 2]
        n1 = o1 - s.pair_mass[k, 1] * v1
        n2 = o2 - s.pair_mass[k, 2] * v2
        lim = mu * new
        nrm = math.sqrt(n1 * n1 + n2 * n2)
        if nrm > lim:
            sc = lim / nrm if nrm > 0.0 else 0.0
            n1 *= sc
            n2 *= sc
        s.pair_imp[k, 1] = n1
        s.pair_imp[k, 2] = n2
        d1, d2 = n1 - o1, n2 - o2
        qx, qy, qz = d1 * t1x + d2 * t2x, d1 * t1y + d2 * t2y, d1 * t1z + d2 * t2z
        _apply(m, s, a, rax, ray, raz, qx, qy, qz, -1.0)
        _apply(m, s, b, rbx, rby, rbz, qx, qy, qz, 1.0)


# ---------------------------------------------------------------------------------------
# 5. positions
# ---------------------------------------------------------------------------------------


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _integrate_positions(m, s, h):
    for b in range(s.body_pos.shape[0]):
        if m.body_inv_mass[b] == 0.0:
            continue
        s.body_pos[b, 0] += h * s.body_linvel[b, 0]
        s.body_pos[b, 1] += h * s.body_linvel[b, 1]
        s.body_pos[b, 2] += h * s.body_linvel[b, 2]
        wx, wy, wz = 0.5 * h * s.body_angvel[b, 0], 0.5 * h * s.body_angvel[b, 1], 0.5 * h * s.body_angvel[b, 2]
        qw, qx, qy, qz = s.body_rot[b, 0], s.body_rot[b, 1], s.body_rot[b, 2], s.body_rot[b, 3]
        dw, dx, dy, dz = _qmul(0.0, wx, wy, wz, qw, qx, qy, qz)
        qw += dw
        qx += dx
        qy += dy
        qz += dz
        inv = 1.0 / math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        s.body_rot[b, 0] = qw * inv
        s.body_rot[b, 1] = qx * inv
        s.body_rot[b, 2] = qy * inv
        s.body_rot[b, 3] = qz * inv


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _rotate_by(s, b, dx, dy, dz, sign):
    """q <- normalize(q + 1/2 (0, sign*d) q): a small rotation by the vector d."""
    qw, qx, qy, qz = s.body_rot[b, 0], s.body_rot[b, 1], s.body_rot[b, 2], s.body_rot[b, 3]
    ew, ex, ey, ez = _qmul(0.0, 0.5 * sign * dx, 0.5 * sign * dy, 0.5 * sign * dz, qw, qx, qy, qz)
    qw += ew
    qx += ex
    qy += ey
    qz += ez
    inv = 1.0 / math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
    s.body_rot[b, 0] = qw * inv
    s.body_rot[b, 1] = qx * inv
    s.body_rot[b, 2] = qy * inv
    s.body_rot[b, 3] = qz * inv


@njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _project_joints(m, s):
    """Non-linear Gauss-Seidel position projection of the ball joints (Box2D v2.4's
    post-stabilization): move the two bodies, by their inverse masses, so the anchors
    meet. Velocities are untouched, so it adds no energy; it removes the O(h^2) drift
    that velocity-level sequential impulses leave along chains with large mass ratios."""
    for j in range(m.joint_parent.shape[0]):
        a = m.joint_parent[j]
        b = m.joint_child[j]
        pax, pay, paz = _world_point(m, s, a, m.joint_anchor_parent[j, 0], m.joint_anchor_parent[j, 1],
                                     m.joint_anchor_parent[j, 2])
        pbx, pby, pbz = _world_point(m, s, b, m.joint_anchor_child[j, 0], m.joint_anchor_child[j, 1],
                                     m.joint_anchor_child[j, 2])
        ex, ey, ez = _mat3_vec(s.joint_kinv, j, pbx - pax, pby - pay, pbz - paz)
        px, py, pz = -ex, -ey, -ez
        rax, ray, raz = pax - s.body_pos[a, 0], pay - s.body_pos[a, 1], paz - s.body_pos[a, 2]
        rbx, rby, rbz = pbx - s.body_pos[b, 0], pby - s.body_pos[b, 1], pbz - s.body_pos[b, 2]
        for side in range(2):
            bb = a if side == 0 else b
            im = m.body_inv_mass[bb]
            if im == 0.0:
                continue
            sign = -1.0 if side == 0 else 1.0
            rx, ry, rz = (rax, ray, raz) if side == 0 else (rbx, rby, rbz)
            s.body_pos[bb, 0] += sign * im * px
            s.body_pos[bb, 1] += sign * im * py
            s.body_pos[bb, 2] += sign * im * pz
            tx, ty, tz = _cross(rx, ry, rz, px, py, pz)
            dx, dy, dz = _mat3_vec(s.body_iinv_world, bb, tx, ty, tz)
            _rotate_by(s, bb, dx, dy, dz, sign)


# ---------------------------------------------------------------------------------------
# The step
# ---------------------------------------------------------------------------------------


@njit(cache=True)
def step_kernel(m, s, dt, nsub, niter, nproject, nsteps):
    """Advance ``nsteps`` steps of ``dt`` seconds, each in ``nsub`` substeps with
    ``niter`` solve and ``niter`` relax iterations. Returns 0, or 1 if the state became
    non-finite (the caller raises; the kernel never hides a NaN)."""
    h = dt / nsub
    for _ in range(nsteps):
        for _sub in range(nsub):
            _prepare(m, s, h)
            _integrate_velocities(m, s, h)
            _warm_start(m, s)
            direct = m.params[P_SOLVER] != 0.0
            # foot contacts solved through the tree read joint-consistent velocities
            articulated = direct and s.cbody_n[0] > 0
            for _it in range(niter):
                _solve_joints(m, s, h, True, not direct)
                if articulated:
                    _solve_points_direct(m, s, h, True)
                _solve_contacts(m, s, h, True)
                if direct:
                    _solve_points_direct(m, s, h, True)
            _integrate_positions(m, s, h)
            for _it in range(niter):
                _solve_joints(m, s, h, False, not direct)
                if articulated:
                    _solve_points_direct(m, s, h, False)
                _solve_contacts(m, s, h, False)
                if direct:
                    _solve_points_direct(m, s, h, False)
            for _it in range(nproject):
                _project_joints(m, s)
        s.clock[0] += dt
        s.clock[1] += 1.0
    for b in range(s.body_pos.shape[0]):
        for c in range(3):
            if not (math.isfinite(s.body_pos[b, c]) and math.isfinite(s.body_linvel[b, c])
                    and math.isfinite(s.body_angvel[b, c])):
                return 1
    return 0


@njit(cache=True)
def joint_separation_kernel(m, s, out):
    """Distance (m) between the two anchors of each ball joint, into out (njoint,)."""
    for j in range(m.joint_parent.shape[0]):
        a = m.joint_parent[j]
        b = m.joint_child[j]
        pax, pay, paz = _world_point(m, s, a, m.joint_anchor_parent[j, 0], m.joint_anchor_parent[j, 1],
                                     m.joint_anchor_parent[j, 2])
        pbx, pby, pbz = _world_point(m, s, b, m.joint_anchor_child[j, 0], m.joint_anchor_child[j, 1],
                                     m.joint_anchor_child[j, 2])
        out[j] = math.sqrt((pbx - pax) ** 2 + (pby - pay) ** 2 + (pbz - paz) ** 2)
