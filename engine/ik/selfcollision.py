"""Static part of the limb phase's self-collision (issue 16), built with the plan: one
capsule proxy per body and the list of pairs to test. The kernel is
``engine.ik._collide``; its layout is documented there.

Proxy of a body: a capsule along its box's longest axis, radius the mean of the two other
half-extents (a flat box, a palm or a slab of torso, is neither inflated to its width
nor shrunk to its thickness), the capsule's ends inside the box's ends. Carried by:

- a body the limb phase moves (a limb body in the IK sub-tree): its bone, from its joint
  particle to its child or tip particle; a body rigid on its parent in the limb phase
  (no child particle of its own) and a free body (no IK, placed by the caller) below a
  limb body ride on the nearest such bone above them;
- any other body (the spine, the root, delegated heads and mouths, and free bodies
  below them): its nearest posed ancestor, fixed during the limb phase.

Pairs: every two bodies that are not parent and child (the validation grid's
``self_intersection`` tests the same pairs), skipping pairs that cannot move apart in the
limb phase (both fixed, or both on the same bone), siblings pivoting about one joint
(their joints closer than their two radii: a fork's toes, a hand's fingers, which touch
at the joint by construction and turn into each other there whenever the fork folds) and
siblings whose proxies already touch at rest (a neck and the shoulder beside it on the
chest: the raised shoulder pushed the neck and the head it carries, 0.72 rad in one
frame on the twoheaded). Each pair may overlap as deeply as its proxies do in the rest
pose (creatures are built with boxes overlapping at a shoulder or a neck: that is theirs).
A planted foot's goal is never settled (``_planted``).
"""

from __future__ import annotations

import numpy as np

from engine.ik import _collide as C
from engine.mathx import quat_conj, quat_rotate


def capsule_of_box(extent):
    """(axis index, half length of the segment, radius) of a box's capsule proxy."""
    e = np.asarray(extent, np.float64)
    k = int(np.argmax(e))
    others = np.delete(e, k)
    r = float(np.mean(others))
    r = min(r, float(e[k]))
    return k, max(float(e[k]) - r, 0.0), r


def _rest_segment(c, body):
    """World (root-relative rest) ends of a body's capsule and its radius."""
    k, h, r = capsule_of_box(c.body_extent[body])
    axis = np.zeros(3)
    axis[k] = 1.0
    q = c.body_rootrel_rot[body]
    centre = c.body_rootrel_pos[body]
    d = quat_rotate(q, axis) * h
    return centre - d, centre + d, r


def closest_distance(a0, a1, b0, b1):
    s, t = C.closest_params((a0[0], a0[1], a0[2]), (a1[0], a1[1], a1[2]),
                            (b0[0], b0[1], b0[2]), (b1[0], b1[1], b1[2]))
    return float(np.linalg.norm((a0 + s * (a1 - a0)) - (b0 + t * (b1 - b0))))


def _planted(c, b: int) -> bool:
    """Whether body b's goal is a foot's place on the ground (a foot that is not also a
    grasper): the standing and gait stages chose it, and settling it out of a neighbouring
    leg's proxy would slide a planted foot (random creature 4246's crowded legs: 7 mm, the
    grid's standing_slide failing in four cells), so it is never settled."""
    return c.has_cap(b, "foot") and not c.has_cap(b, "grasper")


def build(c, has_ik, lp_body, lp_mode, lp_c1, lp_attach, enabled: bool, rounds: int, work_row: int,
          goal_body=(), goal_lp=()):
    """(cl_i int32, cl_f float64, work rows, pair bodies (npair, 2) int64) for one plan.
    ``enabled`` False gives empty fields (nothing is tested: the solve is the one without
    self-collision). The first ``nbody`` work rows always hold the limb phase's goal
    positions (``engine.ik._collide.settle_goals``); the goal section lists, per goal of
    the plan (``goal_body``, ``goal_lp``), the pairs its body is settled against."""
    n = c.nbody
    parent = c.body_parent
    if not enabled or n < 3:
        return np.array([0, 0, 0, work_row, 0, 0], np.int32), np.zeros(0), n, np.zeros((0, 2), np.int64)
    # The bone each limb body swings with: (pivot particle, direction particle).
    bone_of = {}
    for i in range(len(lp_body)):
        if lp_mode[i] == 3 or lp_c1[i] < 0 or lp_mode[i] == 2:
            continue
        bone_of[int(lp_body[i])] = (i, int(lp_c1[i]))
    limb_bodies = {int(lp_body[i]) for i in range(len(lp_body)) if lp_mode[i] != 3}

    def owner(b):
        """(carrier body, pivot, dir, frame body) of body b's proxy."""
        o = b
        while o > 0 and (not has_ik[o] or (o in limb_bodies and o not in bone_of)):
            o = int(parent[o])
        if o in bone_of:
            i, d = bone_of[o]
            return int(lp_attach[i]), i, d, o
        return o, -1, -1, o

    owners = [owner(b) for b in range(n)]
    # bodies that carry a head (a neck, the head itself and what rides on it): their pushes
    # go to the other side of a contact when that side yields (an arm)
    head_borne = [False] * n
    for b in range(n):                  # a head and what rides on it (jaw, eyes, ears)
        head_borne[b] = c.has_cap(b, "head") or (parent[b] >= 0 and head_borne[int(parent[b])])
    for b in range(n - 1, -1, -1):     # and the neck below it, down to the spine
        if head_borne[b] and parent[b] >= 0 and not c.has_cap(int(parent[b]), "spine"):
            head_borne[int(parent[b])] = True
    segs = [_rest_segment(c, b) for b in range(n)]
    order = [b for b in range(n) if owners[b][1] >= 0] + [b for b in range(n) if owners[b][1] < 0]
    slot = {b: k for k, b in enumerate(order)}
    nmove = sum(1 for b in range(n) if owners[b][1] >= 0)
    ints = [len(order), nmove, 0, work_row, int(rounds), 0]
    floats = []
    for b in order:
        s, i, d, o = owners[b]
        a0, a1, r = segs[b]
        # a fixed proxy in its carrier's frame about the carrier's origin; a mover in its
        # bone body's frame about that body's joint (its pivot particle)
        qs = quat_conj(c.body_rootrel_rot[o])
        ps = c.body_rootrel_joint[o] if i >= 0 else c.body_rootrel_pos[o]
        ints += [s, i, d]
        floats += list(quat_rotate(qs, a0 - ps)) + list(quat_rotate(qs, a1 - ps))
        floats += [r, 0.5 * float(np.linalg.norm(a1 - a0)) + r]   # bounding radius about the middle
        floats += [0.0 if head_borne[b] else 1.0]
    pairs = []
    pair_bodies = []
    allowed = []
    for a in range(n):
        for b in range(a + 1, n):
            if parent[b] == a or parent[a] == b:
                continue
            oa, ob = owners[a], owners[b]
            if oa[1] < 0 and ob[1] < 0:
                continue          # neither moves in the limb phase
            if oa == ob:
                continue          # rigid on the same bone
            a0, a1, ra = segs[a]
            b0, b1, rb = segs[b]
            if parent[a] == parent[b] and np.linalg.norm(c.body_rootrel_joint[a] - c.body_rootrel_joint[b]) < ra + rb:
                continue          # siblings pivoting about one joint (a fork's toes, fingers): neighbours
            allow = max(0.0, ra + rb - closest_distance(a0, a1, b0, b1))
            if parent[a] == parent[b] and allow > 0.0:
                continue          # siblings built touching (a neck beside a shoulder): neighbours
            pairs.append((slot[a], slot[b]))
            pair_bodies.append((a, b))
            reach = floats[C.NF_PROX * slot[a] + 7] + floats[C.NF_PROX * slot[b] + 7] - allow
            allowed += [allow, max(reach, 0.0) ** 2]
    ints[2] = len(pairs)
    for p in pairs:
        ints += list(p)
    # Goal section: per goal (own proxy slot, first entry, entries; entries -1 for a
    # planted foot, which is never moved), then entries (pair, other slot, other goal or
    # -1): the fixed proxies a limb goal body's position goal is settled against, and the
    # other limb goals' bodies it is kept apart from.
    goal_of = {int(b): gi for gi, b in enumerate(goal_body) if goal_lp[gi] >= 0}
    ints[5] = len(ints)
    head = len(ints)
    ints += [0, 0, 0] * len(goal_body)
    for gi, b in enumerate(goal_body):
        b = int(b)
        ints[head + 3 * gi] = slot[b]
        ints[head + 3 * gi + 1] = len(ints)
        if goal_lp[gi] < 0:
            continue
        if _planted(c, b):
            ints[head + 3 * gi + 2] = -1      # never moved, and no goal is kept apart from it
            continue
        cnt = 0
        for p, (x, y) in enumerate(pair_bodies):
            if b not in (x, y):
                continue
            o = y if x == b else x
            if owners[o][1] < 0:
                ints += [p, slot[o], -1]
            elif o in goal_of:
                ints += [p, slot[o], goal_of[o]]
            else:
                continue
            cnt += 1
        ints[head + 3 * gi + 2] = cnt
    cl_i = np.array(ints, np.int32)
    cl_f = np.array(floats + allowed, np.float64)
    return cl_i, cl_f, n + C.W * len(order) + 2 * len(lp_body), np.array(pair_bodies, np.int64).reshape(-1, 2)


def pose_excess(plan, pos, rot, margin: float = 0.0) -> np.ndarray:
    """(npair,) how much deeper than at rest each of the plan's pairs' capsules overlap
    in a world pose ``pos`` (nbody, 3), ``rot`` (nbody, 4) (0 where they do not): the
    kernel's own measure, on a pose's bodies instead of its particles (tests pick goals
    outside the body with it). ``margin`` (share of the thinner radius) counts pairs that
    come that close as overlapping: the kernel poses a fork body's capsule by its first
    branch alone, so its proxy can touch where the final pose's does not quite."""
    c = plan.creature
    pairs = plan.self_collision_pairs
    out = np.zeros(len(pairs))
    if len(pairs) == 0:
        return out
    segs = {}
    for b in np.unique(pairs):
        k, h, r = capsule_of_box(c.body_extent[b])
        axis = np.zeros(3)
        axis[k] = 1.0
        d = quat_rotate(rot[b], axis) * h
        segs[int(b)] = (pos[b] - d, pos[b] + d, r)
    rest = {}
    for j, (a, b) in enumerate(pairs):
        a0, a1, ra = segs[int(a)]
        b0, b1, rb = segs[int(b)]
        if (int(a), int(b)) not in rest:
            ra0, ra1, _ = _rest_segment(c, int(a))
            rb0, rb1, _ = _rest_segment(c, int(b))
            rest[int(a), int(b)] = max(0.0, ra + rb - closest_distance(ra0, ra1, rb0, rb1))
        out[j] = max(0.0, ra + rb + margin * min(ra, rb) - closest_distance(a0, a1, b0, b1) - rest[int(a), int(b)])
    return out


def settled_goals(plan, goal_pos, goal_pw, body_pos, body_rot, scratch=None) -> np.ndarray:
    """(nbody, 3) the position goals the plan's limb phase pins to, for goals
    ``goal_pos`` (nbody, 3) of weights ``goal_pw`` (nbody,) on a creature whose posed
    spine and root are ``body_pos``/``body_rot`` (a solved pose: the limb phase does not
    move them): goals inside the creature's own bodies moved to their surface
    (``engine.ik._collide.settle_goals``); rows of bodies without a limb goal are
    ``goal_pos``'s. With self-collision off, ``goal_pos`` unchanged."""
    from engine.ik import _kernels as K

    out = np.array(goal_pos, np.float64)
    a = plan.arrays
    if int(a.cl_i[0]) == 0:
        return out
    if scratch is None:
        scratch = plan.make_scratch()
    K.settle_packed(plan.plan_i, plan.plan_f, plan.plan_f3, plan.plan_f4, np.ascontiguousarray(goal_pos, np.float64),
                    np.ascontiguousarray(goal_pw, np.float64), np.ascontiguousarray(body_pos, np.float64),
                    np.ascontiguousarray(body_rot, np.float64), scratch)
    w0 = int(a.cl_i[3])
    for b in plan.goal_bodies:
        out[b] = scratch[w0 + b]
    return out
