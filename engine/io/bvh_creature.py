"""BVH skeletons as Menagerie creatures: one body per joint, boxes along the bones.

``creature_def_from_bvh`` turns a BVH hierarchy into a ``CreatureDef`` (and
``creature_from_bvh`` builds it), so captured motion has a creature to play on and the
animation system has a real human skeleton to specialize onto (Hecker et al. 2008,
section 1.2: a creature is bodies with capabilities; the spine must be one chain).

How each piece is made (all in Menagerie axes and metres, see ``engine.io.bvh``):

* **Rest pose** is the skeleton's OFFSET pose (every rotation zero), not frame 0,
  converted with ``to_menagerie_axes`` and scaled (``scale=None``: ``auto_scale`` picks the
  file unit). It is then moved so the root joint is above the origin and the lowest box
  corner is at z = 0: the creature stands on the ground.
* **One body per joint.** End Sites are not bodies; they give their joint's bone its end.
* **Boxes** (``_bone_boxes``): a joint's *targets* are its child joints and its End Site;
  a child sitting on the joint itself (zero offset, like CMU's LHipJoint under Hips) is
  looked through to its own targets. The box's local **X axis** runs from the joint
  toward the mean of the targets, with the minimal rotation from identity (no twist about
  the bone beyond what the shortest arc gives; a bone along -X turns about Z). The box
  bounds the joint and the targets in that frame: for a plain bone it is centred on the
  bone's midpoint with half-length = half the bone length. Half-thickness across the bone
  is at least ``THICKNESS_FRACTION`` x the bone length (the longest joint-to-target
  distance) and never below ``MIN_HALF_EXTENT``. The root gets a compact box
  aligned with the character axes (identity rotation) bounding it and its targets, e.g.
  the pelvis spanning both hip joints and the lower back. A joint with no length at all
  (an End Site on the joint, or no End Site) continues its parent's bone: same direction,
  same length, a guess at the part the file leaves out (CMU's MotionBuilder-friendly
  heads, toes and fingers end this way).
* **Capabilities** come from joint names through ``DEFAULT_CAPS_TABLE``: ordered
  (regex, caps) pairs, matched case-insensitively against the whole name with any
  namespace prefix (``mixamorig:``, ``Armature|``) removed; the first match wins. A
  user's ``caps_table`` is tried before the defaults. Then, in order:
  1. an unmatched joint is a ``limb``, except one that links spine joints (its parent is
     spine, or it is the root, and a spine joint lies below it), which is ``spine`` so
     the chain stays connected; if nothing matched ``spine`` at all, the root is spine;
  2. along each limb only the foot and grasper nearest the spine keep that capability;
     ones further out become ``detail`` (3dsMax-friendly CMU files have both LeftWrist
     and lhand; each leg and arm thus gets exactly one foot or grasper).
  The head gets ``spine, head, mouth``: mocap skeletons rarely have a jaw, and the
  animation system needs a mouth to aim eating and biting at, so the head stands in for
  it (unless some joint, e.g. a ``jaw``, matched ``mouth`` itself).

Errors: unreadable files raise ``BvhError``; a caps table that cannot be used raises
``CapsTableError``; a result the builder rejects (e.g. a custom caps table that makes the
spine branch) raises ``CreatureError`` naming the BVH file and the joint's line.
"""

from __future__ import annotations

import os
import re

import numpy as np

from engine.errors import DataError
from engine.io.bvh import BvhClip, auto_scale, load_bvh, to_menagerie_axes
from engine.model.builder import build_creature
from engine.model.caps import CAPABILITIES
from engine.model.creature import Creature
from engine.model.definition import BodyDef, CreatureDef

#: Half-thickness of a bone's box across the bone, as a fraction of the bone length.
THICKNESS_FRACTION = 0.15
#: Smallest half-extent of any box, metres (so every box is at least 1.5 cm across).
MIN_HALF_EXTENT = 0.0075


class CapsTableError(DataError):
    """A capabilities table (``--caps FILE`` or the ``caps_table`` argument) that cannot be used."""


# -- the default naming table ------------------------------------------------------------

_PRE = r"(?:left|right|l|r)?[_ .-]?"     # optional side prefix: Left, R, l_, ...
_POST = r"(?:[_ .-]?(?:left|right|l|r))?"  # optional side suffix: _L, .R, Left, ...
_SEP = r"[_ .-]?"

#: Default joint-name patterns -> capabilities, tried in order, first match wins. Covers the
#: CMU MotionBuilder-friendly naming (Hips, LHipJoint, LeftUpLeg, LeftLeg, LeftFoot,
#: LeftToeBase, LowerBack, Spine, Spine1, Neck, Neck1, Head, LeftShoulder, LeftArm,
#: LeftForeArm, LeftHand, LeftFingerBase, LeftHandIndex1, LFingers, LThumb), the
#: 3dsMax-friendly one (LeftHip, LeftKnee, LeftAnkle, LeftToe, lowerback, Chest, Chest2,
#: lowerneck, LeftCollar, LeftShoulder, LeftElbow, LeftWrist, lhand), Biovision (Ab,
#: LeftToes) and common rig names (Mixamo after its prefix, pelvis/thigh/calf/clavicle...).
DEFAULT_CAPS_TABLE: dict[str, list[str]] = {
    # The spine, from the pelvis to the head (unsided names only).
    r"hips?|pelvis|root": ["spine"],
    rf"(?:lower|upper|middle|mid)?{_SEP}(?:back|spine|torso|waist|abdomen|ab|abs|chest|thorax|trunk|lumbar)"
    rf"{_SEP}\d*": ["spine"],
    rf"(?:lower|upper)?{_SEP}neck{_SEP}\d*": ["spine"],
    r"head": ["spine", "head", "mouth"],
    rf"head{_SEP}(?:top|end|nub|top{_SEP}end)": ["detail"],
    # Parts of a head and other appendages, for skeletons that have them.
    rf"{_PRE}(?:jaw|mouth){_SEP}\d*{_POST}": ["mouth"],
    rf"{_PRE}eye{_SEP}\d*{_POST}": ["eye"],
    rf"{_PRE}ear{_SEP}\d*{_POST}": ["ear"],
    rf"tail{_SEP}\d*": ["tail"],
    rf"{_PRE}wing(?:{_SEP}?[a-z]+)?{_SEP}\d*{_POST}": ["wing"],  # Wing, wing_2, WingArm, winghumerus
    # Legs. (A sided "hip" is a leg joint: LeftHip; the unsided one is the pelvis, above.)
    rf"{_PRE}(?:hip{_SEP}joint|pelvis){_POST}": ["limb"],
    rf"{_PRE}(?:up{_SEP}leg|upper{_SEP}leg|thigh|hip|femur){_POST}": ["limb"],
    rf"{_PRE}(?:leg|knee|shin|calf|lower{_SEP}leg|low{_SEP}leg|tibia){_POST}": ["limb"],
    rf"{_PRE}(?:foot|ankle){_POST}": ["limb", "foot"],
    rf"{_PRE}(?:toes?|toe{_SEP}base|toe{_SEP}end|ball|toe{_SEP}\d+){_POST}": ["detail"],
    # Arms.
    rf"{_PRE}(?:collar|clavicle|shoulder){_POST}": ["limb"],
    rf"{_PRE}(?:arm|up{_SEP}arm|upper{_SEP}arm|humerus|fore{_SEP}arm|lower{_SEP}arm|elbow|radius)"
    rf"{_POST}": ["limb"],
    rf"{_PRE}(?:hand|wrist){_POST}": ["limb", "grasper"],
    rf"{_PRE}(?:hand{_SEP})?(?:fingers?|finger{_SEP}base|index|middle|ring|pinky|little|thumb)"
    rf"{_SEP}\d*{_POST}": ["detail"],
    rf"{_PRE}(?:hand|finger|thumb){_SEP}(?:end|nub|tip){_POST}": ["detail"],
}


def _compile_table(table: dict, source: str | None, lines: dict | None = None) -> list[tuple[re.Pattern, list[str]]]:
    """Validate a {pattern: caps} table and compile it; errors name the pattern (and line)."""
    if not isinstance(table, dict):
        raise CapsTableError(f"a caps table maps name patterns to capability lists, got {type(table).__name__}",
                             path=source)
    out = []
    for pattern, caps in table.items():
        line = (lines or {}).get(pattern)
        if not isinstance(pattern, str) or not pattern:
            raise CapsTableError(f"pattern must be a non-empty string, got {pattern!r}", path=source, line=line)
        try:
            rx = re.compile(pattern, re.IGNORECASE)
        except re.error as exc:
            raise CapsTableError(f"bad regular expression: {exc}", path=source, line=line,
                                 subject=pattern, kind="pattern") from None
        if isinstance(caps, str):
            caps = [caps]
        if not isinstance(caps, (list, tuple)) or not all(isinstance(c, str) for c in caps):
            raise CapsTableError(f"capabilities must be a list of names, got {caps!r}", path=source, line=line,
                                 subject=pattern, kind="pattern")
        for c in caps:
            if c not in CAPABILITIES:
                raise CapsTableError(f"unknown capability '{c}' (known: {', '.join(CAPABILITIES)})",
                                     path=source, line=line, subject=pattern, kind="pattern")
        out.append((rx, list(caps)))
    return out


_DEFAULT_COMPILED = _compile_table(DEFAULT_CAPS_TABLE, "DEFAULT_CAPS_TABLE")


def load_caps_table(path: str | os.PathLike) -> dict[str, list[str]]:
    """Read a YAML caps table ``{pattern: [caps]}`` (a single cap may be a plain string).

    Patterns are Python regular expressions matched case-insensitively against whole joint
    names (namespace prefix removed). Errors name the file and line.
    """
    from engine.model.fileio import read_yaml_located

    path_str = os.fspath(path)
    try:
        with open(path_str, encoding="utf-8") as f:
            text = f.read()
    except OSError as exc:
        raise CapsTableError(f"cannot read caps table: {exc.strerror}", path=path_str) from None
    except UnicodeDecodeError as exc:
        raise CapsTableError(f"not a UTF-8 text file ({exc.reason})", path=path_str) from None
    root = read_yaml_located(text, path_str, error=CapsTableError)
    if not isinstance(root.value, dict):
        raise CapsTableError("the caps table must be a mapping of name patterns to capability lists",
                             path=path_str, line=root.line)
    table: dict[str, list[str]] = {}
    lines: dict[str, int] = {}
    for pattern, item in root.value.items():
        value = item.value
        if isinstance(value, list):
            value = [v.value for v in value]
        table[pattern] = value
        lines[pattern] = item.line
    _compile_table(table, path_str, lines)  # validate with line numbers
    return {p: [c] if isinstance(c, str) else list(c) for p, c in table.items()}


def _strip_namespace(name: str) -> str:
    """``mixamorig:LeftHand`` -> ``LeftHand``; ``Armature|Hips`` -> ``Hips``."""
    return re.split(r"[:|]", name)[-1]


def joint_caps(clip: BvhClip, caps_table: dict | None = None) -> list[list[str]]:
    """Capabilities of every joint of ``clip`` from its names alone (see the module docstring)."""
    return caps_from_names(clip.joint_names, clip.joint_parent, caps_table)


def caps_from_names(names, parent, caps_table: dict | None = None) -> list[list[str]]:
    """Capabilities from joint names (``parent`` parents first, -1 for the root)."""
    table = (_compile_table(caps_table, "caps_table") if caps_table else []) + _DEFAULT_COMPILED
    n = len(names)
    parent = np.asarray(parent)
    caps: list[list[str] | None] = []
    for name in names:
        short = _strip_namespace(name)
        caps.append(next((list(c) for rx, c in table if rx.fullmatch(short)), None))

    # 1. Unmatched joints: spine where they link spine joints, otherwise limb.
    is_spine = np.array([c is not None and "spine" in c for c in caps])
    spine_below = np.zeros(n, bool)  # a spine joint strictly below j
    for j in range(n - 1, 0, -1):
        if is_spine[j] or spine_below[j]:
            spine_below[parent[j]] = True
    for j in range(n):  # parents first, so a run of unmatched links resolves top down
        if caps[j] is None:
            linking = spine_below[j] and (parent[j] < 0 or is_spine[parent[j]])
            caps[j] = ["spine"] if linking else ["limb"]
            is_spine[j] = linking
    if not is_spine.any():
        caps[0] = ["spine"] + [c for c in caps[0] if c != "spine"]
        is_spine[0] = True

    # The head stands in for a mouth only when no joint is a mouth of its own (a jaw).
    if any("mouth" in c and "head" not in c for c in caps):
        for c in caps:
            if "head" in c and "mouth" in c:
                c.remove("mouth")

    # 2. One foot and one grasper per limb chain: the one nearest the spine.
    for cap in ("foot", "grasper"):
        above = np.zeros(n, bool)  # a non-spine ancestor on the same limb has ``cap``
        for j in range(n):
            p = parent[j]
            above[j] = p >= 0 and not is_spine[p] and (above[p] or cap in caps[p])
            if above[j] and cap in caps[j] and not is_spine[j]:
                caps[j] = [c for c in caps[j] if c != cap]
                if "detail" not in caps[j]:
                    caps[j].append("detail")
    return [list(c) for c in caps]  # type: ignore[arg-type]


# -- boxes -------------------------------------------------------------------------------


def _quat_from_x_to(direction: np.ndarray) -> np.ndarray:
    """The shortest-arc rotation taking +X to the unit vector ``direction`` (w, x, y, z).
    Opposite to +X the arc is not unique; a half turn about Z is used."""
    d = direction
    w = 1.0 + d[0]
    if w < 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    q = np.array([w, 0.0, -d[2], d[1]])  # (1 + x.d, x cross d)
    return q / np.linalg.norm(q)


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    u = q[1:]
    t = 2.0 * np.cross(u, v)
    return v + q[0] * t + np.cross(u, t)


def _rotate_inv(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return _rotate(np.array([q[0], -q[1], -q[2], -q[3]]), v)


def _bone_boxes(parent: np.ndarray, joint_pos: np.ndarray, end_pos: np.ndarray, eps: float):
    """Boxes for every joint: centres (n, 3), rotations (n, 4) and half-extents (n, 3).

    ``joint_pos`` and ``end_pos`` (NaN rows where no End Site) are rest positions in
    Menagerie axes and metres. See the module docstring for the rules.
    """
    n = len(parent)
    children: list[list[int]] = [[] for _ in range(n)]
    for j in range(1, n):
        children[parent[j]].append(j)

    def targets(j: int) -> list[np.ndarray]:
        out = []
        stack = list(reversed(children[j]))
        while stack:  # look through children that sit on the joint
            c = stack.pop()
            if np.linalg.norm(joint_pos[c] - joint_pos[j]) <= eps:
                if not np.isnan(end_pos[c, 0]) and np.linalg.norm(end_pos[c] - joint_pos[j]) > eps:
                    out.append(end_pos[c])
                stack.extend(reversed(children[c]))
            else:
                out.append(joint_pos[c])
        if not np.isnan(end_pos[j, 0]) and np.linalg.norm(end_pos[j] - joint_pos[j]) > eps:
            out.append(end_pos[j])
        return out

    centre = np.zeros((n, 3))
    rot = np.zeros((n, 4))
    half = np.zeros((n, 3))
    axis = np.zeros((n, 3))       # bone direction, for children with no length
    length = np.zeros(n)          # bone length, likewise
    for j in range(n):
        p = joint_pos[j]
        ts = targets(j)
        if parent[j] < 0:
            # The root: a compact box along the character axes around it and its targets.
            pts = np.array([p] + ts)
            lo, hi = pts.min(axis=0), pts.max(axis=0)
            bone = max((float(np.linalg.norm(t - p)) for t in ts), default=0.0)
            h = max(THICKNESS_FRACTION * bone, MIN_HALF_EXTENT)
            centre[j] = 0.5 * (lo + hi)
            rot[j] = (1.0, 0.0, 0.0, 0.0)
            half[j] = np.maximum(0.5 * (hi - lo), h)
            axis[j] = (0.0, 0.0, 1.0)
            length[j] = bone
            continue
        if not ts:
            # No length of its own: continue the parent's bone.
            d, bone = axis[parent[j]], length[parent[j]]
            ts = [p + d * bone] if bone > eps else []
        if not ts:
            centre[j] = p
            rot[j] = rot[parent[j]]
            half[j] = MIN_HALF_EXTENT
            axis[j] = axis[parent[j]]
            continue
        offsets = np.array(ts) - p
        mean = offsets.mean(axis=0)
        if np.linalg.norm(mean) > eps:
            d = mean / np.linalg.norm(mean)
        else:  # targets balanced around the joint: point at the farthest one
            far = offsets[int(np.argmax(np.linalg.norm(offsets, axis=1)))]
            d = far / np.linalg.norm(far)
        q = _quat_from_x_to(d)
        local = np.array([np.zeros(3)] + [_rotate_inv(q, o) for o in offsets])
        lo, hi = local.min(axis=0), local.max(axis=0)
        bone = float(np.max(np.linalg.norm(offsets, axis=1)))
        h = max(THICKNESS_FRACTION * bone, MIN_HALF_EXTENT)
        ext = 0.5 * (hi - lo)
        ext[0] = max(ext[0], MIN_HALF_EXTENT)
        ext[1:] = np.maximum(ext[1:], h)
        centre[j] = p + _rotate(q, 0.5 * (lo + hi))
        rot[j] = q
        half[j] = ext
        axis[j] = d
        length[j] = float(np.linalg.norm(mean)) if np.linalg.norm(mean) > eps else bone
    return centre, rot, half


def _box_min_z(centre: np.ndarray, rot: np.ndarray, half: np.ndarray) -> float:
    lowest = np.inf
    for c, q, h in zip(centre, rot, half, strict=True):
        # The lowest corner of a box: its centre minus the sum of |world z| of each half axis.
        axes = np.array([_rotate(q, np.eye(3)[k]) * h[k] for k in range(3)])
        lowest = min(lowest, c[2] - float(np.abs(axes[:, 2]).sum()))
    return lowest


def _back_on_ground(joint_pos: np.ndarray, centre: np.ndarray, rot: np.ndarray, half: np.ndarray):
    """``joint_pos`` and ``centre`` moved along z so the lowest box corner is at z = 0 (after
    the relaxed rest turned limbs: straighter legs reach lower, a hanging arm's box may)."""
    dz = np.array([0.0, 0.0, -_box_min_z(centre, rot, half)])
    return joint_pos + dz, centre + dz


# -- the creature ------------------------------------------------------------------------


def _resolve_scale(clip: BvhClip, scale: float | None) -> tuple[float, str]:
    """The scale to use and a note for the description."""
    if scale is None:
        scale, unit = auto_scale(clip)
        return scale, f"unit {unit} (x{scale:.6g}, auto)"
    scale = float(scale)
    if not (np.isfinite(scale) and scale > 0.0):
        raise DataError(f"scale must be a positive number, got {scale!r}", path=clip.path, field="scale")
    return scale, f"x{scale:.6g}"


def _rest_boxes(clip: BvhClip, scale: float):
    """Rest joint positions and body boxes in Menagerie axes and metres, before grounding."""
    pos_file, end_file = clip.rest_positions()
    joint_pos = to_menagerie_axes(pos_file, scale)
    end_pos = to_menagerie_axes(end_file, scale)
    size = float(np.max(np.ptp(np.concatenate([joint_pos, end_pos[~np.isnan(end_pos[:, 0])]]), axis=0)))
    eps = max(1e-9, 1e-6 * size)
    centre, rot, half = _bone_boxes(clip.joint_parent, joint_pos, end_pos, eps)
    return joint_pos, centre, rot, half


def creature_def_from_bvh(clip_or_path: BvhClip | str | os.PathLike, caps_table: dict | None = None,
                          scale: float | None = None, name: str | None = None,
                          caps_from: str = "shape", rest: str | int = "relaxed") -> CreatureDef:
    """A ``CreatureDef`` for a BVH skeleton (a ``BvhClip`` or a file path).

    Args:
        caps_table: extra ``{regex: [caps]}`` entries tried before ``DEFAULT_CAPS_TABLE``
            (e.g. from ``load_caps_table``).
        scale: file units -> metres; None picks the unit with ``engine.io.bvh.auto_scale``.
        name: the creature's name; default the file's stem (or ``bvh_creature``).
        caps_from: ``"shape"`` (``engine.model.shape_caps``: the rest pose first, names as a
            hint, a user's ``caps_table`` last) or ``"names"`` (the name table alone).
        rest: ``"relaxed"`` swings T-pose arms down (``engine.model.rest_pose``) so
            rest-relative channels act as on the library humanoid; ``"file"`` keeps the
            OFFSET pose; a frame number takes the capture's pose at that frame (capabilities
            still come from the OFFSET pose, where the skeleton is symmetric).

    The definition is validated by building it once, so a caps table that breaks the spine
    chain fails here with ``CreatureError`` naming the BVH file and the joint's line.
    """
    return creature_def_from_bvh_explained(clip_or_path, caps_table, scale, name, caps_from, rest)[0]


def creature_def_from_bvh_explained(clip_or_path, caps_table=None, scale=None, name=None, caps_from="shape",
                                    rest="relaxed"):
    """``creature_def_from_bvh`` and the reason for each body's capabilities."""
    from engine.model.shape_caps import find_caps

    clip = clip_or_path if isinstance(clip_or_path, BvhClip) else load_bvh(clip_or_path)
    scale, scale_note = _resolve_scale(clip, scale)
    joint_pos, centre, rot, half = _rest_boxes(clip, scale)

    # Stand on the ground, root above the origin.
    shift = np.array([-joint_pos[0, 0], -joint_pos[0, 1], -_box_min_z(centre, rot, half)])
    joint_pos = joint_pos + shift
    centre = centre + shift
    _, end_file = clip.rest_positions()
    tip = to_menagerie_axes(end_file, scale) + shift
    caps, reasons = find_caps(clip.joint_names, clip.joint_parent, joint_pos, centre, rot, half,
                              caps_table=caps_table, mode=caps_from, tip=tip)
    if isinstance(rest, int) and not isinstance(rest, bool):
        # A chosen capture frame as the rest: every body where the capture has it at that
        # frame (bvh_body_poses), then on the ground with the root joint above the origin.
        if not (0 <= rest < clip.nframe):
            raise DataError(f"rest frame {rest} is outside the capture's 0..{clip.nframe - 1}", path=clip.path,
                            field="rest_frame")
        body_pos, body_rot = bvh_body_poses(clip, scale=scale, frames=[rest])
        world_pos, _ = clip.forward_kinematics([rest])
        joint_pos = to_menagerie_axes(world_pos, scale)[0]
        centre, rot = body_pos[0], body_rot[0]
        shift = np.array([-joint_pos[0, 0], -joint_pos[0, 1], -_box_min_z(centre, rot, half)])
        joint_pos = joint_pos + shift
        centre = centre + shift
        for j in range(len(reasons)):
            reasons[j] += f"; rest from capture frame {rest}" if j == 0 else ""
    elif rest == "relaxed":
        from engine.model.rest_pose import relax_arms, relax_legs

        joint_pos, centre, rot, delta, turned = relax_arms(clip.joint_parent, caps, joint_pos, centre, rot)
        for g, s, ang in turned:
            reasons[g] += f"; arm swung down at {clip.joint_names[s]} ({ang:.0f} deg from hanging)"
        joint_pos, centre, rot, _, legs = relax_legs(clip.joint_parent, caps, joint_pos, centre, rot, delta)
        for f, s, ang in legs:
            reasons[f] += f"; leg turned in under the hip at {clip.joint_names[s]} ({ang:.0f} deg out before)"
        if turned or legs:
            joint_pos, centre = _back_on_ground(joint_pos, centre, rot, half)
    elif rest != "file":
        raise DataError(f"rest must be 'relaxed', 'file' or a frame number, got {rest!r}", path=clip.path,
                        field="rest")

    if name is None:
        name = os.path.splitext(os.path.basename(clip.path))[0] if clip.path else "bvh_creature"
    source = os.path.basename(clip.path) if clip.path else "BVH text"
    bodies = []
    for j, jname in enumerate(clip.joint_names):
        p = int(clip.joint_parent[j])
        bodies.append(BodyDef(
            name=jname,
            parent=clip.joint_names[p] if p >= 0 else None,
            caps=caps[j],
            pos=tuple(float(v) for v in centre[j]),
            rot=tuple(float(v) for v in rot[j]),
            joint=tuple(float(v) for v in joint_pos[j]),
            extents=tuple(float(v) for v in half[j]),
            line=int(clip.joint_line[j]),
        ))
    cdef = CreatureDef(name=name, description=f"from {source}: {clip.njoint} joints, {scale_note}",
                       bodies=bodies, path=clip.path)
    build_creature(cdef)  # validate now, with the BVH file and joint lines in any error
    return cdef, reasons


def creature_from_bvh(clip_or_path: BvhClip | str | os.PathLike, caps_table: dict | None = None,
                      scale: float | None = None, name: str | None = None, rest: str | int = "relaxed") -> Creature:
    """The built ``Creature`` for a BVH skeleton; arguments as ``creature_def_from_bvh``."""
    return build_creature(creature_def_from_bvh(clip_or_path, caps_table=caps_table, scale=scale, name=name,
                                                rest=rest))


def bvh_body_poses(clip: BvhClip, scale: float | None = None, frames=None) -> tuple[np.ndarray, np.ndarray]:
    """The captured motion as poses of the bodies ``creature_def_from_bvh(clip, scale=scale)``
    makes: world box centres (nf, nj, 3) and rotations (nf, nj, 4) per frame, in Menagerie
    axes and metres, in BVH joint order (body ``j`` is ``clip.joint_names[j]``).

    A body moves rigidly with its joint: at the OFFSET pose the joint frames are the world
    axes, so body = joint world transform * (box relative to the joint at rest). Positions
    keep the capture's own floor and placement (the file origin maps to the Menagerie
    origin), not the rest pose's grounding shift. Computed for all frames at once (numpy);
    bake once, then index per frame.
    """
    from engine.io.bvh import quat_mul, quat_rotate, quat_to_menagerie_axes

    scale, _ = _resolve_scale(clip, scale)
    joint_pos, centre, rot, _ = _rest_boxes(clip, scale)
    world_pos, world_rot = clip.forward_kinematics(frames)
    world_pos = to_menagerie_axes(world_pos, scale)
    world_rot = quat_to_menagerie_axes(world_rot)
    body_pos = world_pos + quat_rotate(world_rot, np.broadcast_to(centre - joint_pos, world_pos.shape))
    body_rot = quat_mul(world_rot, np.broadcast_to(rot, world_rot.shape))
    return body_pos, body_rot
