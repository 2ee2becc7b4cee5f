"""Variants and mirroring: the paper's worked examples (Hecker et al. 2008, 4.1.2, Fig. 4).

Five bodies A, B, 1, 2, 3 viewed from the front: A and 1 on the left, B, 2 and 3 on the
right, so 2 and 3 share a side and 1 is opposite both (that is what the paper's lists
imply: same-side gives 23, 32; opposite-side gives 12, 13, 21, 31).
"""

from __future__ import annotations

import numpy as np
import pytest

from engine.anim.variants import closest_variant, slot_mirror, variant_product
from engine.model import creature_from_text

FIG4 = """\
format: 1
name: fig4
description: the abstract character of Hecker et al. 2008, Figure 4
bodies:
  - {name: torso, caps: [spine], pos: [0, 0, 1], extents: [0.2, 0.3, 0.3]}
  - {name: A, parent: torso, caps: [{a}], pos: [0, 0.2, 1.5], extents: [0.05, 0.05, 0.05]}
  - {name: B, parent: torso, caps: [{a}], pos: [0, -0.2, 1.5], extents: [0.05, 0.05, 0.05]}
  - {name: "1", parent: torso, caps: [grasper], pos: [0.1, 0.5, 1.0], extents: [0.05, 0.05, 0.05]}
  - {name: "2", parent: torso, caps: [grasper], pos: [0.1, -0.5, 1.1], extents: [0.05, 0.05, 0.05]}
  - {name: "3", parent: torso, caps: [grasper], pos: [0.1, -0.5, 0.9], extents: [0.05, 0.05, 0.05]}
"""


def _names(c, combos):
    return ["".join(c.body_names[b] for b in combo) for combo in combos]


@pytest.fixture(scope="module")
def all_graspers():
    return creature_from_text(FIG4.replace("{a}", "grasper"))


@pytest.fixture(scope="module")
def mouths():
    return creature_from_text(FIG4.replace("{a}", "mouth"))


def test_single_group_one_variant_per_body(all_graspers):
    c = all_graspers
    g = list(c.bodies_with("grasper"))
    assert _names(c, variant_product([g], [None], c.body_side)) == ["A", "B", "1", "2", "3"]


def test_two_groups_hand_over(mouths):
    # Only A and B are the graspers of a hand-over: AB and BA.
    c = mouths
    ab = [c.body("A"), c.body("B")]
    assert _names(c, variant_product([ab, ab], [None, None], c.body_side)) == ["AB", "BA"]


def test_grasper_to_mouth(mouths):
    c = mouths
    graspers = list(c.bodies_with("grasper"))
    mouth = list(c.bodies_with("mouth"))
    got = _names(c, variant_product([graspers, mouth], [None, None], c.body_side))
    assert got == ["1A", "1B", "2A", "2B", "3A", "3B"]


@pytest.mark.parametrize("side,expected", [
    ("same", ["23", "32"]),
    ("opposite", ["12", "13", "21", "31"]),
    (None, ["12", "13", "21", "23", "31", "32"]),
])
def test_side_constraints(mouths, side, expected):
    c = mouths
    g = list(c.bodies_with("grasper"))
    assert _names(c, variant_product([g, g], [None, side], c.body_side)) == expected


def test_mirror_flags():
    # Fig. 5a: left false, right true; Fig. 5b: the channel does not mirror.
    assert slot_mirror(True, +1, False) is False
    assert slot_mirror(True, -1, False) is True
    assert slot_mirror(False, -1, True) is False
    # Centre bodies mirror only in a mirrored variant.
    assert slot_mirror(True, 0, False) is False
    assert slot_mirror(True, 0, True) is True


def test_closest_variant(mouths):
    from engine.anim.variants import Variant

    c = mouths
    variants = [Variant(i, c.body_names[b], (int(b),), ("hand",), False)
                for i, b in enumerate(c.bodies_with("grasper"))]
    assert closest_variant(variants, c, (0.1, -0.6, 0.85)).id == "3"
    assert closest_variant(variants, c, (0.2, 0.6, 1.0)).id == "1"
    with pytest.raises(ValueError):
        closest_variant(variants, c, (0, np.nan, 0))
