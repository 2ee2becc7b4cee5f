"""Static analysis of a creature for its gait (Hecker et al. 2008, section 4.2, "Leg
Groups" and the float/crawl heuristic): which bodies step, how they cluster into leg
groups of roughly equal length, the harmonized relative cycle frequency of each group,
and how far each foot can sweep before its leg overreaches.

A *stepper* is a limb with feet: the feet of a branching limb step together so the
cross-constraints of the IK (section 4.3.3) keep their relative positions. A crawler's
stepper is one spine body (a pseudo-foot).

Float or crawl (creatures without usable legs). The creature crawls when its rest pose
lies on the ground (the lowest point of its bounding box is within 5% of its height of
z = 0) *and* it has a spine of at least four bodies that runs more along the ground than
up (horizontal span of the spine joints at least twice their vertical span): such a body
can arch and push. Everything else floats (fish, jellyfish, a blob resting on the ground
with a short spine hovers just above it).

Arrays (F feet, S steppers, G groups; all read-only):

    foot_body (F,) int32          the foot body (a crawler: a spine body)
    foot_stepper (F,) int32       its stepper
    foot_neutral (F, 3)           rest position of the foot origin, character space, m
    foot_offset (F,)              height of the foot origin above its lowest box corner at rest, m
    foot_rest_rot (F, 4)          rest rotation, character space
    foot_hip (F, 3)               hip joint (where the limb meets the spine) in the root's frame
    foot_jointrel (F, 3)          rest foot joint minus rest foot origin (character space)
    foot_reach (F,)               longest hip-joint to foot-joint distance the gait allows, m
    foot_chain (F,)               chain length from the hip joint to the foot joint, m
    foot_rigid (F,) int32         1 when one rigid segment joins hip and foot (no knee): the foot
                                  stays on a sphere around the hip, so the hips vault over the
                                  planted foot (a compass gait) and the swing foot follows the sphere
    foot_contact (F, 3)           rest contact point (centre of the foot box's lowest face or edge)
                                  minus the rest foot origin, character space
    foot_knee (F, 4)              a *pivot* foot (see below): rest foot joint minus rest foot origin
                                  (character space) and the rigid segment's length from hip joint to
                                  foot joint (its last entry; 0 for every other foot)

A pivot foot is the lower leg of a knee-less limb: one rigid segment joins the hip to the
foot's joint and the foot body reaches far from that joint down to the ground (a
centipede's tibia). Holding such a foot at a fixed rotation would make the leg a compass
leg hanging from a near-horizontal femur, whose hip height changes as the square root of
the foot's shift. The foot joint is a knee instead: the gait plants the contact point and
turns the foot about it so the joint sits on the segment's sphere around the hip
(``engine.gait._kernels.pivot_goal``). For the rest of the gait such a leg is an ordinary
bending leg whose "foot joint" is the contact point (``foot_jointrel`` = ``foot_contact``,
``foot_chain`` = segment + foot reach).
    step_foot_adr, step_foot_num (S,) int32   feet of stepper s: foot_* rows [adr, adr+num)
    step_group (S,) int32, step_side (S,) float64 (+1 left, -1 right, 0 middle), step_rank (S,) int32
                                  (row from the front within its group)
    group_length (G,)             mean leg length of the group, m
    group_ratio (G,)              relative cycle frequency (small rational, the longest group is 1)
    group_radius (G,)             largest horizontal distance of a rest foot from the character origin, m
    group_sweep (G, NCROUCH)      half-sweep a foot of the group may make from its rest spot
                                  (worst foot, worst direction) at crouch c = k / (NCROUCH-1) * MAX_CROUCH
                                  leg lengths, m
    group_min_crouch (G,)         crouch (leg lengths) the group needs for a half-sweep of
                                  MIN_SWEEP leg lengths (straight legs must bend to step)
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from engine.model.creature import Creature

#: Legs whose length differs by less than this factor share a group.
GROUP_TOLERANCE = 1.3
#: Denominators (and numerators) of the harmonized ratios stay at or below this.
MAX_RATIO_TERM = 4
#: Share of the chain length a leg may extend to (the IK meets such goals exactly).
REACH_SHARE = 0.9
NCROUCH = 21
MAX_CROUCH = 0.4
#: Half-sweep (leg lengths) a group must be able to make; straight legs crouch for it.
MIN_SWEEP = 0.2
#: A knee-less leg's foot is a pivot foot when its contact point lies at least this share
#: of the rigid segment's length from the foot joint, and the segment and the foot meet at
#: an angle between PIVOT_ANGLE and 180 degrees - PIVOT_ANGLE (a knee that can bend both
#: ways; a straight stick is a compass leg).
PIVOT_REACH = 0.25
PIVOT_ANGLE = np.radians(30.0)
MODES = ("walk", "crawl", "float")


@dataclass(frozen=True)
class GaitRig:
    mode: str
    foot_body: np.ndarray
    foot_stepper: np.ndarray
    foot_neutral: np.ndarray
    foot_offset: np.ndarray
    foot_rest_rot: np.ndarray
    foot_hip: np.ndarray
    foot_jointrel: np.ndarray
    foot_reach: np.ndarray
    foot_chain: np.ndarray
    foot_rigid: np.ndarray
    foot_contact: np.ndarray
    foot_knee: np.ndarray
    step_foot_adr: np.ndarray
    step_foot_num: np.ndarray
    step_group: np.ndarray
    step_side: np.ndarray
    step_rank: np.ndarray
    group_length: np.ndarray
    group_ratio: np.ndarray
    group_ratio_pq: tuple
    group_radius: np.ndarray
    group_sweep: np.ndarray
    group_min_crouch: np.ndarray
    float_height: float

    @property
    def nfoot(self) -> int:
        return int(self.foot_body.shape[0])

    @property
    def nstep(self) -> int:
        return int(self.step_group.shape[0])

    @property
    def ngroup(self) -> int:
        return int(self.group_length.shape[0])

    def group_steppers(self, g: int) -> np.ndarray:
        """Steppers of group g in front-to-back order."""
        idx = np.flatnonzero(self.step_group == g)
        return idx[np.argsort(self.step_rank[idx], kind="stable")]


def harmonize(lengths, max_term: int = MAX_RATIO_TERM) -> list[Fraction]:
    """Relative cycle frequencies of leg groups: the longest group cycles at 1, a group
    ``r`` times shorter at the small rational closest to ``r`` (numerator and denominator
    at most ``max_term``), so every group's cycle is locked to the others (section 4.2)."""
    lengths = [float(v) for v in lengths]
    if not lengths:
        return []
    longest = max(lengths)
    candidates = sorted({Fraction(p, q) for p in range(1, max_term + 1) for q in range(1, max_term + 1)
                         if p >= q})
    out = []
    for length in lengths:
        r = longest / max(length, 1e-9)
        out.append(min(candidates, key=lambda c: (abs(float(c) / r - 1.0), c.denominator)))
    return out


def cluster_lengths(lengths, tolerance: float = GROUP_TOLERANCE) -> np.ndarray:
    """Group index per leg: legs sorted by length, a new group starts when a leg is more
    than ``tolerance`` times the shortest leg of the current group; groups numbered from
    the longest."""
    lengths = np.asarray(lengths, float)
    order = np.argsort(-lengths, kind="stable")
    group = np.zeros(len(lengths), np.int32)
    g, top = -1, None
    for i in order:
        if top is None or top > tolerance * lengths[i]:
            g += 1
            top = lengths[i]
        group[i] = g
    return group


def _rot(q, v):
    w, x, y, z = q
    u = np.array([x, y, z])
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _corners(c: Creature, b: int) -> np.ndarray:
    """The eight corners of body b's box at rest, character space (8, 3)."""
    e = c.body_extent[b]
    corners = np.array([[sx * e[0], sy * e[1], sz * e[2]] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return np.array([_rot(c.body_rest_rot[b], k) + c.body_rest_pos[b] for k in corners])


def _lowest_corner(c: Creature, b: int) -> float:
    return float(np.min(_corners(c, b)[:, 2]))


def contact_point(c: Creature, b: int) -> np.ndarray:
    """Where body b touches flat ground at rest (character space): the centre of its box's
    lowest face, edge or corner (corners within 5% of the box's largest half-extent of the
    lowest count as touching)."""
    k = _corners(c, b)
    zmin = float(np.min(k[:, 2]))
    tol = 1e-6 + 0.05 * float(np.max(c.body_extent[b]))
    low = k[k[:, 2] <= zmin + tol]
    p = low.mean(axis=0)
    p[2] = zmin
    return p


def _pivot(c: Creature, f: int, hip: np.ndarray, chain: float):
    """(foot joint - origin, contact - origin) of foot body f when it is a pivot foot of a
    knee-less leg whose hip joint is ``hip`` (character space, rest) and segment ``chain`` m
    long (see the module docstring), else None."""
    joint = c.body_joint[f]
    contact = contact_point(c, f)
    reach = float(np.linalg.norm(contact - joint))
    if chain <= 1e-6 or reach < PIVOT_REACH * chain:
        return None
    a, b = hip - joint, contact - joint
    cosang = float(np.dot(a, b) / max(np.linalg.norm(a) * np.linalg.norm(b), 1e-12))
    ang = float(np.arccos(min(max(cosang, -1.0), 1.0)))
    if not (PIVOT_ANGLE <= ang <= np.pi - PIVOT_ANGLE):
        return None
    origin = c.body_rest_pos[f]
    return joint - origin, contact - origin


def decide_mode(c: Creature, usable_legs: int) -> str:
    """'walk' with usable legs, else the float/crawl heuristic of the module docstring."""
    if usable_legs > 0:
        return "walk"
    height = max(float(c.bounds[1, 2]), 1e-6)
    on_ground = float(c.bounds[0, 2]) <= 0.05 * height
    spine = c.spine_chain
    if on_ground and len(spine) >= 4:
        j = c.body_joint[spine]
        span_xy = float(np.max(np.ptp(j[:, :2], axis=0)))
        span_z = float(np.ptp(j[:, 2]))
        if span_xy >= 2.0 * span_z:
            return "crawl"
    return "float"


def analyze(c: Creature) -> GaitRig:
    """The GaitRig of ``c`` (see the module docstring)."""
    # usable legs: a chain long enough to move the foot relative to its hip
    legs = [k for k in range(c.nleg) if float(c.body_limb_length[c.leg_foot[k]]) > 1e-3]
    mode = decide_mode(c, len(legs))
    if mode == "walk":
        return _walk_rig(c, legs)
    if mode == "crawl":
        return _crawl_rig(c)
    return _empty_rig(c)


def _empty_rig(c: Creature) -> GaitRig:
    z0 = np.zeros(0)
    i0 = np.zeros(0, np.int32)
    return GaitRig(mode="float", foot_body=i0, foot_stepper=i0, foot_neutral=np.zeros((0, 3)), foot_offset=z0,
                   foot_rest_rot=np.zeros((0, 4)), foot_hip=np.zeros((0, 3)), foot_jointrel=np.zeros((0, 3)),
                   foot_reach=z0, foot_chain=z0, foot_rigid=i0, foot_contact=np.zeros((0, 3)),
                   foot_knee=np.zeros((0, 4)), step_foot_adr=i0, step_foot_num=i0, step_group=i0,
                   step_side=z0,
                   step_rank=i0, group_length=z0, group_ratio=z0, group_ratio_pq=(), group_radius=z0,
                   group_sweep=np.zeros((0, NCROUCH)), group_min_crouch=z0, float_height=float(max(c.size[2], 1e-3)))


def _order(neutral_x: np.ndarray, side: np.ndarray, length_scale: float) -> np.ndarray:
    """Front to back by rest x (rounded to 5% of the leg length so mirror pairs tie), left
    before right."""
    q = np.round(neutral_x / max(0.05 * length_scale, 1e-6))
    return np.lexsort((-side, -q))


def _walk_rig(c: Creature, legs: list[int]) -> GaitRig:
    # steppers: one per limb with usable feet
    limb_of = {}
    for k in legs:
        limb_of.setdefault(int(c.body_limb[c.leg_foot[k]]), []).append(k)
    limbs = sorted(limb_of)
    step_len = np.array([max(float(c.leg_length[k]) for k in limb_of[m]) for m in limbs])
    step_group = cluster_lengths(step_len)
    ngroup = int(step_group.max()) + 1
    group_length = np.array([float(np.mean(step_len[step_group == g])) for g in range(ngroup)])
    ratios = harmonize(group_length)
    foot_rows = []
    step_rows = []
    for s, m in enumerate(limbs):
        ks = limb_of[m]
        adr = len(foot_rows)
        limb_root = int(c.limb_root[m])
        for k in ks:
            f = int(c.leg_foot[k])
            chain = float(c.body_limb_length[f])
            rigid = 1 if len(c.leg_path(k)) <= 2 else 0
            foot_rows.append((f, s, limb_root, chain, rigid))
        ys = np.mean([c.body_rest_pos[int(c.leg_foot[k]), 1] for k in ks])
        xs = np.mean([c.body_rest_pos[int(c.leg_foot[k]), 0] for k in ks])
        step_rows.append((adr, len(ks), xs, 1.0 if ys > 1e-6 else (-1.0 if ys < -1e-6 else 0.0)))
    foot_body = np.array([r[0] for r in foot_rows], np.int32)
    foot_stepper = np.array([r[1] for r in foot_rows], np.int32)
    foot_hip = np.array([c.body_rootrel_joint[r[2]] for r in foot_rows])
    chain = np.array([r[3] for r in foot_rows])
    foot_rigid = np.array([r[4] for r in foot_rows], np.int32)
    step_side = np.array([r[3] for r in step_rows])
    step_x = np.array([r[2] for r in step_rows])
    step_rank = np.zeros(len(limbs), np.int32)
    for g in range(ngroup):
        idx = np.flatnonzero(step_group == g)
        order = idx[_order(step_x[idx], step_side[idx], group_length[g])]
        step_rank[order] = np.arange(len(order))
    foot_neutral = c.body_rest_pos[foot_body].copy()
    foot_offset = np.array([c.body_rest_pos[f, 2] - _lowest_corner(c, f) for f in foot_body])
    foot_jointrel = c.body_joint[foot_body] - foot_neutral
    foot_contact = np.array([contact_point(c, int(f)) for f in foot_body]).reshape(-1, 3) - foot_neutral
    # hip joint in character space at rest (the root at rest)
    root_p, root_q = c.body_rest_pos[0], c.body_rest_rot[0]
    hip_rest = np.array([root_p + _rot(root_q, h) for h in foot_hip]).reshape(-1, 3)
    # pivot feet: the foot joint is a knee, the contact point the leg's end
    foot_knee = np.zeros((len(foot_body), 4))
    for f in range(len(foot_body)):
        if not foot_rigid[f]:
            continue
        piv = _pivot(c, int(foot_body[f]), hip_rest[f], float(chain[f]))
        if piv is None:
            continue
        knee, contact = piv
        foot_knee[f, :3] = knee
        foot_knee[f, 3] = chain[f]
        foot_jointrel[f] = contact
        chain[f] = chain[f] + float(np.linalg.norm(contact - knee))
        foot_rigid[f] = 0
    foot_reach = REACH_SHARE * chain
    group_radius = np.zeros(ngroup)
    group_sweep = np.zeros((ngroup, NCROUCH))
    crouch = np.linspace(0.0, MAX_CROUCH, NCROUCH)
    for g in range(ngroup):
        feet = np.flatnonzero(step_group[foot_stepper] == g)
        group_radius[g] = float(np.max(np.hypot(foot_neutral[feet, 0], foot_neutral[feet, 1])))
        for ci, cr in enumerate(crouch):
            worst = np.inf
            for f in feet:
                d = (foot_neutral[f] + foot_jointrel[f]) - hip_rest[f]
                v = -d[2] - cr * group_length[g]         # hip height above the foot joint after crouching
                r0 = float(np.hypot(d[0], d[1]))
                R = foot_reach[f]
                if foot_rigid[f]:
                    # compass: the hips may sink to 90% of the leg over the planted foot
                    avail = float(np.sqrt(max(chain[f] ** 2 - (0.9 * chain[f]) ** 2, 0.0))) - r0
                elif v <= 0.0:                               # crouched below the foot: only the reach bounds it
                    avail = R - r0
                elif R > v:
                    avail = float(np.sqrt(R * R - v * v)) - r0
                else:
                    avail = 0.0
                worst = min(worst, avail)
            group_sweep[g, ci] = max(worst, 0.0)
    group_min_crouch = np.zeros(ngroup)
    feet_of_group = [np.flatnonzero(step_group[foot_stepper] == g) for g in range(ngroup)]
    for g in range(ngroup):
        if np.all(foot_rigid[feet_of_group[g]]):
            continue                                       # compass legs never crouch: the hips vault
        ok = np.flatnonzero(group_sweep[g] >= MIN_SWEEP * group_length[g])
        k = int(ok[0]) if len(ok) else int(np.argmax(group_sweep[g]))
        group_min_crouch[g] = crouch[k]
    return GaitRig(mode="walk", foot_body=foot_body, foot_stepper=foot_stepper, foot_neutral=foot_neutral,
                   foot_offset=foot_offset, foot_rest_rot=c.body_rest_rot[foot_body].copy(), foot_hip=foot_hip,
                   foot_jointrel=foot_jointrel, foot_reach=foot_reach, foot_chain=chain, foot_rigid=foot_rigid,
                   foot_contact=foot_contact, foot_knee=foot_knee,
                   step_foot_adr=np.array([r[0] for r in step_rows], np.int32),
                   step_foot_num=np.array([r[1] for r in step_rows], np.int32), step_group=step_group,
                   step_side=step_side, step_rank=step_rank, group_length=group_length,
                   group_ratio=np.array([float(r) for r in ratios]), group_ratio_pq=tuple(ratios),
                   group_radius=group_radius, group_sweep=group_sweep, group_min_crouch=group_min_crouch,
                   float_height=0.0)


def _crawl_rig(c: Creature) -> GaitRig:
    """Pseudo-feet: up to three or four spine bodies that touch the ground at rest, spread as
    evenly along the chain as they allow, never the root (the IK drives it forward-kinematically),
    at least two bodies apart and, where possible, two away from the root. More pseudo-feet
    over-constrain the spine: the IK's spine phase places particles only at branch points
    (section 4.3.2), and goals on many interior spine bodies cannot all be met."""
    spine = [int(b) for b in c.spine_chain]
    height = max(float(c.bounds[1, 2]), 1e-6)
    # only bodies that lie on the ground at rest can push on it (an inch-worm's arch stays up)
    touching = [i for i, b in enumerate(spine) if b != 0 and _lowest_corner(c, b) <= 0.05 * height + 1e-4]
    if not touching:
        return _empty_rig(c)
    k = 4 if len(spine) >= 8 else 3
    # pseudo-feet at least two bodies apart along the chain: neighbours share a joint, so
    # the spine between them cannot stretch or bend to let one stay planted while the
    # other moves
    # ... and two bodies away from the root, whose position the gait sets (the IK does not
    # move it), when the creature has such bodies on the ground
    if 0 in spine:
        r0 = spine.index(0)
        away = [j for j in touching if abs(j - r0) >= 2]
        touching = away or touching
    chosen: list[int] = []
    for target in np.linspace(0, len(spine) - 1, k):
        free = [j for j in touching if all(abs(j - i) >= 2 for i in chosen)]
        if free:
            chosen.append(min(free, key=lambda j: abs(j - target)))
    picks = [spine[i] for i in sorted(set(chosen))]
    if not picks:
        return _empty_rig(c)
    foot_body = np.array(picks, np.int32)
    n = len(picks)
    foot_neutral = c.body_rest_pos[foot_body].copy()
    # crawler "leg length": the spacing of pseudo-feet along the body
    joints = c.body_joint[c.spine_chain]
    span = float(np.sum(np.linalg.norm(np.diff(joints, axis=0), axis=1)))
    spacing = max(span / max(n, 1), 1e-3)
    foot_offset = np.array([c.body_rest_pos[f, 2] - _lowest_corner(c, f) for f in foot_body])
    step_x = foot_neutral[:, 0]
    rank = np.zeros(n, np.int32)
    rank[np.argsort(-step_x, kind="stable")] = np.arange(n)
    # a pseudo-foot may sweep a share of its distance from the root (the spine stretches
    # and shrinks by at most 10-20% in the IK, section 4.3.2)
    dist_root = np.linalg.norm(foot_neutral - c.body_rest_pos[0], axis=1)
    sweep = max(0.08 * float(np.min(dist_root)), 0.05 * spacing)
    return GaitRig(mode="crawl", foot_body=foot_body, foot_stepper=np.arange(n, dtype=np.int32),
                   foot_neutral=foot_neutral, foot_offset=foot_offset,
                   foot_rest_rot=c.body_rest_rot[foot_body].copy(), foot_hip=np.zeros((n, 3)),
                   foot_jointrel=np.zeros((n, 3)), foot_reach=np.full(n, np.inf), foot_chain=np.zeros(n),
                   foot_rigid=np.zeros(n, np.int32),
                   foot_contact=np.array([contact_point(c, int(f)) for f in foot_body]) - foot_neutral,
                   foot_knee=np.zeros((n, 4)), step_foot_adr=np.arange(n, dtype=np.int32),
                   step_foot_num=np.ones(n, np.int32),
                   step_group=np.zeros(n, np.int32), step_side=np.zeros(n), step_rank=rank,
                   group_length=np.array([spacing]), group_ratio=np.ones(1), group_ratio_pq=(Fraction(1),),
                   group_radius=np.array([float(np.max(np.hypot(step_x, foot_neutral[:, 1])))]),
                   group_sweep=np.full((1, NCROUCH), sweep), group_min_crouch=np.zeros(1), float_height=0.0)
