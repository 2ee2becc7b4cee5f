"""A relaxed standing rest pose for skeletons captured or rigged in a T- or A-pose.

Rest-relative animation channels (Hecker et al. 2008, section 2: a channel's goal is
specialized from the body's rest frame) assume the library's rest: arms hanging at the
sides. An imported human in a T-pose would reach out sideways instead (``pick_up_rock``
put a capture's hand goal on the ground 0.6 m out at its side). ``relax_arms`` swings each
arm down about its shoulder:

* An **arm** is the chain of limb bodies from where it leaves the spine to its grasper.
* Its **shoulder** is the joint on that chain lying ``SHOULDER_FRACTION`` of the chain's
  length from the grasper (measured along the joints), so a clavicle stays where it is
  (clavicle ~ 25 % of a human arm chain) and a chain without one turns at its first joint.
* An arm whose shoulder-to-grasper direction is more than ``RELAX_MIN_ANGLE`` from
  straight down is turned, with everything below the shoulder, by the shortest rotation
  that points it down and ``SPLAY`` outward (hands clear of the hips). An arm that would
  then reach within 2 % of the height of the ground is left as it is.

``relax_legs`` puts a biped's feet under its hips: a capture's skeleton in its OFFSET pose
often stands with its legs splayed (the CMU skeletons' thighs lean 20 degrees out: feet
0.8 m apart under a 1.5 m figure), and standing and stepping keep the feet where the rest
has them.

* Only a creature with exactly **two feet** (bodies with the ``foot`` capability), one on
  each side of the sagittal plane, below their hips: many-legged creatures splay their legs
  by nature (a spider, a frog) and are left as they are.
* A leg is the chain from where it leaves the spine to its foot; its **hip** is the joint
  ``HIP_FRACTION`` of the chain's length from the foot (a pelvis bone between the spine and
  the thigh, as CMU's ``LHipJoint``, stays where it is).
* A leg leaning out more than ``LEG_MIN_SPLAY`` from straight down, seen from the front, is
  turned about the forward axis at its hip until it leans ``LEG_SPLAY`` out; its forward or
  backward lean and the knee's bend are kept. The foot is turned back about the ankle, so
  the sole lies as before.

The importer puts the result back on the ground (legs hanging straighter reach lower).

The result is the creature's rest: positions, rotations and joints of the bodies below each
shoulder and hip change, their shapes do not (a rigid turn of each limb). ``rest_delta``
gives the world rotation applied to each body (identity elsewhere), so an exporter can
return to the file's own bind pose.
"""

from __future__ import annotations

import numpy as np

from engine.mathx import quat_mul, quat_rotate

#: Where an arm turns: this fraction of its chain length from the grasper.
SHOULDER_FRACTION = 0.78
#: Arms within this angle of straight down (radians) are left as they are.
RELAX_MIN_ANGLE = np.radians(35.0)
#: The hanging arm's outward tilt (radians) from straight down.
SPLAY = np.radians(8.0)
#: Where a leg turns: the joint this fraction of its chain length from the foot.
HIP_FRACTION = 0.85
#: Legs leaning out less than this (radians, seen from the front) are left as they are.
LEG_MIN_SPLAY = np.radians(10.0)
#: The relaxed leg's outward lean (radians) from straight down, seen from the front.
LEG_SPLAY = np.radians(5.0)


def _quat_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Shortest rotation (w, x, y, z) taking unit vector a onto unit vector b."""
    c = float(np.dot(a, b))
    axis = np.cross(a, b)
    if c < -1.0 + 1e-12:  # opposite: any perpendicular axis
        perp = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(perp) < 1e-6:
            perp = np.cross(a, [0.0, 1.0, 0.0])
        perp /= np.linalg.norm(perp)
        return np.array([0.0, *perp])
    q = np.array([1.0 + c, *axis])
    return q / np.linalg.norm(q)


def _children(parent) -> list[list[int]]:
    children = [[] for _ in range(len(parent))]
    for j in range(1, len(parent)):
        if parent[j] >= 0:
            children[parent[j]].append(j)
    return children


def _limb_pivot(parent, caps, joint, end: int, fraction: float) -> int | None:
    """The body on the chain from where it leaves the spine to ``end`` whose joint lies
    ``fraction`` of the chain's length (along the joints) from ``end``: a shoulder, a hip.
    None for a chain of one body or of no length."""
    path = [end]
    while parent[path[-1]] >= 0 and "spine" not in caps[parent[path[-1]]]:
        path.append(int(parent[path[-1]]))
    path.reverse()  # chain start ... end
    if len(path) < 2:
        return None
    along = np.zeros(len(path))  # distance along the joints to the end
    for i in range(len(path) - 2, -1, -1):
        along[i] = along[i + 1] + float(np.linalg.norm(joint[path[i + 1]] - joint[path[i]]))
    total = along[0]
    if total <= 0:
        return None
    return path[int(np.argmin(np.abs(along[:-1] / total - fraction)))]


def _turn_subtree(children, root: int, pivot: np.ndarray, q: np.ndarray, joint, pos, rot, delta) -> None:
    """Turn ``root`` and every body below it by ``q`` about ``pivot`` (a rigid turn)."""
    stack = [root]
    while stack:
        b = stack.pop()
        joint[b] = pivot + quat_rotate(q, joint[b] - pivot)
        pos[b] = pivot + quat_rotate(q, pos[b] - pivot)
        rot[b] = quat_mul(q, rot[b])
        delta[b] = quat_mul(q, delta[b])
        stack.extend(children[b])


def relax_arms(parent, caps, joint, pos, rot):
    """Swing T-/A-pose arms down (see the module docstring).

    Args:
        parent: (n,) parents first, -1 for the root.
        caps: list of capability-name lists per body.
        joint, pos: (n, 3) joint points and box centres; rot: (n, 4) box rotations (w, x, y, z).

    Returns:
        (joint, pos, rot, rest_delta, turned): new arrays, the world rotation applied to
        each body (n, 4), and a list of (grasper index, shoulder index, angle in degrees).
    """
    parent = np.asarray(parent)
    n = len(parent)
    joint = np.array(joint, float)
    pos = np.array(pos, float)
    rot = np.array(rot, float)
    delta = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    children = _children(parent)
    ground = 0.0
    height = float(max(joint[:, 2].max(), pos[:, 2].max()) - ground)
    turned = []
    for g in range(n):
        if "grasper" not in caps[g] or "spine" in caps[g]:
            continue
        s = _limb_pivot(parent, caps, joint, g, SHOULDER_FRACTION)
        if s is None:
            continue
        d = joint[g] - joint[s]
        length = float(np.linalg.norm(d))
        if length <= 1e-9:
            continue
        d /= length
        angle = float(np.arccos(np.clip(-d[2], -1.0, 1.0)))
        if angle <= RELAX_MIN_ANGLE:
            continue
        side = np.sign(joint[s, 1] - joint[0, 1]) or 1.0
        target = np.array([0.0, side * np.sin(SPLAY), -np.cos(SPLAY)])
        # Keep the grasper (and its box) above the ground.
        reach = float(np.max([np.linalg.norm(c - joint[s]) for c in (pos[g], joint[g])]))
        if joint[s, 2] - reach * np.cos(SPLAY) < ground + 0.02 * height:
            continue
        _turn_subtree(children, s, joint[s].copy(), _quat_between(d, target), joint, pos, rot, delta)
        turned.append((g, s, float(np.degrees(angle))))
    rot /= np.linalg.norm(rot, axis=1, keepdims=True)
    return joint, pos, rot, delta, turned


def relax_legs(parent, caps, joint, pos, rot, delta=None):
    """Put a biped's splayed feet under its hips (see the module docstring). Arguments as
    ``relax_arms``, plus ``delta`` (n, 4): the rest delta so far (``relax_arms``'), composed.

    Returns:
        (joint, pos, rot, rest_delta, turned): as ``relax_arms``; ``turned`` lists (foot
        index, hip index, lean out in degrees before).
    """
    parent = np.asarray(parent)
    n = len(parent)
    joint = np.array(joint, float)
    pos = np.array(pos, float)
    rot = np.array(rot, float)
    delta = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)) if delta is None else np.array(delta, float)
    children = _children(parent)
    feet = [f for f in range(n) if "foot" in caps[f] and "spine" not in caps[f]
            and not (parent[f] >= 0 and "foot" in caps[parent[f]])]
    if len(feet) != 2:
        return joint, pos, rot, delta, []
    legs = []
    for f in feet:
        hip = _limb_pivot(parent, caps, joint, f, HIP_FRACTION)
        if hip is None:
            return joint, pos, rot, delta, []
        d = joint[f] - joint[hip]
        side = float(np.sign(joint[hip, 1] - joint[0, 1]))
        if d[2] >= 0.0 or side == 0.0:
            return joint, pos, rot, delta, []       # a foot not below its hip, or a hip on the midline
        legs.append((f, hip, d, side))
    if legs[0][3] == legs[1][3]:
        return joint, pos, rot, delta, []           # both on one side: not a pair
    turned = []
    for f, hip, d, side in legs:
        lean = float(np.arctan2(side * d[1], -d[2]))   # outward, seen from the front
        if lean <= LEG_MIN_SPLAY:
            continue
        a = -side * (lean - LEG_SPLAY)                 # about +X: y cos a - z sin a
        q = np.array([np.cos(a / 2), np.sin(a / 2), 0.0, 0.0])
        pivot = joint[hip].copy()
        _turn_subtree(children, hip, pivot, q, joint, pos, rot, delta)
        # the foot turned back about its ankle: its sole lies as it did
        _turn_subtree(children, f, joint[f].copy(), q * np.array([1.0, -1.0, -1.0, -1.0]), joint, pos, rot, delta)
        turned.append((f, hip, float(np.degrees(lean))))
    rot /= np.linalg.norm(rot, axis=1, keepdims=True)
    delta /= np.linalg.norm(delta, axis=1, keepdims=True)
    return joint, pos, rot, delta, turned
