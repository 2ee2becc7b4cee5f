"""Continuity: pops, flips and jitter, beyond what the goals themselves ask for.

A body that turns 2.8 rad between two frames while its goals barely moved has flipped; a
body that turns fast because its rotation goal (or a goal further out on its limb, or the
root) turned fast has not. Per frame step and body:

- ``turn`` the angle the body's world rotation turned, rad;
- ``asked`` the turn its goals ask for (``_kernels.asked_motion``: its own effective
  rotation goal, the angle every goal in its sub-tree moves as seen from its joint, what
  its parent was asked, the root's own turn), rad;
- the **excess** ``turn - asked``: the part nobody asked for.

Metrics (``continuity(rec, ctx)``):

``rotation_pop`` (rad per 60 Hz frame)    largest excess turn, mid-clip and at its ends
``position_pop`` (size per frame)         largest excess move: |move| - what the goals ask
``angular_speed`` (rad/s)                 largest turn rate (reported; detail per class)
``angular_accel`` (rad/s^2)               largest change of angular velocity beyond the
                                          goals' own (a kink: a fade that is not C1)
``jitter`` (size/s^3)                     largest third difference of a body's position
                                          beyond its goals' (shaking, not motion)
``start_pop`` / ``end_pop`` (rad)         ``rotation_pop`` in the fade-in (the first
                                          fade + 0.1 s) and from the fade-out on (the last
                                          fade + 0.1 s of the clip, and the settle after it)
``return_pose`` (size)                    after the settle, how far any body is from where a
                                          character playing nothing stands (not for a clip
                                          another continues: it hands over to that one)

Body classes (``detail``): ``ik`` (posed by the IK that frame), ``passive`` (Jiggles), and
``free`` (eyes, ears, spikes and details: small bodies nothing animates).
"""

from __future__ import annotations

import numpy as np

from engine.mathx import quat_conj, quat_mul, quat_rotate, quat_swing_twist
from engine.model.caps import DETAIL, EAR, EYE, SPIKE
from engine.validation import _kernels as K
from engine.validation.measure import Measure, worst

FREE_CAPS = EYE | EAR | SPIKE | DETAIL


def body_classes(creature, driven: np.ndarray) -> np.ndarray:
    """(nf, nb) int8: 0 ik (driven), 1 passive, 2 free detail (not driven, a detail cap)."""
    free = (creature.body_caps & np.uint32(FREE_CAPS)) != 0
    out = np.where(driven, 0, np.where(free[None, :], 2, 1)).astype(np.int8)
    return out


CLASS_NAMES = ("ik", "passive", "free")


def continuity(rec, ctx) -> list[Measure]:
    """The continuity measures of a recording (see the module docstring). ``ctx`` is the
    cell context (``engine.validation.cell.CellContext``: creature constants, scale, the
    rest reference)."""
    c = rec.creature
    names = c.body_names
    n = rec.nframe
    if n < 3:
        return []
    dt = rec.dt
    t = rec.t
    eff_pos, eff_rot = K.effective_goals(rec.goal_pos, rec.goal_rot, rec.goal_pw, rec.goal_rw, rec.root_pos,
                                         rec.root_rot, c.body_rootrel_pos, c.body_rootrel_rot)
    turn = K.step_angles(rec.world_rot)                       # (n-1, nb)
    asked, asked_move = K.asked_motion(c.body_parent, c.body_subtree_end, c.body_joint_offset, rec.world_pos,
                                       rec.world_rot, eff_pos, eff_rot, rec.goal_pw, rec.goal_rw, rec.root_rot,
                                       ctx.floor)
    excess = np.maximum(turn - asked, 0.0)
    move = np.linalg.norm(rec.world_pos[1:] - rec.world_pos[:-1], axis=-1)
    excess_move = np.maximum(move - asked_move, 0.0) / ctx.scale
    cls = body_classes(c, rec.driven[1:])
    # step i -> i+1 is reported at frame i+1 (the frame that shows it)
    out = []
    out.append(_pop("rotation_pop", excess, turn, asked, cls, c, t, 0, rec.world_rot))
    out.append(worst("position_pop", excess_move, "size/frame", names, t, frame_offset=1))

    speed = worst("angular_speed", turn / dt, "rad/s", names, t, frame_offset=1)
    for k, cname in enumerate(CLASS_NAMES):
        m = cls == k
        speed.detail[f"{cname}_max"] = float(turn[m].max() / dt) if m.any() else 0.0
    speed.series = None
    out.append(speed)

    # angular acceleration beyond the goals': the change of the turn rate between steps,
    # less the change of the asked rate (a goal that speeds up asks for it)
    if n >= 4:
        accel = np.abs(turn[1:] - turn[:-1]) - np.abs(asked[1:] - asked[:-1])
        accel = np.maximum(accel, 0.0) / (dt * dt)
        out.append(worst("angular_accel", accel, "rad/s^2", names, t, frame_offset=2))
    # jitter: third difference of positions, beyond the effective goals' own
    if n >= 5:
        x = rec.world_pos
        j = np.linalg.norm(x[3:] - 3 * x[2:-1] + 3 * x[1:-2] - x[:-3], axis=-1)
        g = eff_pos
        jg = np.linalg.norm(g[3:] - 3 * g[2:-1] + 3 * g[1:-2] - g[:-3], axis=-1)
        jit = np.maximum(j - _carry_max(c, jg), 0.0) / (dt ** 3) / ctx.scale
        out.append(worst("jitter", jit, "size/s^3", names, t, frame_offset=2))

    # the ends of the clip
    lead = int(round((rec.fade + 0.1) / dt))
    k0 = min(lead, len(excess))
    m = _pop("start_pop", excess[:k0], turn[:k0], asked[:k0], cls[:k0], c, t, 0, rec.world_rot)
    m.series = None
    out.append(m)
    e0 = max(rec.end_frame - lead - 1, 0)
    m = _pop("end_pop", excess[e0:], turn[e0:], asked[e0:], cls[e0:], c, t, e0, rec.world_rot)
    m.series = None
    out.append(m)

    # a clip another continues (a fall, then lying: ``engine.anim.chain``) hands over to it
    # instead of returning to the rest pose; that clip's cell judges where it ends
    if ctx.rest_pos is not None and rec.error is None and n >= 1 and "then" not in rec.meta:
        ref = ctx.rest_pos[min(n, len(ctx.rest_pos)) - 1]
        d = np.linalg.norm(rec.world_pos[-1] - ref, axis=-1) / ctx.scale
        b = int(np.argmax(d))
        out.append(Measure("return_pose", float(d[b]), "size", body=str(names[b]), frame=n - 1, time=float(t[-1])))
    return out


def _pop(name, excess, turn, asked, cls, c, t, offset, world_rot) -> Measure:
    """The worst excess turn as a Measure, with its turn (split into the swing of the
    body's long axis and the twist about it), what was asked, the class of the body, its
    parent's turn in that frame and the worst excess per body class."""
    m = worst(name, excess, "rad/frame", c.body_names, t, frame_offset=offset + 1)
    if excess.size:
        i, b = divmod(int(np.argmax(excess)), excess.shape[1])
        p = int(c.body_parent[b])
        m.detail["turn"] = float(turn[i, b])
        swing, twist = swing_twist(world_rot[offset + i, b], world_rot[offset + i + 1, b], bone_axis(c, b))
        m.detail["swing"] = swing
        m.detail["twist"] = twist
        m.detail["asked"] = float(asked[i, b])
        m.detail["class"] = CLASS_NAMES[int(cls[i, b])]
        m.detail["parent_turn"] = float(turn[i, p]) if p >= 0 else 0.0
        for k, cname in enumerate(CLASS_NAMES):
            sel = cls == k
            m.detail[f"{cname}_max"] = float(excess[sel].max()) if sel.any() else 0.0
    return m


def bone_axis(c, b: int) -> np.ndarray:
    """Unit axis of body ``b`` in its own frame along which a turn is a swing: from its
    joint to its origin (along the bone) where the box sits off its joint, else its box's
    longest axis."""
    off = np.asarray(c.body_joint_offset[b], float)
    ext = np.asarray(c.body_extent[b], float)
    n = float(np.linalg.norm(off))
    if n > 0.25 * float(ext.max()):
        return off / n
    a = np.zeros(3)
    a[int(np.argmax(ext))] = 1.0
    return a


def swing_twist(q0, q1, axis) -> tuple[float, float]:
    """(swing, twist) in radians of the turn from ``q0`` to ``q1`` (w-first, world): how
    far the body's ``axis`` (a unit vector in its frame, ``bone_axis``) swings, and how far
    the body then turns about it. A flip that is mostly twist is the orientation rebuild
    spinning a body about a bone that hardly moved (a twist reference's singular
    direction); mostly swing, the bones themselves jumped (the particles took another
    solution)."""
    q0 = np.asarray(q0, float)
    d = quat_mul(np.asarray(q1, float), quat_conj(q0))    # the world turn q0 -> q1
    sw, tw = quat_swing_twist(d, quat_rotate(q0, np.asarray(axis, float)))   # d = swing * twist about the bone
    return _angle(sw), _angle(tw)


def _angle(q) -> float:
    return float(2.0 * np.arctan2(np.linalg.norm(q[1:]), abs(float(q[0]))))


def _carry_max(c, per_body: np.ndarray) -> np.ndarray:
    """(nf, nb): for each body the largest value over itself, its sub-tree and its
    ancestors (the goals that can move it)."""
    nb = c.nbody
    out = np.empty_like(per_body)
    end = c.body_subtree_end
    parent = c.body_parent
    for b in range(nb):
        out[:, b] = per_body[:, b:end[b]].max(axis=1)
        p = parent[b]
        if p >= 0:
            out[:, b] = np.maximum(out[:, b], out[:, p])
    return out
