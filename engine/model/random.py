"""Random creatures: Spore-like morphologies for property tests, benchmarks and demos.

Hecker et al. 2008 (section 1.2) describe what players build: a serial spine of
bodies, limbs and anatomical parts (mouths, eyes, graspers, feet, spikes, ...), usually
20 to 80 bodies, any number of legs of different lengths in arbitrary (sometimes
branching) arrangements (section 4.2, figure 6). ``random_creature_def(seed)`` makes
such a creature as a ``CreatureDef``; ``generate_creatures`` writes a batch of files.

Every draw comes from ``numpy.random.default_rng(seed)`` in a fixed order (no Python
``hash``, no set order), so a seed gives the same creature, to the bit, in every run
and process. numpy does not promise identical Generator streams across its major
versions, so a numpy upgrade may change what a seed makes.

The distribution (per creature, before the 20-80 body-count fit described below):

- height (top of the bounding box above z = 0): log-uniform in [0.1 m, 10 m]. The
  creature is designed with a spine of length 1 and scaled uniformly at the end, so
  every position, joint and extent scales together.
- spine: 3-14 bodies (uniform; 8-14 for legless crawlers); posture horizontal
  (quadruped-like, pitch -10..15 deg), inclined (15..60 deg) or upright (biped-like,
  60..90 deg), weighted by the leg count; 40% are curved in the sagittal plane (up to
  -60..+100 deg end to end). Boxes thickest mid-spine.
- the front spine body is the head (caps spine + head) in about half of the headed
  creatures; otherwise heads sit on necks.
- legs (feet): 0 18%, 1 3%, 2 22%, 3 5%, 4 22%, 5 3%, 6 12%, 7 2%, 8 8%, 9 1%, 10 4%.
  An odd count puts one leg on the sagittal plane (a single centre leg, a tripod).
  Pairs of legs merge into one branching pair (a hip limb splitting into two feet)
  with probability 0.25 per chance. Each leg limb has 2-4 bones and a foot, erect
  (knees bent fore/aft in a zigzag or an arc) or sprawled (spider/lizard-like, knees
  up). Legs hang off the back/lower spine bodies (all of them on a horizontal spine,
  the lowest ones on an upright spine).
- arms (graspers): 0 35%, 1 4%, 2 33%, 3 3%, 4 15%, 5 2%, 6 8%; an odd count adds
  a centre trunk-like arm. 2-3 bones and a hand, on the front/upper spine bodies.
- heads: 0 12%, 1 68%, 2 12%, 3 8%. One head: spine head (55%) or a centre neck head;
  two: a left/right pair on necks; three: a centre head and a pair. Each head has a
  mouth (its own body 75%, else the head body has the mouth cap), 0, 1, 2 or 4 eyes,
  and ears (35%). Headless creatures get a mouth on the front spine body (70%).
- tail 50% (70% for crawlers, 2-8 bones), wings 15% (a pair, 2-3 bones), spikes along
  the back 35% (1-5), detail pairs on the spine sides 30% (1-3 pairs).
- without feet: crawls with the spine on the ground (60%) or floats above it (40%).
- asymmetry (20%): one left/right pair of legs, arms, neck heads or wings loses one
  side or has one side re-shaped (the leg, arm and head shares above are before a
  side is dropped); a creature with no pair gets a single arm on one side (a horn on
  one flank when ``narms`` is fixed). Symmetric creatures are exact mirrors: the
  right side is the left with y negated and rotations mirrored,
  (w, x, y, z) -> (w, -x, y, -z).

Body count: over 80, the plan sheds parts in a fixed order (details, spikes, ears,
extra eyes, tail, wing, neck, spine, leg and arm bones) until it fits; under 20, it
gains detail pairs on the spine sides. Keyword overrides (``nspine``, ``nlegs``,
``narms``, ``nheads``, ``height``, ``posture``, ``symmetric``) fix a feature; the
rest is drawn as above.

Geometry: a leg is solved from its hip down to the ground, so every foot box rests on
z = 0; other limbs that would dip below the ground are lifted. Limb boxes are aligned
with their bones (local +X along the bone), the creature faces +X, the left side is +Y.
Names read like ``spine3``, ``leg2_l_seg1``, ``leg0_r_a_foot``, ``arm0_r_hand``,
``head1_l_mouth``, ``tail0_seg4``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from engine.errors import CreatureError
from engine.model.definition import BodyDef, CreatureDef
from engine.model.fileio import write_creature_def

#: Body-count range the generator fits every creature into (Hecker et al. 2008, 1.2).
MIN_BODIES = 20
MAX_BODIES = 80
#: Height range (m) of the default distribution.
MIN_HEIGHT = 0.1
MAX_HEIGHT = 10.0
POSTURES = ("horizontal", "inclined", "upright")

_X = np.array([1.0, 0.0, 0.0])
_Y = np.array([0.0, 1.0, 0.0])
_Z = np.array([0.0, 0.0, 1.0])
_DEG = math.pi / 180.0
#: Below-ground slack in design units (spine length 1): rounding, not geometry.
_EPS = 1e-9

_LEG_P = np.array([0.18, 0.03, 0.22, 0.05, 0.22, 0.03, 0.12, 0.02, 0.08, 0.01, 0.04])
_ARM_P = np.array([0.35, 0.04, 0.33, 0.03, 0.15, 0.02, 0.08])
_HEAD_P = np.array([0.12, 0.68, 0.12, 0.08])


# -- small geometry helpers (numpy, build time only) -------------------------------------


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _rot_from_x(direction: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of the shortest rotation taking +X to ``direction``."""
    d = _unit(direction)
    c = float(d[0])  # X . d
    if c < -1.0 + 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])  # half turn about Z
    q = np.array([1.0 + c, 0.0, -d[2], d[1]])  # (1 + X.d, X x d)
    return q / np.linalg.norm(q)


def _yaw(angle: float) -> np.ndarray:
    return np.array([math.cos(0.5 * angle), 0.0, 0.0, math.sin(0.5 * angle)])


def _rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``v`` rotated by unit quaternion ``q``: v + 2w (u x v) + 2 u x (u x v), u = q[1:]."""
    w, x, y, z = (float(a) for a in q)
    vx, vy, vz = (float(a) for a in v)
    tx, ty, tz = 2.0 * (y * vz - z * vy), 2.0 * (z * vx - x * vz), 2.0 * (x * vy - y * vx)
    return np.array([vx + w * tx + (y * tz - z * ty), vy + w * ty + (z * tx - x * tz),
                     vz + w * tz + (x * ty - y * tx)])


def _swap_side(name: str) -> str:
    """``leg0_l_a_foot`` -> ``leg0_r_a_foot``: swap every ``l``/``r`` token of a name."""
    return "_".join({"l": "r", "r": "l"}.get(tok, tok) for tok in name.split("_"))


@dataclass
class _Body:
    """One body under construction (design units until the final scale)."""

    name: str
    parent: str | None
    caps: list[str]
    pos: np.ndarray
    rot: np.ndarray
    joint: np.ndarray
    extents: np.ndarray

    def mirrored(self) -> _Body:
        """The sagittal mirror: y negated, rotation (w, x, y, z) -> (w, -x, y, -z)."""
        flip = np.array([1.0, -1.0, 1.0])
        return _Body(_swap_side(self.name), None if self.parent is None else _swap_side(self.parent),
                     list(self.caps), self.pos * flip, self.rot * np.array([1.0, -1.0, 1.0, -1.0]),
                     self.joint * flip, self.extents.copy())

    def min_z(self) -> float:
        """Lowest corner of the box: z of the centre minus the box's reach along world z."""
        w, x, y, z = self.rot
        row = np.array([2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)])
        return float(self.pos[2] - np.abs(row) @ self.extents)


def _segment(name: str, parent: str, caps: list[str], start: np.ndarray, end: np.ndarray,
             half_y: float, half_z: float) -> _Body:
    """A bone box from ``start`` (its joint) to ``end``, local +X along the bone."""
    v = end - start
    return _Body(name, parent, caps, 0.5 * (start + end), _rot_from_x(v), start.copy(),
                 np.array([0.5 * float(np.linalg.norm(v)), half_y, half_z]))


def _min_z(bodies: list[_Body]) -> float:
    return min(b.min_z() for b in bodies) if bodies else math.inf


def _bend_normal(u: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Unit vector perpendicular to ``u`` in the plane of ``u`` and ``ref`` (falls back
    to Z, X, Y when ``ref`` is nearly parallel to ``u``)."""
    for r in (ref, _Z, _X, _Y):
        n = r - float(r @ u) * u
        norm = float(np.linalg.norm(n))
        if norm > 1e-3:
            return n / norm
    return _Y.copy()  # unreachable: u cannot be parallel to all three axes


def _polyline(start: np.ndarray, end: np.ndarray, fractions: np.ndarray, ref: np.ndarray,
              amplitude: float, pattern: str) -> np.ndarray:
    """Joint points of a bent chain of ``len(fractions)`` bones from ``start`` to ``end``.

    Interior joints sit at chord parameters t (cumulative bone fractions), pushed off
    the chord along the bend normal by ``amplitude * chord * shape(t)``: ``arc`` is
    sin(pi t) (one smooth bow, e.g. a spider leg's raised knee), ``zigzag`` alternates
    sides with shrinking size (knee forward, hock back: a digitigrade leg)."""
    chord = end - start
    length = float(np.linalg.norm(chord))
    u = chord / length
    n = _bend_normal(u, ref)
    t = np.concatenate([[0.0], np.cumsum(fractions) / np.sum(fractions)])
    t[-1] = 1.0
    pts = start[None, :] + t[:, None] * chord[None, :]
    for i in range(1, len(t) - 1):
        shape = math.sin(math.pi * t[i]) if pattern == "arc" else (-0.7) ** (i - 1)
        pts[i] = pts[i] + amplitude * length * shape * n
    pts[0], pts[-1] = start, end
    return pts


# -- the plan: what the creature has, before any geometry --------------------------------


@dataclass
class _Head:
    """Features of one head: a mouth body (or the mouth cap on the head), eyes, ears."""

    mouth_body: bool
    eyes: int  # 0, 1 (centre), 2 (a pair) or 4 (two pairs)
    ears: bool
    size: float = 1.0  # head half-size relative to the spine radius

    def count(self) -> int:
        return int(self.mouth_body) + self.eyes + 2 * int(self.ears)


@dataclass
class _Part:
    """A limb or ornament hanging off spine body ``attach``, on one side.

    Geometry is always built on the left (y > 0) or the sagittal plane; a right part is
    the mirror of its left partner (``mirror_of``) or, when altered or single, the
    mirror of its own left-side build."""

    kind: str  # leg | arm | neck | tail | wing | spike | detail
    index: int
    side: int  # +1 left, -1 right, 0 centre
    attach: int
    nseg: int = 1
    branch_up: int = 0  # legs: bones above the split into two feet (0: no split)
    head: _Head | None = None
    p: dict = field(default_factory=dict)
    mirror_of: _Part | None = None

    @property
    def prefix(self) -> str:
        """Name prefix of the left/centre build (a right part swaps ``l`` to ``r``)."""
        base = "head" if self.kind == "neck" else self.kind
        return f"{base}{self.index}" + ("" if self.side == 0 else "_l")

    def count(self) -> int:
        if self.mirror_of is not None:
            return self.mirror_of.count()
        if self.kind == "leg":
            if self.branch_up:
                return self.branch_up + 2 * (self.nseg - self.branch_up + 1)
            return self.nseg + 1
        if self.kind == "arm":
            return self.nseg + 1
        if self.kind == "neck":
            return self.nseg + 1 + self.head.count()
        return self.nseg  # tail, wing (bones), spike and detail (1)


@dataclass
class _Plan:
    seed: int
    height: float
    posture: str
    pitch: float
    curvature: float
    nspine: int
    seg_fractions: np.ndarray
    radius: float
    aspect: float
    profile_jitter: np.ndarray
    locomotion: str  # legs | crawl | float
    clearance: float  # lowest spine box corner above the ground, design units
    sprawl: bool
    stance: float
    spine_head: _Head | None
    headless_mouth: str  # none | body | cap (creatures with no head)
    headless_eyes: bool
    parts: list[_Part]
    asymmetry: str = ""  # what was made asymmetric, for the description; "" if symmetric

    def count(self) -> int:
        n = self.nspine + sum(p.count() for p in self.parts)
        if self.spine_head is not None:
            n += self.spine_head.count()
        elif self.headless_mouth == "body":
            n += 1
        if self.spine_head is None and self.headless_eyes:
            n += 2
        return n

    def spine_limit(self) -> int:
        """Spine bodies that can carry limbs (the spine head cannot)."""
        return self.nspine - 1 if self.spine_head is not None else self.nspine


def _check_count(value, name: str, lo: int, hi: int) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= int(value) <= hi:
        raise CreatureError(f"expected an integer in [{lo}, {hi}], got {value!r}", field=name,
                            subject="random_creature_def", kind="function")
    return int(value)


def _sample_plan(rng: np.random.Generator, seed: int, c: dict) -> _Plan:
    """Draw everything but geometry. The draw order is fixed: do not reorder."""
    u = rng.uniform
    height = c["height"] if c["height"] is not None else float(
        math.exp(u(math.log(MIN_HEIGHT), math.log(MAX_HEIGHT))))
    nfeet = c["nlegs"] if c["nlegs"] is not None else int(rng.choice(11, p=_LEG_P))
    narms = c["narms"] if c["narms"] is not None else int(rng.choice(7, p=_ARM_P))
    nheads = c["nheads"] if c["nheads"] is not None else int(rng.choice(4, p=_HEAD_P))
    if nfeet > 0:
        locomotion = "legs"
    else:
        locomotion = "crawl" if rng.random() < 0.6 else "float"

    # Posture follows the legs: bipeds stand up, many-legged creatures lie along the ground.
    if c["posture"] is not None:
        posture = c["posture"]
    elif locomotion == "crawl":
        posture = "horizontal"
    else:
        w = {0: (0.6, 0.3, 0.1), 1: (0.4, 0.3, 0.3), 2: (0.15, 0.25, 0.6), 3: (0.4, 0.35, 0.25)}
        posture = POSTURES[int(rng.choice(3, p=w.get(nfeet, (0.65, 0.25, 0.1))))]
    pitch = {"horizontal": u(-10, 15), "inclined": u(15, 60), "upright": u(60, 90)}[posture] * _DEG
    curvature = 0.0
    if rng.random() < 0.4:
        curvature = u(-60, 100) * _DEG * (0.15 if locomotion == "crawl" else 1.0)
    if c["nspine"] is not None:
        nspine = c["nspine"]
    elif locomotion == "crawl":
        nspine = int(rng.integers(8, 15))
    else:
        nspine = int(rng.integers(3, 15))
    seg_fractions = u(0.7, 1.3, 14)
    radius = u(0.03, 0.08) if locomotion == "crawl" and nspine >= 10 else u(0.06, 0.2)
    aspect = u(0.7, 1.4)
    profile_jitter = u(0.9, 1.1, 14)
    sprawl = locomotion == "legs" and rng.random() < (0.35 if nfeet >= 4 else 0.1)
    if locomotion == "legs":
        clearance = {"horizontal": u(0.25, 1.0), "inclined": u(0.3, 1.0), "upright": u(0.5, 1.6)}[posture]
        if sprawl:
            clearance *= 0.5
    elif locomotion == "float":
        clearance = u(0.3, 1.0)
    else:
        clearance = 0.0
    stance = u(0.0, 0.6) if posture != "upright" else u(0.0, 0.15)

    def head_plan() -> _Head:
        return _Head(mouth_body=bool(rng.random() < 0.75), eyes=int(rng.choice([0, 1, 2, 4], p=[0.1, 0.15, 0.65, 0.1])),
                     ears=bool(rng.random() < 0.35), size=float(u(0.7, 1.3)))

    # Heads: a spine head (the front spine body) and/or heads on necks.
    spine_head = None
    neck_centre = False
    neck_pair = False
    if nheads == 1:
        if rng.random() < 0.55:
            spine_head = head_plan()
        else:
            neck_centre = True
    elif nheads == 2:
        neck_pair = True
    elif nheads == 3:
        neck_pair = True
        if rng.random() < 0.5:
            spine_head = head_plan()
        else:
            neck_centre = True
    headless_mouth = "none"
    headless_eyes = False
    if nheads == 0:
        r = rng.random()
        headless_mouth = "body" if r < 0.35 else ("cap" if r < 0.7 else "none")
        headless_eyes = bool(rng.random() < 0.5)

    plan = _Plan(seed=seed, height=height, posture=posture, pitch=pitch, curvature=curvature, nspine=nspine,
                 seg_fractions=seg_fractions, radius=radius, aspect=aspect, profile_jitter=profile_jitter,
                 locomotion=locomotion, clearance=clearance, sprawl=sprawl, stance=stance,
                 spine_head=spine_head, headless_mouth=headless_mouth, headless_eyes=headless_eyes, parts=[])
    m = plan.spine_limit()  # spine bodies 0..m-1 can carry limbs

    def region(lo: float, hi: float, k: int, count: int) -> int:
        """Spine index of item k of count spread over the fraction range [lo, hi]."""
        f = lo if count == 1 else lo + (hi - lo) * k / (count - 1)
        return int(round(f * (m - 1)))

    # Legs: pairs (some branching) and, for odd counts, one centre leg behind them.
    pairs = nfeet // 2
    kinds: list[str] = []  # per leg limb: pair | branch | centre
    while pairs > 0:
        if pairs >= 2 and rng.random() < 0.25:
            kinds.append("branch")
            pairs -= 2
        else:
            kinds.append("pair")
            pairs -= 1
    if nfeet % 2:
        kinds.insert(0, "centre")
    leg_hi = {"horizontal": 1.0, "inclined": 0.6, "upright": 0.25}[posture]
    for k, kind in enumerate(kinds):
        attach = region(0.0, leg_hi, k, len(kinds))
        if posture == "horizontal" and len(kinds) > 1 and kind != "centre":
            attach = region(0.1, 0.95, k, len(kinds))
        nseg = int(rng.choice([2, 3, 4], p=[0.4, 0.4, 0.2]))
        p = _leg_params(rng, rel=(k + 0.5) / len(kinds))
        side = 0 if kind == "centre" else 1
        part = _Part("leg", k, side, attach, nseg=nseg, p=p)
        if kind == "branch":
            part.branch_up = int(rng.integers(1, nseg))
        plan.parts.append(part)
        if side:
            plan.parts.append(_Part("leg", k, -1, attach, nseg=nseg, branch_up=part.branch_up, mirror_of=part))

    # Arms: pairs on the front/upper spine, an odd one as a centre trunk at the front.
    arm_lo = {"horizontal": 0.6, "inclined": 0.6, "upright": 0.7}[posture]
    npairs = narms // 2
    for k in range(npairs):
        attach = region(1.0, arm_lo, k, npairs)
        part = _Part("arm", k, 1, attach, nseg=int(rng.choice([2, 3], p=[0.6, 0.4])), p=_arm_params(rng, posture))
        plan.parts += [part, _Part("arm", k, -1, attach, nseg=part.nseg, mirror_of=part)]
    if narms % 2:
        part = _Part("arm", npairs, 0, m - 1, nseg=int(rng.choice([2, 3])), p=_arm_params(rng, posture))
        part.p["out"] = 0.0
        plan.parts.append(part)

    # Heads on necks.
    hk = 1 if spine_head is not None else 0
    if neck_centre:
        plan.parts.append(_Part("neck", hk, 0, m - 1, nseg=int(rng.integers(1, 4)), head=head_plan(),
                                p=_neck_params(rng, pair=False)))
        hk += 1
    if neck_pair:
        part = _Part("neck", hk, 1, m - 1, nseg=int(rng.integers(1, 4)), head=head_plan(),
                     p=_neck_params(rng, pair=True))
        plan.parts += [part, _Part("neck", hk, -1, m - 1, nseg=part.nseg, mirror_of=part)]

    # Tail, wings, spikes, details.
    if rng.random() < (0.7 if locomotion == "crawl" else 0.5):
        plan.parts.append(_Part("tail", 0, 0, 0, nseg=int(rng.integers(2, 9)), p=dict(
            length=u(0.3, 1.2), droop=u(-35, 40) * _DEG, curl=u(-0.3, 0.3), fractions=u(0.8, 1.2, 8),
            taper=u(0.2, 0.6), thickness=u(0.4, 0.6))))
    if rng.random() < 0.15:
        part = _Part("wing", 0, 1, region(0.75, 0.75, 0, 1), nseg=int(rng.integers(2, 4)), p=dict(
            span=u(0.4, 1.2), chord=u(0.08, 0.25), back=u(-0.4, 0.1), up=u(0.0, 0.5), arc=u(0.0, 0.15),
            fractions=u(0.8, 1.2, 3)))
        plan.parts += [part, _Part("wing", 0, -1, part.attach, nseg=part.nseg, mirror_of=part)]
    if rng.random() < 0.35:
        nspike = int(rng.integers(1, 6))
        for k in range(nspike):
            plan.parts.append(_Part("spike", k, 0, region(0.1, 0.9, k, nspike), p=dict(
                length=u(0.5, 1.5), back=u(0.0, 0.8), along=u(-0.3, 0.3))))
    if rng.random() < 0.3:
        for k in range(int(rng.integers(1, 4))):
            _add_detail_pair(plan, rng, k)

    # Asymmetry: drop or re-shape one side of one pair.
    want_asym = c["symmetric"] is False or (c["symmetric"] is None and rng.random() < 0.2)
    if want_asym:
        _make_asymmetric(plan, rng, c)
    return plan


def _leg_params(rng: np.random.Generator, rel: float) -> dict:
    u = rng.uniform
    return dict(rel=rel, along=u(-0.3, 0.3), splay=u(0.0, 0.6), sprawl_splay=u(0.5, 1.3),
                amplitude=u(0.08, 0.3), sign=1.0 if rng.random() < 0.5 else -1.0,
                pattern="zigzag" if rng.random() < 0.6 else "arc", fractions=u(0.7, 1.3, 4),
                thickness=u(0.04, 0.1), foot_length=u(0.08, 0.2), foot_width=u(1.0, 1.8),
                foot_height=u(0.8, 1.1), split=u(0.2, 0.45), branch_at=u(0.35, 0.55))


def _arm_params(rng: np.random.Generator, posture: str) -> dict:
    u = rng.uniform
    return dict(along=u(-0.3, 0.3), length=u(0.4, 0.9) if posture == "upright" else u(0.25, 0.8),
                forward=u(0.0, 1.0), out=u(0.3, 1.0), down=u(-0.2, 1.0), amplitude=u(0.05, 0.25),
                fractions=u(0.8, 1.2, 3), thickness=u(0.04, 0.08), hand_length=u(0.1, 0.2),
                hand_width=u(1.2, 2.0))


def _neck_params(rng: np.random.Generator, pair: bool) -> dict:
    u = rng.uniform
    return dict(length=u(0.15, 0.6), pitch=u(10, 75) * _DEG, yaw=u(20, 50) * _DEG if pair else 0.0,
                amplitude=u(-0.15, 0.15), fractions=u(0.8, 1.2, 3), head_length=u(0.8, 1.5))


def _add_detail_pair(plan: _Plan, rng: np.random.Generator, k: int) -> None:
    m = plan.spine_limit()
    p = dict(along=rng.uniform(-0.3, 0.3), size=rng.uniform(0.15, 0.35), up=rng.uniform(-0.2, 0.5))
    part = _Part("detail", k, 1, int(rng.integers(0, m)), p=p)
    plan.parts += [part, _Part("detail", k, -1, part.attach, mirror_of=part)]


def _make_asymmetric(plan: _Plan, rng: np.random.Generator, c: dict) -> None:
    fixed = {"leg": c["nlegs"] is not None, "arm": c["narms"] is not None, "neck": c["nheads"] is not None,
             "wing": False}
    rights = [p for p in plan.parts if p.mirror_of is not None and p.kind in fixed]
    if not rights:
        if c["narms"] is not None:  # keep the arm count: a horn on one flank instead
            # (spikes elsewhere sit on the sagittal plane, so nothing can pass for its mirror)
            part = _Part("spike", 90, 1, int(rng.integers(0, plan.spine_limit())),
                         p=dict(length=rng.uniform(0.8, 1.5), back=rng.uniform(0.0, 0.8), along=0.0,
                                asymmetry=True))
            part.side = 1 if rng.random() < 0.5 else -1
            plan.parts.append(part)
            plan.asymmetry = f"a horn on the {'left' if part.side > 0 else 'right'} flank"
            return
        side = 1 if rng.random() < 0.5 else -1
        nextk = sum(1 for p in plan.parts if p.kind == "arm" and p.side >= 0)
        part = _Part("arm", nextk, side, plan.spine_limit() - 1, nseg=int(rng.integers(2, 4)),
                     p=_arm_params(rng, plan.posture))
        part.p["length"] *= 1.4
        plan.parts.append(part)
        plan.asymmetry = f"a single {'left' if side > 0 else 'right'} arm"
        return
    right = rights[int(rng.integers(0, len(rights)))]
    left = right.mirror_of
    drop = not fixed[right.kind] and rng.random() < 0.5
    label = {"leg": "leg", "arm": "arm", "neck": "head", "wing": "wing"}[right.kind]
    if drop:
        victim = right if rng.random() < 0.5 else left
        if victim is left:  # keep the survivor's geometry: it becomes a standalone part
            right.mirror_of = None
            right.p = dict(left.p)
            right.head = left.head
            right.nseg, right.branch_up = left.nseg, left.branch_up
        plan.parts.remove(victim)
        plan.asymmetry = f"{label}{left.index} only on the {'right' if victim is left else 'left'}"
        return
    # Re-shape the right side: its own copy of the parameters, changed enough to show.
    right.mirror_of = None
    right.p = dict(left.p)
    right.head = left.head
    right.nseg, right.branch_up = left.nseg, left.branch_up
    p = right.p
    if right.kind == "leg":
        p["splay"] = p["splay"] * 1.5 + 0.5
        p["sprawl_splay"] *= 1.5
        p["along"] = -p["along"] + 0.3
        p["amplitude"] *= 0.5
        p["sign"] = -p["sign"]
        if right.branch_up == 0:
            right.nseg = 2 + (left.nseg - 1) % 3  # 2 -> 3 -> 4 -> 2
    elif right.kind == "arm":
        p["length"] *= 0.6 if rng.random() < 0.5 else 1.5
        p["down"] = p["down"] - 0.5
    elif right.kind == "neck":
        p["length"] *= 1.6
        p["pitch"] = min(p["pitch"] + 25 * _DEG, 85 * _DEG)
    else:
        p["span"] *= 0.55
    plan.asymmetry = f"right {label}{left.index} re-shaped"


def _fit_body_count(plan: _Plan, c: dict, rng: np.random.Generator) -> None:
    """Shed parts until the plan has at most MAX_BODIES, then add detail pairs up to MIN_BODIES."""
    def own(kind: str) -> list[_Part]:
        return [p for p in plan.parts if p.kind == kind and p.mirror_of is None]

    def shed_one() -> bool:
        for kind in ("detail", "spike"):
            parts = [p for p in plan.parts if p.kind == kind and not p.p.get("asymmetry")]
            if parts:  # the last one, with its mirror partner
                victim = parts[-1].mirror_of or parts[-1]
                plan.parts = [p for p in plan.parts if p is not victim and p.mirror_of is not victim]
                return True
        heads = [p.head for p in plan.parts if p.head is not None and p.mirror_of is None]
        if plan.spine_head is not None:
            heads.append(plan.spine_head)
        for h in heads:
            if h.ears:
                h.ears = False
                return True
        for h in heads:
            if h.eyes > 2:
                h.eyes = 2
                return True
        for kind, floor in (("tail", 2), ("wing", 2), ("neck", 1)):
            for p in own(kind):
                if p.nseg > floor:
                    p.nseg -= 1
                    return True
        if c["nspine"] is None and plan.nspine > 6:
            plan.nspine -= 1
            for p in plan.parts:  # keep attachments on the shorter spine
                p.attach = min(p.attach, plan.spine_limit() - 1)
            return True
        for kind in ("leg", "arm"):
            parts = sorted(own(kind), key=lambda p: -p.nseg)
            for p in parts:
                if p.nseg > 2 and p.nseg - 1 > p.branch_up:
                    p.nseg -= 1
                    return True
                if p.branch_up > 1:
                    p.branch_up -= 1
                    p.nseg -= 1
                    return True
        for h in heads:
            if h.eyes > 1:
                h.eyes = 1
                return True
        return False

    while plan.count() > MAX_BODIES:
        if not shed_one():  # cannot happen within the documented ranges (<= 74 bodies at minimum)
            raise CreatureError(f"cannot fit the creature into {MAX_BODIES} bodies "
                                f"({plan.count()} at minimum) with the given overrides",
                                subject="random_creature_def", kind="function")
    k = 1 + max((p.index for p in plan.parts if p.kind == "detail"), default=-1)
    while plan.count() < MIN_BODIES:
        if MIN_BODIES - plan.count() == 1:
            m = plan.spine_limit()
            plan.parts.append(_Part("spike", 50 + k, 0, int(rng.integers(0, m)), p=dict(
                length=rng.uniform(0.3, 0.6), back=rng.uniform(0.0, 0.8), along=rng.uniform(-0.3, 0.3))))
        else:
            _add_detail_pair(plan, rng, k)
        k += 1


# -- geometry ----------------------------------------------------------------------------


class _Geometry:
    """Turns a plan into bodies in design units (spine length 1), then scales them."""

    def __init__(self, plan: _Plan) -> None:
        self.plan = plan
        self.bodies: list[_Body] = []
        self.built: dict[int, list[_Body]] = {}  # id(part) -> its left/centre build
        self._spine()

    # spine ----------------------------------------------------------------------------

    def _spine(self) -> None:
        plan = self.plan
        n = plan.nspine
        frac = plan.seg_fractions[:n] / plan.seg_fractions[:n].sum()
        pts = np.zeros((n + 1, 3))
        lo, hi = -40 * _DEG, 110 * _DEG
        for i in range(n):
            theta = min(max(plan.pitch + plan.curvature * ((i + 0.5) / n - 0.5), lo), hi)
            pts[i + 1] = pts[i] + frac[i] * np.array([math.cos(theta), 0.0, math.sin(theta)])
        self.spine_pts = pts
        spine = []
        for i in range(n):
            profile = (0.65 + 0.35 * math.sin(math.pi * (i + 0.5) / n)) * plan.profile_jitter[i]
            h = plan.radius * profile
            w = h * plan.aspect
            name, caps = f"spine{i}", ["spine"]
            if i == n - 1 and plan.spine_head is not None:
                name, caps = "head0", ["spine", "head"]
                size = plan.radius * plan.spine_head.size
                h, w = max(h, size), max(w, size)
                if not plan.spine_head.mouth_body:
                    caps.append("mouth")
            elif i == n - 1 and plan.headless_mouth == "cap":
                caps.append("mouth")
            b = _segment(name, None if i == 0 else spine[-1].name, caps, pts[i], pts[i + 1], w, h)
            spine.append(b)
        # Place it: lowest box corner at the clearance, centred on x = 0.
        shift = np.array([-0.5 * (pts[:, 0].min() + pts[:, 0].max()), 0.0, plan.clearance - _min_z(spine)])
        for b in spine:
            b.pos = b.pos + shift
            b.joint = b.joint + shift
        self.spine_pts = pts + shift
        self.spine = spine
        self.bodies += spine

    def anchor(self, index: int, along: float, side_y: float, up: float) -> np.ndarray:
        """A point on spine body ``index``: ``along`` half-lengths along its axis, ``side_y``
        half-widths to the left, ``up`` half-heights up its local z."""
        b = self.spine[index]
        local = np.array([along * b.extents[0], side_y * b.extents[1], up * b.extents[2]])
        return b.pos + _rotate(b.rot, local)

    # parts ----------------------------------------------------------------------------

    def add(self, part: _Part) -> None:
        if part.mirror_of is not None:
            left = self.built[id(part.mirror_of)]
            self.bodies += [b.mirrored() for b in left]
            return
        built = getattr(self, "_" + part.kind)(part)
        self.built[id(part)] = built
        self.bodies += [b.mirrored() for b in built] if part.side < 0 else built

    def _lifted(self, build, direction: np.ndarray) -> list[_Body]:
        """Build a limb along ``direction``; while any box dips below the ground, tilt the
        direction up (half a unit of +Z at a time), finally pointing straight up."""
        for _ in range(10):
            bodies = build(direction)
            if _min_z(bodies) >= -_EPS:
                return bodies
            direction = _unit(direction + 0.5 * _Z)
        return build(_Z.copy())

    def _leg(self, part: _Part) -> list[_Body]:
        """Hip on the spine body's side, ankle above a foot resting on z = 0 (section 4.2)."""
        plan, p = self.plan, part.p
        b = self.spine[part.attach]
        side = 0.0 if part.side == 0 else 0.8
        hip = self.anchor(part.attach, p["along"], side, -0.35)
        reach = float(hip[2])
        if part.side == 0:
            splay = 0.0
        elif plan.sprawl:
            splay = reach * p["sprawl_splay"]
        else:
            splay = float(b.extents[1]) * p["splay"]
        dx = reach * plan.stance * (p["rel"] - 0.5) * 2.0
        span = math.hypot(reach, splay)
        r0 = min(span * p["thickness"], 0.45 * float(min(b.extents[1], b.extents[2])), 0.25 * reach)
        # Radius of the bone above the foot (bones taper by 12% each; a split leg's lower
        # bones start at 80%). The foot is at least that tall, so that bone's box, whose
        # corners reach sqrt(2) r below the ankle, stays above the ground.
        if part.branch_up:
            r_last = 0.8 * r0 * (1.0 - 0.12 * (part.nseg - part.branch_up - 1))
        else:
            r_last = r0 * (1.0 - 0.12 * (part.nseg - 1))
        fh = r_last * p["foot_height"]  # foot half-height; the ankle sits on top of the foot box
        foot_half = max(span * p["foot_length"], 1.5 * r_last)
        ankle = np.array([hip[0] + dx, hip[1] + splay, 2.0 * fh])
        ref = _Z if plan.sprawl and part.side != 0 else p["sign"] * _X
        prefix = part.prefix
        # Feet point forward, turned outward on sprawled legs.
        out = np.array([ankle[0] - hip[0], ankle[1] - hip[1], 0.0])
        fdir = _X + (0.6 * _unit(out) if plan.sprawl and np.linalg.norm(out) > 1e-9 else 0.0)
        fyaw = math.atan2(float(fdir[1]), float(fdir[0]))

        def foot(name: str, parent: str, at: np.ndarray) -> _Body:
            q = _yaw(fyaw)
            centre = np.array([at[0], at[1], fh]) + _rotate(q, np.array([0.6 * foot_half, 0.0, 0.0]))
            if part.side == 0:
                centre[1] = 0.0
            return _Body(name, parent, ["foot"], centre, q, at.copy(),
                         np.array([foot_half, r_last * p["foot_width"], fh]))

        def chain(prefix_: str, parent: str, pts: np.ndarray, first: int, r_start: float) -> list[_Body]:
            out_ = []
            for i in range(len(pts) - 1):
                r = r_start * (1.0 - 0.12 * i)
                out_.append(_segment(f"{prefix_}_seg{first + i}", parent, ["limb"], pts[i], pts[i + 1], r, r))
                parent = out_[-1].name
            return out_

        def build(amplitude: float) -> list[_Body]:
            fr = p["fractions"]
            if not part.branch_up:
                pts = _polyline(hip, ankle, fr[:part.nseg], ref, amplitude, p["pattern"])
                bones = chain(prefix, b.name, pts, 0, r0)
                return bones + [foot(f"{prefix}_foot", bones[-1].name, ankle)]
            # A branching leg: the hip limb splits into two lower legs, feet fore and aft.
            sep = np.array([reach * p["split"], 0.0, 0.0])
            branch = hip + p["branch_at"] * (ankle - hip)
            up = _polyline(hip, branch, fr[:part.branch_up], ref, 0.5 * amplitude, "arc")
            bones = chain(prefix, b.name, up, 0, r0)
            feet = []
            for tag, a in (("a", ankle + sep), ("b", ankle - sep)):
                low = _polyline(branch, a, fr[part.branch_up:part.nseg], ref, amplitude, p["pattern"])
                sub = chain(f"{prefix}_{tag}", bones[part.branch_up - 1].name, low, part.branch_up, 0.8 * r0)
                bones += sub
                feet.append(foot(f"{prefix}_{tag}_foot", sub[-1].name, a))
            return bones + feet

        # A bend that pushes a knee or shin into the ground is halved until it clears.
        amplitude = p["amplitude"]
        for _ in range(8):
            bodies = build(amplitude)
            if _min_z([x for x in bodies if "foot" not in x.caps]) >= -_EPS:
                return bodies
            amplitude *= 0.5
        return build(0.0)

    def _arm(self, part: _Part) -> list[_Body]:
        p = part.p
        b = self.spine[part.attach]
        if part.side == 0:  # a centre arm leaves the front end of the spine
            shoulder = self.anchor(part.attach, 0.9, 0.0, 0.0)
        else:
            shoulder = self.anchor(part.attach, p["along"], 0.9, 0.3)
        length = p["length"]
        r0 = min(length * p["thickness"], 0.4 * float(min(b.extents[1], b.extents[2])), 0.4 * float(shoulder[2]))
        direction = _unit(np.array([p["forward"] + (0.5 if part.side == 0 else 0.0), p["out"], -p["down"]]))
        prefix = part.prefix

        def build(d: np.ndarray) -> list[_Body]:
            end = shoulder + length * d
            pts = _polyline(shoulder, end, p["fractions"][:part.nseg], -_X, p["amplitude"], "arc")
            if part.side == 0:
                pts[:, 1] = 0.0
            out, parent = [], b.name
            for i in range(part.nseg):
                r = r0 * (1.0 - 0.1 * i)
                out.append(_segment(f"{prefix}_seg{i}", parent, ["limb"], pts[i], pts[i + 1], r, r))
                parent = out[-1].name
            last = _unit(pts[-1] - pts[-2])
            hl = length * p["hand_length"]
            hand = _segment(f"{prefix}_hand", parent, ["grasper"], pts[-1], pts[-1] + 2.0 * hl * last,
                            r0 * p["hand_width"] * 0.8, r0 * 0.6)
            return out + [hand]

        return self._lifted(build, direction)

    def _neck(self, part: _Part) -> list[_Body]:
        plan, p = self.plan, part.p
        b = self.spine[part.attach]
        side = 0.0 if part.side == 0 else 0.6
        base = self.anchor(part.attach, 0.8, side, 0.4)
        r = 0.5 * float(min(b.extents[1], b.extents[2]))
        r = min(r, 0.4 * float(base[2]))
        direction = np.array([math.cos(p["pitch"]) * math.cos(p["yaw"]), math.cos(p["pitch"]) * math.sin(p["yaw"]),
                              math.sin(p["pitch"])])
        size = plan.radius * part.head.size
        prefix = part.prefix

        def build(d: np.ndarray) -> list[_Body]:
            end = base + p["length"] * d
            pts = _polyline(base, end, p["fractions"][:part.nseg], _Z, p["amplitude"], "arc")
            if part.side == 0:
                pts[:, 1] = 0.0
            out, parent = [], b.name
            for i in range(part.nseg):
                out.append(_segment(f"{prefix}_neck{i}", parent, ["limb"], pts[i], pts[i + 1], r, r))
                parent = out[-1].name
            # The head looks mostly level along the neck's heading.
            last = pts[-1] - pts[-2]
            hdir = _unit(np.array([last[0], last[1], 0.3 * last[2]])) if abs(last[0]) + abs(last[1]) > 1e-9 \
                else _X.copy()
            caps = ["head"] if part.head.mouth_body else ["head", "mouth"]
            head = _segment(prefix, parent, caps, pts[-1], pts[-1] + 2.0 * size * p["head_length"] * hdir,
                            size, 0.85 * size)
            return out + [head] + self._features(head, part.head, centred=part.side == 0)

        return self._lifted(build, direction)

    def _features(self, head: _Body, plan: _Head, centred: bool) -> list[_Body]:
        """Mouth, eyes and ears on a head, placed in its face frame: the head's heading
        turned level, so an upright spine head still looks forward (+X)."""
        fwd = _rotate(head.rot, _X)
        yaw = math.atan2(float(fwd[1]), float(fwd[0])) if abs(fwd[0]) + abs(fwd[1]) > 1e-6 else 0.0
        if centred:  # a head on the sagittal plane faces forward, whatever its box's pitch
            yaw = 0.0
        q = _yaw(yaw)
        # Half-extents of the head box seen in the face frame.
        rel = _qmul(np.array([q[0], -q[1], -q[2], -q[3]]), head.rot)
        a = _abs_rot(rel) @ head.extents
        c = head.pos
        name = head.name
        out: list[_Body] = []

        def at(local) -> np.ndarray:
            pt = c + _rotate(q, np.array(local, float) * a)
            if centred and local[1] == 0.0:
                pt[1] = 0.0
            return pt

        def box(nm, caps, local, ext) -> _Body:
            pt = at(local)
            return _Body(nm, name, caps, pt, q.copy(), pt.copy(), np.array(ext, float) * a.min())

        def pair(nm, caps, local, ext) -> list[_Body]:
            left = box(nm + "_l", caps, local, ext)
            if centred:
                return [left, left.mirrored()]
            return [left, box(nm + "_r", caps, (local[0], -local[1], local[2]), ext)]

        if plan.mouth_body:
            mouth = box(f"{name}_mouth", ["mouth"], (0.85, 0.0, -0.45), (0.35, 0.5, 0.25))
            mouth.extents = np.array([0.35 * a[0], 0.5 * a[1], 0.25 * a[2]])
            out.append(mouth)
        if plan.eyes == 1:
            out.append(box(f"{name}_eye", ["eye"], (0.75, 0.0, 0.55), (0.3, 0.3, 0.3)))
        elif plan.eyes >= 2:
            out += pair(f"{name}_eye", ["eye"], (0.7, 0.45, 0.5), (0.2, 0.2, 0.2))
            if plan.eyes == 4:
                out += pair(f"{name}_eye2", ["eye"], (0.35, 0.6, 0.75), (0.15, 0.15, 0.15))
        if plan.ears:
            base = at((-0.2, 0.6, 0.8))
            tip_dir = _rotate(q, _unit(np.array([-0.3, 0.5, 1.0])))
            ear = _segment(f"{name}_ear_l", name, ["ear"], base, base + 0.9 * a[2] * tip_dir, 0.2 * a[1], 0.08 * a[1])
            if centred:
                out += [ear, ear.mirrored()]
            else:
                base_r = at((-0.2, -0.6, 0.8))
                tip_r = _rotate(q, _unit(np.array([-0.3, -0.5, 1.0])))
                out += [ear, _segment(f"{name}_ear_r", name, ["ear"], base_r, base_r + 0.9 * a[2] * tip_r,
                                      0.2 * a[1], 0.08 * a[1])]
        return out

    def _tail(self, part: _Part) -> list[_Body]:
        p = part.p
        b = self.spine[0]
        base = self.spine_pts[0].copy()
        back = -_unit(self.spine_pts[1] - self.spine_pts[0])
        heading = math.atan2(float(back[2]), float(back[0]))
        r0 = min(p["thickness"] * float(min(b.extents[1], b.extents[2])), 0.4 * float(base[2]) if base[2] > 0 else 1.0)

        def build(d: np.ndarray) -> list[_Body]:
            pts = _polyline(base, base + p["length"] * d, p["fractions"][:part.nseg], _Z, p["curl"], "arc")
            pts[:, 1] = 0.0
            out, parent = [], b.name
            for i in range(part.nseg):
                r = r0 * (1.0 - (1.0 - p["taper"]) * i / max(part.nseg - 1, 1))
                out.append(_segment(f"tail{part.index}_seg{i}", parent, ["tail"], pts[i], pts[i + 1], r, r))
                parent = out[-1].name
            return out

        angle = heading - p["droop"] if back[0] < 0 else heading + p["droop"]
        return self._lifted(build, np.array([math.cos(angle), 0.0, math.sin(angle)]))

    def _wing(self, part: _Part) -> list[_Body]:
        p = part.p
        b = self.spine[part.attach]
        base = self.anchor(part.attach, 0.0, 0.8, 0.6)
        span = p["span"]
        chord = p["chord"]

        def build(d: np.ndarray) -> list[_Body]:
            pts = _polyline(base, base + span * d, p["fractions"][:part.nseg], _Z, p["arc"], "arc")
            out, parent = [], b.name
            for i in range(part.nseg):
                ch = chord * (1.0 - 0.25 * i)
                out.append(_segment(f"{part.prefix}_seg{i}", parent, ["wing"], pts[i], pts[i + 1], ch, 0.08 * ch))
                parent = out[-1].name
            return out

        return self._lifted(build, _unit(np.array([p["back"], 1.0, p["up"]])))

    def _spike(self, part: _Part) -> list[_Body]:
        """A spike on the ridge of a spine body, raked back; or, off the sagittal plane,
        a horn on its left flank pointing out and up."""
        p = part.p
        b = self.spine[part.attach]
        centre = part.side == 0
        base = self.anchor(part.attach, p["along"], 0.0 if centre else 0.9, 0.9 if centre else 0.3)
        up = _rotate(b.rot, _Z)
        d = _unit(up - p["back"] * _X + (0.0 if centre else 1.5) * _Y)
        if centre:
            base[1] = d[1] = 0.0
        length = p["length"] * float(b.extents[2])
        r = min(0.25 * float(b.extents[2]), 0.25 * length)

        def build(direction: np.ndarray) -> list[_Body]:
            s = _segment(part.prefix, b.name, ["spike"], base, base + length * direction, r, r)
            if centre:
                s.pos[1] = 0.0
            return [s]

        return self._lifted(build, _unit(d))

    def _detail(self, part: _Part) -> list[_Body]:
        p = part.p
        b = self.spine[part.attach]
        base = self.anchor(part.attach, p["along"], 0.95, p["up"])
        ext = b.extents * np.array([0.5 * p["size"], p["size"], p["size"]])
        d = _Body(part.prefix, b.name, ["detail"], base, b.rot.copy(), base.copy(), ext)
        if d.min_z() < 0.0:  # too low on a crawler's flank: move it to the top of the body
            d.pos = self.anchor(part.attach, 0.0, 0.7, 0.9)
            d.joint = d.pos.copy()
            d.extents = d.extents * 0.5
        return [d]

    # whole creature -------------------------------------------------------------------

    def headless_features(self) -> None:
        plan = self.plan
        front = self.spine[-1]
        if plan.headless_mouth == "body":
            pt = self.anchor(plan.nspine - 1, 1.0, 0.0, -0.3)
            pt[1] = 0.0
            self.bodies.append(_Body("mouth0", front.name, ["mouth"], pt, front.rot.copy(), pt.copy(),
                                     front.extents * np.array([0.3, 0.5, 0.3])))
        if plan.headless_eyes:
            pt = self.anchor(plan.nspine - 1, 0.8, 0.5, 0.7)
            eye = _Body("eye0_l", front.name, ["eye"], pt, front.rot.copy(), pt.copy(),
                        np.full(3, 0.25 * float(front.extents[1:].min())))
            self.bodies += [eye, eye.mirrored()]

    def scaled(self, height: float) -> list[BodyDef]:
        """Centre the creature on x = 0 and scale it so its top is ``height`` above the ground."""
        reach = np.array([_abs_rot(b.rot) @ b.extents for b in self.bodies])
        pos = np.array([b.pos for b in self.bodies])
        dx = -0.5 * float((pos[:, 0] - reach[:, 0]).min() + (pos[:, 0] + reach[:, 0]).max())
        s = height / float((pos[:, 2] + reach[:, 2]).max())
        out = []
        for b in self.bodies:
            pos = b.pos.copy()
            joint = b.joint.copy()
            pos[0] += dx
            joint[0] += dx
            out.append(BodyDef(
                name=b.name, parent=b.parent, caps=list(b.caps),
                pos=tuple(float(v) for v in pos * s), rot=tuple(float(v) for v in b.rot),
                joint=tuple(float(v) for v in joint * s), extents=tuple(float(v) for v in b.extents * s)))
        return out


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _abs_rot(q: np.ndarray) -> np.ndarray:
    """|R(q)| element-wise: |R| @ extents is the half-size of a box's axis-aligned bounds."""
    w, x, y, z = q
    r = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])
    return np.abs(r)


# -- public API --------------------------------------------------------------------------


def random_creature_def(seed: int, *, nspine: int | None = None, nlegs: int | None = None,
                        narms: int | None = None, nheads: int | None = None, height: float | None = None,
                        posture: str | None = None, symmetric: bool | None = None) -> CreatureDef:
    """A random, valid Spore-like creature, the same for the same seed and overrides.

    Args:
        seed: integer >= 0, the only source of randomness (``numpy.random.default_rng``).
        nspine: spine bodies, 3..14. nlegs: feet, 0..10 (a branching leg counts each foot).
        narms: graspers, 0..6. nheads: heads, 0..3. height: top of the creature above the
            ground, m (> 0). posture: ``horizontal``, ``inclined`` or ``upright``.
        symmetric: True for an exact left/right mirror, False to force one asymmetry.
    Unset overrides are drawn from the distribution in the module docstring. The
    creature is named ``random_<seed>``; its description lists what it has.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or int(seed) < 0:
        raise CreatureError(f"seed must be an integer >= 0, got {seed!r}", field="seed",
                            subject="random_creature_def", kind="function")
    seed = int(seed)
    c = dict(nspine=_check_count(nspine, "nspine", 3, 14), nlegs=_check_count(nlegs, "nlegs", 0, 10),
             narms=_check_count(narms, "narms", 0, 6), nheads=_check_count(nheads, "nheads", 0, 3),
             height=None, posture=None, symmetric=None)
    if height is not None:
        if isinstance(height, bool) or not isinstance(height, (int, float, np.integer, np.floating)) \
                or not math.isfinite(float(height)) or float(height) <= 0.0:
            raise CreatureError(f"height must be a finite number > 0 (metres), got {height!r}", field="height",
                                subject="random_creature_def", kind="function")
        c["height"] = float(height)
    if posture is not None:
        if posture not in POSTURES:
            raise CreatureError(f"posture must be one of {', '.join(POSTURES)}, got {posture!r}", field="posture",
                                subject="random_creature_def", kind="function")
        c["posture"] = posture
    if symmetric is not None:
        if not isinstance(symmetric, bool):
            raise CreatureError(f"symmetric must be True, False or None, got {symmetric!r}", field="symmetric",
                                subject="random_creature_def", kind="function")
        c["symmetric"] = symmetric

    rng = np.random.default_rng(seed)
    plan = _sample_plan(rng, seed, c)
    _fit_body_count(plan, c, rng)
    geo = _Geometry(plan)
    for part in plan.parts:
        geo.add(part)
    if plan.spine_head is not None:
        head = geo.spine[-1]
        geo.bodies += geo._features(head, plan.spine_head, centred=True)
    else:
        geo.headless_features()
    bodies = geo.scaled(plan.height)
    return CreatureDef(name=f"random_{seed}", description=_describe(plan, bodies), bodies=bodies)


def _describe(plan: _Plan, bodies: list[BodyDef]) -> str:
    caps = [cap for b in bodies for cap in b.caps]
    legs = caps.count("foot")
    arms = caps.count("grasper")
    heads = caps.count("head")
    text = (f"Random creature (seed {plan.seed}): {len(bodies)} bodies, {plan.posture} spine of {plan.nspine}, "
            f"{_plural(legs, 'leg')}, {_plural(arms, 'arm')}, {_plural(heads, 'head')}, {plan.height:.3g} m tall, "
            f"{'walks' if plan.locomotion == 'legs' else plan.locomotion + 's'}; ")
    text += f"asymmetric: {plan.asymmetry}." if plan.asymmetry else "symmetric."
    return text


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def generate_creatures(seed: int, count: int, out_dir: str | os.PathLike, overwrite: bool = False) -> list[str]:
    """Write ``random_<seed + k>.yaml`` for k in 0..count-1 into ``out_dir``; return the paths.

    Nothing is written if any target file exists and ``overwrite`` is False: the error
    names the first existing file and how many there are.
    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or int(count) < 0:
        raise CreatureError(f"count must be an integer >= 0, got {count!r}", field="count",
                            subject="generate_creatures", kind="function")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or int(seed) < 0:
        raise CreatureError(f"seed must be an integer >= 0, got {seed!r}", field="seed",
                            subject="generate_creatures", kind="function")
    out = os.fspath(out_dir)
    if os.path.exists(out) and not os.path.isdir(out):
        raise CreatureError("output path exists and is not a directory", path=out)
    paths = [os.path.join(out, f"random_{int(seed) + k}.yaml") for k in range(int(count))]
    existing = [p for p in paths if os.path.exists(p)]
    if existing and not overwrite:
        more = f" (and {len(existing) - 1} more of the {len(paths)})" if len(existing) > 1 else ""
        raise CreatureError(f"file exists{more}; pass overwrite=True (menagerie: --force) to replace",
                            path=existing[0])
    for k, path in enumerate(paths):
        try:
            write_creature_def(random_creature_def(int(seed) + k), path, overwrite=overwrite)
        except OSError as exc:
            raise CreatureError(f"cannot write creature file: {exc.strerror or exc}", path=path) from None
    return paths


__all__ = ["MAX_BODIES", "MIN_BODIES", "POSTURES", "generate_creatures", "random_creature_def"]
