"""The gait stage of many characters in one kernel call (``GaitController.step`` for a
stack of controllers: see ``engine.gait.controller.GaitStack``).

The kernel is the controller's former Python ``step``, operation for operation in the
same order, so its output is bitwise the same: Python's ``min``/``max`` (the first
argument wins ties), ``math.hypot`` (CPython's correctly rounded algorithm, not the C
library's ``hypot``, which differs in the last bit for about 0.3 % of inputs),
``math.remainder`` and the float ``%`` are reproduced exactly (``_pymin`` ... ``_pymod``).

What needs Python stays in Python (``engine.gait.controller._finish_rows``): a row that
must plant afresh (first frame, a teleport, new terrain) is flagged ``FLAG_START`` and
skipped; a row on a terrain given by a Python function is flagged ``FLAG_TERRAIN`` after
the first half of its step (its query points are written), the runtime samples the
function and runs the second half (``phase`` 1).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from engine.gait import _kernels as K

# Columns of the per-controller scalar state (``GaitStack.sv``).
(YAW, TURN, CROUCH, TIME, IDLE, STARTED, WRITTEN, IMMOBILE, SPEED_LIMIT, CMD_W, LEN, REPLANT, RADIUS, SLOPE_E,
 MIN_CROUCH, MAX_CROUCH, BOB_SCALE, ACCEL, TURN_ACCEL, SLOPE_ALIGN, TERRAIN, HAS_NORMAL, GROUND_IN, NX, NY, NZ,
 FLAG) = range(27)
NSCALAR = 27
FLAG_START, FLAG_TERRAIN = 1.0, 2.0
MODE_WALK, MODE_CRAWL, MODE_FLOAT = 0, 1, 2

#: Bumped when a gait controller is made or moves to a stack of its own: a crowd
#: re-gathers its walking members then (``engine.runtime._Group._gait_batch``).
EPOCH = [0]

# The controller's constants (``engine.gait.controller``; repeated so the kernel file has no
# import cycle; a test checks they agree).
HEIGHT_TAU = 0.12
TILT_TAU = 0.25
FOOT_TILT_TAU = 0.05
BOB_TAU = 0.06
IDLE_SPEED = 1e-3
IDLE_TURN = 1e-3
_DBL_MIN = 2.2250738585072014e-308


@njit(cache=True)
def _pymin(a, b):
    """Python's ``min(a, b)``: ``a`` unless ``b < a``."""
    return b if b < a else a


@njit(cache=True)
def _pymax(a, b):
    """Python's ``max(a, b)``: ``a`` unless ``b > a``."""
    return b if b > a else a


@njit(cache=True)
def _split(x):
    t = x * 134217729.0          # Veltkamp-Dekker: 2 ** 27 + 1
    hi = t - (t - x)
    return hi, x - hi


@njit(cache=True)
def _sqr(x):
    """x * x as an exact double-length (hi, lo) pair (Dekker's mul12)."""
    return _mul(x, x)


@njit(cache=True)
def _mul(x, y):
    xh, xl = _split(x)
    yh, yl = _split(y)
    p = xh * yh
    q = xh * yl + xl * yh
    z = p + q
    return z, p - z + q + xl * yl


@njit(cache=True)
def _pyhypot(x, y):
    """``math.hypot(x, y)`` as CPython computes it (scaled, compensated sum of exact
    squares, a corrected square root): bitwise equal to it (checked on 10 million pairs
    in ``tests/test_gait_batch.py``)."""
    x = abs(x)
    y = abs(y)
    if math.isinf(x) or math.isinf(y):
        return math.inf
    if math.isnan(x) or math.isnan(y):
        return math.nan
    mx = x if x > y else y
    if mx == 0.0:
        return mx
    _, e = math.frexp(mx)
    tiny = 1.0
    if e < -1023:
        x /= _DBL_MIN
        y /= _DBL_MIN
        mx /= _DBL_MIN
        tiny = _DBL_MIN
        _, e = math.frexp(mx)
    scale = math.ldexp(1.0, -e)
    csum = 1.0
    f1 = 0.0
    f2 = 0.0
    x *= scale
    ph, pl = _sqr(x)
    s = csum + ph
    f2 += ph - (s - csum)
    csum = s
    f1 += pl
    y *= scale
    ph, pl = _sqr(y)
    s = csum + ph
    f2 += ph - (s - csum)
    csum = s
    f1 += pl
    h = math.sqrt(csum - 1.0 + (f1 + f2))
    ph, pl = _mul(-h, h)
    s = csum + ph
    f2 += ph - (s - csum)
    csum = s
    f1 += pl
    d = csum - 1.0 + (f1 + f2)
    h += d / (2.0 * h)
    return tiny * (h / scale)


@njit(cache=True)
def _pymod(x, w):
    """Python's float ``x % w``."""
    m = np.fmod(x, w)
    if m != 0.0:
        if (w < 0.0) != (m < 0.0):
            m += w
    else:
        m = math.copysign(0.0, w)
    return m


@njit(cache=True)
def _pyremainder(x, y):
    """Python's ``math.remainder`` for finite arguments."""
    ax = abs(x)
    ay = abs(y)
    m = np.fmod(ax, ay)
    c = ay - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * np.fmod(0.5 * (ax - m), ay)
    return math.copysign(1.0, x) * r


@njit(cache=True)
def _sweep(cc, t, g, crouch):
    """``GaitController._sweep``: calibrated half-sweeps of group g at ``crouch``."""
    if crouch <= cc[0]:
        return t[g, 0, 0], t[g, 0, 1]
    n = cc.shape[0]
    for k in range(n - 1):
        if crouch <= cc[k + 1]:
            a = (crouch - cc[k]) / (cc[k + 1] - cc[k])
            return t[g, k, 0] * (1 - a) + t[g, k + 1, 0] * a, t[g, k, 1] * (1 - a) + t[g, k + 1, 1] * a
    return t[g, n - 1, 0], t[g, n - 1, 1]


@njit(cache=True)
def _bracket(t, n, x):
    k = 0
    while k + 1 < n and t[k + 1, 0] <= x:
        k += 1
    return k


@njit(cache=True)
def _params(tab, tab_n, tab_w, tab_nl, g, x, out):
    """``GaitController._params``: the blended speed-entry row of group g at speed ``x``
    (style layer tables padded in ``tab`` (G, layers, rows, 8), ``tab_n`` rows used)."""
    n = tab_n[g, 0]
    k = _bracket(tab[g, 0], n, x)
    if k + 1 >= n or x <= tab[g, 0, 0, 0]:
        kk = k if x > tab[g, 0, 0, 0] else 0
        for j in range(8):
            out[j] = tab[g, 0, kk, j]
    else:
        a = (x - tab[g, 0, k, 0]) / (tab[g, 0, k + 1, 0] - tab[g, 0, k, 0])
        for j in range(8):
            out[j] = (tab[g, 0, k + 1, j] - tab[g, 0, k, j]) * a + tab[g, 0, k, j]
    for lay in range(1, tab_nl[g]):
        t = tab[g, lay]
        n = tab_n[g, lay]
        w = tab_w[g, lay]
        k = _bracket(t, n, x)
        for j in range(1, 8):
            if k + 1 >= n or x <= t[0, 0]:
                v = t[k if x > t[0, 0] else 0, j]
            else:
                a = (x - t[k, 0]) / (t[k + 1, 0] - t[k, 0])
                v = t[k, j] + a * (t[k + 1, j] - t[k, j])
            out[j] += w * (v - out[j])


@njit(cache=True)
def gait_rows(dt, phase, rows, crows, place_pos, place_rot, root_pos, root_rot, goal_pos, goal_rot, goal_pw,
              goal_rw, ground, ground_set, sv, cmd_v, velocity, prev_v, last_place, group_phase, group_support,
              group_rate, group_duty, group_sweep, group_park, group_lift, group_bob, group_sway, crouch_want, path,
              step_trigger, step_duty_scale, step_lift_scale, step_state, step_progress, step_prev_u, step_parked,
              step_lift_u, step_done, foot_world, foot_lift, foot_yaw, foot_lift_yaw, foot_target, foot_target_yaw,
              query, heights, place3, vel3, foot_slope, foot_tilt, slope_w, ground_plane, root_dq, root_dpos, bob,
              prow, tilt, lean, cal_crouch, cal_sweep, group_stretch, foot_bias, prev_root_pos, prev_root_rot,
              goal_written, tab, tab_n, tab_w, tab_nl, sc_cap, sc_top, sc_ptop, sc_sa, sc_settle, mode, float_height,
              group_length, group_radius, group_ratio, group_first, step_group, step_side, step_foot_adr,
              step_foot_num, foot_body, foot_neutral, foot_offset, foot_rest_rot, foot_hip, foot_jointrel,
              foot_chain, foot_rigid, foot_knee, foot_contact):
    """One gait step (``GaitController`` module docstring, steps 1-6) of the gait-stack
    rows ``rows``, whose characters are rows ``crows`` of the character arrays. ``phase``
    0: the whole step (a row on a Python terrain stops after step 3, flagged); 1: steps
    4-6 of the rows flagged for terrain (heights sampled, ``GROUND_IN`` and the normal set).
    Returns how many rows were flagged for Python."""
    nflag = 0
    ngroup = group_length.shape[0]
    nstep = step_group.shape[0]
    F = foot_body.shape[0]
    for i in range(rows.shape[0]):
        r = rows[i]
        c = crows[i]
        s = sv[r]
        pp = place_pos[c]
        pr = place_rot[c]
        hts = heights[r]
        if phase == 0:
            yaw_now = 2.0 * math.atan2(pr[3], pr[0])
            if (s[STARTED] == 0.0
                    or _pyhypot(pp[0] - last_place[r, 0], pp[1] - last_place[r, 1]) > s[REPLANT]
                    or abs(_pyremainder(yaw_now - s[YAW], 2 * math.pi)) > 1e-6):
                s[FLAG] = FLAG_START
                nflag += 1
                continue
            s[TIME] += dt
            L = s[LEN]
            # 1. speed limit (no overreach) and acceleration-limited root motion
            limit = math.inf
            limit_y = math.inf
            for g in range(ngroup):
                Lg = group_length[g]
                cap = sc_cap[r, g]
                top = sc_top[r, g]
                p = sc_ptop[r, g]
                sa = sc_sa[r, g]
                sb0, sb1 = _sweep(cal_crouch[r], cal_sweep[r], g, s[CROUCH])
                duty = _pymax(p[2], 0.05)
                limit = _pymin(_pymin(limit, cap * _pymin(p[1] * Lg, 1.6 * _pymin(sa[0], sb0) / duty)),
                               top * Lg * 1.25)
                limit_y = _pymin(_pymin(limit_y, cap * _pymin(p[1] * Lg, 1.6 * _pymin(sa[1], sb1) / duty)),
                                 top * Lg * 1.25)
            s[SPEED_LIMIT] = limit
            cmd = cmd_v[r]
            cmd_speed = _pyhypot(cmd[0], cmd[1])
            w_cmd = s[CMD_W]
            radius = s[RADIUS]
            demand = 0.0
            if limit < math.inf:
                lo = _pymax(_pymin(limit, limit_y), 1e-12)
                demand = (_pyhypot(cmd[0] / _pymax(limit, 1e-12), cmd[1] / _pymax(limit_y, 1e-12))
                          + abs(w_cmd) * radius / lo)
            if demand > 1.0:
                k = 1.0 / demand
                tx, ty, tw = cmd[0] * k, cmd[1] * k, w_cmd * k
            else:
                tx, ty, tw = cmd[0], cmd[1], w_cmd
            acc = s[ACCEL] * L
            tacc = s[TURN_ACCEL]
            vel = velocity[r]
            dvx, dvy = tx - vel[0], ty - vel[1]
            dv = _pyhypot(dvx, dvy)
            if dv > acc * dt:
                dvx, dvy = dvx * acc * dt / dv, dvy * acc * dt / dv
            prev_v[r, 0] = vel[0]
            prev_v[r, 1] = vel[1]
            vel[0] += dvx
            vel[1] += dvy
            dw = tw - s[TURN]
            s[TURN] += _pymax(-tacc * dt, _pymin(tacc * dt, dw))
            yaw0 = s[YAW]
            yaw = yaw0 + s[TURN] * dt
            s[YAW] = yaw
            ym = 0.5 * (yaw0 + yaw)
            cm, sm = math.cos(ym), math.sin(ym)
            vx = cm * vel[0] - sm * vel[1]
            vy = sm * vel[0] + cm * vel[1]
            pp[0] += vx * dt
            pp[1] += vy * dt
            h = 0.5 * yaw
            pr[0] = math.cos(h)
            pr[1] = 0.0
            pr[2] = 0.0
            pr[3] = math.sin(h)
            speed = _pyhypot(vel[0], vel[1])
            idle = (cmd_speed < IDLE_SPEED * L and abs(w_cmd) < IDLE_TURN
                    and speed < IDLE_SPEED * L and abs(s[TURN]) < IDLE_TURN)
            immobile = nstep > 0 and _pymin(limit, limit_y) <= 0.0
            s[IMMOBILE] = 1.0 if immobile else 0.0
            if immobile:
                idle = True
            if s[IDLE] != 0.0 and not idle:
                parked = True
                for k in range(nstep):
                    if step_parked[r, k] != 1:
                        parked = False
                if parked:
                    # setting off from a stand: each group's cycle starts just before its
                    # front stepper lifts
                    for g in range(ngroup):
                        first = group_first[g]
                        _params(tab[r], tab_n[r], tab_w[r], tab_nl[r], g, 0.0, prow[r])
                        duty0 = prow[r, 2] * step_duty_scale[r, first]
                        group_phase[r, g] = _pymod(step_trigger[r, first] + duty0 - 0.005, 1.0)
                        for k in range(nstep):
                            if step_group[k] == g:
                                step_prev_u[r, k] = _pymod(group_phase[r, g] - step_trigger[r, k], 1.0)
                                step_done[r, k] = 0
            s[IDLE] = 1.0 if idle else 0.0
            # 2. cadence per group, locked by the harmonized ratios
            base = 0.0
            for g in range(ngroup):
                Lg = group_length[g]
                v_eff = speed + abs(s[TURN]) * group_radius[g]
                p = prow[r]
                _params(tab[r], tab_n[r], tab_w[r], tab_nl[r], g, v_eff / Lg, p)
                sx, sy = _sweep(cal_crouch[r], cal_sweep[r], g, s[CROUCH])
                duty = p[2]
                ux, uy = vel[0] / _pymax(speed, 1e-12), vel[1] / _pymax(speed, 1e-12)
                if speed > 0:
                    s_dir = 1.0 / _pymax(_pyhypot(ux / _pymax(sx, 1e-12), uy / _pymax(sy, 1e-12)), 1e-12)
                else:
                    s_dir = sx
                stride = _pymin(p[1] * Lg, 1.6 * s_dir / duty)
                stride_turn = _pymin(p[1] * Lg, 1.6 * _pymin(sx, sy) / duty)
                f_g = (speed / _pymax(stride, 1e-6)
                       + abs(s[TURN]) * group_radius[g] / _pymax(stride_turn, 1e-6))
                settle = sc_settle[r, g]
                if not idle:
                    f_g = _pymax(f_g, 0.35 * settle)
                else:
                    moving = False
                    for k in range(nstep):
                        if step_group[k] == g and step_parked[r, k] == 0:
                            moving = True
                    if moving:
                        f_g = settle
                base = _pymax(base, f_g / group_ratio[g])
                group_duty[r, g] = duty
                group_sweep[r, g, 0] = 0.97 * sx
                group_sweep[r, g, 1] = 0.97 * sy
                group_park[r, g] = 0.03 * Lg
                group_lift[r, g] = p[3] * Lg
                gain = _pymin(v_eff / Lg, 1.0)
                group_bob[r, g] = p[4] * Lg * gain * s[BOB_SCALE]
                group_sway[r, g] = p[5] * Lg * gain
                crouch_want[r, g] = p[7] * Lg
            for g in range(ngroup):
                group_rate[r, g] = base * group_ratio[g]
            # 3. stance/flight transitions and touchdown predictions
            place3[r, 0] = pp[0]
            place3[r, 1] = pp[1]
            place3[r, 2] = yaw
            vel3[r, 0] = vx
            vel3[r, 1] = vy
            vel3[r, 2] = s[TURN]
            q = query[r]
            if nstep:
                K.gait_plan(dt, place3[r], vel3[r], idle, group_rate[r], group_phase[r], group_duty[r],
                            group_sweep[r], group_park[r], path[r], step_group, step_trigger[r],
                            step_duty_scale[r], step_foot_adr, step_foot_num, step_state[r], step_progress[r],
                            step_prev_u[r], step_parked[r], step_lift_u[r], step_done[r], foot_body, foot_neutral,
                            foot_world[r], foot_lift[r], foot_yaw[r], foot_lift_yaw[r], foot_target[r],
                            foot_target_yaw[r], goal_pw[c], q, pp[2], prev_root_pos[r], prev_root_rot[r],
                            foot_hip, foot_jointrel, foot_chain, foot_rigid, group_stretch[r], group_support[r])
            # ground under the centre and four points around it (slope at the body's scale)
            e = s[SLOPE_E]
            cy, sy = math.cos(yaw), math.sin(yaw)
            q[3 * F, 0], q[3 * F, 1] = pp[0], pp[1]
            q[3 * F + 1, 0], q[3 * F + 1, 1] = pp[0] + e * cy, pp[1] + e * sy
            q[3 * F + 2, 0], q[3 * F + 2, 1] = pp[0] - e * cy, pp[1] - e * sy
            q[3 * F + 3, 0], q[3 * F + 3, 1] = pp[0] - e * sy, pp[1] + e * cy
            q[3 * F + 4, 0], q[3 * F + 4, 1] = pp[0] + e * sy, pp[1] - e * cy
            if s[TERRAIN] != 0.0:
                s[FLAG] = FLAG_TERRAIN            # 4. the ground comes from Python
                nflag += 1
                continue
            # 4. the flat ground z = 0
            hts[:] = 0.0
            ground_z = 0.0
        else:
            if s[FLAG] != FLAG_TERRAIN:
                continue
            s[FLAG] = 0.0
            ground_z = s[GROUND_IN]
        yaw = s[YAW]
        L = s[LEN]
        e = s[SLOPE_E]
        cy, sy = math.cos(yaw), math.sin(yaw)
        vel = velocity[r]
        speed = _pyhypot(vel[0], vel[1])
        # 5. placement height and torso slope
        a_h = 1.0 - math.exp(-dt / HEIGHT_TAU)
        pp[2] += a_h * (ground_z - pp[2])
        if s[HAS_NORMAL] != 0.0:
            nz = _pymax(s[NZ], 1e-3)
            gx, gy = -s[NX] / nz, -s[NY] / nz
            sx, sl = cy * gx + sy * gy, -sy * gx + cy * gy
        else:
            sx = (hts[3 * F + 1] - hts[3 * F + 2]) / (2 * e)
            sl = (hts[3 * F + 3] - hts[3 * F + 4]) / (2 * e)
        gx, gy = cy * sx - sy * sl, sy * sx + cy * sl
        nrm = math.sqrt(gx * gx + gy * gy + 1.0)
        gp = ground_plane[r]
        gp[0], gp[1], gp[2] = -gx / nrm, -gy / nrm, 1.0 / nrm
        gp[3] = gp[0] * pp[0] + gp[1] * pp[1] + gp[2] * hts[3 * F]
        a_t = 1.0 - math.exp(-dt / TILT_TAU)
        tl = tilt[r]
        tl[0] += a_t * (sx - tl[0])
        tl[1] += a_t * (sl - tl[1])
        lean_k = 0.0
        if ngroup:
            _params(tab[r], tab_n[r], tab_w[r], tab_nl[r], 0, speed / L, prow[r])
            lean_k = prow[r, 6]
        ax = (vel[0] - prev_v[r, 0]) / dt
        ay = speed * s[TURN]
        ln = lean[r]
        ln[0] += a_t * (lean_k * ax / L - ln[0])
        ln[1] += a_t * (-lean_k * ay / L - ln[1])
        align = s[SLOPE_ALIGN]
        pitch = -align * math.atan(tl[0]) + ln[0]
        roll = align * math.atan(tl[1]) + ln[1]
        dq = root_dq[r]
        dq[0], dq[1], dq[2], dq[3] = K._pitch_roll(pitch, roll)
        slope_w[r, 0] = cy * tl[0] - sy * tl[1]
        slope_w[r, 1] = sy * tl[0] + cy * tl[1]
        want = s[MIN_CROUCH]
        for g in range(ngroup):
            want = _pymax(want, crouch_want[r, g])
        want = _pymin(want, s[MAX_CROUCH])
        s[CROUCH] += a_t * (want - s[CROUCH])
        root_dpos[r, 2] = -s[CROUCH]
        if mode == MODE_CRAWL:
            root_dpos[r, 2] = 0.0
            group_bob[r, :] = 0.0
            group_sway[r, :] = 0.0
        if mode == MODE_FLOAT:
            root_dpos[r, 2] = 0.03 * float_height * (1.0 - math.cos(2.0 * math.pi * 0.4 * s[TIME]))
        # 6. feet and root
        K.gait_pose(pp, yaw, hts, path[r], group_lift[r], group_bob[r], group_sway[r], group_duty[r], step_group,
                    step_side, step_lift_scale[r], step_duty_scale[r], step_foot_adr, step_foot_num, step_state[r],
                    step_progress[r], step_prev_u[r], foot_body, foot_offset, foot_rest_rot, foot_hip, foot_jointrel,
                    foot_chain, foot_rigid, foot_knee, foot_contact, foot_world[r], foot_lift[r], foot_yaw[r],
                    foot_lift_yaw[r], foot_target[r], foot_target_yaw[r], slope_w[r], foot_slope[r],
                    1.0 - math.exp(-dt / FOOT_TILT_TAU), foot_tilt[r], root_dq[r], root_dpos[r], bob[r],
                    1.0 - math.exp(-dt / BOB_TAU), root_pos[c], root_rot[c], goal_pos[c], goal_rot[c], goal_pw[c],
                    goal_rw[c], foot_bias[r], step_lift_u[r], step_parked[r], step_done[r], goal_written[r])
        s[WRITTEN] = 1.0
        for k in range(3):
            last_place[r, k] = pp[k]
            prev_root_pos[r, k] = root_pos[c, k]
        for k in range(4):
            prev_root_rot[r, k] = root_rot[c, k]
            ground[c, k] = gp[k]
        ground_set[c] = True
    return nflag


@njit(cache=True)
def observe_rows(rows, crows, char_pos, char_rot, sv, goal_written, step_state, foot_bias, cal_bias, observe_limit,
                 foot_body, foot_stepper, foot_rest_rot, foot_contact, gain, flight_gain):
    """``GaitController.observe`` of the gait-stack rows ``rows`` (characters ``crows``)."""
    F = foot_body.shape[0]
    for i in range(rows.shape[0]):
        r = rows[i]
        c = crows[i]
        if sv[r, WRITTEN] == 0.0 or F == 0:
            continue
        sv[r, WRITTEN] = 0.0
        K.observe_feet(char_pos[c], char_rot[c], goal_written[r], foot_body, foot_stepper, step_state[r],
                       foot_rest_rot, foot_contact, foot_bias[r], cal_bias[r], gain, flight_gain, observe_limit[r])
