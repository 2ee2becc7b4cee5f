"""The grid's thresholds, in one table: every metric, its unit, when it warns and fails, and why.

A value at or below ``warn`` passes, above ``warn`` warns, above ``fail`` fails. A metric
with ``fail = None`` is reported and never fails a cell; ``warn = None`` never warns.
Lengths are relative to the creature (see each metric's module): the creatures span a
0.1 m random mite to a 10 m giant, so no threshold is in metres.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Threshold:
    metric: str
    unit: str
    warn: float | None
    fail: float | None
    why: str


THRESHOLDS: tuple[Threshold, ...] = (
    Threshold("rotation_pop", "rad/frame", 0.25, 0.5,
              "a body turning half a radian in one 60 Hz frame (30 rad/s) that no goal asked for is a visible "
              "flip; a quarter radian is a jerk a viewer notices on a limb"),
    Threshold("start_pop", "rad/frame", 0.25, 0.5, "rotation_pop in the fade-in: the same bound, reported apart"),
    Threshold("end_pop", "rad/frame", 0.25, 0.5,
              "rotation_pop from the fade-out to the settle: the same bound (clip ends hide pops)"),
    Threshold("position_pop", "size/frame", 0.02, 0.05,
              "5% of the creature jumping in one frame beyond its goals' motion (3 sizes/s) is a pop"),
    Threshold("angular_accel", "rad/s^2", 2000.0, None,
              "a kink in angular velocity beyond the goals' (a fade that is not smooth); library cells free of "
              "pops stay under 480: 2,000 warns"),
    Threshold("jitter", "size/s^3", 10000.0, None,
              "third difference of positions beyond the goals' (shaking); on library cells free of pops it is "
              "at most 3,900 (a jump's landing, p99 2,600): 10,000 warns, pops themselves fail as pops"),
    Threshold("angular_speed", "rad/s", None, None, "reported (per body class in detail)"),
    Threshold("return_pose", "size", 0.01, 0.05,
              "a second after the clip ends every body should be back where a character playing nothing "
              "stands; 5% of the size off means the clip left something behind"),
    Threshold("reach_miss", "reach", 0.01, 0.03,
              "a reachable full-weight goal missed by 3% of the limb's reach (5 cm on a human arm) is a hand "
              "visibly off its target; the IK meets such goals to 1e-9 when nothing conflicts"),
    Threshold("beyond_reach", "reach", 0.02, 0.05,
              "an unreachable goal (past the stretched limb, or closer to its root than the folded limb can "
              "come) is met as well as it can be by a limb pointing straight at it; 5% of the reach beyond "
              "that is a limb not even trying"),
    Threshold("spine_miss", "size", 0.05, None,
              "goals on spine bodies and one-body limbs (a head, a jaw) are compromises the spine phase makes "
              "between all of them (section 4.3.2); a miss of 5% of the size warns"),
    Threshold("rotation_miss", "rad", 0.35, 1.0,
              "a full-weight rotation goal missed by a radian; position goals on the same limb can compete "
              "with it, so only a large miss fails"),
    Threshold("lookat_miss", "rad", 0.2, 0.5, "a head or eye told to look at a target pointing half a radian off"),
    Threshold("below_ground", "height", 0.005, 0.02,
              "a box corner 2% of the creature's height below the ground is a foot or hand visibly in it"),
    Threshold("standing_slide", "leg", 0.002, 0.01,
              "a standing foot's contact point moving 1% of the leg (a centimetre on a human) is skating"),
    Threshold("self_intersection", "height", 0.02, 0.06,
              "boxes of one creature overlapping 6% of its height deeper than at rest is an arm through a "
              "belly; known until the IK avoids its own bodies (issue 16)"),
    Threshold("joint_stretch", "bone", 0.03, 0.1,
              "the IK stretches a limb at most 2% to meet a goal at full reach; a joint pulled 10% of its "
              "bone apart is a dislocated limb"),
    Threshold("spine_gap", "bone", 0.15, 0.33,
              "spine chords may stretch to 1.2 of rest (section 4.3.2) and interior bodies ride a spline, so "
              "a gap of 15% of a bone is by design; a third of a bone is a spine come apart"),
    Threshold("spine_chord", "ratio", 0.02, 0.1,
              "beyond the spine phase's [0.9, 1.2] chord limits (section 4.3.2) by 0.1: a spine that "
              "stretched or crushed"),
    Threshold("path_independence", "size", 1e-6, 1e-3,
              "the IK solves from rest each frame, so a pose must not depend on the frames before it; a "
              "thousandth of the size is a visible difference when a game scrubs or skips frames"),
    Threshold("mirror", "size", 1e-6, 1e-3,
              "a variant and its mirror image on a symmetric creature must be mirror poses"),
    Threshold("ms_per_tick", "ms", None, None, "reported: median wall time of one tick"),
)

BY_METRIC: dict[str, Threshold] = {t.metric: t for t in THRESHOLDS}

#: Verdicts, best to worst.
PASS, WARN, FAIL, NA = "pass", "warn", "fail", "na"
RANK = {PASS: 0, WARN: 1, FAIL: 2}


def verdict(metric: str, value: float) -> str:
    """pass / warn / fail of one value (an unknown metric is reported, never judged)."""
    t = BY_METRIC.get(metric)
    if t is None:
        return PASS
    if not (value == value):          # NaN
        return FAIL
    if t.fail is not None and value > t.fail:
        return FAIL
    if t.warn is not None and value > t.warn:
        return WARN
    return PASS


def table() -> list[dict]:
    """The table as JSON rows (for the report)."""
    return [{"metric": t.metric, "unit": t.unit, "warn": t.warn, "fail": t.fail, "why": t.why} for t in THRESHOLDS]
