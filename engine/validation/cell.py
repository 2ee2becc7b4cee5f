"""One grid cell: an animation variant on a creature, played, measured and judged.

``run_creature(creature, animations)`` plays every animation and variant on one creature
(the grid's unit of work: one Dask task per creature) and returns a ``CellResult`` per
(animation, variant). A cell plays once per target set: animations with external targets
play with the file's default targets and ``RANDOM_TARGET_SETS`` random reachable ones;
the cell's value of each metric is its worst over those plays. The mirror image of a
variant plays with the mirror image of its targets, so the two can be compared.

A cell's status is the worst verdict of its metrics (``engine.validation.thresholds``),
``na`` when the animation's branch predicates decline the creature (with the reason), and
``fail`` with the message when playing raised or the output was not finite. A failing
cell names its worst metric, the body, the time and the value.
"""

from __future__ import annotations

import traceback
import zlib
from dataclasses import dataclass, field

import numpy as np

from engine.anim.animation import Animation
from engine.anim.binding import BindError, bind
from engine.anim.evaluate import default_target
from engine.channels import _kernels as CK
from engine.model.creature import Creature
from engine.validation import _kernels as K
from engine.validation import thresholds as T
from engine.validation.consistency import mirror_difference, path_independence, scrub_frames
from engine.validation.continuity import continuity
from engine.validation.goals import goal_error
from engine.validation.ground import ground
from engine.validation.limits import ik_limits
from engine.validation.measure import Measure
from engine.validation.record import FPS, PlaySpec, Recording, record_cell, record_cells, record_rest, scrub_poses
from engine.validation.selfcollision import nonadjacent_pairs, rest_depths, self_intersection

#: Random reachable target sets per cell, besides the file's defaults.
RANDOM_TARGET_SETS = 2
#: Poses kept for the report: the worst frame, and a filmstrip of this many frames.
FILMSTRIP = 8


def _inner_radii(c: Creature, root_of: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(inner_reach, inner_chain) per body: the closest its origin, and its joint, can come to
    its limb root's joint. A chain of segments reaches every distance from max(0, longest -
    the others) to their sum; inside that a goal is out of reach as surely as past the sum
    (the spider's palp is one bone: a goal at its mouth, 6 mm from the palp's root, cannot
    be met by a 3.7 cm bone). Segments: the bones from the limb root's joint to the body's
    joint, and for the origin the body's own joint-to-origin offset."""
    inner_reach = np.zeros(c.nbody)
    inner_chain = np.zeros(c.nbody)
    for b in range(c.nbody):
        r = int(root_of[b])
        if r < 0:
            continue
        bones = []
        k = b
        while k != r:
            p = int(c.body_parent[k])
            bones.append(float(np.linalg.norm(c.body_joint[k] - c.body_joint[p])))
            k = p
        if bones:
            inner_chain[b] = max(0.0, 2.0 * max(bones) - sum(bones))
        bones.append(float(np.linalg.norm(c.body_joint_offset[b])))
        inner_reach[b] = max(0.0, 2.0 * max(bones) - sum(bones))
    return inner_reach, inner_chain


@dataclass
class CellContext:
    """Constants of one creature the metrics share (computed once per creature)."""

    creature: Creature
    scale: float                    # largest side of the rest bounding box, m
    height: float                   # top of the rest bounding box, m
    floor: float                    # smallest lever for asked turns, m
    limb_bodies: np.ndarray         # bodies on a limb
    limb_root_of: np.ndarray        # (nb,) first body of each body's limb (-1 on the spine)
    reach: np.ndarray               # (nb,) path from the limb root's joint to the body origin, m
    chain: np.ndarray               # (nb,) path from the limb root's joint to the body's joint, m
    inner_reach: np.ndarray         # (nb,) closest the body origin can come to its limb root's joint, m
    inner_chain: np.ndarray         # (nb,) the same for the body's joint (its rotation held), m
    chain_bodies: np.ndarray        # bodies below the root of a limb (a chain of 2+ bodies)
    spine_goal_bodies: np.ndarray   # spine bodies other than the root, and one-body limbs
    is_chain: np.ndarray            # (nb,) bool masks of the two
    is_spine_goal: np.ndarray
    foot_contact_local: np.ndarray  # (nfoot, 3) contact point in the foot's frame
    leg_length: np.ndarray          # (nfoot,) m
    pair_a: np.ndarray
    pair_b: np.ndarray
    pair_rest_depth: np.ndarray
    bone_length: np.ndarray         # (nb,) parent joint to joint at rest, floored, m
    spine_rest_chord: np.ndarray    # (nspine - 1,) m
    symmetric: bool                 # every body has a mirror partner and the rest pose mirrors
    rest_low: np.ndarray            # (nb,) lowest corner of each box at rest, m
    rest_pos: np.ndarray | None = None

    @classmethod
    def for_creature(cls, c: Creature) -> CellContext:
        from engine.gait.rig import contact_point
        from engine.mathx import quat_rotate_inv

        scale = float(np.max(c.size))
        height = max(float(c.height), 1e-6)
        limb = np.flatnonzero(c.body_limb >= 0)
        root_of = np.full(c.nbody, -1, np.int64)
        root_of[limb] = c.limb_root[c.body_limb[limb]]
        chain = np.zeros(c.nbody)
        chain[limb] = c.body_limb_length[limb]
        reach = np.zeros(c.nbody)
        reach[limb] = chain[limb] + np.linalg.norm(c.body_joint_offset[limb], axis=1)
        reach = np.maximum(reach, 0.01 * scale)
        chained = np.array([b for b in limb if c.body_limb_length[b] > 0.0], np.int64)
        inner_reach, inner_chain = _inner_radii(c, root_of)
        single = np.array([b for b in limb if c.body_limb_length[b] <= 0.0
                           and c.body_subtree_end[b] == b + 1], np.int64)
        spine = np.concatenate([np.array([b for b in c.spine_chain if b != 0], np.int64), single])
        feet = c.leg_foot
        contact = np.array([quat_rotate_inv(c.body_rest_rot[f], contact_point(c, int(f)) - c.body_rest_pos[f])
                            for f in feet]).reshape(-1, 3)
        pa, pb = nonadjacent_pairs(c)
        bone = np.full(c.nbody, 0.01 * scale)
        for b in range(1, c.nbody):
            p = int(c.body_parent[b])
            bone[b] = max(float(np.linalg.norm(c.body_joint[b] - c.body_joint[p])), 0.01 * scale)
        sc = c.spine_chain
        chord = np.linalg.norm(c.body_joint[sc[1:]] - c.body_joint[sc[:-1]], axis=1) if sc.size > 1 \
            else np.zeros(0)
        mirror = c.body_mirror
        symmetric = bool(np.all(mirror >= 0)) and bool(
            np.allclose(c.body_rest_pos[mirror] * [1, -1, 1], c.body_rest_pos, atol=1e-9 * scale))
        return cls(creature=c, scale=scale, height=height, floor=0.01 * scale, limb_bodies=limb,
                   limb_root_of=root_of, reach=reach, chain=chain, inner_reach=inner_reach,
                   inner_chain=inner_chain, chain_bodies=chained, spine_goal_bodies=spine,
                   is_chain=np.isin(np.arange(c.nbody), chained), is_spine_goal=np.isin(np.arange(c.nbody), spine),
                   foot_contact_local=contact,
                   leg_length=np.maximum(np.asarray(c.leg_length, float), 1e-6), pair_a=pa, pair_b=pb,
                   pair_rest_depth=rest_depths(c, pa, pb), bone_length=bone,
                   spine_rest_chord=np.maximum(chord, 1e-9), symmetric=symmetric,
                   rest_low=K.box_min_z(c.body_rest_pos[None], c.body_rest_rot[None], c.body_extent)[0])

    def rest_reference(self, frames: int) -> np.ndarray:
        """World positions (frames, nb, 3) of the creature standing, playing nothing."""
        if self.rest_pos is None or len(self.rest_pos) < frames:
            self.rest_pos, _ = record_rest(self.creature, max(frames, 60))
        return self.rest_pos


@dataclass
class CellResult:
    """One cell's verdict and measures (``to_json`` for the report)."""

    creature: str
    animation: str
    variant: int
    variant_id: str
    status: str
    reason: str = ""                 # na: why the branch declined; fail: the worst metric, or the error
    measures: dict = field(default_factory=dict)     # name -> Measure (worst over target sets)
    verdicts: dict = field(default_factory=dict)     # name -> pass / warn / fail
    plays: int = 0                   # target sets played
    frames: int = 0
    ms_per_tick: float = 0.0
    error: str | None = None         # traceback of a raise
    known: list = field(default_factory=list)        # known defects among the failures
    poses: dict = field(default_factory=dict)        # "worst": (pos, rot), "film": [(t, pos, rot)...]
    target_sets: list = field(default_factory=list)
    source: str = ""
    animation_path: str = ""

    @property
    def worst(self) -> str | None:
        """The metric that decided the status (the worst verdict, then the largest value
        relative to its fail threshold)."""
        best, key = None, None
        for name, v in self.verdicts.items():
            t = T.BY_METRIC.get(name)
            rel = 0.0
            m = self.measures.get(name)
            if t is not None and m is not None and t.fail:
                rel = m.value / t.fail
            k = (T.RANK.get(v, 0), rel)
            if key is None or k > key:
                best, key = name, k
        return best

    def to_json(self, with_series: bool = False) -> dict:
        w = self.worst
        out = {"creature": self.creature, "animation": self.animation, "variant": self.variant,
               "variant_id": self.variant_id, "status": self.status, "reason": self.reason, "plays": self.plays,
               "frames": self.frames, "ms_per_tick": round(self.ms_per_tick, 5), "known": self.known,
               "source": self.source, "animation_path": self.animation_path}
        if w is not None and self.status in (T.WARN, T.FAIL):
            m = self.measures[w]
            out["worst"] = {"metric": w, "value": m.value, "unit": m.unit, "body": m.body, "time": m.time}
        out["metrics"] = {k: dict(m.to_json(with_series), verdict=self.verdicts.get(k, T.PASS))
                          for k, m in self.measures.items()}
        if self.error:
            out["error"] = self.error
        if self.target_sets:
            out["target_sets"] = [{k: [round(float(x), 5) for x in v] for k, v in s.items()} for s in self.target_sets]
        return out


# -- targets ------------------------------------------------------------------------------


def target_sets(animation: Animation, creature: Creature, bound, n_random: int = RANDOM_TARGET_SETS) -> list[dict]:
    """The external target sets a cell plays with: the file's defaults first, then
    ``n_random`` random points each of the bodies that use a target can reach (within 30-85%
    of its reach from its limb's root, in front, above the ground), drawn from a seed made
    of the creature's and the animation's names (the same sets in every run)."""
    names = list(animation.target_names)
    if not names:
        return [{}]
    defaults = {n: default_target(animation, creature, n) for n in names}
    sets = [defaults]
    seed = zlib.crc32(f"{creature.name}/{animation.name}/{bound.variant.id}".encode())
    rng = np.random.default_rng(seed)
    consts = bound.slots
    size = float(np.max(creature.size))
    for _ in range(n_random):
        s = {}
        for k, name in enumerate(names):
            users = [int(b) for b, row in zip(consts.slot_body, consts.slot_target, strict=True) if row == k]
            limb_users = [b for b in users if creature.body_limb[b] >= 0]
            if limb_users:
                b = limb_users[0]
                root = int(creature.limb_root[creature.body_limb[b]])
                base = creature.body_joint[root]
                reach = float(creature.body_limb_length[b] + np.linalg.norm(creature.body_joint_offset[b]))
            else:
                base = defaults[name]
                reach = 0.3 * size
            for _attempt in range(32):
                d = rng.normal(size=3)
                d[0] = abs(d[0]) + 0.3                  # in front
                d /= np.linalg.norm(d)
                p = base + d * reach * rng.uniform(0.3, 0.85)
                if p[2] >= 0.05 * creature.height:
                    break
            p[2] = max(p[2], 0.05 * creature.height)
            s[name] = p
        sets.append(s)
    return sets


def cell_target_sets(animation: Animation, creature: Creature, binding, v) -> list[dict]:
    """The target sets of variant ``v``: its own (``target_sets``), except that a mirrored
    variant with an unmirrored partner plays the mirror image of the partner's sets (so the
    two can be compared, and a cell played alone gets the same sets as in the grid)."""
    partner = _mirror_partner(v, binding.variants, creature)
    if v.mirrored and partner is not None and not partner.mirrored:
        return mirrored_targets(target_sets(animation, creature, binding.bound(partner.index)))
    return target_sets(animation, creature, binding.bound(v.index))


def mirrored_targets(sets: list[dict]) -> list[dict]:
    return [{k: np.asarray(v, float) * np.array([1.0, -1.0, 1.0]) for k, v in s.items()} for s in sets]


# -- one cell -----------------------------------------------------------------------------


METRICS = (continuity, goal_error, ground, self_intersection, ik_limits)


def measure_recording(rec: Recording, ctx: CellContext) -> list[Measure]:
    """Every metric of one recording."""
    out = []
    ctx.rest_reference(rec.nframe)
    for fn in METRICS:
        out.extend(fn(rec, ctx))
    return out


def judge(result: CellResult) -> None:
    """Set the cell's verdicts and status from its measures."""
    result.verdicts = {name: T.verdict(name, m.value) for name, m in result.measures.items()}
    status = T.PASS
    for v in result.verdicts.values():
        if T.RANK.get(v, 0) > T.RANK[status]:
            status = v
    if result.error is not None:
        status = T.FAIL
    result.status = status
    result.known = sorted({m.known for n, m in result.measures.items()
                           if m.known and result.verdicts.get(n) == T.FAIL})
    if status == T.FAIL and result.error is None:
        w = result.worst
        m = result.measures[w]
        result.reason = f"{w} {m.value:.4g} {m.unit}" + (f" at {m.body}" if m.body else "") + \
            (f", t={m.time:.2f}s" if m.time is not None else "")
    elif status == T.WARN:
        w = result.worst
        m = result.measures[w]
        result.reason = f"{w} {m.value:.4g} {m.unit}" + (f" at {m.body}" if m.body else "")


def _merge(into: dict, measures: list[Measure], set_index: int) -> None:
    for m in measures:
        m.detail.setdefault("target_set", set_index)
        old = into.get(m.name)
        if old is None or m.value > old.value:
            into[m.name] = m


def _keep_poses(result: CellResult, rec: Recording) -> None:
    """The worst frame's pose and a filmstrip, for the report's pictures."""
    w = result.worst
    m = result.measures.get(w) if w else None
    frame = m.frame if (m is not None and m.frame is not None) else rec.nframe // 2
    frame = int(min(max(frame, 0), rec.nframe - 1))
    result.poses["worst"] = (float(rec.t[frame]), rec.world_pos[frame].copy(), rec.world_rot[frame].copy())
    idx = np.unique(np.linspace(0, rec.nframe - 1, FILMSTRIP).round().astype(int))
    if frame not in idx:
        idx = np.sort(np.append(idx[:-1], frame))
    result.poses["film"] = [(float(rec.t[i]), rec.world_pos[i].copy(), rec.world_rot[i].copy()) for i in idx]
    result.poses["worst_frame"] = frame


def judge_recordings(creature: Creature, animation: Animation, variant: int, recs: list[Recording],
                     ctx: CellContext, scrubs: list | None = None, keep: bool = True) -> CellResult:
    """Judge one cell from its recordings (one per target set) and, for path independence,
    the scrubbed poses of each (``consistency.scrub_requests`` / ``record.scrub_poses``)."""
    binding = bind(animation, creature)
    bound = binding.bound(variant)
    res = CellResult(creature.name, animation.name, int(variant), bound.variant.id, T.PASS,
                     source=creature.path or "", animation_path=animation.path or "",
                     target_sets=[r.targets for r in recs])
    lookat = np.unique(bound.slots.slot_body[bound.slots.slot_rot_mode == CK.ROT_LOOKAT]).astype(np.int64)
    ticks = []
    for k, rec in enumerate(recs):
        rec.meta["lookat_bodies"] = lookat
        res.plays += 1
        res.frames += rec.nframe
        ticks.append(rec.tick_s[: rec.nframe])
        if rec.error is not None:
            res.error = rec.error
            res.reason = f"raised at t={(rec.error_frame + 1) / FPS:.2f}s: {rec.error}"
        finite = bool(np.all(np.isfinite(rec.world_pos)) and np.all(np.isfinite(rec.world_rot)))
        if not finite:
            bad = np.flatnonzero(~np.all(np.isfinite(rec.world_pos), axis=(0, 2)))
            i = int(np.flatnonzero(~np.all(np.isfinite(rec.world_pos), axis=(1, 2)))[0]) if bad.size else 0
            res.error = res.error or "non-finite output"
            res.reason = (f"non-finite output at {creature.body_names[int(bad[0])]}, t={rec.t[i]:.2f}s"
                          if bad.size else "non-finite rotations")
            _merge(res.measures, [Measure("finite", 0.0, "bool")], k)
            continue
        ms = measure_recording(rec, ctx)
        if scrubs is not None and scrubs[k]:
            ms.append(path_independence(rec, ctx, scrubs[k]))
        _merge(res.measures, ms, k)
    allticks = np.concatenate(ticks) if ticks else np.zeros(0)
    res.ms_per_tick = float(np.median(allticks) * 1000.0) if allticks.size else 0.0
    res.measures["ms_per_tick"] = Measure("ms_per_tick", res.ms_per_tick, "ms")
    judge(res)
    if keep and recs and recs[0].nframe:
        w = res.worst
        m = res.measures.get(w) if w else None
        k = int(m.detail.get("target_set", 0)) if m is not None else 0
        _keep_poses(res, recs[min(k, len(recs) - 1)])
    return res


def run_cell(creature: Creature, animation: Animation, variant: int, ctx: CellContext | None = None,
             sets: list[dict] | None = None, keep: bool = True) -> tuple[CellResult, list[Recording]]:
    """Play and judge one cell (every target set), each play a ``Character`` ticked alone.
    Returns the result and the recordings."""
    ctx = ctx or CellContext.for_creature(creature)
    binding = bind(animation, creature)
    if sets is None:
        sets = cell_target_sets(animation, creature, binding, binding.variant(variant))
    recs = [record_cell(creature, animation, variant, targets) for targets in sets]
    specs = [PlaySpec(animation, int(variant), t) for t in sets]
    scrubs = _scrub_all(creature, specs, recs)
    return judge_recordings(creature, animation, variant, recs, ctx, scrubs, keep), recs


def _scrub_all(creature: Creature, specs: list[PlaySpec], recs: list[Recording]) -> list[list]:
    """Scrubbed poses for every recording: [[(frame, pos, rot, driven), ...] per recording]."""
    requests, owner = [], []
    for k, (sp, rec) in enumerate(zip(specs, recs, strict=True)):
        if rec.error is not None:
            continue
        for i in scrub_frames(rec):
            requests.append((sp, float(rec.clip_time[i])))
            owner.append((k, i))
    poses = scrub_poses(creature, requests) if requests else []
    out: list[list] = [[] for _ in recs]
    for (k, i), (pos, rot, driven) in zip(owner, poses, strict=True):
        out[k].append((i, pos, rot, driven))
    return out


def run_creature(creature: Creature, animations, *, keep_poses: bool = True, variant: str | None = None,
                 progress=None) -> list[CellResult]:
    """Every (animation, variant) cell of one creature, judged; a cell that raises is a
    failed cell with its traceback, never a lost run. ``variant``: only the variant with
    this id (``hand_l``; ``default`` for animations without variants). Every play of the
    creature is ticked in crowds of plays of about the same length (``record_cells``)."""
    ctx = CellContext.for_creature(creature)
    results: list[CellResult] = []
    plan = []                       # (animation, binding, variants, first spec, spec owners)
    specs: list[PlaySpec] = []
    for anim in animations:
        try:
            binding = bind(anim, creature)
        except BindError as exc:
            results.append(CellResult(creature.name, anim.name, -1, "", T.NA, reason=exc.reason,
                                      source=creature.path or "", animation_path=anim.path or ""))
            continue
        except Exception as exc:  # noqa: BLE001
            results.append(_crashed(creature, anim, -1, exc))
            continue
        variants = [v for v in binding.variants if variant is None or v.id == variant]
        first, owner = len(specs), []
        for v in variants:
            try:
                for targets in cell_target_sets(anim, creature, binding, v):
                    specs.append(PlaySpec(anim, v.index, targets))
                    owner.append(v.index)
            except Exception as exc:  # noqa: BLE001
                results.append(_crashed(creature, anim, v.index, exc))
        plan.append((anim, variants, first, owner))
    try:
        recs = record_cells(creature, specs)
        ctx.rest_reference(max((r.nframe for r in recs), default=1))
        scrubs = _scrub_all(creature, specs, recs)
    except Exception as exc:  # noqa: BLE001 - record_cells isolates faults; this is a last resort
        for anim, variants, _, _ in plan:
            results.extend(_crashed(creature, anim, v.index, exc) for v in variants)
        return results
    for anim, variants, first, owner in plan:
        recorded: dict[int, tuple[CellResult, list[Recording]]] = {}
        for v in variants:
            mine = [first + k for k, o in enumerate(owner) if o == v.index]
            if not mine:
                continue
            try:
                res = judge_recordings(creature, anim, v.index, [recs[k] for k in mine], ctx,
                                       [scrubs[k] for k in mine], keep=keep_poses)
            except Exception as exc:  # noqa: BLE001
                res = _crashed(creature, anim, v.index, exc)
            recorded[v.index] = (res, [recs[k] for k in mine])
            results.append(res)
            if progress:
                progress(1)
        _mirror_checks(recorded, variants, creature, ctx)
        for k in range(first, first + len(owner)):
            recs[k] = None          # judged: let the frames go
    order = {id(a): i for i, a in enumerate(animations)}
    by_name = {a.name: i for i, a in enumerate(animations)}
    results.sort(key=lambda r: (by_name.get(r.animation, len(order)), r.variant))
    return results


def _crashed(creature, anim, variant, exc) -> CellResult:
    return CellResult(creature.name, anim.name, int(variant), "", T.FAIL, reason=f"{type(exc).__name__}: {exc}",
                      error=traceback.format_exc(), source=creature.path or "", animation_path=anim.path or "")


def _mirror_partner(v, variants, creature):
    if not v.bodies:
        return None
    image = tuple(int(creature.body_mirror[b]) for b in v.bodies)
    if min(image) < 0 or image == tuple(v.bodies):
        return None
    for o in variants:
        if tuple(o.bodies) == image:
            return o
    return None


def _mirror_checks(recorded, variants, creature, ctx) -> None:
    """Mirror consistency of each variant played with its mirror image's targets."""
    if not ctx.symmetric:
        return
    for v in variants:
        if v.mirrored:
            continue
        partner = _mirror_partner(v, variants, creature)
        if partner is None or v.index not in recorded or partner.index not in recorded:
            continue
        (ra, recs_a), (rb, recs_b) = recorded[v.index], recorded[partner.index]
        if not recs_a or len(recs_a) != len(recs_b):
            continue
        m = max((mirror_difference(a, b, ctx) for a, b in zip(recs_a, recs_b, strict=True)
                 if a.error is None and b.error is None), key=lambda x: x.value, default=None)
        if m is None:
            continue
        for res in (ra, rb):
            res.measures["mirror"] = m
            judge(res)
