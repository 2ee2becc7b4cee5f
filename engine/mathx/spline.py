"""Hermite splines: cubic (keyed curves) and quintic (spine splines).

Every function is ``@njit(cache=True)`` and float64. Vector-valued curves take 1-D arrays
of any dimension d (3 for positions, 4 for raw quaternion components, 1 for scalars);
the ``_into`` twins write into a preallocated (d,) array (or view) and allocate nothing.
The returning versions allocate ``out`` and call the twin, so they agree bit for bit.
The curve evaluations (``hermite3_into``, ``hermite5_into`` and their derivatives) read
an input's component before writing the same component of ``out``, so there ``out``
may alias an input; ``auto_tangents_into``, ``chord_params_into`` and
``fit_hermite5_into`` need an ``out`` of their own. The ``_t`` functions return 3-D
results as tuples for kernels that keep vectors in registers.

Parameters run over [0, 1]: a segment from key time t_a to t_b is evaluated at
u = (t - t_a) / (t_b - t_a), and tangents measured per second must be multiplied by
(t_b - t_a) first (``hermite3_keys_into`` does both).

- Cubic Hermite: animators key the generalized q_g curves with explicit Hermite
  tangents (Hecker 2008 sec 3.3); ``auto_tangents`` makes default tangents for keys.
- Quintic Hermite (position, first and second derivative at both ends): the IK fits one
  through the spine bodies between two branch points (Hecker 2008 sec 4.3.2, "Spine
  Splines": cubics did not fit the many inflection points of player-made spines).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# ---------------------------------------------------------------------------------------
# Cubic Hermite on [0, 1]
#   p(t) = h00 p0 + h10 m0 + h01 p1 + h11 m1
#   h00 = 2t^3 - 3t^2 + 1, h10 = t^3 - 2t^2 + t, h01 = -2t^3 + 3t^2, h11 = t^3 - t^2
# ---------------------------------------------------------------------------------------


@njit(cache=True)
def hermite3_basis_into(t, out):
    """out (4,) = cubic Hermite basis (h00, h10, h01, h11) at t, weights of p0, m0, p1, m1."""
    t2 = t * t
    t3 = t2 * t
    out[0] = 2.0 * t3 - 3.0 * t2 + 1.0
    out[1] = t3 - 2.0 * t2 + t
    out[2] = -2.0 * t3 + 3.0 * t2
    out[3] = t3 - t2
    return out


@njit(cache=True)
def hermite3_basis(t):
    """Cubic Hermite basis at t, a new (4,) array (weights of p0, m0, p1, m1)."""
    return hermite3_basis_into(t, np.empty(4))


@njit(cache=True)
def hermite3_basis_deriv_into(t, out):
    """out (4,) = d/dt of the cubic Hermite basis at t."""
    t2 = t * t
    out[0] = 6.0 * t2 - 6.0 * t
    out[1] = 3.0 * t2 - 4.0 * t + 1.0
    out[2] = -6.0 * t2 + 6.0 * t
    out[3] = 3.0 * t2 - 2.0 * t
    return out


@njit(cache=True)
def hermite3_basis_deriv(t):
    """d/dt of the cubic Hermite basis at t, a new (4,) array."""
    return hermite3_basis_deriv_into(t, np.empty(4))


@njit(cache=True)
def hermite3_scalar(p0, m0, p1, m1, t):
    """Cubic Hermite of floats at t in [0, 1] (p(0) = p0, p'(0) = m0, p(1) = p1, p'(1) = m1)."""
    t2 = t * t
    t3 = t2 * t
    return ((2.0 * t3 - 3.0 * t2 + 1.0) * p0 + (t3 - 2.0 * t2 + t) * m0
            + (-2.0 * t3 + 3.0 * t2) * p1 + (t3 - t2) * m1)


@njit(cache=True)
def hermite3_scalar_deriv(p0, m0, p1, m1, t):
    """d/dt of ``hermite3_scalar`` at t."""
    t2 = t * t
    return ((6.0 * t2 - 6.0 * t) * p0 + (3.0 * t2 - 4.0 * t + 1.0) * m0
            + (-6.0 * t2 + 6.0 * t) * p1 + (3.0 * t2 - 2.0 * t) * m1)


@njit(cache=True)
def hermite3_into(p0, m0, p1, m1, t, out):
    """out (d,) = cubic Hermite point at t of end points p0, p1 and end tangents m0, m1
    (all (d,))."""
    t2 = t * t
    t3 = t2 * t
    h00 = 2.0 * t3 - 3.0 * t2 + 1.0
    h10 = t3 - 2.0 * t2 + t
    h01 = -2.0 * t3 + 3.0 * t2
    h11 = t3 - t2
    for k in range(out.shape[0]):
        out[k] = h00 * p0[k] + h10 * m0[k] + h01 * p1[k] + h11 * m1[k]
    return out


@njit(cache=True)
def hermite3(p0, m0, p1, m1, t):
    """Cubic Hermite point at t, a new (d,) array."""
    return hermite3_into(p0, m0, p1, m1, t, np.empty(p0.shape[0]))


@njit(cache=True)
def hermite3_deriv_into(p0, m0, p1, m1, t, out):
    """out (d,) = d/dt of the cubic Hermite at t."""
    t2 = t * t
    d00 = 6.0 * t2 - 6.0 * t
    d10 = 3.0 * t2 - 4.0 * t + 1.0
    d01 = -6.0 * t2 + 6.0 * t
    d11 = 3.0 * t2 - 2.0 * t
    for k in range(out.shape[0]):
        out[k] = d00 * p0[k] + d10 * m0[k] + d01 * p1[k] + d11 * m1[k]
    return out


@njit(cache=True)
def hermite3_deriv(p0, m0, p1, m1, t):
    """d/dt of the cubic Hermite at t, a new (d,) array."""
    return hermite3_deriv_into(p0, m0, p1, m1, t, np.empty(p0.shape[0]))


# ---------------------------------------------------------------------------------------
# Quintic Hermite on [0, 1]: p(t) = sum_k H_k(t) c_k with c = (p0, v0, a0, p1, v1, a1),
# the unique quintic with p, p', p'' prescribed at both ends:
#   H_p0 = 1 - 10t^3 + 15t^4 - 6t^5     H_p1 = 10t^3 - 15t^4 + 6t^5
#   H_v0 = t - 6t^3 + 8t^4 - 3t^5       H_v1 = -4t^3 + 7t^4 - 3t^5
#   H_a0 = (t^2 - 3t^3 + 3t^4 - t^5)/2  H_a1 = (t^3 - 2t^4 + t^5)/2
# ---------------------------------------------------------------------------------------


@njit(cache=True)
def hermite5_basis_into(t, out):
    """out (6,) = quintic Hermite basis at t, the weights of (p0, v0, a0, p1, v1, a1)."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    out[0] = 1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5
    out[1] = t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5
    out[2] = 0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5)
    out[3] = 10.0 * t3 - 15.0 * t4 + 6.0 * t5
    out[4] = -4.0 * t3 + 7.0 * t4 - 3.0 * t5
    out[5] = 0.5 * (t3 - 2.0 * t4 + t5)
    return out


@njit(cache=True)
def hermite5_basis(t):
    """Quintic Hermite basis at t, a new (6,) array (weights of p0, v0, a0, p1, v1, a1)."""
    return hermite5_basis_into(t, np.empty(6))


@njit(cache=True)
def hermite5_basis_deriv_into(t, out):
    """out (6,) = d/dt of the quintic Hermite basis at t."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    out[0] = -30.0 * t2 + 60.0 * t3 - 30.0 * t4
    out[1] = 1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4
    out[2] = t - 4.5 * t2 + 6.0 * t3 - 2.5 * t4
    out[3] = 30.0 * t2 - 60.0 * t3 + 30.0 * t4
    out[4] = -12.0 * t2 + 28.0 * t3 - 15.0 * t4
    out[5] = 1.5 * t2 - 4.0 * t3 + 2.5 * t4
    return out


@njit(cache=True)
def hermite5_basis_deriv(t):
    """d/dt of the quintic Hermite basis at t, a new (6,) array."""
    return hermite5_basis_deriv_into(t, np.empty(6))


@njit(cache=True)
def hermite5_basis_deriv2_into(t, out):
    """out (6,) = d^2/dt^2 of the quintic Hermite basis at t."""
    t2 = t * t
    t3 = t2 * t
    out[0] = -60.0 * t + 180.0 * t2 - 120.0 * t3
    out[1] = -36.0 * t + 96.0 * t2 - 60.0 * t3
    out[2] = 1.0 - 9.0 * t + 18.0 * t2 - 10.0 * t3
    out[3] = 60.0 * t - 180.0 * t2 + 120.0 * t3
    out[4] = -24.0 * t + 84.0 * t2 - 60.0 * t3
    out[5] = 3.0 * t - 12.0 * t2 + 10.0 * t3
    return out


@njit(cache=True)
def hermite5_basis_deriv2(t):
    """d^2/dt^2 of the quintic Hermite basis at t, a new (6,) array."""
    return hermite5_basis_deriv2_into(t, np.empty(6))


@njit(cache=True)
def hermite5_into(p0, v0, a0, p1, v1, a1, t, out):
    """out (d,) = the quintic Hermite at t with p(0) = p0, p'(0) = v0, p''(0) = a0,
    p(1) = p1, p'(1) = v1, p''(1) = a1 (all (d,))."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    b0 = 1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5
    b1 = t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5
    b2 = 0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5)
    b3 = 10.0 * t3 - 15.0 * t4 + 6.0 * t5
    b4 = -4.0 * t3 + 7.0 * t4 - 3.0 * t5
    b5 = 0.5 * (t3 - 2.0 * t4 + t5)
    for k in range(out.shape[0]):
        out[k] = (b0 * p0[k] + b1 * v0[k] + b2 * a0[k]
                  + b3 * p1[k] + b4 * v1[k] + b5 * a1[k])
    return out


@njit(cache=True)
def hermite5(p0, v0, a0, p1, v1, a1, t):
    """Quintic Hermite point at t, a new (d,) array."""
    return hermite5_into(p0, v0, a0, p1, v1, a1, t, np.empty(p0.shape[0]))


@njit(cache=True)
def hermite5_deriv_into(p0, v0, a0, p1, v1, a1, t, out):
    """out (d,) = d/dt of the quintic Hermite at t."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    b0 = -30.0 * t2 + 60.0 * t3 - 30.0 * t4
    b1 = 1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4
    b2 = t - 4.5 * t2 + 6.0 * t3 - 2.5 * t4
    b3 = 30.0 * t2 - 60.0 * t3 + 30.0 * t4
    b4 = -12.0 * t2 + 28.0 * t3 - 15.0 * t4
    b5 = 1.5 * t2 - 4.0 * t3 + 2.5 * t4
    for k in range(out.shape[0]):
        out[k] = (b0 * p0[k] + b1 * v0[k] + b2 * a0[k]
                  + b3 * p1[k] + b4 * v1[k] + b5 * a1[k])
    return out


@njit(cache=True)
def hermite5_deriv(p0, v0, a0, p1, v1, a1, t):
    """d/dt of the quintic Hermite at t, a new (d,) array."""
    return hermite5_deriv_into(p0, v0, a0, p1, v1, a1, t, np.empty(p0.shape[0]))


@njit(cache=True)
def hermite5_deriv2_into(p0, v0, a0, p1, v1, a1, t, out):
    """out (d,) = d^2/dt^2 of the quintic Hermite at t."""
    t2 = t * t
    t3 = t2 * t
    b0 = -60.0 * t + 180.0 * t2 - 120.0 * t3
    b1 = -36.0 * t + 96.0 * t2 - 60.0 * t3
    b2 = 1.0 - 9.0 * t + 18.0 * t2 - 10.0 * t3
    b3 = 60.0 * t - 180.0 * t2 + 120.0 * t3
    b4 = -24.0 * t + 84.0 * t2 - 60.0 * t3
    b5 = 3.0 * t - 12.0 * t2 + 10.0 * t3
    for k in range(out.shape[0]):
        out[k] = (b0 * p0[k] + b1 * v0[k] + b2 * a0[k]
                  + b3 * p1[k] + b4 * v1[k] + b5 * a1[k])
    return out


@njit(cache=True)
def hermite5_deriv2(p0, v0, a0, p1, v1, a1, t):
    """d^2/dt^2 of the quintic Hermite at t, a new (d,) array."""
    return hermite5_deriv2_into(p0, v0, a0, p1, v1, a1, t, np.empty(p0.shape[0]))


@njit(cache=True)
def hermite5_t(p0, v0, a0, p1, v1, a1, t):
    """The quintic Hermite point at t of 3-vectors (arrays or tuples) as an (x, y, z)
    tuple, for kernels that keep vectors in registers. Same formula as
    ``hermite5_into``, so the results agree bit for bit."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    t5 = t4 * t
    b0 = 1.0 - 10.0 * t3 + 15.0 * t4 - 6.0 * t5
    b1 = t - 6.0 * t3 + 8.0 * t4 - 3.0 * t5
    b2 = 0.5 * (t2 - 3.0 * t3 + 3.0 * t4 - t5)
    b3 = 10.0 * t3 - 15.0 * t4 + 6.0 * t5
    b4 = -4.0 * t3 + 7.0 * t4 - 3.0 * t5
    b5 = 0.5 * (t3 - 2.0 * t4 + t5)
    return (b0 * p0[0] + b1 * v0[0] + b2 * a0[0] + b3 * p1[0] + b4 * v1[0] + b5 * a1[0],
            b0 * p0[1] + b1 * v0[1] + b2 * a0[1] + b3 * p1[1] + b4 * v1[1] + b5 * a1[1],
            b0 * p0[2] + b1 * v0[2] + b2 * a0[2] + b3 * p1[2] + b4 * v1[2] + b5 * a1[2])


@njit(cache=True)
def hermite5_deriv_t(p0, v0, a0, p1, v1, a1, t):
    """d/dt of the quintic Hermite of 3-vectors at t as an (x, y, z) tuple."""
    t2 = t * t
    t3 = t2 * t
    t4 = t3 * t
    b0 = -30.0 * t2 + 60.0 * t3 - 30.0 * t4
    b1 = 1.0 - 18.0 * t2 + 32.0 * t3 - 15.0 * t4
    b2 = t - 4.5 * t2 + 6.0 * t3 - 2.5 * t4
    b3 = 30.0 * t2 - 60.0 * t3 + 30.0 * t4
    b4 = -12.0 * t2 + 28.0 * t3 - 15.0 * t4
    b5 = 1.5 * t2 - 4.0 * t3 + 2.5 * t4
    return (b0 * p0[0] + b1 * v0[0] + b2 * a0[0] + b3 * p1[0] + b4 * v1[0] + b5 * a1[0],
            b0 * p0[1] + b1 * v0[1] + b2 * a0[1] + b3 * p1[1] + b4 * v1[1] + b5 * a1[1],
            b0 * p0[2] + b1 * v0[2] + b2 * a0[2] + b3 * p1[2] + b4 * v1[2] + b5 * a1[2])


# ---------------------------------------------------------------------------------------
# Least-squares fit of a quintic spine spline (Hecker 2008 sec 4.3.2, "Spine Splines")
# ---------------------------------------------------------------------------------------

# Eigenvalues of the 4x4 normal matrix below this fraction of the largest count as zero
# (the directions the samples do not determine).
_FIT_RANK_RTOL = 1e-12
# Cyclic Jacobi sweeps; a symmetric 4x4 converges in 5-6, the bound only guards NaN input.
_JACOBI_MAX_SWEEPS = 50


@njit(cache=True)
def _jacobi_eigh4(a, vecs):
    # Eigen-decomposition of the symmetric 4x4 ``a`` in place by cyclic Jacobi rotations:
    # on return the diagonal of ``a`` holds the eigenvalues and the columns of ``vecs``
    # the eigenvectors. Jacobi is accurate for small eigenvalues, which is what the
    # pseudo-inverse needs.
    for i in range(4):
        for j in range(4):
            vecs[i, j] = 1.0 if i == j else 0.0
    for _sweep in range(_JACOBI_MAX_SWEEPS):
        off = 0.0
        for p in range(4):
            for q in range(p + 1, 4):
                off += a[p, q] * a[p, q]
        scale = 0.0
        for p in range(4):
            scale += a[p, p] * a[p, p]
        if not (off > 1e-30 * scale):
            break
        for p in range(3):
            for q in range(p + 1, 4):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                # Rotation angle that zeroes a[p, q] (Golub & Van Loan, sym.schur2).
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                if theta >= 0.0:
                    tan = 1.0 / (theta + math.sqrt(1.0 + theta * theta))
                else:
                    tan = -1.0 / (-theta + math.sqrt(1.0 + theta * theta))
                c = 1.0 / math.sqrt(1.0 + tan * tan)
                s = tan * c
                for k in range(4):
                    akp = a[k, p]
                    akq = a[k, q]
                    a[k, p] = c * akp - s * akq
                    a[k, q] = s * akp + c * akq
                for k in range(4):
                    apk = a[p, k]
                    aqk = a[q, k]
                    a[p, k] = c * apk - s * aqk
                    a[q, k] = s * apk + c * aqk
                for k in range(4):
                    vkp = vecs[k, p]
                    vkq = vecs[k, q]
                    vecs[k, p] = c * vkp - s * vkq
                    vecs[k, q] = s * vkp + c * vkq


@njit(cache=True)
def fit_hermite5_into(points, params, p0, p1, out):
    """Fit the free end derivatives of a quintic Hermite whose ends are fixed at p0 and p1
    (each (d,)) to samples ``points`` (m, d) at ``params`` (m,) in [0, 1], by linear least
    squares. Writes out (4, d) = rows v0, a0, v1, a1.

    The residual of sample j is points[j] - H_p0(t_j) p0 - H_p1(t_j) p1 - sum_k H_k(t_j)
    x_k over the four free coefficients x = (v0, a0, v1, a1); the same 4-column design
    matrix serves every dimension. Four samples at distinct params strictly inside (0, 1)
    determine the fit (the four free basis functions are t(1-t) times independent
    cubics); samples at t = 0 or 1 constrain nothing (they only see p0, p1).

    Under-determined fits (fewer than 4 distinct interior params) take the solution
    closest to the straight segment at constant speed, v0 = v1 = p1 - p0, a0 = a1 = 0:
    the minimum-norm least-squares correction to that prior, through the pseudo-inverse
    of the 4x4 normal matrix (eigenvalues below 1e-12 of the largest count as zero).
    So no interior samples give the straight segment, one gives the curve through it
    nearest the segment, and a fully determined fit ignores the prior.

    Plan-time code (the IK fits rest poses once); allocates a few 4x4 scratch arrays.
    Raises ValueError on non-finite input or mismatched shapes (callers name the
    creature and bodies first; this is the last guard, never a NaN result).
    """
    m = points.shape[0]
    d = points.shape[1]
    if m != params.shape[0] or p0.shape[0] != d or p1.shape[0] != d or out.shape[1] != d:
        raise ValueError("fit_hermite5: points (m, d), params (m,), p0, p1 (d,) and "
                         "out (4, d) disagree in shape")
    for j in range(m):
        if not math.isfinite(params[j]):
            raise ValueError("fit_hermite5: non-finite spline parameter")
        for k in range(d):
            if not math.isfinite(points[j, k]):
                raise ValueError("fit_hermite5: non-finite sample point")
    for k in range(d):
        if not (math.isfinite(p0[k]) and math.isfinite(p1[k])):
            raise ValueError("fit_hermite5: non-finite end point")
    normal = np.zeros((4, 4))
    rhs = np.zeros((4, d))
    basis = np.empty(6)
    # Prior: the straight segment at constant speed.
    prior = np.zeros((4, d))
    for k in range(d):
        prior[0, k] = p1[k] - p0[k]
        prior[2, k] = p1[k] - p0[k]
    # Normal equations for the correction y = x - prior: (A^T A) y = A^T r, where r is
    # each sample's residual after the fixed ends and the prior.
    for j in range(m):
        hermite5_basis_into(params[j], basis)
        row0 = basis[1]
        row1 = basis[2]
        row2 = basis[4]
        row3 = basis[5]
        row = (row0, row1, row2, row3)
        for a in range(4):
            for b in range(4):
                normal[a, b] += row[a] * row[b]
        for k in range(d):
            r = points[j, k] - basis[0] * p0[k] - basis[3] * p1[k]
            r -= row0 * prior[0, k] + row2 * prior[2, k]
            for a in range(4):
                rhs[a, k] += row[a] * r
    # Pseudo-inverse solve: y = V diag(1/lambda, 0 for tiny lambda) V^T rhs.
    vecs = np.empty((4, 4))
    _jacobi_eigh4(normal, vecs)
    lam_max = 0.0
    for a in range(4):
        lam_max = max(lam_max, normal[a, a])
    for a in range(4):
        for k in range(d):
            out[a, k] = prior[a, k]
    if not (lam_max > 0.0 and lam_max < np.inf):
        return out
    for e in range(4):
        lam = normal[e, e]
        if lam <= _FIT_RANK_RTOL * lam_max:
            continue
        for k in range(d):
            proj = 0.0
            for a in range(4):
                proj += vecs[a, e] * rhs[a, k]
            proj /= lam
            for a in range(4):
                out[a, k] += vecs[a, e] * proj
    return out


@njit(cache=True)
def chord_params_into(points, out):
    """out (n,) = chord-length parameters of the polyline ``points`` (n, d): the distance
    along it from the first point, divided by its total length, so out[0] = 0 and
    out[n-1] = 1. The usual parameters for fitting a spine spline through the joint
    positions of its bodies. A polyline of zero length gets even spacing; a single point
    gets 0."""
    n = points.shape[0]
    if n == 0:
        return out
    out[0] = 0.0
    total = 0.0
    for i in range(1, n):
        seg = 0.0
        for k in range(points.shape[1]):
            diff = points[i, k] - points[i - 1, k]
            seg += diff * diff
        total += math.sqrt(seg)
        out[i] = total
    if n == 1:
        return out
    if total > 0.0 and total < np.inf:
        for i in range(1, n - 1):
            out[i] /= total
    else:
        for i in range(1, n - 1):
            out[i] = i / (n - 1)
    out[n - 1] = 1.0
    return out


@njit(cache=True)
def chord_params(points):
    """Chord-length parameters in [0, 1] of the polyline ``points`` (n, d), a new (n,)
    array; see ``chord_params_into``."""
    return chord_params_into(points, np.empty(points.shape[0]))


@njit(cache=True)
def fit_hermite5(points, params, p0, p1):
    """Least-squares quintic Hermite end derivatives through ``points`` (m, d) at
    ``params`` (m,) with ends fixed at p0, p1: returns (v0, a0, v1, a1), each (d,). See
    ``fit_hermite5_into`` for the under-determined case."""
    out = fit_hermite5_into(points, params, p0, p1, np.empty((4, points.shape[1])))
    return out[0].copy(), out[1].copy(), out[2].copy(), out[3].copy()


# ---------------------------------------------------------------------------------------
# Keyed cubic curves: automatic tangents and evaluation
# ---------------------------------------------------------------------------------------

@njit(cache=True)
def auto_tangents_into(times, values, flat, out):
    """out (k, d) = default tangents, in value units per second, for keys ``values``
    (k, d) at strictly increasing ``times`` (k,).

    Interior keys get the derivative of the parabola through the key and its two
    neighbours (non-uniform Catmull-Rom): with slopes s_- and s_+ and durations h_- and
    h_+ of the segments before and after, m = (h_+ s_- + h_- s_+) / (h_- + h_+), which is
    (p_{i+1} - p_{i-1}) / (2h) for even spacing and exact for quadratics. The end keys
    take the slope of their only segment (one-sided). A single key gets 0. With ``flat``
    every tangent is 0 (ease in and out of every key). Raises ValueError when times do
    not strictly increase (callers validate keys with file and line first)."""
    k = times.shape[0]
    d = values.shape[1]
    for i in range(1, k):
        if not (times[i] > times[i - 1]):
            raise ValueError("auto_tangents: key times must strictly increase")
    if flat or k < 2:
        for i in range(k):
            for c in range(d):
                out[i, c] = 0.0
        return out
    # Walk the keys once, carrying the slope of the segment before the current key.
    h_prev = times[1] - times[0]
    for c in range(d):
        out[0, c] = (values[1, c] - values[0, c]) / h_prev
    for i in range(1, k - 1):
        h_minus = times[i] - times[i - 1]
        h_plus = times[i + 1] - times[i]
        for c in range(d):
            s_minus = (values[i, c] - values[i - 1, c]) / h_minus
            s_plus = (values[i + 1, c] - values[i, c]) / h_plus
            out[i, c] = (h_plus * s_minus + h_minus * s_plus) / (h_minus + h_plus)
    h_last = times[k - 1] - times[k - 2]
    for c in range(d):
        out[k - 1, c] = (values[k - 1, c] - values[k - 2, c]) / h_last
    return out


@njit(cache=True)
def auto_tangents(times, values, flat=False):
    """Default tangents (k, d) for cubic Hermite keys, a new array; see
    ``auto_tangents_into``."""
    return auto_tangents_into(times, values, flat, np.empty(values.shape))


@njit(cache=True)
def find_segment(times, t):
    """Index i of the key segment [times[i], times[i+1]] holding t (binary search; t
    before the first key gives 0, at or after the last gives k - 2). Needs k >= 2."""
    lo = 0
    hi = times.shape[0] - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if times[mid] <= t:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def hermite3_keys_into(times, values, tangents, t, out):
    """out (d,) = the keyed cubic Hermite curve (keys ``values`` (k, d) at ``times`` (k,),
    tangents (k, d) in value units per second) at time t, held constant before the first
    and after the last key. Tangents are scaled by each segment's duration to the
    [0, 1] parameter of ``hermite3``."""
    k = times.shape[0]
    d = out.shape[0]
    if k == 1 or t <= times[0]:
        for c in range(d):
            out[c] = values[0, c]
        return out
    if t >= times[k - 1]:
        for c in range(d):
            out[c] = values[k - 1, c]
        return out
    i = find_segment(times, t)
    h = times[i + 1] - times[i]
    u = (t - times[i]) / h
    u2 = u * u
    u3 = u2 * u
    h00 = 2.0 * u3 - 3.0 * u2 + 1.0
    h10 = (u3 - 2.0 * u2 + u) * h
    h01 = -2.0 * u3 + 3.0 * u2
    h11 = (u3 - u2) * h
    for c in range(d):
        out[c] = (h00 * values[i, c] + h10 * tangents[i, c]
                  + h01 * values[i + 1, c] + h11 * tangents[i + 1, c])
    return out


@njit(cache=True)
def hermite3_keys(times, values, tangents, t):
    """The keyed cubic Hermite curve at time t, a new (d,) array."""
    return hermite3_keys_into(times, values, tangents, t, np.empty(values.shape[1]))


@njit(cache=True)
def natural_end_tangent(p_prev, p_end, v_prev):
    """The end tangent of a natural cubic (zero second derivative at the end) through
    p_prev with tangent v_prev and ending at p_end: 3 (p_end - p_prev) / 2 - v_prev / 2.
    Hecker 2008 sec 4.3.2 gives this for the end particle of a spine ("v_i =
    3(p_{i-1} - p_i)/2 - v_{i-1}/2", written there with the chain running the other way).
    Floats or arrays."""
    return 1.5 * (p_end - p_prev) - 0.5 * v_prev
