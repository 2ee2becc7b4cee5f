"""Motion capture replayed on physical bodies (Wilke & Semwal, "Generative Animation in a
Physics Engine using Motion Captures"), on Menagerie's own integrator (engine.physics).

    rig = MocapRig(load_bvh("walk.bvh"), mode="constrained")
    result = track(rig, TrackingParams(order=5, k_f=40.0),
                   scales=[VelocityScale("RightFoot", 1.2, 200, 600)],
                   control=ControlOptions(uncontrolled=("LeftHand",), locked=("LeftLeg",)))
    result.report()          # mean squared positional error and variance, per joint and overall
    result.to_bvh()          # the simulated motion as a BvhClip (save with engine.io.save_bvh)

The skeleton as bodies: each BVH joint j owns one rigid body rb(j). In the two skeleton
modes it is a capsule along j's bone (from the joint to its child joint, or to the mean
of its children when it has several, or to its end site); a joint with no bone (zero
offset) is a sphere. In ``independent`` mode every joint is a sphere at the joint point:
the paper's independent rigid bodies, whose error is measured at their centre.

Modes (the three the paper compares, section 2):
    independent   spheres at the joints, no constraints
    skeleton      capsules along the bones, no constraints ("physical skeleton")
    constrained   capsules joined by ball joints at the joint points
                  ("constrained physical skeleton")

Control (paper eqs. 1-3): between frames f and f+1 each controlled body gets the central
force F = K_f m (K_vc K_v(j, f+1) v(j, f+1) - v_body), where v(j, f) is the velocity of
the body's centre in the capture, by a central difference of odd order n (3..19 points),
K_vc scales every velocity symmetrically and K_v(j, f) scales one joint over a frame
range (asymmetric scaling). Under-controlling leaves a set of bodies uncontrolled, locks
joints (all rotation fixed at the capture's first frame: the zombie's stiff knee) and
overrides body masses. Ground: the terrain at the lowest point the capture's capsules
reach, feet (names with foot/toe/ankle) with the paper's foot handler.

Error (paper eq. 4): e_p(j, f) = r(j, f) - p(rb(j), f), r the capture's joint position,
p the body's joint end (skeleton modes) or centre (independent), gathered in one pass
with Welford's method per joint and overall, in m^2.

Units: Menagerie's metres, so K_vc = 1 replays the capture at its own speed. The paper's
K_vc ~ 100 is a unit factor of its Bullet scene, not a property of the method.
"""

from __future__ import annotations

import math
import re
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from engine import compiling
from engine.errors import DataError
from engine.io.bvh import BvhClip, auto_scale, quat_mul, quat_rotate, quat_to_menagerie_axes, to_menagerie_axes
from engine.physics import BodySpec, PhysicsState, Terrain, WorldSettings, build_model, step
from engine.physics.model import PhysicsModel
from engine.physics.world import joint_separation
from engine.response import _kernels as RK

MODES = ("independent", "skeleton", "constrained")
MIN_ORDER, MAX_ORDER = 3, 19
_FOOT_RE = re.compile(r"(foot|toe|ankle)", re.IGNORECASE)


class TrackingError(DataError):
    """Bad tracking input: a mode, order, joint name, frame range or gain."""

    def __init__(self, message, **kw):
        kw.setdefault("kind", "joint")
        super().__init__(message, **kw)


# ---------------------------------------------------------------------------------------
# Parameters (defaults in one place)
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrackingParams:
    """order: central-difference points n (odd, 3..19); k_f: controller gain (1/s);
    k_vc: symmetric velocity scale; dt, substeps: the physics step; ground: simulate
    the floor; density: kg/m^3 of the bodies; gravity_comp: add m g upward to every
    controlled body (not in the paper: its P controller alone leaves a steady velocity
    error g / K_f downward, which is most of its drift)."""

    order: int = 5
    k_f: float = 40.0
    k_vc: float = 1.0
    dt: float = 0.0005
    substeps: int = 1
    ground: bool = True
    density: float = 1000.0
    gravity_comp: bool = False

    def validate(self) -> None:
        if int(self.order) != self.order or self.order % 2 == 0 or not MIN_ORDER <= self.order <= MAX_ORDER:
            raise TrackingError(f"order must be odd and in {MIN_ORDER}..{MAX_ORDER}, got {self.order}",
                                field="order", kind="parameter", subject="order")
        for name in ("k_f", "k_vc", "dt", "density"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise TrackingError(f"{name} must be a positive number, got {v!r}", field=name,
                                    kind="parameter", subject=name)
        if int(self.substeps) != self.substeps or self.substeps < 1:
            raise TrackingError(f"substeps must be a positive integer, got {self.substeps}", field="substeps",
                                kind="parameter", subject="substeps")


#: A scale's last frame when it has no window: to the end of the clip.
_TO_THE_END = 10**9


class TrackingWarning(UserWarning):
    """Input the tracker accepted but changed (a scale window past the clip)."""


@dataclass(frozen=True)
class VelocityScale:
    """Asymmetric scaling (paper eq. 3): K_v(joint, f) = k for f0 <= f <= f1."""

    joint: str
    k: float
    f0: int = 0
    f1: int = 10**9   # _TO_THE_END

    @classmethod
    def parse(cls, text: str) -> VelocityScale:
        """``JOINT:K`` or ``JOINT:K@F0-F1`` (frames inclusive), e.g. ``RightFoot:1.2@200-600``."""
        m = re.fullmatch(r"\s*([^:@\s]+)\s*:\s*([-+0-9.eE]+)\s*(?:@\s*(\d+)\s*-\s*(\d+))?\s*", text)
        if not m:
            raise TrackingError(f"bad scale '{text}': expected JOINT:K or JOINT:K@F0-F1", field="scale",
                                subject=text)
        try:
            k = float(m.group(2))
        except ValueError:
            raise TrackingError(f"bad scale factor in '{text}'", field="scale", subject=text) from None
        f0 = int(m.group(3)) if m.group(3) else 0
        f1 = int(m.group(4)) if m.group(4) else _TO_THE_END
        return cls(m.group(1), k, f0, f1)


@dataclass(frozen=True)
class ControlOptions:
    """Under-controlling (paper section 1.2 and 2.2): bodies left uncontrolled, joints
    locked (constrained mode), per-body masses in kg."""

    uncontrolled: tuple = ()
    locked: tuple = ()
    mass: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------------------
# Central differences of odd order (3..19 points)
# ---------------------------------------------------------------------------------------


def central_difference_weights(order: int) -> np.ndarray:
    """Weights w_k, k = -m..m (m = (order-1)/2), of the first derivative from ``order``
    equally spaced samples: sum_k w_k k^p = [p == 1] for p = 0..order-1 (exact for
    polynomials of degree order-1), solved as a Vandermonde system."""
    m = (order - 1) // 2
    k = np.arange(-m, m + 1, dtype=np.float64)
    A = np.vander(k, order, increasing=True).T      # A[p, i] = k_i^p
    b = np.zeros(order)
    b[1] = 1.0
    return np.linalg.solve(A, b)


def central_difference(x: np.ndarray, order: int, frame_time: float) -> np.ndarray:
    """d/dt of samples x (nf, ...) by the ``order``-point central difference; near the
    ends the stencil shrinks to the widest one that fits (one-sided at the very ends)."""
    nf = x.shape[0]
    out = np.empty_like(x)
    if nf == 1:
        out[:] = 0.0
        return out
    m_full = (order - 1) // 2
    w_full = central_difference_weights(order)
    for f in range(nf):
        m = min(m_full, f, nf - 1 - f)
        if m == m_full:
            w = w_full
        elif m >= 1:
            w = central_difference_weights(2 * m + 1)
        else:
            # first/last frame: one-sided difference
            out[f] = (x[1] - x[0]) if f == 0 else (x[-1] - x[-2])
            out[f] /= frame_time
            continue
        seg = x[f - m:f + m + 1]
        out[f] = np.tensordot(w, seg, axes=(0, 0)) / frame_time
    return out


# ---------------------------------------------------------------------------------------
# The capture as bodies
# ---------------------------------------------------------------------------------------


def _quat_z_to(d: np.ndarray) -> np.ndarray:
    """Unit quaternion rotating +z onto direction d (shortest arc; +x flip for -z)."""
    d = d / np.linalg.norm(d)
    c = float(d[2])
    if c < -1.0 + 1e-12:
        return np.array([0.0, 1.0, 0.0, 0.0])
    axis = np.cross([0.0, 0.0, 1.0], d)
    q = np.array([1.0 + c, axis[0], axis[1], axis[2]])
    return q / np.linalg.norm(q)


def _qconj(q):
    return q * np.array([1.0, -1.0, -1.0, -1.0])


class MocapRig:
    """A BVH capture as rigid bodies (one per joint) for one mode; see the module
    docstring. Built once per (clip, mode, options); ``model`` is the PhysicsModel.

    Arrays (nf frames, nj joints = bodies, Menagerie axes, metres):
        joint_pos (nf, nj, 3), joint_rot (nf, nj, 4)  the capture's joints, world
        body_pos (nf, nj, 3), body_rot (nf, nj, 4)    the bodies' poses in the capture
        bone_local (nj, 3)     the bone vector in the joint frame (zero: a sphere)
        body_align (nj, 4)     body frame relative to the joint frame
        point_local (nj, 3)    the measured point (joint end or centre) in the body frame
    """

    def __init__(self, clip: BvhClip, mode: str = "constrained", *, scale: float | None = None,
                 control: ControlOptions | None = None, params: TrackingParams | None = None,
                 frames: tuple[int, int] | None = None) -> None:
        if mode not in MODES:
            raise TrackingError(f"unknown mode '{mode}' (known: {', '.join(MODES)})", field="mode",
                                kind="parameter", subject=mode, path=clip.path)
        params = params or TrackingParams()
        params.validate()
        control = control or ControlOptions()
        self.clip = clip
        self.mode = mode
        self.params = params
        self.control = control
        names = clip.joint_names
        for field_name, items in (("uncontrolled", control.uncontrolled), ("locked", control.locked),
                                  ("mass", tuple(control.mass))):
            for nm in items:
                if nm not in names:
                    import difflib

                    close = difflib.get_close_matches(nm, names, n=3)
                    hint = f"; did you mean {', '.join(close)}?" if close else ""
                    raise TrackingError(f"no joint '{nm}' in the capture{hint}", subject=nm, field=field_name,
                                        path=clip.path)
        for nm in control.locked:
            if mode != "constrained":
                raise TrackingError("joints can only be locked in constrained mode", subject=nm, field="locked",
                                    path=clip.path)
            if clip.joint_parent[names.index(nm)] < 0:
                raise TrackingError("the root has no joint to lock", subject=nm, field="locked", path=clip.path)
        for nm, kg in control.mass.items():
            if not (isinstance(kg, (int, float)) and math.isfinite(kg) and kg > 0):
                raise TrackingError(f"mass must be a positive number of kg, got {kg!r}", subject=nm, field="mass",
                                    path=clip.path)
        if scale is None:
            scale, _ = auto_scale(clip)
        self.scale = float(scale)
        nf_all = clip.nframe
        f0, f1 = (0, nf_all - 1) if frames is None else frames
        if not (0 <= f0 < f1 <= nf_all - 1):
            raise TrackingError(f"frame range {f0}-{f1} is outside 0-{nf_all - 1} or empty", field="frames",
                                kind="parameter", subject="frames", path=clip.path)
        self.frame0 = int(f0)
        sel = np.arange(f0, f1 + 1)
        wp, wr = clip.forward_kinematics(sel)
        self.joint_pos = to_menagerie_axes(wp, self.scale)
        self.joint_rot = quat_to_menagerie_axes(wr)
        nj = clip.njoint
        self.njoint = nj
        parent = clip.joint_parent
        # bones: to the child joint, the mean of several children, or the end site
        bone = np.zeros((nj, 3))
        reach = np.zeros(nj)          # mean distance to the children (a hub's size)
        for j in range(nj):
            kids = [c for c in range(nj) if parent[c] == j]
            vecs = [clip.joint_offset[c] for c in kids if np.linalg.norm(clip.joint_offset[c]) > 0]
            if not vecs and not np.isnan(clip.joint_end_site[j, 0]):
                vecs = [clip.joint_end_site[j]]
            if vecs:
                bone[j] = to_menagerie_axes(np.mean(vecs, axis=0), self.scale)
                reach[j] = float(np.mean([np.linalg.norm(v) for v in vecs])) * self.scale
        height = max(clip.standing_height() * self.scale, 1e-6)
        self.height = height
        length = np.linalg.norm(bone, axis=1)
        min_bone = 0.02 * height
        # a hub whose children pull apart (hips between two legs) has a short mean bone:
        # it becomes a sphere sized by its reach, not a sliver
        self.is_capsule = (length > min_bone) & (length > 0.5 * reach) & (mode != "independent")
        # radius: a tenth of the bone, within 1%..5% of the actor's height; spheres half
        # their reach (a pelvis), at least 1.5% of the height
        self.radius = np.clip(0.1 * length, 0.01 * height, 0.05 * height)
        if mode == "independent":
            self.radius[:] = 0.015 * height
        else:
            self.radius[~self.is_capsule] = np.clip(0.5 * reach[~self.is_capsule], 0.015 * height, 0.06 * height)
        self.bone_local = np.where(self.is_capsule[:, None], bone, 0.0)
        self.body_align = np.tile([1.0, 0.0, 0.0, 0.0], (nj, 1))
        centre_local = np.zeros((nj, 3))
        self.point_local = np.zeros((nj, 3))
        for j in range(nj):
            if self.is_capsule[j]:
                self.body_align[j] = _quat_z_to(self.bone_local[j])
                centre_local[j] = 0.5 * self.bone_local[j]
                self.point_local[j] = [0.0, 0.0, -0.5 * length[j]]
        self.body_pos = self.joint_pos + quat_rotate(self.joint_rot, np.broadcast_to(centre_local,
                                                                                     self.joint_pos.shape))
        self.body_rot = quat_mul(self.joint_rot, np.broadcast_to(self.body_align, self.joint_rot.shape))
        # ground: the lowest point any body reaches in the capture
        half = np.where(self.is_capsule, np.maximum(length / 2 - self.radius, 0.0), 0.0)
        axis_world = quat_rotate(self.body_rot, np.broadcast_to([0.0, 0.0, 1.0], self.body_pos.shape))
        low = self.body_pos[..., 2] - np.abs(axis_world[..., 2]) * half - self.radius
        self.ground_z = float(low.min())
        self.model = self._build_model(length)

    @property
    def nframe(self) -> int:
        return int(self.joint_pos.shape[0])

    @property
    def frame_time(self) -> float:
        return self.clip.frame_time

    def _build_model(self, length) -> PhysicsModel:
        clip, control, p = self.clip, self.control, self.params
        specs = []
        for j, name in enumerate(clip.joint_names):
            par = int(clip.joint_parent[j])
            constrained = self.mode == "constrained" and par >= 0
            common = dict(name=name, pos=self.body_pos[0, j], rot=self.body_rot[0, j], density=p.density,
                          mass=control.mass.get(name), contact=("foot" if _FOOT_RE.search(name) else "ground")
                          if p.ground else "none", parent=par if constrained else -1,
                          joint=self.joint_pos[0, j] if constrained else None, locked=name in control.locked)
            if self.is_capsule[j]:
                r = float(self.radius[j])
                specs.append(BodySpec(shape="capsule", radius=r, half_length=max(float(length[j]) / 2 - r, 0.0),
                                      axis=2, **common))
            else:
                specs.append(BodySpec(shape="sphere", radius=float(self.radius[j]), **common))
        terrain = Terrain.flat(self.ground_z if p.ground else -1e9)
        return build_model(specs, terrain=terrain, settings=WorldSettings())

    # -- targets -------------------------------------------------------------------------

    def target_velocities(self, order: int) -> np.ndarray:
        """v(j, f): velocity of each body's centre in the capture, (nf, nj, 3) m/s."""
        return central_difference(self.body_pos, order, self.frame_time)

    def target_points(self) -> np.ndarray:
        """r(j, f): where the measured point of each body is in the capture, (nf, nj, 3)."""
        return self.joint_pos


# ---------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------


@dataclass
class TrackingResult:
    """Output of ``track``: the simulated bodies per frame, the error statistics and
    timing. ``joint_mse``/``joint_var`` (nj,) are the mean and variance over frames of
    e_p^2(j, f) (m^2); ``mse``/``var`` the same over all joints and frames (equal to the
    paper's eq. 4 mean because every joint has every frame)."""

    rig: MocapRig
    params: TrackingParams
    scales: tuple
    body_pos: np.ndarray
    body_rot: np.ndarray
    joint_mse: np.ndarray
    joint_var: np.ndarray
    mse: float
    var: float
    final_mse: float
    max_joint_separation: float
    wall_seconds: float
    sim_seconds: float

    @property
    def realtime_factor(self) -> float:
        return self.sim_seconds / max(self.wall_seconds, 1e-12)

    def report(self) -> dict:
        names = self.rig.clip.joint_names
        return {
            "file": self.rig.clip.path, "mode": self.rig.mode, "frames": self.rig.nframe,
            "frame0": self.rig.frame0,
            "order": self.params.order, "k_f": self.params.k_f, "k_vc": self.params.k_vc, "dt": self.params.dt,
            "gravity_comp": self.params.gravity_comp,
            "scales": [f"{s.joint}:{s.k}@{s.f0}-{s.f1}" for s in self.scales],
            "uncontrolled": list(self.rig.control.uncontrolled), "locked": list(self.rig.control.locked),
            "mass": dict(self.rig.control.mass),
            "mse_m2": self.mse, "var_m4": self.var, "final_frame_mse_m2": self.final_mse,
            "max_joint_separation_mm": 1000.0 * self.max_joint_separation,
            "realtime_factor": self.realtime_factor,
            "joints": {n: {"mse_m2": float(self.joint_mse[j]), "var_m4": float(self.joint_var[j])}
                       for j, n in enumerate(names)},
        }

    def simulated_joint_positions(self) -> np.ndarray:
        """p(rb(j), f) per frame (nf, nj, 3)."""
        out = np.empty_like(self.body_pos)
        for f in range(out.shape[0]):
            RK.tracked_points_kernel(self.body_pos[f], self.body_rot[f], self.rig.point_local, out[f])
        return out

    def to_bvh(self) -> BvhClip:
        """The simulated motion as a BVH clip with the capture's skeleton and channels.

        Skeleton modes: joint world rotation = body rotation * align^-1, local rotations
        by the parent's inverse, the root's translation from its simulated joint point.
        Independent mode: spheres carry no bone orientation, so joints keep the capture's
        rotations and only the root moves as simulated."""
        rig = self.rig
        clip = rig.clip
        nf, nj = self.body_pos.shape[:2]
        if rig.mode == "independent":
            world_rot = rig.joint_rot
        else:
            world_rot = quat_mul(self.body_rot, np.broadcast_to(_qconj(rig.body_align), self.body_rot.shape))
        local = np.empty_like(world_rot)
        for j in range(nj):
            p = int(clip.joint_parent[j])
            local[:, j] = world_rot[:, j] if p < 0 else quat_mul(_qconj(world_rot[:, p]), world_rot[:, j])
        # Menagerie axes back to file axes: q_file = (w, q_y, q_z, q_x), v_file = (v_y, v_z, v_x) / scale
        local_file = local[..., [0, 2, 3, 1]]
        root_pt = self.simulated_joint_positions()[:, 0]
        root_file = root_pt[:, [1, 2, 0]] / rig.scale
        motion = np.array(clip.motion[rig.frame0:rig.frame0 + nf], dtype=np.float64)
        for j, chans in enumerate(clip.joint_channels):
            adr = int(clip.joint_channel_adr[j])
            rot_chans = [c for c in chans if c.endswith("rotation")]
            if rot_chans:
                angles = quat_to_euler(local_file[:, j], "".join(c[0] for c in rot_chans))
                k = 0
                for i, c in enumerate(chans):
                    if c.endswith("rotation"):
                        motion[:, adr + i] = np.degrees(angles[:, k])
                        k += 1
            if j == 0:
                for i, c in enumerate(chans):
                    if c.endswith("position"):
                        motion[:, adr + i] = root_file[:, "XYZ".index(c[0])]
        return BvhClip(joint_names=clip.joint_names, joint_parent=clip.joint_parent, joint_offset=clip.joint_offset,
                       joint_channels=clip.joint_channels, joint_end_site=clip.joint_end_site,
                       frame_time=clip.frame_time, motion=motion)


def quat_to_euler(q: np.ndarray, order: str) -> np.ndarray:
    """Euler angles (..., 3) in radians with R = R_a(alpha) R_b(beta) R_c(gamma) for the
    intrinsic order ``abc`` (e.g. 'ZYX', BVH's reading), from unit quaternions (..., 4).
    With axes i, j, k and e = +1 for a cyclic order (xyz, yzx, zxy), else -1:
    beta = asin(e R[i,k]), alpha = atan2(-e R[j,k], R[k,k]), gamma = atan2(-e R[i,j], R[i,i])."""
    i, j, k = ("XYZ".index(order[0].upper()), "XYZ".index(order[1].upper()), "XYZ".index(order[2].upper()))
    e = 1.0 if (i, j, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    R = np.empty(q.shape[:-1] + (3, 3))
    R[..., 0, 0] = 1 - 2 * (y * y + z * z)
    R[..., 0, 1] = 2 * (x * y - w * z)
    R[..., 0, 2] = 2 * (x * z + w * y)
    R[..., 1, 0] = 2 * (x * y + w * z)
    R[..., 1, 1] = 1 - 2 * (x * x + z * z)
    R[..., 1, 2] = 2 * (y * z - w * x)
    R[..., 2, 0] = 2 * (x * z - w * y)
    R[..., 2, 1] = 2 * (y * z + w * x)
    R[..., 2, 2] = 1 - 2 * (x * x + y * y)
    beta = np.arcsin(np.clip(e * R[..., i, k], -1.0, 1.0))
    alpha = np.arctan2(-e * R[..., j, k], R[..., k, k])
    gamma = np.arctan2(-e * R[..., i, j], R[..., i, i])
    return np.stack([alpha, beta, gamma], axis=-1)


def _scale_table(rig: MocapRig, scales) -> np.ndarray:
    """K_v(j, f) for the rig's frames (nf, nj); frame numbers are the clip's."""
    table = np.ones((rig.nframe, rig.njoint))
    for s in scales:
        if s.joint not in rig.clip.joint_names:
            raise TrackingError(f"no joint '{s.joint}' in the capture", subject=s.joint, field="scale",
                                path=rig.clip.path)
        if not (math.isfinite(s.k) and s.k >= 0):
            raise TrackingError(f"scale must be a number >= 0, got {s.k}", subject=s.joint, field="scale")
        if s.f1 < s.f0:
            raise TrackingError(f"frame range {s.f0}-{s.f1} is empty", subject=s.joint, field="scale")
        j = rig.clip.joint_names.index(s.joint)
        a = max(s.f0 - rig.frame0, 0)
        b = min(s.f1 - rig.frame0, rig.nframe - 1)
        last = rig.frame0 + rig.nframe - 1
        if a > b:
            raise TrackingError(f"frames {s.f0}-{s.f1} are outside the simulated frames {rig.frame0}-{last}",
                                subject=s.joint, field="scale", path=rig.clip.path)
        if s.f1 != _TO_THE_END and (s.f1 > last or s.f0 < rig.frame0):
            warnings.warn(f"scale {s.joint}:{s.k:g}@{s.f0}-{s.f1} reaches past the simulated frames "
                          f"{rig.frame0}-{last}; it scales frames {a + rig.frame0}-{b + rig.frame0}",
                          TrackingWarning, stacklevel=3)
        table[a:b + 1, j] *= s.k
    return table


def track(rig: MocapRig, params: TrackingParams | None = None, *, scales=(), progress=None) -> TrackingResult:
    """Replay the capture on the rig's bodies and measure the error (see the module
    docstring). ``params`` overrides the rig's order/K_f/K_vc/dt (the bodies stay)."""
    params = params or rig.params
    params.validate()
    scales = tuple(VelocityScale.parse(s) if isinstance(s, str) else s for s in scales)
    ktable = _scale_table(rig, scales)
    model = rig.model
    nf, nj = rig.nframe, rig.njoint
    vel = rig.target_velocities(params.order) * params.k_vc
    targets = rig.target_points()
    state = PhysicsState(model)
    state.set_pose(rig.body_pos[0], rig.body_rot[0], vel[0])
    controlled = np.array([n not in rig.control.uncontrolled for n in rig.clip.joint_names])
    gains = np.where(controlled, params.k_f, 0.0)
    if params.gravity_comp:
        g = np.asarray(model.settings.gravity)
        state.body_force[:] = -(model.body_mass * controlled)[:, None] * g[None, :]
    out_pos = np.empty((nf, nj, 3))
    out_rot = np.empty((nf, nj, 4))
    out_pos[0] = state.body_pos
    out_rot[0] = state.body_rot
    count = np.zeros(nj, np.int64)
    mean = np.zeros(nj)
    m2 = np.zeros(nj)
    count_all = np.zeros(1, np.int64)
    mean_all = np.zeros(1)
    m2_all = np.zeros(1)
    actual = np.empty((nj, 3))
    err = np.empty(nj)
    one = np.empty(1)
    sep = np.zeros(model.njoint)
    worst_sep = 0.0
    ft = rig.frame_time
    done = 0
    compiling.notice("physics")   # once per process, when numba's cache is cold
    # Compile (or load) the stepping kernels on a scratch state before the clock starts:
    # the real-time factor is the simulation's, not numba's first-run compile.
    scratch = PhysicsState(model)
    scratch.set_pose(rig.body_pos[0], rig.body_rot[0], vel[0])
    step(model, scratch, params.dt, substeps=params.substeps, steps=1)
    if model.njoint:
        joint_separation(model, scratch, sep)

    def accumulate(f):
        RK.tracked_points_kernel(state.body_pos, state.body_rot, rig.point_local, actual)
        RK.squared_errors_kernel(targets[f], actual, err)
        RK.welford_update(count, mean, m2, err)
        for j in range(nj):
            one[0] = err[j]
            RK.welford_update(count_all, mean_all, m2_all, one)

    accumulate(0)
    t_start = time.perf_counter()
    for f in range(1, nf):
        # paper eq. 1: between frames f-1 and f, aim at the velocity of frame f
        np.multiply(vel[f], ktable[f][:, None], out=state.body_track_vel)
        state.body_track_gain[:] = gains
        goal = int(round(f * ft / params.dt))
        n = goal - done
        if n > 0:
            step(model, state, params.dt, substeps=params.substeps, steps=n)
            done = goal
        out_pos[f] = state.body_pos
        out_rot[f] = state.body_rot
        accumulate(f)
        if model.njoint and f % 10 == 0:
            joint_separation(model, state, sep)
            worst_sep = max(worst_sep, float(sep.max()))
        if progress is not None and f % 200 == 0:
            progress(f, nf)
    wall = time.perf_counter() - t_start
    var = m2 / np.maximum(count - 1, 1)
    final = float(err.mean())
    return TrackingResult(rig=rig, params=params, scales=scales, body_pos=out_pos, body_rot=out_rot,
                          joint_mse=mean.copy(), joint_var=var, mse=float(mean_all[0]),
                          var=float(m2_all[0] / max(count_all[0] - 1, 1)), final_mse=final,
                          max_joint_separation=worst_sep, wall_seconds=wall, sim_seconds=done * params.dt)


# ---------------------------------------------------------------------------------------
# Monte Carlo tuning (paper Algorithm 1)
# ---------------------------------------------------------------------------------------


@dataclass
class TuneResult:
    best: TrackingParams
    best_mse: float
    history: list          # (order, k_f, k_vc, mse) per simulation, in order


def tune(rig: MocapRig, *, points: int = 10, max_order: int = 19, seed: int = 0,
         start: TrackingParams | None = None, step_f: float = 1.0, step_vc: float = 0.01,
         progress=None) -> TuneResult:
    """The paper's modified Monte Carlo search (Algorithm 1), seeded: from a known good
    (K_f, K_vc), for each of ``points`` points and each odd order 3..max_order, simulate
    and keep the best; after each simulation K_f += step_f * U[-1, 1] and
    K_vc += step_vc * U[-1, 1] (the paper's steps are 1 with K_vc ~ 100 in its units;
    ours default to 1 and 0.01 for K_vc ~ 1 in metres). Random numbers come from
    ``numpy.random.default_rng(seed)``: the same seed gives the same search."""
    start = start or rig.params
    start.validate()
    if int(points) != points or points < 1:
        raise TrackingError(f"points must be a positive integer, got {points}", field="points", kind="parameter",
                            subject="points")
    if int(max_order) != max_order or not MIN_ORDER <= max_order <= MAX_ORDER:
        raise TrackingError(f"max_order must be in {MIN_ORDER}..{MAX_ORDER}, got {max_order}", field="max_order",
                            kind="parameter", subject="max_order")
    rng = np.random.default_rng(seed)
    k_f, k_vc = start.k_f, start.k_vc
    best, best_mse = start, math.inf
    history = []
    orders = list(range(MIN_ORDER, max_order + 1, 2))
    for i in range(points):
        for n in orders:
            params = TrackingParams(order=n, k_f=max(k_f, 1e-3), k_vc=max(k_vc, 1e-3), dt=start.dt,
                                    substeps=start.substeps, ground=start.ground, density=start.density,
                                    gravity_comp=start.gravity_comp)
            try:
                mse = track(rig, params).mse
            except Exception as exc:  # a diverged simulation is a bad point, not a crash
                from engine.physics import SimulationDiverged

                if not isinstance(exc, SimulationDiverged):
                    raise
                mse = math.inf
            history.append((n, params.k_f, params.k_vc, mse))
            if mse < best_mse:
                best, best_mse = params, mse
            k_f += step_f * rng.uniform(-1.0, 1.0)
            k_vc += step_vc * rng.uniform(-1.0, 1.0)
            if progress is not None:
                progress(i, n, params, mse, best_mse)
    return TuneResult(best=best, best_mse=best_mse, history=history)
