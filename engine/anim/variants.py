"""Variants: how many ways an animation can play on a creature (Hecker et al. 2008, 4.1.2).

A channel marked with a ``variant_group`` plays on *one* of its selected bodies at a time.
Channels that share a group co-vary: the group's first channel (its *leader*, in file
order) offers the choices, and every other channel of the group follows the leader's
choice — through the limb modifier when its query is the leader's query walked up to the
spine (a grasper and its shoulder), or by position in the selection when both select the
same number of bodies. Several groups combine by the *variant product*: the cartesian
product of their choices, without combinations that use one body twice, and filtered by
each group's side constraint relative to the first group (``same``: on the same side of
the sagittal plane; ``opposite``: on opposite sides; bodies on the plane are on no side
but their own). An animation without variant groups has one variant, ``default``.

Sagittal mirroring (4.1.2, Fig. 5): a variant whose first choice lies on the right
(y < 0) plays the animation's sagittal mirror: its right-side bodies and its centre
bodies specialize with m = true (for channels whose ``mirror`` is on), so handing a fruit
from A to B and from B to A are mirror images. In other variants only right-side bodies
of mirroring channels use m = true, so left and right limbs of one channel move as mirror
images (Fig. 5a); a channel with ``mirror: false`` never mirrors (Fig. 5b).

Variant ids are stable: the chosen bodies' names joined by ``+`` in group order, so a
game can store them, and ``Variant.bodies`` exposes the bodies for its own criteria.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from engine.errors import DataError

DEFAULT_VARIANT = "default"


@dataclass(frozen=True)
class Variant:
    """One way to play an animation on a creature."""

    index: int
    id: str                       # stable id: chosen body names joined by '+', or 'default'
    bodies: tuple[int, ...]       # the chosen body of each variant group, in group order
    groups: tuple[str, ...]       # variant group names, in order
    mirrored: bool                # plays the animation's sagittal mirror

    def body_of(self, group: str) -> int:
        return self.bodies[self.groups.index(group)]


def variant_product(choices: list[list[int]], sides: list[str | None],
                    body_side: np.ndarray) -> list[tuple[int, ...]]:
    """The variant product of several groups' choices (paper, 4.1.2).

    Args:
        choices: per variant group, the bodies it may play on, in selection order.
        sides: per group, None, ``"same"`` or ``"opposite"``: the constraint between this
            group's body and the first group's body (ignored on the first group).
        body_side: (nbody,) +1 left, -1 right, 0 on the sagittal plane.
    Returns:
        Combinations (one body per group), lexicographic in the choices' order, no body
        used twice, side constraints satisfied.
    """
    out = []
    for combo in itertools.product(*choices):
        if len(set(combo)) != len(combo):
            continue
        first = int(body_side[combo[0]])
        ok = True
        for g in range(1, len(combo)):
            s = int(body_side[combo[g]])
            if sides[g] == "same" and s != first:
                ok = False
            elif sides[g] == "opposite" and not (s * first == -1):
                ok = False
        if ok:
            out.append(tuple(int(b) for b in combo))
    return out


def follow_leader(creature, leader_query, leader_bodies: np.ndarray, query, bodies: np.ndarray,
                  chosen: int, *, animation: str = "", channel: str = "") -> np.ndarray:
    """The bodies a co-varying channel poses when its group's leader chose ``chosen``."""
    if query.limb == "spine_segment" and _same_query_but_limb(leader_query, query):
        return np.array([int(creature.body_spine_attach[chosen])], np.int32)
    if len(bodies) == len(leader_bodies):
        hit = np.flatnonzero(leader_bodies == chosen)
        if len(hit):
            return bodies[int(hit[0]) : int(hit[0]) + 1].astype(np.int32)
        # A mirror-image variant chose the partner of a selected body: follow the
        # partner of the follower's body for that selection.
        original = int(creature.body_mirror[chosen])
        hit = np.flatnonzero(leader_bodies == original)
        if original >= 0 and len(hit):
            follower = int(bodies[int(hit[0])])
            partner = int(creature.body_mirror[follower])
            return np.array([partner if partner >= 0 else follower], np.int32)
    raise DataError(
        f"cannot co-vary with its variant group's first channel on creature '{creature.name}': it selects "
        f"{len(bodies)} bodies where the first channel selects {len(leader_bodies)} (use the first channel's "
        f"query with the spine_segment limb modifier, or a query selecting as many bodies)",
        subject=channel, kind="channel", path=animation or None, field="variant_group")


def _same_query_but_limb(a, b) -> bool:
    da, db = a.to_dict(), b.to_dict()
    da.pop("limb", None)
    db.pop("limb", None)
    return da == db


def slot_mirror(channel_mirror: bool, body_side: int, variant_mirrored: bool) -> bool:
    """m for one selected body of one channel in one variant (see the module docstring)."""
    if not channel_mirror:
        return False
    return body_side < 0 or (body_side == 0 and variant_mirrored)


def closest_variant(variants: list[Variant], creature, point, group: int = 0) -> Variant:
    """The variant whose chosen body in ``group`` (default the first) is nearest ``point``
    (character space, at rest) — e.g. the grasper nearest the fruit. Ties: lowest index."""
    p = np.asarray(point, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise ValueError(f"point must be 3 finite numbers, got {point!r}")
    if not variants:
        raise ValueError("no variants to choose from")
    if not variants[0].bodies:
        return variants[0]
    d = [float(np.linalg.norm(creature.body_rest_pos[v.bodies[group]] - p)) for v in variants]
    return variants[int(np.argmin(d))]
