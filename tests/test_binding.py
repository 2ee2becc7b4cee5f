"""The bind phase: branch predicates, variants from real animations, mirroring, co-varying
channels, secondary targets that follow another group's choice, and the cache."""

from __future__ import annotations

import glob

import numpy as np
import pytest
from test_variants import FIG4

import engine
from engine.anim import animation_from_text, load_animation
from engine.anim.binding import BindError, bind, branch_failures, choose_branch, predicate_values
from engine.model import creature_from_text

HANDOVER = """\
format: 1
name: handover
description: pass a fruit from one grasper to another, the giver's shoulder co-varying
length: 1.0
channels:
  - name: give
    select: {type: grasper}
    position: {mode: rest}
    variant_group: giver
    keys: {position: [{t: 0, v: [0, 0, 0]}, {t: 1, v: [0.1, 0, 0]}]}
  - name: give_shoulder
    select: {type: grasper, limb: spine_segment}
    rotation: {mode: rest}
    variant_group: giver
    keys: {rotation: [{t: 0, aa: [0, 0, 1, 0]}, {t: 1, aa: [0, 0, 1, 10]}]}
  - name: take
    select: {type: grasper}
    position: {mode: rest}
    variant_group: taker
{side}    keys: {position: [{t: 0, v: [0, 0, 0]}, {t: 1, v: [0.1, 0, 0]}]}
"""

TO_MOUTH = """\
format: 1
name: to_mouth
description: a grasper to a mouth, both varying; the grasper's target is the chosen mouth
length: 1.0
branches: {has_graspers: true, has_mouth: true}
channels:
  - name: hand
    select: {type: grasper}
    secondary: {type: mouth}
    position: {mode: secondary}
    variant_group: hand
    keys: {position: [{t: 0, v: [0, 0, 0]}, {t: 1, v: [1, 0, 0]}]}
  - name: mouth
    select: {type: mouth}
    rotation: {mode: rest}
    variant_group: mouth
    keys: {rotation: [{t: 0, aa: [0, 1, 0, 0]}, {t: 1, aa: [0, 1, 0, 20]}]}
"""


@pytest.fixture(scope="module")
def fig4_mouths():
    return creature_from_text(FIG4.replace("{a}", "mouth"))


def test_paper_variants_through_real_bindings(fig4_mouths):
    c = fig4_mouths
    for side, expected in (("same", ["2+3", "3+2"]), ("opposite", ["1+2", "1+3", "2+1", "3+1"]),
                           ("null", ["1+2", "1+3", "2+1", "2+3", "3+1", "3+2"])):
        text = HANDOVER.replace("{side}", "" if side == "null" else f"    side: {side}\n")
        b = bind(animation_from_text(text), c)
        assert [v.id for v in b.variants] == expected, side
    b = bind(animation_from_text(TO_MOUTH), c)
    assert [v.id for v in b.variants] == ["1+A", "1+B", "2+A", "2+B", "3+A", "3+B"]


def test_secondary_follows_the_chosen_mouth(fig4_mouths):
    c = fig4_mouths
    anim = animation_from_text(TO_MOUTH)
    b = bind(anim, c)
    n_ext = len(anim.target_names)
    for v in b.variants:
        bv = b.bound(v)
        hand_slot = int(np.flatnonzero(bv.slots.slot_channel == 0)[0])
        assert bv.slots.slot_target[hand_slot] - n_ext == v.body_of("mouth")


def test_shoulder_covaries_with_the_grasper():
    c = engine.load_creature("creatures/humanoid.yaml")
    b = bind(animation_from_text(HANDOVER.replace("{side}", "    side: opposite\n")), c)
    for v in b.variants:
        bv = b.bound(v)
        giver = v.body_of("giver")
        shoulder = bv.channel_bodies[1]
        assert list(shoulder) == [int(c.body_spine_attach[giver])]
        assert c.body_side[v.body_of("taker")] == -c.body_side[giver]


def test_automatic_mirror_variant():
    c = engine.load_creature("creatures/humanoid.yaml")
    wave = load_animation("animations/wave.yaml")   # selects the top left grasper only
    b = bind(wave, c)
    ids = [v.id for v in b.variants]
    assert len(ids) == 2 and ids[0].endswith("_l") and ids[1] == ids[0][:-2] + "_r"
    assert not b.variants[0].mirrored and b.variants[1].mirrored
    left, right = b.bound(0), b.bound(1)
    assert left.slots.slot_mirror_sign[0] == 1.0 and right.slots.slot_mirror_sign[0] == -1.0
    # The game picks by its own criteria: the hand nearest a point on the right.
    assert b.closest_variant((0.3, -0.5, 1.2)).id == ids[1]
    with pytest.raises(BindError, match="no variant 'paw'"):
        b.variant("paw")


def test_branches():
    snake = engine.load_creature("creatures/snake.yaml")
    human = engine.load_creature("creatures/humanoid.yaml")
    assert predicate_values(human)["upright_spine"] and not predicate_values(snake)["upright_spine"]
    wave = load_animation("animations/wave.yaml")
    assert branch_failures(wave, human) == []
    assert branch_failures(wave, snake) == ["has_graspers is false, the animation needs true"]
    with pytest.raises(BindError, match="snake.*has_graspers"):
        bind(wave, snake)
    roar = load_animation("animations/roar.yaml")
    assert choose_branch([wave, roar], snake) is roar
    with pytest.raises(BindError, match="no branch of this action"):
        choose_branch([wave], snake)


def test_cache_and_immutability():
    c = engine.load_creature("creatures/humanoid.yaml")
    wave = load_animation("animations/wave.yaml")
    assert bind(wave, c) is bind(wave, c)
    assert bind(wave, c).bound(0) is bind(wave, c).bound(0)
    with pytest.raises(ValueError):
        bind(wave, c).bound(0).slot_pos_on[0] = 0


def test_every_library_animation_binds_or_says_why():
    creatures = [engine.load_creature(p) for p in sorted(glob.glob("creatures/*.yaml"))]
    for path in sorted(glob.glob("animations/*.yaml")):
        anim = load_animation(path)
        for c in creatures:
            if branch_failures(anim, c):
                continue
            try:
                b = bind(anim, c)
            except BindError as e:
                assert c.name in str(e)     # a clear reason, never a traceback
                continue
            for k in range(b.nvariant):
                bv = b.bound(k)
                # Zero selected bodies is a valid binding (the animation rests there).
                assert np.all((bv.goal_bodies >= 0) & (bv.goal_bodies < c.nbody))


def test_count_predicates():
    text = HANDOVER.replace("{side}", "").replace("length: 1.0\n", "length: 1.0\nbranches: {min_legs: 4, max_graspers: 2}\n")
    anim = animation_from_text(text)
    dog = engine.load_creature("creatures/dog.yaml")          # 4 legs, 0 graspers
    human = engine.load_creature("creatures/humanoid.yaml")   # 2 legs, 2 graspers
    octopus = engine.load_creature("creatures/octopus.yaml")  # 0 legs, 8 graspers
    assert branch_failures(anim, dog) == []
    assert branch_failures(anim, human) == ["it has 2 legs, the animation needs at least 4"]
    assert branch_failures(anim, octopus) == ["it has 0 legs, the animation needs at least 4",
                                              "it has 8 graspers, the animation needs at most 2"]
    with pytest.raises(engine.MenagerieError, match="whole number"):
        animation_from_text(text.replace("min_legs: 4", "min_legs: many"))
    with pytest.raises(engine.MenagerieError, match="whole number"):
        animation_from_text(text.replace("min_legs: 4", "min_legs: -1"))
