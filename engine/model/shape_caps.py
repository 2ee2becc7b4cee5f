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
   ``MIRROR_FRACTION`` x size): a coiled snake's body is off the plane but has none. A
   link whose only child is sided is sided too. Sided bodies hang off as *side chains*.
2. **Head and spine**: among the ends of sagittal chains, the head is the one that lies
   highest and furthest forward (largest x + z relative to the root, by the far end of its
   box); small bodies past it (a jaw, a tongue: under ``HEAD_TRIM_RATIO`` of the body
   before) are trimmed off. The spine runs from the head back to the farthest sagittal body
   that carries a side chain (a quadruped's hips when the file's root is its chest; the
   root when nothing does), then on up to the file's root.
3. **Sagittal branches** off the spine: one whose end lies behind where it leaves the
   spine and that has ``TAIL_MIN_BODIES`` or more bodies is a tail; one off the head is
   the mouth (its first body; the rest are detail); any other is detail.
4. **Side chains** (a sided child of a sagittal body and everything below it). The
   *main path* follows, at each body, the child whose subtree reaches furthest. A chain off
   the head is an ear (or eye, if its name says so). A chain whose lowest box corner is
   within ``GROUND_FRACTION`` x height of the ground is a **leg**: its foot is the first
   body on the main path whose joint lies below ``FOOT_FRACTION`` x the chain's start
   height (else the last body), later bodies are detail. Any other chain is an **arm**:
   its grasper is the first body on the main path where it branches in two or more (a
   hand with fingers), else its last body; later bodies and side branches are detail. A
   free chain shorter than ``ARM_MIN_BODIES`` is a spike (by name) or detail.
5. **Names as a hint**: a name the table maps to ``wing`` turns an arm into a wing (no
   grasper); ``eye``/``ear``/``mouth``/``tail`` names add that capability to a body off
   the spine. Names are matched as in the BVH importer, also with leading ``Xx_`` tokens
   (``CC_Base_``, ``b_``) and a trailing ``_NN`` index removed.

If the head would have no mouth of its own, the head stands in for it (as for BVH).
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


def _box_corners(centre, rot, half):
    from engine.io.gltf import quat_to_matrix

    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    out = np.zeros((len(centre), 8, 3))
    for i in range(len(centre)):
        r = quat_to_matrix(np.asarray(rot[i], float))
        out[i] = centre[i] + (signs * half[i]) @ r.T
    return out


def name_candidates(name: str) -> list[str]:
    """A joint name and the forms the name table is also tried on: namespace removed,
    leading ``Xx_`` tokens removed one by one, a trailing ``_NN`` index removed."""
    base = re.split(r"[:|]", name)[-1]
    out = [base]
    stem = re.sub(r"[_ .-]\d+$", "", base)
    for form in (base, stem):
        parts = form.split("_")
        for k in range(len(parts)):
            cand = "_".join(parts[k:])
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
        return (p[0] - root[0]) + (p[2] - root[2])

    head_end = max(ends, key=score)
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
    while len(path) > 2 and vol[path[-1]] < HEAD_TRIM_RATIO * vol[path[-2]]:
        trimmed.append(path.pop())
    head = path[-1]
    # The spine runs from the head to the farthest body that carries a side chain (the hips
    # of a quadruped whose file root is its chest), then on up a serial chain to the root.
    below_head = set(_subtree(children, head)) | set(trimmed)
    attach = [j for j in range(n) if sag[j] and j not in below_head and any(not sag[c] for c in children[j])]
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

    def subtree(j):
        out, stack = [], [j]
        while stack:
            k = stack.pop()
            out.append(k)
            stack.extend(children[k])
        return sorted(out)

    reach = np.zeros(n)  # furthest tip distance below each body, from its joint
    for k in range(n - 1, -1, -1):
        reach[k] = max([float(np.linalg.norm(tip[k] - joint_pos[k]))]
                       + [reach[c] + float(np.linalg.norm(joint_pos[c] - joint_pos[k])) for c in children[k]])

    def main_path(j):
        out = [j]
        while children[out[-1]]:
            k = out[-1]
            out.append(max(children[k],
                           key=lambda c: reach[c] + float(np.linalg.norm(joint_pos[c] - joint_pos[k]))))
        return out

    def mark(bodies, cap, why):
        for b in bodies:
            if caps[b] is None:
                caps[b] = list(cap)
                reasons[b] = why

    # 3. Sagittal branches off the spine; 4. side chains.
    mouth_found = False
    for s in path:
        for c in children[s]:
            if is_spine[c]:
                continue
            bodies = subtree(c)
            mp = main_path(c)
            nm = names[c]
            lowest = float(corners[bodies][..., 2].min()) - ground
            drop = joint_pos[c] - tip[mp[-1]]
            downward = drop[2] > abs(drop[0])
            back = tip[mp[-1], 0] < joint_pos[s, 0] - 0.02 * size
            if sag[c] and not (s != head and lowest <= GROUND_FRACTION * height and downward
                               and not (back and len(mp) >= TAIL_MIN_BODIES)):
                if s == head:
                    mark([c], ["mouth"], f"mouth: a sagittal branch off the head {names[head]}")
                    mark(bodies, ["detail"], f"detail: below the mouth {nm}")
                    mouth_found = True
                elif back and len(mp) >= TAIL_MIN_BODIES:
                    mark(bodies, ["tail"], f"tail: a sagittal chain of {len(mp)} bodies going backward off "
                                           f"{names[s]}")
                else:
                    mark(bodies, ["detail"], f"detail: a short sagittal branch off {names[s]}")
                continue
            if s == head and not sag[c]:
                hint = named[c] or []
                cap = "eye" if "eye" in hint else "ear"
                mark([c], [cap], f"{cap}: a side chain off the head")
                mark(bodies, ["detail"], f"detail: below {nm}")
                continue
            wing = any("wing" in (named[b] or []) for b in mp)
            if lowest <= GROUND_FRACTION * height and not wing:
                start_z = joint_pos[c, 2] - ground
                foot = next((b for b in mp if joint_pos[b, 2] - ground < FOOT_FRACTION * start_z), mp[-1])
                k = mp.index(foot)
                mark(mp[:k], ["limb"], f"leg: a side chain off {names[s]} reaching the ground")
                mark([foot], ["limb", "foot"], f"foot: the leg's first body near the ground (chain from {nm})")
                mark(bodies, ["detail"], f"detail: past the foot or off the leg's main path ({nm})")
            elif wing:
                mark(mp, ["limb", "wing"], f"wing: a free side chain off {names[s]} named as a wing")
                mark(bodies, ["detail"], "detail: off the wing's main path")
            elif len(mp) < ARM_MIN_BODIES:
                hint = named[c] or []
                cap = "spike" if "spike" in hint else "detail"
                mark(bodies, [cap], f"{cap}: a short free side chain off {names[s]} (an arm has "
                                    f"{ARM_MIN_BODIES} or more bodies)")
            else:
                grasp = next((b for b in mp if len(children[b]) >= 2), mp[-1])
                k = mp.index(grasp)
                mark(mp[:k], ["limb"], f"arm: a side chain off {names[s]} ending free")
                mark([grasp], ["limb", "grasper"], "grasper: where the arm branches into fingers"
                     if len(children[grasp]) >= 2 else "grasper: the arm's last body")
                mark(bodies, ["detail"], f"detail: past the grasper or off the arm's main path ({nm})")
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
                mouth_found |= cap == "mouth"
    if not mouth_found:
        caps[head].append("mouth")
        reasons[head] += "; stands in for a mouth (none of its own)"
    return [list(c) for c in caps], reasons
