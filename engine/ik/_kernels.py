"""Numba kernels of the two-phase Particle IK solver (Hecker et al. 2008, section 4.3).

Everything here takes plain arrays and scalars. Small vectors and quaternions travel as
tuples (``(x, y, z)``, ``(w, x, y, z)``) so the per-solve path never touches the heap.
The plan arrives as flat blobs (``plan_i`` int32, ``plan_f`` float64 and the (k, 3) and
(k, 4) float64 blobs ``plan_f3``, ``plan_f4``) and is unpacked
into the ``PlanArrays`` NamedTuple of views inside the kernel: a Python call then costs
about a microsecond of dispatch instead of one type check per array.

The quaternion and spline helpers are private tuple-valued twins of what engine.mathx
offers on arrays; the solver keeps its own so its inner loops stay in registers.

Reference counting is off (``_nrt=False``) for every kernel here: nothing allocates and
every view lives inside the call, while numba's counts on the plan's views (each read of
``P.field``, each inlined stage taking ``P``) were a third of a solve. Consequence, a
rule: these kernels call only each other (never a kernel compiled with counting, which
would count arrays that carry no owner), and never return an array.
"""

from __future__ import annotations

import math
from collections import namedtuple

from numba import njit
from numba.core import cgutils, types
from numba.extending import intrinsic

from engine.ik import _collide

# -- the plan layout ------------------------------------------------------------------
# (name, width): width 1 fields are 1-D, 3 and 4 are (n, 3) / (n, 4). The order here is
# the order of the blob and of ``PlanArrays``; ``_unpack`` below follows it by hand and a
# test checks the two agree.
INT_FIELDS = (
    "b_parent",            # (nbody,) body parents (copy of the creature's)
    "sp_kind",             # (nsp,) spine-phase particle kind: 0 root, 1 spine, 2 goal, 3 anchor
    "sp_body",             # (nsp,) body the particle belongs to
    "sc_a", "sc_b",        # (nsc,) spine-phase constraint endpoints, leaves inward
    "sc_kind",             # (nsc,) 0 spine, 1 simplified limb, 2 delegated goal, 3 anchor
    "ch_particle",         # (nch,) spine particles, outward per side, sides concatenated
    "ch_prev",             # (nch,) rootward neighbour particle (0 = the root particle)
    "ch_prev_k",           # (nch,) chain slot of that neighbour, -1 for the root
    "ch_next",             # (nch,) outward neighbour particle, -1 at the end of the side
    "ch_con",              # (nch,) constraint to the rootward neighbour
    "ch_seg",              # (nch,) spine spline segment that ends at this particle
    "bp_c1", "bp_c2",      # (nbp,) neighbouring spine constraints watched for buckling
    "seg_a", "seg_b",      # (nseg,) particles at the two ends of each spine spline
    "seg_body_adr", "seg_body_num",  # (nseg,) interior spine bodies of each spline
    "segbody_body",        # (nsb,) interior spine bodies
    "dg_body",             # (ndg,) bodies whose goals are delegated to their spine parent
    "dg_goal",             # (ndg,) their goal slot
    "dg_particle",         # (ndg,) their goal particle in the spine phase
    "dg_spine_particle",   # (ndg,) the spine particle they delegate to
    "rg_body",             # (nrg,) bodies placed rigidly on their parent (delegated ones)
    "lp_body",             # (nlp,) limb-phase particle: the body whose joint it sits at
    "lp_parent",           # (nlp,) parent particle, -1 at a limb root (fixed to the spine)
    "lp_con",              # (nlp,) constraint to the parent particle, -1 at a limb root
    "lp_attach",           # (nlp,) spine body the limb hangs off
    "lp_mode",             # (nlp,) orientation rebuild: 0 one axis, 1 two axes, 2 rigid on parent,
                           # 3 tip (no body), 4 carried by the parent and swung at its tip
    "lp_c1", "lp_c2",      # (nlp,) child particles giving the axes (-1 if unused)
    "lp_goal",             # (nlp,) goal slot of the particle's body, -1 if none
    "lc_a", "lc_b",        # (nlc,) limb constraints, leaves inward
    "lc_goal",             # (nlc,) goal slot whose rotation weight softens it (a tip's brace), else -1
    "ag_pivot",            # (nag,) aim groups: pivot particle
    "ag_moved_adr", "ag_moved_num", "ag_goal_adr", "ag_goal_num",
    "ag_moved",            # particles an aim group moves
    "ag_goal",             # goal slots an aim group aims at
    "goal_body",           # (ngoal,) bodies with goals in this plan
    "goal_sp",             # (ngoal,) spine-phase particle the goal pins, -1 if none
    "goal_lp",             # (ngoal,) limb-phase particle the position goal pins (a tip or the joint), -1 if none
    "goal_lpj",            # (ngoal,) the goal body's joint particle when goal_lp is its tip, else -1
    "goal_lproot",         # (ngoal,) limb root particle of a limb goal (its reach is measured from there), -1
    "goal_limb_root",      # (ngoal,) limb root of a limb goal, 0 for a delegated one, -2 for a spine
                           # body's goal held at its origin (self-delegated), else -1
    "scratch_layout",      # (13,) first row of each scratch block (see ``_scratch_views``)
    "cl_i",                # self-collision proxies and pairs (engine/ik/_collide.py)
    "sp_prev",             # (nsp,) a spine particle's rootward neighbour, -1 for the root, goals, anchors
)
FLOAT_FIELDS = (
    ("b_rootrel_rot", 4), ("b_rootrel_pos", 3), ("b_rootrel_joint", 3),
    ("b_joint_offset", 3), ("b_local_rot", 4), ("b_local_pos", 3), ("b_local_joint", 3),
    ("sp_rest", 3),        # root-relative rest position of every spine-phase particle
    ("sc_len", 1),         # rest length, m
    ("sc_lo", 1), ("sc_hi", 1),      # free range as a fraction of the rest length
    ("sc_plo", 1), ("sc_phi", 1),    # projection range at reconstruction
    ("sc_inva", 1), ("sc_invb", 1),  # inverse mass of each endpoint
    ("sc_stiff", 1),       # share of the correction applied per sweep
    ("bp_sign1", 1),       # -1 when c1 runs the other way (the other side of the root)
    ("bp_rest_angle", 1),  # angle between the two constraints in the rest pose, rad
    ("ch_rest_tangent", 3),  # root-relative rest tangent at each chain particle
    ("seg_v0", 3), ("seg_a0", 3),    # spline tangent/acceleration at the start, start body's frame
    ("seg_v1", 3), ("seg_a1", 3),    # ... at the end, end body's frame
    ("seg_rest_chord", 1),
    ("seg_rest_twist", 4),           # transported frame at t=1 relative to the end body, at rest
    ("segbody_t", 1), ("segbody_off", 3), ("segbody_rot", 4),
    ("dg_chord", 3),       # delegated joint relative to the spine particle, spine body frame
    ("dg_rel_rot", 4),     # delegating body's rest rotation relative to the spine body
    ("lp_local", 3),       # rest joint in the attach body's rest frame
    ("lp_init_local", 3),  # the same with the bend hint for straight rest chains
    ("lp_rot_local", 4),   # rest rotation relative to the attach body
    ("lc_len", 1), ("lc_lo", 1), ("lc_hi", 1), ("lc_plo", 1), ("lc_phi", 1),
    ("lc_inva", 1), ("lc_invb", 1),
    ("goal_reach", 1),     # (ngoal,) reach of the goal particle from the limb root particle, m
    ("goal_reachj", 1),    # (ngoal,) reach of the goal body's joint particle (when tipped), m
    ("params", 1),         # see P_* below
    ("cl_f", 1),           # self-collision proxies and pairs (engine/ik/_collide.py)
    ("seg_rest_arc", 1),   # (nseg,) arc length of each rest spline on the reconstruction's chords, m
    ("segbody_share", 1),  # (nsegbody,) each interior body's share of its rest spline's arc
    ("ag_via", 3),         # (ngroup, 3) direction the aim turns a limb through, in its spine body's
                           # frame (zero: the shortest arc; see ``_limb_phase``)
    ("b_extent", 3),       # (nbody, 3) half extents of each body's box (centred on its origin, body frame), m
    ("b_floor", 1),        # (nbody,) lowest a box corner may go, over the ground: min(0, its rest lowest corner), m
    ("b_ground_r", 1),     # (nbody,) radius about the joint holding the whole box (|joint offset| + |extent|), m
    ("lp_ref_dir", 3),     # (nlp, 3) the rebuild's reference chord direction in the frame of the particle's
                           # parent body; zero: the rest chord carried by the spine (plan.py ``_rebuild_refs``)
    ("lp_ref_rot", 4),     # (nlp, 4) the body's rotation in that frame with its chord on lp_ref_dir
)
FLOAT_NAMES = tuple(n for n, _ in FLOAT_FIELDS)
NINT = len(INT_FIELDS)
PlanArrays = namedtuple("PlanArrays", INT_FIELDS + FLOAT_NAMES)

# Indices into ``params``.
P_SPINE_OUTER, P_SPINE_INNER, P_LIMB_OUTER, P_LIMB_INNER = 0, 1, 2, 3
P_SOFT_SLOPE, P_SOFT_BAND, P_SOFT_WIDTH = 4, 5, 6
P_BUCKLE_ON, P_BUCKLE_FULL, P_ANTI_BUCKLING, P_ROOT_INFLUENCE, P_SUBSTEPS = 7, 8, 9, 10, 11
P_SOFT_REACH, P_LIMB_STRETCH = 12, 13
P_GOAL_AIM, P_ROOT_PIN, P_GROUND = 14, 15, 16
P_CONTACT_ITERATE = 17
P_PULL_CAP = 18
NPARAM = 19

# Scratch blocks (rows of 3): sp_pos, sp_inv, lp_pos, lp_rest, lp_inv, goal_joint, ch_tan,
# state, dg_target, sp_acc, lg_target, lg_jtarget, segbody_tp.
NSCRATCH = 13

EPS = 1e-12
GROUND_BIAS = 0.5      # outward share of a free limb particle's ground lift (``_ground_lift``)
MOBILE = 0.25          # inverse-mass sum below which a length constraint is partly corrected (``relax_constraint``)


# -- small vector and quaternion algebra on tuples -------------------------------------
# These helpers are ordinary calls for numba and are inlined by LLVM, which inlines
# functions this small anyway: numba's own inlining (``inline="always"``) re-ran its
# front end and deep-copied the IR at each of their thousands of call sites, a quarter
# of the solver's compile time, for machine code as fast (measured: benchmarks/startup.py,
# benchmarks/ik.py). The constraint helpers below, with loops, and the small functions
# that take the plan ``P`` stay inlined by numba (a call passes ``P``'s hundred arrays
# field by field). The large stages (``_spine_phase``, ``_spine_reconstruct``,
# ``_limb_phase`` and its parts) are not: inlined by numba, ``solve_one`` took 190 s of
# CPU to compile, 125 of them in numba's inlining pass itself. They are compiled once
# each, marked ``forceinline`` so LLVM inlines them into their one caller (the machine
# code is as fast as before, poses bit-identical), and, like every kernel only other
# kernels call, without a Python wrapper (``no_cpython_wrapper``: unboxing a ``P`` from
# Python is code nobody runs). First IK solve with an empty cache: 205 -> 38 s of CPU.


@njit(cache=True, _nrt=False)
def v3(a, i):
    return (a[i, 0], a[i, 1], a[i, 2])


@njit(cache=True, _nrt=False)
def q4(a, i):
    return (a[i, 0], a[i, 1], a[i, 2], a[i, 3])


@njit(cache=True, _nrt=False)
def set3(a, i, v):
    a[i, 0] = v[0]
    a[i, 1] = v[1]
    a[i, 2] = v[2]


@njit(cache=True, _nrt=False)
def set4(a, i, q):
    a[i, 0] = q[0]
    a[i, 1] = q[1]
    a[i, 2] = q[2]
    a[i, 3] = q[3]


@njit(cache=True, _nrt=False)
def vadd(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True, _nrt=False)
def vsub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True, _nrt=False)
def vscale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@njit(cache=True, _nrt=False)
def vdot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, _nrt=False)
def vcross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, _nrt=False)
def vnorm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@njit(cache=True, _nrt=False)
def vlerp(a, b, t):
    return (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2]))


@njit(cache=True, _nrt=False)
def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(cache=True, _nrt=False)
def qconj(q):
    return (q[0], -q[1], -q[2], -q[3])


@njit(cache=True, _nrt=False)
def qrot(q, v):
    # v + 2w (u x v) + 2 u x (u x v), u the vector part
    u = (q[1], q[2], q[3])
    t = vscale(vcross(u, v), 2.0)
    return vadd(vadd(v, vscale(t, q[0])), vcross(u, t))


@njit(cache=True, _nrt=False)
def qnormalize(q):
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n < EPS:
        return (1.0, 0.0, 0.0, 0.0)
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


@njit(cache=True, _nrt=False)
def qaxis_angle(axis, angle):
    n = vnorm(axis)
    if n < EPS:
        return (1.0, 0.0, 0.0, 0.0)
    s = math.sin(0.5 * angle) / n
    return (math.cos(0.5 * angle), axis[0] * s, axis[1] * s, axis[2] * s)


@njit(cache=True, _nrt=False)
def qbetween(u, v):
    """Minimal-twist (shortest-arc) rotation taking direction u to direction v. For
    opposite directions the axis is the one perpendicular to u closest to the x axis,
    else the y axis, so the answer is defined everywhere (the paper's footnote 11: a
    path-independent solver must put its singularity somewhere)."""
    nu = vnorm(u)
    nv = vnorm(v)
    if nu < EPS or nv < EPS:
        return (1.0, 0.0, 0.0, 0.0)
    a = vscale(u, 1.0 / nu)
    b = vscale(v, 1.0 / nv)
    d = vdot(a, b)
    if d < -1.0 + 1e-12:
        axis = vcross(a, (1.0, 0.0, 0.0))
        if vnorm(axis) < 1e-6:
            axis = vcross(a, (0.0, 1.0, 0.0))
        n = vnorm(axis)
        return (0.0, axis[0] / n, axis[1] / n, axis[2] / n)
    c = vcross(a, b)
    return qnormalize((1.0 + d, c[0], c[1], c[2]))


@njit(cache=True, _nrt=False)
def qslerp(a, b, t):
    if t >= 1.0:
        return b
    if t <= 0.0:
        return a
    d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    if d < 0.0:
        b = (-b[0], -b[1], -b[2], -b[3])
        d = -d
    if d > 0.9995:
        return qnormalize((a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]),
                           a[2] + t * (b[2] - a[2]), a[3] + t * (b[3] - a[3])))
    th = math.acos(d)
    s = math.sin(th)
    wa = math.sin((1.0 - t) * th) / s
    wb = math.sin(t * th) / s
    return (wa * a[0] + wb * b[0], wa * a[1] + wb * b[1], wa * a[2] + wb * b[2], wa * a[3] + wb * b[3])


@njit(cache=True, _nrt=False)
def qlog(q):
    """Rotation vector (axis * angle) of a unit quaternion, angle in [0, pi]."""
    if q[0] < 0.0:
        q = (-q[0], -q[1], -q[2], -q[3])
    s = math.sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if s < EPS:
        return (0.0, 0.0, 0.0)
    ang = 2.0 * math.atan2(s, q[0])
    return (q[1] * ang / s, q[2] * ang / s, q[3] * ang / s)


@njit(cache=True, _nrt=False)
def twist_angle(q, axis):
    """Angle of the twist part of q about the unit ``axis`` (swing-twist split), (-pi, pi]."""
    p = q[1] * axis[0] + q[2] * axis[1] + q[3] * axis[2]
    ang = 2.0 * math.atan2(p, q[0])
    if ang > math.pi:
        ang -= 2.0 * math.pi
    elif ang <= -math.pi:
        ang += 2.0 * math.pi
    return ang


@njit(cache=True, _nrt=False)
def smoothstep(x):
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return x * x * (3.0 - 2.0 * x)


# -- quintic Hermite spline (section 4.3.2, "Spine Splines") ---------------------------


@njit(cache=True, _nrt=False)
def hermite5_basis(t):
    """Quintic Hermite basis on [0, 1] for (p0, v0, a0, p1, v1, a1)."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    return (1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5,
            t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5,
            0.5 * t2 - 1.5 * t3 + 1.5 * t4 - 0.5 * t5,
            10.0 * t3 - 15.0 * t4 + 6.0 * t5,
            -4.0 * t3 + 7.0 * t4 - 3.0 * t5,
            0.5 * t3 - t4 + 0.5 * t5)


@njit(cache=True, _nrt=False)
def hermite5_dbasis(t):
    """Derivatives of ``hermite5_basis`` with respect to t."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    return (-30.0 * t2 + 60.0 * t3 - 30.0 * t4,
            1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4,
            t - 4.5 * t2 + 6.0 * t3 - 2.5 * t4,
            30.0 * t2 - 60.0 * t3 + 30.0 * t4,
            -12.0 * t2 + 28.0 * t3 - 15.0 * t4,
            1.5 * t2 - 4.0 * t3 + 2.5 * t4)


@njit(cache=True, _nrt=False)
def hermite5_point(p0, v0, a0, p1, v1, a1, t):
    h = hermite5_basis(t)
    return (h[0] * p0[0] + h[1] * v0[0] + h[2] * a0[0] + h[3] * p1[0] + h[4] * v1[0] + h[5] * a1[0],
            h[0] * p0[1] + h[1] * v0[1] + h[2] * a0[1] + h[3] * p1[1] + h[4] * v1[1] + h[5] * a1[1],
            h[0] * p0[2] + h[1] * v0[2] + h[2] * a0[2] + h[3] * p1[2] + h[4] * v1[2] + h[5] * a1[2])


@njit(cache=True, _nrt=False)
def hermite5_tangent(p0, v0, a0, p1, v1, a1, t):
    h = hermite5_dbasis(t)
    return (h[0] * p0[0] + h[1] * v0[0] + h[2] * a0[0] + h[3] * p1[0] + h[4] * v1[0] + h[5] * a1[0],
            h[0] * p0[1] + h[1] * v0[1] + h[2] * a0[1] + h[3] * p1[1] + h[4] * v1[1] + h[5] * a1[1],
            h[0] * p0[2] + h[1] * v0[2] + h[2] * a0[2] + h[3] * p1[2] + h[4] * v1[2] + h[5] * a1[2])


@njit(cache=True, _nrt=False)
def transport_frame(p0, v0, a0, p1, v1, a1, frame, t_from, t_to, nsub):
    """Carry ``frame`` along the spline from t_from to t_to by minimal-twist steps, so the
    frame turns with the tangent and never spins about it (parallel transport)."""
    tan = hermite5_tangent(p0, v0, a0, p1, v1, a1, t_from)
    for s in range(1, nsub + 1):
        t = t_from + (t_to - t_from) * s / nsub
        nxt = hermite5_tangent(p0, v0, a0, p1, v1, a1, t)
        if vnorm(tan) > EPS and vnorm(nxt) > EPS:
            frame = qnormalize(qmul(qbetween(tan, nxt), frame))
            tan = nxt
    return frame


# -- the soft length constraint (section 4.3.1) ----------------------------------------


@njit(cache=True, _nrt=False, inline="always")
def soft_response(e, slope, band, width):
    """Correction for a relative length error ``e``, C1 and piecewise: ``slope * e``
    inside the band (soft: only part of a small error is removed per sweep), a quadratic
    blend over ``width`` to slope 1, then ``e`` minus a constant (full correction of any
    further error). Odd in e."""
    a = abs(e)
    if a <= band:
        c = slope * a
    elif a <= band + width:
        x = a - band
        c = slope * a + (1.0 - slope) * x * x / (2.0 * width)
    else:
        c = a - (1.0 - slope) * (band + 0.5 * width)
    return c if e >= 0.0 else -c


@njit(cache=True, _nrt=False, inline="always")
def relax_constraint(pos, inv, a, b, length, lo, hi, inva, invb, stiffness, slope, band, width):
    """One nonlinear length correction (Jakobsen 2001): move both endpoints along the
    constraint axis, in inverse proportion to their masses, by the soft response to how
    far the length is outside [lo, hi] * length. ``inv`` scales each particle's inverse
    mass (goal particles get 1 - goal weight).

    Where both ends are (nearly) pinned, their inverse masses summing below ``MOBILE``,
    only that share of the error is corrected: a goal particle of weight 0.99999 beside a
    pinned one took the whole correction (its share of the sum is 1 for any weight below
    1, and 0 at 1), so a spine goal fading out from weight 1 moved its spine in its first
    frame (random 5221 ``pound_ground``: 0.04 rad for weights x 0.99999). The correction
    fades to none as the sum goes to 0; a constraint with a free end (the plan's inverse
    masses are 0.25 and up) is corrected as before."""
    wa = inva * inv[a]
    wb = invb * inv[b]
    wsum = wa + wb
    if wsum <= 0.0:
        return
    wsum = max(wsum, MOBILE)
    d = (pos[b, 0] - pos[a, 0], pos[b, 1] - pos[a, 1], pos[b, 2] - pos[a, 2])
    L = vnorm(d)
    if length <= 0.0:
        # A zero-length constraint (anchor): pull together by ``stiffness``.
        k = stiffness / wsum
        for j in range(3):
            pos[a, j] += wa * k * d[j]
            pos[b, j] -= wb * k * d[j]
        return
    if L < EPS:
        return
    target = min(max(L, lo * length), hi * length)
    e = (L - target) / length
    if e == 0.0:
        return
    corr = stiffness * soft_response(e, slope, band, width) * length / (L * wsum)
    for j in range(3):
        pos[a, j] += wa * corr * d[j]
        pos[b, j] -= wb * corr * d[j]


@njit(cache=True, _nrt=False, inline="always")
def relax_delta(pos, inv, a, b, length, lo, hi, inva, invb, stiffness, slope, band, width):
    """The moves ``relax_constraint`` would make, returned instead of applied (for the
    simultaneous update of several goals pulling one particle)."""
    zero = (0.0, 0.0, 0.0)
    wa = inva * inv[a]
    wb = invb * inv[b]
    wsum = wa + wb
    if wsum <= 0.0:
        return zero, zero
    wsum = max(wsum, MOBILE)
    d = (pos[b, 0] - pos[a, 0], pos[b, 1] - pos[a, 1], pos[b, 2] - pos[a, 2])
    L = vnorm(d)
    if L < EPS or length <= 0.0:
        return zero, zero
    target = min(max(L, lo * length), hi * length)
    e = (L - target) / length
    if e == 0.0:
        return zero, zero
    corr = stiffness * soft_response(e, slope, band, width) * length / (L * wsum)
    return vscale(d, wa * corr), vscale(d, -wb * corr)


@njit(cache=True, _nrt=False, inline="always")
def project_length(pos, parent, child, length, plo, phi):
    """Projection of reconstruction: put ``child`` on the ray from ``parent`` at a length
    within [plo, phi] * length (section 4.3.2, "Reconstruction")."""
    d = vsub(v3(pos, child), v3(pos, parent))
    L = vnorm(d)
    if L < EPS:
        return
    Lc = min(max(L, plo * length), phi * length)
    if Lc != L:
        set3(pos, child, vadd(v3(pos, parent), vscale(d, Lc / L)))


# -- plan unpacking -------------------------------------------------------------------


@intrinsic
def borrow(typingctx, arr):
    """A view of ``arr`` that numba does not reference-count (its meminfo is NULL); for a
    (named) tuple of arrays, the same tuple of such views.

    Every ``P.field`` read inside the solve hands out a new reference to the plan blob
    the field views, and numba counts it up and down (an atomic add each time, thousands
    per solve). On a crowd solved by several threads those counts all land on the same
    few blobs: the cache line holding the count bounces between the cores. A borrowed
    view is counted as nothing. Only for views used while their owner is an argument of
    the running kernel (they never escape it)."""
    if not isinstance(arr, (types.Array, types.BaseTuple)):
        return None

    def codegen(context, builder, signature, args):
        return _borrowed(context, builder, arr, args[0])

    return arr(arr), codegen


def _borrowed(context, builder, ty, value):
    """``value`` of type ``ty`` with every array in it (also inside (named) tuples)
    re-made with a NULL meminfo and parent; anything else unchanged."""
    if isinstance(ty, types.Array):
        src = context.make_array(ty)(context, builder, value=value)
        dst = context.make_array(ty)(context, builder)
        dst.meminfo = cgutils.get_null_value(dst.meminfo.type)
        dst.parent = cgutils.get_null_value(dst.parent.type)
        dst.nitems = src.nitems
        dst.itemsize = src.itemsize
        dst.data = src.data
        dst.shape = src.shape
        dst.strides = src.strides
        return dst._getvalue()
    if isinstance(ty, types.BaseTuple):
        out = value
        for k, et in enumerate(ty.types):
            out = builder.insert_value(out, _borrowed(context, builder, et, builder.extract_value(value, k)), k)
        return out
    return value


@njit(cache=True, _nrt=False, inline="always")
def _i(pi, k):
    o = pi[2 * k]
    return borrow(pi[o:o + pi[2 * k + 1]])


@njit(cache=True, _nrt=False, inline="always")
def _f(pi, pf, k):
    h = 2 * (NINT + k)
    o = pi[h]
    return borrow(pf[o:o + pi[h + 1]])


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def unpack(pi, pf, pf3, pf4):
    """The plan blobs as a ``PlanArrays`` NamedTuple of borrowed views (no copies, no
    reference counts: the caller's blobs must outlive it, as kernel arguments do)."""
    return PlanArrays(
        _i(pi, 0), _i(pi, 1), _i(pi, 2), _i(pi, 3), _i(pi, 4), _i(pi, 5), _i(pi, 6), _i(pi, 7),
        _i(pi, 8), _i(pi, 9), _i(pi, 10), _i(pi, 11), _i(pi, 12), _i(pi, 13), _i(pi, 14),
        _i(pi, 15), _i(pi, 16), _i(pi, 17), _i(pi, 18), _i(pi, 19), _i(pi, 20), _i(pi, 21),
        _i(pi, 22), _i(pi, 23), _i(pi, 24), _i(pi, 25), _i(pi, 26), _i(pi, 27), _i(pi, 28),
        _i(pi, 29), _i(pi, 30), _i(pi, 31), _i(pi, 32), _i(pi, 33), _i(pi, 34), _i(pi, 35),
        _i(pi, 36), _i(pi, 37), _i(pi, 38), _i(pi, 39), _i(pi, 40), _i(pi, 41), _i(pi, 42),
        _i(pi, 43), _i(pi, 44), _i(pi, 45), _i(pi, 46), _i(pi, 47), _i(pi, 48), _i(pi, 49), _i(pi, 50),
        # floats
        _f(pi, pf4, 0), _f(pi, pf3, 1), _f(pi, pf3, 2), _f(pi, pf3, 3), _f(pi, pf4, 4),
        _f(pi, pf3, 5), _f(pi, pf3, 6), _f(pi, pf3, 7), _f(pi, pf, 8), _f(pi, pf, 9),
        _f(pi, pf, 10), _f(pi, pf, 11), _f(pi, pf, 12), _f(pi, pf, 13), _f(pi, pf, 14),
        _f(pi, pf, 15), _f(pi, pf, 16), _f(pi, pf, 17), _f(pi, pf3, 18), _f(pi, pf3, 19),
        _f(pi, pf3, 20), _f(pi, pf3, 21), _f(pi, pf3, 22), _f(pi, pf, 23), _f(pi, pf4, 24),
        _f(pi, pf, 25), _f(pi, pf3, 26), _f(pi, pf4, 27), _f(pi, pf3, 28), _f(pi, pf4, 29),
        _f(pi, pf3, 30), _f(pi, pf3, 31), _f(pi, pf4, 32), _f(pi, pf, 33), _f(pi, pf, 34),
        _f(pi, pf, 35), _f(pi, pf, 36), _f(pi, pf, 37), _f(pi, pf, 38), _f(pi, pf, 39),
        _f(pi, pf, 40), _f(pi, pf, 41), _f(pi, pf, 42), _f(pi, pf, 43), _f(pi, pf, 44),
        _f(pi, pf, 45), _f(pi, pf3, 46), _f(pi, pf3, 47), _f(pi, pf, 48), _f(pi, pf, 49),
        _f(pi, pf3, 50), _f(pi, pf4, 51),
    )


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _scratch_views(P, scratch):
    """Views of the scratch rows (scratch is (rows, 3) float64; per-particle scalars use
    column 0 of their own rows, so every view is a plain slice)."""
    lay = P.scratch_layout
    nsp = P.sp_kind.shape[0]
    nlp = P.lp_body.shape[0]
    ngoal = P.goal_body.shape[0]
    nch = P.ch_particle.shape[0]
    ndg = P.dg_body.shape[0]
    sp_pos = scratch[lay[0]:lay[0] + nsp]
    sp_inv = scratch[lay[1]:lay[1] + nsp, 0]
    lp_pos = scratch[lay[2]:lay[2] + nlp]
    lp_rest = scratch[lay[3]:lay[3] + nlp]
    lp_inv = scratch[lay[4]:lay[4] + nlp, 0]
    goal_joint = scratch[lay[5]:lay[5] + ngoal]
    ch_tan = scratch[lay[6]:lay[6] + nch]
    state = scratch[lay[7], :]
    dg_target = scratch[lay[8]:lay[8] + ndg]
    sp_acc = scratch[lay[9]:lay[9] + nsp]
    lg_target = scratch[lay[10]:lay[10] + ngoal]
    lg_jtarget = scratch[lay[11]:lay[11] + ngoal]
    segbody_tp = scratch[lay[12]:lay[12] + P.segbody_body.shape[0], 0]
    segbody_lift = scratch[lay[12]:lay[12] + P.segbody_body.shape[0], 1]   # the same rows' second column
    return (sp_pos, sp_inv, lp_pos, lp_rest, lp_inv, goal_joint, ch_tan, state, dg_target, sp_acc,
            lg_target, lg_jtarget, segbody_tp, segbody_lift)


# -- the solve ------------------------------------------------------------------------
# The stages below take the plan ``P`` (a NamedTuple of 92 arrays) and are inlined into
# ``solve_one`` by numba: a real call passes all 92 array structs (some 5 KB) by value,
# which cost about a third of a solve.


@njit(cache=True, _nrt=False, inline="always")
def _goal_targets(P, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w, goal_rot_w, goal_joint):
    """Section 4.3.1: 6-DOF goals become 3-DOF goals at the body's joint. The body's
    rotation at the goal is the rotation goal where one is given (blended by its weight
    into the estimate), else an estimate: the rest rotation aimed along its limb's chord
    from the limb root to the goal (the same minimal-twist aim the limb phase starts from)."""
    for gi in range(P.goal_body.shape[0]):
        g = P.goal_body[gi]
        if goal_pos_w[g] <= 0.0:
            # No position goal: the target is never pulled on, but keep it finite (the
            # caller's unused goal_pos row may hold anything).
            set3(goal_joint, gi, vadd(root_pos, qrot(root_rot, v3(P.b_rootrel_joint, g))))
            continue
        rest_rot = qmul(root_rot, q4(P.b_rootrel_rot, g))
        est = rest_rot
        lr = P.goal_limb_root[gi]
        if lr >= 0:
            chord_rest = qrot(root_rot, vsub(v3(P.b_rootrel_joint, g), v3(P.b_rootrel_joint, lr)))
            attach = vadd(root_pos, qrot(root_rot, v3(P.b_rootrel_joint, lr)))
            chord_goal = vsub(v3(goal_pos, g), attach)
            if vnorm(chord_rest) > 1e-9 and vnorm(chord_goal) > 1e-9:
                est = qmul(qbetween(chord_rest, chord_goal), rest_rot)
        if lr == -2:
            # A spine body's goal held by a particle at its origin: no conversion.
            set3(goal_joint, gi, v3(goal_pos, g))
            continue
        wr = goal_rot_w[g]
        if wr > 0.0:
            est = qslerp(est, q4(goal_rot, g), min(wr, 1.0))
        set3(goal_joint, gi, vsub(v3(goal_pos, g), qrot(est, v3(P.b_joint_offset, g))))


@njit(cache=True, _nrt=False, inline="always")
def _delegated_targets(P, goal_rot, goal_rot_w, goal_joint, dg_target):
    """A delegated goal with a rotation fixes its spine body's rotation, so it also gives
    that spine body's joint a target: the delegated joint's target minus the chord turned
    by that rotation (the 6-DOF goal converted at the spine body's joint, 4.3.1)."""
    for d in range(P.dg_body.shape[0]):
        db = P.dg_body[d]
        if goal_rot_w[db] <= 0.0:
            set3(dg_target, d, v3(goal_joint, P.dg_goal[d]))  # unused; finite
            continue
        spine_rot = qmul(q4(goal_rot, db), qconj(q4(P.dg_rel_rot, d)))
        set3(dg_target, d, vsub(v3(goal_joint, P.dg_goal[d]), qrot(spine_rot, v3(P.dg_chord, d))))


@njit(cache=True, _nrt=False, inline="always")
def _share(w, inv_n):
    """The pull per pin of a goal of weight ``w`` back to its weighted target
    (``_weighted_target``) after each of the 1 / ``inv_n`` sweeps of a spine solve:
    1 - (1 - w)^(1/n), so n pulls together take a displaced particle w of the way back
    (weight 0.02 pulled 0.02 each time over 15 pins would take it 26% of the way: a light
    goal would hold its particle as firmly as a heavy one). The particle's inverse mass is
    1 - w, so what the constraints move it by vanishes as w goes to 1. (The limb phase
    blends its targets by weight the same way, ``_limb_phase``.)"""
    if w <= 0.0 or w >= 1.0:
        return w
    return 1.0 - math.pow(1.0 - w, inv_n)


@njit(cache=True, _nrt=False, inline="always")
def _pin_delegated(dg_body, dg_spine_particle, goal_pos_w, goal_rot_w, dg_target, sp_pos, sp_inv, first, inv_n,
                   sp_rest, root_pos, root_rot):
    # The helpers called inside iteration loops take the plan arrays they read, not the
    # plan: an inlined ``P`` argument is a copy of 92 arrays (a reference count each).
    for d in range(dg_body.shape[0]):
        db = dg_body[d]
        w = min(max(goal_pos_w[db], 0.0), 1.0) * min(max(goal_rot_w[db], 0.0), 1.0)
        if w <= 0.0 or (not first and w >= 1.0):
            continue
        i = dg_spine_particle[d]
        target = _weighted_target(sp_rest, root_pos, root_rot, i, v3(dg_target, d), w)
        if first:
            set3(sp_pos, i, target)
            sp_inv[i] = min(sp_inv[i], 1.0 - w)
        else:
            set3(sp_pos, i, vlerp(v3(sp_pos, i), target, _share(w, inv_n)))


@njit(cache=True, _nrt=False, inline="always")
def _weighted_target(sp_rest, root_pos, root_rot, i, goal, w):
    """Where a spine-phase goal of weight ``w`` holds its particle: ``w`` of the way from
    its rest place (carried by the root) to the goal. The particle starts there (inverse
    mass 1 - w) and is pulled back there after every sweep (``_share``). It used to start
    ``_share(w)`` of the way to the goal itself and be pulled to the goal: the share's
    slope is infinite at w = 1 (0.47 of the way at w = 0.999, all of it at 1), so a goal
    fading out from weight 1 snapped the spine in its first frame (random 4259's chest at
    the end of ``perform``: 0.68 rad with the hands' weights at 0.987)."""
    rest = vadd(root_pos, qrot(root_rot, v3(sp_rest, i)))
    return vlerp(rest, goal, w)


@njit(cache=True, _nrt=False, inline="always")
def _pin_root_children(ch_particle, ch_prev, sp_body, b_parent, sp_rest, root_pos, root_rot, sp_pos, sp_inv):
    """The root's frame is the game's, so a spine body hanging straight off the root has
    its joint where the root's frame puts it: its particle is fixed there (after any goal
    wrote it), else the spine phase swings it about the root's origin and the body comes
    off the root (a gap of a whole bone at the root's child)."""
    for k in range(ch_particle.shape[0]):
        i = ch_particle[k]
        if ch_prev[k] == 0 and b_parent[sp_body[i]] == 0:
            set3(sp_pos, i, vadd(root_pos, qrot(root_rot, v3(sp_rest, i))))
            sp_inv[i] = 0.0


# -- the ground (issues 12/16) ---------------------------------------------------------
# The solve runs in character space; ``ground`` is a plane (nx, ny, nz, d) there, n . x = d
# with n the unit up normal, or off (``ground_on`` False). Every body's box must keep its
# lowest corner at or above the plane plus its floor ``b_floor`` (0, or lower where the box
# dips into the ground at rest, so the rest pose is never moved). During the iterations
# only particles exist, so each body's box is carried by the particle at its joint with
# the rotation the reconstruction will give it (its rest rotation swung so its bone points
# from its joint particle to its first child particle, as ``_limb_rebuild`` does; a spine
# body's bone is the chord from its rootward neighbour). The box's corners are split, once
# and for all by the rest bone, into those on the joint's side of its centre (the joint
# particle lifts them) and those on the child's side (the child particle lifts them), so a
# body lying on the ground is lifted at both ends and a pinned end (a goal) never makes the
# other end climb. A lift is max(0, deficit) along the normal: continuous in the goals, no
# lever factors (whose choice would jump where two corners tie). Goal particles are pinned
# (inverse mass 0) and never lifted: goals on or below the floor are still met.


@njit(cache=True, _nrt=False, inline="always")
def _box_lows(rot, off, ext, n, bone):
    """Lowest height along the unit ``n`` of a box (centre ``off`` from the joint, half
    extents ``ext``, both in the body frame ``rot``), relative to the joint: over the
    corners on the joint's side of the centre along ``bone`` (a body-frame direction;
    zero: every corner) and over those on the far side (1e300 when none)."""
    ln = qrot(qconj(rot), n)
    ac = vdot(bone, off)
    near = 1e300
    far = 1e300
    for sx in (-1.0, 1.0):
        for sy in (-1.0, 1.0):
            for sz in (-1.0, 1.0):
                c = (off[0] + sx * ext[0], off[1] + sy * ext[1], off[2] + sz * ext[2])
                h = vdot(ln, c)
                if vdot(bone, c) <= ac:
                    near = min(near, h)
                else:
                    far = min(far, h)
    return near, far


@njit(cache=True, _nrt=False, inline="always")
def _ground_spine(ch_particle, ch_prev, sp_body, sp_rest, b_rootrel_rot, b_joint_offset, b_extent, b_floor,
                  b_ground_r, root_rot, gn, gd, sp_pos, sp_inv):
    """Spine-phase particles (spine bodies' joints) lifted so their bodies' boxes, carried
    by the chord from the rootward neighbour, stay above the ground (see above)."""
    for k in range(ch_particle.shape[0]):
        i = ch_particle[k]
        if sp_inv[i] <= 0.0:
            continue
        s = sp_body[i]
        x = v3(sp_pos, i)
        floor = gd + b_floor[s]
        if vdot(gn, x) - floor >= b_ground_r[s]:
            continue                          # the whole box is above the floor
        j = ch_prev[k]
        swing = qbetween(qrot(root_rot, vsub(v3(sp_rest, i), v3(sp_rest, j))), vsub(x, v3(sp_pos, j)))
        rot = qmul(swing, qmul(root_rot, q4(b_rootrel_rot, s)))
        low, _far = _box_lows(rot, v3(b_joint_offset, s), v3(b_extent, s), gn, (0.0, 0.0, 0.0))
        # scaled by the inverse mass: a particle pinned by a goal of weight w (1 - w) moves
        # as much less, so the lift fades in and out with the goal
        lift = (floor - (vdot(gn, x) + low)) * min(sp_inv[i], 1.0)
        if lift > 0.0:
            set3(sp_pos, i, vadd(x, vscale(gn, lift)))


@njit(cache=True, _nrt=False, inline="always")
def _ground_share(i, lp_parent, lp_inv, goal_body, goal_lp, goal_lpj, goal_pos_w, goal_rot_w):
    """How much of a lift particle ``i`` takes, and the goal slot (and 0 target, 1 joint
    target) whose pin moves with it: a free particle all of it, a limb root none, a particle
    pinned by a goal of weight w (``_pin_limb_goals``) 1 - w, so a goal at full weight is
    met where it is (on or below the floor) and a fading goal hands its particle to the
    ground without a step."""
    if lp_parent[i] < 0:
        return 0.0, -1, 0
    if lp_inv[i] > 0.0:
        return min(lp_inv[i], 1.0), -1, 0
    for gi in range(goal_body.shape[0]):
        b = goal_body[gi]
        w = min(max(goal_pos_w[b], 0.0), 1.0)
        if goal_lp[gi] == i:
            return 1.0 - w, gi, 0
        if goal_lpj[gi] == i:
            return 1.0 - min(w, min(max(goal_rot_w[b], 0.0), 1.0)), gi, 1
    return 0.0, -1, 0


@njit(cache=True, _nrt=False, inline="always")
def _ground_lift(i, lift, share, gi, which, gn, lp_pos, lg_target, lg_jtarget, ctr):
    """Move particle ``i`` up by ``share`` x ``lift`` (and the pin that holds it, if any)."""
    d = vscale(gn, lift * share)
    if gi < 0:
        # a free particle is lifted up and, by half as much, outward (horizontally away
        # from the root). Straight up, a knee under its chain's line was pushed back down
        # by every sweep and the chain never settled: octopus eat_fruit / hand_to_mouth
        # missed their goals by 4-7% of the reach (grid, s28 ground8). The bias does not
        # pick the side a knee goes round its chain's line (pick_fruit and punch still flip)
        o = vsub(v3(lp_pos, i), ctr)
        o = vsub(o, vscale(gn, vdot(o, gn)))
        no = vnorm(o)
        if no > EPS:
            d = vadd(d, vscale(o, GROUND_BIAS * lift * share / no))
    set3(lp_pos, i, vadd(v3(lp_pos, i), d))
    if gi >= 0:
        if which == 0:
            set3(lg_target, gi, vadd(v3(lg_target, gi), d))
        else:
            set3(lg_jtarget, gi, vadd(v3(lg_jtarget, gi), d))


@njit(cache=True, _nrt=False, inline="always")
def _ground_limbs(lp_body, lp_parent, lp_mode, lp_c1, lp_attach, lp_rot_local, b_joint_offset, b_extent, b_floor,
                  b_ground_r, gn, gd, out_rot, lp_rest, lp_pos, lp_inv, goal_body, goal_lp, goal_lpj, goal_pos_w,
                  goal_rot_w, lg_target, lg_jtarget, ctr):
    """Limb particles lifted so every limb body's box stays above the ground (see above):
    the joint particle lifts the corners on its side, the first child particle (or the
    tip) those on the far side; a body without one turns with its parent's bone. Each
    particle takes its ``_ground_share`` of a lift."""
    for i in range(lp_body.shape[0]):
        if lp_mode[i] == 3:
            continue                          # a tip: its body is carried by its joint particle
        b = lp_body[i]
        x = v3(lp_pos, i)
        floor = gd + b_floor[b]
        if vdot(gn, x) - floor >= b_ground_r[b]:
            continue
        rest_rot = qmul(q4(out_rot, lp_attach[i]), q4(lp_rot_local, i))
        c = lp_c1[i]
        bone = (0.0, 0.0, 0.0)
        if c >= 0:
            e_rest = vsub(v3(lp_rest, c), v3(lp_rest, i))
            swing = qbetween(e_rest, vsub(v3(lp_pos, c), x))
            bone = qrot(qconj(rest_rot), e_rest)
        elif lp_parent[i] >= 0:
            p = lp_parent[i]
            swing = qbetween(vsub(v3(lp_rest, i), v3(lp_rest, p)), vsub(x, v3(lp_pos, p)))
        else:
            swing = (1.0, 0.0, 0.0, 0.0)
        rot = qmul(swing, rest_rot)
        near, far = _box_lows(rot, v3(b_joint_offset, b), v3(b_extent, b), gn, bone)
        h = vdot(gn, x)
        lift = floor - (h + near)
        if lift > 0.0:
            share, gi, which = _ground_share(i, lp_parent, lp_inv, goal_body, goal_lp, goal_lpj, goal_pos_w,
                                             goal_rot_w)
            if share > 0.0:
                _ground_lift(i, lift, share, gi, which, gn, lp_pos, lg_target, lg_jtarget, ctr)
                h += lift * share
        if c >= 0 and far < 1e299:
            lift = floor - (h + far)
            if lift > 0.0:
                share, gi, which = _ground_share(c, lp_parent, lp_inv, goal_body, goal_lp, goal_lpj, goal_pos_w,
                                                 goal_rot_w)
                if share > 0.0:
                    _ground_lift(c, lift, share, gi, which, gn, lp_pos, lg_target, lg_jtarget, ctr)


@njit(cache=True, _nrt=False, inline="always")
def _ground_interior(segbody_body, b_extent, b_floor, adr, num, gn, gd, segbody_tp, segbody_lift, out_pos, out_rot):
    """Interior spine bodies of one posed spline (no particles: the spline between two
    lifted particles can still dip into the ground) lifted along the normal by a lift
    field over the spline's parameter: the largest of each body's own deficit (its box's
    lowest corner under its floor) spread by a hat that falls to 0 at the spline's ends,
    so every body is lifted at least by its deficit, its neighbours with it (the bone aim
    that follows keeps the spine in one piece) and the end particles not at all. A max of
    continuous functions of the pose: continuous in the goals."""
    any_low = False
    for j in range(adr, adr + num):
        body = segbody_body[j]
        x = v3(out_pos, body)
        e = v3(b_extent, body)
        floor = gd + b_floor[body]
        segbody_lift[j] = 0.0
        if vdot(gn, x) - floor >= vnorm(e):
            continue
        low, _far = _box_lows(q4(out_rot, body), (0.0, 0.0, 0.0), e, gn, (0.0, 0.0, 0.0))
        d = floor - (vdot(gn, x) + low)
        if d > 0.0:
            segbody_lift[j] = d
            any_low = True
    if not any_low:
        return
    for k in range(adr, adr + num):
        tk = segbody_tp[k]
        lift = 0.0
        for j in range(adr, adr + num):
            d = segbody_lift[j]
            if d <= 0.0:
                continue
            tj = segbody_tp[j]
            if tk <= tj:
                w = tk / tj if tj > EPS else 1.0
            else:
                w = (1.0 - tk) / (1.0 - tj) if tj < 1.0 - EPS else 1.0
            lift = max(lift, d * w)
        if lift > 0.0:
            body = segbody_body[k]
            set3(out_pos, body, vadd(v3(out_pos, body), vscale(gn, lift)))


@njit(cache=True, _nrt=False, forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _spine_phase(P, root_pos, root_rot, goal_pos_w, goal_rot_w, goal_joint, dg_target, sp_pos, sp_inv,
                 state, sp_acc, ground_on, gn, gd):
    """Section 4.3.2: iterate the spine-phase constraints (simplified limbs, delegated
    goals, spine constraints between branch points) leaves inward, 5 outer iterations,
    watching for buckling and blending toward the rest pose when it happens."""
    prm = P.params
    slope, band, width = prm[P_SOFT_SLOPE], prm[P_SOFT_BAND], prm[P_SOFT_WIDTH]
    nsp = P.sp_kind.shape[0]
    # Initialization: every particle at the root-relative rest pose, carried by the root.
    for i in range(nsp):
        sp_acc[i, 0] = 0.0
        sp_acc[i, 1] = 0.0
        sp_acc[i, 2] = 0.0
        set3(sp_pos, i, vadd(root_pos, qrot(root_rot, v3(P.sp_rest, i))))
        k = P.sp_kind[i]
        sp_inv[i] = 0.0 if (k == 0 or k == 3) else 1.0
    # Goal particles start at their goals (the distal end of a simplified limb).
    for gi in range(P.goal_body.shape[0]):
        i = P.goal_sp[gi]
        if i < 0:
            continue
        w = min(max(goal_pos_w[P.goal_body[gi]], 0.0), 1.0)
        set3(sp_pos, i, _weighted_target(P.sp_rest, root_pos, root_rot, i, v3(goal_joint, gi), w))
        sp_inv[i] = 1.0 - w
    dg_body, dg_spine_particle = P.dg_body, P.dg_spine_particle
    n_outer = int(prm[P_SPINE_OUTER])
    n_inner = int(prm[P_SPINE_INNER])
    inv_n = 1.0 / (1 + n_outer * n_inner)        # pins per solve: the start and every sweep
    _pin_delegated(dg_body, dg_spine_particle, goal_pos_w, goal_rot_w, dg_target, sp_pos, sp_inv, True, inv_n,
                   P.sp_rest, root_pos, root_rot)
    root_pin = prm[P_ROOT_PIN] > 0.0
    ch_particle, ch_prev, sp_body, b_parent, sp_rest = P.ch_particle, P.ch_prev, P.sp_body, P.b_parent, P.sp_rest
    if root_pin:
        _pin_root_children(ch_particle, ch_prev, sp_body, b_parent, sp_rest, root_pos, root_rot, sp_pos, sp_inv)
    buckle = 0.0
    nsc = P.sc_a.shape[0]
    anti = prm[P_ANTI_BUCKLING] > 0.0
    pull_cap = prm[P_PULL_CAP]
    for _outer in range(n_outer):
        for _inner in range(n_inner):
            for c in range(nsc):
                kind = P.sc_kind[c]
                if kind == 1 or kind == 2:
                    # Goals pulling a spine particle act together (Jacobi): each pull is
                    # summed and applied after the sweep, each weighted 1/k by the plan,
                    # so conflicting goals settle between them whatever their order.
                    da, db = relax_delta(sp_pos, sp_inv, P.sc_a[c], P.sc_b[c], P.sc_len[c], P.sc_lo[c],
                                         P.sc_hi[c], P.sc_inva[c], P.sc_invb[c], P.sc_stiff[c], slope, band,
                                         width)
                    b = P.sc_b[c]
                    set3(sp_pos, b, vadd(v3(sp_pos, b), db))
                    a = P.sc_a[c]
                    set3(sp_acc, a, vadd(v3(sp_acc, a), da))
                    continue
                # Before a spine constraint or an anchor moves a particle, its pending
                # pulls land.
                _flush_acc(sp_pos, sp_acc, P.sc_a[c], P.sp_prev, pull_cap)
                _flush_acc(sp_pos, sp_acc, P.sc_b[c], P.sp_prev, pull_cap)
                if kind == 3:
                    if buckle > 0.0:
                        relax_constraint(sp_pos, sp_inv, P.sc_a[c], P.sc_b[c], 0.0, 1.0, 1.0,
                                         P.sc_inva[c], P.sc_invb[c], buckle, slope, band, width)
                    continue
                relax_constraint(sp_pos, sp_inv, P.sc_a[c], P.sc_b[c], P.sc_len[c], P.sc_lo[c],
                                 P.sc_hi[c], P.sc_inva[c], P.sc_invb[c], P.sc_stiff[c], slope, band, width)
            for i in range(nsp):
                _flush_acc(sp_pos, sp_acc, i, P.sp_prev, pull_cap)
            # Goals with weight below 1 are pulled back toward their goal after each sweep.
            for gi in range(P.goal_body.shape[0]):
                i = P.goal_sp[gi]
                if i >= 0:
                    w = min(max(goal_pos_w[P.goal_body[gi]], 0.0), 1.0)
                    if 0.0 < w < 1.0:
                        set3(sp_pos, i, vlerp(v3(sp_pos, i), _weighted_target(sp_rest, root_pos, root_rot, i,
                                                                              v3(goal_joint, gi), w), _share(w, inv_n)))
            _pin_delegated(dg_body, dg_spine_particle, goal_pos_w, goal_rot_w, dg_target, sp_pos, sp_inv, False,
                           inv_n, sp_rest, root_pos, root_rot)
            if root_pin:
                _pin_root_children(ch_particle, ch_prev, sp_body, b_parent, sp_rest, root_pos, root_rot, sp_pos,
                                   sp_inv)
            if ground_on:
                _ground_spine(ch_particle, ch_prev, sp_body, sp_rest, P.b_rootrel_rot, P.b_joint_offset, P.b_extent,
                              P.b_floor, P.b_ground_r, root_rot, gn, gd, sp_pos, sp_inv)
        if anti:
            b = smoothstep((_buckle_metric(P.bp_c1, P.bp_c2, P.bp_sign1, P.bp_rest_angle, P.sc_a, P.sc_b, P.sp_rest,
                                           root_rot, sp_pos) - prm[P_BUCKLE_ON])
                           / (prm[P_BUCKLE_FULL] - prm[P_BUCKLE_ON]))
            buckle = max(buckle, b)
    state[0] = buckle


@njit(cache=True, _nrt=False, inline="always")
def _flush_acc(sp_pos, sp_acc, i, sp_prev, cap):
    """The goals' summed pull d lands on particle ``i``, eased as d / sqrt(1 + (|d| / L)^2),
    L = ``cap`` times the particle's distance to its rootward neighbour (``cap`` 0: whole;
    ``IKParams.spine_pull_cap``): a pull longer than that chord, along a line through the
    neighbour, carried the particle through its pivot in one sweep and the chord's
    projection then put it above or below at random (random 4258 hold_platter: spine5's
    chord swung from 62 degrees down to 60 up within a goal weight change of 0.005). Eased,
    the particle goes round its pivot over the sweeps, the way the pull turns it."""
    if sp_acc[i, 0] != 0.0 or sp_acc[i, 1] != 0.0 or sp_acc[i, 2] != 0.0:
        d = v3(sp_acc, i)
        j = sp_prev[i]
        if cap > 0.0 and j >= 0:
            lim = cap * vnorm(vsub(v3(sp_pos, i), v3(sp_pos, j)))
            n = vnorm(d)
            if lim > 0.0:
                d = vscale(d, 1.0 / math.sqrt(1.0 + (n / lim) ** 2))
        set3(sp_pos, i, vadd(v3(sp_pos, i), d))
        sp_acc[i, 0] = 0.0
        sp_acc[i, 1] = 0.0
        sp_acc[i, 2] = 0.0


@njit(cache=True, _nrt=False, inline="always")
def _buckle_metric(bp_c1, bp_c2, bp_sign1, bp_rest_angle, sc_a, sc_b, sp_rest, root_rot, sp_pos):
    """How far the spine has folded: the largest increase, over the rest pose, of the
    angle between neighbouring spine constraints (the first constraint of a side with no
    neighbour is compared with its own rest direction carried by the root), rad."""
    worst = 0.0
    for k in range(bp_c2.shape[0]):
        c2 = bp_c2[k]
        d2 = vsub(v3(sp_pos, sc_b[c2]), v3(sp_pos, sc_a[c2]))
        c1 = bp_c1[k]
        if c1 >= 0:
            d1 = vscale(vsub(v3(sp_pos, sc_b[c1]), v3(sp_pos, sc_a[c1])), bp_sign1[k])
        else:
            d1 = qrot(root_rot, vsub(v3(sp_rest, sc_b[c2]), v3(sp_rest, sc_a[c2])))
        n1 = vnorm(d1)
        n2 = vnorm(d2)
        if n1 < EPS or n2 < EPS:
            continue
        c = min(max(vdot(d1, d2) / (n1 * n2), -1.0), 1.0)
        worst = max(worst, math.acos(c) - bp_rest_angle[k])
    return worst


@njit(cache=True, _nrt=False, inline="always")
def _root_influence(P, root_pos, root_rot, sp_pos):
    """Footnote 8: the root's immediate spine children pull the root's rotation slightly
    toward where the spine phase moved them (a fraction of the mean rotation)."""
    kappa = P.params[P_ROOT_INFLUENCE]
    if kappa <= 0.0:
        return root_rot
    acc = (0.0, 0.0, 0.0)
    n = 0
    for k in range(P.ch_particle.shape[0]):
        if P.ch_prev_k[k] >= 0:
            continue
        i = P.ch_particle[k]
        d_rest = qrot(root_rot, v3(P.sp_rest, i))
        d_pose = vsub(v3(sp_pos, i), root_pos)
        acc = vadd(acc, qlog(qbetween(d_rest, d_pose)))
        n += 1
    if n == 0:
        return root_rot
    rv = vscale(acc, kappa / n)
    ang = vnorm(rv)
    return qnormalize(qmul(qaxis_angle(rv, ang), root_rot))


@njit(cache=True, _nrt=False)
def spline_arc(p0, v0, a0, p1, v1, a1, t_to, n):
    """Arc length of the quintic from t = 0 to ``t_to``, measured on ``n`` uniform chords
    of [0, 1] (linearly within the chord holding ``t_to``); ``spline_param_at_arc`` is its
    inverse on the same chords."""
    if t_to <= 0.0:
        return 0.0
    prev = p0
    acc = 0.0
    for s in range(1, n + 1):
        cur = hermite5_point(p0, v0, a0, p1, v1, a1, s / n)
        d = vnorm(vsub(cur, prev))
        if s == n or s / n >= t_to:
            return acc + d * min(max((t_to - (s - 1) / n) * n, 0.0), 1.0)
        acc += d
        prev = cur
    return acc


@njit(cache=True, _nrt=False)
def spline_param_at_arc(p0, v0, a0, p1, v1, a1, length, n):
    """The parameter at which the quintic's arc length from t = 0 (on ``n`` uniform
    chords, as ``spline_arc``) reaches ``length``; 1 beyond its end."""
    if length <= 0.0:
        return 0.0
    prev = p0
    acc = 0.0
    for s in range(1, n + 1):
        cur = hermite5_point(p0, v0, a0, p1, v1, a1, s / n)
        d = vnorm(vsub(cur, prev))
        if acc + d >= length and d > EPS:
            return (s - 1 + (length - acc) / d) / n
        acc += d
        prev = cur
    return 1.0


#: Chords per transport substep on which the spine splines' arc lengths are measured.
ARC_CHORDS = 16
#: Bisection steps drawing in a spine spline that bulges past its stretch limit.
ARC_BISECT = 10


@njit(cache=True, _nrt=False)
def rest_arc_shares(sp_rest, b_rootrel_rot, sp_body, seg_a, seg_b, seg_v0, seg_a0, seg_v1, seg_a1,
                    seg_body_adr, seg_body_num, segbody_t, nsub, seg_rest_arc, segbody_share):
    """Static part of the reconstruction (at plan build): each rest spline's arc length and
    each interior body's share of it, on the chords ``_spine_reconstruct`` measures the
    posed splines on (``ARC_CHORDS`` per transport substep), from the plan's own fitted
    splines, as the solve would compute them."""
    narc = ARC_CHORDS * max(nsub, 1)
    for g in range(seg_a.shape[0]):
        qa = q4(b_rootrel_rot, sp_body[seg_a[g]])
        qb = q4(b_rootrel_rot, sp_body[seg_b[g]])
        rp0 = v3(sp_rest, seg_a[g])
        rp1 = v3(sp_rest, seg_b[g])
        rv0 = qrot(qa, v3(seg_v0, g))
        ra0 = qrot(qa, v3(seg_a0, g))
        rv1 = qrot(qb, v3(seg_v1, g))
        ra1 = qrot(qb, v3(seg_a1, g))
        rest_arc = spline_arc(rp0, rv0, ra0, rp1, rv1, ra1, 1.0, narc)
        seg_rest_arc[g] = rest_arc
        for j in range(seg_body_adr[g], seg_body_adr[g] + seg_body_num[g]):
            segbody_share[j] = (spline_arc(rp0, rv0, ra0, rp1, rv1, ra1, segbody_t[j], narc) / rest_arc
                                if rest_arc > EPS else 0.0)


@njit(cache=True, _nrt=False, forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _spine_reconstruct(P, root_pos, root_rot, goal_pos_w, goal_rot, goal_rot_w, sp_pos, ch_tan, segbody_tp,
                       out_pos, out_rot, buckle, ground_on, gn, gd, segbody_lift):
    """Section 4.3.2, "Reconstruction": outward projection of the spine particles to the
    allowed shrink/stretch, tangents by the three-point and natural-end formulas, minimal
    twist from the rest tangent, delegated goals blended in, interior bodies by frame
    transport along the quintic splines."""
    set3(out_pos, 0, root_pos)
    set4(out_rot, 0, root_rot)
    set3(sp_pos, 0, root_pos)
    nch = P.ch_particle.shape[0]
    # Positions, outward (chain slots are ordered outward on each side).
    for k in range(nch):
        c = P.ch_con[k]
        project_length(sp_pos, P.ch_prev[k], P.ch_particle[k], P.sc_len[c], P.sc_plo[c], P.sc_phi[c])
    # Tangents and orientations of the particle bodies.
    for k in range(nch):
        i = P.ch_particle[k]
        pprev = v3(sp_pos, P.ch_prev[k])
        if P.ch_next[k] >= 0:
            tan = vscale(vsub(v3(sp_pos, P.ch_next[k]), pprev), 0.5)
        else:
            if P.ch_prev_k[k] >= 0:
                vprev = v3(ch_tan, P.ch_prev_k[k])
            else:
                vprev = qrot(root_rot, v3(P.seg_v0, P.ch_seg[k]))
            tan = vsub(vscale(vsub(v3(sp_pos, i), pprev), 1.5), vscale(vprev, 0.5))
        set3(ch_tan, k, tan)
        s = P.sp_body[i]
        rest_rot = qmul(root_rot, q4(P.b_rootrel_rot, s))
        rot = qmul(qbetween(qrot(root_rot, v3(P.ch_rest_tangent, k)), tan), rest_rot)
        # Delegated position goals: swing the body so the delegated joints point at
        # where the spine phase put them (their goals, when reachable).
        acc_r = (0.0, 0.0, 0.0)
        acc_p = (0.0, 0.0, 0.0)
        wsum = 0.0
        for d in range(P.dg_body.shape[0]):
            if P.dg_spine_particle[d] != i:
                continue
            w = min(max(goal_pos_w[P.dg_body[d]], 0.0), 1.0)
            if w <= 0.0:
                continue
            wsum += w
            acc_r = vadd(acc_r, vscale(qrot(rot, v3(P.dg_chord, d)), w))
            acc_p = vadd(acc_p, vscale(vsub(v3(sp_pos, P.dg_particle[d]), v3(sp_pos, i)), w))
        if vnorm(acc_r) > EPS and vnorm(acc_p) > EPS:
            # When the spine buckled it is blended toward rest, and so is this swing
            # (else an unreachable delegated goal folds the end body over). The swing is
            # taken as far as the goals weigh (their weights sum, to 1): the weighted means
            # above do not shrink with the weights, so a goal of weight 1e-10 swung the body
            # all the way to a particle it no longer held (random 4259's chest, 1.9 rad in
            # the first frame of a crossfade into idle_breathe, whose spine goals start at
            # weight 0.009; a spine body's own goal is such a delegated one).
            rot = qslerp(rot, qmul(qbetween(acc_r, acc_p), rot), (1.0 - buckle) * min(wsum, 1.0))
        # The spine body's own rotation goal, blended by its weight and, where an outward
        # spine joint hangs on the body, faded by the buckling as the swing above is (the
        # buckled spine's next joint is where the chord put it, and a body turned away from
        # its chord opens a gap there: captured chests in dance, 0.35 of a bone). The end
        # of a side carries no spine joint: its goal turns it about its joint once the
        # spine's shape is made and folds nothing (faded, a head told to look at a fruit
        # while an arm's reach buckled the spine looked 1.9 rad away from it: random 4246
        # pick_fruit, buckle 0.83).
        fade = 1.0 - buckle if P.ch_next[k] >= 0 else 1.0
        for gi in range(P.goal_body.shape[0]):
            if P.goal_sp[gi] == i:
                wr = min(max(goal_rot_w[s], 0.0), 1.0) * fade
                if wr > 0.0:
                    rot = qslerp(rot, q4(goal_rot, s), wr)
        # Delegated rotation goals: the spine body takes the rotation that puts the
        # delegating body on its goal, blended by the goal's weight (faded the same way).
        for d in range(P.dg_body.shape[0]):
            if P.dg_spine_particle[d] != i:
                continue
            db = P.dg_body[d]
            wr = min(max(goal_rot_w[db], 0.0), 1.0) * fade
            if wr > 0.0:
                rot = qslerp(rot, qmul(q4(goal_rot, db), qconj(q4(P.dg_rel_rot, d))), wr)
        set4(out_rot, s, rot)
        set3(out_pos, s, vadd(v3(sp_pos, i), qrot(rot, v3(P.b_joint_offset, s))))
    # Interior spine bodies, by frame transport along each posed spline, each at the
    # parameter where the posed spline's arc length is the body's rest share of it (at its
    # rest parameter a bent or bulging spline spaces the joints further apart or closer
    # than their bones). A spline longer than its stretch limit allows is drawn in first by
    # shortening its end tangents (and accelerations, squared), so the bones are not pulled
    # apart along a bulge; the particles' chord is within that limit already. At rest the
    # posed spline is the rest spline and every parameter is the rest one.
    nsub = int(P.params[P_SUBSTEPS])
    narc = ARC_CHORDS * max(nsub, 1)
    for g in range(P.seg_a.shape[0]):
        a = P.seg_a[g]
        b = P.seg_b[g]
        A = P.sp_body[a]
        B = P.sp_body[b]
        ra = q4(out_rot, A)
        rb = q4(out_rot, B)
        p0 = v3(sp_pos, a)
        p1 = v3(sp_pos, b)
        chord = vnorm(vsub(p1, p0))
        scale = chord / P.seg_rest_chord[g] if P.seg_rest_chord[g] > EPS else 1.0
        v0 = vscale(qrot(ra, v3(P.seg_v0, g)), scale)
        a0 = vscale(qrot(ra, v3(P.seg_a0, g)), scale)
        v1 = vscale(qrot(rb, v3(P.seg_v1, g)), scale)
        a1 = vscale(qrot(rb, v3(P.seg_a1, g)), scale)
        adr = P.seg_body_adr[g]
        num = P.seg_body_num[g]
        if num == 0:
            continue
        rest_arc = P.seg_rest_arc[g]
        arc = spline_arc(p0, v0, a0, p1, v1, a1, 1.0, narc)
        phi = 1.0
        for k in range(P.ch_particle.shape[0]):
            if P.ch_seg[k] == g:
                phi = P.sc_phi[P.ch_con[k]]
        limit = phi * rest_arc
        if rest_arc > EPS and arc > limit:
            lo = 0.0
            hi = 1.0
            for _it in range(ARC_BISECT):
                f = 0.5 * (lo + hi)
                if spline_arc(p0, vscale(v0, f), vscale(a0, f * f), p1, vscale(v1, f), vscale(a1, f * f),
                              1.0, narc) > limit:
                    hi = f
                else:
                    lo = f
            f = max(lo, 0.5 ** ARC_BISECT)
            v0 = vscale(v0, f)
            a0 = vscale(a0, f * f)
            v1 = vscale(v1, f)
            a1 = vscale(a1, f * f)
            arc = spline_arc(p0, v0, a0, p1, v1, a1, 1.0, narc)
        frame = ra
        t_prev = 0.0
        # First pass: transported frames at each interior body's parameter.
        for j in range(adr, adr + num):
            t = P.segbody_t[j]
            if rest_arc > EPS:
                t = spline_param_at_arc(p0, v0, a0, p1, v1, a1, P.segbody_share[j] * arc, narc)
            segbody_tp[j] = t
            frame = transport_frame(p0, v0, a0, p1, v1, a1, frame, t_prev, t, nsub)
            t_prev = t
            body = P.segbody_body[j]
            set4(out_rot, body, frame)
            set3(out_pos, body, hermite5_point(p0, v0, a0, p1, v1, a1, t))
        frame_end = transport_frame(p0, v0, a0, p1, v1, a1, frame, t_prev, 1.0, nsub)
        # The end body may be twisted about the spine relative to the transported frame
        # by more (or less) than at rest: spread that twist linearly along the spline.
        delta = qmul(qmul(qconj(frame_end), rb), qconj(q4(P.seg_rest_twist, g)))
        axis_local = qrot(qconj(ra), hermite5_tangent(p0, v0, a0, p1, v1, a1, 0.0))
        n_ax = vnorm(axis_local)
        theta = 0.0
        if n_ax > EPS:
            axis_local = vscale(axis_local, 1.0 / n_ax)
            theta = twist_angle(delta, axis_local)
        for j in range(adr, adr + num):
            body = P.segbody_body[j]
            t = segbody_tp[j]
            fr = qmul(q4(out_rot, body), qaxis_angle(axis_local, theta * t))
            rot = qnormalize(qmul(fr, q4(P.segbody_rot, j)))
            joint = vadd(v3(out_pos, body), qrot(fr, v3(P.segbody_off, j)))
            set4(out_rot, body, rot)
            set3(out_pos, body, vadd(joint, qrot(rot, v3(P.b_joint_offset, body))))
    # The spline places every spine joint; the transported frames point each body along
    # the spline's tangent at its own joint, which on a tightly bent spine (a capture's
    # short lower back folding forward) misses the next joint by up to half a bone. Swing
    # each spine body (not the root, whose frame is given) about its joint so it points at
    # its outward neighbour's joint: the spine stays in one piece and keeps its twist.
    # With the ground on, the interior bodies are first lifted out of it (twice: the aim
    # turns the lifted boxes a little, the second round takes what that put back under).
    for _round in range(2 if ground_on else 1):
        for g in range(P.seg_a.shape[0]):
            adr = P.seg_body_adr[g]
            num = P.seg_body_num[g]
            if ground_on and num > 0:
                _ground_interior(P.segbody_body, P.b_extent, P.b_floor, adr, num, gn, gd, segbody_tp, segbody_lift,
                                 out_pos, out_rot)
            prev = P.sp_body[P.seg_a[g]]
            for j in range(adr, adr + num + 1):
                nxt = P.segbody_body[j] if j < adr + num else P.sp_body[P.seg_b[g]]
                if prev != 0 and P.b_parent[nxt] == prev:
                    _aim_at_child(P, prev, nxt, goal_pos_w, goal_rot_w, out_pos, out_rot)
                prev = nxt


@njit(cache=True, _nrt=False, inline="always")
def _aim_at_child(P, x, y, goal_pos_w, goal_rot_w, out_pos, out_rot):
    """Swing body ``x`` about its joint so that its child ``y``'s joint lies on its bone.
    A body held at a goal of its own swings only as far as the goal leaves it free: with
    ``goal_aim`` 1 (the default) as far as its position and rotation weights together
    (pw * rw) pin it, since a full pose goal (a crawler's pseudo-foot on the ground) says
    where the body is and a swing would lift its origin off the goal, while a position-only
    goal leaves the rotation to the spine (the brace in the spine phase has put the child's
    joint where the body can point at it with its origin on the goal); with ``goal_aim`` 0
    as far as its position weight alone (a spine held at position goals comes apart). An
    origin on its joint is not moved by the swing, so such a body always aims."""
    w = 0.0
    for gi in range(P.goal_body.shape[0]):
        if P.goal_body[gi] == x:
            w = min(max(goal_pos_w[x], 0.0), 1.0)
            if int(P.params[P_GOAL_AIM]) == 1:
                w *= min(max(goal_rot_w[x], 0.0), 1.0)
    off = v3(P.b_joint_offset, x)
    if vnorm(off) <= EPS:
        w = 0.0
    if w >= 1.0:
        return
    rx = q4(out_rot, x)
    jx = vsub(v3(out_pos, x), qrot(rx, off))
    jy = vsub(v3(out_pos, y), qrot(q4(out_rot, y), v3(P.b_joint_offset, y)))
    cur = qrot(rx, vadd(off, v3(P.b_local_joint, y)))
    want = vsub(jy, jx)
    if vnorm(cur) > EPS and vnorm(want) > EPS:
        d = qbetween(cur, want)
        if w > 0.0:
            d = qslerp((1.0, 0.0, 0.0, 0.0), d, 1.0 - w)
        rx = qnormalize(qmul(d, rx))
        set4(out_rot, x, rx)
        set3(out_pos, x, vadd(jx, qrot(rx, off)))


@njit(cache=True, _nrt=False, forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _limb_phase(P, goal_pos, goal_pos_w, goal_rot, goal_rot_w, goal_joint, lp_pos, lp_rest, lp_inv,
                out_pos, out_rot, lg_target, lg_jtarget, scratch, ground_on, gn, gd):
    """Section 4.3.3: particles at every limb joint, aimed at the goals (serial chains and,
    recursively with weighted goal averages, branches), constraint iterations, then
    positions by outward projection and orientations by minimal twist from the rest pose
    (or from two constraint axes where cross-constraints fix the frame)."""
    prm = P.params
    nlp = P.lp_body.shape[0]
    # Rest pose of each limb carried rigidly by its posed spine attachment body.
    for i in range(nlp):
        s = P.lp_attach[i]
        ps = v3(out_pos, s)
        rs = q4(out_rot, s)
        set3(lp_rest, i, vadd(ps, qrot(rs, v3(P.lp_local, i))))
        set3(lp_pos, i, vadd(ps, qrot(rs, v3(P.lp_init_local, i))))
        lp_inv[i] = 0.0 if P.lp_parent[i] < 0 else 1.0
    # Where each goal pins its particles (fixed during the iterations: the limb roots do
    # not move in this phase).
    for gi in range(P.goal_body.shape[0]):
        if P.goal_lp[gi] < 0:
            continue
        set3(lg_target, gi, _limb_target(P.goal_lpj, P.goal_body, P.goal_lproot, P.goal_reach, prm[P_SOFT_REACH],
                                         goal_pos, goal_joint, lp_pos, gi))
        if P.goal_lpj[gi] >= 0:
            set3(lg_jtarget, gi, soft_reach(v3(goal_joint, gi), v3(lp_pos, P.goal_lproot[gi]), P.goal_reachj[gi],
                                            P.params[P_SOFT_REACH]))
    # A goal of weight w < 1 pins its particle w of the way from where the limb starts
    # (carried by the spine, at rest) to its target: the pose follows the weight, and a
    # goal fading to 0 hands the limb back to its rest pose without a step.
    for gi in range(P.goal_body.shape[0]):
        i = P.goal_lp[gi]
        if i < 0:
            continue
        b = P.goal_body[gi]
        w = min(max(goal_pos_w[b], 0.0), 1.0)
        if 0.0 < w < 1.0:
            set3(lg_target, gi, vlerp(v3(lp_pos, i), v3(lg_target, gi), w))
        j = P.goal_lpj[gi]
        if j >= 0:
            wj = min(w, min(max(goal_rot_w[b], 0.0), 1.0))
            if 0.0 < wj < 1.0:
                set3(lg_jtarget, gi, vlerp(v3(lp_pos, j), v3(lg_jtarget, gi), wj))
    # Aim preconditioner: rotate and scale each group about its pivot so the weighted
    # mean of its goal particles lands on the weighted mean of their goals.
    for g in range(P.ag_pivot.shape[0]):
        piv = v3(lp_pos, P.ag_pivot[g])
        cur = (0.0, 0.0, 0.0)
        tgt = (0.0, 0.0, 0.0)
        wsum = 0.0
        for j in range(P.ag_goal_adr[g], P.ag_goal_adr[g] + P.ag_goal_num[g]):
            gi = P.ag_goal[j]
            w = min(max(goal_pos_w[P.goal_body[gi]], 0.0), 1.0)
            if w <= 0.0:
                continue
            # Aim the goal body's joint particle where it has one (the tip particle at a
            # foot's origin sits off the knee's bend plane: aiming it would read a forward
            # knee as bent backward), else the goal particle itself.
            if P.goal_lpj[gi] >= 0:
                pc = v3(lp_pos, P.goal_lpj[gi])
                gt = v3(lg_jtarget, gi)
            else:
                pc = v3(lp_pos, P.goal_lp[gi])
                gt = v3(lg_target, gi)
            cur = vadd(cur, vscale(pc, w))
            tgt = vadd(tgt, vscale(gt, w))
            wsum += w
        if wsum <= 0.0:
            continue
        vr = vsub(vscale(cur, 1.0 / wsum), piv)
        vg = vsub(vscale(tgt, 1.0 / wsum), piv)
        nr = vnorm(vr)
        ng = vnorm(vg)
        if nr < 1e-9 or ng < 1e-9:
            continue
        # The shortest arc from vr to vg turns about an axis that is arbitrary where the
        # goal lies opposite the limb's rest direction (a hanging arm's hand raised to the
        # mouth or over the head): there the limb turned over between two frames. A limb
        # root's aim goes through ``ag_via`` instead (forward, across the limb: the arm
        # raised in front), which moves that one ill-defined direction to the opposite
        # of ``ag_via`` (straight behind), where goals rarely go.
        via = v3(P.ag_via, g)
        if vdot(via, via) > 0.5:
            w = qrot(q4(out_rot, P.lp_attach[P.ag_pivot[g]]), via)
            rot = qnormalize(qmul(qbetween(w, vg), qbetween(vr, w)))
        else:
            rot = qbetween(vr, vg)
        scale = ng / nr
        ghat = vscale(vg, 1.0 / ng)
        # Squashing along v_g (goal closer than at rest) would flatten the chain onto the
        # line, where the constraint iterations may fold it either way. Unlike the paper
        # we also widen the chain across v_g so its segments keep their length on
        # average: the rest bend grows (knees and elbows fold the way they bend at rest)
        # and the fold is a smooth function of the goal distance.
        widen = 1.0
        if scale < 1.0:
            h2 = 0.0
            nm = P.ag_moved_num[g]
            for j in range(P.ag_moved_adr[g], P.ag_moved_adr[g] + nm):
                y = qrot(rot, vsub(v3(lp_pos, P.ag_moved[j]), piv))
                yp = vsub(y, vscale(ghat, vdot(y, ghat)))
                h2 += vdot(yp, yp)
            h2 /= max(nm, 1)
            if h2 > 1e-12 * nr * nr:
                widen = min(math.sqrt(1.0 + (1.0 - scale * scale) * nr * nr / (4.0 * h2)), 10.0)
        for j in range(P.ag_moved_adr[g], P.ag_moved_adr[g] + P.ag_moved_num[g]):
            m = P.ag_moved[j]
            y = qrot(rot, vsub(v3(lp_pos, m), piv))
            along = vdot(y, ghat)
            across = vsub(y, vscale(ghat, along))
            set3(lp_pos, m, vadd(piv, vadd(vscale(ghat, scale * along), vscale(across, widen))))
    # Goal particles at their goals (weighted), then the constraint iterations.
    collide = P.cl_i[0] > 0   # limbs kept out of the creature's other bodies (issue 16)
    if collide:
        _collide.begin(P, scratch, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot)
    _limb_iterate(P, goal_pos_w, goal_rot_w, lg_target, lg_jtarget, lp_pos, lp_inv, int(prm[P_LIMB_OUTER]),
                  int(prm[P_LIMB_INNER]), lp_rest, out_rot, ground_on, gn, gd, v3(out_pos, 0), collide, scratch,
                  goal_rot, out_pos)
    _soft_reach_stretch(P, goal_pos, goal_pos_w, goal_rot_w, goal_joint, lp_pos)
    _seat_free_joints(P, goal_pos_w, goal_rot_w, lp_pos, lp_rest)
    if collide:
        _collide.resolve(P, scratch, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot, lp_inv)
    _limb_rebuild(P, goal_pos_w, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot)


@njit(cache=True, _nrt=False, inline="always")
def _seat_free_joints(P, goal_pos_w, goal_rot_w, lp_pos, lp_rest):
    """A goal body with a position goal and no rotation goal has its tip pinned and its
    joint free: the joint may sit anywhere on the circle about the line from its
    parent's joint to the tip, and where the iterations leave it on that circle depends
    on where they started, so a small step of the goal can swing the body half a turn
    (a hand or a toe spinning about its wrist or ankle). Seat the joint where the parent
    bone and the goal body, taken as one rigid piece in their rest shape, put it when
    that piece is turned (shortest arc from where the bone above carries it) onto the
    parent-joint-to-tip line: the joint is only turned about that line, so its distances
    to both ends stay what the iterations made them. Only braced tips (bent at rest): a
    straight rest shape says nothing about the side, and there the iterations decide."""
    for gi in range(P.goal_body.shape[0]):
        j = P.goal_lpj[gi]
        if j < 0:
            continue
        e = P.lp_parent[j]
        if e < 0 or P.lp_mode[j] != 4:
            continue
        b = P.goal_body[gi]
        if min(max(goal_pos_w[b], 0.0), 1.0) <= 0.0 or min(max(goal_rot_w[b], 0.0), 1.0) > 0.0:
            continue
        i = P.goal_lp[gi]
        pe = v3(lp_pos, e)
        pj = v3(lp_pos, j)
        pt = v3(lp_pos, i)
        re = v3(lp_rest, e)
        ej_r = vsub(v3(lp_rest, j), re)
        et_r = vsub(v3(lp_rest, i), re)
        et = vsub(pt, pe)
        d = vnorm(et)
        a = vnorm(ej_r)
        bl = vnorm(vsub(v3(lp_rest, i), v3(lp_rest, j)))
        if d < EPS or a < EPS or bl < EPS:
            continue
        u = vscale(et, 1.0 / d)
        g = P.lp_parent[e]
        if g >= 0:
            # The rest shape as the bone above carries it (turned the way the rebuild
            # turns that bone), so the piece turns from nearby, not from the rest pose.
            rg = qbetween(vsub(re, v3(lp_rest, g)), vsub(pe, v3(lp_pos, g)))
            et_r = qrot(rg, et_r)
            ej_r = qrot(rg, ej_r)
        rigid = qrot(qbetween(et_r, et), ej_r)
        rp = vsub(rigid, vscale(u, vdot(rigid, u)))
        ij = vsub(pj, pe)
        ip = vsub(ij, vscale(u, vdot(ij, u)))
        nrp = vnorm(rp)
        nip = vnorm(ip)
        side = vscale(ip, 1.0 / max(nip, EPS))
        # Trust the rest shape's side where it is clearly bent (the joint more than 0.3
        # of the body's length off the line), the fallback where it is nearly straight
        # (below 0.1), and blend in between.
        f = smoothstep((nrp / bl - 0.1) / 0.2)
        side = vadd(vscale(rp, f / max(nrp, EPS)), vscale(side, 1.0 - f))
        ns = vnorm(side)
        if ns < EPS:
            continue
        # Only turn the joint about the line (its distances to both ends, which the
        # iterations and the soft reach set, stay as they are).
        set3(lp_pos, j, vadd(pe, vadd(vscale(u, vdot(ij, u)), vscale(side, nip / ns))))


@njit(cache=True, _nrt=False, inline="always")
def _soft_reach_stretch(P, goal_pos, goal_pos_w, goal_rot_w, goal_joint, lp_pos):
    """The soft reach bent a serial limb as if its goal were a little closer; now stretch
    the limb uniformly about its root (within the allowed stretch) so its end meets the
    real goal: the knee's angle is eased, the goal still met up to full reach."""
    kmax = P.params[P_LIMB_STRETCH]
    for g in range(P.ag_pivot.shape[0]):
        root = P.ag_pivot[g]
        if P.lp_parent[root] >= 0 or P.ag_goal_num[g] != 1:
            continue
        gi = P.ag_goal[P.ag_goal_adr[g]]
        b = P.goal_body[gi]
        if min(max(goal_pos_w[b], 0.0), 1.0) <= 0.0:
            continue
        r = v3(lp_pos, root)
        soft = P.params[P_SOFT_REACH]
        # Stretch for the joint target (what a rotation goal places the body by) ...
        tj = v3(goal_joint, gi)
        ej = vnorm(vsub(soft_reach(tj, r, P.goal_reachj[gi], soft), r))
        k = vnorm(vsub(tj, r)) / ej if ej > EPS else 1.0
        if P.goal_lpj[gi] >= 0:
            # ... and for the tip (what places it without one), blended by the rotation weight.
            tt = v3(goal_pos, b)
            et = vnorm(vsub(soft_reach(tt, r, P.goal_reach[gi], soft), r))
            kt = vnorm(vsub(tt, r)) / et if et > EPS else 1.0
            wr = min(max(goal_rot_w[b], 0.0), 1.0)
            k = kt + wr * (k - kt)
        k = min(k, kmax)
        k = 1.0 + min(max(goal_pos_w[b], 0.0), 1.0) * (k - 1.0)    # a fading goal stretches less
        if k <= 1.0 + 1e-12:
            continue
        for j in range(P.ag_moved_adr[g], P.ag_moved_adr[g] + P.ag_moved_num[g]):
            m = P.ag_moved[j]
            set3(lp_pos, m, vadd(r, vscale(vsub(v3(lp_pos, m), r), k)))


@njit(cache=True, _nrt=False)
def soft_reach(target, origin, reach, soft):
    """Soft reach (no knee pop): past ``soft * reach`` from ``origin`` the distance of a
    target is eased toward ``reach`` exponentially, C1 at the join, so as a goal moves out
    to and beyond full reach the limb straightens at a bounded rate and then only turns
    to point at it; inside ``soft * reach`` the target is untouched. With ``soft`` = 1
    the target is only clamped to full reach (a pinned goal out of reach would otherwise
    drag the chain's last segments into whatever the projection leaves)."""
    if reach <= 0.0:
        return target
    d = vsub(target, origin)
    dist = vnorm(d)
    ds = soft * reach
    if dist <= ds:
        return target
    if soft >= 1.0:
        eased = reach  # no easing: only clamped to full reach
    else:
        eased = reach - (reach - ds) * math.exp(-(dist - ds) / (reach - ds))
    return vadd(origin, vscale(d, eased / dist))


@njit(cache=True, _nrt=False, inline="always")
def _limb_target(goal_lpj, goal_body, goal_lproot, goal_reach, soft, goal_pos, goal_joint, lp_pos, gi):
    """Where goal ``gi`` pins its limb particle: a tip particle (at the body's origin) goes
    to the position goal itself, a joint particle to the goal converted to the joint;
    both within the limb's soft reach."""
    if goal_lpj[gi] >= 0:
        t = v3(goal_pos, goal_body[gi])
    else:
        t = v3(goal_joint, gi)
    return soft_reach(t, v3(lp_pos, goal_lproot[gi]), goal_reach[gi], soft)


@njit(cache=True, _nrt=False, inline="always")
def _pin_limb_goals(goal_body, goal_lp, goal_lpj, lp_parent, goal_pos_w, goal_rot_w, lg_target, lg_jtarget, lp_pos,
                    lp_inv, first):
    """Pin goal particles at their targets (``_limb_phase`` blends a target by its goal's
    weight from where the limb starts) and make them immovable by the constraints; the
    inner sweeps (``first`` False) leave them there, the outer projections move them and
    they are pinned again. A body with a tip particle has its tip pinned at
    the position goal and, as far as it has a rotation goal, its joint at the 6-DOF goal
    converted to the joint (4.3.1); without a rotation goal the joint is free and the tip
    decides the body's direction, so position-only goals are met exactly."""
    for gi in range(goal_body.shape[0]):
        i = goal_lp[gi]
        if i < 0 or lp_parent[i] < 0:
            continue
        b = goal_body[gi]
        w = min(max(goal_pos_w[b], 0.0), 1.0)
        if w > 0.0 and first:
            set3(lp_pos, i, v3(lg_target, gi))
            lp_inv[i] = 0.0
        j = goal_lpj[gi]
        if j >= 0 and lp_parent[j] >= 0:
            wj = min(w, min(max(goal_rot_w[b], 0.0), 1.0))
            if wj > 0.0 and first:
                set3(lp_pos, j, v3(lg_jtarget, gi))
                lp_inv[j] = 0.0


@njit(cache=True, _nrt=False, forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _limb_iterate(P, goal_pos_w, goal_rot_w, lg_target, lg_jtarget, lp_pos, lp_inv, n_outer, n_inner, lp_rest,
                  out_rot, ground_on, gn, gd, ctr, collide, scratch, goal_rot, out_pos):
    """Pin the goal particles (weighted), then ``n_outer`` times: ``n_inner`` sweeps of the
    constraints leaves inward, and an outward projection of every particle to its allowed
    stretch from its parent. The inward sweeps carry the goal error toward the spine; the
    projection carries what is left back out, so a chain settles in a few iterations
    (the same projection ends the solve, section 4.3.3 "Reconstruction")."""
    prm = P.params
    slope, band, width = prm[P_SOFT_SLOPE], prm[P_SOFT_BAND], prm[P_SOFT_WIDTH]
    goal_body, goal_lp, goal_lpj, lp_parent = P.goal_body, P.goal_lp, P.goal_lpj, P.lp_parent
    _pin_limb_goals(goal_body, goal_lp, goal_lpj, lp_parent, goal_pos_w, goal_rot_w, lg_target, lg_jtarget, lp_pos,
                    lp_inv, True)
    nlc = P.lc_a.shape[0]
    nlp = P.lp_body.shape[0]
    push = collide and prm[P_CONTACT_ITERATE] > 0.0
    for _outer in range(n_outer):
        if _outer > 0:
            for i in range(nlp):
                c = P.lp_con[i]
                if c >= 0:
                    project_length(lp_pos, P.lp_parent[i], i, P.lc_len[c], P.lc_plo[c], P.lc_phi[c])
            _pin_limb_goals(goal_body, goal_lp, goal_lpj, lp_parent, goal_pos_w, goal_rot_w, lg_target, lg_jtarget,
                            lp_pos, lp_inv, True)
            if push:
                # contacts pushed with the goals held; the sweeps below route the limb
                _collide.push_round(P, scratch, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot, lp_inv)
        for _inner in range(n_inner):
            if ground_on:
                # lifted first, so the sweep that follows puts the lengths right again
                _ground_limbs(P.lp_body, lp_parent, P.lp_mode, P.lp_c1, P.lp_attach, P.lp_rot_local,
                              P.b_joint_offset, P.b_extent, P.b_floor, P.b_ground_r, gn, gd, out_rot, lp_rest, lp_pos,
                              lp_inv, goal_body, goal_lp, goal_lpj, goal_pos_w, goal_rot_w, lg_target, lg_jtarget,
                              ctr)
            for c in range(nlc):
                stiff = 1.0
                gi = P.lc_goal[c]
                if gi >= 0:
                    # A tip's brace to the parent joint keeps the body at its rest angle
                    # to its parent, as far as no rotation goal says otherwise.
                    stiff = 1.0 - min(max(goal_rot_w[P.goal_body[gi]], 0.0), 1.0)
                    if stiff <= 0.0:
                        continue
                relax_constraint(lp_pos, lp_inv, P.lc_a[c], P.lc_b[c], P.lc_len[c], P.lc_lo[c],
                                 P.lc_hi[c], P.lc_inva[c], P.lc_invb[c], stiff, slope, band, width)
            _pin_limb_goals(goal_body, goal_lp, goal_lpj, lp_parent, goal_pos_w, goal_rot_w, lg_target, lg_jtarget,
                            lp_pos, lp_inv, False)


@njit(cache=True, _nrt=False, forceinline=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _limb_rebuild(P, goal_pos_w, goal_rot, goal_rot_w, lp_pos, lp_rest, out_pos, out_rot):
    """Limb reconstruction (4.3.3): positions by outward projection to the allowed
    stretch, orientations by minimal twist from the rest pose, or from two constraint
    axes where cross-constraints fix the frame; rotation goals blended in, keeping every
    child's joint on its parent."""
    nlp = P.lp_body.shape[0]
    # Positions: outward projection to the allowed stretch (particles are parents first).
    for i in range(nlp):
        c = P.lp_con[i]
        if c >= 0:
            project_length(lp_pos, P.lp_parent[i], i, P.lc_len[c], P.lc_plo[c], P.lc_phi[c])
    # Orientations, parents first.
    for i in range(nlp):
        mode = P.lp_mode[i]
        if mode == 3:
            continue
        b = P.lp_body[i]
        s = P.lp_attach[i]
        _seat_on_parent(P, i, b, goal_pos_w, lp_pos, out_pos, out_rot)
        rest_rot = qmul(q4(out_rot, s), q4(P.lp_rot_local, i))
        if mode == 2:
            rot = qmul(q4(out_rot, P.b_parent[b]), q4(P.b_local_rot, b))
        elif mode == 4:
            # A braced tip body: carried by its parent, then swung so its origin points
            # at its tip particle (its twist is the parent's: never ill-defined).
            carried = qmul(q4(out_rot, P.b_parent[b]), q4(P.b_local_rot, b))
            rot = qmul(qbetween(qrot(carried, v3(P.b_joint_offset, b)),
                                vsub(v3(lp_pos, P.lp_c1[i]), v3(lp_pos, i))), carried)
        else:
            c1 = P.lp_c1[i]
            e1p = vsub(v3(lp_pos, c1), v3(lp_pos, i))
            dref = v3(P.lp_ref_dir, i)
            if vdot(dref, dref) > 0.5:
                # carried by the parent and turned from the reference chord, whose
                # opposite is a pose limbs do not take (plan.py ``_rebuild_refs``)
                qref = q4(out_rot, P.lp_body[P.lp_parent[i]])
                rot = qmul(qbetween(qrot(qref, dref), e1p), qmul(qref, q4(P.lp_ref_rot, i)))
                swing = qmul(rot, qconj(rest_rot))
            else:
                e1r = vsub(v3(lp_rest, c1), v3(lp_rest, i))
                swing = qbetween(e1r, e1p)
                rot = qmul(swing, rest_rot)
            if mode == 1:
                # Cross-constraints fix the frame: turn about the first axis until the
                # second axis lies in its posed plane.
                c2 = P.lp_c2[i]
                ax = e1p
                nax = vnorm(ax)
                if nax > EPS:
                    ax = vscale(ax, 1.0 / nax)
                    e2r = qrot(swing, vsub(v3(lp_rest, c2), v3(lp_rest, i)))
                    e2p = vsub(v3(lp_pos, c2), v3(lp_pos, i))
                    u = vsub(e2r, vscale(ax, vdot(e2r, ax)))
                    v = vsub(e2p, vscale(ax, vdot(e2p, ax)))
                    nu = vnorm(u)
                    nv = vnorm(v)
                    if nu > 1e-9 and nv > 1e-9:
                        ang = math.atan2(vdot(ax, vcross(u, v)), vdot(u, v))
                        # Where the two axes are (nearly) parallel the second one says
                        # nothing about the twist: fade to the minimal twist so the frame
                        # never jumps (sines below 0.05 ignore it, above 0.2 trust it).
                        sin_lo = min(nu / (vnorm(e2r) + EPS), nv / (vnorm(e2p) + EPS))
                        ang *= smoothstep((sin_lo - 0.05) / 0.15)
                        rot = qmul(qaxis_angle(ax, ang), rot)
        gi = P.lp_goal[i]
        if mode == 0 and P.lp_body[P.lp_c1[i]] == b:
            # A leaf held at its origin by its tip particle: its chord is short beside the
            # limb, so as a fading goal lets the tip go a millimetre of the wrist swings it
            # through a large angle. It turns with the goal's weight from the pose its
            # parent carries it in (where the clip and Jiggles leave it) to its chord.
            wp = min(max(goal_pos_w[b], 0.0), 1.0)
            if wp < 1.0:
                carried = qmul(q4(out_rot, P.b_parent[b]), q4(P.b_local_rot, b))
                rot = qslerp(carried, qnormalize(rot), wp)
        if gi >= 0:
            wr = min(max(goal_rot_w[b], 0.0), 1.0)
            if wr > 0.0:
                c1 = P.lp_c1[i]
                if mode <= 1 and c1 >= 0 and P.lp_parent[c1] == i and P.lp_mode[c1] != 3:
                    # A body with a limb joint below it (a tail segment, a forearm): its
                    # child's joint stays on it. The chord to that joint turns with the
                    # rotation goal where nothing below is pinned by a position goal (the
                    # particles below turn with it), else the body keeps the chord the
                    # constraints gave and the goal sets only its twist about it.
                    local = qrot(qconj(rot), vsub(v3(lp_pos, c1), v3(lp_pos, i)))
                    rot = qnormalize(qslerp(rot, q4(goal_rot, b), wr))
                    want = qrot(rot, local)
                    piv = v3(lp_pos, i)
                    e1p = vsub(v3(lp_pos, c1), piv)
                    if not _pinned_below(P, c1, goal_pos_w):
                        d = qbetween(e1p, want)
                        for k in range(c1, nlp):
                            if _particle_below(P.lp_parent, k, c1):
                                set3(lp_pos, k, vadd(piv, qrot(d, vsub(v3(lp_pos, k), piv))))
                        e1p = vsub(v3(lp_pos, c1), piv)
                    rot = qmul(qbetween(qrot(rot, local), e1p), rot)
                else:
                    rot = qslerp(rot, q4(goal_rot, b), wr)
        rot = qnormalize(rot)
        set4(out_rot, b, rot)
        set3(out_pos, b, vadd(v3(lp_pos, i), qrot(rot, v3(P.b_joint_offset, b))))


@njit(cache=True, _nrt=False, inline="always")
def _seat_on_parent(P, i, b, goal_pos_w, lp_pos, out_pos, out_rot):
    """Put limb particle ``i`` (body ``b``'s joint) where its parent body's final frame
    holds that joint, carrying the particles below it along, unless ``i`` is the joint the
    parent's chord was rebuilt on (its first axis child: on the chord, stretched as the
    limb allows). A parent's other children (a head's eyes, ears and jaw beside the chord
    its rebuild took, a foot's second toe) are held to it only by their distance to its
    joint, so they drifted round it while the parent turned to its own rotation goal
    (the gorilla's eye 4.8 cm off its head in ``perform``). A position goal below ``i``
    keeps that share of the particle where the constraints put it (weights fade: no pop)."""
    p = P.lp_parent[i]
    if p < 0 or P.lp_c1[p] == i:
        return
    pb = P.lp_body[p]
    if P.b_parent[b] != pb:
        return
    w = 0.0
    nlp = P.lp_body.shape[0]
    for k in range(i, nlp):
        if P.lp_goal[k] >= 0 and _particle_below(P.lp_parent, k, i):
            w = max(w, min(max(goal_pos_w[P.lp_body[k]], 0.0), 1.0))
    if w >= 1.0:
        return
    target = vadd(v3(out_pos, pb), qrot(q4(out_rot, pb), v3(P.b_local_joint, b)))
    d = vscale(vsub(target, v3(lp_pos, i)), 1.0 - w)
    for k in range(i, nlp):
        if _particle_below(P.lp_parent, k, i):
            set3(lp_pos, k, vadd(v3(lp_pos, k), d))


@njit(cache=True, _nrt=False, inline="always")
def _particle_below(lp_parent, k, c):
    """Whether limb particle ``k`` is ``c`` or hangs below it (particles are parents first)."""
    while k > c:
        k = lp_parent[k]
    return k == c


@njit(cache=True, _nrt=False, inline="always")
def _pinned_below(P, c, goal_pos_w):
    """Whether a position goal pins particle ``c`` or one below it."""
    for k in range(c, P.lp_body.shape[0]):
        if P.lp_goal[k] >= 0 and goal_pos_w[P.lp_body[k]] > 0.0 and _particle_below(P.lp_parent, k, c):
            return True
    return False


@njit(cache=True, _nrt=False, inline="always")
def _place_rigid(P, out_pos, out_rot):
    """Delegated bodies ride rigidly on their spine parent (the spine bent for them)."""
    for k in range(P.rg_body.shape[0]):
        b = P.rg_body[k]
        p = P.b_parent[b]
        rp = q4(out_rot, p)
        set4(out_rot, b, qnormalize(qmul(rp, q4(P.b_local_rot, b))))
        set3(out_pos, b, vadd(v3(out_pos, p), qrot(rp, v3(P.b_local_pos, b))))


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def solve_one(P, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w, goal_rot_w, out_pos, out_rot,
              scratch, ground):
    """One whole solve: goals to joint targets, spine phase, root influence, spine
    reconstruction, rigid delegated bodies, limb phase. Writes the IK sub-tree only.
    ``ground`` (nx, ny, nz, d): the plane n . x = d under the character in the solve's
    (character) space, n pointing up (any length); a zero normal, or ``IKParams.ground``
    off, leaves the ground out."""
    (sp_pos, sp_inv, lp_pos, lp_rest, lp_inv, goal_joint, ch_tan, state, dg_target, sp_acc, lg_target,
     lg_jtarget, segbody_tp, segbody_lift) = _scratch_views(P, scratch)
    rr = qnormalize(root_rot)
    gl = vnorm((ground[0], ground[1], ground[2]))
    ground_on = P.params[P_GROUND] > 0.0 and gl > EPS and math.isfinite(gl) and math.isfinite(ground[3])
    gn = (0.0, 0.0, 1.0)
    gd = 0.0
    if ground_on:
        gn = (ground[0] / gl, ground[1] / gl, ground[2] / gl)
        gd = ground[3] / gl
    _goal_targets(P, root_pos, rr, goal_pos, goal_rot, goal_pos_w, goal_rot_w, goal_joint)
    _delegated_targets(P, goal_rot, goal_rot_w, goal_joint, dg_target)
    root_rot_in = rr
    for _round in range(3):
        _spine_phase(P, root_pos, root_rot_in, goal_pos_w, goal_rot_w, goal_joint, dg_target, sp_pos, sp_inv,
                     state, sp_acc, ground_on, gn, gd)
        rr = _root_influence(P, root_pos, root_rot_in, sp_pos)
        _spine_reconstruct(P, root_pos, rr, goal_pos_w, goal_rot, goal_rot_w, sp_pos, ch_tan, segbody_tp,
                           out_pos, out_rot, state[0], ground_on, gn, gd, segbody_lift)
        _place_rigid(P, out_pos, out_rot)
        # A spine or delegated goal without a full rotation goal was converted to its joint
        # with an estimated rotation; convert again with the rotation the spine gave it
        # and, if the target moved, solve the spine again (from rest: still path
        # independent). A fixed-point iteration of at most 3 rounds.
        moved = 0.0
        for gi in range(P.goal_body.shape[0]):
            db = P.goal_body[gi]
            i = P.goal_sp[gi]
            if i < 0 or P.sp_kind[i] == 0 or goal_pos_w[db] <= 0.0 or goal_rot_w[db] >= 1.0:
                continue
            if P.sp_kind[i] == 2 and P.goal_limb_root[gi] != 0:
                continue  # a limb goal: its rotation comes from the limb phase
            target = vsub(v3(goal_pos, db), qrot(q4(out_rot, db), v3(P.b_joint_offset, db)))
            moved = max(moved, vnorm(vsub(target, v3(goal_joint, gi))))
            set3(goal_joint, gi, target)
        if moved <= 1e-7:
            break
    # goals inside the creature's own bodies moved to their surface (issue 16; a copy:
    # the caller's goals are not written)
    goal_limb = _collide.settle_goals(P, scratch, goal_pos, goal_pos_w, goal_joint, out_pos, out_rot)
    # P_GROUND 1: both phases keep boxes above the ground; 0.5: the spine phase only
    _limb_phase(P, goal_limb, goal_pos_w, goal_rot, goal_rot_w, goal_joint, lp_pos, lp_rest, lp_inv,
                out_pos, out_rot, lg_target, lg_jtarget, scratch, ground_on and P.params[P_GROUND] >= 1.0, gn, gd)


@njit(cache=True, _nrt=False)
def settle_packed(plan_i, plan_f, plan_f3, plan_f4, goal_pos, goal_pos_w, body_pos, body_rot, scratch):
    """The limb phase's settled goals (``_collide.settle_goals``) for a posed creature
    whose spine and root are ``body_pos``/``body_rot``: written into the scratch rows the
    solve uses (``engine.ik.selfcollision.settled_goals`` reads them)."""
    P = unpack(plan_i, plan_f, plan_f3, plan_f4)
    views = _scratch_views(P, scratch)
    _collide.settle_goals(P, scratch, goal_pos, goal_pos_w, views[5], body_pos, body_rot)


@njit(cache=True, _nrt=False, inline="always")
def check_inputs(P, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w, goal_rot_w):
    """-1 when the inputs are usable; -2 for a bad root pose; else the first goal body
    with a non-finite goal, a weight outside [0, 1] or a zero rotation goal. Checked in
    the kernel before anything is written, so bad input never reaches the output."""
    for j in range(3):
        if not math.isfinite(root_pos[j]):
            return -2
    n = 0.0
    for j in range(4):
        if not math.isfinite(root_rot[j]):
            return -2
        n += root_rot[j] * root_rot[j]
    if n < 1e-12:
        return -2
    for gi in range(P.goal_body.shape[0]):
        g = P.goal_body[gi]
        wp = goal_pos_w[g]
        wr = goal_rot_w[g]
        if not (0.0 <= wp <= 1.0) or not (0.0 <= wr <= 1.0):
            return g
        for j in range(3):
            if wp > 0.0 and not math.isfinite(goal_pos[g, j]):
                return g
        if wr > 0.0:
            qn = 0.0
            for j in range(4):
                if not math.isfinite(goal_rot[g, j]):
                    return g
                qn += goal_rot[g, j] * goal_rot[g, j]
            if qn < 1e-12:
                return g
    return -1


@njit(cache=True, _nrt=False)
def solve_packed(plan_i, plan_f, plan_f3, plan_f4, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w, goal_rot_w,
                 out_pos, out_rot, scratch, ground):
    """One solve from the plan blobs; see ``engine.ik.solver.solve_ik``; ``ground`` (4,)
    the plane under the character (``solve_one``). Returns the ``check_inputs`` code
    (-1 = solved)."""
    P = unpack(plan_i, plan_f, plan_f3, plan_f4)
    bad = check_inputs(P, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w, goal_rot_w)
    if bad != -1:
        return bad
    solve_one(P, (root_pos[0], root_pos[1], root_pos[2]),
              (root_rot[0], root_rot[1], root_rot[2], root_rot[3]),
              goal_pos, goal_rot, goal_pos_w, goal_rot_w, out_pos, out_rot, scratch,
              (ground[0], ground[1], ground[2], ground[3]))
    return -1


@njit(cache=True, _nrt=False)
def solve_packed_batch(plan_i, plan_f, plan_f3, plan_f4, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w,
                       goal_rot_w, out_pos, out_rot, scratch, bad, ground):
    """Many independent solves sharing one plan (a crowd): inputs stacked on a leading
    axis of length n, one scratch reused in turn. ``bad[c]`` gets character c's
    ``check_inputs`` code; a character with bad input is skipped, the others solved.
    ``ground`` (n, 4): each character's ground plane (``solve_one``)."""
    P = unpack(plan_i, plan_f, plan_f3, plan_f4)
    nbad = 0
    for c in range(root_pos.shape[0]):
        nbad += solve_row(P, c, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w, goal_rot_w, out_pos, out_rot,
                          scratch, bad, (ground[c, 0], ground[c, 1], ground[c, 2], ground[c, 3]))
    return nbad


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def solve_row(P, c, root_pos, root_rot, goal_pos, goal_rot, goal_pos_w, goal_rot_w, out_pos, out_rot, scratch, bad,
              ground):
    """Row ``c`` of stacked inputs (leading axis over characters): checks its input into
    ``bad[c]`` and solves it if usable (``ground``: its plane, a 4-tuple, ``solve_one``);
    returns 1 for a bad row, else 0. The row views are
    borrowed (see ``borrow``): threads solving other rows never touch a shared count."""
    gp = borrow(goal_pos[c])
    gr = borrow(goal_rot[c])
    gpw = borrow(goal_pos_w[c])
    grw = borrow(goal_rot_w[c])
    rp = borrow(root_pos[c])
    rr = borrow(root_rot[c])
    code = check_inputs(P, rp, rr, gp, gr, gpw, grw)
    bad[c] = code
    if code != -1:
        return 1
    solve_one(P, (rp[0], rp[1], rp[2]), (rr[0], rr[1], rr[2], rr[3]), gp, gr, gpw, grw, borrow(out_pos[c]),
              borrow(out_rot[c]), borrow(scratch), ground)
    return 0


@njit(cache=True, _nrt=False)
def transport_rest(p0, v0, a0, p1, v1, a1, frame0, ts, nsub, out_frames, out_points):
    """Rest-pose helper for the plan builder: transported frames and spline points at the
    parameters ``ts`` (same steps as the solve, so a rest-pose solve reproduces the rest
    pose exactly), and the frame at t = 1 as the return value."""
    frame = frame0
    t_prev = 0.0
    for j in range(ts.shape[0]):
        frame = transport_frame(p0, v0, a0, p1, v1, a1, frame, t_prev, ts[j], nsub)
        t_prev = ts[j]
        set4(out_frames, j, frame)
        set3(out_points, j, hermite5_point(p0, v0, a0, p1, v1, a1, ts[j]))
    return transport_frame(p0, v0, a0, p1, v1, a1, frame, t_prev, 1.0, nsub)


def _check_layout():
    assert len(PlanArrays._fields) == len(INT_FIELDS) + len(FLOAT_FIELDS) == 51 + 52


_check_layout()
