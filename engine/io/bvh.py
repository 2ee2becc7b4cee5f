"""BVH motion capture: read, write, forward kinematics and Menagerie axes.

A BVH file is a joint hierarchy (``HIERARCHY``: ``ROOT``/``JOINT`` blocks with an
``OFFSET``, a ``CHANNELS`` list and optional ``End Site`` blocks) followed by ``MOTION``:
a frame count, a frame time and one line of channel values per frame. ``load_bvh`` and
``parse_bvh_text`` return a ``BvhClip`` that keeps everything in the FILE's units and
axes (BVH is Y up); ``to_menagerie_axes`` and ``quat_to_menagerie_axes`` convert at the
border (DESIGN.md: formats convert at the border, nothing inside does).

Conventions this module fixes (and the tests check on the CMU captures):

* Rotation channels are Euler angles in degrees, applied *intrinsically in the listed
  order*: for ``CHANNELS 3 Zrotation Yrotation Xrotation`` the joint's local rotation is
  ``R = Rz(z) @ Ry(y) @ Rx(x)`` (column vectors), i.e. the quaternion product
  ``q = qz * qy * qx``. Every joint has its own order; orders may be mixed in one file.
* A joint's local translation is its ``OFFSET``. A position channel, where present,
  *replaces* the matching offset component (the reading Blender's and assimp's importers
  use; roots in practice have a zero offset, where replacing and adding agree).
* Forward kinematics: ``world_rot[j] = world_rot[parent] * local_rot[j]`` and
  ``world_pos[j] = world_pos[parent] + rotate(world_rot[parent], local_trans[j])``.
* Axis map to Menagerie (Z up, X forward, Y left): ``(x, y, z)_bvh -> (z, x, y)``. BVH
  captures face +Z with the actor's left on +X (CMU and Biovision files do); the map makes
  that +X forward and +Y left. The map is the cyclic permutation matrix ``AXIS_MAP``, a
  proper rotation (det +1), so rotations convert by permuting the quaternion's vector part.

Bad input raises ``engine.errors.BvhError`` naming the file and 1-based line. A ``Frames:``
count that disagrees with the motion lines present is a ``BvhWarning`` (not an error):
the frames that are there are used.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass

import numpy as np

from engine.errors import BvhError

#: Channel names BVH knows, in their canonical spelling (files are read case-insensitively).
CHANNEL_NAMES: tuple[str, ...] = (
    "Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation",
)
_CHANNEL_BY_LOWER = {c.lower(): c for c in CHANNEL_NAMES}

#: Menagerie-from-BVH axis matrix: v_menagerie = AXIS_MAP @ v_bvh, i.e. (x, y, z) -> (z, x, y).
AXIS_MAP = np.array([[0.0, 0.0, 1.0],
                     [1.0, 0.0, 0.0],
                     [0.0, 1.0, 0.0]])
AXIS_MAP.flags.writeable = False

#: Unit factors (file unit -> metres) the auto-scale chooses from; see ``auto_scale``.
UNIT_SCALES: dict[str, float] = {
    "metres": 1.0,
    "decimetres": 0.1,
    "centimetres": 0.01,
    "millimetres": 0.001,
    "inches": 0.0254,
    "feet": 0.3048,
    # CMU ASF skeletons are in inches / 0.45 ("length 0.45" in the ASF header); the cgspeed
    # BVH conversions keep those units, so one unit is 0.0254 / 0.45 m = 5.64 cm.
    "cmu-asf-units": 0.0254 / 0.45,
}

#: Standing height (m) the auto-scale aims for: a typical adult human.
TYPICAL_HEIGHT = 1.7


class BvhWarning(UserWarning):
    """A BVH file was read after tolerating a fault (e.g. a wrong ``Frames:`` count)."""


# -- the clip ----------------------------------------------------------------------------


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class BvhClip:
    """A BVH skeleton and its motion, in the file's units and axes. Immutable.

    Attributes (nj = number of joints, nc = number of channels, nf = number of frames):
        joint_names: tuple of nj names, parents before children (file order).
        joint_parent (nj,) int32: parent index, -1 for the root (``joint_parent[j] < j``).
        joint_offset (nj, 3) float64: ``OFFSET`` of each joint, file units and axes.
        joint_channels: tuple of nj tuples of channel names in file order (0, 3 or 6 of
            ``CHANNEL_NAMES``; any order, any count up to 6 without repeats).
        joint_channel_adr (nj,) int32: column of the joint's first channel in ``motion``.
        joint_channel_num (nj,) int32: number of channels of the joint.
        joint_end_site (nj, 3) float64: ``End Site`` offset of the joint, NaN where none.
        joint_line (nj,) int32: 1-based line of each joint's ``ROOT``/``JOINT`` keyword
            (0 for clips built in code).
        frame_time: seconds per frame, > 0.
        motion (nf, nc) float64: raw channel values per frame (degrees for rotations).
        path: the file read, or None.
        declared_frames: the ``Frames:`` count in the header (may differ from nf).
    """

    joint_names: tuple[str, ...]
    joint_parent: np.ndarray
    joint_offset: np.ndarray
    joint_channels: tuple[tuple[str, ...], ...]
    joint_end_site: np.ndarray
    frame_time: float
    motion: np.ndarray
    path: str | None = None
    joint_line: np.ndarray | None = None
    declared_frames: int | None = None

    def __post_init__(self) -> None:
        nj = len(self.joint_names)
        where = self.path or "BVH clip"
        parent = np.asarray(self.joint_parent, np.int32)
        offset = np.asarray(self.joint_offset, np.float64)
        end = np.asarray(self.joint_end_site, np.float64)
        motion = np.asarray(self.motion, np.float64)
        channels = tuple(tuple(c) for c in self.joint_channels)
        if nj == 0:
            raise BvhError("a BVH skeleton needs at least one joint", path=self.path)
        if parent.shape != (nj,) or offset.shape != (nj, 3) or end.shape != (nj, 3) or len(channels) != nj:
            raise BvhError(f"{where}: joint arrays disagree in length with {nj} joint names", path=self.path)
        if parent[0] != -1 or np.any(parent[1:] < 0) or np.any(parent[1:] >= np.arange(1, nj)):
            raise BvhError("joints must be ordered parents first with one root at index 0", path=self.path)
        for j, chans in enumerate(channels):
            if len(set(chans)) != len(chans) or any(c not in CHANNEL_NAMES for c in chans):
                raise BvhError(f"bad channel list {list(chans)}", path=self.path,
                               subject=self.joint_names[j], kind="joint")
        num = np.array([len(c) for c in channels], np.int32)
        adr = np.zeros(nj, np.int32)
        adr[1:] = np.cumsum(num)[:-1]
        nchannel = int(num.sum())
        if motion.ndim != 2 or motion.shape[1] != nchannel:
            raise BvhError(f"motion must have shape (nframe, {nchannel}), got {motion.shape}", path=self.path)
        if not (np.all(np.isfinite(offset)) and np.all(np.isfinite(motion))):
            raise BvhError("non-finite offset or motion value", path=self.path)
        if not (math.isfinite(self.frame_time) and self.frame_time > 0.0):
            raise BvhError(f"frame time must be a positive number, got {self.frame_time!r}", path=self.path)
        line = (np.zeros(nj, np.int32) if self.joint_line is None
                else np.asarray(self.joint_line, np.int32))
        set_ = object.__setattr__
        set_(self, "joint_names", tuple(self.joint_names))
        set_(self, "joint_parent", _frozen(parent))
        set_(self, "joint_offset", _frozen(offset))
        set_(self, "joint_channels", channels)
        set_(self, "joint_end_site", _frozen(end))
        set_(self, "motion", _frozen(motion))
        set_(self, "joint_line", _frozen(line))
        set_(self, "frame_time", float(self.frame_time))
        set_(self, "joint_channel_num", _frozen(num))
        set_(self, "joint_channel_adr", _frozen(adr))
        if self.declared_frames is None:
            set_(self, "declared_frames", motion.shape[0])

    # -- sizes -------------------------------------------------------------------------

    @property
    def njoint(self) -> int:
        return len(self.joint_names)

    @property
    def nchannel(self) -> int:
        return int(self.motion.shape[1])

    @property
    def nframe(self) -> int:
        return int(self.motion.shape[0])

    @property
    def fps(self) -> float:
        return 1.0 / self.frame_time

    @property
    def duration(self) -> float:
        """Seconds from the first to one frame past the last frame."""
        return self.nframe * self.frame_time

    @property
    def nend_site(self) -> int:
        return int(np.count_nonzero(~np.isnan(self.joint_end_site[:, 0])))

    def joint(self, name: str) -> int:
        """Index of the joint called ``name``; ``KeyError`` lists close names."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            import difflib

            close = difflib.get_close_matches(name, self.joint_names, n=3)
            raise KeyError(f"no joint '{name}' in {self.path or 'the clip'}"
                           + (f"; did you mean {', '.join(close)}?" if close else "")) from None

    def channel_names(self) -> list[str]:
        """``'<joint>.<channel>'`` for every motion column."""
        return [f"{n}.{c}" for n, chans in zip(self.joint_names, self.joint_channels, strict=True) for c in chans]

    # -- per-frame local transforms ----------------------------------------------------

    def _frames(self, frames) -> np.ndarray:
        if frames is None:
            return self.motion
        if isinstance(frames, slice):
            return self.motion[frames]
        return self.motion[np.atleast_1d(np.asarray(frames, np.int64))]

    def local_rotations(self, frames=None) -> np.ndarray:
        """Local joint rotations (nf, nj, 4), w-first, in file axes.

        ``frames`` selects frames (an index, a sequence of indices, a slice, or None for
        all; the same in every method here). Each
        joint's Euler channels are composed intrinsically in their listed order.
        """
        values = self._frames(frames)
        out = np.zeros((values.shape[0], self.njoint, 4))
        out[..., 0] = 1.0
        for j, chans in enumerate(self.joint_channels):
            adr = int(self.joint_channel_adr[j])
            q = None
            for k, c in enumerate(chans):
                if not c.endswith("rotation"):
                    continue
                half = np.radians(values[:, adr + k]) * 0.5
                qc = np.zeros((values.shape[0], 4))
                qc[:, 0] = np.cos(half)
                qc[:, 1 + "XYZ".index(c[0])] = np.sin(half)
                q = qc if q is None else quat_mul(q, qc)
            if q is not None:
                out[:, j] = q
        return out

    def local_translations(self, frames=None) -> np.ndarray:
        """Local joint translations (nf, nj, 3): offsets, position channels replacing components."""
        values = self._frames(frames)
        out = np.broadcast_to(self.joint_offset, (values.shape[0], self.njoint, 3)).copy()
        for j, chans in enumerate(self.joint_channels):
            adr = int(self.joint_channel_adr[j])
            for k, c in enumerate(chans):
                if c.endswith("position"):
                    out[:, j, "XYZ".index(c[0])] = values[:, adr + k]
        return out

    def root_translation(self, frames=None) -> np.ndarray:
        """Root position per frame (nf, 3), file units and axes."""
        return self.local_translations(frames)[:, 0]

    def forward_kinematics(self, frames=None) -> tuple[np.ndarray, np.ndarray]:
        """World joint positions (nf, nj, 3) and rotations (nf, nj, 4), file units and axes.

        One forward loop over joints (parents first), vectorised over frames.
        """
        local_rot = self.local_rotations(frames)
        local_pos = self.local_translations(frames)
        world_rot = np.empty_like(local_rot)
        world_pos = np.empty_like(local_pos)
        for j in range(self.njoint):
            p = int(self.joint_parent[j])
            if p < 0:
                world_rot[:, j] = local_rot[:, j]
                world_pos[:, j] = local_pos[:, j]
            else:
                world_rot[:, j] = quat_mul(world_rot[:, p], local_rot[:, j])
                world_pos[:, j] = world_pos[:, p] + quat_rotate(world_rot[:, p], local_pos[:, j])
        return world_pos, world_rot

    def end_site_positions(self, world_pos: np.ndarray, world_rot: np.ndarray) -> np.ndarray:
        """World positions of the end sites (nf, nj, 3) given FK output; NaN where none."""
        return world_pos + quat_rotate(world_rot, np.broadcast_to(self.joint_end_site, world_pos.shape))

    def rest_positions(self) -> tuple[np.ndarray, np.ndarray]:
        """The OFFSET pose: joint positions (nj, 3) and end-site positions (nj, 3, NaN where
        none), with every rotation zero and the root at its offset. File units and axes."""
        pos = np.zeros((self.njoint, 3))
        for j in range(self.njoint):
            p = int(self.joint_parent[j])
            pos[j] = self.joint_offset[j] if p < 0 else pos[p] + self.joint_offset[j]
        return pos, pos + self.joint_end_site

    def standing_height(self) -> float:
        """Height (file units) of the OFFSET pose along the file's up axis (Y): the span of
        all joints and end sites."""
        pos, end = self.rest_positions()
        ys = np.concatenate([pos[:, 1], end[~np.isnan(end[:, 1]), 1]])
        return float(ys.max() - ys.min())


# -- quaternion helpers, vectorised over leading axes (w, x, y, z) ------------------------


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternion arrays (..., 4), broadcasting."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ], axis=-1)


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors (..., 3) by unit quaternions (..., 4), broadcasting."""
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + q[..., :1] * t + np.cross(u, t)


# -- axes --------------------------------------------------------------------------------


def to_menagerie_axes(v, scale: float = 1.0) -> np.ndarray:
    """Vectors (..., 3) from BVH axes (Y up, facing +Z, left +X) to Menagerie axes (Z up,
    X forward, Y left), multiplied by ``scale`` (file units -> metres):
    ``(x, y, z) -> scale * (z, x, y)``."""
    v = np.asarray(v, np.float64)
    return scale * v[..., [2, 0, 1]]


def quat_to_menagerie_axes(q) -> np.ndarray:
    """Rotations (..., 4) from BVH axes to Menagerie axes: the same rotation seen through
    ``AXIS_MAP`` (a proper rotation), i.e. ``(w, x, y, z) -> (w, z, x, y)``."""
    q = np.asarray(q, np.float64)
    return q[..., [0, 3, 1, 2]]


def auto_scale(clip: BvhClip, target_height: float = TYPICAL_HEIGHT) -> tuple[float, str]:
    """Pick the file unit: the factor in ``UNIT_SCALES`` that brings the OFFSET pose's
    standing height nearest (as a ratio) to ``target_height`` metres.

    Choosing among real units (rather than stretching to exactly 1.7 m) keeps the actor's
    true size when the file's unit is a common one: a 1.55 m actor in centimetres stays
    1.55 m. It assumes a roughly human-sized skeleton; for anything else pass ``scale``.
    Returns ``(factor, unit name)``. A skeleton with no height (all joints in a plane
    normal to Y) falls back to scaling its largest extent to ``target_height``.
    """
    height = clip.standing_height()
    if not height > 0.0:
        pos, end = clip.rest_positions()
        pts = np.concatenate([pos, end[~np.isnan(end[:, 0])]])
        size = float(np.max(pts.max(axis=0) - pts.min(axis=0)))
        if size <= 0.0:
            return 1.0, "metres"
        return target_height / size, "normalised"
    best = min(UNIT_SCALES.items(), key=lambda kv: abs(math.log(height * kv[1] / target_height)))
    return best[1], best[0]


# -- parsing -----------------------------------------------------------------------------


_FLOAT_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


def load_bvh(path: str | os.PathLike) -> BvhClip:
    """Read a BVH file into a ``BvhClip``; errors name the file and line."""
    path_str = os.fspath(path)
    try:
        with open(path_str, "rb") as f:
            raw = f.read()
    except OSError as exc:
        raise BvhError(f"cannot read BVH file: {exc.strerror}", path=path_str) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")  # joint names from old tools; the numbers are ASCII
    return parse_bvh_text(text, path_str)


class _Lines:
    """The header's lines as (1-based line number, tokens), with a cursor."""

    def __init__(self, lines: list[str], path: str | None) -> None:
        self.lines = lines
        self.path = path
        self.i = 0  # index of the next line to read

    def next_nonblank(self, what: str) -> tuple[int, list[str]]:
        while self.i < len(self.lines):
            tokens = self.lines[self.i].split()
            self.i += 1
            if tokens:
                return self.i, tokens
        raise BvhError(f"unexpected end of file, expected {what}", path=self.path,
                       line=len(self.lines) or 1)


def _number(token: str, path, line, what: str) -> float:
    if not _FLOAT_RE.match(token):
        raise BvhError(f"expected a number for {what}, got '{token}'", path=path, line=line)
    value = float(token)
    if not math.isfinite(value):
        raise BvhError(f"{what} is out of range: '{token}'", path=path, line=line)
    return value


def parse_bvh_text(text: str, path: str | None = None) -> BvhClip:
    """Parse BVH text (``path`` is only used in messages). See the module docstring."""
    if text.startswith("\ufeff"):
        text = text[1:]  # a UTF-8 byte-order mark from some Windows tools
    lines = text.splitlines()  # handles \n, \r\n and \r alike
    cur = _Lines(lines, path)

    lineno, tokens = cur.next_nonblank("HIERARCHY")
    if tokens[0].upper() != "HIERARCHY":
        raise BvhError(f"expected 'HIERARCHY' at the start of the file, got '{tokens[0]}'",
                       path=path, line=lineno)
    if len(tokens) > 1:
        raise BvhError(f"unexpected '{tokens[1]}' after HIERARCHY", path=path, line=lineno)

    names: list[str] = []
    parents: list[int] = []
    offsets: list[tuple[float, float, float]] = []
    channels: list[tuple[str, ...]] = []
    ends: list[tuple[float, float, float] | None] = []
    joint_lines: list[int] = []
    seen: dict[str, int] = {}

    lineno, tokens = cur.next_nonblank("ROOT")
    if tokens[0].upper() != "ROOT":
        raise BvhError(f"expected 'ROOT <name>', got '{tokens[0]}'", path=path, line=lineno)

    def read_open_brace(rest: list[str], lineno: int, what: str) -> None:
        """A '{' either ends the current line (``rest``) or is alone on the next line."""
        if rest:
            if rest != ["{"]:
                raise BvhError(f"unexpected '{' '.join(rest)}' after {what}", path=path, line=lineno)
            return
        ln, toks = cur.next_nonblank(f"'{{' opening {what}")
        if toks[0] != "{":
            raise BvhError(f"expected '{{' opening {what}, got '{toks[0]}'", path=path, line=ln)
        if len(toks) > 1:
            raise BvhError(f"unexpected '{toks[1]}' after '{{'", path=path, line=ln)

    def read_offset(what: str) -> tuple[float, float, float]:
        ln, toks = cur.next_nonblank(f"OFFSET of {what}")
        if toks[0].upper() != "OFFSET":
            raise BvhError(f"missing OFFSET in {what} (got '{toks[0]}')", path=path, line=ln)
        if len(toks) != 4:
            raise BvhError(f"OFFSET needs 3 numbers, got {len(toks) - 1}", path=path, line=ln)
        return tuple(_number(t, path, ln, f"the OFFSET of {what}") for t in toks[1:])  # type: ignore[return-value]

    def split_name(toks: list[str]) -> tuple[str, list[str]]:
        # Joint names may contain spaces; a '{' may follow on the same line.
        if toks and toks[-1] == "{":
            return " ".join(toks[:-1]), ["{"]
        if toks and toks[-1].endswith("{"):
            return " ".join(toks[:-1] + [toks[-1][:-1]]), ["{"]
        return " ".join(toks), []

    # Iterative descent over the hierarchy: a stack of open joints (index, open line).
    stack: list[tuple[int, int]] = []

    def start_joint(name_tokens: list[str], lineno: int, parent: int, keyword: str) -> None:
        name, rest = split_name(name_tokens)
        if not name:
            raise BvhError(f"{keyword} without a name", path=path, line=lineno)
        if name in seen:
            raise BvhError(f"duplicate joint name '{name}' (first at line {joint_lines[seen[name]]})",
                           path=path, line=lineno, subject=name, kind="joint")
        read_open_brace(rest, lineno, f"joint '{name}'")
        offset = read_offset(f"joint '{name}'")
        ln, toks = cur.next_nonblank(f"CHANNELS of joint '{name}'")
        if toks[0].upper() != "CHANNELS":
            raise BvhError(f"missing CHANNELS in joint '{name}' (got '{toks[0]}')", path=path, line=ln,
                           subject=name, kind="joint")
        if len(toks) < 2 or not toks[1].isdigit():
            raise BvhError("CHANNELS needs a count, then the channel names", path=path, line=ln,
                           subject=name, kind="joint")
        count = int(toks[1])
        chan_tokens = toks[2:]
        if count > 6:
            raise BvhError(f"CHANNELS count {count} is more than 6", path=path, line=ln, subject=name, kind="joint")
        if len(chan_tokens) != count:
            raise BvhError(f"CHANNELS says {count} channels but lists {len(chan_tokens)}", path=path, line=ln,
                           subject=name, kind="joint")
        chans = []
        for t in chan_tokens:
            c = _CHANNEL_BY_LOWER.get(t.lower())
            if c is None:
                raise BvhError(f"unknown channel name '{t}' (known: {', '.join(CHANNEL_NAMES)})",
                               path=path, line=ln, subject=name, kind="joint")
            if c in chans:
                raise BvhError(f"channel '{c}' listed twice", path=path, line=ln, subject=name, kind="joint")
            chans.append(c)
        seen[name] = len(names)
        names.append(name)
        parents.append(parent)
        offsets.append(offset)
        channels.append(tuple(chans))
        ends.append(None)
        joint_lines.append(lineno)
        stack.append((len(names) - 1, lineno))

    start_joint(tokens[1:], lineno, -1, "ROOT")
    motion_line = None
    while stack:
        lineno, tokens = cur.next_nonblank(f"'}}' closing joint '{names[stack[-1][0]]}'")
        key = tokens[0].upper()
        if key == "JOINT":
            start_joint(tokens[1:], lineno, stack[-1][0], "JOINT")
        elif key == "END":
            owner = stack[-1][0]
            rest = tokens[1:]
            if not rest or rest[0].upper().rstrip("{") != "SITE":
                raise BvhError(f"expected 'End Site', got '{' '.join(tokens)}'", path=path, line=lineno)
            rest = ([rest[0][4:]] if len(rest[0]) > 4 else []) + rest[1:]
            if ends[owner] is not None:
                raise BvhError(f"joint '{names[owner]}' has a second End Site", path=path, line=lineno,
                               subject=names[owner], kind="joint")
            read_open_brace(rest, lineno, f"the End Site of '{names[owner]}'")
            ends[owner] = read_offset(f"the End Site of '{names[owner]}'")
            ln, toks = cur.next_nonblank(f"'}}' closing the End Site of '{names[owner]}'")
            if toks != ["}"]:
                raise BvhError(f"expected '}}' closing the End Site of '{names[owner]}', got '{' '.join(toks)}'",
                               path=path, line=ln)
        elif all(set(t) == {"}"} for t in tokens):
            # One or more closing braces (some tools write "}}" or "} }").
            for _ in range(sum(len(t) for t in tokens)):
                if not stack:
                    raise BvhError("unbalanced braces: '}' with no joint open", path=path, line=lineno)
                stack.pop()
        elif key == "MOTION":
            raise BvhError(f"unbalanced braces: MOTION reached with {len(stack)} joint(s) still open "
                           f"(innermost '{names[stack[-1][0]]}', opened at line {stack[-1][1]})",
                           path=path, line=lineno)
        elif key == "ROOT":
            raise BvhError("a second ROOT inside a joint (unbalanced braces?)", path=path, line=lineno)
        else:
            raise BvhError(f"unexpected '{tokens[0]}' in joint '{names[stack[-1][0]]}' "
                           "(expected JOINT, End Site or '}')", path=path, line=lineno)

    # After the hierarchy: MOTION, Frames:, Frame Time:.
    while cur.i < len(lines):
        tokens = lines[cur.i].split()
        cur.i += 1
        if not tokens:
            continue
        if tokens[0].upper() == "MOTION":
            motion_line = cur.i
            break
        if tokens[0] == "}":
            raise BvhError("unbalanced braces: '}' after the root joint was closed", path=path, line=cur.i)
        if tokens[0].upper() == "ROOT":
            raise BvhError("a second ROOT: Menagerie reads one skeleton per file", path=path, line=cur.i)
        raise BvhError(f"unexpected '{tokens[0]}' after the hierarchy, expected MOTION", path=path, line=cur.i)
    if motion_line is None:
        raise BvhError("no MOTION section", path=path, line=len(lines) or 1)

    lineno, tokens = cur.next_nonblank("'Frames: <count>'")
    joined = " ".join(tokens)
    m = re.fullmatch(r"(?i)frames\s*:\s*(\S+)", joined)
    if not m:
        raise BvhError(f"expected 'Frames: <count>', got '{joined}'", path=path, line=lineno)
    if not m.group(1).isdigit():
        raise BvhError(f"frame count must be a whole number, got '{m.group(1)}'", path=path, line=lineno)
    declared = int(m.group(1))
    lineno, tokens = cur.next_nonblank("'Frame Time: <seconds>'")
    joined = " ".join(tokens)
    m = re.fullmatch(r"(?i)frame\s*time\s*:\s*(\S+)", joined)
    if not m:
        raise BvhError(f"expected 'Frame Time: <seconds>', got '{joined}'", path=path, line=lineno)
    frame_time = _number(m.group(1), path, lineno, "the frame time")
    if not frame_time > 0.0:
        raise BvhError(f"frame time must be > 0, got {frame_time}", path=path, line=lineno)

    nchannel = sum(len(c) for c in channels)
    motion = _parse_motion(lines, cur.i, nchannel, path)
    if nchannel == 0:  # no channels: frames are empty lines, so trust the header
        motion = np.zeros((declared, 0))
    if motion.shape[0] != declared:
        warnings.warn(f"{path or 'BVH text'}: header declares {declared} frames but the file has "
                      f"{motion.shape[0]} motion lines; using the {motion.shape[0]} present",
                      BvhWarning, stacklevel=2)

    end_arr = np.array([e if e is not None else (np.nan,) * 3 for e in ends], np.float64)
    return BvhClip(
        joint_names=tuple(names), joint_parent=np.array(parents, np.int32),
        joint_offset=np.array(offsets, np.float64), joint_channels=tuple(channels),
        joint_end_site=end_arr.reshape(-1, 3), frame_time=frame_time, motion=motion, path=path,
        joint_line=np.array(joint_lines, np.int32), declared_frames=declared,
    )


def _parse_motion(lines: list[str], start: int, nchannel: int, path) -> np.ndarray:
    """Motion lines from ``lines[start:]`` as (nframe, nchannel); blank lines are skipped.

    One tokenising pass and one numpy conversion; the per-line token counts are checked
    so a short or long line is reported by its number.
    """
    rows = [ln.split() for ln in lines[start:]]
    counts = np.fromiter((len(r) for r in rows), np.int64, len(rows))
    nonblank = np.flatnonzero(counts)
    bad = nonblank[counts[nonblank] != nchannel]
    if bad.size:
        i = int(bad[0])
        raise BvhError(f"motion line has {counts[i]} values, expected {nchannel} (one per channel)",
                       path=path, line=start + i + 1)
    flat = [t for r in rows for t in r]
    try:
        values = np.array(flat, dtype=np.float64)
    except ValueError:
        values = None
    if values is None or not np.all(np.isfinite(values)):
        for k in nonblank:  # slow path only to locate the fault
            for t in rows[k]:
                try:
                    ok = math.isfinite(float(t))
                except ValueError:
                    ok = False
                if not ok:
                    raise BvhError(f"motion value '{t}' is not a finite number", path=path,
                                   line=start + int(k) + 1)
    return values.reshape(len(nonblank), nchannel) if nchannel else np.zeros((len(nonblank), 0))


# -- writing -----------------------------------------------------------------------------


def bvh_text(clip: BvhClip, precision: int | None = 6) -> str:
    """BVH text for ``clip``. ``precision`` is the number of decimals (default 6, as most
    tools write); None writes ``repr`` of every float, which reads back bit for bit."""

    def num(v: float) -> str:
        v = float(v)
        if precision is None:
            return repr(v)
        s = f"{v:.{precision}f}"
        return "0." + "0" * precision if s.lstrip("-").strip("0.") == "" else s  # no "-0.000000"

    out = ["HIERARCHY"]
    children: list[list[int]] = [[] for _ in range(clip.njoint)]
    for j in range(1, clip.njoint):
        children[int(clip.joint_parent[j])].append(j)
    # The file order is depth first with children in index order; a clip read from a file
    # is already in that order, so it is reproduced, and clips built in code are fixed up.
    # An explicit stack (not recursion) so long chains of joints cannot overflow.
    order: list[int] = []
    stack: list[tuple[int, int, bool]] = [(0, 0, False)]  # (joint, depth, closing?)
    while stack:
        j, depth, closing = stack.pop()
        ind = "\t" * depth
        if closing:
            if not np.isnan(clip.joint_end_site[j, 0]):
                out.append(f"{ind}\tEnd Site")
                out.append(f"{ind}\t{{")
                out.append(f"{ind}\t\tOFFSET " + " ".join(num(v) for v in clip.joint_end_site[j]))
                out.append(f"{ind}\t}}")
            out.append(f"{ind}}}")
            continue
        order.append(j)
        out.append(f"{ind}{'ROOT' if depth == 0 else 'JOINT'} {clip.joint_names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET " + " ".join(num(v) for v in clip.joint_offset[j]))
        chans = clip.joint_channels[j]
        out.append(f"{ind}\tCHANNELS {len(chans)}" + "".join(f" {c}" for c in chans))
        stack.append((j, depth, True))
        stack.extend((c, depth + 1, False) for c in reversed(children[j]))
    columns = np.array([c for j in order for c in range(int(clip.joint_channel_adr[j]),
                        int(clip.joint_channel_adr[j] + clip.joint_channel_num[j]))], np.int64)
    out.append("MOTION")
    out.append(f"Frames: {clip.nframe}")
    out.append(f"Frame Time: {clip.frame_time!r}")
    motion = clip.motion[:, columns]
    if precision is None:
        out.extend(" ".join(repr(float(v)) for v in row) for row in motion)
    else:
        fmt = " ".join([f"%.{precision}f"] * motion.shape[1])
        motion = np.round(motion, precision) + 0.0  # + 0.0 turns -0.0 into 0.0: no "-0.000000"
        out.extend(fmt % tuple(row) for row in motion)
    return "\n".join(out) + "\n"


def save_bvh(clip: BvhClip, path: str | os.PathLike, overwrite: bool = False, precision: int | None = 6) -> None:
    """Write ``clip`` as a BVH file. Refuses to replace a file unless ``overwrite``."""
    path_str = os.fspath(path)
    if os.path.exists(path_str) and not overwrite:
        raise FileExistsError(f"{path_str} exists; pass overwrite=True (or --force) to replace it")
    directory = os.path.dirname(path_str)
    if directory:
        os.makedirs(directory, exist_ok=True)
    text = bvh_text(clip, precision)
    with open(path_str, "w", encoding="utf-8", newline="\n") as f:
        f.write(text)
