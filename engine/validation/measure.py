"""A measurement of one grid cell: the worst value of one metric, where and when it was.

Every metric module returns ``Measure`` objects; ``engine.validation.thresholds`` turns a
value into pass, warn or fail. Lengths are relative to the creature's size (its height
for ground and self-intersection, the size of the limb for goal misses) and every measure
states its unit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Measure:
    """The worst value of one metric over a cell, with where and when it happened."""

    name: str
    value: float
    unit: str
    body: str | None = None
    frame: int | None = None          # index into the recording's frames
    time: float | None = None         # seconds since play at that frame
    detail: dict = field(default_factory=dict)
    series: np.ndarray | None = None  # the per-frame worst (for the report's plots)
    known: str | None = None          # a known defect this waits for ("issue 16: ...")

    def to_json(self, with_series: bool = False) -> dict:
        out = {"value": _clean(self.value), "unit": self.unit}
        if self.body is not None:
            out["body"] = self.body
        if self.time is not None:
            out["time"] = round(float(self.time), 4)
        if self.frame is not None:
            out["frame"] = int(self.frame)
        if self.detail:
            out["detail"] = {k: _clean(v) for k, v in self.detail.items()}
        if self.known:
            out["known"] = self.known
        if with_series and self.series is not None:
            out["series"] = [_clean(v, 5) for v in np.asarray(self.series, float)]
        return out


def _clean(v, digits: int = 6):
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if not np.isfinite(f):
            return None if np.isnan(f) else (1e308 if f > 0 else -1e308)
        return float(f"{f:.{digits}g}")
    if isinstance(v, (list, tuple)):
        return [_clean(x, digits) for x in v]
    return v


def worst(name: str, values: np.ndarray, unit: str, body_names, t: np.ndarray, *, frame_offset: int = 0,
          **detail) -> Measure:
    """The largest entry of ``values (nframe, nbody)`` as a Measure (0 when empty), with the
    per-frame maximum as its series. ``frame_offset``: index of row 0 in the recording."""
    if values.size == 0:
        return Measure(name, 0.0, unit, detail=detail, series=np.zeros(0))
    flat = int(np.argmax(values))
    i, b = divmod(flat, values.shape[1])
    frame = i + frame_offset
    return Measure(name, float(values[i, b]), unit, body=str(body_names[b]), frame=frame,
                   time=float(t[min(frame, len(t) - 1)]), detail=detail, series=values.max(axis=1))
