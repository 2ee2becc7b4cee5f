"""Response: motion capture replayed on physical bodies (``tracking``, Wilke & Semwal),
and, in a later issue, impact response (Zordan et al. 2005) on the same integrator.

    from engine.response import MocapRig, TrackingParams, track, tune
"""

from engine.response.tracking import (
    MODES,
    ControlOptions,
    MocapRig,
    TrackingError,
    TrackingParams,
    TrackingResult,
    TuneResult,
    VelocityScale,
    central_difference,
    central_difference_weights,
    quat_to_euler,
    track,
    tune,
)

__all__ = [
    "MODES", "ControlOptions", "MocapRig", "TrackingError", "TrackingParams", "TrackingResult", "TuneResult",
    "VelocityScale", "central_difference", "central_difference_weights", "quat_to_euler", "track", "tune",
]
