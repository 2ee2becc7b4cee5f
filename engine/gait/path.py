"""Path following for locomotion: turn a polyline of waypoints into the (velocity,
turn rate) commands ``Character.locomote`` takes (pure pursuit: steer toward the point
``lookahead`` metres further along the path, slow down near the end).

    follower = PathFollower([(0, 0), (2, 1), (4, 0)], speed=1.0, lookahead=0.6)
    while not follower.done:
        char.locomote(*follower.command(char.position, heading_of(char.rotation)))
        char.tick(dt)
"""

from __future__ import annotations

import math

import numpy as np

from engine.gait.controller import GaitError


class PathFollower:
    """Pure pursuit along a polyline (world x, y)."""

    def __init__(self, points, speed: float, lookahead: float, *, max_turn_rate: float = 2.0,
                 arrive: float | None = None) -> None:
        p = np.asarray(points, dtype=float)
        if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2 or not np.all(np.isfinite(p)):
            raise GaitError(f"PathFollower: points must be (n >= 2, 2) finite numbers, got shape {p.shape}")
        for name, v in (("speed", speed), ("lookahead", lookahead), ("max_turn_rate", max_turn_rate)):
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise GaitError(f"PathFollower: {name} must be a finite number > 0, got {v!r}")
        seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
        self.points = p
        self.cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.length = float(self.cum[-1])
        self.speed = float(speed)
        self.lookahead = float(lookahead)
        self.max_turn_rate = float(max_turn_rate)
        self.arrive = float(arrive) if arrive is not None else 2.0 * lookahead
        self.progress = 0.0            # arc length of the closest point reached so far
        self.done = False

    def point_at(self, s: float) -> np.ndarray:
        s = min(max(s, 0.0), self.length)
        k = int(np.searchsorted(self.cum, s, side="right")) - 1
        k = min(max(k, 0), len(self.points) - 2)
        seg = self.cum[k + 1] - self.cum[k]
        t = 0.0 if seg <= 0 else (s - self.cum[k]) / seg
        return self.points[k] + t * (self.points[k + 1] - self.points[k])

    def _closest(self, xy: np.ndarray) -> float:
        best, best_s = math.inf, self.progress
        for k in range(len(self.points) - 1):
            a, b = self.points[k], self.points[k + 1]
            ab = b - a
            L2 = float(ab @ ab)
            t = 0.0 if L2 <= 0 else min(max(float((xy - a) @ ab) / L2, 0.0), 1.0)
            d = float(np.linalg.norm(a + t * ab - xy))
            s = self.cum[k] + t * math.sqrt(L2)
            if d < best and s >= self.progress - self.lookahead:
                best, best_s = d, s
        return max(best_s, self.progress)

    def command(self, position, heading: float) -> tuple[tuple[float, float], float]:
        """((forward, left) m/s, turn rate rad/s) for a character at ``position`` (3,) facing
        ``heading`` (radians about +Z)."""
        xy = np.asarray(position, dtype=float)[:2]
        self.progress = self._closest(xy)
        remaining = self.length - self.progress
        if remaining < 0.02 * self.lookahead:
            self.done = True
            return (0.0, 0.0), 0.0
        goal = self.point_at(self.progress + self.lookahead)
        d = goal - xy
        ang = math.atan2(d[1], d[0]) - heading
        ang = math.atan2(math.sin(ang), math.cos(ang))
        dist = max(float(np.hypot(d[0], d[1])), 1e-9)
        # pure pursuit curvature 2 sin(alpha) / distance; speed eases off toward the end
        v = self.speed * min(1.0, remaining / self.arrive) * max(math.cos(ang), 0.0)
        turn = 2.0 * self.speed * math.sin(ang) / dist
        turn = max(-self.max_turn_rate, min(self.max_turn_rate, turn))
        return (v, 0.0), turn


def heading_of(rotation) -> float:
    """Yaw (radians about +Z) of a w-first quaternion."""
    q = np.asarray(rotation, dtype=float)
    return math.atan2(2.0 * (q[0] * q[3] + q[1] * q[2]), 1.0 - 2.0 * (q[2] ** 2 + q[3] ** 2))
