"""Measuring a gait on the runtime's output (issue 6's quality figures).

``run_scenario(creature, ...)`` walks a ``Character`` along a curved path with speed
changes, a sudden stop, a reverse and a sharp turn, on flat ground or on rolling
terrain scaled to the creature, and measures on ``char.world_positions`` (after the IK):

- ``stance_slide_mm``: the largest distance a foot's contact point moves in world space
  during one stance (from its first stance frame). The contact point is the point of the
  foot body that touches the ground at rest (``rig.foot_contact``, carried by the foot's
  output pose): a foot that rolls or pivots about it (a centipede's tibia) is planted, a
  foot that turns about its origin while its tip scrapes the ground is not;
- ``touchdown_error_mm``: the largest |contact height - terrain height| at touchdown;
- ``below_ground_mm``: how far a contact point ever gets below the terrain (0 if never).
  A crawler's pseudo-feet roll as the spine arches: their contact point is taken as the
  body origin minus its rest height above its lowest corner;
- ``stretch_ratio``: the largest hip-joint to foot-joint distance over the leg's chain
  length (1 = straight; the IK's limb constraints stretch at most 2%);
- ``root_accel``: the largest root acceleration, leg lengths per s^2 (continuity: the
  commanded velocity jumps, the root must not), and ``root_accel_time`` when it was, s;
- ``foot_speed``: the largest foot speed, leg lengths per s;
- ``over_bound``: True when foot speed or root acceleration exceed ``continuity_bound``;
- ``finite``: every output was finite;
- ``travel``: distance the character covered, in leg lengths (the command asks for about
  7 leg lengths in 8 s; a gait that cannot step without its feet missing their goals
  stands still instead, see ``GaitController._calibrate``).
"""

from __future__ import annotations

import time

import numpy as np

from engine.mathx import quat_mul_batch, quat_rotate_batch
from engine.model.creature import Creature

#: Continuity bounds (issue 6) the scenario's sudden stop, reverse and sharp turn must stay
#: under, measured on the runtime's output: foot speed in leg lengths per second, root
#: acceleration in leg lengths per second squared. What a viewer sees of a root acceleration
#: ``a`` at 60 Hz is a one-frame departure from a smooth path of ``a * dt^2`` = a / 3600 leg
#: lengths. Knee-less (compass) legs: their hips ride on arcs over the planted feet and the
#: arc's vertical velocity turns over at each (instantaneous) double support, a kink a rigid
#: walker has by its geometry; 120 is a one-frame departure of 1/30 of a leg (1.5% of a
#: biped's size), under the grid's position_pop warning (2% of the size in a frame,
#: engine/validation/thresholds.py): a hop nobody sees. Beyond it the hips jump visibly (the
#: test biped's 306 at the sidestep turn, before the hip hike eased out, was 8.5% of its leg
#: in one frame; 64 now). Legs with knees bend through the kink: 25 (0.7% of a leg a frame).
FOOT_SPEED_BOUND = 12.0
ROOT_ACCEL_BOUND = 25.0
ROOT_ACCEL_BOUND_COMPASS = 120.0


def continuity_bound(rig) -> tuple[float, float]:
    """(foot speed, root acceleration) bounds for a creature's gait rig (see above)."""
    compass = rig.mode == "walk" and rig.nfoot > 0 and bool(np.any(rig.foot_rigid == 1))
    return FOOT_SPEED_BOUND, ROOT_ACCEL_BOUND_COMPASS if compass else ROOT_ACCEL_BOUND


def rolling_terrain(scale: float, amplitude: float = 0.06):
    """Gentle hills sized to a creature of leg length ``scale`` (height in m, vectorised)."""
    a = amplitude * scale
    lam = 2.5 * max(scale, 1e-3)

    def height(x, y):
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        return a * (np.sin(x / lam) + 0.7 * np.cos(0.8 * y / lam + 0.3) + 0.3 * np.sin((x + y) / (0.6 * lam)))

    return height


def scenario_commands(t: float, L: float):
    """(forward, left, turn) at time t for a creature of leg length L: curved walk, faster
    curve, sudden stop, reverse, sharp turn, walk on."""
    if t < 2.0:
        return 0.8 * L, 0.0, 0.4
    if t < 4.0:
        return 1.4 * L, 0.0, -0.3
    if t < 4.8:
        return 0.0, 0.0, 0.0                  # sudden stop
    if t < 6.0:
        return -0.5 * L, 0.0, 0.0             # reverse
    if t < 7.0:
        return 0.8 * L, 0.3 * L, 1.2          # sharp turn with a sidestep
    return 1.0 * L, 0.0, 0.0


def run_scenario(creature: Creature, seconds: float = 8.0, dt: float = 1.0 / 60.0, terrain: bool = True,
                 style: str | None = None, commands=None) -> dict:
    """Walk ``creature`` and measure (see the module docstring)."""
    from engine.runtime import Character

    ch = Character(creature)
    ch.locomote((0.0, 0.0), 0.0)
    gait = ch.gait
    rig = gait.rig
    L = float(np.max(rig.group_length)) if rig.ngroup else max(float(creature.size[2]), 0.1)
    if style is not None:
        gait.set_style(style)
    height = rolling_terrain(L) if terrain else None
    if height is not None:
        ch.set_terrain(height)
    commands = commands or scenario_commands
    nsteps = int(round(seconds / dt))
    feet = rig.foot_body
    F = len(feet)
    stance_start = np.zeros((F, 3))
    in_stance = np.zeros(F, bool)
    out = {"creature": creature.name, "mode": rig.mode, "legs": creature.nleg, "groups": rig.ngroup,
           "stance_slide_mm": 0.0, "touchdown_error_mm": 0.0, "below_ground_mm": 0.0, "stretch_ratio": 0.0,
           "root_accel": 0.0, "root_accel_time": 0.0, "foot_speed": 0.0, "finite": True, "stances": 0, "gait_ms": 0.0,
           "tick_ms": 0.0,
           "worst": "", "travel": 0.0}
    # hip and foot joints for the stretch ratio (walkers only)
    if rig.mode == "walk":
        limb_root = np.array([int(creature.limb_root[creature.body_limb[f]]) for f in feet])
        chain = np.array([float(creature.body_limb_length[f]) for f in feet])
    last_place = ch.position
    prev_root = None
    prev_root_v = None
    prev_feet = None
    t_all = 0.0
    warm = 10
    for i in range(nsteps):
        t = i * dt
        vx, vy, w = commands(t, L)
        ch.locomote((vx, vy), w)
        t0 = time.perf_counter()
        ch.tick(dt)
        t1 = time.perf_counter()
        if i >= warm:
            t_all += t1 - t0
        wp = ch.world_positions
        if not np.all(np.isfinite(wp)) or not np.all(np.isfinite(ch.world_rotations)):
            out["finite"] = False
            break
        # continuity of the root
        root = wp[0].copy()
        pp = ch.position
        out["travel"] += float(np.hypot(pp[0] - last_place[0], pp[1] - last_place[1])) / L
        last_place[:] = pp
        if prev_root is not None:
            v = (root - prev_root) / dt
            if prev_root_v is not None and i > warm:
                acc = float(np.linalg.norm(v - prev_root_v)) / dt / L
                if acc > out["root_accel"]:
                    out["root_accel"], out["root_accel_time"] = acc, t
            prev_root_v = v
        prev_root = root
        if F == 0:
            continue
        fp = wp[feet]
        if prev_feet is not None and i > warm:
            out["foot_speed"] = max(out["foot_speed"], float(np.max(np.linalg.norm(fp - prev_feet, axis=1))) / dt / L)
        prev_feet = fp.copy()
        if rig.mode == "walk":
            cp = contact_points(rig, wp, ch.world_rotations)
        else:
            cp = fp.copy()
            cp[:, 2] -= rig.foot_offset
        ground = height(cp[:, 0], cp[:, 1]) if height is not None else np.zeros(F)
        contact = cp[:, 2]
        out["below_ground_mm"] = max(out["below_ground_mm"], float(np.max(ground - contact)) * 1000.0)
        state = gait.step_state[rig.foot_stepper]
        stance = state == 0
        for f in range(F):
            if stance[f] and not in_stance[f]:
                stance_start[f] = cp[f]
                if i > 0:
                    err = abs(float(contact[f] - ground[f])) * 1000.0
                    if err > out["touchdown_error_mm"]:
                        out["touchdown_error_mm"] = err
                    out["stances"] += 1
            elif stance[f]:
                slide = float(np.linalg.norm(cp[f] - stance_start[f])) * 1000.0
                if slide > out["stance_slide_mm"]:
                    out["stance_slide_mm"] = slide
                    out["worst"] = f"{creature.body_names[feet[f]]} t={t:.2f}s"
        in_stance = stance
        if rig.mode == "walk":
            wr = ch.world_rotations
            for f in range(F):
                b = feet[f]
                foot_joint = fp[f] - _rot(wr[b], creature.body_joint_offset[b])
                h = limb_root[f]
                hip_joint = wp[h] - _rot(wr[h], creature.body_joint_offset[h])
                if chain[f] > 0:
                    out["stretch_ratio"] = max(out["stretch_ratio"], float(np.linalg.norm(foot_joint - hip_joint))
                                               / chain[f])
    fb, rb = continuity_bound(rig)
    out["over_bound"] = bool(out["foot_speed"] > fb or out["root_accel"] > rb)
    out["tick_ms"] = 1000.0 * t_all / max(nsteps - warm, 1)
    return out


def contact_points(rig, world_pos: np.ndarray, world_rot: np.ndarray) -> np.ndarray:
    """Where each foot of ``rig`` touches the ground (F, 3): its rest contact point
    (``rig.foot_contact``) carried by the foot's pose in ``world_pos`` (nbody, 3) and
    ``world_rot`` (nbody, 4)."""
    feet = rig.foot_body
    rest = rig.foot_rest_rot
    turn = quat_mul_batch(np.ascontiguousarray(world_rot[feet]),
                          np.ascontiguousarray(rest * np.array([1.0, -1.0, -1.0, -1.0])))
    return world_pos[feet] + quat_rotate_batch(turn, np.ascontiguousarray(rig.foot_contact))


def gait_ms(creature: Creature, frames: int = 240, dt: float = 1.0 / 60.0) -> float:
    """Mean wall time of ``GaitController.step`` alone per frame (ms), walking on terrain."""
    from engine.runtime import Character

    ch = Character(creature)
    ch.locomote((0.0, 0.0), 0.0)
    L = float(np.max(ch.gait.rig.group_length)) if ch.gait.rig.ngroup else 0.5
    ch.set_terrain(rolling_terrain(L))
    s, r = ch._stack, ch._row
    for _ in range(20):
        ch.locomote((L, 0.0), 0.3)
        ch.tick(dt)
    t0 = time.perf_counter()
    for _ in range(frames):
        s.goal_pw[r] = 0.0                  # what the blend does every frame
        ch.gait.step(dt, s.place_pos[r], s.place_rot[r], s.root_pos[r], s.root_rot[r], s.goal_pos[r],
                     s.goal_rot[r], s.goal_pw[r], s.goal_rw[r])
    return 1000.0 * (time.perf_counter() - t0) / frames


def _rot(q, v):
    u = q[1:]
    t = 2.0 * np.cross(u, v)
    return v + q[0] * t + np.cross(u, t)
