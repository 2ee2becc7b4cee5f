"""Writes the generalized reaction clips of animations/reactions/ (the staggers, brace, falls, lying and
getting up of the impact response): run from the repository root, `python animations/reactions/_generate.py`."""
import os

# ruff: noqa: E501, E731, UP031  (a data generator: long key lists read better on one line)


def key(t, v=None, aa=None, flat=False):
    t = round(t, 4)
    if flat:       # zero tangents: a held foot stays planted right up to its step
        return "        - {t: %s, v: [%s], tin: [0, 0, 0], tout: [0, 0, 0]}" % (t, ", ".join(str(x) for x in v))
    if aa is not None:
        return "        - {t: %s, aa: [%s]}" % (t, ", ".join(str(x) for x in aa))
    return "        - {t: %s, v: [%s]}" % (t, ", ".join(str(x) for x in v))

def channel(name, select, pos=None, rot=None, posspec="{mode: rest, scale: creature_size}",
            rotspec="{mode: rest}", priority=None, extra="", flat=None, mirror=True):
    """mirror=False: the keys are directions in character space for every selected body (a
    step toward the push); by default right-side bodies specialize mirrored (their y keys
    point outward, as the left side's do), which sent the right feet of a stagger to the
    left away from the push and crossed the feet of a fall to the side."""
    out = [f"  - name: {name}", f"    select: {select}"]
    if not mirror:
        out.append("    mirror: false")
    if pos is not None:
        out.append(f"    position: {posspec}")
    if rot is not None:
        out.append(f"    rotation: {rotspec}")
    if priority is not None:
        out.append(f"    priority: {priority}")
    out.append("    keys:")
    if pos is not None:
        out.append("      position:")
        out += [key(t, v=v, flat=flat if flat is not None else posspec == FOOTSPEC) for t, v in pos]
    if rot is not None:
        out.append("      rotation:")
        out += [key(t, aa=a) for t, a in rot]
    return "\n".join(out)

def clip(name, desc, length, chans, loop=False, branches=None, follows=None):
    """``follows``: the clip this one continues (the impact response plays it after that one;
    the validation grid plays that one first, never this one from the rest pose)."""
    head = [ "format: 1", f"name: {name}", f'description: "{desc}"', f"length: {length}"]
    if loop:
        head.append("loop: true")
    if follows:
        head.append(f"follows: {follows}")
    if branches:
        head.append("branches: {" + ", ".join(f"{k}: {str(v).lower()}" for k, v in branches.items()) + "}")
    head.append("channels:")
    return "\n".join(head) + "\n" + "\n".join(chans) + "\n"

ROOT = "{type: root}"
FEET = "{type: foot}"
LEFT = "{type: foot, y: left, y_space: setspace}"
RIGHT = "{type: foot, y: right, y_space: setspace}"
FRONT = "{type: foot, x: front, y_space: setspace}"
GRASP = "{type: grasper}"
SPINE = "{type: spine}"
FOOTSPEC = "{mode: rest, scale: limb_length}"
FOOTSPEC_LOW = "{mode: rest, scale: limb_length, sagittal: true}"   # y: share of the way to the midline
LOW_TUCK = 0.12
SIZESPEC = "{mode: rest, scale: creature_size}"
LIFT = 0.12     # step height, limb lengths

# direction -> (unit ground vector (x, y), lean axis (x, y, z) for 'top goes along the push')
DIRS = {
    "back": ((-1, 0), (0, 1, 0), -1),    # pushed from the front: moves -x, leans back (-deg about +Y)
    "front": ((1, 0), (0, 1, 0), 1),
    "left": ((0, 1), (1, 0, 0), -1),     # moves +y: the top tips to +y (-deg about +X)
    "right": ((0, -1), (1, 0, 0), 1),
}

def r(x):
    return round(x, 4)

def stagger(d, low=False):
    """Ends displaced: the root and every foot by the same ``root_step`` creature sizes, the
    rest pose moved, so the impact response can move the character's placement by it at the
    end (clips have no root motion) and what played before goes on from there. ``low`` (for
    creatures whose spine is not upright): no lean, since a horizontal body turned about its
    root puts its far end into the ground (the snake's tail 3.4 heights under it, the
    centipede's 1.2, from 14 + 20 degrees of lean)."""
    (ux, uy), ax, sg = DIRS[d]
    k = 0.0 if low else 1.0
    lean = lambda deg: [ax[0], ax[1], ax[2], r(sg * deg * k)]
    root_step = 0.2      # creature sizes: more and a long creature's feet cannot follow its root
    T = 1.1
    end = [r(ux * root_step), r(uy * root_step), 0]
    # the leading feet: the side the push goes to (left/right), else the left ones first
    first, second = (LEFT, RIGHT) if d != "right" else (RIGHT, LEFT)
    def foot(t0, over):
        # lift, travel, set down: a foot moves across the ground only while it is up
        x, y = ux * root_step * over, uy * root_step * over
        mx, my = ux * root_step * (1 + over) / 2, uy * root_step * (1 + over) / 2
        return [(0.0, [0, 0, 0]), (t0, [0, 0, 0]), (t0 + 0.05, [0, 0, 0.04]),
                (t0 + 0.13, [r(x * 0.5), r(y * 0.5), 0.06]), (t0 + 0.21, [r(x), r(y), 0.03]), (t0 + 0.26, [r(x), r(y), 0]),
                (0.72, [r(x), r(y), 0]), (0.76, [r(x), r(y), 0.03]), (0.84, [r(mx), r(my), 0.04]),
                (0.91, [end[0], end[1], 0.02]), (0.96, end), (T, end)]
    root_pos = [(0.0, [0, 0, 0]), (0.25, [r(ux * root_step * 0.6), r(uy * root_step * 0.6), -0.04]),
                (0.55, [r(ux * root_step * 0.95), r(uy * root_step * 0.95), -0.03]), (0.9, [end[0], end[1], -0.01]),
                (T, end)]
    chans = [
        channel("root", ROOT, priority=1, pos=root_pos,
                rot=[(0.0, lean(0)), (0.18, lean(14)), (0.5, lean(6)), (0.9, lean(1)), (T, lean(0))]),
        # rest mode is character space: the spine's keys carry the root's lean
        channel("spine", SPINE,
                rot=[(0.0, lean(0)), (0.12, lean(20)), (0.45, lean(4)), (0.9, lean(1)), (T, lean(0))]),
        channel("lead_feet", first, pos=foot(0.05, 1.25), rot=None, posspec=SIZESPEC, flat=True, mirror=False),
        channel("other_feet", second, pos=foot(0.3, 0.8), rot=None, posspec=SIZESPEC, flat=True, mirror=False),
        # the graspers come up and out for balance: back against the push along x, and
        # outward (mirrored keys: +y is outward on both sides) for a push to the side
        channel("arms", GRASP, posspec="{mode: rest, scale: limb_length}",
                pos=[(0.0, [0, 0, 0]), (0.2, [r(-ux * 0.15), r(abs(uy) * 0.15), 0.25]),
                     (0.6, [r(-ux * 0.05), r(abs(uy) * 0.05), 0.1]), (T, [0, 0, 0])]),
    ]
    how = "the body shifts (no lean: a horizontal body)" if low else "the body leans"
    return clip(f"stagger_{d}{'_low' if low else ''}", f"Stagger {d}: pushed toward the {d}, {how} and the feet "
                f"step that way (leading feet past, the others short, then together) and it ends {root_step} "
                f"creature sizes over, in the rest pose (root and feet in creature sizes).", T, chans,
                branches=branches(low))

def brace(low=False):
    bend = 0 if low else 12      # degrees forward; a horizontal body would put its tail in the ground
    chans = [
        channel("root", ROOT, priority=1, posspec="{mode: rest, ground: true}",
                pos=[(0.0, [0, 0, 0]), (0.25, [0, 0, 0.22]), (0.8, [0, 0, 0.22]), (1.3, [0, 0, 0])]),
        channel("spine", SPINE, rot=[(0.0, [0, 1, 0, 0]), (0.25, [0, 1, 0, bend]), (0.8, [0, 1, 0, bend]),
                                     (1.3, [0, 1, 0, 0])]),
        # every foot steps outward: the channel mirrors, so +y is outward on both sides
        # (a right-feet channel keyed -y stepped the right feet inward, across the midline)
        channel("feet", FEET, posspec=FOOTSPEC,
                pos=[(0.0, [0, 0, 0]), (0.1, [0, 0.07, LIFT]), (0.22, [0, 0.14, 0]), (0.9, [0, 0.14, 0]),
                     (1.05, [0, 0.07, LIFT * 0.6]), (1.2, [0, 0, 0]), (1.3, [0, 0, 0])]),
        channel("arms", GRASP, posspec="{mode: rest, scale: limb_length}",
                pos=[(0.0, [0, 0, 0]), (0.2, [0.35, 0, 0.45]), (0.8, [0.35, 0, 0.45]), (1.3, [0, 0, 0])]),
    ]
    return clip("brace_low" if low else "brace", "Brace: the body drops a fifth of the way to the ground, the feet "
                "step apart, " + ("" if low else "the trunk bends forward ") + "and the graspers come up in front "
                "(ground-relative root).", 1.3, chans, branches=branches(low))

FALL_T = 0.9
# the lying pose: upright creatures topple (turned LIE deg, the feet slide away from the fall
# so the legs lie straight); horizontal ones (upright_spine false) collapse, tilted LOW deg
# ("pitch": the tilt of a fall to the front or back; a long horizontal body pitched 25 degrees
# put an end more than its height into the ground: centipede 1.15, crawler 0.6)
LIE = {"z": 0.8, "shift": 0.7, "deg": 80, "pitch": 80, "feet": 0.85}
LOW = {"z": 0.62, "shift": 0.25, "deg": 12, "pitch": 0, "feet": 0.1}
# The feet of a fall, lying and getting up slide the same way, in character space
# (mirror=False): a mirrored -y crossed the feet of a fall to the side.

def lie_pose(d, low=False):
    (ux, uy), ax, sg = DIRS[d]
    L = LOW if low else LIE
    # a low collapse to the side tucks its feet in toward the midline by a share of their
    # own distance from it (sagittal-relative y, FOOTSPEC_LOW): a tuck in limb lengths
    # crossed the feet of long-legged creatures with a narrow stance (random 4: 0.96 m of
    # tuck, 0.68 m from the midline); keeping them still left them under the falling body
    feet_y = LOW_TUCK * abs(uy) if low else -uy * L["feet"]
    deg = L["deg"] if uy else L["pitch"]
    return dict(pos=[r(ux * L["shift"]), r(uy * L["shift"]), L["z"]], rot=[ax[0], ax[1], ax[2], r(sg * deg)],
                deg=deg, feet=[r(-ux * L["feet"]), r(feet_y), 0], feetspec=FOOTSPEC_LOW if low else FOOTSPEC)

def branches(low):
    return {"upright_spine": not low}

def fall(d, low):
    (ux, uy), ax, sg = DIRS[d]
    L = lie_pose(d, low)
    ang = lambda f: [ax[0], ax[1], ax[2], r(sg * L["deg"] * f)]
    P = L["pos"]
    chans = [
        channel("root", ROOT, priority=1, posspec="{mode: rest, ground: true, scale: creature_size}",
                # falls from the first frame (a clip that stood still first would match every
                # tap: its opening windows look like a body held in place), faster as it
                # goes, a small bounce on landing
                pos=[(0.0, [0, 0, 0]), (0.15, [r(P[0] * 0.1), r(P[1] * 0.1), 0.05]), (0.4, [r(P[0] * 0.35), r(P[1] * 0.35), 0.2]),
                     (0.65, [r(P[0] * 0.7), r(P[1] * 0.7), 0.55]),
                     (FALL_T, P), (FALL_T + 0.12, [P[0], P[1], r(P[2] - 0.06)]), (FALL_T + 0.3, P)],
                rot=[(0.0, ang(0)), (0.15, ang(0.1)), (0.4, ang(0.35)), (0.65, ang(0.72)), (FALL_T, ang(1.0)),
                     (FALL_T + 0.12, ang(0.96)), (FALL_T + 0.3, ang(1.0))]),
        channel("feet", FEET, posspec=L["feetspec"], mirror=False,
                pos=[(0.0, [0, 0, 0]), (0.2, [0, 0, 0]), (0.5, [r(L["feet"][0] * 0.5), r(L["feet"][1] * 0.5), LIFT]),
                     (FALL_T, L["feet"]), (FALL_T + 0.3, L["feet"])]),
    ]
    sfx = "_low" if low else ""
    how = ("collapses toward the {d}, tilted {deg} degrees (creatures whose spine is not upright)" if low else
           "topples toward the {d} about its feet, ends lying turned {deg} degrees, the feet sliding away")
    return clip(f"fall_{d}{sfx}", f"Fall {d}: the body " + how.format(d=d, deg=L["deg"]) +
                f" (root ground-relative); continues into lie_{d}{sfx}.", FALL_T + 0.3, chans, branches=branches(low))

def lie(d, low):
    L = lie_pose(d, low)
    P = L["pos"]
    (ux, uy), ax, sg = DIRS[d]
    chans = [
        channel("root", ROOT, priority=1, posspec="{mode: rest, ground: true, scale: creature_size}",
                pos=[(0.0, P), (1.0, [P[0], P[1], r(P[2] - 0.02)]), (2.0, P)],
                rot=[(0.0, L["rot"]), (2.0, L["rot"])]),
        channel("feet", FEET, posspec=L["feetspec"], mirror=False, pos=[(0.0, L["feet"]), (2.0, L["feet"])]),
    ]
    sfx = "_low" if low else ""
    return clip(f"lie_{d}{sfx}", f"Lying after a fall to the {d}: the pose fall_{d}{sfx} ends on, breathing (loops).",
                2.0, chans, loop=True, branches=branches(low), follows=f"fall_{d}{sfx}")

def get_up(d, low):
    L = lie_pose(d, low)
    P = L["pos"]
    (ux, uy), ax, sg = DIRS[d]
    ang = lambda f: [ax[0], ax[1], ax[2], r(sg * L["deg"] * f)]
    T = 1.8
    chans = [
        channel("root", ROOT, priority=1, posspec="{mode: rest, ground: true, scale: creature_size}",
                # push up to sitting / kneeling (trunk half up, low), then rise over the feet
                pos=[(0.0, P), (0.6, [r(P[0] * 0.6), r(P[1] * 0.6), 0.6]), (1.2, [r(P[0] * 0.15), r(P[1] * 0.15), 0.3]),
                     (T, [0, 0, 0])],
                rot=[(0.0, ang(1.0)), (0.6, ang(0.5)), (1.2, ang(0.1)), (T, ang(0))]),
        channel("feet", FEET, posspec=L["feetspec"], mirror=False, pos=[(0.0, L["feet"]), (0.5, L["feet"]), (0.8, [r(L["feet"][0] * 0.5), r(L["feet"][1] * 0.5), LIFT]),
                                                     (1.1, [0, 0, 0]), (T, [0, 0, 0])]),
    ]
    sfx = "_low" if low else ""
    return clip(f"get_up_{d}{sfx}", f"Get up after lie_{d}{sfx}: push up to a crouch over the feet, then rise to "
                f"the rest pose.", T, chans, branches=branches(low), follows=f"lie_{d}{sfx}")

out = {"brace": brace(), "brace_low": brace(True)}
for d in DIRS:
    for low in (False, True):
        sfx = "_low" if low else ""
        out[f"stagger_{d}{sfx}"] = stagger(d, low)
        out[f"fall_{d}{sfx}"] = fall(d, low)
        out[f"lie_{d}{sfx}"] = lie(d, low)
        out[f"get_up_{d}{sfx}"] = get_up(d, low)
os.makedirs("animations/reactions", exist_ok=True)
for n, txt in out.items():
    with open(f"animations/reactions/{n}.yaml", "w") as f:
        f.write(txt)
print(len(out), "clips")
