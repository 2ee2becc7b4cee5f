"""Movement modes and the functions G and S (Hecker et al. 2008, sections 3.2.1-3.2.2).

A channel's movement mode says what matters about its motion. It defines, for each
selected body b, the specialization ``q_s = S(b, q_g, m)`` from generalized to
character-space pose and its exact inverse, the generalization ``G``.

Position modes (``PositionSpec``):

``absolute``
    q_s = scale * q_g. Every selected body goes to the same place (no use as an
    "origin" at rest: the only mode where the rest pose is not q_g = 0).
``rest``
    q_s = rest + scale * q_g: a delta from the body's rest position.
``rest`` + ``ground``  (ground-relative, the paper's mode)
    z is distorted: z_g = 0 at the rest height, z_g = 1 with the body's rest box resting
    on the ground plane z = 0 (the body origin at the box's half-height), so "touch the
    ground" at z_g = 1 touches it on every creature with the same timing.
``rest`` + ``sagittal``  (sagittal-relative: planned in the paper's footnote 3, ours here)
    y is distorted the same way across the sagittal plane: y_s = y_rest * (1 - y_g),
    so y_g = 0 is the rest y and y_g = 1 is the sagittal plane y = 0, for left and right
    bodies alike (the axis points from the body toward the plane on either side). A clap
    keyed at y_g = 1 meets in the middle for any shoulder width; y_g = 1.2 crosses over by
    a fifth of each body's own offset. Bodies on the plane (``body_side == 0``) have no
    offset to scale; they get a short axis of ``SAGITTAL_MIN`` of the character's
    largest size, pointing right (left when mirrored), so G stays defined.
    ``ground`` and ``sagittal`` combine (they distort different axes).
``secondary``  (secondary-relative)
    The frame runs from the body's rest position toward the secondary target t (another
    query's body or a named external target): x_g = 0 at rest, x_g = 1 at the target; y
    is horizontal to the left of that direction (e_z x x), z completes a right-handed
    frame. The frame is rebuilt from the target at every evaluation, so a moving target
    drags the motion along and the rest pose stays the rest pose.
    With ``directional_only`` (SecondaryDirectionalOnly) the x axis keeps unit length
    (times the scale): the motion turns toward the target but keeps its size.
    With ``contact`` x_g = 1 is where the body's box touches the target's instead of where
    their origins meet: the x axis is shortened by both boxes' half-widths along it (their
    rest orientations; an external target is a point), so a hand brought to a mouth stops
    at the face, whatever the sizes of the hand, the head and the gap between them. The
    axis keeps at least a quarter of the distance (``_kernels.CONTACT_KEEP``).

Scale modes scale the axes that are not distorted: ``none`` (metres), ``creature_size``
(non-uniform, by the character's bounding-box size along x, y, z, so 0.1 means a tenth of
the creature's length / width / height) and ``limb_length`` (by the body's *reach*: its
limb length plus the distance from its joint to its origin, i.e. the path from the spine
to the body's centre; bodies on the spine get their half-segment, never zero).

Rotation modes (``RotationSpec``): ``absolute`` (q_s = q_g), ``rest`` (q_s = q_g * rest,
a delta in character space) and ``lookat`` (q_s = A * q_g * rest, where A turns the body's
rest forward axis, its local +X, toward the target; A fades to the identity through soft
joint limits as the target moves behind the body, from full strength while the angle is
<= limits[0] to none at limits[1], so of several heads the ones facing the target follow
it). In lookat mode q_g = identity means "the rest pose aimed at the target".

Mirroring (section 4.1.2): a mirrored slot (m true) reflects its generalized pose across
the sagittal plane before specializing: position y_g -> -y_g (the y axis is negated),
rotation (w, x, y, z) -> (w, -x, y, -z). Sagittal-relative y is its own mirror image.

All of a mode's per-body constants are computed once per (channel, creature, body), the
*slot*, into ``SlotConstants``; S then runs over slots in numba (``_kernels``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from engine.channels import _kernels as K
from engine.errors import DataError

POSITION_MODES = {"absolute": K.POS_ABSOLUTE, "rest": K.POS_REST, "secondary": K.POS_SECONDARY}
ROTATION_MODES = {"absolute": K.ROT_ABSOLUTE, "rest": K.ROT_REST, "lookat": K.ROT_LOOKAT}
SCALE_MODES = ("none", "creature_size", "limb_length")

#: Default soft joint limits of lookat, degrees: full aim up to 90 degrees off the body's
#: forward axis (the target in the front halfspace), none when it is straight behind.
LOOKAT_LIMITS = (90.0, 180.0)
#: Sagittal axis of a body on the sagittal plane, as a fraction of the creature's size.
SAGITTAL_MIN = 0.01
#: Shortest ground axis (m): a body whose box already rests on the ground.
MIN_GROUND_AXIS = 1e-9


#: Words written as a position mode that are flags beside it (the file's field names).
_FLAG_MODES = {"ground": "ground", "sagittal": "sagittal", "directional_only": "directional_only",
               "directional": "directional_only", "contact": "contact"}


@dataclass(frozen=True)
class PositionSpec:
    """How a channel's position curve is interpreted (see the module docstring)."""

    mode: str = "rest"
    ground: bool = False
    sagittal: bool = False
    directional_only: bool = False
    scale: str = "none"
    contact: bool = False

    def __post_init__(self) -> None:
        if self.mode not in POSITION_MODES:
            hint = ""
            if self.mode in _FLAG_MODES:
                hint = f"; {self.mode} is a flag beside the mode: {{mode: rest, {_FLAG_MODES[self.mode]}: true}}"
            raise DataError(f"unknown position mode {self.mode!r} (known: {', '.join(POSITION_MODES)}){hint}",
                            field="mode")
        if self.scale not in SCALE_MODES:
            raise DataError(f"unknown scale mode {self.scale!r} (known: {', '.join(SCALE_MODES)})",
                            field="scale")
        for flag in ("ground", "sagittal", "directional_only", "contact"):
            if not isinstance(getattr(self, flag), bool):
                raise DataError(f"'{flag}' must be true or false", field=flag)
        if (self.ground or self.sagittal) and self.mode != "rest":
            raise DataError(f"ground and sagittal distort the rest frame; they need mode 'rest', "
                            f"not {self.mode!r}", field="ground" if self.ground else "sagittal")
        if self.directional_only and self.mode != "secondary":
            raise DataError("directional_only (SecondaryDirectionalOnly) needs mode 'secondary'",
                            field="directional_only")
        if self.contact and (self.mode != "secondary" or self.directional_only):
            raise DataError("contact (x = 1 where the boxes touch) needs mode 'secondary' without "
                            "directional_only", field="contact")

    @property
    def flags(self) -> int:
        return ((K.FLAG_GROUND if self.ground else 0) | (K.FLAG_SAGITTAL if self.sagittal else 0)
                | (K.FLAG_DIRECTIONAL if self.directional_only else 0) | (K.FLAG_CONTACT if self.contact else 0))

    @property
    def needs_target(self) -> bool:
        return self.mode == "secondary"


@dataclass(frozen=True)
class RotationSpec:
    """How a channel's rotation curve is interpreted. ``limits`` (degrees, lookat only):
    the soft joint limits, 0 <= limits[0] < limits[1] <= 180 (degrees, the unit animators
    write; the slots hold radians)."""

    mode: str = "rest"
    limits: tuple[float, float] = LOOKAT_LIMITS

    def __post_init__(self) -> None:
        if self.mode not in ROTATION_MODES:
            raise DataError(f"unknown rotation mode {self.mode!r} (known: {', '.join(ROTATION_MODES)})",
                            field="mode")
        lo, hi = self.limits
        if not (0.0 <= lo < hi <= 180.0):
            raise DataError(f"lookat limits must satisfy 0 <= lo < hi <= 180 degrees, got {list(self.limits)}",
                            field="limits")

    @property
    def needs_target(self) -> bool:
        return self.mode == "lookat"


class SlotConstants(NamedTuple):
    """What S needs per slot (one selected body of one channel), computed once at bind.

    slot_body (n,) int32            the body
    slot_channel (n,) int32         the channel (index into the animation's channels)
    slot_pos_mode (n,) int32        K.POS_* (POS_NONE: the channel has no position)
    slot_pos_flags (n,) int32       K.FLAG_* bits
    slot_rot_mode (n,) int32        K.ROT_* (ROT_NONE: no rotation)
    slot_rest_pos (n, 3) float64    rest position of the body origin, character space, m
    slot_rest_rot (n, 4) float64    rest rotation
    slot_scale (n, 3) float64       scale of each axis (1, the creature size or the reach)
    slot_ground_axis (n,) float64   z axis of ground-relative mode: -(height of the body
                                    origin above its resting-on-the-ground height), m
    slot_sagittal_axis (n,) float64 y axis of sagittal-relative mode, m
    slot_mirror_sign (n,) float64   -1 mirrored, +1 not
    slot_forward (n, 3) float64     rest forward axis (the body's local +X), lookat
    slot_lookat_limits (n, 2)       soft joint limits, radians
    slot_target (n,) int32          row of the target table, -1 none
    slot_contact (n, 6, 3) float64  contact mode: the body's rest box half axes (3) and
                                    its target body's (3; zero for an external target)
    """

    slot_body: np.ndarray
    slot_channel: np.ndarray
    slot_pos_mode: np.ndarray
    slot_pos_flags: np.ndarray
    slot_rot_mode: np.ndarray
    slot_rest_pos: np.ndarray
    slot_rest_rot: np.ndarray
    slot_scale: np.ndarray
    slot_ground_axis: np.ndarray
    slot_sagittal_axis: np.ndarray
    slot_mirror_sign: np.ndarray
    slot_forward: np.ndarray
    slot_lookat_limits: np.ndarray
    slot_target: np.ndarray
    slot_contact: np.ndarray

    @property
    def nslot(self) -> int:
        return int(self.slot_body.shape[0])


@dataclass(frozen=True)
class Slot:
    """One slot before packing: a body posed by a channel with these modes."""

    body: int
    position: PositionSpec | None
    rotation: RotationSpec | None
    mirror: bool = False
    target: int = -1
    channel: int = 0
    target_body: int = -1      # the body whose position the target row holds (-1: external)


def body_reach(creature, body: int) -> float:
    """The LimbLength scale of a body: limb length + |origin - joint| (never 0)."""
    reach = float(creature.body_limb_length[body]) + float(
        np.linalg.norm(creature.body_rest_pos[body] - creature.body_joint[body]))
    return max(reach, float(np.max(creature.body_extent[body])))


def ground_height(creature, body: int) -> float:
    """Height of the body origin when its rest box rests on the ground: the box's
    half-height along z in its rest rotation."""
    from engine.mathx.quat import quat_to_matrix

    rot = quat_to_matrix(np.ascontiguousarray(creature.body_rest_rot[body]))
    return float(np.abs(rot[2]) @ creature.body_extent[body])


def _half_axes(creature, body: int) -> np.ndarray:
    """(3, 3) rows: the body's rest box axes times its half extents, character space."""
    from engine.mathx.quat import quat_to_matrix

    rot = quat_to_matrix(np.ascontiguousarray(creature.body_rest_rot[body]))
    return (rot * np.asarray(creature.body_extent[body], float)[None, :]).T


def build_slots(creature, slots: list[Slot]) -> SlotConstants:
    """Pack slots into the read-only arrays S runs over. Runs once per binding."""
    n = len(slots)
    body = np.array([s.body for s in slots], np.int32).reshape(n)
    if n and (body.min() < 0 or body.max() >= creature.nbody):
        raise DataError(f"slot body index out of range 0..{creature.nbody - 1}")
    size = np.asarray(creature.size, float)
    big = float(np.max(size))
    out = dict(
        slot_body=body,
        slot_channel=np.array([s.channel for s in slots], np.int32).reshape(n),
        slot_pos_mode=np.zeros(n, np.int32), slot_pos_flags=np.zeros(n, np.int32),
        slot_rot_mode=np.zeros(n, np.int32),
        slot_rest_pos=np.ascontiguousarray(creature.body_rest_pos[body], float).reshape(n, 3),
        slot_rest_rot=np.ascontiguousarray(creature.body_rest_rot[body], float).reshape(n, 4),
        slot_scale=np.ones((n, 3)), slot_ground_axis=np.zeros(n), slot_sagittal_axis=np.zeros(n),
        slot_mirror_sign=np.ones(n), slot_forward=np.zeros((n, 3)),
        slot_lookat_limits=np.tile(np.radians(LOOKAT_LIMITS), (n, 1)).reshape(n, 2),
        slot_target=np.array([s.target for s in slots], np.int32).reshape(n),
        slot_contact=np.zeros((n, 6, 3)),
    )
    from engine.mathx.quat import quat_rotate

    for i, s in enumerate(slots):
        b = s.body
        sign = -1.0 if s.mirror else 1.0
        out["slot_mirror_sign"][i] = sign
        if s.position is not None:
            p = s.position
            out["slot_pos_mode"][i] = POSITION_MODES[p.mode]
            out["slot_pos_flags"][i] = p.flags
            if p.scale == "creature_size":
                out["slot_scale"][i] = size
            elif p.scale == "limb_length":
                out["slot_scale"][i] = body_reach(creature, b)
            h = float(creature.body_rest_pos[b, 2]) - ground_height(creature, b)
            out["slot_ground_axis"][i] = -math.copysign(max(abs(h), MIN_GROUND_AXIS), h)
            side = int(creature.body_side[b])
            y = float(creature.body_rest_pos[b, 1])
            out["slot_sagittal_axis"][i] = -y if side != 0 else -SAGITTAL_MIN * big * sign
            if p.contact:
                out["slot_contact"][i, :3] = _half_axes(creature, b)
                if 0 <= s.target_body < creature.nbody:
                    out["slot_contact"][i, 3:] = _half_axes(creature, s.target_body)
        if s.rotation is not None:
            out["slot_rot_mode"][i] = ROTATION_MODES[s.rotation.mode]
            out["slot_lookat_limits"][i] = np.radians(s.rotation.limits)
            out["slot_forward"][i] = quat_rotate(np.ascontiguousarray(creature.body_rest_rot[b]),
                                                 np.array([1.0, 0.0, 0.0]))
        needs = (s.position is not None and s.position.needs_target) or (
            s.rotation is not None and s.rotation.needs_target)
        if needs and s.target < 0:
            raise DataError(f"body '{creature.body_names[b]}': its mode needs a secondary target "
                            "(a secondary query or an external target)", subject=creature.body_names[b])
    for key, value in out.items():
        value = np.ascontiguousarray(value)
        value.flags.writeable = False
        out[key] = value
    return SlotConstants(**out)


# -- S and G from Python -------------------------------------------------------------------


def _targets(targets, nslot_needs: bool) -> np.ndarray:
    if targets is None:
        return np.zeros((1, 3))
    t = np.ascontiguousarray(targets, dtype=np.float64)
    if t.ndim != 2 or t.shape[1] != 3:
        raise DataError(f"targets must have shape (ntarget, 3), got {t.shape}", field="targets")
    if len(t) == 0:
        return np.zeros((1, 3))
    return t


def specialize(c: SlotConstants, qg_pos, qg_rot, targets=None, out_pos=None, out_rot=None):
    """S over every slot. qg_pos (nslot, 3), qg_rot (nslot, 4) -> q_s, written into
    out_pos/out_rot when given (the per-frame path) or new arrays."""
    n = c.nslot
    qg_pos = np.ascontiguousarray(qg_pos, dtype=np.float64).reshape(n, 3)
    qg_rot = np.ascontiguousarray(qg_rot, dtype=np.float64).reshape(n, 4)
    out_pos = np.zeros((n, 3)) if out_pos is None else out_pos
    out_rot = np.tile(np.array([1.0, 0.0, 0.0, 0.0]), (n, 1)) if out_rot is None else out_rot
    K.specialize_kernel(c, _targets(targets, True), qg_pos, qg_rot, out_pos, out_rot,
                        np.zeros((3, 3)), np.zeros((3, 4)))
    return out_pos, out_rot


def frames(c: SlotConstants, targets=None):
    """Every slot's frames: origin (n, 3), axes (n, 3, 3), front (n, 4), back (n, 4)."""
    t = _targets(targets, True)
    n = c.nslot
    origin, axes = np.zeros((n, 3)), np.zeros((n, 3, 3))
    front, back = np.zeros((n, 4)), np.zeros((n, 4))
    for i in range(n):
        K.position_frame_into(c, i, t, origin[i], axes[i])
        K.rotation_frame_into(c, i, t, front[i], back[i])
    return origin, axes, front, back


def _qmul(a, b):
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], -1)


def _qconj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def generalize(c: SlotConstants, qs_pos, qs_rot, targets=None):
    """G over every slot, the exact inverse of S (numpy; tools and key remapping).
    qs_pos (nslot, 3), qs_rot (nslot, 4) -> q_g (new arrays). Rotations keep their sign:
    G(S(q)) returns q itself, not -q."""
    n = c.nslot
    qs_pos = np.asarray(qs_pos, dtype=float).reshape(n, 3)
    qs_rot = np.asarray(qs_rot, dtype=float).reshape(n, 4)
    origin, axes, front, back = frames(c, targets)
    qg_pos = np.zeros((n, 3))
    has_pos = c.slot_pos_mode != K.POS_NONE
    if np.any(has_pos):
        qg_pos[has_pos] = np.linalg.solve(axes[has_pos], (qs_pos - origin)[has_pos][..., None])[..., 0]
    qg_rot = np.tile(np.array([1.0, 0.0, 0.0, 0.0]), (n, 1))
    has_rot = c.slot_rot_mode != K.ROT_NONE
    if np.any(has_rot):
        q = _qmul(_qmul(_qconj(front), qs_rot), _qconj(back))
        mirror = (c.slot_mirror_sign < 0)[:, None] * np.array([False, True, False, True])
        q = np.where(mirror, -q, q)
        qg_rot[has_rot] = q[has_rot]
    return qg_pos, qg_rot
