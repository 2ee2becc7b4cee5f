"""Numba kernels of the gait stage (Hecker et al. 2008, section 4.2). One frame is two
kernel calls around one call of the game's terrain height function:

1. ``gait_plan``: advance every group's cycle, move steppers between stance and flight
   (lift-off at the step trigger + duty factor, touchdown when the flight ends, parking
   when the character stands still, a rescue step when a planted foot would overreach),
   predict each flying foot's touchdown spot, and list the ground points whose height
   the frame needs (``query``).
2. (Python) ``heights = terrain(query)``.
3. ``gait_pose``: plant landing feet on the ground, move flying feet along the style's
   normalized flight path scaled to the step, keep everything above the ground, and write
   every foot's goal in character space through this frame's placement; add the hip bob
   and sway to the root.

Stepper states: 0 stance (planted: fixed in world space), 1 flight, 2 touching down this
frame, 3 owned by a playing animation (tracked, not driven).
"""

from __future__ import annotations

import math

from numba import njit

STANCE, FLIGHT, LANDING, OWNED = 0, 1, 2, 3
#: Compass legs: how far (share of leg length) a planted rigid leg may hang before it
#: lifts off, and how close a swinging one must come to the ground to touch down.
COMPASS_TOL = 5e-4
#: Compass legs: ground clearance of the swing foot, share of the style's foot lift, and
#: the largest pelvis roll (rad) a hip hike may use to get it.
COMPASS_CLEAR = 0.1
COMPASS_ROLL = 0.35
#: Compass legs: the most the hip hike's roll eases out per frame, rad (a pelvis turning
#: 0.05 rad in a frame is a fifth of the grid's rotation_pop warning).
COMPASS_ROLL_STEP = 0.05
#: Compass legs: share of the way to its touchdown circle a foot hanging at the end of its
#: flight is drawn in per frame.
COMPASS_REACH_IN = 0.15


@njit(cache=True, inline="always")
def _path_at(path, g, s):
    """(forward, up, pitch) of group g's normalized flight path at progress s in [0, 1]."""
    n = path.shape[1]
    x = min(max(s, 0.0), 1.0) * (n - 1)
    i = min(int(x), n - 2)
    t = x - i
    return ((1.0 - t) * path[g, i, 0] + t * path[g, i + 1, 0], (1.0 - t) * path[g, i, 1] + t * path[g, i + 1, 1],
            (1.0 - t) * path[g, i, 2] + t * path[g, i + 1, 2])


@njit(cache=True, inline="always")
def _predict(px, py, yaw, vx, vy, omega, t):
    """Placement (x, y, yaw) after t seconds at constant world velocity (vx, vy) seen in
    the turning heading frame: the velocity turns with the heading at rate omega."""
    if abs(omega) * t < 1e-6:
        return px + vx * t, py + vy * t, yaw + omega * t
    a = omega * t
    s = math.sin(a) / omega
    c = (1.0 - math.cos(a)) / omega
    return px + s * vx - c * vy, py + c * vx + s * vy, yaw + a


@njit(cache=True, inline="always")
def _foot_joint(foot_world, foot_jointrel, foot_yaw, f, place_pos, cy, sy, yaw):
    """Foot joint in character space: the foot's position there plus its rest joint
    offset turned by the foot's yaw relative to the heading."""
    dx = foot_world[f, 0] - place_pos[0]
    dy = foot_world[f, 1] - place_pos[1]
    px = cy * dx + sy * dy
    py = -sy * dx + cy * dy
    pz = foot_world[f, 2] - place_pos[2]
    a = foot_yaw[f] - yaw
    ca, sa = math.cos(a), math.sin(a)
    jx, jy = foot_jointrel[f, 0], foot_jointrel[f, 1]
    return px + ca * jx - sa * jy, py + sa * jx + ca * jy, pz + foot_jointrel[f, 2]


@njit(cache=True, inline="always")
def _hip(root_pos, root_rot, foot_hip, f):
    """Hip joint in character space: the root-relative hip point carried by the root."""
    w, x, y, z = root_rot[0], root_rot[1], root_rot[2], root_rot[3]
    vx, vy, vz = foot_hip[f, 0], foot_hip[f, 1], foot_hip[f, 2]
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (root_pos[0] + vx + w * tx + (y * tz - z * ty), root_pos[1] + vy + w * ty + (z * tx - x * tz),
            root_pos[2] + vz + w * tz + (x * ty - y * tx))


@njit(cache=True, inline="always")
def _ellipse(ex, ey, c, s, group_sweep, g):
    """A world offset (ex, ey) of a foot from its rest spot, seen in the heading frame
    (cos, sin of the heading) and measured on the ellipse of group g's half-sweeps."""
    fx = c * ex + s * ey
    fy = -s * ex + c * ey
    return math.hypot(fx / max(group_sweep[g, 0], 1e-12), fy / max(group_sweep[g, 1], 1e-12))


@njit(cache=True)
def gait_plan(dt, place, vel, idle, group_rate, group_phase, group_duty, group_sweep, group_park, path,
              step_group, step_trigger, step_duty_scale, step_foot_adr, step_foot_num, step_state,
              step_progress, step_prev_u, step_parked, step_lift_u, step_done, foot_body, foot_neutral,
              foot_world, foot_lift, foot_yaw, foot_lift_yaw, foot_target, foot_target_yaw, goal_pw, query,
              place_z, prev_root_pos, prev_root_rot, foot_hip, foot_jointrel, foot_chain, foot_rigid, group_stretch,
              group_support):
    """Stage 1 of a frame (see the module docstring).

    place (3,)     new placement x, y, heading yaw (world)
    vel (3,)       world velocity vx, vy (m/s) and turn rate (rad/s) of the placement
    idle           the character is asked to stand still
    group_* (G,)   cycle rate (cycles/s), phase (in/out), duty factor, allowed half-sweeps
                   (G, 2: forward/back and sideways in the character frame, m), parking
                   tolerance (m); path (G, NS, 3) the normalized flight path
    step_* (S,)    group, trigger, duty scale, foot range, state/progress/previous cycle
                   position/parked/cycle position at lift-off/lifted this cycle (in/out); a flight always ends at
                   the end of the stepper's cycle, so a rescue step does not drift out of phase
    foot_* (F, .)  body, rest spot (character space), world position, lift-off position,
                   world yaw, lift-off yaw, touchdown target (x, y written here), target yaw
    goal_pw (nbody,) the blended animation goal weights (a foot with weight > 0 is owned)
    query (3F + 5, 2) out: ground points to sample (see ``GaitController``)
    place_z, prev_root_pos (3,), prev_root_rot (4,)  last frame's placement height and root
                   pose (character space), to see how far planted legs are stretched
    group_stretch (G,) hip-to-foot distance over chain length the IK was verified to meet:
                   a planted foot past it takes a rescue step
    group_support (G,) int32 scratch: planted compass (rigid-legged) steppers per group. The
                   last one never lifts (it holds the hips, see ``gait_pose``), and a compass
                   stepper's flight ends when its foot meets the ground, not on the clock
    """
    nfoot = foot_body.shape[0]
    px, py, yaw = place[0], place[1], place[2]
    cy, sy = math.cos(yaw), math.sin(yaw)
    # 1. group cycles
    for g in range(group_phase.shape[0]):
        group_phase[g] = (group_phase[g] + group_rate[g] * dt) % 1.0
        group_support[g] = 0
    for s in range(step_group.shape[0]):
        if step_state[s] == STANCE and foot_rigid[step_foot_adr[s]] == 1:
            group_support[step_group[s]] += 1
    # 2. steppers
    for s in range(step_group.shape[0]):
        g = step_group[s]
        a0 = step_foot_adr[s]
        a1 = a0 + step_foot_num[s]
        duty = min(max(group_duty[g] * step_duty_scale[s], 0.05), 0.97)
        u = (group_phase[g] - step_trigger[s]) % 1.0
        prev = step_prev_u[s]
        step_prev_u[s] = u
        if u < prev:                              # a new cycle of this stepper begins
            step_done[s] = 0
        owned = False
        for f in range(a0, a1):
            if goal_pw[foot_body[f]] > 0.0:
                owned = True
        if owned:
            step_state[s] = OWNED
            continue
        if step_state[s] == OWNED:               # released by the animation: step back into the gait
            step_state[s] = FLIGHT
            step_progress[s] = 0.0
            step_parked[s] = 0
            step_lift_u[s] = u
            step_done[s] = 1
            for f in range(a0, a1):
                for j in range(3):
                    foot_lift[f, j] = foot_world[f, j]
                foot_lift_yaw[f] = foot_yaw[f]
        # how far the stepper's feet are from their rest spots under this placement (m), and
        # the same on the ellipse of the allowed half-sweeps (1 = at the edge)
        disp = 0.0
        reach = 0.0
        for f in range(a0, a1):
            nx = px + cy * foot_neutral[f, 0] - sy * foot_neutral[f, 1]
            ny = py + sy * foot_neutral[f, 0] + cy * foot_neutral[f, 1]
            disp = max(disp, math.hypot(foot_world[f, 0] - nx, foot_world[f, 1] - ny))
            reach = max(reach, _ellipse(foot_world[f, 0] - nx, foot_world[f, 1] - ny, cy, sy, group_sweep, g))
        if step_state[s] == STANCE:
            # lift-off once per cycle, once the cycle passes the duty factor (the duty factor
            # moves with speed, so this is a window, not a crossing)
            crossed = u >= duty and step_done[s] == 0
            lift = False
            if crossed:
                if idle and disp <= group_park[g]:
                    step_parked[s] = 1           # standing still and already home: stay planted
                    step_done[s] = 1
                else:
                    lift = True
            if not lift and not (idle and step_parked[s] == 1):
                if reach > 1.0:
                    lift = True                  # rescue step: the planted foot would overreach
                else:
                    for f in range(a0, a1):
                        if foot_rigid[f] == 0 and foot_chain[f] > 0.0:
                            jx, jy, jz = _foot_joint(foot_world, foot_jointrel, foot_yaw, f, (px, py, place_z), cy,
                                                     sy, yaw)
                            hx, hy, hz = _hip(prev_root_pos, prev_root_rot, foot_hip, f)
                            if math.sqrt((jx - hx) ** 2 + (jy - hy) ** 2 + (jz - hz) ** 2) > (
                                    group_stretch[g] * foot_chain[f]):
                                lift = True      # ... or is stretched past what the IK was seen to meet
            if lift and foot_rigid[a0] == 1:
                # a compass stepper lifts only while another one holds the hips, and on the
                # clock only from a full stance (setting off): in a walk it lifts when the
                # hips rise over the new foot and leave it hanging (``gait_pose``)
                airborne = False
                for k in range(step_group.shape[0]):
                    if step_group[k] == g and foot_rigid[step_foot_adr[k]] == 1 and step_state[k] == FLIGHT:
                        airborne = True
                if group_support[g] <= 1 or (airborne and reach <= 1.0):
                    lift = False
                else:
                    group_support[g] -= 1
            if lift:
                step_state[s] = FLIGHT
                step_progress[s] = 0.0
                step_parked[s] = 0
                step_lift_u[s] = min(u, duty) if crossed else u
                step_done[s] = 1
                for f in range(a0, a1):
                    for j in range(3):
                        foot_lift[f, j] = foot_world[f, j]
                    foot_lift_yaw[f] = foot_yaw[f]
        elif step_state[s] == FLIGHT:
            rate = group_rate[g] / max(1.0 - step_lift_u[s], 0.1) if group_rate[g] > 0.0 else 0.0
            if rate <= 0.0:
                rate = 1.0
            step_progress[s] += rate * dt
            if step_progress[s] >= 1.0:
                step_progress[s] = 1.0
                if foot_rigid[a0] == 0:
                    step_state[s] = LANDING      # compass feet land in gait_pose, on contact
        if step_state[s] == FLIGHT and foot_rigid[a0] == 1 and step_progress[s] >= 1.0:
            # a compass foot at the end of its flight that has not met the ground yet keeps
            # its target (``gait_pose`` draws it in under the hip until it touches)
            for f in range(a0, a1):
                query[f, 0] = foot_target[f, 0]
                query[f, 1] = foot_target[f, 1]
                query[nfoot + f, 0] = foot_target[f, 0]
                query[nfoot + f, 1] = foot_target[f, 1]
        elif step_state[s] == FLIGHT or step_state[s] == LANDING:
            # touchdown target: the rest spot under the placement predicted for the middle
            # of the coming stance, so the stance sweeps evenly around the rest spot
            rate = group_rate[g] if group_rate[g] > 0.0 else 1.0
            t_left = (1.0 - step_progress[s]) * max(1.0 - step_lift_u[s], 0.1) / rate
            t_ahead = t_left + 0.5 * duty / rate
            qx, qy, qyaw = _predict(px, py, yaw, vel[0], vel[1], vel[2], t_ahead)
            if idle:
                qx, qy, qyaw = px, py, yaw
            cq, sq = math.cos(qyaw), math.sin(qyaw)
            fw, up, pitch = _path_at(path, g, step_progress[s])
            # never aim further from the rest spot under the placement at touchdown than
            # most of the allowed sweep (a foot landing there would need a rescue step at once)
            lx, ly, lyaw = _predict(px, py, yaw, vel[0], vel[1], vel[2], t_left)
            if idle:
                lx, ly, lyaw = px, py, yaw
            cl, sl = math.cos(lyaw), math.sin(lyaw)
            k = 1.0
            for f in range(a0, a1):
                tx = qx + cq * foot_neutral[f, 0] - sq * foot_neutral[f, 1]
                ty = qy + sq * foot_neutral[f, 0] + cq * foot_neutral[f, 1]
                nx = lx + cl * foot_neutral[f, 0] - sl * foot_neutral[f, 1]
                ny = ly + sl * foot_neutral[f, 0] + cl * foot_neutral[f, 1]
                d = _ellipse(tx - nx, ty - ny, cl, sl, group_sweep, g)
                if d > 0.85:
                    k = min(k, 0.85 / d)
            for f in range(a0, a1):
                nx = lx + cl * foot_neutral[f, 0] - sl * foot_neutral[f, 1]
                ny = ly + sl * foot_neutral[f, 0] + cl * foot_neutral[f, 1]
                foot_target[f, 0] = nx + k * (qx + cq * foot_neutral[f, 0] - sq * foot_neutral[f, 1] - nx)
                foot_target[f, 1] = ny + k * (qy + sq * foot_neutral[f, 0] + cq * foot_neutral[f, 1] - ny)
                foot_target_yaw[f] = lyaw + k * (qyaw - lyaw)
                query[f, 0] = foot_target[f, 0]
                query[f, 1] = foot_target[f, 1]
                query[nfoot + f, 0] = foot_lift[f, 0] + fw * (foot_target[f, 0] - foot_lift[f, 0])
                query[nfoot + f, 1] = foot_lift[f, 1] + fw * (foot_target[f, 1] - foot_lift[f, 1])
        else:
            for f in range(a0, a1):
                query[f, 0] = foot_world[f, 0]
                query[f, 1] = foot_world[f, 1]
                query[nfoot + f, 0] = foot_world[f, 0]
                query[nfoot + f, 1] = foot_world[f, 1]
    # 3. rest spots under the placement (ground height and slope under the body)
    for f in range(nfoot):
        query[2 * nfoot + f, 0] = px + cy * foot_neutral[f, 0] - sy * foot_neutral[f, 1]
        query[2 * nfoot + f, 1] = py + sy * foot_neutral[f, 0] + cy * foot_neutral[f, 1]


@njit(cache=True, inline="always")
def _qmul(a0, a1, a2, a3, b0, b1, b2, b3):
    return (a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3, a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
            a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1, a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0)


@njit(cache=True, inline="always")
def _qrot(w, x, y, z, vx, vy, vz):
    """v rotated by the unit quaternion (w, x, y, z)."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz), vz + w * tz + (x * ty - y * tx)


@njit(cache=True, inline="always")
def _pitch_roll(pitch, roll):
    """Quaternion of a rotation by ``pitch`` about +y after ``roll`` about +x."""
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    return cp * cr, cp * sr, sp * cr, -sp * sr


@njit(cache=True, inline="always")
def _foot_rel_rot(rel_yaw, foot_tilt, pitch):
    """A foot goal's rotation relative to its rest rotation (character space): yaw about
    z, the slope tilt, the flight pitch about the left axis (as the goals are written)."""
    h = 0.5 * rel_yaw
    q = _qmul(math.cos(h), 0.0, 0.0, math.sin(h), foot_tilt[0], foot_tilt[1], foot_tilt[2], foot_tilt[3])
    return _qmul(q[0], q[1], q[2], q[3], math.cos(0.5 * pitch), 0.0, -math.sin(0.5 * pitch), 0.0)


@njit(cache=True, inline="always")
def _compass_leg(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt, f, place_pos, cy, sy, yaw,
                 pitch, root_pos, root_rot):
    """A rigid leg in the character frame: its foot's joint (x, y, z, the foot as its goal
    rotation leaves it), its hip's height, and how far above the joint the hip sits when
    the leg, one chain length long, reaches from the joint's horizontal spot to the hip's."""
    rw, rx, ry, rz = _foot_rel_rot(foot_yaw[f] - yaw, foot_tilt[f], pitch)
    ox, oy, oz = _qrot(rw, rx, ry, rz, foot_jointrel[f, 0], foot_jointrel[f, 1], foot_jointrel[f, 2])
    dx = foot_world[f, 0] - place_pos[0]
    dy = foot_world[f, 1] - place_pos[1]
    jx = cy * dx + sy * dy + ox
    jy = -sy * dx + cy * dy + oy
    jz = foot_world[f, 2] - place_pos[2] + oz
    hx, hy, hz = _hip(root_pos, root_rot, foot_hip, f)
    need = math.sqrt(max(foot_chain[f] ** 2 - (hx - jx) ** 2 - (hy - jy) ** 2, 0.0))
    return jz, oz, hz, need


@njit(cache=True, inline="always")
def _compass_dz(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt, f, place_pos, cy, sy, yaw,
                pitch, root_pos, root_rot):
    """How far the root must rise (m, negative: sink) for a rigid leg's hip to sit exactly
    one leg length above its foot's joint (the foot as its goal rotation leaves it)."""
    jz, _, hz, need = _compass_leg(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt, f,
                                   place_pos, cy, sy, yaw, pitch, root_pos, root_rot)
    return jz + need - hz


@njit(cache=True, inline="always")
def _compass_gap(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt, foot_offset, ground_z, f,
                 place_pos, cy, sy, yaw, pitch, root_pos, root_rot):
    """How far (m) the lowest point of a swinging rigid leg's sphere (at the foot's present
    horizontal spot) is above the ground ``ground_z`` (world), as the foot's contact point."""
    _, oz, hz, need = _compass_leg(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt, f,
                                   place_pos, cy, sy, yaw, pitch, root_pos, root_rot)
    return (hz - need) - (ground_z - place_pos[2] + foot_offset[f] + oz)


@njit(cache=True)
def _compass_hips(step_group, step_state, step_foot_adr, step_foot_num, step_progress, step_parked, step_lift_u,
                  step_u, step_done, foot_rigid, foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt,
                  foot_lift, foot_lift_yaw, place_pos, cy, sy, yaw, root_pos, root_rot, bob_state):
    """Hip height of compass legs and lift-off of the planted ones left hanging (see the
    comment in ``gait_pose``)."""
    have = False
    dz_top = -1e9
    for s in range(step_group.shape[0]):
        if step_state[s] != STANCE:
            continue
        for f in range(step_foot_adr[s], step_foot_adr[s] + step_foot_num[s]):
            if foot_rigid[f] == 0:
                continue
            dz = _compass_dz(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt, f, place_pos,
                             cy, sy, yaw, 0.0, root_pos, root_rot)
            dz_top = max(dz_top, dz)
            have = True
    if have:
        root_pos[2] += dz_top
        bob_state[2] = root_pos[2]
        bob_state[3] = 1.0
        # planted compass legs left hanging lift off (the hips went up over another foot)
        for s in range(step_group.shape[0]):
            if step_state[s] != STANCE or foot_rigid[step_foot_adr[s]] == 0:
                continue
            hang = 0.0
            for f in range(step_foot_adr[s], step_foot_adr[s] + step_foot_num[s]):
                dz = _compass_dz(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt, f, place_pos,
                                 cy, sy, yaw, 0.0, root_pos, root_rot)
                hang = max(hang, -dz)
            if hang > COMPASS_TOL * foot_chain[step_foot_adr[s]]:
                step_state[s] = FLIGHT
                step_progress[s] = 0.0
                step_parked[s] = 0
                step_lift_u[s] = step_u[s]
                step_done[s] = 1
                for f in range(step_foot_adr[s], step_foot_adr[s] + step_foot_num[s]):
                    for j in range(3):
                        foot_lift[f, j] = foot_world[f, j]
                    foot_lift_yaw[f] = foot_yaw[f]
    elif bob_state[3] > 0.0:
        root_pos[2] = bob_state[2]
    return dz_top if have else 0.0


@njit(cache=True)
def pivot_goal(gp, gq, rest_q, hip, knee, contact):
    """Turn a pivot foot's goal about its contact point so the foot joint sits on the
    sphere of the leg's rigid segment around the hip: the foot joint is the leg's knee (see
    ``engine.gait.rig``).

    gp (3,), gq (4,)   the foot goal's position and rotation, character space (in/out)
    rest_q (4,)        the foot's rest rotation
    hip (3,)           the hip joint where the goal's pose will be met, character space
    knee (4,)          the rig's ``foot_knee`` row: rest foot joint - rest origin, segment length
    contact (3,)       the rig's ``foot_contact`` row: rest contact point - rest origin

    Of the circle of joint spots that fit both the segment and the foot, the one nearest
    where the goal put the joint wins, so the knee keeps its side and moves smoothly. A hip
    too far from (or too near to) the contact point for both lengths gets the straightest
    (most folded) leg along the hip-contact line; the IK then misses, as with any leg
    asked past its reach."""
    # the goal's rotation relative to rest carries the rest offsets
    rw, rx, ry, rz = _qmul(gq[0], gq[1], gq[2], gq[3], rest_q[0], -rest_q[1], -rest_q[2], -rest_q[3])
    cx, cy, cz = _qrot(rw, rx, ry, rz, contact[0], contact[1], contact[2])
    kx, ky, kz = _qrot(rw, rx, ry, rz, knee[0], knee[1], knee[2])
    cx += gp[0]
    cy += gp[1]
    cz += gp[2]
    kx += gp[0]
    ky += gp[1]
    kz += gp[2]
    seg = knee[3]
    foot = math.sqrt((knee[0] - contact[0]) ** 2 + (knee[1] - contact[1]) ** 2 + (knee[2] - contact[2]) ** 2)
    dx, dy, dz = hip[0] - cx, hip[1] - cy, hip[2] - cz
    dn = math.sqrt(dx * dx + dy * dy + dz * dz)
    if dn < 1e-9 or seg <= 0.0 or foot <= 0.0:
        return
    ux, uy, uz = dx / dn, dy / dn, dz / dn
    # the circle: centre at distance a from the contact point along u, radius rad
    a = (foot * foot - seg * seg + dn * dn) / (2.0 * dn)
    a = min(max(a, -foot), foot)
    rad = math.sqrt(max(foot * foot - a * a, 0.0))
    mx, my, mz = cx + a * ux, cy + a * uy, cz + a * uz
    wx, wy, wz = kx - mx, ky - my, kz - mz
    wu = wx * ux + wy * uy + wz * uz
    wx -= wu * ux
    wy -= wu * uy
    wz -= wu * uz
    wn = math.sqrt(wx * wx + wy * wy + wz * wz)
    if wn < 1e-12:
        return                                  # the joint lies on the hip-contact line: no side to keep
    nx, ny, nz = mx + rad * wx / wn, my + rad * wy / wn, mz + rad * wz / wn
    # the shortest rotation taking (joint - contact) to (new joint - contact)
    ax, ay, az = kx - cx, ky - cy, kz - cz
    bx, by, bz = nx - cx, ny - cy, nz - cz
    an = math.sqrt(ax * ax + ay * ay + az * az)
    bn = math.sqrt(bx * bx + by * by + bz * bz)
    if an < 1e-12 or bn < 1e-12:
        return
    ax, ay, az = ax / an, ay / an, az / an
    bx, by, bz = bx / bn, by / bn, bz / bn
    dw = 1.0 + ax * bx + ay * by + az * bz
    if dw < 1e-9:
        return                                  # half a turn: never asked by a continuous gait
    qx, qy, qz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    qn = math.sqrt(dw * dw + qx * qx + qy * qy + qz * qz)
    dw, qx, qy, qz = dw / qn, qx / qn, qy / qn, qz / qn
    ox, oy, oz = _qrot(dw, qx, qy, qz, gp[0] - cx, gp[1] - cy, gp[2] - cz)
    gp[0] = cx + ox
    gp[1] = cy + oy
    gp[2] = cz + oz
    q = _qmul(dw, qx, qy, qz, gq[0], gq[1], gq[2], gq[3])
    for j in range(4):
        gq[j] = q[j]


@njit(cache=True)
def gait_pose(place_pos, yaw, heights, path, group_lift, group_bob, group_sway, group_duty, step_group, step_side,
              step_lift_scale, step_duty_scale, step_foot_adr, step_foot_num, step_state, step_progress, step_u,
              foot_body, foot_offset, foot_rest_rot, foot_hip, foot_jointrel, foot_chain, foot_rigid, foot_knee,
              foot_contact, foot_world, foot_lift, foot_yaw, foot_lift_yaw, foot_target, foot_target_yaw, slope_w,
              foot_slope, slope_alpha, foot_tilt, root_dq, root_dpos,
              bob_state, bob_alpha, root_pos, root_rot, goal_pos, goal_rot, goal_pw, goal_rw, foot_bias,
              step_lift_u, step_parked, step_done, goal_written):
    """Stage 2 of a frame (see the module docstring).

    place_pos (3,), yaw        this frame's placement (world)
    heights (3F + 5,)          ground height at the query points of ``gait_plan``
    group_lift/bob/sway (G,)   peak foot lift, hip bob and hip sway amplitudes, m
    slope_w (2,)               the body's filtered ground slope (world dz/dx, dz/dy)
    foot_slope (F, 2)          each foot's ground slope (world; in/out): frozen while planted (a
                               planted foot never turns), turned toward ``slope_w`` in flight and
                               while owned by an animation, by ``slope_alpha`` per frame
    foot_tilt (F, 4)           out: each foot's slope rotation in its own heading frame
    root_dq (4,), root_dpos (3,)  slope/lean rotation and crouch offset added to the root
    bob_state (7,), bob_alpha  low-pass filtered hip bob and sway, the compass legs' last root
                               height and whether it is set, the hip hike's roll last frame (in/out),
                               and the filter's share per frame (many fast feet must not shake the hips)
    foot_hip/jointrel/chain/rigid/knee/contact  see ``engine.gait.rig`` (compass legs, pivot feet)
    root_pos, root_rot, goal_* in/out (character space)
    step_lift_u, step_parked, step_done (S,)  as in ``gait_plan`` (a hanging compass leg lifts here)
    goal_written (F, 7)        out: each foot's goal as written (position, rotation; character
                               space), for ``observe_feet``
    foot_bias (F, 3)           the IK's miss of each foot (character space): taken off the goal so
                               the output lands on the spot (calibrated at the rest stance, then
                               followed from what the IK did last frame: ``observe_feet``)
    """
    nfoot = foot_body.shape[0]
    ngroup = group_lift.shape[0]
    cy, sy = math.cos(yaw), math.sin(yaw)
    bob = 0.0
    sway = 0.0
    for s in range(step_group.shape[0]):
        g = step_group[s]
        a0 = step_foot_adr[s]
        a1 = a0 + step_foot_num[s]
        st = step_state[s]
        if st == OWNED:
            # follow the animation's goal in world space so the gait can take over smoothly
            for f in range(a0, a1):
                b = foot_body[f]
                gx, gy, gz = goal_pos[b, 0], goal_pos[b, 1], goal_pos[b, 2]
                foot_world[f, 0] = place_pos[0] + cy * gx - sy * gy
                foot_world[f, 1] = place_pos[1] + sy * gx + cy * gy
                foot_world[f, 2] = place_pos[2] + gz
                foot_yaw[f] = yaw
            continue
        if st == LANDING:
            for f in range(a0, a1):
                foot_world[f, 0] = foot_target[f, 0]
                foot_world[f, 1] = foot_target[f, 1]
                foot_world[f, 2] = heights[f] + foot_offset[f]
                foot_yaw[f] = foot_target_yaw[f]
            step_state[s] = STANCE
        elif st == FLIGHT:
            p = step_progress[s]
            fw, up, pitch = _path_at(path, g, p)
            lift = group_lift[g] * step_lift_scale[s]
            bump = math.sin(math.pi * p) ** 2         # zero slope at lift-off and touchdown: no velocity jump
            bob += group_bob[g] * bump
            sway -= group_sway[g] * step_side[s] * bump
            for f in range(a0, a1):
                tz = heights[f] + foot_offset[f]
                x = foot_lift[f, 0] + fw * (foot_target[f, 0] - foot_lift[f, 0])
                y = foot_lift[f, 1] + fw * (foot_target[f, 1] - foot_lift[f, 1])
                z = foot_lift[f, 2] + fw * (tz - foot_lift[f, 2]) + lift * up
                # never below the ground under the foot (clear it by a share of the lift)
                floor = heights[nfoot + f] + foot_offset[f] + 0.25 * lift * up
                foot_world[f, 0] = x
                foot_world[f, 1] = y
                foot_world[f, 2] = max(z, floor)
                foot_yaw[f] = foot_lift_yaw[f] + fw * (foot_target_yaw[f] - foot_lift_yaw[f])
    # each foot's slope rotation, in its own heading frame (``_foot_rel_rot`` turns it by the
    # foot's yaw): planted feet keep the slope they landed with
    for s in range(step_group.shape[0]):
        for f in range(step_foot_adr[s], step_foot_adr[s] + step_foot_num[s]):
            if step_state[s] != STANCE:
                foot_slope[f, 0] += slope_alpha * (slope_w[0] - foot_slope[f, 0])
                foot_slope[f, 1] += slope_alpha * (slope_w[1] - foot_slope[f, 1])
            cf, sf = math.cos(foot_yaw[f]), math.sin(foot_yaw[f])
            sx = cf * foot_slope[f, 0] + sf * foot_slope[f, 1]
            sl = -sf * foot_slope[f, 0] + cf * foot_slope[f, 1]
            q = _pitch_roll(-math.atan(sx), math.atan(sl))
            for j in range(4):
                foot_tilt[f, j] = q[j]
    # root: crouch, slope and lean rotation, bob and sway
    n_per = max(step_group.shape[0], 1) / max(ngroup, 1)
    # two first-order stages in a row (bob_state[4:6] the first): a single stage passes the
    # corners of many short flights' bumps on as root acceleration spikes
    bob_state[4] += bob_alpha * (bob / max(n_per * 0.5, 1.0) - bob_state[4])
    bob_state[5] += bob_alpha * (sway / max(n_per * 0.5, 1.0) - bob_state[5])
    bob_state[0] += bob_alpha * (bob_state[4] - bob_state[0])
    bob_state[1] += bob_alpha * (bob_state[5] - bob_state[1])
    root_pos[0] += root_dpos[0]
    root_pos[1] += root_dpos[1] + bob_state[1]
    root_pos[2] += root_dpos[2] + bob_state[0]
    q = _qmul(root_dq[0], root_dq[1], root_dq[2], root_dq[3], root_rot[0], root_rot[1], root_rot[2], root_rot[3])
    for j in range(4):
        root_rot[j] = q[j]
    # compass legs (one rigid segment, no knee; section 4.2: "the hips are translated and
    # rotated as the feet are moved"). A planted rigid leg holds its hip exactly one leg
    # length from its foot joint, so the hips ride on arcs over the planted feet: their
    # height is computed here from the leg length, never asked of the IK. Several planted
    # legs ask different heights; the hips take the highest, and a planted leg that would
    # then hang (its hip further than a leg length) lifts off at once: double support of a
    # rigid-legged walk is instantaneous, as in a compass gait. With no rigid leg planted
    # the hips keep their last height (bob_state[2], valid when bob_state[3] > 0).
    dz_top = _compass_hips(step_group, step_state, step_foot_adr, step_foot_num, step_progress, step_parked,
                           step_lift_u, step_u, step_done, foot_rigid, foot_world, foot_jointrel, foot_yaw, foot_hip,
                           foot_chain, foot_tilt, foot_lift, foot_lift_yaw, place_pos, cy, sy, yaw, root_pos, root_rot,
                           bob_state)
    # a swinging compass leg whose sphere dips below the ground (plus a small clearance)
    # gets it from a hip hike: the pelvis rolls about the forward axis so the swing side
    # rises while the planted leg keeps the hips exact (a stiff-legged waddle)
    roll = 0.0
    for s in range(step_group.shape[0]):
        if step_state[s] != FLIGHT or foot_rigid[step_foot_adr[s]] == 0:
            continue
        g = step_group[s]
        fw, up, pitch = _path_at(path, g, step_progress[s])
        clear = COMPASS_CLEAR * group_lift[g] * step_lift_scale[s] * up
        for f in range(step_foot_adr[s], step_foot_adr[s] + step_foot_num[s]):
            deficit = -_compass_gap(foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain, foot_tilt,
                                    foot_offset, heights[nfoot + f], f, place_pos, cy, sy, yaw,
                                    pitch * step_lift_scale[s], root_pos, root_rot) + clear
            if deficit <= 0.0:
                continue
            hx, hy, hz = _hip(root_pos, root_rot, foot_hip, f)
            ysum = 0.0
            n = 0
            for k in range(step_group.shape[0]):
                if step_state[k] == STANCE and foot_rigid[step_foot_adr[k]] == 1:
                    for e in range(step_foot_adr[k], step_foot_adr[k] + step_foot_num[k]):
                        ysum += _hip(root_pos, root_rot, foot_hip, e)[1]
                        n += 1
            if n == 0:
                continue
            lever = hy - ysum / n
            if abs(lever) < 0.02 * foot_chain[f]:
                continue
            # (10% over: the hips are re-solved after the roll, a first-order estimate)
            want = min(max(1.1 * deficit / lever, -COMPASS_ROLL), COMPASS_ROLL)
            if abs(want) > abs(roll):
                roll = want
    # the roll a hike no longer needs (its foot landed) eases out, COMPASS_ROLL_STEP per
    # frame, instead of dropping in one frame (a 0.35 rad turn of the pelvis and a jump of
    # the hips re-solved on the landed leg); a hike needed more takes effect at once
    prev = bob_state[6]
    if not (roll * prev >= 0.0 and abs(roll) >= abs(prev)):
        roll = prev + min(max(roll - prev, -COMPASS_ROLL_STEP), COMPASS_ROLL_STEP)
    bob_state[6] = roll
    if roll != 0.0:
        root_pos[2] -= dz_top
        q = _qmul(math.cos(0.5 * roll), math.sin(0.5 * roll), 0.0, 0.0, root_rot[0], root_rot[1], root_rot[2],
                  root_rot[3])
        for j in range(4):
            root_rot[j] = q[j]
        dz_top = _compass_hips(step_group, step_state, step_foot_adr, step_foot_num, step_progress, step_parked,
                               step_lift_u, step_u, step_done, foot_rigid, foot_world, foot_jointrel, foot_yaw,
                               foot_hip, foot_chain, foot_tilt, foot_lift, foot_lift_yaw, place_pos, cy, sy, yaw,
                               root_pos, root_rot, bob_state)
    # compass legs in flight swing on the sphere of their leg around the hip and touch down
    # where the sphere meets the ground (from mid-flight on), so the new foot asks exactly
    # the height the hips are at
    landed = False
    for s in range(step_group.shape[0]):
        if step_state[s] != FLIGHT or foot_rigid[step_foot_adr[s]] == 0:
            continue
        g = step_group[s]
        p = step_progress[s]
        fw, up, pitch = _path_at(path, g, p)
        clear = COMPASS_CLEAR * group_lift[g] * step_lift_scale[s] * up
        contact = True
        for f in range(step_foot_adr[s], step_foot_adr[s] + step_foot_num[s]):
            L = foot_chain[f]
            rw, rx, ry, rz = _foot_rel_rot(foot_yaw[f] - yaw, foot_tilt[f], pitch * step_lift_scale[s])
            ox, oy, oz = _qrot(rw, rx, ry, rz, foot_jointrel[f, 0], foot_jointrel[f, 1], foot_jointrel[f, 2])
            # foot joint and hip in character space
            dx = foot_world[f, 0] - place_pos[0]
            dy = foot_world[f, 1] - place_pos[1]
            jx = cy * dx + sy * dy + ox
            jy = -sy * dx + cy * dy + oy
            hx, hy, hz = _hip(root_pos, root_rot, foot_hip, f)
            ground = heights[nfoot + f] - place_pos[2] + foot_offset[f] + oz     # joint height, foot on the ground
            ax, ay = jx - hx, jy - hy
            if p >= 1.0:
                # flight over and the ground not met (the hips stand too high for the
                # target): draw the foot in under the hip, at most COMPASS_REACH_IN of the
                # way a frame, to where its sphere meets the ground
                a = hz - ground
                d = math.hypot(ax, ay)
                d_touch = math.sqrt(L * L - a * a) if 0.0 < a < L else (0.0 if a >= L else d)
                if d > d_touch and d > 0.0:
                    k = max(d_touch / d, 1.0 - COMPASS_REACH_IN)
                    mx = -(1.0 - k) * ax
                    my = -(1.0 - k) * ay
                    wx, wy = cy * mx - sy * my, sy * mx + cy * my
                    foot_world[f, 0] += wx
                    foot_world[f, 1] += wy
                    foot_target[f, 0] += wx
                    foot_target[f, 1] += wy
                    ax, ay = k * ax, k * ay
            need = math.sqrt(max(L * L - ax * ax - ay * ay, 0.0))
            jz = hz - need
            # never below the ground (the IK then misses the swing foot a little: a rigid leg
            # cannot shorten to clear a bump)
            foot_world[f, 2] = place_pos[2] + max(jz, ground + clear) - oz
            if p < 0.5 or jz - ground > COMPASS_TOL * L:
                contact = False
        if contact:
            for f in range(step_foot_adr[s], step_foot_adr[s] + step_foot_num[s]):
                foot_world[f, 2] = heights[nfoot + f] + foot_offset[f]
            step_state[s] = STANCE
            landed = True
    if landed:
        # a foot that met the ground a little below its sphere (a bump) asks the hips up:
        # settle them with the new foot before the goals are written
        root_pos[2] -= dz_top
        _compass_hips(step_group, step_state, step_foot_adr, step_foot_num, step_progress, step_parked, step_lift_u,
                      step_u, step_done, foot_rigid, foot_world, foot_jointrel, foot_yaw, foot_hip, foot_chain,
                      foot_tilt, foot_lift, foot_lift_yaw, place_pos, cy, sy, yaw, root_pos, root_rot, bob_state)
    # goals in character space through this frame's placement
    for s in range(step_group.shape[0]):
        if step_state[s] == OWNED:
            continue
        g = step_group[s]
        a0 = step_foot_adr[s]
        a1 = a0 + step_foot_num[s]
        pitch = 0.0
        if step_state[s] == FLIGHT:
            fw, up, pitch = _path_at(path, g, step_progress[s])
            pitch *= step_lift_scale[s]
        hp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
        for f in range(a0, a1):
            b = foot_body[f]
            dx = foot_world[f, 0] - place_pos[0]
            dy = foot_world[f, 1] - place_pos[1]
            goal_pos[b, 0] = cy * dx + sy * dy - foot_bias[f, 0]
            goal_pos[b, 1] = -sy * dx + cy * dy - foot_bias[f, 1]
            goal_pos[b, 2] = foot_world[f, 2] - place_pos[2] - foot_bias[f, 2]
            goal_pw[b] = 1.0
            # rotation: yaw relative to the heading, the slope tilt, the flight pitch (toe up
            # about the character's left axis), then the rest rotation
            h = 0.5 * (foot_yaw[f] - yaw)
            q = _qmul(math.cos(h), 0.0, 0.0, math.sin(h), foot_tilt[f, 0], foot_tilt[f, 1], foot_tilt[f, 2],
                      foot_tilt[f, 3])
            q = _qmul(q[0], q[1], q[2], q[3], hp, 0.0, -sp, 0.0)
            q = _qmul(q[0], q[1], q[2], q[3], foot_rest_rot[f, 0], foot_rest_rot[f, 1], foot_rest_rot[f, 2],
                      foot_rest_rot[f, 3])
            for j in range(4):
                goal_rot[b, j] = q[j]
            goal_rw[b] = 1.0
            if foot_knee[f, 3] > 0.0:
                # a pivot foot turns about its contact point to keep its knee on the
                # segment's sphere around the hip
                hx, hy, hz = _hip(root_pos, root_rot, foot_hip, f)
                pivot_goal(goal_pos[b], goal_rot[b], foot_rest_rot[f], (hx, hy, hz), foot_knee[f],
                           foot_contact[f])
    for f in range(nfoot):
        b = foot_body[f]
        for j in range(3):
            goal_written[f, j] = goal_pos[b, j]
        for j in range(4):
            goal_written[f, 3 + j] = goal_rot[b, j]


@njit(cache=True)
def observe_feet(char_pos, char_rot, goal_written, foot_body, foot_stepper, step_state, foot_rest_rot, foot_contact,
                 foot_bias, cal_bias, gain, flight_gain, limit):
    """The gait sees the IK (issue 16): ``char_pos``, ``char_rot`` (nbody, 3/4) are what the IK
    made of the goals ``goal_written`` (F, 7) the last ``gait_pose`` wrote (character space).
    The miss that matters is the foot's contact point's (``foot_contact``, carried by the
    foot's rotation: a foot met at its origin but turned a little off its goal still lifts or
    sinks its sole). Each driven foot's bias (taken off its goal position) moves by ``gain``
    toward the miss the IK just made at that goal, so the next output lands where the gait
    wants it: with goal = want - bias and output = goal + miss, bias = miss gives output =
    want. A goal the IK cannot meet at all (a swinging knee-less leg over a bump) would wind
    the bias up: it stays within ``limit`` (m, per foot) of the rest stance's calibrated bias
    ``cal_bias``."""
    for f in range(foot_body.shape[0]):
        if step_state[foot_stepper[f]] == OWNED:
            continue
        b = foot_body[f]
        rw, rx, ry, rz = foot_rest_rot[f, 0], -foot_rest_rot[f, 1], -foot_rest_rot[f, 2], -foot_rest_rot[f, 3]
        cx, cy, cz = foot_contact[f, 0], foot_contact[f, 1], foot_contact[f, 2]
        qo = _qmul(char_rot[b, 0], char_rot[b, 1], char_rot[b, 2], char_rot[b, 3], rw, rx, ry, rz)
        qg = _qmul(goal_written[f, 3], goal_written[f, 4], goal_written[f, 5], goal_written[f, 6], rw, rx, ry, rz)
        co = _qrot(qo[0], qo[1], qo[2], qo[3], cx, cy, cz)
        cg = _qrot(qg[0], qg[1], qg[2], qg[3], cx, cy, cz)
        k = gain if step_state[foot_stepper[f]] == STANCE else flight_gain
        for j in range(3):
            miss = char_pos[b, j] + co[j] - goal_written[f, j] - cg[j]
            v = foot_bias[f, j] + k * (miss - foot_bias[f, j])
            lo = cal_bias[f, j] - limit[f]
            hi = cal_bias[f, j] + limit[f]
            foot_bias[f, j] = min(max(v, lo), hi)
