"""Numba kernels of the movement modes: the per-body frames and the specialization S.

Every kernel takes plain arrays (or the ``SlotConstants`` NamedTuple of arrays, see
``engine.channels.modes``) and writes into preallocated outputs; nothing allocates.

The position frame of a slot is an origin ``o`` (3,) and three axis columns ``A`` (3, 3):
``S(q_g) = o + A q_g`` and ``G(q_s) = A^-1 (q_s - o)``. The rotation frame is a pair of
rotations ``F`` (in front) and ``R`` (behind): ``S(q_g) = F M(q_g) R`` with ``M`` the
sagittal mirror when the slot is mirrored. Hecker et al. 2008, sections 3.2.1-3.2.2.
"""

from __future__ import annotations

import math

from numba import njit

from engine.mathx.quat import quat_mul_into, quat_slerp_into

# Position modes, rotation modes and position flags (stored per slot as int32).
POS_NONE = 0
POS_ABSOLUTE = 1
POS_REST = 2
POS_SECONDARY = 3
ROT_NONE = 0
ROT_ABSOLUTE = 1
ROT_REST = 2
ROT_LOOKAT = 3
FLAG_GROUND = 1
FLAG_SAGITTAL = 2
FLAG_DIRECTIONAL = 4
FLAG_CONTACT = 8
#: With FLAG_CONTACT, the x axis keeps at least this fraction of the distance to the target
#: (a body whose rest box already touches its target's would otherwise get no axis).
CONTACT_KEEP = 0.25

# Shortest secondary axis (m): a target sitting on the body's rest position gives a frame
# along +X of this length, so S and G stay finite (G is then very sensitive, as it must be).
MIN_AXIS = 1e-9


@njit(cache=True, inline="always")
def position_frame_into(c, i, targets, origin, axes):
    """Origin (3,) and axis columns (3, 3) of slot ``i``'s position frame.

    absolute      o = 0,    A = diag(scale)
    rest          o = rest, A = diag(scale); with FLAG_GROUND the z column is
                  (0, 0, ground_axis): z_g = 0 at rest height, 1 with the box on the
                  ground; with FLAG_SAGITTAL the y column is (0, sagittal_axis, 0):
                  y_g = 0 at rest, 1 on the sagittal plane y = 0.
    secondary     o = rest, x column = target - rest (1 at the target), or its unit
                  direction * scale_x with FLAG_DIRECTIONAL (SecondaryDirectionalOnly), or
                  with FLAG_CONTACT shortened by both boxes' half-widths along it (1 where
                  the body's rest box touches the target's; at least CONTACT_KEEP of it);
                  y = unit(e_z x x), z = x_hat x y, times scale_y, scale_z.
    The y column is multiplied by the slot's mirror sign (-1 mirrored), except the
    sagittal column, which already points toward the plane on either side.
    """
    mode = c.slot_pos_mode[i]
    flags = c.slot_pos_flags[i]
    sx = c.slot_scale[i, 0]
    sy = c.slot_scale[i, 1]
    sz = c.slot_scale[i, 2]
    m = c.slot_mirror_sign[i]
    for r in range(3):
        for k in range(3):
            axes[r, k] = 0.0
    if mode == POS_ABSOLUTE:
        origin[0] = 0.0
        origin[1] = 0.0
        origin[2] = 0.0
        axes[0, 0] = sx
        axes[1, 1] = sy * m
        axes[2, 2] = sz
        return
    origin[0] = c.slot_rest_pos[i, 0]
    origin[1] = c.slot_rest_pos[i, 1]
    origin[2] = c.slot_rest_pos[i, 2]
    if mode == POS_SECONDARY:
        row = c.slot_target[i]
        if row >= 0:
            dx = targets[row, 0] - origin[0]
            dy = targets[row, 1] - origin[1]
            dz = targets[row, 2] - origin[2]
        else:
            dx = 0.0
            dy = 0.0
            dz = 0.0
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        if not (d >= MIN_AXIS):  # also catches NaN targets
            dx, dy, dz, d = MIN_AXIS, 0.0, 0.0, MIN_AXIS
        ux, uy, uz = dx / d, dy / d, dz / d
        if flags & FLAG_DIRECTIONAL:
            axes[0, 0] = ux * sx
            axes[1, 0] = uy * sx
            axes[2, 0] = uz * sx
        elif flags & FLAG_CONTACT:
            # x = 1 where the two boxes touch along u: the distance less both boxes'
            # half-widths along u (each box's support: the sum of |u . half axis|)
            reach = 0.0
            for k in range(6):
                reach += abs(ux * c.slot_contact[i, k, 0] + uy * c.slot_contact[i, k, 1]
                             + uz * c.slot_contact[i, k, 2])
            dc = max(d - reach, CONTACT_KEEP * d)
            axes[0, 0] = ux * dc
            axes[1, 0] = uy * dc
            axes[2, 0] = uz * dc
        else:
            axes[0, 0] = dx
            axes[1, 0] = dy
            axes[2, 0] = dz
        # y = e_z x u (horizontal, to the left of the direction); near vertical use the
        # part of e_y perpendicular to u.
        yx, yy, yz = -uy, ux, 0.0
        n = math.sqrt(yx * yx + yy * yy)
        if n < 1e-9:
            p = uy  # e_y . u
            yx, yy, yz = -p * ux, 1.0 - p * uy, -p * uz
            n = math.sqrt(yx * yx + yy * yy + yz * yz)
        yx, yy, yz = yx / n, yy / n, yz / n
        zx = uy * yz - uz * yy
        zy = uz * yx - ux * yz
        zz = ux * yy - uy * yx
        axes[0, 1] = yx * sy * m
        axes[1, 1] = yy * sy * m
        axes[2, 1] = yz * sy * m
        axes[0, 2] = zx * sz
        axes[1, 2] = zy * sz
        axes[2, 2] = zz * sz
        return
    # rest-relative, with the ground and sagittal distortions
    axes[0, 0] = sx
    if flags & FLAG_SAGITTAL:
        axes[1, 1] = c.slot_sagittal_axis[i]
    else:
        axes[1, 1] = sy * m
    if flags & FLAG_GROUND:
        axes[2, 2] = c.slot_ground_axis[i]
    else:
        axes[2, 2] = sz


@njit(cache=True, inline="always")
def lookat_weight(cos_angle, lo, hi):
    """Soft joint limit of the lookat controller: 1 while the angle between the body's rest
    forward axis and the target direction is <= lo, 0 from hi on, a C1 smoothstep between."""
    a = math.acos(min(1.0, max(-1.0, cos_angle)))
    if a <= lo:
        return 1.0
    if a >= hi:
        return 0.0
    s = (hi - a) / (hi - lo)
    return s * s * (3.0 - 2.0 * s)


@njit(cache=True, inline="always")
def rotation_frame_into(c, i, targets, front, back):
    """The rotation frame of slot ``i``: S(q) = front * M(q) * back.

    absolute  front = back = identity
    rest      front = identity, back = rest rotation (a delta in character space)
    lookat    front = slerp(identity, shortest arc from the rest forward axis to the
              target direction, soft-limit weight), back = rest rotation: q_g is a rest
              relative rotation in a frame aimed at the target, so a nod stays a nod.
    """
    mode = c.slot_rot_mode[i]
    front[0] = 1.0
    front[1] = 0.0
    front[2] = 0.0
    front[3] = 0.0
    if mode == ROT_ABSOLUTE or mode == ROT_NONE:
        back[0] = 1.0
        back[1] = 0.0
        back[2] = 0.0
        back[3] = 0.0
        return
    back[0] = c.slot_rest_rot[i, 0]
    back[1] = c.slot_rest_rot[i, 1]
    back[2] = c.slot_rest_rot[i, 2]
    back[3] = c.slot_rest_rot[i, 3]
    if mode != ROT_LOOKAT:
        return
    row = c.slot_target[i]
    if row < 0:
        return
    dx = targets[row, 0] - c.slot_rest_pos[i, 0]
    dy = targets[row, 1] - c.slot_rest_pos[i, 1]
    dz = targets[row, 2] - c.slot_rest_pos[i, 2]
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    if not (d > MIN_AXIS):
        return
    fx = c.slot_forward[i, 0]
    fy = c.slot_forward[i, 1]
    fz = c.slot_forward[i, 2]
    w = lookat_weight((fx * dx + fy * dy + fz * dz) / d, c.slot_lookat_limits[i, 0],
                      c.slot_lookat_limits[i, 1])
    if w <= 0.0:
        return
    # front = the shortest arc from forward to d, turned only w of the way.
    _between_scalars(fx, fy, fz, dx, dy, dz, front)
    if w < 1.0:
        _scale_from_identity(front, w)


@njit(cache=True, inline="always")
def _between_scalars(ux, uy, uz, vx, vy, vz, out):
    # Shortest-arc rotation u -> v (the formula of mathx.quat_between, on scalars so the
    # kernel needs no temporary 3-vectors).
    nu = math.sqrt(ux * ux + uy * uy + uz * uz)
    nv = math.sqrt(vx * vx + vy * vy + vz * vz)
    ux, uy, uz = ux / nu, uy / nu, uz / nu
    vx, vy, vz = vx / nv, vy / nv, vz / nv
    d = ux * vx + uy * vy + uz * vz
    cx = uy * vz - uz * vy
    cy = uz * vx - ux * vz
    cz = ux * vy - uy * vx
    # q = (1 + d, u x v) normalized is the half-angle rotation from u to v; near d = -1
    # the weight is already 0 (hi <= pi), so the opposite case never reaches here with w > 0
    # unless hi > pi, which the builder refuses.
    w = 1.0 + d
    n = math.sqrt(w * w + cx * cx + cy * cy + cz * cz)
    if n < 1e-300:
        out[0] = 1.0
        out[1] = 0.0
        out[2] = 0.0
        out[3] = 0.0
        return
    out[0] = w / n
    out[1] = cx / n
    out[2] = cy / n
    out[3] = cz / n


@njit(cache=True, inline="always")
def _scale_from_identity(q, t):
    # slerp(identity, q, t) in place: rotation about q's axis by t times its angle.
    w = q[0]
    s = math.sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if s < 1e-15:
        return
    half = math.atan2(s, w)
    k = math.sin(t * half) / s
    q[0] = math.cos(t * half)
    q[1] *= k
    q[2] *= k
    q[3] *= k


@njit(cache=True, inline="always")
def mirror_quat_into(q, sign, out):
    """Sagittal mirror of a rotation when sign < 0 (reflecting y: (w, -x, y, -z)), else copy."""
    out[0] = q[0]
    out[2] = q[2]
    if sign < 0.0:
        out[1] = -q[1]
        out[3] = -q[3]
    else:
        out[1] = q[1]
        out[3] = q[3]


@njit(cache=True, inline="always")
def specialize_slot_into(c, i, targets, qg_pos, qg_rot, out_pos, out_rot, scratch_axes, scratch_q):
    """S for one slot: qg_pos (3,), qg_rot (4,) -> out_pos (3,), out_rot (4,).
    scratch_axes (3, 3) and scratch_q (3, 4) are caller-owned work space."""
    if c.slot_pos_mode[i] != POS_NONE:
        o = scratch_q[0, :3]
        position_frame_into(c, i, targets, o, scratch_axes)
        for r in range(3):
            out_pos[r] = o[r] + (scratch_axes[r, 0] * qg_pos[0] + scratch_axes[r, 1] * qg_pos[1]
                                 + scratch_axes[r, 2] * qg_pos[2])
    if c.slot_rot_mode[i] != ROT_NONE:
        front = scratch_q[0]
        back = scratch_q[1]
        mq = scratch_q[2]
        rotation_frame_into(c, i, targets, front, back)
        mirror_quat_into(qg_rot, c.slot_mirror_sign[i], mq)
        quat_mul_into(front, mq, mq)
        quat_mul_into(mq, back, out_rot)


@njit(cache=True)
def specialize_kernel(c, targets, qg_pos, qg_rot, out_pos, out_rot, scratch_axes, scratch_q):
    """S for every slot: qg_pos (nslot, 3), qg_rot (nslot, 4) -> out_pos, out_rot (nslot, ...)."""
    for i in range(c.slot_body.shape[0]):
        specialize_slot_into(c, i, targets, qg_pos[i], qg_rot[i], out_pos[i], out_rot[i],
                             scratch_axes, scratch_q)



# -- keyed curves (section 3.3) -------------------------------------------------------------
# A curve is a run of keys [adr, adr + num) in packed arrays: times (k,), values (k, d) and
# outgoing/incoming tangents per second. Positions and weights are cubic Hermite per
# component. Rotations are Hermite in the tangent space of each segment's first key:
#     q(t) = q_a exp(r(s)),  r = Hermite(0, h w_a, log(q_a^-1 q_b), h J_r^-1(r_b) w_b)
# where w are body-frame angular velocities (rad/s) and J_r^-1 the inverse right Jacobian
# of the exponential map, so the angular velocity is w_a leaving key a and exactly w_b
# arriving at key b: rotations stay on the unit sphere and are C1 across keys.


@njit(cache=True)
def find_segment(times, adr, num, t):
    """Index a (absolute) with times[a] <= t < times[a + 1] within [adr, adr + num), by
    binary search; t before the first key gives adr, after the last gives adr + num - 1."""
    lo = adr
    hi = adr + num - 1
    if t <= times[lo]:
        return lo
    if t >= times[hi]:
        return hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def sample_vector_into(times, values, tout, tin, adr, num, t, out):
    """Cubic Hermite of the curve at time t (held constant outside its keys) -> out (d,)."""
    d = out.shape[0]
    a = find_segment(times, adr, num, t)
    if a == adr + num - 1 or t <= times[a]:
        for j in range(d):
            out[j] = values[a, j]
        return
    b = a + 1
    h = times[b] - times[a]
    s = (t - times[a]) / h
    s2 = s * s
    s3 = s2 * s
    h00 = 2.0 * s3 - 3.0 * s2 + 1.0
    h10 = s3 - 2.0 * s2 + s
    h01 = -2.0 * s3 + 3.0 * s2
    h11 = s3 - s2
    for j in range(d):
        out[j] = h00 * values[a, j] + h10 * h * tout[a, j] + h01 * values[b, j] + h11 * h * tin[b, j]


@njit(cache=True)
def _relative_rotvec(qa, qb, out):
    # out = log(qa^-1 qb) as a rotation vector (angle in [0, pi]).
    w = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3]
    x = qa[0] * qb[1] - qa[1] * qb[0] - qa[2] * qb[3] + qa[3] * qb[2]
    y = qa[0] * qb[2] + qa[1] * qb[3] - qa[2] * qb[0] - qa[3] * qb[1]
    z = qa[0] * qb[3] - qa[1] * qb[2] + qa[2] * qb[1] - qa[3] * qb[0]
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 * math.atan2(s, w) / s if s > 0.0 else 2.0
    out[0] = x * k
    out[1] = y * k
    out[2] = z * k


@njit(cache=True)
def inverse_right_jacobian_apply(phi0, phi1, phi2, v0, v1, v2, out):
    """out = J_r^-1(phi) v, J_r^-1 = I + [phi]x / 2 + (1/th^2 - (1 + cos th)/(2 th sin th)) [phi]x^2."""
    th2 = phi0 * phi0 + phi1 * phi1 + phi2 * phi2
    th = math.sqrt(th2)
    if th < 1e-4:
        c = 1.0 / 12.0 + th2 / 720.0
    else:
        sn = math.sin(th)
        if sn < 1e-9:  # at pi the Jacobian is singular; keys that far apart are refused
            sn = 1e-9
        c = 1.0 / th2 - (1.0 + math.cos(th)) / (2.0 * th * sn)
    # a = phi x v ; b = phi x a
    a0 = phi1 * v2 - phi2 * v1
    a1 = phi2 * v0 - phi0 * v2
    a2 = phi0 * v1 - phi1 * v0
    b0 = phi1 * a2 - phi2 * a1
    b1 = phi2 * a0 - phi0 * a2
    b2 = phi0 * a1 - phi1 * a0
    out[0] = v0 + 0.5 * a0 + c * b0
    out[1] = v1 + 0.5 * a1 + c * b1
    out[2] = v2 + 0.5 * a2 + c * b2


@njit(cache=True)
def sample_rotation_into(times, values, tout, tin, adr, num, t, out, work):
    """Rotation curve at t -> out (4,). work (3, 3) is caller-owned scratch."""
    a = find_segment(times, adr, num, t)
    if a == adr + num - 1 or t <= times[a]:
        for j in range(4):
            out[j] = values[a, j]
        return
    b = a + 1
    h = times[b] - times[a]
    s = (t - times[a]) / h
    s2 = s * s
    s3 = s2 * s
    h10 = s3 - 2.0 * s2 + s
    h01 = -2.0 * s3 + 3.0 * s2
    h11 = s3 - s2
    rb = work[0]
    mb = work[1]
    r = work[2]
    _relative_rotvec(values[a], values[b], rb)
    inverse_right_jacobian_apply(rb[0], rb[1], rb[2], tin[b, 0], tin[b, 1], tin[b, 2], mb)
    for j in range(3):
        r[j] = h10 * h * tout[a, j] + h01 * rb[j] + h11 * h * mb[j]
    # out = q_a exp(r)
    th = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    if th < 1e-3:
        k = 0.5 - th * th / 48.0
    else:
        k = math.sin(0.5 * th) / th
    ew = math.cos(0.5 * th)
    ex = r[0] * k
    ey = r[1] * k
    ez = r[2] * k
    aw, ax, ay, az = values[a, 0], values[a, 1], values[a, 2], values[a, 3]
    w = aw * ew - ax * ex - ay * ey - az * ez
    x = aw * ex + ax * ew + ay * ez - az * ey
    y = aw * ey - ax * ez + ay * ew + az * ex
    z = aw * ez + ax * ey - ay * ex + az * ew
    n = math.sqrt(w * w + x * x + y * y + z * z)
    out[0] = w / n
    out[1] = x / n
    out[2] = y / n
    out[3] = z / n


# -- blending (section 3.2.3) -----------------------------------------------------------------


@njit(cache=True)
def blend_kernel(slot_body, slot_pos_on, slot_rot_on, slot_weight, slot_pos, slot_rot,
                 rest_pos, rest_rot, goal_pos, goal_rot, goal_pos_weight, goal_rot_weight):
    """Blend the specialized poses of every slot into per-body goals.

    Slots arrive in ownership order with ``slot_pos_on`` / ``slot_rot_on`` already 0 for
    the slots whose blend group does not own that DOF of their body (computed once at
    bind). Positions blend as the weighted mean; rotations by incremental slerp (the
    k-th rotation enters with weight w_k / (w_1 + ... + w_k), exact for two). The goal
    weight is min(1, sum of weights), 0 = no goal on that DOF (goal = the rest pose then,
    so the output never holds garbage). Weights <= 0 contribute nothing.
    """
    nbody = goal_pos.shape[0]
    for b in range(nbody):
        goal_pos[b, 0] = 0.0
        goal_pos[b, 1] = 0.0
        goal_pos[b, 2] = 0.0
        goal_pos_weight[b] = 0.0
        goal_rot_weight[b] = 0.0
    for i in range(slot_body.shape[0]):
        w = slot_weight[i]
        if not (w > 0.0):
            continue
        b = slot_body[i]
        if slot_pos_on[i]:
            goal_pos[b, 0] += w * slot_pos[i, 0]
            goal_pos[b, 1] += w * slot_pos[i, 1]
            goal_pos[b, 2] += w * slot_pos[i, 2]
            goal_pos_weight[b] += w
        if slot_rot_on[i]:
            total = goal_rot_weight[b] + w
            if goal_rot_weight[b] == 0.0:
                for j in range(4):
                    goal_rot[b, j] = slot_rot[i, j]
            else:
                quat_slerp_into(goal_rot[b], slot_rot[i], w / total, goal_rot[b])
            goal_rot_weight[b] = total
    for b in range(nbody):
        wp = goal_pos_weight[b]
        if wp > 0.0:
            goal_pos[b, 0] /= wp
            goal_pos[b, 1] /= wp
            goal_pos[b, 2] /= wp
            goal_pos_weight[b] = min(wp, 1.0)
        else:
            goal_pos[b, 0] = rest_pos[b, 0]
            goal_pos[b, 1] = rest_pos[b, 1]
            goal_pos[b, 2] = rest_pos[b, 2]
        if goal_rot_weight[b] > 0.0:
            goal_rot_weight[b] = min(goal_rot_weight[b], 1.0)
        else:
            for j in range(4):
                goal_rot[b, j] = rest_rot[b, j]
