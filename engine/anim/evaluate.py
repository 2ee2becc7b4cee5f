"""Goals of an animation on a creature at a time: the simple path for tests, tools and the
README (the bind phase with variants and caching replaces ``bind_all`` in the next stage).

``bind_all`` binds every channel to *all* the bodies its query selects (no variants),
with m = true for right-side bodies of mirroring channels. Each selected body of a
channel is a *slot*; ``SlotConstants`` hold what S needs per slot. A channel whose mode
needs a secondary target and whose secondary query selects nothing on this creature
cannot play there and gets no slots. A primary body's secondary target is the nearest
body (at rest) the secondary query selects, other than itself when there is a choice.

The target table that S reads has one row per external target (in
``Animation.target_names`` order) followed by one row per body; external rows come from
the game (``targets={"fruit": (x, y, z)}``) or the animation's preview default, body rows
from ``body_pos`` (the creature's rest positions unless given), so a moving secondary
body or external target costs one array write.

Output (``Goals``), per body, in character space relative to the creature's rest frame:
``goal_pos (nbody, 3)``, ``goal_rot (nbody, 4)``, ``goal_pos_weight (nbody,)`` and
``goal_rot_weight (nbody,)`` (0 = no goal on that DOF; the goal is then the rest pose).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from engine.anim import _kernels as AK
from engine.anim.animation import Animation, AnimationError
from engine.channels.blend import channel_order, ownership
from engine.channels.modes import Slot, SlotConstants, build_slots


class Goals(NamedTuple):
    """Per-body pose goals, what the IK takes."""

    goal_pos: np.ndarray
    goal_rot: np.ndarray
    goal_pos_weight: np.ndarray
    goal_rot_weight: np.ndarray

    @classmethod
    def empty(cls, nbody: int) -> Goals:
        rot = np.zeros((nbody, 4))
        rot[:, 0] = 1.0
        return cls(np.zeros((nbody, 3)), rot, np.zeros(nbody), np.zeros(nbody))


class EvalScratch(NamedTuple):
    """Per-frame work arrays of one binding (preallocated once)."""

    ch_pos: np.ndarray      # (nchannel, 3)
    ch_rot: np.ndarray      # (nchannel, 4)
    ch_weight: np.ndarray   # (nchannel,)
    slot_pos: np.ndarray    # (nslot, 3)
    slot_rot: np.ndarray    # (nslot, 4)
    slot_weight: np.ndarray  # (nslot,)
    work33: np.ndarray      # (3, 3)
    work34: np.ndarray      # (3, 4)
    body_rot: np.ndarray    # (nbody, 4) the goal-pose estimate of body secondaries


class SimpleBinding(NamedTuple):
    """An animation bound to a creature with every selected body playing (no variants)."""

    slots: SlotConstants          # in ownership order
    slot_pos_on: np.ndarray       # (nslot,) int8: this slot blends into its body's position
    slot_rot_on: np.ndarray       # (nslot,) int8
    channel_bodies: tuple         # per channel: int32 array of the bodies it poses
    target_names: tuple           # external target rows, in order
    nbody: int


def _nearest(creature, bodies: np.ndarray, to: int) -> int:
    choice = bodies[bodies != to] if len(bodies) > 1 else bodies
    d = np.linalg.norm(creature.body_rest_pos[choice] - creature.body_rest_pos[to], axis=1)
    return int(choice[int(np.argmin(d))])


def bind_all(animation: Animation, creature) -> SimpleBinding:
    """Bind every channel to all its selected bodies (see the module docstring)."""
    names = animation.target_names
    n_ext = len(names)
    slots: list[Slot] = []
    groups: dict[str, int] = {}
    slot_group: list[int] = []
    channel_bodies = []
    for ci in channel_order([c.priority for c in animation.channels]):
        ch = animation.channels[int(ci)]
        bodies = ch.query.evaluate(creature)
        secondary = ch.secondary.evaluate(creature) if ch.secondary is not None else None
        if ch.needs_target and ch.target is None and (secondary is None or len(secondary) == 0):
            bodies = bodies[:0]
        gid = groups.setdefault(ch.group, len(groups))
        for b in bodies:
            b = int(b)
            if ch.target is not None:
                row = names.index(ch.target)
            elif secondary is not None and len(secondary):
                row = n_ext + _nearest(creature, secondary, b)
            else:
                row = -1
            mirror = bool(ch.mirror and creature.body_side[b] < 0)
            slots.append(Slot(b, ch.position, ch.rotation, mirror=mirror, target=row, channel=int(ci),
                              target_body=row - n_ext if row >= n_ext else -1))
            slot_group.append(gid)
    per_channel = {i: [] for i in range(animation.nchannel)}
    for s in slots:
        per_channel[s.channel].append(s.body)
    channel_bodies = tuple(np.array(per_channel[i], np.int32) for i in range(animation.nchannel))
    consts = build_slots(creature, slots)
    pos_on, rot_on = ownership(consts.slot_body, np.array(slot_group, np.int32),
                               consts.slot_pos_mode != 0, consts.slot_rot_mode != 0)
    pos_on.flags.writeable = False
    rot_on.flags.writeable = False
    return SimpleBinding(consts, pos_on, rot_on, channel_bodies, names, creature.nbody)


def make_scratch(animation: Animation, binding: SimpleBinding) -> EvalScratch:
    n, k = animation.nchannel, binding.slots.nslot
    return EvalScratch(np.zeros((n, 3)), np.zeros((n, 4)), np.zeros(n), np.zeros((k, 3)), np.zeros((k, 4)),
                       np.zeros(k), np.zeros((3, 3)), np.zeros((3, 4)), np.zeros((binding.nbody, 4)))


def has_body_targets(binding) -> bool:
    """Whether some slot is secondary-relative to one of the creature's own bodies (its
    target row follows the external targets)."""
    return bool(np.any(binding.slots.slot_target >= len(binding.target_names)))


def make_scratches(animation: Animation, binding: SimpleBinding, n: int) -> EvalScratch:
    """``n`` scratches stacked on a leading axis of every field (one per thread chunk of
    ``engine._runtime_kernels.goals_pairs_parallel``)."""
    one = make_scratch(animation, binding)
    return EvalScratch(*(np.zeros((n,) + a.shape) for a in one))


def default_target(animation: Animation, creature, name: str) -> np.ndarray:
    """Preview position of external target ``name``: its default (x forward, y left, z up)
    from the centre of the creature's ground footprint, x and y in units of the
    creature's largest side and z in units of its height, so [1, 0, 0.5] is a body
    length ahead at half height for a snake, a giant and a spider alike."""
    d = animation.target_default(name)
    if d is None:
        raise AnimationError(f"external target '{name}' is not set and has no default in the file",
                             path=animation.path, field="targets")
    b = creature.bounds
    base = np.array([0.5 * (b[0, 0] + b[1, 0]), 0.5 * (b[0, 1] + b[1, 1]), 0.0])
    size = creature.size
    unit = np.array([np.max(size), np.max(size), size[2]])
    return base + np.asarray(d, float) * unit


def fill_targets(animation: Animation, creature, binding: SimpleBinding, targets, body_pos, out) -> np.ndarray:
    """Write the target table (n_ext + nbody, 3) into ``out``."""
    n_ext = len(binding.target_names)
    targets = targets or {}
    for name in targets:
        if name not in binding.target_names:
            raise AnimationError(f"animation '{animation.name}' has no external target '{name}' "
                                 f"(it uses: {', '.join(binding.target_names) or 'none'})",
                                 path=animation.path, field="targets")
    for r, name in enumerate(binding.target_names):
        if name in targets:
            p = np.asarray(targets[name], dtype=float)
            if p.shape != (3,) or not np.all(np.isfinite(p)):
                raise AnimationError(f"external target '{name}' must be 3 finite numbers, got {targets[name]!r}",
                                     path=animation.path, field="targets")
            out[r] = p
        else:
            out[r] = default_target(animation, creature, name)
    out[n_ext:] = creature.body_rest_pos if body_pos is None else body_pos
    return out


_CACHE: dict = {}
_CACHE_MAX = 256


def _bound(animation, creature):
    key = (id(animation), id(creature))
    hit = _CACHE.get(key)
    if hit is not None and hit[0] is animation and hit[1] is creature:
        return hit[2], hit[3], hit[4]
    binding = bind_all(animation, creature)
    scratch = make_scratch(animation, binding)
    table = np.zeros((len(binding.target_names) + creature.nbody, 3))
    if len(_CACHE) >= _CACHE_MAX:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = (animation, creature, binding, scratch, table)
    return binding, scratch, table


def evaluate_goals(animation: Animation, creature, t: float, targets: dict | None = None,
                   out: Goals | None = None, body_pos: np.ndarray | None = None) -> Goals:
    """Goals of ``animation`` on ``creature`` at play time ``t`` (seconds; wrapped when the
    animation loops, clamped otherwise). ``targets`` maps external target names to
    character-space positions; ``body_pos`` (nbody, 3) positions the secondary bodies
    (default: where this frame's goals put them, as the runtime does:
    ``engine.anim._kernels.goals_kernel_body_targets``). Pass ``out``
    (``Goals.empty(nbody)``) to write in place: after the first call for an (animation,
    creature) pair nothing is allocated but the small dict lookups."""
    binding, scratch, table = _bound(animation, creature)
    if out is None:
        out = Goals.empty(creature.nbody)
    if body_pos is not None:
        body_pos = np.asarray(body_pos, dtype=float)
        if body_pos.shape != (creature.nbody, 3) or not np.all(np.isfinite(body_pos)):
            raise AnimationError(f"body_pos must be finite with shape ({creature.nbody}, 3)", field="body_pos")
    fill_targets(animation, creature, binding, targets, body_pos, table)
    args = (animation.curves, binding.slots, binding.slot_pos_on, binding.slot_rot_on, table,
            float(animation.local_time(float(t))), creature.body_rest_pos, creature.body_rest_rot, scratch,
            out.goal_pos, out.goal_rot, out.goal_pos_weight, out.goal_rot_weight)
    if body_pos is None and has_body_targets(binding):
        # the runtime's way: secondary bodies where this frame's goals put them
        AK.goals_kernel_body_targets(*args, creature.body_parent, creature.body_local_pos, creature.body_local_rot,
                                     len(binding.target_names))
    else:
        AK.goals_kernel(*args)
    return out
