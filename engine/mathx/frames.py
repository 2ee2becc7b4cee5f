"""Frames carried along curves: minimal-twist rotations and parallel frame transport.

Hecker 2008 sec 4.3.2 rebuilds a creature's spine from a few IK particles: the
orientation of a particle's spine body is its root-relative rest orientation turned by
"the minimal-twist rotation between" its rest tangent and its posed tangent
(``minimal_twist_rotate``), and the spine bodies between particles are placed by
stepping along the posed spine spline "transporting a coordinate frame" with it
(``frame_transport``). Both turn frames only about axes perpendicular to the tangent, so
a spine never picks up twist it did not have at rest.

All functions are ``@njit(cache=True)``, float64, quaternions (w, x, y, z).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from engine.mathx.quat import _normalize4, quat_between_t, quat_mul_t
from engine.mathx.spline import hermite5_deriv_t, hermite5_t


@njit(cache=True)
def minimal_twist_rotate_t(rest_rot, rest_dir, new_dir):
    """quat_between(rest_dir, new_dir) * rest_rot as a (w, x, y, z) tuple (inputs may be
    arrays or tuples)."""
    return quat_mul_t(quat_between_t(rest_dir, new_dir), rest_rot)


@njit(cache=True)
def minimal_twist_rotate_into(rest_rot, rest_dir, new_dir, out):
    """out = quat_between(rest_dir, new_dir) * rest_rot: the rest orientation turned by
    the shortest-arc rotation taking the rest tangent to the new one (Hecker 2008 sec
    4.3.2: "construct the minimal-twist rotation between these tangents and use it to
    rotate the root-relative rest orientation"). A zero-length direction leaves
    rest_rot unchanged. out may alias any input."""
    w, x, y, z = minimal_twist_rotate_t(rest_rot, rest_dir, new_dir)
    out[0] = w
    out[1] = x
    out[2] = y
    out[3] = z
    return out


@njit(cache=True)
def minimal_twist_rotate(rest_rot, rest_dir, new_dir):
    """quat_between(rest_dir, new_dir) * rest_rot, a new (4,) array."""
    return minimal_twist_rotate_into(rest_rot, rest_dir, new_dir, np.empty(4))


@njit(cache=True)
def polyline_tangent_into(points, i, out):
    """out (3,) = the (unnormalized) tangent of the polyline ``points`` (n, 3) at point i
    used by ``frame_transport``: the central difference points[i+1] - points[i-1] at
    interior points (parallel to the circle's tangent at evenly spaced points of a
    circle, and to (p_{i+1} - p_{i-1}) / 2 of Hecker 2008 sec 4.3.2), the one-sided
    difference points[1] - points[0] at the first point and points[n-1] - points[n-2]
    at the last. A single point has tangent 0."""
    n = points.shape[0]
    if n < 2:
        out[0] = 0.0
        out[1] = 0.0
        out[2] = 0.0
        return out
    lo = i - 1 if i > 0 else 0
    hi = i + 1 if i < n - 1 else n - 1
    for k in range(3):
        out[k] = points[hi, k] - points[lo, k]
    return out


@njit(cache=True)
def _transport(points, t0x, t0y, t0z, rot0, out_rots):
    # Parallel transport (Hecker 2008 sec 4.3.2, "frame transport"): each frame is the
    # previous one turned by the minimal-twist rotation between their tangents, so the
    # frame turns only with the curve and never about it. A zero tangent (repeated
    # points) carries the frame unchanged and is skipped as a reference, so the next
    # nonzero tangent is compared with the last nonzero one. (t0x, t0y, t0z) is the
    # tangent rot0 belongs to; zero means rot0 already sits at point 0. Scalars only:
    # nothing is allocated.
    n = points.shape[0]
    px, py, pz = t0x, t0y, t0z
    have_prev = px * px + py * py + pz * pz > 0.0
    rw, rx, ry, rz = rot0[0], rot0[1], rot0[2], rot0[3]
    for i in range(n):
        # Tangent at point i (see polyline_tangent_into).
        lo = i - 1 if i > 0 else 0
        hi = i + 1 if i < n - 1 else n - 1
        cx = points[hi, 0] - points[lo, 0]
        cy = points[hi, 1] - points[lo, 1]
        cz = points[hi, 2] - points[lo, 2]
        if cx * cx + cy * cy + cz * cz > 0.0:
            if have_prev:
                rw, rx, ry, rz = quat_mul_t(quat_between_t((px, py, pz), (cx, cy, cz)),
                                            (rw, rx, ry, rz))
                # Renormalize so a long polyline does not drift off unit length.
                rw, rx, ry, rz = _normalize4(rw, rx, ry, rz)
            px, py, pz = cx, cy, cz
            have_prev = True
        out_rots[i, 0] = rw
        out_rots[i, 1] = rx
        out_rots[i, 2] = ry
        out_rots[i, 3] = rz
    return out_rots


@njit(cache=True)
def frame_transport_into(points, rot0, out_rots, tangent0=None):
    """Parallel-transport the unit orientation rot0 along the polyline ``points`` (n, 3),
    writing out_rots (n, 4); allocates nothing.

    The tangent at each point is ``polyline_tangent_into``'s: points[i+1] - points[i-1]
    inside, points[1] - points[0] at the first point, points[n-1] - points[n-2] at the
    last. out_rots[i] = quat_between(tangent[i-1], tangent[i]) * out_rots[i-1], so the
    frame turns only about axes perpendicular to the curve (no twist about it).

    Without tangent0, rot0 is the frame at point 0: out_rots[0] = rot0. With tangent0
    (3,), rot0 is a frame that belongs to the direction tangent0 (say, a rest tangent)
    and is first turned onto the polyline: out_rots[0] = quat_between(tangent0,
    tangent[0]) * rot0 (a zero tangent0 counts as none). Repeated points (zero tangents)
    carry the frame unchanged, and a single point keeps rot0. rot0 should be unit; the
    frames are renormalized after every step (a zero rot0 becomes the identity).
    """
    if tangent0 is None:
        return _transport(points, 0.0, 0.0, 0.0, rot0, out_rots)
    return _transport(points, tangent0[0], tangent0[1], tangent0[2], rot0, out_rots)


@njit(cache=True)
def frame_transport(points, tangent0, rot0):
    """Orientations (n, 4) of the frame rot0, which belongs to direction tangent0,
    parallel-transported along ``points`` (n, 3); see ``frame_transport_into``."""
    return frame_transport_into(points, rot0, np.empty((points.shape[0], 4)), tangent0)


@njit(cache=True)
def spline_frame_transport_into(p0, v0, a0, p1, v1, a1, params, rot0, substeps,
                                out_pos, out_rots):
    """Step along the quintic Hermite spline (p0, v0, a0, p1, v1, a1) (each (3,)),
    transporting the frame rot0 with the spline tangent (Hecker 2008 sec 4.3.2: "step
    along the spline, transporting a coordinate frame with its y axis parallel to the
    spline tangent, to a point near each body's position"). Writes out_pos (n, 3), the
    spline points at ``params`` (n,), and out_rots (n, 4), the transported frames there.

    rot0 is the frame at t = 0 and belongs to the tangent v0 there: whatever local axis
    rot0 maps onto v0 stays on the tangent (give rot0 its y axis along v0 to follow the
    paper). The tangent is the analytic derivative of the spline. Between consecutive
    params (starting from t = 0) the frame takes ``substeps`` >= 1 equal minimal-twist
    steps; planar splines are exact for any count, twisted ones converge as the count
    grows (the discrete transport approaches the continuous rotation-minimizing frame;
    the rest and posed splines of one body should use the same count). Params need not
    increase. A zero tangent is skipped, as in ``frame_transport_into``. Allocates
    nothing.
    """
    n = params.shape[0]
    steps = substeps if substeps >= 1 else 1
    rw, rx, ry, rz = rot0[0], rot0[1], rot0[2], rot0[3]
    px, py, pz = v0[0], v0[1], v0[2]
    have_prev = px * px + py * py + pz * pz > 0.0
    t_prev = 0.0
    for i in range(n):
        t_next = params[i]
        for s in range(1, steps + 1):
            t = t_prev + (t_next - t_prev) * (s / steps)
            cx, cy, cz = hermite5_deriv_t(p0, v0, a0, p1, v1, a1, t)
            if cx * cx + cy * cy + cz * cz > 0.0:
                if have_prev:
                    rw, rx, ry, rz = quat_mul_t(quat_between_t((px, py, pz), (cx, cy, cz)),
                                                (rw, rx, ry, rz))
                    rw, rx, ry, rz = _normalize4(rw, rx, ry, rz)
                px, py, pz = cx, cy, cz
                have_prev = True
        x, y, z = hermite5_t(p0, v0, a0, p1, v1, a1, t_next)
        out_pos[i, 0] = x
        out_pos[i, 1] = y
        out_pos[i, 2] = z
        out_rots[i, 0] = rw
        out_rots[i, 1] = rx
        out_rots[i, 2] = ry
        out_rots[i, 3] = rz
        t_prev = t_next
    return out_pos, out_rots


@njit(cache=True)
def spline_frame_transport(p0, v0, a0, p1, v1, a1, params, rot0, substeps):
    """(points (n, 3), frames (n, 4)) of ``spline_frame_transport_into``, new arrays."""
    n = params.shape[0]
    return spline_frame_transport_into(p0, v0, a0, p1, v1, a1, params, rot0, substeps,
                                       np.empty((n, 3)), np.empty((n, 4)))
