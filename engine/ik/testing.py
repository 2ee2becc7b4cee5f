"""Creatures and goal generators for the IK tests, the benchmark and the debug pictures.

``arm_chain_creature(n)``: a spine root with one serial arm of n joints (the benchmark's
6-joint chain). ``humanoid_creature()``: a 25-body humanoid built in code, used until the
library's creatures/humanoid.yaml is available. ``random_reachable_pose`` and
``reachable_goals`` make goals the creature can meet by construction: a random
forward-kinematic pose of the limbs (bends limited to ``max_bend``), read back as goals.
"""

from __future__ import annotations

import numpy as np

from engine.ik import _kernels as K
from engine.model import creature_from_text

MINI_TEXT = """\
format: 1
name: mini
description: tiny test biped
bodies:
  - name: chest
    caps: [spine]
    pos: [0, 0, 1.3]
    extents: [0.1, 0.15, 0.15]
  - name: pelvis
    parent: chest
    caps: [spine]
    pos: [0, 0, 1.0]
    joint: [0, 0, 1.15]
    extents: [0.1, 0.15, 0.1]
  - name: thigh_l
    parent: pelvis
    caps: [limb]
    pos: [0, 0.1, 0.75]
    joint: [0, 0.1, 0.95]
    extents: [0.05, 0.05, 0.2]
  - name: foot_l
    parent: thigh_l
    caps: [foot]
    pos: [0.05, 0.1, 0.05]
    joint: [0, 0.1, 0.5]
    extents: [0.1, 0.04, 0.04]
  - name: thigh_r
    parent: pelvis
    caps: [limb]
    pos: [0, -0.1, 0.75]
    joint: [0, -0.1, 0.95]
    extents: [0.05, 0.05, 0.2]
  - name: foot_r
    parent: thigh_r
    caps: [foot]
    pos: [0.05, -0.1, 0.05]
    joint: [0, -0.1, 0.5]
    extents: [0.1, 0.04, 0.04]
  - name: head
    parent: chest
    caps: [head, mouth]
    pos: [0, 0, 1.6]
    joint: [0, 0, 1.45]
    extents: [0.1, 0.1, 0.12]
"""


def _body(name, parent, caps, pos, joint=None, ext=(0.05, 0.05, 0.05)):
    lines = [f"  - name: {name}"]
    if parent:
        lines.append(f"    parent: {parent}")
    lines.append(f"    caps: [{', '.join(caps)}]")
    lines.append(f"    pos: [{pos[0]:.6g}, {pos[1]:.6g}, {pos[2]:.6g}]")
    if joint is not None:
        lines.append(f"    joint: [{joint[0]:.6g}, {joint[1]:.6g}, {joint[2]:.6g}]")
    lines.append(f"    extents: [{ext[0]:.6g}, {ext[1]:.6g}, {ext[2]:.6g}]")
    return "\n".join(lines)


def mini_creature():
    return creature_from_text(MINI_TEXT, "<mini>")


def arm_chain_creature(njoint: int = 6, segment: float = 0.2, bend: float = 0.15):
    """A spine root with one arm of ``njoint`` joints along +x, zig-zagging slightly in z
    (``bend`` rad per joint) so the rest pose says which way it bends. The hand is the
    last body."""
    bodies = [_body("base", None, ["spine"], (0, 0, 1.0), ext=(0.1, 0.1, 0.1))]
    joint = np.array([0.1, 0.0, 1.0])
    parent = "base"
    ang = 0.0
    for k in range(njoint):
        name = "hand" if k == njoint - 1 else f"seg{k}"
        ang += bend if k % 2 == 0 else -0.5 * bend
        d = np.array([np.cos(ang), 0.0, np.sin(ang)])
        caps = ["grasper"] if k == njoint - 1 else ["limb"]
        bodies.append(_body(name, parent, caps, joint + 0.5 * segment * d, joint, (0.5 * segment, 0.03, 0.03)))
        joint = joint + segment * d
        parent = name
    text = "format: 1\nname: arm{}\ndescription: serial arm\nbodies:\n{}\n".format(njoint, "\n".join(bodies))
    return creature_from_text(text, f"<arm{njoint}>")


def humanoid_text() -> str:
    """25 bodies: 5 spine (pelvis .. neck), head with jaw, arms of clavicle, upper arm,
    forearm, hand, legs of thigh, shin, foot, toe, and a 2-body tail."""
    b = []
    b.append(_body("pelvis", None, ["spine"], (0, 0, 1.0), ext=(0.1, 0.15, 0.08)))
    b.append(_body("spine1", "pelvis", ["spine"], (0, 0, 1.15), (0, 0, 1.08), (0.09, 0.14, 0.06)))
    b.append(_body("spine2", "spine1", ["spine"], (0.01, 0, 1.3), (0, 0, 1.22), (0.09, 0.15, 0.07)))
    b.append(_body("chest", "spine2", ["spine"], (0.02, 0, 1.45), (0.01, 0, 1.37), (0.1, 0.17, 0.08)))
    b.append(_body("neck", "chest", ["spine"], (0.02, 0, 1.6), (0.02, 0, 1.55), (0.04, 0.04, 0.05)))
    b.append(_body("head", "neck", ["head"], (0.04, 0, 1.75), (0.02, 0, 1.66), (0.1, 0.08, 0.1)))
    b.append(_body("jaw", "head", ["mouth"], (0.09, 0, 1.69), (0.06, 0, 1.71), (0.04, 0.05, 0.02)))
    for side, s in (("l", 1.0), ("r", -1.0)):
        b.append(_body(f"clavicle_{side}", "chest", ["limb"], (0.01, s * 0.1, 1.5), (0.02, s * 0.03, 1.5),
                       (0.02, 0.07, 0.02)))
        b.append(_body(f"upperarm_{side}", f"clavicle_{side}", ["limb"], (0.0, s * 0.2, 1.35),
                       (0.0, s * 0.18, 1.49), (0.04, 0.04, 0.14)))
        b.append(_body(f"forearm_{side}", f"upperarm_{side}", ["limb"], (0.04, s * 0.22, 1.09),
                       (-0.01, s * 0.21, 1.21), (0.04, 0.04, 0.13)))
        b.append(_body(f"hand_{side}", f"forearm_{side}", ["grasper"], (0.1, s * 0.23, 0.93),
                       (0.08, s * 0.23, 0.97), (0.04, 0.03, 0.06)))
    for side, s in (("l", 1.0), ("r", -1.0)):
        b.append(_body(f"thigh_{side}", "pelvis", ["limb"], (0.01, s * 0.1, 0.72), (0, s * 0.1, 0.92),
                       (0.06, 0.06, 0.2)))
        b.append(_body(f"shin_{side}", f"thigh_{side}", ["limb"], (0.0, s * 0.1, 0.3), (0.03, s * 0.1, 0.52),
                       (0.05, 0.05, 0.2)))
        b.append(_body(f"foot_{side}", f"shin_{side}", ["foot"], (0.06, s * 0.1, 0.04), (0.0, s * 0.1, 0.09),
                       (0.1, 0.05, 0.04)))
        b.append(_body(f"toe_{side}", f"foot_{side}", ["detail"], (0.19, s * 0.1, 0.02), (0.16, s * 0.1, 0.02),
                       (0.03, 0.04, 0.02)))
    b.append(_body("tail1", "pelvis", ["tail"], (-0.18, 0, 0.95), (-0.1, 0, 0.98), (0.08, 0.03, 0.03)))
    b.append(_body("tail2", "tail1", ["tail"], (-0.34, 0, 0.9), (-0.26, 0, 0.92), (0.08, 0.02, 0.02)))
    return "format: 1\nname: humanoid25\ndescription: 25-body humanoid for IK tests\nbodies:\n" + "\n".join(b) + "\n"


def humanoid_creature():
    return creature_from_text(humanoid_text(), "<humanoid25>")


def _qmul(a, b):
    return np.array(K.qmul(tuple(a), tuple(b)))


def random_axis_angle(rng, max_angle):
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    ang = rng.uniform(0.0, max_angle)
    return np.array(K.qaxis_angle(tuple(axis), ang))


def fk_pose(creature, root_pos, root_rot, local_rot):
    """World poses from per-body local rotations (joints stay at their local rest points)."""
    n = creature.nbody
    pos = np.empty((n, 3))
    rot = np.empty((n, 4))
    rot[0] = root_rot
    pos[0] = root_pos
    for b in range(1, n):
        p = int(creature.body_parent[b])
        rp = tuple(rot[p])
        joint = pos[p] + np.array(K.qrot(rp, tuple(creature.body_local_joint[b])))
        rot[b] = _qmul(rp, local_rot[b])
        pos[b] = joint + np.array(K.qrot(tuple(rot[b]), tuple(creature.body_joint_offset[b])))
    return pos, rot


def random_reachable_pose(creature, rng, root_pos=None, root_rot=None, max_bend=0.6, spine_bend=0.0,
                          rigid=()):
    """A random pose reachable by construction: every limb body turns by a random
    rotation of at most ``max_bend`` rad from its local rest rotation, spine bodies by at
    most ``spine_bend``, bodies in ``rigid`` (delegated ones) not at all. Returns
    (pos, rot, local_rot)."""
    n = creature.nbody
    root_pos = creature.body_rest_pos[0] if root_pos is None else root_pos
    root_rot = creature.body_rest_rot[0] if root_rot is None else root_rot
    local = np.array(creature.body_local_rot, float)
    for b in range(1, n):
        m = spine_bend if creature.body_is_spine[b] else max_bend
        if m > 0 and b not in rigid:
            local[b] = _qmul(random_axis_angle(rng, m), local[b])
    pos, rot = fk_pose(creature, root_pos, root_rot, local)
    return pos, rot, local


def joint_world(creature, pos, rot, b):
    """World position of body b's joint given its pose."""
    return pos[b] - np.array(K.qrot(tuple(rot[b]), tuple(creature.body_joint_offset[b])))
