"""Kernel of ``engine.response.strike``: the deepest overlap of one character's striking
capsule with another character's capsules (numba, allocation-free)."""

from __future__ import annotations

import math

from numba import njit

from engine.physics._kernels import _closest_segments


@njit(cache=True)
def _world(pos, rot, b, v):
    w, x, y, z = rot[b, 0], rot[b, 1], rot[b, 2], rot[b, 3]
    vx, vy, vz = v[b, 0], v[b, 1], v[b, 2]
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (pos[b, 0] + vx + w * tx + (y * tz - z * ty), pos[b, 1] + vy + w * ty + (z * tx - x * tz),
            pos[b, 2] + vz + w * tz + (x * ty - y * tx))


@njit(cache=True)
def deepest_overlap(apos, arot, aseg_a, aseg_b, ar, ab, vpos, vrot, vseg_a, vseg_b, vr, out):
    """Capsule of body ``ab`` of the attacker against every capsule of the victim. Writes
    out[0] victim body (-1: none within reach), out[1] depth (m, > 0 overlapping), out[2:5]
    the contact point (midway between the surfaces), out[5:8] the normal from the attacker
    toward the victim. Returns the victim body."""
    p1x, p1y, p1z = _world(apos, arot, ab, aseg_a)
    q1x, q1y, q1z = _world(apos, arot, ab, aseg_b)
    best = -1
    depth = -1e300
    for b in range(vpos.shape[0]):
        p2x, p2y, p2z = _world(vpos, vrot, b, vseg_a)
        q2x, q2y, q2z = _world(vpos, vrot, b, vseg_b)
        s, t = _closest_segments(p1x, p1y, p1z, q1x, q1y, q1z, p2x, p2y, p2z, q2x, q2y, q2z)
        cx1, cy1, cz1 = p1x + s * (q1x - p1x), p1y + s * (q1y - p1y), p1z + s * (q1z - p1z)
        cx2, cy2, cz2 = p2x + t * (q2x - p2x), p2y + t * (q2y - p2y), p2z + t * (q2z - p2z)
        dx, dy, dz = cx2 - cx1, cy2 - cy1, cz2 - cz1
        d = math.sqrt(dx * dx + dy * dy + dz * dz)
        pen = ar[ab] + vr[b] - d
        if pen > depth:
            depth = pen
            best = b
            if d > 1e-12:
                nx, ny, nz = dx / d, dy / d, dz / d
            else:
                nx, ny, nz = 1.0, 0.0, 0.0
            out[2] = cx1 + nx * (ar[ab] - 0.5 * pen)
            out[3] = cy1 + ny * (ar[ab] - 0.5 * pen)
            out[4] = cz1 + nz * (ar[ab] - 0.5 * pen)
            out[5], out[6], out[7] = nx, ny, nz
    out[0] = best
    out[1] = depth
    return best
