"""Context queries (Hecker 2008 sec 3.1.1): invalid inputs, a hand-checked creature, and a
plain-Python reference compared over random creatures."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import DataError
from engine.model import build_creature, creature_from_text
from engine.model.random import random_creature_def
from engine.query import CENTER_ZONE, EXTENTS, Query, nearest, select

# Four graspers: front-left, front-right, back-left (all at different heights) and one on
# the sagittal plane in front (a trunk). Hand-checkable bounds: x in [-0.45, 0.55].
QUAD = """\
format: 1
name: quad
bodies:
  - name: chest
    caps: [spine]
    pos: [0.2, 0, 1.0]
    extents: [0.1, 0.2, 0.1]
  - name: pelvis
    parent: chest
    caps: [spine]
    pos: [-0.2, 0, 1.0]
    joint: [0, 0, 1.0]
    extents: [0.1, 0.2, 0.1]
  - name: arm_fl
    parent: chest
    caps: [limb]
    pos: [0.35, 0.3, 1.1]
    joint: [0.25, 0.2, 1.1]
    extents: [0.05, 0.05, 0.05]
  - name: hand_fl
    parent: arm_fl
    caps: [grasper]
    pos: [0.5, 0.3, 1.2]
    joint: [0.45, 0.3, 1.1]
    extents: [0.05, 0.05, 0.05]
  - name: hand_fr
    parent: chest
    caps: [grasper]
    pos: [0.5, -0.3, 1.3]
    joint: [0.3, -0.2, 1.1]
    extents: [0.05, 0.05, 0.05]
  - name: hand_bl
    parent: pelvis
    caps: [grasper]
    pos: [-0.4, 0.3, 0.9]
    joint: [-0.3, 0.2, 1.0]
    extents: [0.05, 0.05, 0.05]
  - name: trunk
    parent: chest
    caps: [grasper, mouth]
    pos: [0.45, 0.0, 0.8]
    joint: [0.3, 0.0, 0.9]
    extents: [0.05, 0.05, 0.05]
"""


@pytest.fixture(scope="module")
def quad():
    return creature_from_text(QUAD)


def names(c, idx):
    return [c.body_names[i] for i in idx]


# -- invalid inputs ------------------------------------------------------------------------

INVALID = [
    (dict(type="hand"), "type"),
    (dict(type="grasper", x="left"), "x"),
    (dict(type="grasper", y="front"), "y"),
    (dict(type="grasper", z="up"), "z"),
    (dict(type="grasper", x="front", x_space="bounds"), "x_space"),
    (dict(type="grasper", extent="middlemost"), "extent"),
    (dict(type="grasper", limb="clavicle"), "limb"),
]


@pytest.mark.parametrize("kwargs,field", INVALID)
def test_invalid_query_names_the_field(kwargs, field):
    with pytest.raises(DataError) as exc:
        Query(**kwargs)
    assert exc.value.field == field


def test_from_dict_rejects_unknown_and_missing_fields():
    with pytest.raises(DataError, match="unknown query field 'side'"):
        Query.from_dict({"type": "grasper", "side": "left"})
    with pytest.raises(DataError, match="needs a 'type'"):
        Query.from_dict({"x": "front"})


def test_nearest_rejects_bad_point(quad):
    with pytest.raises(DataError, match="point"):
        nearest(quad, "grasper", (0.0, np.nan, 1.0))


# -- hand-checked -----------------------------------------------------------------------------


def test_type_selects_every_body_with_the_cap_in_index_order(quad):
    got = Query("grasper").evaluate(quad)
    assert got.dtype == np.int32
    assert sorted(names(quad, got)) == ["hand_bl", "hand_fl", "hand_fr", "trunk"]
    assert list(got) == sorted(got)
    assert names(quad, Query("root").evaluate(quad)) == [quad.body_names[0]]
    assert len(Query("foot").evaluate(quad)) == 0  # zero bodies is a valid answer


def test_character_halfspaces_include_the_centre_zone(quad):
    # Character bounds x: [-0.45, 0.55], mid 0.05: front keeps x >= 0.05 - band.
    assert sorted(names(quad, Query("grasper", x="front").evaluate(quad))) == ["hand_fl", "hand_fr", "trunk"]
    assert names(quad, Query("grasper", x="back").evaluate(quad)) == ["hand_bl"]
    # left/right split at the sagittal plane; the trunk (y = 0) is centre, so it is in both.
    assert sorted(names(quad, Query("grasper", y="left").evaluate(quad))) == ["hand_bl", "hand_fl", "trunk"]
    assert sorted(names(quad, Query("grasper", y="right").evaluate(quad))) == ["hand_fr", "trunk"]
    assert names(quad, Query("grasper", y="center").evaluate(quad)) == ["trunk"]


def test_setspace_separates_bodies_clumped_at_one_end(quad):
    # All three front graspers are "front" of the character; within the graspers' own
    # box (x from -0.45 to 0.55 again, but z from 0.75 to 1.35), top splits them.
    top_char = sorted(names(quad, Query("grasper", z="top").evaluate(quad)))
    top_set = sorted(names(quad, Query("grasper", z="top", z_space="setspace").evaluate(quad)))
    assert top_char == ["hand_fl", "hand_fr"]   # character z: [0.75, 1.35], mid 1.05
    assert top_set == ["hand_fl", "hand_fr"]
    # Feet-free creature: front graspers only, setspace front picks the forward ones of them.
    front = Query("grasper", x="front")
    front_set = Query("grasper", x="front", x_space="setspace")
    assert set(front_set.evaluate(quad)) <= set(Query("grasper").evaluate(quad))
    assert set(front.evaluate(quad)) == set(front_set.evaluate(quad))


def test_setspace_differs_from_character_when_clumped():
    text = QUAD.replace("pos: [-0.4, 0.3, 0.9]", "pos: [0.3, 0.3, 0.9]")
    c = creature_from_text(text)
    # every grasper is in the character's front half; the setspace splits them.
    assert len(Query("grasper", x="front").evaluate(c)) == 4
    assert sorted(names(c, Query("grasper", x="front", x_space="setspace").evaluate(c))) == \
        ["hand_fl", "hand_fr", "trunk"]


def test_extents_pick_one_body_with_deterministic_ties(quad):
    assert names(quad, Query("grasper", extent="frontmost").evaluate(quad)) == ["hand_fl"]  # tie with hand_fr
    assert names(quad, Query("grasper", extent="backmost").evaluate(quad)) == ["hand_bl"]
    assert names(quad, Query("grasper", extent="topmost").evaluate(quad)) == ["hand_fr"]
    assert names(quad, Query("grasper", extent="bottommost").evaluate(quad)) == ["trunk"]
    assert names(quad, Query("grasper", extent="rightmost").evaluate(quad)) == ["hand_fr"]
    assert len(Query("grasper", extent="leftmost").evaluate(quad)) == 1
    assert len(Query("foot", extent="leftmost").evaluate(quad)) == 0


def test_spine_segment_walks_up_to_the_spine(quad):
    got = Query("grasper", limb="spine_segment").evaluate(quad)
    assert sorted(names(quad, got)) == ["chest", "pelvis"]
    got = Query("grasper", x="front", y="left", extent="frontmost", limb="spine_segment").evaluate(quad)
    assert names(quad, got) == ["chest"]


def test_helpers_for_game_code(quad):
    assert sorted(names(quad, select(quad, "grasper", left=True, front=True))) == ["hand_fl", "trunk"]
    assert names(quad, select(quad, "grasper", extent="backmost")) == ["hand_bl"]
    assert quad.body_names[nearest(quad, "grasper", (0.5, -0.4, 1.3))] == "hand_fr"
    assert nearest(quad, "foot", (0, 0, 0)) == -1
    with pytest.raises(DataError):
        select(quad, "grasper", left=True, right=True)


def test_dict_round_trip():
    q = Query("grasper", x="front", y="left", y_space="setspace", extent="topmost", limb="spine_segment")
    assert Query.from_dict(q.to_dict()) == q
    assert Query.from_dict({"type": "mouth"}).to_dict() == {"type": "mouth"}


# -- reference over random creatures ----------------------------------------------------------


def reference(c, q: Query) -> list[int]:
    """Plain-Python query evaluation, body by body."""
    if q.type == "root":
        sel = [0]
        setbox = c.bounds
    else:
        from engine.model.caps import CAPABILITIES
        sel = [i for i in range(c.nbody) if c.has_cap(i, q.type)]
        setbox = c.cap_bounds[CAPABILITIES.index(q.type)]
    for k, axis in enumerate("xyz"):
        zone = getattr(q, axis)
        if zone is None:
            continue
        space = getattr(q, axis + "_space")
        box = setbox if space == "setspace" else c.bounds
        mid = 0.0 if (axis == "y" and space == "character") else (box[0][k] + box[1][k]) / 2
        band = CENTER_ZONE * (box[1][k] - box[0][k]) / 2
        keep = []
        for i in sel:
            d = c.body_rest_pos[i][k] - mid
            pos_name, centre, _ = {"x": ("front", "center", "back"), "y": ("left", "center", "right"),
                                   "z": ("top", "center", "bottom")}[axis]
            ok = abs(d) <= band if zone == centre else (d >= -band if zone == pos_name else d <= band)
            if ok:
                keep.append(i)
        sel = keep
    if q.extent and sel:
        k, sign = EXTENTS[q.extent]
        best = max(sign * c.body_rest_pos[i][k] for i in sel)
        sel = [min(i for i in sel if sign * c.body_rest_pos[i][k] >= best - 1e-9 * max(c.size))]
    if q.limb and sel:
        sel = sorted({int(c.body_spine_attach[i]) for i in sel})
    return sel


queries = st.builds(
    Query,
    type=st.sampled_from(["root", "grasper", "foot", "mouth", "head", "spine", "tail", "eye", "wing"]),
    x=st.sampled_from([None, "front", "center", "back"]), y=st.sampled_from([None, "left", "center", "right"]),
    z=st.sampled_from([None, "top", "center", "bottom"]),
    x_space=st.sampled_from(["character", "setspace"]), y_space=st.sampled_from(["character", "setspace"]),
    z_space=st.sampled_from(["character", "setspace"]),
    extent=st.sampled_from([None] + list(EXTENTS)), limb=st.sampled_from([None, "spine_segment"]))

_CREATURES = {}


def random_creature(seed):
    if seed not in _CREATURES:
        _CREATURES[seed] = build_creature(random_creature_def(seed))
    return _CREATURES[seed]


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 40), q=queries)
def test_matches_reference_on_random_creatures(seed, q):
    c = random_creature(seed)
    got = q.evaluate(c)
    assert list(got) == reference(c, q)
    assert q.evaluate(c).tolist() == got.tolist()  # deterministic


def test_left_right_partition_symmetric_creatures():
    for seed in range(10):
        c = build_creature(random_creature_def(seed, symmetric=True))
        left = set(select(c, "foot", left=True))
        right = set(select(c, "foot", right=True))
        assert left | right == set(Query("foot").evaluate(c))
        mirrored = {int(c.body_mirror[b]) for b in left}
        assert mirrored == right
