#!/usr/bin/env python
"""Generate Menagerie's creature library: every ``creatures/*.yaml`` comes from here.

Run ``python creatures/_make.py`` from anywhere; it rewrites the YAML files beside it,
deterministically (the same script gives the same bytes). The YAML files are the product;
this script only keeps them consistent (left and right sides exact mirror images, every
child joint at its parent's distal end, feet on the ground). The engine never imports it.

Conventions (DESIGN.md): metres, Z up, X forward (creatures face +X), Y left; the ground
is z = 0. A body's ``pos`` is its box centre, ``joint`` where it attaches to its parent,
``extents`` its half-extents in its own frame; a limb segment's box runs from its
proximal joint to the next joint with the box's long axis turned onto the bone (the
minimal rotation from the nearest principal axis, so near-vertical legs keep nearly
identity rotations). Left-side bodies end in ``_l``; ``Maker.mirror`` adds the ``_r``
copies by negating y (and mirroring rotations: (w, x, y, z) -> (w, -x, y, -z)).

Descriptions say how each tail is built: a "tail chain" is a chain of ``tail`` bodies
hanging off the back end of the spine; a tail "on/part of the spine" is ``spine`` +
``tail`` bodies inside the serial spine chain. Sizes in descriptions are measured.
Rotations are written at full precision and chosen so that their computed norm is
exactly 1.0 (``exact_unit``): the builder's normalisation then leaves them untouched, and
load -> save -> load is exact.
"""

from __future__ import annotations

import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
POS_DECIMALS = 5   # 0.01 mm: plenty for a 0.1 m creature, exact mirror images survive rounding


# -- small vector helpers ----------------------------------------------------------------


def v(*a) -> np.ndarray:
    return np.array(a, dtype=float)


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    ])


def qrot(q, p):
    u = np.asarray(q[1:], float)
    t = 2.0 * np.cross(u, p)
    return np.asarray(p, float) + q[0] * t + np.cross(u, t)


def quat_between(a, b):
    """The minimal rotation taking direction ``a`` to direction ``b`` (never opposite here)."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    q = np.array([1.0 + a @ b, *np.cross(a, b)])
    return q / np.linalg.norm(q)


def exact_unit(q):
    """``q`` scaled so that ``np.linalg.norm`` of it is exactly 1.0 in floating point.

    The builder divides every rotation by its norm; a quaternion whose computed norm is
    exactly 1.0 passes through unchanged, so a file's rotations survive load -> save ->
    load bit for bit. Normalising again usually gets there; otherwise the largest
    component is nudged by a few ulps (magnitude only, so mirror images stay exact)."""
    q = np.asarray(q, float) / np.linalg.norm(q)
    for _ in range(8):
        n = np.linalg.norm(q)
        if n == 1.0:
            return q
        q = q / n
    k = int(np.argmax(np.abs(q)))
    for steps in range(1, 200):
        for direction in (0.0, 2.0):
            t = q.copy()
            mag = abs(t[k])
            for _ in range(steps):
                mag = np.nextafter(mag, direction)
            t[k] = math.copysign(mag, q[k])
            if np.linalg.norm(t) == 1.0:
                return t
    raise ValueError(f"no exactly-unit representation found for {q}")


def quat_yaw(deg):
    t = math.radians(deg) / 2.0
    return v(math.cos(t), 0.0, 0.0, math.sin(t))


def rot_z(deg, p):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return v(c * p[0] - s * p[1], s * p[0] + c * p[1], p[2])


def polar(r, deg, z):
    """A point at radius ``r`` and heading ``deg`` (0 = +X, 90 = +Y) at height ``z``."""
    return v(r * math.cos(math.radians(deg)), r * math.sin(math.radians(deg)), z)


def dir_pitch(deg):
    """Unit vector in the sagittal plane, ``deg`` above the +X axis."""
    return v(math.cos(math.radians(deg)), 0.0, math.sin(math.radians(deg)))


SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)


def corners(pos, rot, ext):
    return np.array([pos + qrot(rot, s * ext) for s in SIGNS])


def seg_box(a, b, cross, axis=None):
    """Centre, half-extents and rotation of a box from joint ``a`` to joint ``b``."""
    d = b - a
    length = float(np.linalg.norm(d))
    k = int(np.argmax(np.abs(d))) if axis is None else axis
    e = np.zeros(3)
    e[k] = 1.0 if (axis is not None or d[k] >= 0.0) else -1.0
    rot = quat_between(e, d)
    ext = np.zeros(3)
    ext[k] = 0.5 * length
    others = [i for i in range(3) if i != k]
    cr = (cross, cross) if np.isscalar(cross) else cross
    ext[others[0]], ext[others[1]] = cr
    return 0.5 * (a + b), ext, rot


# -- the maker ---------------------------------------------------------------------------


class Body:
    __slots__ = ("name", "parent", "caps", "pos", "ext", "joint", "rot")

    def __init__(self, name, parent, caps, pos, ext, joint, rot):
        self.name, self.parent, self.caps = name, parent, list(caps)
        self.pos, self.ext = v(*pos), v(*ext)
        self.joint = None if joint is None else v(*joint)
        self.rot = v(1, 0, 0, 0) if rot is None else v(*rot) / np.linalg.norm(rot)


class Maker:
    """Collects the bodies of one creature; helpers place boxes, limbs, feet and mirrors."""

    def __init__(self, name: str, description: str):
        self.name = name
        self.description = description
        self.bodies: list[Body] = []
        self.index: dict[str, Body] = {}

    # basic bodies ------------------------------------------------------------------------

    def add(self, name, parent, caps, pos, ext, joint=None, rot=None) -> str:
        if name in self.index:
            raise ValueError(f"{self.name}: duplicate body {name}")
        b = Body(name, parent, caps, pos, ext, joint, rot)
        self.bodies.append(b)
        self.index[name] = b
        return name

    def __getitem__(self, name) -> Body:
        return self.index[name]

    def seg(self, name, parent, caps, a, b, cross, axis=None) -> np.ndarray:
        """A segment from joint ``a`` to ``b``: box centre midway, long axis along the bone.

        ``cross`` is the half-thickness (one number, or two for the two other axes in
        x, y, z order). ``axis`` forces the box axis (0, 1, 2) that turns onto the bone,
        otherwise the principal axis nearest the bone is used. Returns ``b``.
        """
        a, b = np.asarray(a, float), np.asarray(b, float)
        pos, ext, rot = seg_box(a, b, cross, axis)
        self.add(name, parent, caps, pos, ext, joint=a, rot=rot)
        return b

    def foot_seg(self, name, parent, a, tip_xy, cross, caps=("foot",)) -> np.ndarray:
        """A foot that is a segment from joint ``a`` down to a tip above ground point
        ``tip_xy``, the tip raised just enough that the box's lowest corner is at z = 0."""
        b = v(tip_xy[0], tip_xy[1], 0.0)
        for _ in range(100):   # fixed point: lift the tip by the depth of the lowest corner
            pos, ext, rot = seg_box(np.asarray(a, float), b, cross, None)
            low = corners(pos, rot, ext)[:, 2].min()
            if abs(low) < 1e-9:
                break
            b[2] -= low
        return self.seg(name, parent, caps, a, b, cross)

    def chain(self, names, parent, caps, points, cross, axis=None) -> list[str]:
        """Segments through ``points`` (len(names) + 1 of them), each the parent of the next."""
        assert len(points) == len(names) + 1, (self.name, names)
        for i, name in enumerate(names):
            c = caps[i] if isinstance(caps[0], (list, tuple)) else caps
            cr = cross[i] if isinstance(cross, list) else cross
            self.seg(name, parent, c, points[i], points[i + 1], cr, axis=axis)
            parent = name
        return list(names)

    def foot(self, name, parent, ankle, fwd, ext, yaw=0.0, caps=("foot",)) -> str:
        """A flat foot box lying on the ground (its bottom at z = 0), jointed at ``ankle``,
        its centre ``fwd`` ahead of the ankle along heading ``yaw`` (degrees)."""
        p = np.asarray(ankle, float) + rot_z(yaw, v(fwd, 0.0, 0.0))
        p[2] = ext[2]
        return self.add(name, parent, caps, p, ext, joint=ankle, rot=quat_yaw(yaw))

    def on(self, name, parent, caps, rel, ext, push=(0, 0, 0), rot=None) -> str:
        """A small body stuck on ``parent``'s box: ``rel`` is a point in the parent's frame in
        units of its half-extents (1 = on the face), ``push`` a further offset in metres in
        the parent's frame. The joint is the nearest point of the parent box."""
        p = self[parent]
        rel = np.asarray(rel, float)
        surface = p.pos + qrot(p.rot, np.clip(rel, -1.0, 1.0) * p.ext)
        pos = p.pos + qrot(p.rot, rel * p.ext + np.asarray(push, float))
        r = p.rot if rot is None else qmul(p.rot, rot)
        return self.add(name, parent, caps, pos, ext, joint=surface, rot=r)

    def leg(self, names, parent, hip, profile, cross, foot_ext, foot_fwd, *, yaw=0.0,
            foot_yaw=None, caps=("limb",), foot_caps=("foot",), ankle_z=None) -> list[str]:
        """A leg from ``hip`` down to a foot on the ground.

        ``profile`` lists the joints from the hip (0, 0, 0) to the ankle (dx, dy, -1) as
        fractions of the hip's height above the ankle; (dx, dy) are turned by ``yaw``
        degrees. The ankle sits at the top of the foot box unless ``ankle_z`` is given.
        """
        hip = np.asarray(hip, float)
        if ankle_z is None:
            ankle_z = 2.0 * foot_ext[2]
        hh = hip[2] - ankle_z
        assert abs(profile[-1][2] + 1.0) < 1e-12 and len(profile) == len(names), (self.name, names)
        pts = []
        for dx, dy, dz in profile:
            off = rot_z(yaw, v(dx * hh, dy * hh, 0.0))
            pts.append(v(hip[0] + off[0], hip[1] + off[1], hip[2] + dz * hh))
        pts[-1][2] = ankle_z
        self.chain(names[:-1], parent, list(caps), pts, cross)
        self.foot(names[-1], names[-2], pts[-1], foot_fwd, foot_ext,
                  yaw=yaw if foot_yaw is None else foot_yaw, caps=foot_caps)
        return list(names)

    # symmetry -----------------------------------------------------------------------------

    def mirror(self) -> None:
        """Add the right side: every ``*_l`` body without a ``*_r`` twin is copied with y
        negated, right after the run of left bodies it belongs to."""
        out: list[Body] = []
        run: list[Body] = []

        def flush():
            for b in run:
                rname = b.name[:-2] + "_r"
                if rname in self.index:
                    continue
                parent = b.parent
                if parent is not None and parent.endswith("_l") and parent[:-2] + "_r" in names_l:
                    parent = parent[:-2] + "_r"
                m = Body(rname, parent, b.caps, b.pos * v(1, -1, 1), b.ext,
                         None if b.joint is None else b.joint * v(1, -1, 1),
                         b.rot * v(1, -1, 1, -1))
                out.append(m)
                self.index[rname] = m
            run.clear()

        names_l = {b.name[:-2] + "_r" for b in self.bodies if b.name.endswith("_l")}
        for b in self.bodies:
            if b.name.endswith("_l"):
                run.append(b)
                out.append(b)
                continue
            flush()
            out.append(b)
        flush()
        self.bodies = out

    def scale_to_height(self, height: float) -> None:
        """Scale the whole creature about the ground origin so its top is at ``height``."""
        top = max(corners(b.pos, b.rot, b.ext)[:, 2].max() for b in self.bodies)
        k = height / top
        for b in self.bodies:
            b.pos = b.pos * k
            b.ext = b.ext * k
            if b.joint is not None:
                b.joint = b.joint * k

    # output -------------------------------------------------------------------------------

    def lowest(self) -> float:
        return min(corners(b.pos, b.rot, b.ext)[:, 2].min() for b in self.bodies)

    def text(self) -> str:
        def num(x, decimals):
            r = round(float(x), decimals)
            return repr(0.0 if r == 0.0 else r)

        def vec(values, decimals=POS_DECIMALS):
            return "[" + ", ".join(num(x, decimals) for x in values) + "]"

        lines = [
            "# Menagerie creature file. Generated by creatures/_make.py: edit the script, rerun it.",
            "format: 1",
            f"name: {self.name}",
            f"description: {json.dumps(self.description)}",
            "bodies:",
        ]
        for b in self.bodies:
            lines.append(f"  - name: {b.name}")
            if b.parent is not None:
                lines.append(f"    parent: {b.parent}")
            lines.append("    caps: [" + ", ".join(b.caps) + "]")
            lines.append(f"    pos: {vec(b.pos)}")
            if not np.allclose(b.rot, (1, 0, 0, 0), atol=1e-12):
                q = exact_unit(b.rot)
                lines.append("    rot: [" + ", ".join(repr(0.0 if x == 0.0 else float(x))
                                                     for x in q) + "]")
            if b.parent is not None and b.joint is not None:
                lines.append(f"    joint: {vec(b.joint)}")
            lines.append(f"    extents: {vec(b.ext)}")
        return "\n".join(lines) + "\n"


# -- shared parts ------------------------------------------------------------------------


def face(c, head, *, mouth=None, eyes=None, ears=None, eye_rel=(0.75, 0.55, 0.45),
         mouth_rel=(1.0, 0.0, -0.45), ear_rel=(-0.3, 0.6, 1.0), suffix=""):
    """Mouth, eyes and ears on a head box whose local +X looks forward.

    ``mouth``, ``eyes`` and ``ears`` are half-extents (or None for none). Each ``*_rel`` is
    a point in the head's frame in units of its half-extents; it is moved out to the face
    of the box it is nearest (its largest coordinate becomes +-1), and the part sticks out
    of that face: eyes by half their size, mouths and ears by their full size."""
    for name, caps, ext, rel, out in (("jaw" + suffix, ["mouth"], mouth, mouth_rel, 1.0),
                                      ("eye" + suffix + "_l", ["eye"], eyes, eye_rel, 0.5),
                                      ("ear" + suffix + "_l", ["ear"], ears, ear_rel, 1.0)):
        if ext is None:
            continue
        rel = np.array(rel, float)
        k = int(np.argmax(np.abs(rel)))
        rel[k] = math.copysign(1.0, rel[k])
        push = np.zeros(3)
        push[k] = rel[k] * out * ext[k]
        c.on(name, head, caps, rel, ext, push=push)


def neck_and_head(c, parent, base, pitch, n, length, cross, head_len, head_cross, head_pitch,
                  *, head_caps=("spine", "head"), neck_caps=("spine",), prefix="neck",
                  neck_names=None):
    """A neck of ``n`` segments rising at ``pitch`` degrees from ``base``, then a head box
    pointing at ``head_pitch`` degrees (its local +X forward). Returns the head name."""
    pts = [np.asarray(base, float) + dir_pitch(pitch) * (length * i / max(n, 1))
           for i in range(n + 1)]
    names = neck_names or [f"{prefix}{i + 1}" if n > 1 else prefix for i in range(n)]
    cr = cross if isinstance(cross, list) else [cross] * n
    if n:
        c.chain(names, parent, list(neck_caps), pts, cr)
        parent = names[-1]
    tip = pts[-1] + dir_pitch(head_pitch) * head_len
    c.seg("head", parent, list(head_caps), pts[-1], tip, head_cross, axis=0)
    return "head"


def tail_chain(c, parent, base, n, length, pitches, cross, caps=("tail",), prefix="tail",
               last_caps=None):
    """A tail of ``n`` segments from ``base`` backwards; ``pitches`` (degrees below the
    backward horizontal, one per segment) shape its curve; ``cross`` tapers (first, last)."""
    pts = [np.asarray(base, float)]
    seg_len = length / n
    for i in range(n):
        a = math.radians(pitches[i])
        pts.append(pts[-1] + v(-math.cos(a), 0.0, -math.sin(a)) * seg_len)
    names = [f"{prefix}{i + 1}" for i in range(n)]
    cr = [cross[0] + (cross[1] - cross[0]) * i / max(n - 1, 1) for i in range(n)]
    caps_list = [list(caps)] * n
    if last_caps is not None:
        caps_list[-1] = list(last_caps)
    c.chain(names, parent, caps_list, pts, cr)
    return names


def spine_line(c, names, parent, points, cross, caps=("spine",)):
    """Spine bodies through ``points``; ``cross`` is one (half-width, half-height) pair or
    a list of them. The box's long axis follows the line (x for a horizontal back)."""
    crs = cross if isinstance(cross, list) else [cross] * len(names)
    caps_list = caps if isinstance(caps[0], (list, tuple)) else [list(caps)] * len(names)
    for i, name in enumerate(names):
        a, b = np.asarray(points[i], float), np.asarray(points[i + 1], float)
        d = b - a
        k = int(np.argmax(np.abs(d)))
        cw, ch = crs[i]
        cr = (cw, ch) if k == 0 else ((ch, cw) if k == 1 else (ch, cw))
        if k == 2:   # vertical: x thickness = ch, y width = cw
            cr = (ch, cw)
        c.seg(name, parent, caps_list[i], a, b, cr)
        parent = name
    return names


# -- the creatures -----------------------------------------------------------------------

CREATURES = []


def creature(fn):
    CREATURES.append(fn)
    return fn


@creature
def humanoid():
    c = Maker("humanoid", "A 25-body humanoid biped, 1.75 m tall: the benchmark creature "
              "(Hecker et al. 2008 time a 25-body character).")
    c.add("pelvis", None, ["spine"], (0, 0, 0.98), (0.1, 0.16, 0.08))
    spine_line(c, ["spine1", "spine2", "spine3"], "pelvis",
               [v(0, 0, 1.06), v(0, 0, 1.19), v(0, 0, 1.33), v(0, 0, 1.46)],
               [(0.14, 0.09), (0.15, 0.095), (0.17, 0.1)])
    c.seg("neck", "spine3", ["spine"], v(0, 0, 1.46), v(0, 0, 1.54), (0.05, 0.05))
    c.add("head", "neck", ["spine", "head"], (0.015, 0, 1.645), (0.1, 0.08, 0.105),
          joint=(0, 0, 1.54))
    face(c, "head", mouth=(0.015, 0.03, 0.012), eyes=(0.012, 0.014, 0.012),
         ears=(0.015, 0.01, 0.028), eye_rel=(0.9, 0.45, 0.2), mouth_rel=(1.0, 0.0, -0.5),
         ear_rel=(-0.05, 1.0, 0.05))
    c.chain(["clavicle_l", "upperarm_l", "forearm_l", "hand_l"], "spine3",
            [["limb"], ["limb"], ["limb"], ["limb", "grasper"]],
            [v(0, 0.03, 1.43), v(-0.01, 0.19, 1.43), v(-0.03, 0.235, 1.14),
             v(0.0, 0.255, 0.88), v(0.01, 0.262, 0.71)],
            [0.03, 0.045, 0.038, (0.045, 0.018)])
    c.leg(["thigh_l", "shin_l", "foot_l"], "pelvis", v(0, 0.095, 0.92),
          [(0, 0, 0), (0.018, 0, -0.5), (0, 0, -1)], [0.07, 0.05], (0.125, 0.045, 0.04), 0.05,
          ankle_z=0.085)
    c.mirror()
    return c


def quadruped(name, desc, *, length, zb, back_n, torso, hip_drop, hip_y, fore_y=None,
              hind_profile, fore_profile, hind_names, fore_names, leg_cross, foot_ext, foot_fwd,
              neck_n, neck_len, neck_pitch, neck_cross, head_len, head_cross, head_pitch,
              face_kw, tail=None, head_caps=("spine", "head"), arch=0.0, neck_names=None):
    """A four-legged creature: ``back_n`` spine bodies from the pelvis (at -length/2) to
    the chest (at +length/2), legs hung at the ends, a neck and head in front, an optional
    tail behind (``tail = (mode, n, length, pitches, cross)``, mode 'spine' or 'chain')."""
    c = Maker(name, desc)
    xs = np.linspace(-0.5 * length, 0.5 * length, back_n + 1)
    zs = zb + arch * np.sin(np.linspace(0.0, math.pi, back_n + 1))
    pts = [v(x, 0, z) for x, z in zip(xs, zs, strict=True)]
    names = ["pelvis"] + [f"back{i}" for i in range(1, back_n - 1)] + ["chest"]
    crs = torso if isinstance(torso, list) else [torso] * back_n
    # Authored root: the pelvis (its joint is its own centre); the builder re-roots.
    c.add("pelvis", None, ["spine"], 0.5 * (pts[0] + pts[1]),
          (0.5 * float(np.linalg.norm(pts[1] - pts[0])), crs[0][0], crs[0][1]),
          rot=quat_between(v(1, 0, 0), pts[1] - pts[0]))
    spine_line(c, names[1:], "pelvis", pts[1:], crs[1:])
    fy = hip_y if fore_y is None else fore_y
    c.leg([n + "_l" for n in hind_names], "pelvis",
          v(xs[0] + 0.25 * (xs[1] - xs[0]), hip_y, zs[0] - hip_drop), hind_profile, leg_cross,
          foot_ext, foot_fwd)
    c.leg([n + "_l" for n in fore_names], "chest",
          v(xs[-1] - 0.25 * (xs[-1] - xs[-2]), fy, zs[-1] - hip_drop), fore_profile, leg_cross,
          foot_ext, foot_fwd)
    base = pts[-1] + v(0, 0, 0.3 * crs[-1][1])
    head = neck_and_head(c, "chest", base, neck_pitch, neck_n, neck_len, neck_cross, head_len,
                         head_cross, head_pitch, head_caps=head_caps, neck_names=neck_names)
    if face_kw is not None:
        face(c, head, **face_kw)
    if tail is not None:
        mode, n, tlen, pitches, cross = tail
        caps = ("spine", "tail") if mode == "spine" else ("tail",)
        tail_chain(c, "pelvis", pts[0] + v(0, 0, 0.3 * crs[0][1]), n, tlen, pitches, cross, caps)
    return c


@creature
def dog():
    c = quadruped(
        "dog", "A dog, 0.85 m tall at the ears, with a three-body tail chain hanging off "
        "the pelvis (tail not part of the spine).",
        length=0.6, zb=0.52, back_n=3, torso=[(0.1, 0.09), (0.1, 0.1), (0.11, 0.115)],
        hip_drop=0.05, hip_y=0.07,
        hind_profile=[(0, 0, 0), (0.14, 0, -0.38), (-0.1, 0, -0.76), (-0.07, 0, -1)],
        hind_names=["thigh", "shin", "hock", "hindpaw"],
        fore_profile=[(0, 0, 0), (-0.07, 0, -0.45), (0.0, 0, -0.88), (0.03, 0, -1)],
        fore_names=["upperarm", "forearm", "wrist", "forepaw"],
        leg_cross=[0.045, 0.03, 0.022], foot_ext=(0.04, 0.03, 0.02), foot_fwd=0.03,
        neck_n=1, neck_len=0.2, neck_pitch=50, neck_cross=(0.06, 0.065),
        head_len=0.24, head_cross=(0.07, 0.065), head_pitch=-12,
        face_kw=dict(mouth=(0.035, 0.035, 0.015), eyes=(0.012, 0.012, 0.012),
                     ears=(0.02, 0.03, 0.04), eye_rel=(0.3, 0.75, 0.55),
                     ear_rel=(-0.6, 0.6, 1.0)),
        tail=("chain", 3, 0.33, [-35, -10, 15], (0.025, 0.015)))
    c.mirror()
    return c


@creature
def horse():
    c = quadruped(
        "horse", "A horse, 2.2 m tall at the ears, with a long head and a three-body tail "
        "that is part of the spine (the spine runs tail to head).",
        length=1.2, zb=1.35, back_n=4, torso=[(0.22, 0.25), (0.24, 0.28), (0.24, 0.28),
                                                (0.22, 0.28)],
        hip_drop=0.12, hip_y=0.14, arch=-0.04,
        hind_profile=[(0, 0, 0), (0.12, 0, -0.35), (-0.12, 0, -0.62), (-0.1, 0, -0.9),
                      (-0.06, 0, -1)],
        hind_names=["thigh", "gaskin", "cannon", "pastern", "hoof"],
        fore_profile=[(0, 0, 0), (-0.06, 0, -0.3), (-0.03, 0, -0.62), (0.0, 0, -0.9),
                      (0.04, 0, -1)],
        fore_names=["upperarm", "forearm", "fcannon", "fpastern", "fhoof"],
        leg_cross=[0.09, 0.065, 0.045, 0.04], foot_ext=(0.075, 0.06, 0.04), foot_fwd=0.04,
        neck_n=3, neck_len=0.8, neck_pitch=55, neck_cross=[(0.17, 0.12), (0.14, 0.09),
                                                             (0.12, 0.08)],
        head_len=0.6, head_cross=(0.12, 0.1), head_pitch=-55,
        face_kw=dict(mouth=(0.05, 0.05, 0.03), eyes=(0.025, 0.02, 0.025),
                     ears=(0.03, 0.03, 0.07), eye_rel=(-0.35, 0.85, 0.8),
                     mouth_rel=(1.0, 0.0, -0.3), ear_rel=(-0.85, 0.5, 1.0)),
        tail=("spine", 3, 0.75, [30, 55, 75], (0.06, 0.04)))
    c.mirror()
    return c


@creature
def grazer():
    c = quadruped(
        "grazer", "A long-necked grazer, 4.5 m tall: six neck vertebrae on the spine, two "
        "horn stubs, a thin four-body tail chain.",
        length=1.3, zb=2.3, back_n=3, torso=[(0.24, 0.25), (0.26, 0.3), (0.27, 0.32)],
        hip_drop=0.1, hip_y=0.14, fore_y=0.15, arch=0.0,
        hind_profile=[(0, 0, 0), (0.1, 0, -0.3), (-0.08, 0, -0.6), (-0.04, 0, -1)],
        hind_names=["thigh", "shin", "cannon", "hoof"],
        fore_profile=[(0, 0, 0), (-0.04, 0, -0.32), (0.0, 0, -0.65), (0.02, 0, -1)],
        fore_names=["upperarm", "forearm", "fcannon", "fhoof"],
        leg_cross=[0.09, 0.06, 0.045], foot_ext=(0.08, 0.065, 0.045), foot_fwd=0.04,
        neck_n=6, neck_len=2.1, neck_pitch=68,
        neck_cross=[(0.17, 0.15), (0.14, 0.13), (0.12, 0.11), (0.1, 0.1), (0.09, 0.09),
                    (0.08, 0.08)],
        head_len=0.55, head_cross=(0.1, 0.09), head_pitch=-20,
        face_kw=dict(mouth=(0.05, 0.055, 0.03), eyes=(0.025, 0.02, 0.025),
                     ears=(0.03, 0.05, 0.025), eye_rel=(-0.2, 0.9, 0.5),
                     ear_rel=(-0.7, 0.9, 0.5)),
        tail=("chain", 4, 0.8, [70, 80, 85, 85], (0.035, 0.02)))
    c.on("horn_l", "head", ["detail"], (-0.55, 0.35, 1.0), (0.025, 0.025, 0.07),
         push=(0, 0, 0.07))
    c.mirror()
    return c


@creature
def tiny():
    c = quadruped(
        "tiny", "A mouse, 0.1 m tall at the ear tips, with a long five-body tail chain: "
        "the smallest creature in the library.",
        length=0.06, zb=0.042, back_n=3, torso=[(0.018, 0.017), (0.02, 0.02), (0.018, 0.018)],
        hip_drop=0.008, hip_y=0.012, arch=0.006,
        hind_profile=[(0, 0, 0), (0.25, 0, -0.45), (-0.15, 0, -0.8), (-0.1, 0, -1)],
        hind_names=["thigh", "shin", "hock", "hindpaw"],
        fore_profile=[(0, 0, 0), (-0.1, 0, -0.5), (0.05, 0, -1)],
        fore_names=["upperarm", "forearm", "forepaw"],
        leg_cross=[0.005, 0.004, 0.003], foot_ext=(0.006, 0.004, 0.002), foot_fwd=0.004,
        neck_n=0, neck_len=0.0, neck_pitch=0, neck_cross=(0.01, 0.01),
        head_len=0.036, head_cross=(0.012, 0.011), head_pitch=-10,
        head_caps=("head",),
        face_kw=dict(mouth=(0.003, 0.004, 0.002), eyes=(0.002, 0.002, 0.002),
                     ears=(0.002, 0.007, 0.012), eye_rel=(0.35, 0.75, 0.55),
                     mouth_rel=(1.0, 0.0, -0.4), ear_rel=(-0.4, 0.8, 1.0)),
        tail=("chain", 5, 0.08, [30, 15, 5, 0, 0], (0.003, 0.0015)))
    c.mirror()
    c.scale_to_height(0.1)   # the ear tips at exactly 0.1 m
    return c


@creature
def giant():
    c = Maker("giant", "A 10 m stone giant: stocky biped with long arms, a short neck, "
              "a non-spine head with horns, and shoulder spikes.")
    c.add("pelvis", None, ["spine"], (0, 0, 4.9), (0.7, 1.05, 0.5))
    spine_line(c, ["belly", "chest"], "pelvis", [v(0, 0, 5.4), v(0.05, 0, 6.5), v(0.2, 0, 7.8)],
               [(1.0, 0.6), (1.35, 0.75)])
    c.seg("neck", "chest", ["spine"], v(0.2, 0, 7.8), v(0.45, 0, 8.3), (0.4, 0.4))
    c.seg("head", "neck", ["head"], v(0.45, 0, 8.3), v(1.35, 0, 8.55), (0.6, 0.65), axis=0)
    face(c, "head", mouth=(0.15, 0.35, 0.12), eyes=(0.08, 0.1, 0.08),
         eye_rel=(0.9, 0.45, 0.35), mouth_rel=(1.0, 0.0, -0.55))
    c.on("horn_l", "head", ["spike"], (-0.2, 0.7, 1.0), (0.12, 0.12, 0.5), push=(0, 0, 0.5))
    c.chain(["shoulder_l", "upperarm_l", "forearm_l", "hand_l"], "chest",
            [["limb"], ["limb"], ["limb"], ["limb", "grasper"]],
            [v(0.2, 0.4, 7.7), v(0.2, 1.75, 7.6), v(0.05, 2.05, 5.8), v(0.45, 2.15, 4.0),
             v(0.6, 2.2, 3.0)],
            [0.4, 0.42, 0.36, (0.4, 0.2)])
    c.on("shoulderspike_l", "shoulder_l", ["spike"], (0.3, 0.0, 1.0), (0.15, 0.15, 0.45),
         push=(0, 0, 0.45))
    c.leg(["thigh_l", "shin_l", "foot_l"], "pelvis", v(0, 0.62, 4.6),
          [(0, 0, 0), (0.06, 0.02, -0.52), (0, 0.04, -1)], [0.55, 0.45], (1.0, 0.45, 0.25),
          0.35, ankle_z=0.55)
    c.mirror()
    c.scale_to_height(10.0)   # horn tips at exactly 10 m
    return c


@creature
def hexapod():
    c = Maker("hexapod", "A six-legged beetle, 0.23 m long: abdomen, three thorax segments "
              "each carrying a leg pair, and a head with mandibles and antennae.")
    z = 0.07
    pts = [v(-0.11, 0, z + 0.005), v(-0.04, 0, z), v(-0.01, 0, z), v(0.02, 0, z),
           v(0.045, 0, z), v(0.075, 0, z - 0.005)]
    c.add("metathorax", None, ["spine"], 0.5 * (pts[1] + pts[2]), (0.015, 0.035, 0.022))
    c.seg("abdomen", "metathorax", ["spine"], pts[1], pts[0], (0.045, 0.028))
    c.seg("mesothorax", "metathorax", ["spine"], pts[2], pts[3], (0.03, 0.02))
    c.seg("prothorax", "mesothorax", ["spine"], pts[3], pts[4], (0.028, 0.02))
    c.seg("head", "prothorax", ["spine", "head"], pts[4], pts[5], (0.02, 0.016), axis=0)
    c["metathorax"].joint = None
    face(c, "head", eyes=(0.004, 0.004, 0.004), eye_rel=(0.4, 0.95, 0.4))
    c.on("mandible_l", "head", ["mouth"], (1.0, 0.4, -0.5), (0.008, 0.003, 0.003),
         push=(0.008, 0, 0), rot=quat_yaw(-20))
    c.on("antenna_l", "head", ["detail"], (0.9, 0.6, 0.8), (0.025, 0.0015, 0.0015),
         push=(0.022, 0.01, 0.01), rot=qmul(quat_yaw(25), quat_between(v(1, 0, 0),
                                                                       v(1, 0, 0.5))))
    profile = [(0, 0, 0), (0.0, 0.25, -0.05), (0.0, 0.75, 0.45), (0.0, 1.25, -1)]
    for seg_name, x, yaw in (("metathorax", -0.025, -40), ("mesothorax", 0.005, -5),
                             ("prothorax", 0.032, 35)):
        tag = {"metathorax": "hind", "mesothorax": "mid", "prothorax": "front"}[seg_name]
        c.leg([f"{tag}coxa_l", f"{tag}femur_l", f"{tag}tibia_l", f"{tag}tarsus_l"], seg_name,
              v(x, 0.018, z - 0.012), profile, [0.004, 0.0035, 0.0025], (0.008, 0.0025, 0.002),
              0.005, yaw=yaw, foot_yaw=90 + yaw)
    c.mirror()
    return c


@creature
def spider():
    c = Maker("spider", "An eight-legged spider, 0.4 m across: cephalothorax with all "
              "eight legs, abdomen, chelicerae, pedipalps that grasp, four eyes.")
    z = 0.09
    c.add("cephalothorax", None, ["spine", "head"], (0.02, 0, z), (0.045, 0.035, 0.022))
    c.seg("abdomen", "cephalothorax", ["spine"], v(-0.025, 0, z + 0.005),
          v(-0.14, 0, z + 0.025), (0.045, 0.035))
    c.on("spinneret", "abdomen", ["detail"], (1.0, 0.0, -0.3), (0.006, 0.005, 0.005),
         push=(0.006, 0, 0))
    c["spinneret"].pos = c["abdomen"].pos + qrot(c["abdomen"].rot, v(0.063, 0, -0.01))
    c.on("eye_l", "cephalothorax", ["eye"], (0.85, 0.3, 1.0), (0.004, 0.004, 0.004),
         push=(0, 0, 0.003))
    c.on("eyeback_l", "cephalothorax", ["eye"], (0.55, 0.5, 1.0), (0.003, 0.003, 0.003),
         push=(0, 0, 0.002))
    c.on("chelicera_l", "cephalothorax", ["mouth"], (1.0, 0.3, -0.5), (0.006, 0.005, 0.012),
         push=(0.005, 0, -0.008))
    c.chain(["palp_l", "palptip_l"], "cephalothorax", [["limb"], ["limb", "grasper"]],
            [v(0.06, 0.02, z - 0.005), v(0.09, 0.035, z + 0.01), v(0.12, 0.04, z - 0.03)],
            [0.004, 0.0035])
    profile = [(0, 0, 0), (0.0, 0.45, 0.5), (0.0, 1.15, 0.2), (0.0, 1.75, -0.6), (0, 2.0, -1)]
    for k, (x, yaw) in enumerate(((0.045, 55), (0.03, 18), (0.01, -15), (-0.01, -45))):
        c.leg([f"femur{k + 1}_l", f"tibia{k + 1}_l", f"metatarsus{k + 1}_l", f"tarsus{k + 1}_l",
               f"claw{k + 1}_l"], "cephalothorax",
              v(x, 0.03, z - 0.005), profile, [0.006, 0.005, 0.004, 0.003],
              (0.006, 0.002, 0.002), 0.004, yaw=yaw, foot_yaw=90 + yaw)
    c.mirror()
    return c


@creature
def centipede():
    c = Maker("centipede", "A centipede, 1.2 m long with 24 legs: twelve trunk segments "
              "each with a leg pair, head with forcipules and antennae, two tail cerci.")
    n = 12
    z = 0.045
    xs = np.linspace(0.45, -0.55, n + 1)
    c.add("trunk1", None, ["spine"], (0.5 * (xs[0] + xs[1]), 0, z),
          (0.5 * (xs[0] - xs[1]), 0.035, 0.02))
    for i in range(1, n):
        c.seg(f"trunk{i + 1}", f"trunk{i}", ["spine"], v(xs[i], 0, z), v(xs[i + 1], 0, z),
              (0.035 - 0.0012 * i, 0.02))
    c.seg("head", "trunk1", ["spine", "head"], v(xs[0], 0, z), v(xs[0] + 0.06, 0, z),
          (0.03, 0.018))
    face(c, "head", eyes=(0.005, 0.005, 0.005), eye_rel=(0.4, 0.8, 0.8))
    c.on("forcipule_l", "head", ["mouth"], (1.0, 0.5, -0.6), (0.012, 0.004, 0.004),
         push=(0.01, 0, 0), rot=quat_yaw(-30))
    c.on("antenna_l", "head", ["detail"], (1.0, 0.6, 0.6), (0.05, 0.002, 0.002),
         push=(0.045, 0.025, 0), rot=quat_yaw(30))
    for i in range(n):
        # Each leg: a femur rising outwards, then a foot segment down to the ground.
        x = 0.5 * (xs[i] + xs[i + 1])
        yaw = 10 - 20 * i / (n - 1)
        hip = v(x, 0.8 * c[f"trunk{i + 1}"].ext[1], z - 0.005)
        knee = hip + rot_z(yaw, v(0.0, 0.05, 0.0)) + v(0, 0, 0.012)
        tip = hip + rot_z(yaw, v(0.0, 0.1, 0.0))
        c.seg(f"leg{i + 1}_l", f"trunk{i + 1}", ["limb"], hip, knee, 0.004)
        c.foot_seg(f"foot{i + 1}_l", f"leg{i + 1}_l", knee, tip[:2], 0.003)
    c.on("cercus_l", f"trunk{n}", ["tail"], (-1.0, 0.6, 0.2), (0.03, 0.002, 0.002),
         push=(-0.028, 0.01, 0), rot=quat_yaw(-20))
    c.mirror()
    return c


@creature
def snake():
    c = Maker("snake", "A limbless 2.1 m snake lying straight on the ground: a head and "
              "sixteen spine bodies, the last five the tail (tail is part of the spine).")
    n = 16
    xs = [0.9 - 0.12 * i for i in range(n + 1)]
    widths = [0.035 + 0.012 * math.sin(math.pi * min(i / 10, 1.0)) for i in range(n)]
    widths = [w if i < 11 else 0.035 * (1 - (i - 10) / 7) for i, w in enumerate(widths)]
    for i in range(n):
        caps = ["spine", "tail"] if i >= n - 5 else ["spine"]
        h = widths[i] * 0.8
        c.add(f"body{i + 1}", None if i == 0 else f"body{i}", caps,
              (0.5 * (xs[i] + xs[i + 1]), 0, h), (0.06, widths[i], h),
              joint=None if i == 0 else (xs[i], 0, h))
        if i > 0:   # the joint sits between the two box centres' heights
            c[f"body{i + 1}"].joint = v(xs[i], 0, 0.5 * (h + widths[i - 1] * 0.8))
    c.add("head", "body1", ["spine", "head"], (0.96, 0, 0.032), (0.06, 0.04, 0.03),
          joint=(0.9, 0, 0.034))
    face(c, "head", eyes=(0.006, 0.006, 0.006), eye_rel=(0.3, 0.85, 0.7))
    c.on("jaw", "head", ["mouth"], (0.6, 0.0, -1.0), (0.04, 0.03, 0.005), push=(0, 0, 0.003))
    c.on("tongue", "jaw", ["detail"], (1.0, 0, 0), (0.02, 0.003, 0.002), push=(0.02, 0, 0))
    c.mirror()
    return c


@creature
def fish():
    c = Maker("fish", "A fish-like floater, 1.1 m long, hovering 0.55 m above the ground: "
              "no feet; the tail is the spine's back end plus a caudal fin hanging off it.")
    z = 0.8
    c.add("body2", None, ["spine"], (0.05, 0, z), (0.15, 0.12, 0.2))
    c.seg("body1", "body2", ["spine"], v(0.2, 0, z), v(0.3, 0, z), (0.11, 0.18))
    c.seg("head", "body1", ["spine", "head"], v(0.3, 0, z), v(0.5, 0, z - 0.02),
          (0.08, 0.13), axis=0)
    c.seg("body3", "body2", ["spine"], v(-0.1, 0, z), v(-0.3, 0, z), (0.08, 0.13))
    c.seg("peduncle", "body3", ["spine", "tail"], v(-0.3, 0, z), v(-0.43, 0, z), (0.035, 0.06))
    c.seg("caudalfin", "peduncle", ["tail"], v(-0.43, 0, z), v(-0.55, 0, z), (0.012, 0.18))
    face(c, "head", mouth=(0.025, 0.04, 0.02), eyes=(0.018, 0.01, 0.018),
         eye_rel=(0.2, 0.85, 0.3), mouth_rel=(1.0, 0.0, -0.3))
    c.seg("pectoralfin_l", "body1", ["limb"], v(0.22, 0.1, z - 0.08), v(0.12, 0.22, z - 0.12),
          (0.05, 0.006))
    c.seg("pelvicfin_l", "body2", ["detail"], v(0.0, 0.06, z - 0.18), v(-0.08, 0.12, z - 0.24),
          (0.035, 0.005))
    c.seg("dorsalfin", "body2", ["detail"], v(0.1, 0, z + 0.2), v(-0.15, 0, z + 0.32),
          (0.006, 0.06))
    c.seg("analfin", "body3", ["detail"], v(-0.15, 0, z - 0.13), v(-0.3, 0, z - 0.2),
          (0.005, 0.04))
    c.mirror()
    return c


@creature
def bird():
    c = Maker("bird", "A crow-sized bird, 0.4 m tall, 1.1 m across the wings: two digitigrade "
              "legs, two three-segment wings held half open, a two-body tail-fan chain, a beak.")
    c.seg("pelvis", None, ["spine"], v(-0.1, 0, 0.2), v(-0.01, 0, 0.24), (0.05, 0.045), axis=0)
    c["pelvis"].joint = None
    c.seg("chest", "pelvis", ["spine"], v(-0.01, 0, 0.24), v(0.08, 0, 0.3), (0.06, 0.055),
          axis=0)
    neck_and_head(c, "chest", v(0.08, 0, 0.3), 70, 2, 0.08, (0.022, 0.022), 0.06,
                  (0.025, 0.022), 0)
    face(c, "head", eyes=(0.006, 0.006, 0.006), eye_rel=(0.2, 0.9, 0.35))
    c.seg("beak", "head", ["mouth"], c["head"].pos + v(0.03, 0, 0), c["head"].pos + v(0.08, 0, -0.01),
          (0.008, 0.006), axis=0)
    tail_chain(c, "pelvis", v(-0.1, 0, 0.2), 2, 0.16, [25, 20], (0.045, 0.055))
    for t in ("tail1", "tail2"):   # a flat fan: wide in y, thin in z
        e = c[t].ext
        c[t].ext = v(e[0], e[1], 0.006)
    c.chain(["humerus_l", "ulna_l", "manus_l"], "chest", [["limb", "wing"]] * 3,
            [v(0.04, 0.05, 0.3), v(0.0, 0.2, 0.33), v(-0.02, 0.36, 0.31), v(-0.1, 0.5, 0.29)],
            [(0.05, 0.008), (0.06, 0.006), (0.07, 0.004)])
    c.leg(["thigh_l", "shank_l", "tarsus_l", "foot_l"], "pelvis", v(-0.04, 0.035, 0.2),
          [(0, 0, 0), (0.35, 0, -0.35), (-0.15, 0, -0.7), (0.0, 0, -1)],
          [0.025, 0.012, 0.007], (0.035, 0.02, 0.004), 0.02)
    c.mirror()
    return c


@creature
def centaur():
    c = quadruped(
        "centaur", "A centaur, 2.15 m tall: a horse body with four legs and a tail chain, a "
        "human torso rising from its chest, two arms with hands.",
        length=1.0, zb=1.15, back_n=3, torso=[(0.2, 0.22), (0.22, 0.25), (0.2, 0.22)],
        hip_drop=0.1, hip_y=0.12,
        hind_profile=[(0, 0, 0), (0.12, 0, -0.35), (-0.12, 0, -0.65), (-0.06, 0, -1)],
        hind_names=["thigh", "gaskin", "cannon", "hoof"],
        fore_profile=[(0, 0, 0), (-0.06, 0, -0.33), (0.0, 0, -0.66), (0.04, 0, -1)],
        fore_names=["foreupper", "forelower", "forecannon", "forehoof"],
        leg_cross=[0.08, 0.06, 0.04], foot_ext=(0.07, 0.055, 0.04), foot_fwd=0.04,
        neck_n=3, neck_len=0.75, neck_pitch=80, neck_names=["waist", "torso", "neck"],
        neck_cross=[(0.13, 0.16), (0.11, 0.14), (0.16, 0.1)],
        head_len=0.21, head_cross=(0.09, 0.08), head_pitch=80, face_kw=None,
        tail=("chain", 3, 0.6, [40, 60, 75], (0.05, 0.035)))
    # A human head sits upright on the neck: an axis-aligned box, face towards +X.
    head = c["head"]
    head.rot = v(1, 0, 0, 0)
    head.ext = v(0.1, 0.08, 0.105)
    head.pos = head.joint + v(0.015, 0, 0.105)
    face(c, "head", mouth=(0.015, 0.03, 0.012), eyes=(0.012, 0.014, 0.012),
         eye_rel=(0.9, 0.45, 0.2), mouth_rel=(1.0, 0.0, -0.5))
    shoulder = c["torso"]
    top = shoulder.joint + (shoulder.pos - shoulder.joint) * 1.7   # near the torso's top
    sh = v(top[0], 0.03, top[2])
    c.chain(["clavicle_l", "upperarm_l", "forearm_l", "hand_l"], "torso",
            [["limb"], ["limb"], ["limb"], ["limb", "grasper"]],
            [sh, sh + v(-0.02, 0.18, 0.0), sh + v(-0.03, 0.24, -0.3), sh + v(0.08, 0.27, -0.55),
             sh + v(0.13, 0.28, -0.7)],
            [0.03, 0.045, 0.038, (0.04, 0.018)])
    c.mirror()
    return c


@creature
def tripod():
    c = Maker("tripod", "A three-legged walker, 1.9 m tall: one leg in front on the "
              "sagittal plane and two behind at 120 degrees, a tall body with three eyes.")
    c.add("hub", None, ["spine"], (0, 0, 1.05), (0.2, 0.2, 0.1))
    c.seg("torso", "hub", ["spine"], v(0, 0, 1.15), v(0, 0, 1.55), (0.15, 0.16))
    c.seg("head", "torso", ["spine", "head"], v(0, 0, 1.55), v(0, 0, 1.9), (0.14, 0.14))
    c.on("mouth", "head", ["mouth"], (1.0, 0, -0.4), (0.02, 0.06, 0.02), push=(0.02, 0, 0))
    c.on("eye", "head", ["eye"], (1.0, 0, 0.5), (0.02, 0.025, 0.025), push=(0.02, 0, 0))
    c.on("eye_l", "head", ["eye"], (0.7, 0.7, 0.3), (0.02, 0.02, 0.02), push=(0.02, 0.02, 0))
    profile = [(0, 0, 0), (0.4, 0, 0.25), (0.9, 0, -1)]
    for suffix, yaw in (("front", 0.0), ("back_l", 120.0)):
        hip = polar(0.17, yaw, 1.0)
        c.leg([f"thigh_{suffix}", f"shin_{suffix}", f"foot_{suffix}"], "hub", hip, profile,
              [0.07, 0.05], (0.12, 0.07, 0.04), 0.06, yaw=yaw)
    c.mirror()
    return c


@creature
def octopus():
    c = Maker("octopus", "An octopus-like creature, 1.7 m across: a mantle and head on "
              "the spine and eight four-segment arms spread on the ground, each tip a "
              "grasper; no feet.")
    c.add("body", None, ["spine", "head"], (0, 0, 0.22), (0.16, 0.15, 0.11))
    c.seg("mantle", "body", ["spine"], v(0, 0, 0.3), v(-0.2, 0, 0.55), (0.16, 0.15), axis=0)
    c.on("eye_l", "body", ["eye"], (0.75, 0.85, 0.6), (0.02, 0.025, 0.025), push=(0, 0.01, 0))
    c.on("beak", "body", ["mouth"], (0.0, 0.0, -1.0), (0.03, 0.03, 0.01), push=(0, 0, 0.02))
    radii = [0.14, 0.32, 0.52, 0.72, 0.92]
    heights = [0.13, 0.045, 0.032, 0.022, 0.014]
    cross = [(0.04, 0.035), (0.03, 0.026), (0.022, 0.018), (0.014, 0.011)]
    for k, yaw in enumerate((22.5, 67.5, 112.5, 157.5)):
        pts = [polar(r, yaw, h) for r, h in zip(radii, heights, strict=True)]
        names = [f"arm{k + 1}a_l", f"arm{k + 1}b_l", f"arm{k + 1}c_l", f"arm{k + 1}tip_l"]
        caps = [["limb"], ["limb"], ["limb"], ["limb", "grasper"]]
        for i, name in enumerate(names):
            a, b = pts[i], pts[i + 1]
            d = b - a
            # Arms lie flat-ish: the box's y axis is the arm's width, turned by the heading.
            rot = qmul(quat_yaw(yaw), quat_between(v(1, 0, 0), rot_z(-yaw, d)))
            length = float(np.linalg.norm(d))
            c.add(name, names[i - 1] if i else "body", caps[i], 0.5 * (a + b),
                  (0.5 * length, cross[i][0], cross[i][1]), joint=a, rot=rot)
    c.mirror()
    return c


def biped_core(c, *, hip_z, hip_y, leg_profile, leg_cross, foot_ext, foot_fwd, leg_names,
               pelvis_ext, ankle_z=None):
    c.add("pelvis", None, ["spine"], (0, 0, hip_z + 0.3 * pelvis_ext[2]), pelvis_ext)
    c.leg([n + "_l" for n in leg_names], "pelvis", v(0, hip_y, hip_z), leg_profile, leg_cross,
          foot_ext, foot_fwd, ankle_z=ankle_z)


def arm(c, parent, names, shoulder, pts, cross, hand_caps=("limb", "grasper")):
    caps = [["limb"]] * (len(names) - 1) + [list(hand_caps)]
    c.chain(names, parent, caps, [np.asarray(shoulder, float)] + [v(*p) for p in pts], cross)


@creature
def twoheaded():
    c = Maker("twoheaded", "A two-headed biped, 2.4 m tall: the spine ends at the chest "
              "and each head hangs off it on its own neck limb (heads not on the spine).")
    biped_core(c, hip_z=1.1, hip_y=0.14, leg_profile=[(0, 0, 0), (0.04, 0, -0.5), (0, 0, -1)],
               leg_cross=[0.1, 0.075], foot_ext=(0.16, 0.07, 0.05), foot_fwd=0.06,
               leg_names=["thigh", "shin", "foot"], pelvis_ext=(0.14, 0.25, 0.12))
    spine_line(c, ["belly", "chest"], "pelvis", [v(0, 0, 1.26), v(0, 0, 1.55), v(0, 0, 1.95)],
               [(0.26, 0.15), (0.34, 0.17)])
    c.seg("neck_l", "chest", ["limb"], v(0, 0.16, 1.95), v(0.03, 0.24, 2.15), (0.06, 0.06))
    c.add("head_l", "neck_l", ["head"], (0.06, 0.25, 2.29), (0.13, 0.11, 0.14),
          joint=(0.03, 0.24, 2.15))
    c.on("jaw_l", "head_l", ["mouth"], (1.0, 0, -0.5), (0.02, 0.045, 0.02), push=(0.02, 0, 0))
    c.on("eye_l", "head_l", ["eye"], (1.0, 0.0, 0.3), (0.015, 0.03, 0.02), push=(0.015, 0, 0))
    arm(c, "chest", ["shoulder_l", "upperarm_l", "forearm_l", "hand_l"], v(0, 0.06, 1.9),
        [(0, 0.36, 1.9), (-0.03, 0.43, 1.5), (0.03, 0.46, 1.13), (0.05, 0.47, 0.92)],
        [0.05, 0.075, 0.06, (0.07, 0.03)])
    c.mirror()
    return c


@creature
def threearmed():
    c = Maker("threearmed", "An asymmetric three-armed biped, 1.9 m tall: two slender arms "
              "on the left, one heavy arm on the right.")
    biped_core(c, hip_z=0.95, hip_y=0.11, leg_profile=[(0, 0, 0), (0.03, 0, -0.5), (0, 0, -1)],
               leg_cross=[0.075, 0.055], foot_ext=(0.13, 0.05, 0.04), foot_fwd=0.05,
               leg_names=["thigh", "shin", "foot"], pelvis_ext=(0.11, 0.18, 0.09))
    spine_line(c, ["belly", "chest", "neck"], "pelvis",
               [v(0, 0, 1.07), v(0, 0, 1.3), v(0.01, 0, 1.58), v(0.03, 0, 1.68)],
               [(0.16, 0.1), (0.2, 0.12), (0.05, 0.05)])
    c.add("head", "neck", ["spine", "head"], (0.05, 0, 1.79), (0.1, 0.085, 0.11),
          joint=(0.03, 0, 1.68))
    face(c, "head", mouth=(0.015, 0.03, 0.012), eyes=(0.012, 0.014, 0.012),
         eye_rel=(0.9, 0.45, 0.2), mouth_rel=(1.0, 0.0, -0.5))
    c.mirror()   # legs and eyes; the arms below are deliberately one-sided
    arm(c, "chest", ["shoulder_top_l", "upperarm_top_l", "forearm_top_l", "hand_top_l"],
        v(0, 0.05, 1.54), [(0, 0.22, 1.54), (0.05, 0.33, 1.3), (0.2, 0.36, 1.18),
                           (0.3, 0.37, 1.15)], [0.03, 0.04, 0.033, (0.015, 0.04)])
    arm(c, "belly", ["shoulder_low_l", "upperarm_low_l", "forearm_low_l", "hand_low_l"],
        v(0, 0.05, 1.25), [(0, 0.2, 1.25), (-0.02, 0.25, 1.02), (0.02, 0.27, 0.8),
                           (0.03, 0.28, 0.66)], [0.03, 0.038, 0.032, (0.04, 0.016)])
    arm(c, "chest", ["shoulder_big_r", "upperarm_big_r", "forearm_big_r", "hand_big_r"],
        v(0, -0.06, 1.48), [(-0.02, -0.3, 1.5), (-0.06, -0.4, 1.12), (0.04, -0.44, 0.78),
                            (0.08, -0.46, 0.58)], [0.06, 0.08, 0.07, (0.09, 0.04)])
    return c


@creature
def longspine():
    c = Maker("longspine", "A tall upright biped, 2.55 m, with a very long S-curved spine of "
              "twelve vertebrae, a neck and a head (fourteen spine bodies).")
    biped_core(c, hip_z=0.92, hip_y=0.1, leg_profile=[(0, 0, 0), (0.05, 0, -0.5), (0, 0, -1)],
               leg_cross=[0.06, 0.045], foot_ext=(0.12, 0.045, 0.035), foot_fwd=0.05,
               leg_names=["thigh", "shin", "foot"], pelvis_ext=(0.09, 0.15, 0.07))
    n = 12
    pts = []
    for i in range(n + 1):
        t = i / n
        pts.append(v(0.06 * math.sin(2 * math.pi * t), 0, 1.0 + 1.2 * t))
    names = [f"vertebra{i + 1}" for i in range(n)]
    spine_line(c, names, "pelvis", pts,
               [(0.12 + 0.04 * math.sin(math.pi * i / n), 0.07) for i in range(n)])
    top = pts[-1]
    c.seg("neck", names[-1], ["spine"], top, top + v(0.04, 0, 0.14), (0.04, 0.04))
    c.seg("head", "neck", ["spine", "head"], top + v(0.04, 0, 0.14), top + v(0.16, 0, 0.3),
          (0.07, 0.08), axis=0)
    face(c, "head", mouth=(0.015, 0.03, 0.012), eyes=(0.012, 0.014, 0.012),
         eye_rel=(0.9, 0.45, 0.3), mouth_rel=(1.0, 0.0, -0.5))
    sh = pts[9]
    arm(c, names[9], ["upperarm_l", "forearm_l", "hand_l"], sh + v(0, 0.14, 0),
        [sh + v(-0.04, 0.2, -0.4), sh + v(0.02, 0.22, -0.75), sh + v(0.04, 0.23, -0.92)],
        [0.04, 0.035, (0.04, 0.016)])
    c.mirror()
    return c


@creature
def hopper():
    c = Maker("hopper", "A one-legged hopper, 1.4 m tall: one thick digitigrade leg on the "
              "sagittal plane, a short balancing tail chain, two small arms.")
    c.add("pelvis", None, ["spine"], (0, 0, 0.8), (0.14, 0.14, 0.1))
    c.leg(["thigh", "shin", "metatarsus", "foot"], "pelvis", v(0, 0, 0.72),
          [(0, 0, 0), (0.22, 0, -0.4), (-0.08, 0, -0.8), (0.0, 0, -1)], [0.08, 0.06, 0.045],
          (0.16, 0.08, 0.04), 0.08)
    c.seg("torso", "pelvis", ["spine"], v(0, 0, 0.9), v(0.04, 0, 1.2), (0.12, 0.17))
    c.seg("head", "torso", ["spine", "head"], v(0.04, 0, 1.2), v(0.08, 0, 1.4), (0.1, 0.09))
    face(c, "head", mouth=(0.02, 0.04, 0.015), eyes=(0.015, 0.015, 0.015),
         eye_rel=(0.9, 0.5, 0.3), mouth_rel=(1.0, 0.0, -0.3))
    arm(c, "torso", ["arm_l", "hand_l"], v(0.04, 0.14, 1.15),
        [(0.12, 0.2, 1.0), (0.2, 0.2, 0.94)], [0.03, (0.03, 0.015)])
    tail_chain(c, "pelvis", v(-0.14, 0, 0.8), 2, 0.4, [20, 35], (0.05, 0.035))
    c.mirror()
    return c


@creature
def forkstrider():
    c = Maker("forkstrider", "A biped whose legs branch: each thigh forks at the knee into a "
              "front shin and a back shin, each ending in a foot (four feet, two hips).")
    c.add("pelvis", None, ["spine"], (0, 0, 1.05), (0.13, 0.2, 0.1))
    c.seg("chest", "pelvis", ["spine"], v(0, 0, 1.15), v(0.02, 0, 1.6), (0.12, 0.17))
    c.seg("head", "chest", ["spine", "head"], v(0.02, 0, 1.6), v(0.1, 0, 1.84), (0.1, 0.09))
    face(c, "head", mouth=(0.02, 0.04, 0.015), eyes=(0.015, 0.015, 0.015),
         eye_rel=(0.9, 0.5, 0.3), mouth_rel=(1.0, 0.0, -0.3))
    c.seg("thigh_l", "pelvis", ["limb"], v(0, 0.14, 1.0), v(0.0, 0.19, 0.62), 0.07)
    knee = v(0.0, 0.19, 0.62)
    for part, dx in (("front", 0.3), ("back", -0.3)):
        ankle = v(dx, 0.21, 0.08)
        c.seg(f"shin{part}_l", "thigh_l", ["limb"], knee, ankle, 0.045)
        c.foot(f"foot{part}_l", f"shin{part}_l", ankle, 0.05, (0.11, 0.05, 0.04))
    arm(c, "chest", ["upperarm_l", "forearm_l", "hand_l"], v(0.02, 0.16, 1.55),
        [(0.0, 0.25, 1.25), (0.06, 0.27, 1.0), (0.09, 0.28, 0.88)], [0.04, 0.035, (0.035, 0.015)])
    c.mirror()
    return c


@creature
def maw():
    c = Maker("maw", "A headless four-legged maw beast, 1.4 m tall: its mouth sits "
              "directly on the front spine body, its eyes on stalks, spikes along its back.")
    z = 0.75
    c.add("rump", None, ["spine"], (-0.4, 0, z), (0.15, 0.26, 0.28))
    spine_line(c, ["middle", "front"], "rump", [v(-0.25, 0, z), v(0.05, 0, z + 0.02),
                                                 v(0.35, 0, z)], [(0.3, 0.32), (0.28, 0.3)])
    c.on("mouth", "front", ["mouth"], (1.0, 0.0, -0.1), (0.04, 0.22, 0.12), push=(0.04, 0, 0))
    c.seg("eyestalk_l", "middle", ["limb"], v(-0.02, 0.15, z + 0.3), v(0.13, 0.25, z + 0.55),
          0.02)
    c.add("eye_l", "eyestalk_l", ["eye"], (0.15, 0.265, z + 0.58), (0.04, 0.04, 0.04),
          joint=(0.13, 0.25, z + 0.55))
    for i, body in enumerate(("rump", "middle", "front")):
        c.on(f"spike{i + 1}", body, ["spike"], (0.0, 0, 1.0), (0.04, 0.03, 0.09),
             push=(0, 0, 0.08))
    profile_h = [(0, 0, 0), (0.1, 0.1, -0.45), (-0.05, 0.18, -1)]
    c.leg(["hindthigh_l", "hindshin_l", "hindfoot_l"], "rump", v(-0.42, 0.2, z - 0.15),
          profile_h, [0.08, 0.06], (0.1, 0.08, 0.04), 0.04)
    c.leg(["forethigh_l", "foreshin_l", "forefoot_l"], "front", v(0.25, 0.22, z - 0.15),
          [(0, 0, 0), (-0.1, 0.1, -0.45), (0.05, 0.18, -1)], [0.08, 0.06], (0.1, 0.08, 0.04),
          0.04)
    c.mirror()
    return c


@creature
def prehensile():
    c = quadruped(
        "prehensile", "A monkey-like quadruped, 0.95 m tall at the tail tip, whose six-body "
        "tail chain curls up and ends in a grasper.",
        length=0.45, zb=0.45, back_n=3, torso=[(0.09, 0.08), (0.09, 0.085), (0.1, 0.09)],
        hip_drop=0.04, hip_y=0.07,
        hind_profile=[(0, 0, 0), (0.2, 0, -0.45), (-0.05, 0, -1)],
        hind_names=["thigh", "shin", "hindfoot"],
        fore_profile=[(0, 0, 0), (-0.08, 0, -0.5), (0.03, 0, -1)],
        fore_names=["upperarm", "forearm", "forehand"],
        leg_cross=[0.035, 0.028], foot_ext=(0.06, 0.03, 0.015), foot_fwd=0.035,
        neck_n=1, neck_len=0.1, neck_pitch=40, neck_cross=(0.04, 0.045),
        head_len=0.14, head_cross=(0.07, 0.065), head_pitch=0,
        face_kw=dict(mouth=(0.015, 0.03, 0.012), eyes=(0.012, 0.012, 0.012),
                     ears=(0.01, 0.02, 0.025), eye_rel=(0.9, 0.45, 0.3),
                     mouth_rel=(1.0, 0.0, -0.5), ear_rel=(-0.2, 1.0, 0.3)))
    tail_chain(c, "pelvis", v(-0.225, 0, 0.47), 6, 0.72, [-20, -45, -70, -95, -130, -165],
               (0.025, 0.014), caps=("tail", "limb"), last_caps=("tail", "grasper"))
    c.mirror()
    return c


@creature
def crawler():
    c = Maker("crawler", "A prone crawling salamander, 1 m long and only 0.11 m tall: "
              "sprawling legs, a flat head, a five-body tail on the spine resting on the "
              "ground.")
    z = 0.07
    pts = [v(-0.2, 0, z), v(-0.05, 0, z), v(0.1, 0, z), v(0.2, 0, z)]
    c.add("pelvis", None, ["spine"], 0.5 * (pts[0] + pts[1]), (0.075, 0.06, 0.035))
    spine_line(c, ["belly", "chest"], "pelvis", pts[1:], [(0.065, 0.04), (0.06, 0.036)])
    c.seg("head", "chest", ["spine", "head"], pts[3], v(0.32, 0, 0.055), (0.05, 0.028), axis=0)
    face(c, "head", eyes=(0.008, 0.008, 0.008), eye_rel=(0.2, 0.8, 0.9))
    c.on("jaw", "head", ["mouth"], (0.4, 0.0, -1.0), (0.05, 0.04, 0.006), push=(0, 0, 0.006))
    tpts = [v(-0.2, 0, z)]
    for dx, zz in ((0.1, 0.05), (0.1, 0.036), (0.1, 0.027), (0.09, 0.02), (0.09, 0.014)):
        tpts.append(v(tpts[-1][0] - dx, 0, zz))
    spine_line(c, [f"tail{i + 1}" for i in range(5)], "pelvis", tpts,
               [(0.045 - 0.007 * i, 0.028 - 0.004 * i) for i in range(5)],
               caps=("spine", "tail"))
    profile = [(0, 0, 0), (0.0, 1.6, 0.2), (0.2, 2.3, -1)]
    c.leg(["hindthigh_l", "hindshin_l", "hindfoot_l"], "pelvis", v(-0.13, 0.05, z - 0.01),
          profile, [0.018, 0.012], (0.03, 0.02, 0.008), 0.015, foot_yaw=-30)
    c.leg(["forethigh_l", "foreshin_l", "forefoot_l"], "chest", v(0.15, 0.05, z - 0.01),
          [(0, 0, 0), (0.0, 1.5, 0.2), (0.3, 2.0, -1)], [0.016, 0.011], (0.028, 0.018, 0.008),
          0.014, foot_yaw=30)
    c.mirror()
    return c


@creature
def mixedlegs():
    c = Maker("mixedlegs", "A six-legged stalker with a sloping back: two short front legs "
              "and four long rear legs (leg lengths differ 2.5x).")
    pts = [v(-0.65, 0, 1.05), v(-0.3, 0, 0.95), v(0.05, 0, 0.8), v(0.35, 0, 0.45)]
    c.seg("rear", None, ["spine"], pts[0], pts[1], (0.18, 0.12), axis=0)
    c["rear"].joint = None
    c.seg("middle", "rear", ["spine"], pts[1], pts[2], (0.2, 0.14), axis=0)
    c.seg("front", "middle", ["spine"], pts[2], pts[3], (0.17, 0.12), axis=0)
    c.seg("head", "front", ["spine", "head"], pts[3], pts[3] + v(0.26, 0, 0.04), (0.1, 0.1),
          axis=0)
    face(c, "head", mouth=(0.03, 0.06, 0.02), eyes=(0.02, 0.02, 0.02),
         eye_rel=(0.7, 0.6, 0.6), mouth_rel=(1.0, 0.0, -0.4))
    long_profile = [(0, 0, 0), (0.15, 0.05, -0.45), (-0.12, 0.1, -0.85), (-0.1, 0.12, -1)]
    c.leg(["rearthigh_l", "rearshin_l", "rearshank_l", "rearfoot_l"], "rear",
          v(-0.55, 0.15, 0.93), long_profile, [0.07, 0.05, 0.04], (0.09, 0.06, 0.035), 0.04)
    c.leg(["midthigh_l", "midshin_l", "midshank_l", "midfoot_l"], "middle",
          v(-0.15, 0.17, 0.8), long_profile, [0.07, 0.05, 0.04], (0.09, 0.06, 0.035), 0.04)
    c.leg(["frontthigh_l", "frontshin_l", "frontfoot_l"], "front", v(0.22, 0.15, 0.42),
          [(0, 0, 0), (-0.1, 0.15, -0.5), (0.05, 0.2, -1)], [0.06, 0.045], (0.08, 0.05, 0.03),
          0.04)
    c.mirror()
    return c


@creature
def kangaroo():
    c = Maker("kangaroo", "A kangaroo, 1.6 m tall: long feet, small arms with hands, big "
              "ears, and a heavy five-body tail chain whose tip rests on the ground.")
    c.seg("pelvis", None, ["spine"], v(-0.08, 0, 0.6), v(0.0, 0, 0.75), (0.15, 0.14), axis=2)
    c["pelvis"].joint = None
    c.seg("belly", "pelvis", ["spine"], v(0.0, 0, 0.75), v(0.08, 0, 1.0), (0.14, 0.15), axis=2)
    c.seg("chest", "belly", ["spine"], v(0.08, 0, 1.0), v(0.12, 0, 1.22), (0.12, 0.12), axis=2)
    c.seg("neck", "chest", ["spine"], v(0.12, 0, 1.22), v(0.16, 0, 1.33), (0.05, 0.05), axis=2)
    c.seg("head", "neck", ["spine", "head"], v(0.16, 0, 1.35), v(0.36, 0, 1.3), (0.065, 0.07),
          axis=0)
    c["head"].joint = v(0.16, 0, 1.33)
    face(c, "head", mouth=(0.02, 0.035, 0.015), eyes=(0.012, 0.012, 0.012),
         ears=(0.02, 0.03, 0.08), eye_rel=(-0.1, 0.85, 0.6), ear_rel=(-0.7, 0.6, 1.0))
    arm(c, "chest", ["upperarm_l", "forearm_l", "hand_l"], v(0.16, 0.1, 1.15),
        [(0.22, 0.13, 1.0), (0.3, 0.14, 0.92), (0.35, 0.14, 0.88)],
        [0.03, 0.025, (0.015, 0.02)])
    c.leg(["thigh_l", "shin_l", "foot_l"], "pelvis", v(-0.02, 0.11, 0.62),
          [(0, 0, 0), (0.35, 0, -0.35), (-0.2, 0, -1)], [0.08, 0.045], (0.17, 0.045, 0.025),
          0.08)
    pelvis = c["pelvis"]   # the tail leaves the back of the tilted pelvis box
    base = pelvis.pos + qrot(pelvis.rot, v(-0.8 * pelvis.ext[0], 0, -0.6 * pelvis.ext[2]))
    tail_chain(c, "pelvis", base, 5, 1.0, [55, 50, 40, 20, 5], (0.07, 0.03))
    c.mirror()
    return c


@creature
def gorilla():
    c = Maker("gorilla", "A knuckle-walking ape, 1.4 m tall on all fours: its hands are "
              "both graspers and feet, its head hangs off the chest (not on the spine).")
    c.add("pelvis", None, ["spine"], (-0.2, 0, 0.76), (0.12, 0.2, 0.1),
          rot=quat_between(v(0, 0, 1), v(0.5, 0, 1)))
    c.seg("belly", "pelvis", ["spine"], v(-0.16, 0, 0.85), v(0.0, 0, 1.05), (0.12, 0.22),
          axis=2)
    c.seg("chest", "belly", ["spine"], v(0.0, 0, 1.05), v(0.2, 0, 1.22), (0.14, 0.27), axis=2)
    c.seg("head", "chest", ["head"], v(0.2, 0, 1.22), v(0.42, 0, 1.27), (0.11, 0.12), axis=0)
    face(c, "head", mouth=(0.03, 0.05, 0.03), eyes=(0.015, 0.015, 0.015),
         eye_rel=(0.9, 0.45, 0.4), mouth_rel=(1.0, 0.0, -0.5))
    c.seg("clavicle_l", "chest", ["limb"], v(0.14, 0.05, 1.17), v(0.14, 0.3, 1.15), 0.05)
    c.leg(["upperarm_l", "forearm_l", "hand_l"], "clavicle_l", v(0.14, 0.3, 1.15),
          [(0, 0, 0), (0.02, 0.03, -0.5), (0.1, 0.02, -1)], [0.07, 0.06], (0.06, 0.06, 0.035),
          0.03, caps=("limb",), foot_caps=("grasper", "foot"))
    c.leg(["thigh_l", "shin_l", "foot_l"], "pelvis", v(-0.25, 0.14, 0.68),
          [(0, 0, 0), (0.2, 0.03, -0.5), (0.05, 0.04, -1)], [0.08, 0.06], (0.12, 0.06, 0.035),
          0.05)
    c.mirror()
    return c


@creature
def dragon():
    c = quadruped(
        "dragon", "A winged dragon, 2 m tall with a 4.6 m wingspan: four legs, two three-segment wings, a "
        "four-vertebra neck, horns, back spikes and a six-body tail chain.",
        length=1.3, zb=1.0, back_n=4, torso=[(0.22, 0.2), (0.26, 0.24), (0.26, 0.24),
                                               (0.24, 0.22)],
        hip_drop=0.1, hip_y=0.16, arch=0.05,
        hind_profile=[(0, 0, 0), (0.2, 0.05, -0.4), (-0.12, 0.08, -0.8), (-0.05, 0.1, -1)],
        hind_names=["thigh", "shin", "shank", "hindfoot"],
        fore_profile=[(0, 0, 0), (-0.1, 0.05, -0.45), (0.05, 0.08, -0.85), (0.08, 0.1, -1)],
        fore_names=["upperarm", "forearm", "wrist", "forefoot"],
        leg_cross=[0.09, 0.07, 0.05], foot_ext=(0.12, 0.08, 0.04), foot_fwd=0.06,
        neck_n=4, neck_len=0.9, neck_pitch=50,
        neck_cross=[(0.13, 0.13), (0.11, 0.11), (0.1, 0.1), (0.09, 0.09)],
        head_len=0.5, head_cross=(0.11, 0.1), head_pitch=-15,
        face_kw=dict(mouth=(0.06, 0.06, 0.025), eyes=(0.02, 0.02, 0.02),
                     eye_rel=(0.0, 0.9, 0.7), mouth_rel=(0.9, 0.0, -0.6)),
        tail=("chain", 6, 1.8, [10, 8, 5, 3, 0, -5], (0.09, 0.03)))
    c.on("horn_l", "head", ["spike"], (-0.7, 0.6, 1.0), (0.12, 0.02, 0.02), push=(-0.1, 0, 0.03),
         rot=quat_between(v(1, 0, 0), v(1, 0, -0.4)))
    for i, body in enumerate(("pelvis", "back1", "back2", "chest")):
        c.on(f"spike{i + 1}", body, ["spike"], (0, 0, 1.0), (0.05, 0.02, 0.1), push=(0, 0, 0.09))
    chest = c["chest"]
    sh = chest.pos + v(-0.05, 0.18, 0.2)
    c.chain(["winghumerus_l", "wingulna_l", "wingfinger_l"], "chest", [["limb", "wing"]] * 3,
            [sh, sh + v(-0.15, 0.55, 0.45), sh + v(-0.3, 1.25, 0.6), sh + v(-0.7, 1.95, 0.55)],
            [(0.18, 0.02), (0.26, 0.015), (0.32, 0.01)])
    c.mirror()
    return c


@creature
def crab():
    c = Maker("crab", "A crab, 1.15 m across: eight walking legs splayed sideways, two "
              "big claws forward, eyes on stalks, a mouth on the carapace.")
    z = 0.2
    c.add("carapace", None, ["spine", "head"], (0, 0, z), (0.14, 0.2, 0.06))
    c.seg("abdomen", "carapace", ["spine"], v(-0.1, 0, z - 0.04), v(-0.2, 0, z - 0.07),
          (0.09, 0.015), axis=0)
    c.on("mouth", "carapace", ["mouth"], (1.0, 0.0, -0.3), (0.015, 0.05, 0.02),
         push=(0.015, 0, 0))
    c.seg("eyestalk_l", "carapace", ["limb"], v(0.12, 0.06, z + 0.04), v(0.15, 0.07, z + 0.1),
          0.008)
    c.add("eye_l", "eyestalk_l", ["eye"], (0.152, 0.071, z + 0.113), (0.012, 0.012, 0.012),
          joint=(0.15, 0.07, z + 0.1))
    profile = [(0, 0, 0), (0.0, 0.6, 0.55), (0.0, 1.55, 0.15), (0.0, 2.1, -1)]
    for k, (x, yaw) in enumerate(((0.09, 70), (0.03, 85), (-0.03, 100), (-0.09, 115))):
        c.leg([f"merus{k + 1}_l", f"carpus{k + 1}_l", f"propodus{k + 1}_l", f"dactyl{k + 1}_l"],
              "carapace", v(x, 0.18, z - 0.02), [(dx, dy, dz) for dx, dy, dz in profile],
              [0.018, 0.014, 0.01], (0.025, 0.008, 0.005), 0.018, yaw=yaw - 90, foot_yaw=yaw)
    c.chain(["clawarm_l", "clawwrist_l", "claw_l"], "carapace",
            [["limb"], ["limb"], ["limb", "grasper"]],
            [v(0.12, 0.13, z - 0.02), v(0.25, 0.26, z + 0.0), v(0.36, 0.2, z - 0.03),
             v(0.5, 0.13, z - 0.06)], [0.03, 0.035, (0.06, 0.035)])
    c.mirror()
    return c


@creature
def minimal():
    c = Maker("minimal", "The smallest biped that still has every part the gaits need: "
              "eight bodies (pelvis, chest, head, one eye, two thighs, two feet).")
    c.add("pelvis", None, ["spine"], (0, 0, 0.62), (0.1, 0.15, 0.08))
    c.seg("chest", "pelvis", ["spine"], v(0, 0, 0.7), v(0, 0, 1.0), (0.1, 0.13))
    c.add("head", "chest", ["spine", "head", "mouth"], (0.03, 0, 1.12), (0.11, 0.1, 0.12),
          joint=(0, 0, 1.0))
    c.on("eye", "head", ["eye"], (1.0, 0.0, 0.35), (0.02, 0.04, 0.03), push=(0.02, 0, 0))
    c.leg(["thigh_l", "foot_l"], "pelvis", v(0, 0.09, 0.58), [(0, 0, 0), (0.02, 0, -1)],
          [0.06], (0.12, 0.06, 0.04), 0.05)
    c.mirror()
    return c


@creature
def mantis():
    c = Maker("mantis", "A praying mantis, 0.3 m tall: four walking legs, a raised "
              "prothorax carrying two folded raptorial arms that grasp, antennae.")
    z = 0.1
    c.add("metathorax", None, ["spine"], (-0.02, 0, z), (0.03, 0.018, 0.016))
    c.seg("abdomen", "metathorax", ["spine"], v(-0.05, 0, z), v(-0.25, 0, z + 0.03),
          (0.026, 0.02), axis=0)
    c.seg("mesothorax", "metathorax", ["spine"], v(0.01, 0, z), v(0.05, 0, z + 0.01),
          (0.016, 0.015), axis=0)
    c.seg("prothorax", "mesothorax", ["spine"], v(0.05, 0, z + 0.01), v(0.12, 0, z + 0.15),
          (0.012, 0.011))
    c.seg("head", "prothorax", ["spine", "head"], v(0.12, 0, z + 0.15), v(0.16, 0, z + 0.14),
          (0.018, 0.03), axis=0)
    face(c, "head", mouth=(0.006, 0.008, 0.006), eyes=(0.008, 0.008, 0.008),
         eye_rel=(0.3, 1.0, 0.5), mouth_rel=(1.0, 0.0, -0.6))
    c.on("antenna_l", "head", ["detail"], (0.8, 0.4, 1.0), (0.04, 0.0012, 0.0012),
         push=(0.03, 0.008, 0.025), rot=qmul(quat_yaw(15), quat_between(v(1, 0, 0),
                                                                        v(1, 0, 0.8))))
    for tag, body, x, yaw in (("mid", "mesothorax", 0.03, 25), ("hind", "metathorax", -0.02,
                                                                -35)):
        c.leg([f"{tag}coxa_l", f"{tag}femur_l", f"{tag}tibia_l", f"{tag}tarsus_l"], body,
              v(x, 0.012, z - 0.01), [(0, 0, 0), (0, 0.2, -0.05), (0, 0.9, 0.45), (0, 1.5, -1)],
              [0.004, 0.0035, 0.0025], (0.01, 0.002, 0.002), 0.006, yaw=yaw, foot_yaw=90 + yaw)
    base = v(0.11, 0.01, z + 0.12)
    c.chain(["raptorcoxa_l", "raptorfemur_l", "raptortibia_l"], "prothorax",
            [["limb"], ["limb"], ["limb", "grasper"]],
            [base, base + v(0.04, 0.015, -0.05), base + v(0.06, 0.02, 0.03),
             base + v(0.04, 0.02, -0.02)], [0.006, (0.009, 0.006), 0.004])
    c.mirror()
    return c


@creature
def trex():
    c = Maker("trex", "A tyrannosaur, 4 m tall and 9 m long: a prone biped whose six-body tail is part "
              "of the spine, a huge head with a jaw, tiny two-body arms.")
    z = 2.9
    c.add("pelvis", None, ["spine"], (0, 0, z), (0.5, 0.35, 0.45))
    spine_line(c, ["belly", "chest"], "pelvis", [v(0.5, 0, z), v(1.2, 0, z + 0.1),
                                                 v(1.8, 0, z + 0.25)],
               [(0.45, 0.6), (0.4, 0.5)])
    neck_and_head(c, "chest", v(1.8, 0, z + 0.25), 40, 2, 0.8, [(0.28, 0.3), (0.25, 0.25)],
                  1.4, (0.3, 0.32), -10)
    face(c, "head", mouth=(0.55, 0.26, 0.1), eyes=(0.05, 0.05, 0.05),
         eye_rel=(-0.3, 0.9, 0.7), mouth_rel=(0.25, 0.0, -1.0))
    tpts = [v(-0.5, 0, z + 0.05)]
    for dx, dz in ((0.8, -0.05), (0.8, -0.15), (0.8, -0.2), (0.75, -0.25), (0.7, -0.3),
                   (0.7, -0.3)):
        tpts.append(tpts[-1] + v(-dx, 0, dz))
    spine_line(c, [f"tail{i + 1}" for i in range(6)], "pelvis", tpts,
               [(0.32 - 0.045 * i, 0.38 - 0.055 * i) for i in range(6)], caps=("spine", "tail"))
    c.leg(["thigh_l", "shin_l", "metatarsus_l", "foot_l"], "pelvis", v(0.1, 0.33, z - 0.2),
          [(0, 0, 0), (0.25, 0.02, -0.4), (-0.08, 0.03, -0.8), (0.0, 0.03, -1)],
          [0.3, 0.2, 0.13], (0.45, 0.2, 0.1), 0.25)
    arm(c, "chest", ["arm_l", "hand_l"], v(1.65, 0.3, z - 0.1),
        [(1.85, 0.35, z - 0.35), (2.0, 0.34, z - 0.45)], [0.07, (0.05, 0.03)])
    c.mirror()
    return c


@creature
def spikebeast():
    c = quadruped(
        "spikebeast", "An armoured 80-body beast: a low five-body back, short neck, "
        "clubbed seven-body tail chain and 51 spikes (the largest creature file).",
        length=2.0, zb=1.0, back_n=5, torso=[(0.45, 0.3), (0.55, 0.38), (0.6, 0.4),
                                               (0.55, 0.38), (0.45, 0.32)],
        hip_drop=0.15, hip_y=0.35, arch=0.1,
        hind_profile=[(0, 0, 0), (0.1, 0.05, -0.5), (-0.02, 0.08, -1)],
        hind_names=["thigh", "shin", "hindfoot"],
        fore_profile=[(0, 0, 0), (-0.06, 0.05, -0.5), (0.03, 0.08, -1)],
        fore_names=["upperarm", "forearm", "forefoot"],
        leg_cross=[0.15, 0.12], foot_ext=(0.16, 0.14, 0.05), foot_fwd=0.05,
        neck_n=2, neck_len=0.4, neck_pitch=10, neck_cross=[(0.28, 0.25), (0.24, 0.22)],
        head_len=0.5, head_cross=(0.25, 0.2), head_pitch=-20,
        face_kw=dict(mouth=(0.06, 0.14, 0.05), eyes=(0.03, 0.03, 0.03),
                     eye_rel=(0.3, 0.95, 0.5), mouth_rel=(1.0, 0.0, -0.5)))
    tail_chain(c, "pelvis", v(-1.0, 0, 1.0), 6, 2.0, [10, 12, 10, 8, 5, 3], (0.18, 0.08))
    c.seg("tailclub", "tail6", ["tail", "spike"], c["tail6"].pos + qrot(c["tail6"].rot,
          v(c["tail6"].ext[0], 0, 0)), c["tail6"].pos + qrot(c["tail6"].rot,
          v(c["tail6"].ext[0] + 0.4, 0, 0)), (0.2, 0.14))
    backs = ["pelvis", "back1", "back2", "back3", "chest"]
    for i, b in enumerate(backs):
        c.on(f"backspike{i + 1}", b, ["spike"], (0, 0, 1.0), (0.06, 0.04, 0.16), push=(0, 0, 0.15))
        c.on(f"ridgespike{i + 1}_l", b, ["spike"], (0.0, 0.6, 0.9), (0.05, 0.04, 0.12),
             push=(0, 0.02, 0.1), rot=quat_between(v(0, 0, 1), v(0, 0.5, 1)))
        c.on(f"flankspike{i + 1}_l", b, ["spike"], (0.0, 1.0, 0.1), (0.05, 0.12, 0.04),
             push=(0, 0.11, 0))
    for i in (1, 2):
        c.on(f"neckspike{i}", f"neck{i}", ["spike"], (0, 0, 1.0), (0.04, 0.03, 0.1),
             push=(0, 0, 0.09))
        c.on(f"neckspike{i}_l", f"neck{i}", ["spike"], (0, 1.0, 0.3), (0.04, 0.08, 0.03),
             push=(0, 0.07, 0))
    c.on("horn_l", "head", ["spike"], (-0.8, 0.8, 0.8), (0.04, 0.04, 0.12), push=(0, 0.03, 0.1),
         rot=quat_between(v(0, 0, 1), v(-0.5, 0.4, 1)))
    for i in range(6):
        c.on(f"tailspike{i + 1}_l", f"tail{i + 1}", ["spike"], (0, 1.0, 0.3),
             (0.04, 0.1, 0.03), push=(0, 0.09, 0))
    for i in (3,):
        c.on(f"tailridge{i}", f"tail{i}", ["spike"], (0, 0, 1.0), (0.04, 0.03, 0.09),
             push=(0, 0, 0.08))
    for leg in ("shin", "forearm"):
        c.on(f"{leg}spike_l", f"{leg}_l", ["spike"], (0, 1.0, 0.0), (0.03, 0.07, 0.03),
             push=(0, 0.06, 0))
    c.mirror()
    return c


@creature
def elephant():
    c = quadruped(
        "elephant", "An elephant, 3 m tall: straight pillar legs, big flat ears, two tusks "
        "and a five-body trunk chain hanging off the head whose tip is a grasper.",
        length=1.9, zb=2.2, back_n=3, torso=[(0.5, 0.55), (0.6, 0.65), (0.55, 0.6)],
        hip_drop=0.25, hip_y=0.3,
        hind_profile=[(0, 0, 0), (0.04, 0, -0.5), (0.0, 0, -1)],
        hind_names=["thigh", "shin", "hindfoot"],
        fore_profile=[(0, 0, 0), (-0.02, 0, -0.5), (0.0, 0, -1)],
        fore_names=["upperarm", "forearm", "forefoot"],
        leg_cross=[0.2, 0.16], foot_ext=(0.2, 0.18, 0.05), foot_fwd=0.03,
        neck_n=1, neck_len=0.35, neck_pitch=20, neck_cross=(0.4, 0.4),
        head_len=0.75, head_cross=(0.4, 0.45), head_pitch=-10,
        face_kw=dict(mouth=(0.08, 0.15, 0.06), eyes=(0.04, 0.04, 0.04), ears=(0.05, 0.45, 0.5),
                     eye_rel=(0.3, 1.0, 0.3), mouth_rel=(0.55, 0.0, -1.0),
                     ear_rel=(-0.6, 1.0, 0.2)),
        tail=("chain", 2, 0.7, [75, 85], (0.05, 0.03)))
    head = c["head"]
    tip = head.pos + qrot(head.rot, v(head.ext[0], 0, -0.3 * head.ext[2]))
    pts = [tip, tip + v(0.2, 0, -0.3), tip + v(0.3, 0, -0.7), tip + v(0.32, 0, -1.1),
           tip + v(0.3, 0, -1.45), tip + v(0.36, 0, -1.7)]
    c.chain(["trunk1", "trunk2", "trunk3", "trunk4", "trunktip"], "head",
            [["limb"], ["limb"], ["limb"], ["limb"], ["limb", "grasper"]], pts,
            [0.13, 0.11, 0.09, 0.075, 0.06])
    c.seg("tusk_l", "head", ["spike"], head.pos + qrot(head.rot, v(0.7 * head.ext[0], 0.3,
                                                                   -0.8 * head.ext[2])),
          head.pos + qrot(head.rot, v(1.6 * head.ext[0], 0.34, -1.6 * head.ext[2])), 0.05)
    c.mirror()
    return c


@creature
def jellyfish():
    c = Maker("jellyfish", "A jellyfish, 1.9 m tall, hovering 0.5 m up: a bell on the spine, a mouth "
              "under it on the spine, eight three-body tentacle chains; no feet, no head.")
    z = 1.5
    c.add("bell", None, ["spine"], (0, 0, z + 0.2), (0.3, 0.3, 0.16))
    c.seg("manubrium", "bell", ["spine"], v(0, 0, z + 0.04), v(0, 0, z - 0.16), (0.07, 0.07))
    c.on("mouth", "manubrium", ["mouth"], (0, 0, -1.0), (0.05, 0.05, 0.02), push=(0, 0, -0.02))
    for k, heading in enumerate((0.0, 45.0, 90.0, 135.0, 180.0)):
        suffix = "_l" if 0.0 < heading < 180.0 else ""
        tag = {0.0: "front", 180.0: "back"}.get(heading, str(k))
        r0 = 0.26
        pts = [polar(r0, heading, z + 0.06), polar(r0 + 0.05, heading, z - 0.3),
               polar(r0 + 0.02, heading, z - 0.65), polar(r0 + 0.07, heading, z - 1.0)]
        c.chain([f"tentacle{tag}a{suffix}", f"tentacle{tag}b{suffix}", f"tentacle{tag}c{suffix}"],
                "bell", ["detail"], pts, [0.02, 0.016, 0.012])
    c.mirror()
    return c


@creature
def bat():
    c = Maker("bat", "A bat standing on its hind legs, 0.3 m tall, wings spread: each "
              "wing three segments with a clawed thumb that grasps, big ears, a tail "
              "membrane.")
    c.seg("pelvis", None, ["spine"], v(-0.01, 0, 0.13), v(0, 0, 0.17), (0.03, 0.025), axis=2)
    c["pelvis"].joint = None
    c.seg("chest", "pelvis", ["spine"], v(0, 0, 0.17), v(0.01, 0, 0.24), (0.035, 0.03), axis=2)
    c.seg("head", "chest", ["spine", "head"], v(0.01, 0, 0.24), v(0.05, 0, 0.27),
          (0.022, 0.022), axis=0)
    face(c, "head", mouth=(0.006, 0.01, 0.005), eyes=(0.004, 0.004, 0.004),
         ears=(0.004, 0.012, 0.02), eye_rel=(0.9, 0.5, 0.3), mouth_rel=(1.0, 0.0, -0.5),
         ear_rel=(-0.3, 0.6, 1.0))
    sh = v(0.01, 0.025, 0.23)
    c.chain(["humerus_l", "radius_l", "finger_l"], "chest", [["limb", "wing"]] * 3,
            [sh, sh + v(-0.02, 0.07, 0.03), sh + v(-0.03, 0.16, 0.05), sh + v(-0.08, 0.28, 0.0)],
            [(0.02, 0.004), (0.035, 0.003), (0.05, 0.002)])
    wrist = sh + v(-0.03, 0.16, 0.05)
    c.seg("thumb_l", "radius_l", ["limb", "grasper"], wrist, wrist + v(0.02, 0.005, 0.015),
          0.003)
    c.leg(["thigh_l", "shin_l", "foot_l"], "pelvis", v(-0.01, 0.018, 0.135),
          [(0, 0, 0), (0.1, 0.15, -0.5), (0.0, 0.2, -1)], [0.007, 0.005],
          (0.012, 0.006, 0.003), 0.006)
    c.seg("uropatagium", "pelvis", ["tail"], v(-0.03, 0, 0.135), v(-0.08, 0, 0.07),
          (0.005, 0.025), axis=0)
    c.mirror()
    return c


@creature
def scorpion():
    c = Maker("scorpion", "A scorpion, 0.4 m long: eight legs, two pincer arms, and a "
              "five-segment tail on the spine curling over its back to a stinger.")
    z = 0.06
    c.add("prosoma", None, ["spine", "head"], (0.06, 0, z), (0.045, 0.04, 0.02))
    c.seg("mesosoma1", "prosoma", ["spine"], v(0.015, 0, z), v(-0.05, 0, z), (0.045, 0.02))
    c.seg("mesosoma2", "mesosoma1", ["spine"], v(-0.05, 0, z), v(-0.12, 0, z + 0.005),
          (0.04, 0.018))
    pts = [v(-0.12, 0, z + 0.005)]
    for pitch in (150, 115, 85, 55, 25):   # the metasoma curls up and forwards
        pts.append(pts[-1] + 0.045 * dir_pitch(pitch))
    spine_line(c, [f"tail{i + 1}" for i in range(5)], "mesosoma2", pts,
               [(0.016 - 0.001 * i, 0.014 - 0.001 * i) for i in range(5)],
               caps=("spine", "tail"))
    c.seg("stinger", "tail5", ["tail", "spike"], pts[-1], pts[-1] + v(0.03, 0, -0.025), 0.007)
    face(c, "prosoma", eyes=(0.004, 0.004, 0.004), eye_rel=(0.5, 0.3, 1.0))
    c.on("chelicera_l", "prosoma", ["mouth"], (1.0, 0.3, -0.2), (0.006, 0.006, 0.005),
         push=(0.006, 0, 0))
    profile = [(0, 0, 0), (0.0, 0.9, 0.5), (0.0, 1.7, 0.1), (0.0, 2.2, -1)]
    for k, (x, yaw) in enumerate(((0.06, 30), (0.035, 5), (0.0, -20), (-0.035, -45))):
        c.leg([f"femur{k + 1}_l", f"patella{k + 1}_l", f"tibia{k + 1}_l", f"tarsus{k + 1}_l"],
              "prosoma" if k < 2 else "mesosoma1", v(x, 0.03, z - 0.01), profile,
              [0.005, 0.004, 0.003], (0.008, 0.003, 0.002), 0.005, yaw=yaw, foot_yaw=90 + yaw)
    c.chain(["pedipalp_l", "palpwrist_l", "pincer_l"], "prosoma",
            [["limb"], ["limb"], ["limb", "grasper"]],
            [v(0.1, 0.025, z), v(0.12, 0.08, z + 0.015), v(0.16, 0.1, z + 0.01),
             v(0.22, 0.08, z + 0.0)], [0.007, 0.009, (0.014, 0.01)])
    c.mirror()
    return c


@creature
def inchworm():
    c = Maker("inchworm", "A footless inchworm, 0.5 m long, mid-stride: twelve spine bodies "
              "arched up between its two ends resting on the ground, a head with jaws, eyes "
              "and antennae.")
    n = 12
    # The spine follows a raised arch: its ends lie on the ground, its middle is 0.16 m up.
    r = 0.018
    xs = np.linspace(-0.22, 0.2, n + 1)
    pts = [v(x, 0, r + 0.16 * math.sin(math.pi * (x + 0.22) / 0.42) ** 2) for x in xs]
    c.seg("segment1", None, ["spine"], pts[0], pts[1], (r, r))
    c["segment1"].joint = None
    for i in range(1, n):
        c.seg(f"segment{i + 1}", f"segment{i}", ["spine"], pts[i], pts[i + 1], (r, r))
    head_end = pts[-1] + v(0.045, 0, 0.0)
    c.seg("head", f"segment{n}", ["spine", "head"], pts[-1], head_end, (0.02, 0.018), axis=0)
    face(c, "head", mouth=(0.006, 0.012, 0.005), eyes=(0.004, 0.004, 0.004),
         eye_rel=(0.5, 0.9, 0.5), mouth_rel=(1.0, 0.0, -0.4))
    c.on("antenna_l", "head", ["detail"], (0.5, 0.5, 1.0), (0.0015, 0.0015, 0.012),
         push=(0.0, 0.0, 0.012))
    # Rest the two ends on the ground exactly.
    low = c.lowest()
    for b in c.bodies:
        b.pos = b.pos - v(0, 0, low)
        if b.joint is not None:
            b.joint = b.joint - v(0, 0, low)
    c.mirror()
    return c


# -- main --------------------------------------------------------------------------------


def build_all():
    return [fn() for fn in CREATURES]


def main(argv=None) -> int:
    out_dir = HERE
    makers = build_all()
    names = [m.name for m in makers]
    if len(set(names)) != len(names):
        raise SystemExit("duplicate creature names")
    for m in makers:
        low = m.lowest()
        if low < -1e-4:
            print(f"warning: {m.name} reaches {low:.4f} m below the ground", file=sys.stderr)
        with open(os.path.join(out_dir, m.name + ".yaml"), "w", encoding="utf-8") as f:
            f.write(m.text())
    print(f"wrote {len(makers)} creatures to {out_dir}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
