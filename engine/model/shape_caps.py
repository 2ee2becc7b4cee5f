"""Capabilities from a skeleton's shape, names as a hint (for imported BVH and glTF rigs).

Hecker et al. 2008, section 1.2: the animation system needs to know which bodies are the
spine, legs and feet, arms and graspers, head, mouth and tail. Joint names say so only
when they follow a convention the table knows; a Character Creator capture
(``CC_Base_L_Thigh``), the Fox (``b_LeftLeg01_015``) or a spider (``FrontLeg2.L``) do not.
So the rest pose decides first, in Menagerie axes (Z up, X forward, Y left) with the
creature standing on z = 0:

1. **Sagittal bodies**: the root and every body whose parent is sagittal and that is not
   *sided*. A body is sided when it lies off the plane (joint or box centre beyond
   ``SIDE_FRACTION`` x size) and has a mirror partner (a body at its reflection within
   ``MIRROR_FRACTION`` x size): a coiled snake's body is off the plane but has none. Small
   bodies (eyes on a head) are sided at the scale of their own bone
   (``LOCAL_SIDE_FRACTION``, ``LOCAL_MIRROR_FRACTION``) when their parents are one body or
   a pair. A link whose only child is sided is sided too. Sided bodies hang off as *side
   chains*; a branch lying wholly to one side with no partner (a third arm) is one too.
2. **Head and spine**: among the ends of sagittal chains that do not stand on the ground
   (and the root), the head is the one lying furthest forward and highest (2x + z relative
   to the root, by the far end of its box: a scorpion's tail curls up over its back). Small
   leaf bodies past it (a jaw, a tongue: under ``HEAD_TRIM_RATIO`` of the body before, with
   nothing but trimmed bodies below them) are trimmed off; the lowest one hanging off the
   head is its mouth. The head may be the root (a crab's carapace). The spine runs from the
   head back to the farthest sagittal body that carries a leg or an arm (a quadruped's hips
   when the file's root is its chest; spikes do not count), then on up to the file's root.
   The front end is no head when it carries limbs and no face (no small body past it, no
   jaw, eye, ear or trunk off it, no neck heads): a palm carrying its fingers. A chain lying
   wholly to one side, off a body that carries paired side chains, is a side chain, not a
   candidate for the head (a thumb, a third arm).
3. **Sagittal branches** off the spine: one whose end lies behind where it leaves the
   spine and that has ``TAIL_MIN_BODIES`` or more bodies is a tail, unless it leaves the
   middle of the back (not the spine's rear end) rising more than it goes back: a dorsal
   fin or crest (detail); one off the head is
   the mouth (its first body; the rest are detail), or a trunk (an arm) with
   ``TRUNK_MIN_BODIES`` or more; any other is detail. A sagittal chain that runs back
   along the body and then comes down to the ground under it is spine, then a **leg** (a
   tripod's hind leg at the rear of a long back): the leg is the part whose bones fall
   steeper than 45 degrees (the split that best parts them from the bones lying along the
   body), its first joint at least ``SAGITTAL_LEG_ROOT_FRACTION`` of the root's height up
   and its foot under it (``SAGITTAL_LEG_LEAN``); the spine runs on to where it leaves. A
   tail trailing down to the ground behind (a kangaroo's) leans too far to be one; a tail
   hanging straight down is a leg by its shape and stays a tail only by its name.
4. **Side chains** (a sided child of a sagittal body and everything below it). The
   *main path* follows, at each body, the child whose subtree reaches furthest. A chain off
   the head reaching less than ``EAR_MAX_FRACTION`` x size is an ear (or eye, if its name
   says so). A chain of two or more bodies whose lowest box corner is within
   ``GROUND_FRACTION`` x height of the ground, lies at most ``LEG_SPREAD_RATIO`` times
   its drop away sideways (it comes down to the ground rather than lying along it), and
   whose joints come down ``LEG_DESCENT_FRACTION`` of the way from its root to the ground
   (a box's thickness near the ground does not make a leg: a shark's fin) is a
   **leg**: its foot is the first body on the main path whose joint lies below
   ``FOOT_FRACTION`` x the chain's start height (else the last body), later bodies are
   detail; a branch before the foot that reaches the ground too is another leg (a forked
   leg). A chain rising ``NECK_RISE_FRACTION`` of its length to above the head's joint is a
   neck carrying a **head** (where it branches, else its end), and so is a chain that does
   not go down and ends in a face (a body carrying two or more small leaves); a sagittal
   head that carries such necks is the shoulders they share, not a head. A chain whose far
   end lies behind its root (``SWEEP_BACK_FRACTION``), going out more than down and not
   coming down to the ground, is a **wing** when it spans ``WING_MIN_SPAN`` x size and is
   level or raised (``WING_MAX_DROOP``; a short branch off its leading bones that does not
   sweep back is its claw, a grasper: a bat's thumb), else a **fin** (limb, no grasper).
   ``FAN_MIN_CHAINS`` free chains off one body pointing within ``FAN_ANGLE`` of each other
   are a hand's **digits** (limb), with any other free chain there no longer than them
   (the thumb). Any other chain is an **arm**: its
   grasper is the first body on the main path where it branches in two or more (a hand
   with fingers), else its last body; later bodies and side branches are detail. A chain
   ending in a body named as an eye or an ear is a stalk. A free chain shorter than
   ``ARM_MIN_BODIES`` is a spike (by name) or detail.
5. **Names as a hint**: a name the table maps to ``wing`` turns an arm into a wing (no
   grasper); ``eye``/``ear``/``mouth``/``tail`` names add that capability to a body off
   the spine. Names are matched as in the BVH importer, also with leading ``Xx_`` tokens
   (``CC_Base_``, ``b_``) and a trailing ``_NN`` index removed, and, failing those, with
   trailing tokens removed (``wing0_l_seg2``). A foot named as a hand stays a foot: the
   Khronos fox's forefeet are ``b_LeftHand``, so a name cannot tell a knuckle-walker.

A head with no mouth of its own stands in for it (as for BVH).
``mode="names"`` uses the name table alone (``engine.io.bvh_creature.joint_caps``' rules).
Every body gets a one-line reason (``menagerie creatures explain``).
"""

from __future__ import annotations

import re

import numpy as np

#: |y| below this fraction of the creature's size: on the sagittal plane.
SIDE_FRACTION = 0.03
#: A chain reaching within this fraction of the height of the ground is a leg.
GROUND_FRACTION = 0.12
#: A leg's foot: the first body whose joint is below this fraction of the leg's start height.
FOOT_FRACTION = 0.22
#: A free side chain needs this many bodies on its main path to be an arm (else a spike, a fin stub).
ARM_MIN_BODIES = 2
#: Bodies at the mirror image of each other within this fraction of the size are a pair.
MIRROR_FRACTION = 0.06
#: A body at the end of the head path smaller than this fraction of its parent is not the head.
HEAD_TRIM_RATIO = 0.3
#: A sagittal branch going backward needs this many bodies to be a tail.
TAIL_MIN_BODIES = 2
#: A sagittal chain that runs back along the body and then comes down to the ground is spine
#: then a leg (a tripod's hind leg at the rear end of a long back): the leg is the part whose
#: bones fall steeper than 45 degrees, and its first joint lies at least this fraction of the
#: root's height above the ground (a tail curling down to the ground meets it low).
SAGITTAL_LEG_ROOT_FRACTION = 0.5
#: ... and its foot lies under that first joint: no farther from it along the ground than
#: this fraction of the drop (the library's tripod: 0.40, random rear legs 0.05-0.42; tails
#: trailing down to the ground 0.6-1.1, an inchworm's arch 1.0).
SAGITTAL_LEG_LEAN = 0.5
#: A small body is off the plane when |y| exceeds this fraction of its bone (its distance
#: from its parent's joint) and it pairs with a mirror partner ...
LOCAL_SIDE_FRACTION = 0.15
#: ... found within this fraction of its bone of its reflection.
LOCAL_MIRROR_FRACTION = 0.3
#: A leg comes down to the ground: its lowest point lies at most this many times its drop
#: (from where it leaves the body) away sideways. Tentacles lying out flat are arms.
LEG_SPREAD_RATIO = 4.0
#: A side chain rising this much of its length above where it leaves the spine, and ending
#: above the sagittal head's joint, carries a head on a neck (a two-headed creature).
NECK_RISE_FRACTION = 0.5
#: A sagittal branch off the head with this many bodies is a trunk (an arm), not a jaw.
TRUNK_MIN_BODIES = 3
#: A side chain off the head reaching less than this fraction of the size is an ear or an
#: eye (a longer one is a limb: a crab's claws and legs hang off its carapace, the head).
EAR_MAX_FRACTION = 0.2
#: A leg comes down through its joints: its lowest joint (or bone end) lies at least this
#: fraction of the way from where it leaves the body down to the ground. A box's thickness
#: does not make a leg (a shark's pectoral fin, a finger lying flat). Library and random
#: 500-559 legs: 0.75 and up; the shark's fins 0.40, a flat hand's fingers 0.
LEG_DESCENT_FRACTION = 0.6
#: A free side chain whose far end lies behind its root by more than this fraction of its
#: reach, going out more than down, sweeps back: a fin or a wing, not an arm (arms reach
#: forward, out or down; library and random 500-559 arms: forward component 0.04 and up).
SWEEP_BACK_FRACTION = 0.2
#: A swept-back chain spanning at least this fraction of the size, and not angled down by
#: more than ``WING_MAX_DROOP`` of its reach, is a wing; a shorter or drooping one is a fin.
#: Library and random 500-559 wings: span 0.20-0.49, droop at most 0.02; the shark's
#: pectoral fins: span 0.12, droop 0.41.
WING_MIN_SPAN = 0.16
WING_MAX_DROOP = 0.2
#: This many free chains leaving one body and pointing within ``FAN_ANGLE`` degrees of
#: their mean direction are the fingers of a hand, not arms (an octopus's or a starfish's
#: arms radiate; a pair of arms points out to either side); another free chain off that
#: body reaching no farther than the longest finger is its thumb.
FAN_MIN_CHAINS = 4
FAN_ANGLE = 15.0


def _box_corners(centre, rot, half):
    from engine.io.gltf import quat_to_matrix

    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    out = np.zeros((len(centre), 8, 3))
    for i in range(len(centre)):
        r = quat_to_matrix(np.asarray(rot[i], float))
        out[i] = centre[i] + (signs * half[i]) @ r.T
    return out


def name_candidates(name: str) -> list[str]:
    """A joint name and the forms the name table is also tried on, most specific first:
    namespace removed, leading ``Xx_`` tokens removed one by one, a trailing ``_NN`` index
    removed; then trailing tokens removed one by one, so a part named before its segments
    (``wing0_l_seg2``, ``tail0_seg1``, ``upperarm_twist_01_l``) still says what it is. The
    last token wins over the first (``arm0_l_hand`` is a hand, not an arm)."""
    base = re.split(r"[:|]", name)[-1]
    out = [base]
    stem = re.sub(r"[_ .-]\d+$", "", base)
    for form in (base, stem):
        parts = form.split("_")
        for k in range(len(parts)):
            cand = "_".join(parts[k:])
            if cand and cand not in out:
                out.append(cand)
    parts = base.split("_")
    for k in range(len(parts) - 1, 0, -1):
        cand = "_".join(parts[:k])
        if cand and cand not in out:
            out.append(cand)
    return out


def name_caps(name: str, compiled) -> list[str] | None:
    for cand in name_candidates(name):
        for rx, caps in compiled:
            if rx.fullmatch(cand):
                return list(caps)
    return None


def _subtree(children, j):
    out, stack = [], [j]
    while stack:
        k = stack.pop()
        out.append(k)
        stack.extend(children[k])
    return out


def _tree_path(parent, a, b):
    """Bodies on the tree path from ``a`` to ``b`` (both included)."""
    up_a, j = [], a
    while j >= 0:
        up_a.append(int(j))
        j = parent[j]
    up_b, j = [], b
    seen = set(up_a)
    while j not in seen:
        up_b.append(int(j))
        j = parent[j]
    lca = int(j)
    return up_a[:up_a.index(lca) + 1] + up_b[::-1]


def _ancestors(parent, j):
    """The bodies above ``j``, nearest first."""
    out = []
    j = parent[j]
    while j >= 0:
        out.append(int(j))
        j = parent[j]
    return out


def _chain_start(parent, j, is_spine):
    """The first body of the side chain holding ``j`` (the child of a spine body)."""
    while parent[j] >= 0 and not is_spine[parent[j]]:
        j = parent[j]
    return int(j)


def find_caps(names, parent, joint_pos, centre, rot, half, caps_table=None, mode="shape", tip=None):
    """Capabilities (list per body) and a reason per body. Arrays in Menagerie axes, the
    creature grounded; ``parent`` parents-first with the root at 0; ``tip`` (n, 3) the end
    of each body's bone where the file says (NaN rows: the far end of its box)."""
    from engine.io.bvh_creature import _DEFAULT_COMPILED, _compile_table, caps_from_names

    parent = np.asarray(parent)
    n = len(names)
    if mode == "names":
        caps = caps_from_names(names, parent, caps_table)
        return caps, ["from the name table"] * n
    if mode != "shape":
        raise ValueError(f"caps mode must be 'shape' or 'names', got {mode!r}")
    user = _compile_table(caps_table, "caps_table") if caps_table else []
    named = [name_caps(nm, user + _DEFAULT_COMPILED) for nm in names]
    forced = [name_caps(nm, user) if user else None for nm in names]
    joint_pos = np.asarray(joint_pos, float)
    centre = np.asarray(centre, float)
    corners = _box_corners(centre, rot, np.asarray(half, float))
    size = float(np.max(np.ptp(corners.reshape(-1, 3), axis=0)))
    height = float(corners[..., 2].max() - corners[..., 2].min())
    ground = float(corners[..., 2].min())
    box_tip = 2.0 * centre - joint_pos  # the far end of each box along its bone
    if tip is None:
        tip = box_tip
    else:
        tip = np.where(np.isnan(np.asarray(tip, float)), box_tip, tip)
    children = [[] for _ in range(n)]
    for j in range(1, n):
        children[parent[j]].append(j)

    # 1. Sagittal bodies. A body is off the plane when its joint or box centre is, and a
    #    mirror partner (another body at its reflection across the plane) exists: a coiled
    #    snake's body is off the plane but has no partner.
    side_tol = SIDE_FRACTION * size
    mirror_tol = MIRROR_FRACTION * size
    y0 = joint_pos[0, 1]
    off = np.maximum(np.abs(joint_pos[:, 1] - y0), np.abs(centre[:, 1] - y0)) > side_tol
    mid = 0.5 * (joint_pos + centre)  # a body's place: between its joint and its box centre
    refl = mid.copy()
    refl[:, 1] = 2 * y0 - refl[:, 1]
    sided = np.zeros(n, bool)
    dy = mid[:, 1] - y0
    for j in range(n):
        if abs(dy[j]) <= 0.5 * side_tol:
            continue
        d = np.linalg.norm(mid - refl[j], axis=1)
        d[j] = np.inf
        d[(dy * dy[j] >= 0) | (np.abs(dy) <= 0.5 * side_tol)] = np.inf  # a partner lies on the other side
        k = int(np.argmin(d))
        sided[j] = bool(d[k] <= mirror_tol and (off[j] or off[k]))
    # Small paired bodies close to the plane (the eyes on a head, a spider's chelicerae) are
    # off it by less than the creature-wide tolerance: they are sided when they pair across
    # the plane at the scale of their own bone, and their parents are one body or a pair.
    bone = np.linalg.norm(mid - joint_pos[np.maximum(parent, 0)], axis=1)
    for j in range(1, n):
        if sided[j] or abs(dy[j]) <= LOCAL_SIDE_FRACTION * bone[j]:
            continue
        d = np.linalg.norm(mid - refl[j], axis=1)
        d[j] = np.inf
        d[dy * dy[j] >= 0] = np.inf
        k = int(np.argmin(d))
        pj, pk = parent[j], parent[k]
        same_parent = pj == pk or (pj > 0 and pk > 0 and sided[pj] and sided[pk])
        if d[k] <= LOCAL_MIRROR_FRACTION * max(bone[j], 1e-9) and same_parent:
            sided[j] = sided[k] = True
    # A chain lying wholly to one side of the plane, off a body that carries paired side
    # chains, is a side chain too, partner or not (a thumb beside the fingers, a third arm
    # beside two): not a candidate for the head.
    for p in range(n):
        if not any(sided[c] for c in children[p]):
            continue
        for c in children[p]:
            if sided[c]:
                continue
            sub = _subtree(children, c)
            if len(sub) >= ARM_MIN_BODIES and (np.all(dy[sub] > side_tol) or np.all(dy[sub] < -side_tol)):
                sided[c] = True
    # A link on the plane whose only child is sided belongs to that side chain (CMU's
    # LHipJoint: a zero-offset joint from the hips to the thigh).
    for j in range(n - 1, 0, -1):
        if not sided[j] and len(children[j]) == 1 and sided[children[j][0]]:
            sided[j] = True
    sag = np.zeros(n, bool)
    for j in range(n):
        sag[j] = j == 0 or (sag[parent[j]] and not sided[j])

    # 2. Head: the sagittal end lying highest and furthest forward.
    ends = [j for j in range(n) if sag[j] and not any(sag[c] for c in children[j])]
    root = joint_pos[0]

    def score(j):
        p = tip[j] if j != 0 else joint_pos[j]
        return 2.0 * (p[0] - root[0]) + (p[2] - root[2])

    # Forward counts twice: a scorpion's tail curls up over its back, its head is in front.
    # The root itself is a candidate (score 0) for when every sagittal end lies behind it.
    # A sagittal end on the ground is a foot (a tripod's front leg) unless every end is.
    raised = [j for j in ends if corners[j][:, 2].min() - corners[..., 2].min() > GROUND_FRACTION * height]
    head_end = max((raised or ends) + ([0] if 0 not in ends else []), key=score)
    path = []
    j = head_end
    while j >= 0:
        path.append(j)
        j = parent[j]
    path.reverse()
    # Small bodies at the end of the path (a jaw, a tongue) are not the head: trim them. A
    # run past the last body where the sagittal chain forks (a tongue beside a lower jaw) is
    # trimmed when it is small beside that body; then single small end bodies (a jaw).
    vol = np.prod(np.asarray(half, float), axis=1)
    trimmed = []
    forks = [i for i, b in enumerate(path[1:-1], 1) if sum(sag[c] for c in children[b]) >= 2]
    if forks:
        i = forks[-1]
        if vol[path[i + 1:]].sum() < HEAD_TRIM_RATIO * vol[path[i]] * len(path[i + 1:]):
            trimmed += path[i + 1:][::-1]
            path = path[:i + 1]
    # A small end body is trimmed only when nothing but trimmed bodies hangs off it: a head
    # carries its eyes, ears or jaw, a jaw carries nothing (or a trimmed tongue). The head may
    # then be the file's root (a crab's carapace with its mouth in front).
    while (len(path) >= 2 and all(c in trimmed for c in children[path[-1]])
           and vol[path[-1]] < HEAD_TRIM_RATIO * vol[path[-2]]):
        trimmed.append(path.pop())
    head = path[-1]
    # The spine runs from the head to the farthest body that carries a side chain (the hips
    # of a quadruped whose file root is its chest), then on up a serial chain to the root.
    reach = np.zeros(n)  # furthest tip distance below each body, from its joint
    for k in range(n - 1, -1, -1):
        reach[k] = max([float(np.linalg.norm(tip[k] - joint_pos[k]))]
                       + [reach[c] + float(np.linalg.norm(joint_pos[c] - joint_pos[k])) for c in children[k]])

    def main_path(j, on_plane=False):
        """From ``j`` on, the child reaching furthest at each body (only sagittal children
        with ``on_plane``: a side leg off a sagittal chain is no part of it)."""
        out = [j]
        while True:
            k = out[-1]
            kids = [c for c in children[k] if sag[c]] if on_plane else children[k]
            if not kids:
                return out
            out.append(max(kids, key=lambda c: reach[c] + float(np.linalg.norm(joint_pos[c] - joint_pos[k]))))

    ground_h = GROUND_FRACTION * height

    def lowest_of(c):
        return float(corners[_subtree(children, c)][..., 2].min()) - ground

    def is_leg(c):
        """A side chain reaching the ground that hangs down to it rather than lying along it
        (an octopus's arms spread out over the ground; legs come down to it)."""
        bodies = _subtree(children, c)
        low = lowest_of(c)
        if low > ground_h or len(main_path(c)) < 2:  # a fin or a spike lying low is no leg
            return False
        flat = corners[bodies].reshape(-1, 3)
        foot = flat[int(np.argmin(flat[:, 2]))]
        drop = joint_pos[c, 2] - foot[2]
        spread = float(np.hypot(*(foot[:2] - joint_pos[c, :2])))
        return drop > 0 and spread <= LEG_SPREAD_RATIO * drop and descends(c)

    def descends(c):
        """The chain from ``c`` comes down through its joints (and bone ends) most of the way
        to the ground, not only through the thickness of a box near it."""
        bodies = _subtree(children, c)
        low = float(min(joint_pos[bodies, 2].min(), tip[bodies, 2].min()))
        start = joint_pos[c, 2] - ground
        return start > 0 and joint_pos[c, 2] - low >= LEG_DESCENT_FRACTION * start

    def limb_like(c):
        """A side chain that is a leg or an arm, not a spike or a fin stub."""
        return is_leg(c) or len(main_path(c)) >= ARM_MIN_BODIES

    steep = float(np.sqrt(0.5))  # sine of 45 degrees

    def leg_split(c):
        """Where the main path from ``c`` turns down into a leg: the index of the leg's
        first body (0: the chain from ``c`` is the leg), or -1 when it is no leg. The split
        is the one that best parts bones lying along the body (falling less than 45
        degrees) from bones coming down (steeper), by bone length; the foot's own bone is
        not counted (a foot lies along the ground)."""
        mp = main_path(c, on_plane=True)
        start = joint_pos[c, 2] - ground
        if start <= 0 or len(mp) < 2:
            return -1
        fi = next((i for i, b in enumerate(mp) if joint_pos[b, 2] - ground < FOOT_FRACTION * start), len(mp) - 1)
        if fi < 1:
            return -1
        bones = np.diff(joint_pos[mp[:fi + 1]], axis=0)
        length = np.linalg.norm(bones, axis=1)
        fall = -bones[:, 2] / np.maximum(length, 1e-12)
        along = length * np.maximum(0.0, fall - steep)   # cost of a steep bone left in the spine part
        down = length * np.maximum(0.0, steep - fall)    # cost of a shallow bone put in the leg
        cost = [float(along[:k].sum() + down[k:].sum()) for k in range(fi)]
        k = int(np.argmin(cost))
        r = mp[k]
        d = joint_pos[mp[fi]] - joint_pos[r]
        if (joint_pos[r, 2] - ground < SAGITTAL_LEG_ROOT_FRACTION * (joint_pos[0, 2] - ground)
                or float(np.hypot(d[0], d[1])) > SAGITTAL_LEG_LEAN * -d[2] or fall[k:].min() <= 0.0
                or not is_leg(r) or any("tail" in (named[b] or []) for b in mp[k:])):
            return -1  # a tail hanging to the ground (by its shape, or by its name)
        return k

    def sagittal_leg(c):
        """``c`` (sagittal, off a sagittal body) is the first body of a leg on the plane."""
        return sag[c] and parent[c] >= 0 and sag[parent[c]] and leg_split(c) == 0

    # When the head is the file's root (a crab's carapace), the bodies below it are the
    # rest of the creature, not parts of the head.
    below_head = (set(_subtree(children, head)) if head != 0 else {head}) | set(trimmed)
    attach = [j for j in range(n) if sag[j] and j not in below_head
              and any((not sag[c] and limb_like(c)) or sagittal_leg(c) for c in children[j])]
    if attach:
        far = max(attach, key=lambda a: (len(_tree_path(parent, head, a)), -a))
        path = _tree_path(parent, far, head)
        while parent[path[0]] >= 0 and parent[path[0]] not in path and sag[parent[path[0]]]:
            path.insert(0, int(parent[path[0]]))
    is_spine = np.zeros(n, bool)
    is_spine[path] = True
    caps: list[list[str] | None] = [None] * n
    reasons = [""] * n
    for j in path:
        caps[j] = ["spine"]
        reasons[j] = "spine: on the path from the root to the head"
    caps[head] = ["spine", "head"]
    reasons[head] = "head: the sagittal end lying highest and furthest forward"

    for j in trimmed:
        caps[j] = ["detail"]
        reasons[j] = f"detail: a small body past the head {names[head]}"
    # The trimmed body hanging lowest off the head is its jaw (or beak, or mouth), unless a
    # name says which one is.
    off_head = [j for j in trimmed if parent[j] == head]
    mouths: set[int] = set()  # heads that have a mouth of their own
    guessed_jaw = None  # a jaw found by shape alone gives way to a mouth branch or a name

    def unguess(why):
        nonlocal guessed_jaw
        if guessed_jaw is not None and caps[guessed_jaw] == ["mouth"]:
            caps[guessed_jaw] = ["detail"]
            reasons[guessed_jaw] = f"detail: a small body past the head {names[head]} ({why})"
        guessed_jaw = None

    if off_head:
        by_name = [j for j in off_head if "mouth" in (named[j] or [])]
        jaw = by_name[0] if by_name else min(off_head, key=lambda j: tip[j][2])
        caps[jaw] = ["mouth"]
        reasons[jaw] = f"mouth: the small body hanging lowest off the head {names[head]}"
        mouths.add(head)
        guessed_jaw = None if by_name else jaw

    def subtree(j):
        out, stack = [], [j]
        while stack:
            k = stack.pop()
            out.append(k)
            stack.extend(children[k])
        return sorted(out)

    def mark(bodies, cap, why):
        for b in bodies:
            if caps[b] is None:
                caps[b] = list(cap)
                reasons[b] = why

    def mark_leg(c, s):
        """A leg from ``c``: limb bodies down to its foot; a branch before the foot that
        reaches the ground too is another leg sharing the bodies above it (a forked leg)."""
        mp = main_path(c)
        start_z = joint_pos[c, 2] - ground
        foot = next((b for b in mp if joint_pos[b, 2] - ground < FOOT_FRACTION * start_z), mp[-1])
        k = mp.index(foot)
        mark(mp[:k], ["limb"], f"leg: a side chain off {names[s]} reaching the ground")
        mark([foot], ["limb", "foot"], f"foot: the leg's first body near the ground (chain from {names[c]})")
        for b in mp[:k]:
            for d in children[b]:
                if (d not in mp and caps[d] is None and lowest_of(d) <= ground_h and len(main_path(d)) >= 2
                        and descends(d)):
                    mark_leg(d, s)
        mark(_subtree(children, c), ["detail"], f"detail: past the foot or off the leg's main path ({names[c]})")

    def face_of(mp):
        """The first body on a main path carrying two or more small leaf bodies and nothing
        else (eyes, a jaw: a face; a hand's fingers are chains), or None."""
        for b in mp[1:]:
            kids = children[b]
            if len(kids) >= 2 and all(not children[d] and vol[d] < HEAD_TRIM_RATIO * vol[b] for d in kids):
                return b
        return None

    def neck_head(c):
        """The head at the end of a rising side chain (a neck), or None. A chain that does
        not go down and ends in a face is a neck too, rising or not."""
        mp = main_path(c)
        if len(mp) < 2:
            return None
        length = sum(float(np.linalg.norm(joint_pos[mp[i + 1]] - joint_pos[mp[i]])) for i in range(len(mp) - 1))
        length += float(np.linalg.norm(tip[mp[-1]] - joint_pos[mp[-1]]))
        rise = tip[mp[-1], 2] - joint_pos[c, 2]
        if tip[mp[-1], 2] <= joint_pos[head, 2]:
            return None
        if rise < NECK_RISE_FRACTION * length:
            return face_of(mp) if rise >= 0 else None
        h = next((b for b in mp[1:] if len(children[b]) >= 2), mp[-1])
        if {"eye", "ear"} & set(named[h] or []):  # an eye on a stalk is not a head
            return None
        return h

    def mark_head_parts(h, why):
        """Caps of a head's children: its jaw (named, else the lowest), eyes and ears by name."""
        kids = [d for d in children[h] if caps[d] is None]
        if kids:
            by_name = [d for d in kids if "mouth" in (named[d] or [])]
            jaw = by_name[0] if by_name else min(kids, key=lambda d: tip[d][2])
            mark([jaw], ["mouth"], f"mouth: the body hanging lowest off the head {names[h]}")
            mouths.add(h)
        mark(_subtree(children, h), ["detail"], why)

    def rising(c, s):
        """The chain from ``c`` rises off ``s`` more than it goes back (a dorsal fin)."""
        d = tip[main_path(c)[-1]] - joint_pos[s]
        return d[2] > -d[0]

    def sweep(c):
        """(span, droop) of a side chain whose far end lies behind its root, going out more
        than down, and that does not come down to the ground (a fin or a wing; an octopus's
        hind arms come down to the ground and lie out behind it), else None."""
        d = tip[main_path(c)[-1]] - joint_pos[c]
        span = float(np.linalg.norm(d))
        if span <= 0 or d[0] >= -SWEEP_BACK_FRACTION * span or abs(d[1]) <= -d[2] or descends(c):
            return None
        return span, max(0.0, -float(d[2]) / span)

    fans: dict[int, set] = {}

    def fan(s):
        """The free side chains off ``s`` that point the same way, when there are
        ``FAN_MIN_CHAINS`` or more of them (the digits of a hand), else an empty set."""
        if s not in fans:
            dirs = {}
            for c in children[s]:
                if sag[c] or is_spine[c] or is_leg(c) or len(main_path(c)) < ARM_MIN_BODIES:
                    continue
                d = tip[main_path(c)[-1]] - joint_pos[c]
                if np.linalg.norm(d) > 0:
                    dirs[c] = d / np.linalg.norm(d)
            cos_max = np.cos(np.radians(FAN_ANGLE))
            while len(dirs) >= FAN_MIN_CHAINS:
                mean = np.mean(list(dirs.values()), axis=0)
                mean /= max(float(np.linalg.norm(mean)), 1e-12)
                worst = min(dirs, key=lambda k: float(dirs[k] @ mean))
                if float(dirs[worst] @ mean) >= cos_max:
                    break
                del dirs[worst]
            fingers = set(dirs) if len(dirs) >= FAN_MIN_CHAINS else set()
            if fingers:
                longest = max(reach[c] for c in fingers)
                fingers |= {c for c in children[s] if not sag[c] and not is_spine[c] and c not in fingers
                            and not is_leg(c) and reach[c] <= longest}
            fans[s] = fingers
        return fans[s]

    # 3. Sagittal branches off the spine; 4. side chains.
    ear_reach = EAR_MAX_FRACTION * size
    side_heads = []
    for s in path:
        for c in children[s]:
            if is_spine[c]:
                continue
            bodies = subtree(c)
            mp = main_path(c)
            nm = names[c]
            leg = is_leg(c)
            drop = joint_pos[c] - tip[mp[-1]]
            downward = drop[2] > abs(drop[0])
            back = tip[mp[-1], 0] < joint_pos[s, 0] - 0.02 * size
            # A branch lying wholly to one side with no mirror partner (a third arm) is a side
            # chain all the same; a coiled snake has no such branch, its body is the spine.
            lone = sag[c] and len(mp) >= ARM_MIN_BODIES and (np.all(dy[bodies] > side_tol)
                                                           or np.all(dy[bodies] < -side_tol))
            if sag[c] and not lone and not (s != head and leg and downward
                                            and not (back and len(mp) >= TAIL_MIN_BODIES)) \
                    and not (s != head and sagittal_leg(c)):
                if s == head and len(mp) >= TRUNK_MIN_BODIES and reach[c] >= ear_reach:
                    mark(mp[:-1], ["limb"], f"trunk: a sagittal chain of {len(mp)} bodies off the head {names[head]}")
                    mark([mp[-1]], ["limb", "grasper"], "grasper: the trunk's last body")
                    mark(bodies, ["detail"], f"detail: off the trunk's main path ({nm})")
                elif s == head:
                    unguess(f"the mouth is the branch {nm}")
                    mark([c], ["mouth"], f"mouth: a sagittal branch off the head {names[head]}")
                    mark(bodies, ["detail"], f"detail: below the mouth {nm}")
                    mouths.add(head)
                elif back and len(mp) >= TAIL_MIN_BODIES and s != path[0] and rising(c, s):
                    mark(bodies, ["detail"], f"detail: a crest or fin rising off {names[s]}, the middle of "
                                             f"the back (a tail leaves the rear end of the spine)")
                elif back and len(mp) >= TAIL_MIN_BODIES:
                    mark(bodies, ["tail"], f"tail: a sagittal chain of {len(mp)} bodies going backward off "
                                           f"{names[s]}")
                else:
                    mark(bodies, ["detail"], f"detail: a short sagittal branch off {names[s]}")
                continue
            wing = any("wing" in (named[b] or []) for b in mp)
            # A chain named as a wing, or sweeping back, is no neck: heads look forward.
            h = None if leg or wing or sweep(c) is not None else neck_head(c)
            if s == head and (reach[c] < ear_reach or not leg and h is None and len(mp) < ARM_MIN_BODIES):
                hint = named[c] or []
                cap = "eye" if "eye" in hint else "ear"
                mark([c], [cap], f"{cap}: a short side chain off the head")
                mark(bodies, ["detail"], f"detail: below {nm}")
                continue
            if h is not None and reach[c] >= ear_reach:
                k = mp.index(h)
                mark(mp[:k], ["limb"], f"neck: a side chain rising off {names[s]} to a head")
                mark([h], ["head"], f"head: at the top of the neck from {names[s]}")
                mark_head_parts(h, f"detail: part of the head {names[h]}")
                side_heads.append(h)
                continue
            if leg and not wing:
                mark_leg(c, s)
            elif wing:
                mark(mp, ["limb", "wing"], f"wing: a free side chain off {names[s]} named as a wing")
                mark(bodies, ["detail"], "detail: off the wing's main path")
            elif len(mp) < ARM_MIN_BODIES:
                hint = named[c] or []
                cap = "spike" if "spike" in hint else "detail"
                mark(bodies, [cap], f"{cap}: a short free side chain off {names[s]} (an arm has "
                                    f"{ARM_MIN_BODIES} or more bodies)")
            elif {"eye", "ear"} & set(named[mp[-1]] or []):
                hint = named[mp[-1]]
                cap = "eye" if "eye" in hint else "ear"
                mark([mp[-1]], [cap], f"{cap}: on a stalk off {names[s]} (by its name)")
                mark(bodies, ["detail"], f"detail: the stalk of {names[mp[-1]]}")
            elif c in fan(s):
                mark(mp, ["limb"], f"digit: one of {len(fan(s))} free chains off {names[s]}, fingers pointing "
                                   f"the same way and a thumb (a hand's digits, not arms)")
                mark(bodies, ["detail"], f"detail: off the digit's main path ({nm})")
            elif sweep(c) is not None:
                span, droop = sweep(c)
                if span >= WING_MIN_SPAN * size and droop <= WING_MAX_DROOP:
                    mark(mp, ["limb", "wing"], f"wing: a side chain off {names[s]} sweeping back, spanning "
                                               f"{span / size:.2f} of the size, level or raised")
                    # A branch off the wing's leading bones is its claw (a bat's thumb).
                    for b in mp[:-1]:
                        for d in children[b]:
                            if (d not in mp and caps[d] is None and len(main_path(d)) <= ARM_MIN_BODIES
                                    and sweep(d) is None):
                                mark(_subtree(children, d)[:1], ["limb", "grasper"],
                                     f"grasper: a claw off the wing {names[c]}")
                    mark(bodies, ["detail"], "detail: off the wing's main path")
                else:
                    mark(mp, ["limb"], f"fin: a side chain off {names[s]} sweeping back, spanning "
                                       f"{span / size:.2f} of the size, angled down {droop:.2f}")
                    mark(bodies, ["detail"], f"detail: off the fin's main path ({nm})")
            else:
                grasp = next((b for b in mp if len(children[b]) >= 2), mp[-1])
                k = mp.index(grasp)
                mark(mp[:k], ["limb"], f"arm: a side chain off {names[s]} ending free")
                mark([grasp], ["limb", "grasper"], "grasper: where the arm branches into fingers"
                     if len(children[grasp]) >= 2 else "grasper: the arm's last body")
                mark(bodies, ["detail"], f"detail: past the grasper or off the arm's main path ({nm})")
    # The front end of the spine is a head when it lies past the limbs (a neck or a front
    # end) or carries a face (a jaw, eyes, ears, a trunk): a palm carrying only its fingers,
    # a front body carrying only legs and arms, is no head.
    limbs_off = [d for d in children[head] if not is_spine[d] and not sag[d] and "limb" in (caps[d] or [])]
    face = trimmed or [d for d in children[head] if not is_spine[d] and caps[d] is not None
                       and (sag[d] or {"ear", "eye", "mouth"} & set(caps[d]))]
    if limbs_off and not face and not side_heads:
        caps[head] = ["spine"]
        reasons[head] = ("spine: the front end, not a head: it carries the limbs "
                         + ", ".join(names[d] for d in limbs_off) + " and no face")
    # Heads on necks that hang off the sagittal head: that body is the shoulders they share
    # (a two-headed creature's chest), not a head itself.
    if any(parent[_chain_start(parent, h, is_spine)] == head for h in side_heads):
        caps[head] = ["spine"]
        reasons[head] = "spine: carries the necks of the heads " + ", ".join(names[h] for h in side_heads)
        for d in children[head]:
            if caps[d] == ["mouth"]:
                caps[d] = ["detail"]
                reasons[d] += "; not a mouth: its body carries heads"
        mouths.discard(head)
    heads = [j for j in range(n) if "head" in caps[j]]
    for j in range(n):  # anything still unmarked hangs below detail bodies handled above
        if caps[j] is None:
            caps[j] = ["detail"]
            reasons[j] = "detail"

    # A user's caps table has the last word on the names it matches.
    for j in range(n):
        if forced[j] is not None:
            caps[j] = list(forced[j])
            reasons[j] = "from the user's caps table"

    # 5. Names as a hint, off the spine.
    for j in range(n):
        if is_spine[j] or not named[j] or forced[j] is not None:
            continue
        for cap in ("eye", "ear", "mouth", "tail"):
            if cap in named[j] and cap not in caps[j]:
                caps[j] = [c for c in caps[j] if c != "detail"] + [cap]
                reasons[j] += f"; '{cap}' from its name"
                if cap == "mouth":
                    unguess(f"{names[j]} is the mouth by its name")
                    h = next((a for a in _ancestors(parent, j) if "head" in caps[a]), None)
                    if h is not None:
                        mouths.add(h)
    for h in heads:
        if h not in mouths:
            caps[h].append("mouth")
            reasons[h] += "; stands in for a mouth (none of its own)"
    return [list(c) for c in caps], reasons
