"""The bind phase: an animation meets a creature (Hecker et al. 2008, section 4.1).

The first time an animation plays on a creature, ``bind`` evaluates the animation's
branch predicates on the creature, resolves blend-group ownership and priority, and
enumerates the variants (``engine.anim.variants``). The result, a ``Binding``, is
immutable and cached per (animation, creature). The slot constants S needs for one
variant (``BoundVariant``) are built the first time that variant plays, and cached too.

Branch predicates are three-valued: a predicate the animation states is true or false, a
predicate it leaves out is *ignore*. ``choose_branch`` picks, among several branched
animations of one action, the first whose predicates hold, and says for each why not
when none does.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from engine.anim.animation import Animation, AnimationError
from engine.anim.variants import DEFAULT_VARIANT, Variant, closest_variant, follow_leader, slot_mirror, variant_product
from engine.channels.blend import channel_order, ownership
from engine.channels.modes import Slot, SlotConstants, build_slots
from engine.model.caps import CAP_BIT
from engine.model.creature import Creature


class BindError(AnimationError):
    """An animation that cannot play on a creature (branches, variants)."""


# -- branch predicates -------------------------------------------------------------------


def upright_spine(creature: Creature) -> bool:
    """Whether the spine is predominantly upright (a biped) rather than prone: the line
    from one end of the spine chain to the other rises more than it runs. A one-body
    spine is upright when its box is taller than it is long and wide."""
    chain = creature.spine_chain
    if len(chain) == 1:
        e = creature.body_extent[chain[0]]
        return bool(e[2] > max(e[0], e[1]))
    d = creature.body_rest_pos[chain[-1]] - creature.body_rest_pos[chain[0]]
    return bool(abs(d[2]) > np.hypot(d[0], d[1]))


def predicate_values(creature: Creature) -> dict[str, bool]:
    """Every branch predicate's value on ``creature``."""
    count = {cap: int(creature.cap_count[i]) for i, cap in enumerate(CAP_BIT)}
    return {
        "upright_spine": upright_spine(creature),
        "has_graspers": count["grasper"] > 0,
        "has_feet": creature.nleg > 0,
        "has_mouth": count["mouth"] > 0,
        "has_head": count["head"] > 0,
        "has_eyes": count["eye"] > 0,
        "has_tail": count["tail"] > 0,
        "has_wings": count["wing"] > 0,
    }


def branch_failures(animation: Animation, creature: Creature) -> list[str]:
    """Why ``animation`` does not bind to ``creature`` (empty when it does)."""
    values = predicate_values(creature)
    counts = {"legs": creature.nleg, "graspers": int(creature.cap_count[list(CAP_BIT).index("grasper")]),
              "heads": int(creature.cap_count[list(CAP_BIT).index("head")]),
              "mouths": int(creature.cap_count[list(CAP_BIT).index("mouth")])}
    out = []
    for name, wanted in animation.branches:
        if name.startswith(("min_", "max_")):
            what = name[4:]
            have = counts[what]
            if (name.startswith("min_") and have < wanted) or (name.startswith("max_") and have > wanted):
                bound = "at least" if name.startswith("min_") else "at most"
                out.append(f"it has {have} {what}, the animation needs {bound} {wanted}")
            continue
        if name not in values:
            out.append(f"unknown predicate '{name}'")
        elif values[name] != wanted:
            out.append(f"{name} is {str(values[name]).lower()}, the animation needs {str(wanted).lower()}")
    return out


def choose_branch(animations, creature: Creature) -> Animation:
    """The first of several branched animations of one action whose predicates hold on
    ``creature``; ``BindError`` listing every branch's reason when none does."""
    reasons = []
    for anim in animations:
        failures = branch_failures(anim, creature)
        if not failures:
            return anim
        reasons.append(f"'{anim.name}': {'; '.join(failures)}")
    raise BindError(f"no branch of this action plays on creature '{creature.name}': " + " | ".join(reasons)
                    if reasons else "an action needs at least one branched animation")


# -- bound variants ----------------------------------------------------------------------


@dataclass(frozen=True)
class BoundVariant:
    """One variant of an animation on a creature, ready for the goals kernel."""

    variant: Variant
    slots: SlotConstants          # in ownership order
    slot_pos_on: np.ndarray       # (nslot,) int8: this slot owns its body's position
    slot_rot_on: np.ndarray       # (nslot,) int8
    channel_bodies: tuple         # per channel: int32 bodies it poses in this variant
    target_names: tuple           # external target rows of the target table
    goal_bodies: np.ndarray       # (k,) int32 bodies this variant puts goals on
    nbody: int


@dataclass(eq=False)
class Binding:
    """An animation bound to a creature: the branch holds, the variants, and per-variant
    slot constants built on first use."""

    animation: Animation
    creature: Creature
    variants: tuple[Variant, ...]
    selections: tuple           # per channel: int32 bodies its primary query selects
    secondaries: tuple          # per channel: int32 bodies its secondary query selects, or None
    group_names: tuple[str, ...]
    group_leader: tuple[int, ...]   # channel index leading each variant group
    resting_groups: frozenset = frozenset()   # variant groups that select nothing here
    _bound: dict = field(default_factory=dict, repr=False)

    @property
    def nvariant(self) -> int:
        return len(self.variants)

    def variant(self, which: int | str | Variant | None = None) -> Variant:
        """A variant by index, id or itself; None: the first."""
        if which is None:
            return self.variants[0]
        if isinstance(which, Variant):
            if which not in self.variants:
                raise BindError(f"variant '{which.id}' does not belong to animation '{self.animation.name}' "
                                f"on creature '{self.creature.name}'")
            return which
        if isinstance(which, (int, np.integer)) and not isinstance(which, bool):
            if not 0 <= int(which) < len(self.variants):
                raise BindError(f"variant index {which} out of range 0..{len(self.variants) - 1} for animation "
                                f"'{self.animation.name}' on creature '{self.creature.name}'")
            return self.variants[int(which)]
        for v in self.variants:
            if v.id == which:
                return v
        ids = ", ".join(v.id for v in self.variants[:12])
        raise BindError(f"animation '{self.animation.name}' has no variant '{which}' on creature "
                        f"'{self.creature.name}' (variants: {ids}{', ...' if len(self.variants) > 12 else ''})")

    def closest_variant(self, point, group: int = 0) -> Variant:
        """The variant whose chosen body (in ``group``) is nearest ``point`` (character space)."""
        return closest_variant(list(self.variants), self.creature, point, group)

    def bound(self, which: int | str | Variant | None = None) -> BoundVariant:
        """Slot constants of a variant, built once and cached."""
        v = self.variant(which)
        hit = self._bound.get(v.index)
        if hit is None:
            hit = _bind_variant(self, v)
            self._bound[v.index] = hit
        return hit


def _variant_groups(animation: Animation) -> tuple[list[str], list[int]]:
    names, leaders = [], []
    for i, ch in enumerate(animation.channels):
        if ch.variant_group is not None and ch.variant_group not in names:
            names.append(ch.variant_group)
            leaders.append(i)
    return names, leaders


def _make_binding(animation: Animation, creature: Creature) -> Binding:
    failures = branch_failures(animation, creature)
    if failures:
        raise BindError(f"animation '{animation.name}' does not play on creature '{creature.name}': "
                        + "; ".join(failures), path=animation.path, field="branches")
    selections = tuple(ch.query.evaluate(creature) for ch in animation.channels)
    secondaries = tuple(ch.secondary.evaluate(creature) if ch.secondary is not None else None
                        for ch in animation.channels)
    names, leaders = _variant_groups(animation)
    # A variant group whose first channel selects nothing on this creature cannot vary:
    # its channels rest (zero selected bodies is a valid answer), the others still play.
    keep = [k for k, i in enumerate(leaders) if len(selections[i])]
    resting = {names[k] for k in range(len(names)) if k not in keep}
    names, leaders = [names[k] for k in keep], [leaders[k] for k in keep]
    if not names:
        variants = (Variant(0, DEFAULT_VARIANT, (), (), False),)
    else:
        choices = [list(selections[i]) for i in leaders]
        sides = [animation.channels[i].side for i in leaders]
        combos = variant_product(choices, sides, creature.body_side)
        # Automatic sagittal mirroring (4.1.2): each combination's mirror image is a
        # variant too, when the varying channels mirror and every chosen body has a partner.
        if all(animation.channels[i].mirror for i in leaders):
            seen = set(combos)
            for combo in list(combos):
                image = tuple(int(creature.body_mirror[body]) for body in combo)
                if min(image) >= 0 and image not in seen and len(set(image)) == len(image):
                    combos.append(image)
                    seen.add(image)
        variants = tuple(
            Variant(k, "+".join(creature.body_names[b] for b in combo), combo, tuple(names),
                    bool(creature.body_side[combo[0]] < 0))
            for k, combo in enumerate(combos))
        if not variants:
            empty = [animation.channels[i].name for i, c in zip(leaders, choices, strict=True) if not c]
            why = (f"channel(s) {', '.join(empty)} select no body" if empty
                   else "no combination of bodies satisfies the variant groups' side constraints")
            raise BindError(f"animation '{animation.name}' has no variant on creature '{creature.name}': {why}",
                            path=animation.path, field="variant_group")
    return Binding(animation, creature, variants, selections, secondaries, tuple(names), tuple(leaders),
                   frozenset(resting))


def _bind_variant(b: Binding, v: Variant) -> BoundVariant:
    anim, creature = b.animation, b.creature
    names = anim.target_names
    n_ext = len(names)
    chosen = dict(zip(b.group_names, v.bodies, strict=True))
    leader_query = {g: anim.channels[i].query for g, i in zip(b.group_names, b.group_leader, strict=True)}
    slots: list[Slot] = []
    slot_group: list[int] = []
    groups: dict[str, int] = {}
    per_channel: dict[int, list[int]] = {i: [] for i in range(anim.nchannel)}
    for ci in channel_order([c.priority for c in anim.channels]):
        ci = int(ci)
        ch = anim.channels[ci]
        bodies = b.selections[ci]
        if v.mirrored and ch.mirror and ch.variant_group is None:
            # The animation's mirror image: a channel that picks bodies on one side picks
            # their partners (bodies without a partner stay).
            partner = creature.body_mirror[bodies]
            bodies = np.unique(np.where(partner >= 0, partner, bodies)).astype(np.int32)
        if ch.variant_group in b.resting_groups:
            continue
        if ch.variant_group is not None:
            g = ch.variant_group
            leader = b.group_leader[b.group_names.index(g)]
            if leader == ci:
                bodies = np.array([chosen[g]], np.int32)
            else:
                bodies = follow_leader(creature, leader_query[g], b.selections[leader], ch.query, bodies,
                                       chosen[g], animation=anim.path or anim.name, channel=ch.name)
        secondary = b.secondaries[ci]
        # A secondary query that is a variant group's leader query means "that group's choice".
        secondary_choice = None
        if ch.secondary is not None:
            for g, q in leader_query.items():
                if q == ch.secondary:
                    secondary_choice = chosen[g]
        if ch.needs_target and ch.target is None and secondary_choice is None and (
                secondary is None or len(secondary) == 0):
            continue   # its secondary selects nothing on this creature: the channel rests
        gid = groups.setdefault(ch.group, len(groups))
        for body in bodies:
            body = int(body)
            if ch.target is not None:
                row = names.index(ch.target)
            elif secondary_choice is not None:
                row = n_ext + int(secondary_choice)
            elif secondary is not None and len(secondary):
                row = n_ext + _nearest(creature, secondary, body)
            else:
                row = -1
            mirror = slot_mirror(ch.mirror, int(creature.body_side[body]), v.mirrored)
            slots.append(Slot(body, ch.position, ch.rotation, mirror=mirror, target=row, channel=ci,
                              target_body=row - n_ext if row >= n_ext else -1))
            slot_group.append(gid)
            per_channel[ci].append(body)
    consts = build_slots(creature, slots)
    pos_on, rot_on = ownership(consts.slot_body, np.array(slot_group, np.int32),
                               consts.slot_pos_mode != 0, consts.slot_rot_mode != 0)
    for a in (pos_on, rot_on):
        a.flags.writeable = False
    goal_bodies = np.unique(consts.slot_body).astype(np.int32)
    goal_bodies.flags.writeable = False
    channel_bodies = tuple(np.array(per_channel[i], np.int32) for i in range(anim.nchannel))
    return BoundVariant(v, consts, pos_on, rot_on, channel_bodies, names, goal_bodies, creature.nbody)


def _nearest(creature, bodies: np.ndarray, to: int) -> int:
    choice = bodies[bodies != to] if len(bodies) > 1 else bodies
    d = np.linalg.norm(creature.body_rest_pos[choice] - creature.body_rest_pos[to], axis=1)
    return int(choice[int(np.argmin(d))])


_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def bind(animation: Animation, creature: Creature) -> Binding:
    """The cached Binding of ``animation`` on ``creature`` (built on first use)."""
    per = _CACHE.get(creature)
    if per is None:
        per = weakref.WeakKeyDictionary()
        _CACHE[creature] = per
    hit = per.get(animation)
    if hit is None:
        hit = _make_binding(animation, creature)
        per[animation] = hit
    return hit
