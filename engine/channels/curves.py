"""Keyed generalized curves (Hecker et al. 2008, section 3.3): automatic tangents and
sampling from Python. The per-frame sampling kernels live in ``_kernels``.

Tangents are per second: value units per second for positions and weights, body-frame
angular velocity (rad/s) for rotations. A key's tangent is either explicit (``tin`` /
``tout`` in the file) or automatic:

* interior keys: the derivative of the parabola through the key and its neighbours
  (non-uniform Catmull-Rom, ``(h+ s- + h- s+) / (h- + h+)``), *clamped*: a component
  for which the key is an extremum or a plateau (the slopes before and after do not
  have the same strict sign) gets 0, as animation packages' "auto" tangents do, so held
  poses hold and a hand keyed onto the ground does not overshoot through it;
  rotations are clamped the same way, isotropically: zero when the rotations before and
  after the key turn in opposite directions (dot of the two rotation vectors <= 0);
* the first and last key: zero (the curve eases in and out), except on a looping
  animation whose first key is at 0 and last key at its length, where the neighbours
  across the loop are used so the loop has no kink.

Clamping makes automatic tangents depend on the coordinate axes, so key remapping
(``engine.anim.remap_channel``) writes every remapped tangent out explicitly: the
active body's specialized curve then stays identical between keys too.
"""

from __future__ import annotations

import numpy as np

from engine.channels import _kernels as K


def _three_point(prev_slope, next_slope, h_prev, h_next):
    m = (h_next * prev_slope + h_prev * next_slope) / (h_prev + h_next)
    return np.where(prev_slope * next_slope > 0.0, m, 0.0)


def _three_point_rot(prev_slope, next_slope, h_prev, h_next):
    if float(prev_slope @ next_slope) <= 0.0:
        return np.zeros(3)
    return (h_next * prev_slope + h_prev * next_slope) / (h_prev + h_next)


def auto_tangents(times, values, *, loop_length: float | None = None) -> np.ndarray:
    """Automatic tangents (k, d) for vector keys ``values`` (k, d) at increasing ``times``.
    ``loop_length``: the animation's length when it loops (wrap the end keys)."""
    t = np.asarray(times, float)
    v = np.asarray(values, float).reshape(len(t), -1)
    k = len(t)
    out = np.zeros_like(v)
    if k < 2:
        return out
    for i in range(1, k - 1):
        hp, hn = t[i] - t[i - 1], t[i + 1] - t[i]
        out[i] = _three_point((v[i] - v[i - 1]) / hp, (v[i + 1] - v[i]) / hn, hp, hn)
    if _wraps(t, loop_length) and k >= 3:
        hp, hn = t[-1] - t[-2], t[1] - t[0]
        m = _three_point((v[-1] - v[-2]) / hp, (v[1] - v[0]) / hn, hp, hn)
        out[0] = m
        out[-1] = m
    return out


def rotation_auto_tangents(times, quats, *, loop_length: float | None = None) -> np.ndarray:
    """Automatic angular-velocity tangents (k, 3) for unit quaternion keys (k, 4)."""
    t = np.asarray(times, float)
    q = np.ascontiguousarray(quats, dtype=float).reshape(len(t), 4)
    k = len(t)
    out = np.zeros((k, 3))
    if k < 2:
        return out
    logs = np.zeros((k - 1, 3))
    for i in range(k - 1):
        K._relative_rotvec(q[i], q[i + 1], logs[i])
    for i in range(1, k - 1):
        hp, hn = t[i] - t[i - 1], t[i + 1] - t[i]
        out[i] = _three_point_rot(logs[i - 1] / hp, logs[i] / hn, hp, hn)
    if _wraps(t, loop_length) and k >= 3:
        hp, hn = t[-1] - t[-2], t[1] - t[0]
        m = _three_point_rot(logs[-1] / hp, logs[0] / hn, hp, hn)
        out[0] = m
        out[-1] = m
    return out


def _wraps(t: np.ndarray, loop_length: float | None) -> bool:
    return loop_length is not None and abs(t[0]) < 1e-12 and abs(t[-1] - loop_length) < 1e-12


def sample_vector(times, values, tout, tin, t: float) -> np.ndarray:
    """One vector curve at time t (Python convenience around the kernel)."""
    times = np.ascontiguousarray(times, float)
    values = np.ascontiguousarray(values, float).reshape(len(times), -1)
    out = np.zeros(values.shape[1])
    K.sample_vector_into(times, values, np.ascontiguousarray(tout, float).reshape(values.shape),
                         np.ascontiguousarray(tin, float).reshape(values.shape), 0, len(times), float(t), out)
    return out


def sample_rotation(times, quats, tout, tin, t: float) -> np.ndarray:
    """One rotation curve at time t (Python convenience around the kernel)."""
    times = np.ascontiguousarray(times, float)
    quats = np.ascontiguousarray(quats, float).reshape(len(times), 4)
    out = np.zeros(4)
    K.sample_rotation_into(times, quats, np.ascontiguousarray(tout, float).reshape(len(times), 3),
                           np.ascontiguousarray(tin, float).reshape(len(times), 3), 0, len(times),
                           float(t), out, np.zeros((3, 3)))
    return out
