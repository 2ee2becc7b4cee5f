"""Self-collision kernel of the limb phase (issue 16; Hecker et al. 2008 section 4.3 call
the missing collisions "clearly a flaw": arms through bellies, no hug).

Every body of the creature has a capsule proxy (``engine.ik.selfcollision`` builds them
from the bodies' boxes when the plan is built). A proxy is carried rigidly by a *carrier*
body that is already posed when the limb phase starts (a spine body, the root, or the
spine body a limb hangs off), and, for a body the limb phase moves, swung with the bone
between two limb particles (its *pivot* particle at the body's joint and its *direction*
particle at its child joint or tip) the way the limb rebuild swings the body: the rest
pose carried by the attach body, then the shortest arc taking the rest bone onto the
posed one. Pairs (not parent and child, not both fixed, not riding the same bone) whose
capsules overlap deeper than they do in the rest pose push their bones' particles apart
along the contact normal, split by where the contact lies on each bone (a position-based
edge contact), then the limbs get their lengths back by the same outward projection as
the rebuild. ``rounds`` times, after the constraint iterations and before the rebuild:
a limb that would enter the torso or another limb is pushed out along the surface, a goal
inside another body is met at its surface.

Layout (one int32 and one float64 field of the plan, see ``engine.ik.selfcollision``):
``cl_i`` = [nprox, nmove, npair, work_row, rounds, then per proxy (carrier, pivot, dir),
then per pair (a, b)]; movers come first (pivot >= 0). ``cl_f`` = per proxy (a (3), b (3)
in the carrier's frame, radius, bound = half length + radius, yield: 0 for a body that
carries a head, which lets the other side of its contacts move alone), then per pair the rest
pose's own overlap (m), which is allowed, and the square of the distance between the
two capsules' middles beyond which they cannot touch. Work rows in the scratch: ``W``
per proxy (the world ends of its capsule, their middle, a mover's rest offsets), then
two per limb particle (the pass's summed pushes and their summed weights, zero between
passes).

Like ``engine.ik._kernels`` (whose stage calls this one, inlined), everything is compiled
without reference counts and touches no heap; the small tuple algebra is repeated here
so this module does not import the solver's.
"""

from __future__ import annotations

import math

from numba import njit

EPS = 1e-12
NI_HEAD = 6      # ints before the per-proxy records
NI_PROX = 3      # ints per proxy
NF_PROX = 9      # floats per proxy
W = 5            # work rows per proxy: capsule ends, their middle, a mover's two rest offsets
MIN_DENOM = 0.25  # a contact next to a fixed limb root moves the bone at most 1/0.25 times its depth
SKIN = 1.0       # depth (share of the thinner capsule's radius) over which a contact's push ramps in
SWIVEL_REG = 0.5   # a limb's swivel counts its particles at least this share of its length (along its
                   # bones, root to held end) off its line (0.15: random 4259's hold_platter arms turned
                   # 0.58 rad between two frames; of the line's length, a limb folded with its goal near
                   # its root swivelled by a push over its short line: 0.75-0.87 rad a frame)
CORE = 0.5         # share of the two radii's sum, closest axis to axis, inside which a push fades out
SWIVEL_MAX = 0.3   # most a limb swivels in one round of ``resolve``, rad
EXIT_FULL = 0.25   # an exit side weaker than this (share of a unit) leans a settled goal proportionally less
SETTLE_CORE = 1.0   # share of a proxy's radius about the point where a settled goal has no way out: its
                    # move fades out over this (0.125: a hand goal swept through the chest swung the arm
                    # round it 1.7 rad in a step of 0.3% of the height; 1.0: 0.37)
SETTLE_LEAN = 0.4   # share of a proxy's radius a settled goal leans toward its exit side (so a goal at the
                    # middle of a body is as far from that point as SETTLE_CORE fades, and is settled out)


@njit(cache=True, _nrt=False)
def _v3(a, i):
    return (a[i, 0], a[i, 1], a[i, 2])


@njit(cache=True, _nrt=False)
def _set3(a, i, v):
    a[i, 0] = v[0]
    a[i, 1] = v[1]
    a[i, 2] = v[2]


@njit(cache=True, _nrt=False)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True, _nrt=False)
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True, _nrt=False)
def _scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@njit(cache=True, _nrt=False)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, _nrt=False)
def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, _nrt=False)
def _rot(q, v):
    """Rotate v by the unit quaternion q = (w, x, y, z)."""
    w = q[0]
    u = (q[1], q[2], q[3])
    t = _scale(_cross(u, v), 2.0)
    return _add(_add(v, _scale(t, w)), _cross(u, t))


@njit(cache=True, _nrt=False)
def _between(u, v):
    """Shortest-arc rotation taking u to v (the solver's ``qbetween``, same singular axis)."""
    nu = math.sqrt(_dot(u, u))
    nv = math.sqrt(_dot(v, v))
    if nu < EPS or nv < EPS:
        return (1.0, 0.0, 0.0, 0.0)
    a = _scale(u, 1.0 / nu)
    b = _scale(v, 1.0 / nv)
    d = _dot(a, b)
    if d < -1.0 + 1e-12:
        axis = _cross(a, (1.0, 0.0, 0.0))
        if _dot(axis, axis) < 1e-12:
            axis = _cross(a, (0.0, 1.0, 0.0))
        n = math.sqrt(_dot(axis, axis))
        return (0.0, axis[0] / n, axis[1] / n, axis[2] / n)
    c = _cross(a, b)
    q = (1.0 + d, c[0], c[1], c[2])
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@njit(cache=True, _nrt=False)
def _clamp01(x):
    return min(max(x, 0.0), 1.0)


@njit(cache=True, _nrt=False)
def _closest_params(p1, q1, p2, q2):
    """Parameters (s, t) of the closest points of segments p1q1 and p2q2 (Ericson,
    Real-Time Collision Detection 5.1.9), made continuous where the segments turn
    parallel: there the closest pair is not unique and the textbook answer jumps from
    one end to the other, so below 6 degrees the parameter fades to the middle of the
    segments' overlap (the pushes stay smooth as two forearms or palms line up)."""
    d1 = _sub(q1, p1)
    d2 = _sub(q2, p2)
    r = _sub(p1, p2)
    a = _dot(d1, d1)
    e = _dot(d2, d2)
    f = _dot(d2, r)
    if a <= EPS and e <= EPS:
        return 0.0, 0.0
    if a <= EPS:
        return 0.0, _clamp01(f / e)
    c = _dot(d1, r)
    if e <= EPS:
        return _clamp01(-c / a), 0.0
    b = _dot(d1, d2)
    denom = a * e - b * b
    # middle of the overlap of segment 2 projected on segment 1
    s0 = _clamp01(-c / a)
    s1 = _clamp01((b - c) / a)
    s_mid = 0.5 * (s0 + s1)
    sin2 = denom / (a * e)
    if sin2 > 1e-12:
        s = _clamp01((b * f - c * e) / denom)
    else:
        s = s_mid
    if sin2 < 0.01:
        x = sin2 / 0.01
        k = x * x * (3.0 - 2.0 * x)
        s = s_mid + k * (s - s_mid)
    # t of the point of segment 2 closest to s, then s again from that t (always, not
    # only where t was clamped as in the textbook: where s is exact this changes
    # nothing, and it keeps s continuous as t reaches an end and as the fade turns off)
    t = _clamp01((b * s + f) / e)
    s = _clamp01((b * t - c) / a)
    return s, t


@njit(cache=True, _nrt=False)
def _qmul(a, b):
    return (a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])


@njit(cache=True, _nrt=False)
def _q4(a, i):
    return (a[i, 0], a[i, 1], a[i, 2], a[i, 3])


@njit(cache=True, _nrt=False)
def _nlerp(a, b, t):
    if a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0:
        b = (-b[0], -b[1], -b[2], -b[3])
    q = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]), a[3] + t * (b[3] - a[3]))
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n < EPS:
        return a
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@njit(cache=True, _nrt=False)
def closest_params(p1, q1, p2, q2):
    """``_closest_params`` as a plain kernel (for the plan builder and tests)."""
    return _closest_params(p1, q1, p2, q2)


@njit(cache=True, _nrt=False, inline="always")
def _update(P, cl_i, cl_f, k, work, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot):
    """World ends of proxy k's capsule into its two work rows. A fixed proxy rides its
    carrier; a mover rides its bone's body as the limb rebuild will pose it: the rest
    rotation swung onto the posed bone, turned toward the body's rotation goal by its
    weight (a hand held by a rotation goal hangs at its wrist as the goal says)."""
    h = NI_HEAD + NI_PROX * k
    s = cl_i[h]
    i = cl_i[h + 1]
    f = NF_PROX * k
    la = (cl_f[f], cl_f[f + 1], cl_f[f + 2])
    lb = (cl_f[f + 3], cl_f[f + 4], cl_f[f + 5])
    if i < 0:
        ps = _v3(out_pos, s)
        rs = _q4(out_rot, s)
        a = _add(ps, _rot(rs, la))
        b = _add(ps, _rot(rs, lb))
        _set3(work, W * k, a)
        _set3(work, W * k + 1, b)
        _set3(work, W * k + 2, _scale(_add(a, b), 0.5))
        return
    c = cl_i[h + 2]
    pi = _v3(lp_pos, i)
    sw = _between(_sub(_v3(lp_rest, c), _v3(lp_rest, i)), _sub(_v3(lp_pos, c), pi))
    b = P.lp_body[i]
    wr = min(max(goal_rot_w[b], 0.0), 1.0)
    if wr > 0.0:
        rot = _nlerp(_qmul(sw, _qmul(_q4(out_rot, s), _q4(P.lp_rot_local, i))), _q4(goal_rot, b), wr)
        a = _add(pi, _rot(rot, la))
        bb = _add(pi, _rot(rot, lb))
    else:  # the rest-posed offsets were turned once (``_prepare``)
        a = _add(pi, _rot(sw, _v3(work, W * k + 3)))
        bb = _add(pi, _rot(sw, _v3(work, W * k + 4)))
    _set3(work, W * k, a)
    _set3(work, W * k + 1, bb)
    _set3(work, W * k + 2, _scale(_add(a, bb), 0.5))


@njit(cache=True, _nrt=False, inline="always")
def _prepare(P, cl_i, cl_f, k, work, out_rot):
    """A mover's capsule ends relative to its pivot in the rest pose carried by its attach
    body: fixed during the limb phase, so turned once per solve."""
    h = NI_HEAD + NI_PROX * k
    s = cl_i[h]
    i = cl_i[h + 1]
    f = NF_PROX * k
    rest = _qmul(_q4(out_rot, s), _q4(P.lp_rot_local, i))
    _set3(work, W * k + 3, _rot(rest, (cl_f[f], cl_f[f + 1], cl_f[f + 2])))
    _set3(work, W * k + 4, _rot(rest, (cl_f[f + 3], cl_f[f + 4], cl_f[f + 5])))


@njit(cache=True, _nrt=False, inline="always")
def _bone_weight(lp_pos, i, c, q):
    """Share of a push at point q taken by the bone's direction particle (the pivot takes
    the rest): where q projects on the bone, clamped to it."""
    pi = _v3(lp_pos, i)
    d = _sub(_v3(lp_pos, c), pi)
    dd = _dot(d, d)
    if dd < EPS:
        return 0.5
    return _clamp01(_dot(_sub(q, pi), d) / dd)


@njit(cache=True, _nrt=False, inline="always")
def _rigid_end(P, c):
    """Whether direction particle c is the tip of a chain's end body (a hand, a foot, a
    claw) whose pivot is not the limb's root: the push moves such a body whole, its tip
    following its pivot, so contacts translate it and never turn it (nothing but the
    push would turn it back, and a hand spun by every contact it slides along jerks)."""
    return P.lp_mode[c] == 3 and P.lp_parent[P.lp_parent[c]] >= 0


@njit(cache=True, _nrt=False, inline="always")
def _nudge(delta, count, i, n, m):
    """Add a push of length m along n to particle i, weighted by its length (see
    ``_push_pairs``)."""
    w = abs(m)
    delta[i, 0] += w * m * n[0]
    delta[i, 1] += w * m * n[1]
    delta[i, 2] += w * m * n[2]
    count[i, 0] += w



@njit(cache=True, _nrt=False, inline="always")
def _side_weights(P, lp_body, lp_parent, goal_rot_w, lp_pos, i, c, q):
    """(pivot, tip) shares of a push on one side of a contact: a chain's end body moves
    whole at its pivot (``_rigid_end``); any other bone splits it by where along the bone
    the contact lies, turning toward its tip as far as a rotation goal holds the body."""
    if _rigid_end(P, c):
        return 1.0, 0.0
    wr = min(max(goal_rot_w[lp_body[i]], 0.0), 1.0)
    u = _bone_weight(lp_pos, i, c, q)
    v = (0.0 if lp_parent[i] < 0 else 1.0) * ((1.0 - wr) * (1.0 - u) + wr)
    return v, (1.0 - wr) * u + wr

@njit(cache=True, _nrt=False, inline="always")
def _held(lp_inv, i, c, v, u, rigid):
    """(pivot, tip) shares of a push with the particles pinned by goals held: a pinned
    particle's share is dropped (the other end of the bone takes the push alone, turning
    the bone about the pin); a chain's end body moved whole stays put when either end is
    pinned."""
    pin_i = lp_inv[i] <= 0.0
    pin_c = lp_inv[c] <= 0.0
    if rigid and (pin_i or pin_c):
        return 0.0, 0.0
    return (0.0 if pin_i else v), (0.0 if pin_c else u)


@njit(cache=True, _nrt=False, forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _push_pairs(P, cl_i, cl_f, work, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot, lp_inv, hold):
    """One pass over the pairs: each overlapping deeper than at rest pushes its movers'
    particles apart along the contact normal. The pushes are averaged per particle and
    applied after the pass (Jacobi), so the result does not depend on the order of the pairs: a creature's
    left and right stay mirror images. With ``hold`` 1 (the pushes inside the limb
    iterations, ``push_round``) a particle pinned by a goal (``lp_inv`` 0) takes no share:
    its bone turns about it, so an elbow goes round the chest while the hand stays on its
    goal. With ``hold`` 2 (``resolve``, after the iterations) the same, and a limb whose
    end is held turns about the line to that end instead of being moved off it
    (``_swivel_runs``). Returns how many pairs pushed."""
    nprox = cl_i[0]
    nmove = cl_i[1]
    npair = cl_i[2]
    lp_parent = P.lp_parent
    lp_body = P.lp_body
    pair0 = NI_HEAD + NI_PROX * nprox
    allow0 = NF_PROX * nprox
    for k in range(nmove):
        _update(P, cl_i, cl_f, k, work, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot)
    nlp = lp_pos.shape[0]
    delta = work[W * nprox:W * nprox + nlp]
    count = work[W * nprox + nlp:W * nprox + 2 * nlp]
    pushed = 0
    for p in range(npair):
        ka = cl_i[pair0 + 2 * p]
        kb = cl_i[pair0 + 2 * p + 1]
        fa = NF_PROX * ka
        fb = NF_PROX * kb
        # bounding spheres first (most pairs are far apart)
        dx = work[W * ka + 2, 0] - work[W * kb + 2, 0]
        dy = work[W * ka + 2, 1] - work[W * kb + 2, 1]
        dz = work[W * ka + 2, 2] - work[W * kb + 2, 2]
        if dx * dx + dy * dy + dz * dz >= cl_f[allow0 + 2 * p + 1]:
            continue
        allowed = cl_f[allow0 + 2 * p]
        a0 = _v3(work, W * ka)
        a1 = _v3(work, W * ka + 1)
        b0 = _v3(work, W * kb)
        b1 = _v3(work, W * kb + 1)
        s, t = _closest_params(a0, a1, b0, b1)
        qa = _add(a0, _scale(_sub(a1, a0), s))
        qb = _add(b0, _scale(_sub(b1, b0), t))
        d = _sub(qa, qb)
        dist = math.sqrt(_dot(d, d))
        pen = cl_f[fa + 6] + cl_f[fb + 6] - dist - allowed
        if pen <= 0.0:
            continue
        # skin band: the push ramps in over the first SKIN of the thinner radius (C1 in
        # the depth, so a contact switching on does not turn a body abruptly), then
        # takes all but half the band out
        band = SKIN * min(cl_f[fa + 6], cl_f[fb + 6])
        if pen < band:
            pen = pen * pen / (2.0 * band)
        else:
            pen -= 0.5 * band
        # deep inside, where the two axes come close to crossing, the push fades out: its
        # direction (closest point to closest point) turns over as the axes cross, and a
        # full push there snapped a limb through the other body in one frame (so two
        # crossing axes, with no direction between them, are not pushed at all)
        if dist <= 1e-9:
            continue
        core = CORE * (cl_f[fa + 6] + cl_f[fb + 6])
        if dist < core:
            x = dist / core
            pen *= x * x * (3.0 - 2.0 * x)
        n = _scale(d, 1.0 / dist)
        ha = NI_HEAD + NI_PROX * ka
        hb = NI_HEAD + NI_PROX * kb
        ia, ca = cl_i[ha + 1], cl_i[ha + 2]
        ib, cb = cl_i[hb + 1], cl_i[hb + 2]
        # weights of the pivot (1 - u) and direction (u) particles; a body held by a
        # rotation goal is moved whole (both particles alike) as far as the goal holds it;
        # a chain's end body is pushed at its pivot and its tip follows (``_rigid_end``)
        ua = 0.0
        ub = 0.0
        va = 0.0
        vb = 0.0
        if ia >= 0:
            va, ua = _side_weights(P, lp_body, lp_parent, goal_rot_w, lp_pos, ia, ca, qa)
        if ib >= 0:
            vb, ub = _side_weights(P, lp_body, lp_parent, goal_rot_w, lp_pos, ib, cb, qb)
        if cl_f[fa + 8] != cl_f[fb + 8]:
            # a neck or head (yield 0) against a limb that yields: the limb moves alone,
            # the head stays where its animation aims it (the twoheaded's and random
            # creatures' necks were turned by the arm reaching past them to the mouth)
            va *= cl_f[fa + 8]
            ua *= cl_f[fa + 8]
            vb *= cl_f[fb + 8]
            ub *= cl_f[fb + 8]
        if hold:
            # pinned particles take no share. A contact only they could answer (two
            # clapping hands, a hand held against the torso) stays as the goals put it:
            # ``settle_goals`` has moved the goals a capsule apart, and moving a held
            # hand here, then giving its arm its length back from the shoulder, turned
            # arms over (main grid with self-collision on: 25 flip cells without it,
            # 44-46 with it for every such contact or only the limb-limb ones)
            if ia >= 0:
                va, ua = _held(lp_inv, ia, ca, va, ua, _rigid_end(P, ca))
            if ib >= 0:
                vb, ub = _held(lp_inv, ib, cb, vb, ub, _rigid_end(P, cb))
        denom = va * va + ua * ua + vb * vb + ub * ub
        if denom <= 0.0:
            continue
        lam = pen / max(denom, MIN_DENOM)
        if ia >= 0:
            _nudge(delta, count, ia, n, lam * va)
            _nudge(delta, count, ca, n, lam * ua)
        if ib >= 0:
            _nudge(delta, count, ib, n, -lam * vb)
            _nudge(delta, count, cb, n, -lam * ub)

        pushed += 1
    if pushed:
        # a particle pushed by several contacts moves by their mean weighted by their
        # lengths, not their sum (two contacts pushing a hand the same way would move it
        # twice as far); weighted by length, a contact ramping in through its skin band
        # takes its share gradually instead of halving the others' at once
        for i in range(nlp):
            k = count[i, 0]
            if k > 0.0:
                for j in range(3):
                    delta[i, j] /= k
                count[i, 0] = 0.0
        if hold == 2:
            _swivel_runs(lp_parent, lp_pos, lp_inv, delta, count)
        for i in range(nlp):
            if hold and lp_inv[i] <= 0.0:
                continue
            if hold == 2 and count[i, 2] > 0.0:
                continue          # turned with its run (``_swivel_runs``)
            src = P.lp_parent[i] if _rigid_end(P, i) else i
            for j in range(3):
                lp_pos[i, j] += delta[src, j]
        for i in range(nlp):
            for j in range(3):
                delta[i, j] = 0.0
    return pushed


@njit(cache=True, _nrt=False, inline="always")
def _swivel_runs(lp_parent, lp_pos, lp_inv, delta, count):
    """The pushes on a limb whose end is held by a goal, taken as a turn of the limb
    about the line from where it hangs to its held end (the swivel of an elbow about the
    shoulder-wrist line): every bone keeps its length and the held end stays on its goal,
    so an elbow tucked into the chest swings out instead of the hand being pushed off
    the goal and the arm projected back to length from the shoulder (which moved the hand
    by up to the push: the grid's reach_miss with self-collision on).

    A *run* is a maximal chain of free particles (``lp_inv`` > 0) each with one child,
    ending on a pinned one (``e``); it hangs from ``a``, the parent of its top (a limb
    root, a pinned particle, or a fork). The run turns rigidly about the line a-e by the
    angle that best carries its pushed particles along their pushes (least squares,
    linear in the angle; the rounds of ``resolve`` iterate it). What the turn cannot
    give (a push along the line, or toward or away from it) is dropped: the goal wins.
    Marks the run's particles in ``count[:, 2]`` so the pass does not translate them;
    ``count[:, 1]`` holds each particle's number of children (``begin``)."""
    nlp = lp_pos.shape[0]
    for i in range(nlp):
        count[i, 2] = 0.0
    for e in range(nlp):
        if lp_inv[e] > 0.0:
            continue
        p = lp_parent[e]
        if p < 0 or lp_inv[p] <= 0.0 or count[p, 1] != 1.0:
            continue
        top = p
        while True:
            q = lp_parent[top]
            if q < 0 or lp_inv[q] <= 0.0 or count[q, 1] != 1.0:
                break
            top = q
        a = lp_parent[top]
        if a < 0:
            continue
        pa = _v3(lp_pos, a)
        ax = _sub(_v3(lp_pos, e), pa)
        la = math.sqrt(_dot(ax, ax))
        num = 0.0
        den = 0.0
        d = _sub(_v3(lp_pos, e), _v3(lp_pos, p))
        length = math.sqrt(_dot(d, d))    # the limb's length from a to e along its bones
        j = p
        while True:
            count[j, 2] = 1.0
            d = _sub(_v3(lp_pos, j), _v3(lp_pos, lp_parent[j]))
            length += math.sqrt(_dot(d, d))
            if la > EPS:
                r = _sub(_v3(lp_pos, j), pa)
                rp = _sub(r, _scale(ax, _dot(r, ax) / (la * la)))
                t = _scale(_cross(ax, rp), 1.0 / la)
                num += _dot(t, _v3(delta, j))
                den += _dot(rp, rp)
            if j == top:
                break
            j = lp_parent[j]
        if la <= EPS:
            continue
        # A straight limb lies on its line and cannot turn out of anything: the
        # denominator keeps SWIVEL_REG of the line's length squared, so a run near the
        # line turns little instead of spinning by a push / (its distance from the line),
        # and one round turns at most SWIVEL_MAX (smoothly saturated)
        theta = num / (den + SWIVEL_REG * SWIVEL_REG * length * length)
        theta = SWIVEL_MAX * math.tanh(theta / SWIVEL_MAX)
        h = 0.5 * theta
        sh = math.sin(h) / la
        q = (math.cos(h), ax[0] * sh, ax[1] * sh, ax[2] * sh)
        j = p
        while True:
            _set3(lp_pos, j, _add(pa, _rot(q, _sub(_v3(lp_pos, j), pa))))
            if j == top:
                break
            j = lp_parent[j]


@njit(cache=True, _nrt=False, inline="always")
def begin(P, scratch, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot):
    """Once per solve, before the limb iterations: the movers' rest offsets, the fixed
    proxies (the spine is posed and stays put in the limb phase) and each limb particle's
    number of children (``_swivel_runs`` reads it from ``count[:, 1]``)."""
    cl_i = P.cl_i
    cl_f = P.cl_f
    nprox = cl_i[0]
    nmove = cl_i[1]
    work = _work(P, scratch, lp_pos)
    for k in range(nmove):
        _prepare(P, cl_i, cl_f, k, work, out_rot)
    for k in range(nmove, nprox):   # fixed proxies: posed once
        _update(P, cl_i, cl_f, k, work, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot)
    nlp = lp_pos.shape[0]
    count = work[W * nprox + nlp:W * nprox + 2 * nlp]
    for i in range(nlp):
        count[i, 1] = 0.0
    for i in range(nlp):
        if P.lp_parent[i] >= 0:
            count[P.lp_parent[i], 1] += 1.0


@njit(cache=True, _nrt=False, inline="always")
def _work(P, scratch, lp_pos):
    w0 = P.cl_i[3] + P.b_joint_offset.shape[0]   # after the settled goals (``settle_goals``)
    return scratch[w0:w0 + W * P.cl_i[0] + 2 * lp_pos.shape[0]]


@njit(cache=True, _nrt=False, inline="always")
def push_round(P, scratch, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot, lp_inv):
    """One pass of pushes inside the limb iterations (after ``begin``), the goal-pinned
    particles held: the constraint sweeps that follow carry the push along the limb and
    keep the goals met, so a limb is routed round the bodies in its way instead of
    being pushed off its goal at the end."""
    work = _work(P, scratch, lp_pos)
    return _push_pairs(P, P.cl_i, P.cl_f, work, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot, lp_inv,
                       1 * (lp_pos.shape[0] >= 0))   # 1, but not a literal: one compile of _push_pairs


@njit(cache=True, _nrt=False, forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def resolve(P, scratch, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot, lp_inv):
    """The limb phase's self-collision step (after its constraint iterations, before its
    rebuild; ``begin`` has run): ``rounds`` times update the proxies, push overlapping
    pairs apart, and give the limbs their lengths back by outward projection (as the
    rebuild does). Returns how many pair pushes there were (0: nothing touched)."""
    cl_i = P.cl_i
    cl_f = P.cl_f
    work = _work(P, scratch, lp_pos)
    nlp = P.lp_body.shape[0]
    total = 0
    for _round in range(cl_i[4]):
        pushed = _push_pairs(P, cl_i, cl_f, work, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot, lp_inv,
                             2 * (lp_pos.shape[0] >= 0))   # 2, not a literal (see push_round)
        if pushed == 0:
            break
        total += pushed
        for i in range(nlp):
            c = P.lp_con[i]
            if c < 0:
                continue
            par = P.lp_parent[i]
            d = _sub(_v3(lp_pos, i), _v3(lp_pos, par))
            L = math.sqrt(_dot(d, d))
            if L < EPS:
                continue
            Lc = min(max(L, P.lc_plo[c] * P.lc_len[c]), P.lc_phi[c] * P.lc_len[c])
            if Lc != L:
                _set3(lp_pos, i, _add(_v3(lp_pos, par), _scale(d, Lc / L)))
    return total


@njit(cache=True, _nrt=False)
def _goal_push(pen, band):
    """How far a goal ``pen`` inside a surface (negative: outside) is moved out: 0 beyond
    ``band`` outside, all of it beyond ``band`` inside, a quadratic between (C1: a goal
    crossing the surface moves smoothly, and a deep goal lands on the surface). A goal
    on the surface, as a rest pose's can be, moves out by a quarter band: the clearance
    is worth it (a band kept inside the surface, stop 30: the grid's reach_miss failures
    with self-collision on 149 -> 163, flips 48 -> 50)."""
    if pen <= -band:
        return 0.0
    if pen >= band:
        return pen
    x = pen + band
    return x * x / (4.0 * band)


@njit(cache=True, _nrt=False, inline="always")
def _limb_root_rest(P, gi, out_pos, out_rot):
    """Rest place of goal gi's limb root carried by its posed attach body."""
    i = P.goal_lproot[gi]
    if i < 0:
        return _v3(out_pos, 0)
    s = P.lp_attach[i]
    return _add(_v3(out_pos, s), _rot(_q4(out_rot, s), _v3(P.lp_local, i)))


@njit(cache=True, _nrt=False, inline="always")
def _goal_rest(P, gi, out_pos, out_rot):
    """Rest place of goal gi's particle carried by its posed attach body."""
    i = P.goal_lp[gi]
    s = P.lp_attach[i]
    return _add(_v3(out_pos, s), _rot(_q4(out_rot, s), _v3(P.lp_local, i)))


@njit(cache=True, _nrt=False)
def _perp(v, ax, aa):
    """v without its component along ax (aa = |ax|^2)."""
    if aa <= EPS:
        return v
    return _sub(v, _scale(ax, _dot(v, ax) / aa))


@njit(cache=True, _nrt=False, inline="always")
def _exit_side(P, gi, q, ax, aa, out_pos, out_rot):
    """Direction a goal on a fixed proxy's axis (at q, axis ax) leaves by (unit, or
    shorter where it is weakly defined; see the end): the
    creature's forward (the root's +X) across the axis, where the axis is not itself
    forward, else the side of the goal's limb root. It depends on the posed carrier only,
    never on the goal, so the settled goal is continuous in the goal."""
    fwd = _perp(_rot(_q4(out_rot, 0), (1.0, 0.0, 0.0)), ax, aa)
    nf = math.sqrt(_dot(fwd, fwd))
    side = _perp(_sub(_limb_root_rest(P, gi, out_pos, out_rot), q), ax, aa)
    ns = math.sqrt(_dot(side, side))
    u = _scale(fwd, nf)   # weight forward by how well it crosses the axis
    if ns > EPS:
        u = _add(u, _scale(side, (1.0 - nf) / ns))
    # unit where it is well defined, shrinking to nothing where neither direction crosses
    # the axis (normalized there, a tiny u would turn the lean over as the limb root's
    # side passes the axis); ``settle_goals`` fades the push out where the goal's offset
    # and this lean cancel
    nu = math.sqrt(_dot(u, u))
    return _scale(u, 1.0 / max(nu, EXIT_FULL))


@njit(cache=True, _nrt=False, inline="always")
def settle_goals(P, scratch, goal_pos, goal_pos_w, goal_joint, out_pos, out_rot):
    """Goals made consistent with the creature's own bodies, before the limb phase (issue
    16): a position goal for a limb's goal body that lies inside another body's proxy of
    the same creature (one the limb phase does not move: the torso, the head, a spine
    body; pairs as the kernel's, the rest pose's own overlap allowed) is moved out to
    that proxy's surface plus the goal body's own radius, and two limb goal bodies whose
    goals lie closer than their two radii (the hands of a clap) are moved apart, half
    each. The move is continuous in the goal (``_goal_push``'s band; a goal on a proxy's
    axis leaves toward its limb's root). Writes the goals the limb phase pins to into
    the first ``nbody`` rows of the self-collision work rows and returns them; the joint
    targets (``goal_joint``) move with their goals. With self-collision off the rows are
    the goals unchanged. ``engine.validation.goals`` measures ``reach_miss`` against the
    same settled goals (``engine.ik.selfcollision.settled_goals``)."""
    cl_i = P.cl_i
    cl_f = P.cl_f
    nb = P.b_joint_offset.shape[0]
    w0 = cl_i[3]
    moved = scratch[w0:w0 + nb]
    ngoal = P.goal_body.shape[0]
    for gi in range(ngoal):
        _set3(moved, P.goal_body[gi], _v3(goal_pos, P.goal_body[gi]))
    if cl_i[0] == 0:
        return moved
    nprox = cl_i[0]
    allow0 = NF_PROX * nprox
    gs = cl_i[5]
    for _it in range(2):
        # against the fixed proxies, each goal alone (mirror images stay mirrored)
        for gi in range(ngoal):
            b = P.goal_body[gi]
            if P.goal_lp[gi] < 0 or goal_pos_w[b] <= 0.0:
                continue
            rg = cl_f[NF_PROX * cl_i[gs + 3 * gi] + 6]
            g = _v3(moved, b)
            for e in range(cl_i[gs + 3 * gi + 1], cl_i[gs + 3 * gi + 1] + 3 * max(cl_i[gs + 3 * gi + 2], 0), 3):
                if cl_i[e + 2] >= 0:
                    continue
                p = cl_i[e]
                k = cl_i[e + 1]
                f = NF_PROX * k
                s = cl_i[NI_HEAD + NI_PROX * k]
                ps = _v3(out_pos, s)
                rs = _q4(out_rot, s)
                a0 = _add(ps, _rot(rs, (cl_f[f], cl_f[f + 1], cl_f[f + 2])))
                a1 = _add(ps, _rot(rs, (cl_f[f + 3], cl_f[f + 4], cl_f[f + 5])))
                rk = cl_f[f + 6]
                ax = _sub(a1, a0)
                aa = _dot(ax, ax)
                t = _clamp01(_dot(_sub(g, a0), ax) / aa) if aa > EPS else 0.5
                q = _add(a0, _scale(ax, t))
                d = _sub(g, q)
                dist = math.sqrt(_dot(d, d))
                reach = rk + rg - cl_f[allow0 + 2 * p]
                band = 0.5 * min(rk, rg)
                m = _goal_push(reach - dist, band)
                if m <= 0.0:
                    continue
                # out from the axis point to distance dist + m, along the offset leaned
                # toward the exit side by SETTLE_LEAN of the radius (defined on the axis itself)
                # (the lean grows with the move from 0: none at the band's outer edge)
                lean = SETTLE_LEAN * rk * min(m / band, 1.0)
                n = _add(d, _scale(_exit_side(P, gi, q, ax, aa, out_pos, out_rot), lean))
                nn = math.sqrt(_dot(n, n))
                # n vanishes where the offset from the axis cancels the lean (a goal a lean
                # from the axis on the side opposite the exit): no direction out is right
                # there, so the move fades to nothing within SETTLE_CORE of the proxy's
                # radius of that point instead of turning over as the goal passes it. The
                # move itself fades (goal to its place out), not only its length: a goal
                # set at its own distance along n turned over with n (a hand goal swept
                # through the humanoid's chest jumped 10 cm for 0.4 mm, the arm 1.7 rad)
                if nn < EPS:
                    continue
                out = _add(q, _scale(n, (dist + m) / nn))
                core = SETTLE_CORE * rk
                if nn < core:
                    x = nn / core
                    out = _add(g, _scale(_sub(out, g), x * x * (3.0 - 2.0 * x)))
                g = out
            _set3(moved, b, g)
        # limb goal bodies apart (each pair once: the lower goal index does it; never a
        # planted foot's, entries -1: ``selfcollision._planted``)
        for gi in range(ngoal):
            b = P.goal_body[gi]
            if P.goal_lp[gi] < 0 or goal_pos_w[b] <= 0.0:
                continue
            rg = cl_f[NF_PROX * cl_i[gs + 3 * gi] + 6]
            for e in range(cl_i[gs + 3 * gi + 1], cl_i[gs + 3 * gi + 1] + 3 * max(cl_i[gs + 3 * gi + 2], 0), 3):
                gj = cl_i[e + 2]
                if gj <= gi or cl_i[gs + 3 * gj + 2] < 0:
                    continue
                bj = P.goal_body[gj]
                if goal_pos_w[bj] <= 0.0:
                    continue
                p = cl_i[e]
                rj = cl_f[NF_PROX * cl_i[e + 1] + 6]
                gA = _v3(moved, b)
                gB = _v3(moved, bj)
                d = _sub(gA, gB)
                reach = rg + rj - cl_f[allow0 + 2 * p]
                if reach <= 0.0:
                    continue
                band = 0.5 * min(rg, rj)
                u = _sub(_goal_rest(P, gi, out_pos, out_rot), _goal_rest(P, gj, out_pos, out_rot))
                nu = math.sqrt(_dot(u, u))
                if nu > EPS:
                    # Apart along the line between the two bodies' rest places (carried by
                    # the posed spine), each goal kept on the side it has at rest: goals
                    # that cross (a hug's hands passing each other) stop at each other
                    # instead of jumping to the other side when their difference turns
                    # over. The separation needed along that line falls from ``reach``
                    # (goals level) to 0 (goals ``reach`` apart across it) as a parabola
                    # (the sphere's circle has an infinite slope at its edge: the goals
                    # would slide sideways abruptly); crossed goals are pushed back by
                    # (1 - x2) of their overlap along the line, which is 0 where they are
                    # apart across it (an insect's feet cross their legs' roots at rest).
                    uh = _scale(u, 1.0 / nu)
                    sep = _dot(d, uh)
                    across = _sub(d, _scale(uh, sep))
                    x2 = min(_dot(across, across) / (reach * reach), 1.0)
                    m = _goal_push((1.0 - x2) * (reach - min(sep, 0.0)) - max(sep, 0.0), band)
                    if m <= 0.0:
                        continue
                    _set3(moved, b, _add(gA, _scale(uh, 0.5 * m)))
                    _set3(moved, bj, _sub(gB, _scale(uh, 0.5 * m)))
                    continue
                # two goals of one limb (no side to keep): apart along their difference
                dist = math.sqrt(_dot(d, d))
                m = _goal_push(reach - dist, band)
                if m <= 0.0 or dist < EPS:
                    continue
                h = 0.5 * m / dist
                _set3(moved, b, _add(gA, _scale(d, h)))
                _set3(moved, bj, _sub(gB, _scale(d, h)))
    for gi in range(ngoal):
        b = P.goal_body[gi]
        if P.goal_lp[gi] < 0 or goal_pos_w[b] <= 0.0:
            continue
        dlt = _sub(_v3(moved, b), _v3(goal_pos, b))
        _set3(goal_joint, gi, _add(_v3(goal_joint, gi), dlt))
    return moved
