"""The creature library (``creatures/*.yaml``): every file loads cleanly and is sane.

Each library creature must load without warnings, have 8 to 80 bodies and a description,
stand on the ground (feet touching z = 0, nothing below it), be an exact sagittal mirror
image unless listed as asymmetric, keep its joints where its boxes meet, and survive a
save/load round trip bit for bit. The creatures the rest of Menagerie relies on by name
(the 25-body humanoid benchmark, the spider, the centipede, ...) are checked for the
properties their tests and demos assume. The library is written by ``creatures/_make.py``;
a test checks the script still regenerates every file byte for byte.
"""

from __future__ import annotations

import glob
import importlib.util
import io
import os
import re
import warnings
from contextlib import redirect_stdout

import numpy as np
import pytest

import engine
from engine.model import CAPABILITIES, load_creature

LIBRARY = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "creatures")
FILES = sorted(glob.glob(os.path.join(LIBRARY, "*.yaml")))
NAMES = [os.path.basename(f)[:-5] for f in FILES]

#: Creatures that are deliberately not sagittal mirror images; every other one must be.
ASYMMETRIC = {"threearmed"}

#: Ground tolerance (m): feet touch z = 0 and nothing reaches further below it.
GROUND_TOL = 0.01


def _corners(c) -> np.ndarray:
    """The 8 box corners of every body in character space, (nbody, 8, 3), in plain numpy."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    out = np.empty((c.nbody, 8, 3))
    for i in range(c.nbody):
        w, x, y, z = c.body_rest_rot[i]
        # Rotation matrix of a w-first unit quaternion.
        r = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ])
        out[i] = c.body_rest_pos[i] + (signs * c.body_extent[i]) @ r.T
    return out


def _outside(c, body: int, point: np.ndarray) -> float:
    """How far ``point`` lies outside ``body``'s box (0 when inside), m."""
    w, x, y, z = c.body_rest_rot[body]
    r = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])
    local = r.T @ (point - c.body_rest_pos[body])
    return float(np.linalg.norm(np.maximum(np.abs(local) - c.body_extent[body], 0.0)))


_CACHE: dict[str, engine.Creature] = {}


def creature(name: str) -> engine.Creature:
    if name not in _CACHE:
        _CACHE[name] = load_creature(os.path.join(LIBRARY, name + ".yaml"))
    return _CACHE[name]


def ncap(c, cap: str) -> int:
    return int(c.cap_count[CAPABILITIES.index(cap)])


# -- every file --------------------------------------------------------------------------


def test_library_is_big_enough():
    assert len(FILES) >= 32, f"only {len(FILES)} creature files in {LIBRARY}"


@pytest.mark.parametrize("name", NAMES)
def test_loads_cleanly(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # any CreatureWarning (or other) fails the test
        c = load_creature(os.path.join(LIBRARY, name + ".yaml"))
    assert c.name == name, "the creature's name must match its file name"
    assert 8 <= c.nbody <= 80, f"{name}: {c.nbody} bodies"
    assert c.description.strip(), f"{name}: empty description"
    assert "\n" not in c.description.strip(), f"{name}: the description must be one line"
    for key in ("body_rest_pos", "body_rest_rot", "body_joint", "body_extent", "bounds"):
        assert np.all(np.isfinite(getattr(c, key))), f"{name}: non-finite {key}"


@pytest.mark.parametrize("name", NAMES)
def test_on_the_ground(name):
    c = creature(name)
    low = _corners(c)[:, :, 2].min(axis=1)
    worst = int(np.argmin(low))
    assert low[worst] >= -GROUND_TOL, (
        f"{name}: body '{c.body_names[worst]}' reaches {low[worst]:.4f} m below the ground")
    feet = c.bodies_with("foot")
    if len(feet):
        assert abs(low[feet].min()) <= GROUND_TOL, (
            f"{name}: lowest foot box is at {low[feet].min():.4f} m, not on the ground")
        # Every foot of a library creature rests on the ground at rest, not only the lowest.
        for f in feet:
            assert abs(low[f]) <= GROUND_TOL, (
                f"{name}: foot '{c.body_names[f]}' is at {low[f]:.4f} m, not on the ground")
    else:
        # Footless creatures lie on the ground or hover, but never sink into it.
        assert low.min() >= -GROUND_TOL


@pytest.mark.parametrize("name", NAMES)
def test_joints_where_boxes_meet(name):
    """A body's joint lies in (or on) its own box and its parent's box, so limb segments
    chain end to end: a child's joint is at its parent's distal end."""
    c = creature(name)
    tol = 0.01 * float(np.max(c.size))
    for i in range(1, c.nbody):
        j = c.body_joint[i]
        p = int(c.body_parent[i])
        assert _outside(c, p, j) <= tol, (
            f"{name}: joint of '{c.body_names[i]}' is {_outside(c, p, j):.4f} m outside its "
            f"parent '{c.body_names[p]}'")
        assert _outside(c, i, j) <= tol, (
            f"{name}: joint of '{c.body_names[i]}' is {_outside(c, i, j):.4f} m outside its own box")


@pytest.mark.parametrize("name", [n for n in NAMES if n not in ASYMMETRIC])
def test_symmetric_creatures_mirror_exactly(name):
    c = creature(name)
    flip = np.array([1.0, -1.0, 1.0])
    for i in range(c.nbody):
        m = int(c.body_mirror[i])
        label = f"{name}: body '{c.body_names[i]}'"
        assert m >= 0, f"{label} has no mirror partner"
        assert int(c.body_mirror[m]) == i, f"{label}: mirror partners must pair up"
        if c.body_side[i] == 0:
            assert m == i
            continue
        assert c.body_side[m] == -c.body_side[i]
        assert c.body_caps[m] == c.body_caps[i], f"{label}: partner has other caps"
        np.testing.assert_allclose(c.body_rest_pos[m], c.body_rest_pos[i] * flip, atol=1e-9,
                                   err_msg=label)
        np.testing.assert_allclose(c.body_joint[m], c.body_joint[i] * flip, atol=1e-9,
                                   err_msg=label)
        np.testing.assert_allclose(c.body_extent[m], c.body_extent[i], atol=1e-12, err_msg=label)
        # A mirrored rotation is (w, -x, y, -z), up to the quaternion's sign.
        q, qm = c.body_rest_rot[i] * np.array([1.0, -1.0, 1.0, -1.0]), c.body_rest_rot[m]
        assert min(np.abs(q - qm).max(), np.abs(q + qm).max()) < 1e-9, f"{label}: rotation"
        # The tree is mirrored too: the partner hangs off the parent's partner.
        p = int(c.body_parent[i])
        assert int(c.body_parent[m]) == int(c.body_mirror[p]), f"{label}: parent not mirrored"
    if c.nbody:
        # The spine lies on the sagittal plane.
        assert np.all(c.body_side[c.spine_chain] == 0), f"{name}: spine off the sagittal plane"


@pytest.mark.parametrize("name", NAMES)
def test_save_load_round_trip_is_exact(name, tmp_path):
    c = creature(name)
    out = tmp_path / f"{name}.yaml"
    c.save(out)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d = load_creature(out)
    assert d.body_names == c.body_names
    assert d.name == c.name and d.description == c.description
    assert d.spine_root_index == c.spine_root_index
    for key in ("body_parent", "body_caps", "body_rest_pos", "body_rest_rot", "body_joint",
                "body_extent", "body_mirror", "body_side", "spine_chain", "leg_foot", "leg_hip",
                "leg_length", "limb_root", "bounds", "cap_count"):
        a, b = getattr(c, key), getattr(d, key)
        assert a.dtype == b.dtype and a.shape == b.shape, (name, key)
        assert np.array_equal(a, b), f"{name}: {key} changed in the round trip"


def test_counts_are_sane():
    """The numbers `menagerie creatures list` prints agree with the arrays behind them."""
    for name in NAMES:
        c = creature(name)
        k = c.counts()
        assert k["bodies"] == c.nbody and 8 <= k["bodies"] <= 80
        assert 1 <= k["spine"] <= c.nbody
        assert k["spine"] == int(np.count_nonzero(c.body_is_spine))
        assert k["legs"] == c.nleg == len(c.bodies_with("foot")) - int(
            np.count_nonzero(c.body_is_spine[c.bodies_with("foot")]))
        assert k["arms"] == len(c.bodies_with("grasper"))
        for cap, key in (("head", "heads"), ("mouth", "mouths"), ("eye", "eyes"),
                         ("wing", "wings"), ("tail", "tails")):
            assert k[key] == len(c.bodies_with(cap)), (name, key)
        assert sum(k[key] for key in ("legs", "arms", "heads")) <= c.nbody
        assert k["mouths"] >= 1, f"{name}: every library creature can eat"


def test_cli_lists_the_library():
    from engine.cli import main

    buf = io.StringIO()
    with redirect_stdout(buf):
        assert main(["creatures", "list", LIBRARY]) == 0
    text = buf.getvalue()
    assert f"{len(FILES)} creatures" in text
    for name in NAMES:
        c = creature(name)
        row = next(line for line in text.splitlines() if line.split()[:1] == [name])
        assert row.split()[1:6] == [str(c.counts()[k]) for k in ("bodies", "spine", "legs",
                                                                  "arms", "heads")], row


# -- the named creatures -----------------------------------------------------------------


REQUIRED = [
    "humanoid", "dog", "horse", "hexapod", "spider", "centipede", "snake", "fish", "bird",
    "centaur", "tripod", "octopus", "twoheaded", "threearmed", "grazer", "tiny", "giant",
    "forkstrider", "maw", "prehensile", "crawler", "longspine", "hopper", "mixedlegs",
]


@pytest.mark.parametrize("name", REQUIRED)
def test_required_creature_exists(name):
    assert name in NAMES, f"creatures/{name}.yaml is missing"


def test_humanoid_is_the_benchmark_biped():
    c = creature("humanoid")
    assert c.nbody == 25
    assert c.nleg == 2 and len(c.bodies_with("grasper")) == 2
    assert ncap(c, "head") == 1
    assert c.body_names[0] == "pelvis", "the root is the pelvis, where both legs hang"
    assert 1.70 <= c.height <= 1.80
    # Arms hang at the sides, a little away from the body: hands below the shoulders,
    # outside the torso, above the knees' height band.
    for hand, thigh in (("hand_l", "thigh_l"), ("hand_r", "thigh_r")):
        h, t = c.body(hand), c.body(thigh)
        assert abs(c.body_rest_pos[h, 1]) > abs(c.body_rest_pos[t, 1]) + 0.1
        assert c.body_rest_pos[h, 2] < 1.0
    # Straight legs: hip, knee and ankle nearly on one vertical line.
    for leg in range(c.nleg):
        joints = c.body_joint[c.leg_path(leg)]
        assert np.ptp(joints[:, 0]) < 0.05 and np.ptp(joints[:, 1]) < 0.02


def test_dog_and_horse():
    for name in ("dog", "horse"):
        c = creature(name)
        assert c.nleg == 4 and ncap(c, "head") == 1 and ncap(c, "tail") >= 3
    # The dog's tail hangs off the spine; the horse's is part of it.
    dog, horse = creature("dog"), creature("horse")
    assert not np.any(dog.body_is_spine[dog.bodies_with("tail")])
    assert np.all(horse.body_is_spine[horse.bodies_with("tail")])


def test_insects_and_arthropods():
    assert creature("hexapod").nleg == 6
    assert creature("spider").nleg == 8
    c = creature("centipede")
    assert c.nleg >= 20 and c.nleg % 2 == 0
    assert creature("crab").nleg == 8 and len(creature("crab").bodies_with("grasper")) == 2


@pytest.mark.parametrize("name", ["snake", "octopus", "fish"])
def test_footless_creatures(name):
    assert creature(name).nleg == 0


def test_octopus_has_eight_grasping_arms():
    c = creature("octopus")
    graspers = c.bodies_with("grasper")
    assert len(graspers) == 8
    assert len({int(c.body_limb[g]) for g in graspers}) == 8, "one grasper per arm"


def test_fish_floats_and_snake_lies_on_the_ground():
    fish, snake = creature("fish"), creature("snake")
    assert fish.bounds[0, 2] > 0.3, "the fish hovers"
    assert abs(snake.bounds[0, 2]) <= GROUND_TOL and snake.height < 0.15, "the snake lies flat"
    assert len(snake.spine_chain) >= 10


def test_bird_and_dragon_have_wings():
    bird = creature("bird")
    assert bird.nleg == 2 and ncap(bird, "wing") >= 2
    wings = bird.bodies_with("wing")
    assert set(np.unique(bird.body_side[wings])) == {-1, 1}, "a wing on each side"
    dragon = creature("dragon")
    assert dragon.nleg == 4 and ncap(dragon, "wing") >= 2


def test_centaur_tripod_and_hopper():
    centaur = creature("centaur")
    assert centaur.nleg == 4 and len(centaur.bodies_with("grasper")) == 2
    tripod = creature("tripod")
    assert tripod.nleg == 3
    assert sorted(int(tripod.body_side[f]) for f in tripod.leg_foot) == [-1, 0, 1]
    hopper = creature("hopper")
    assert hopper.nleg == 1 and hopper.body_side[hopper.leg_foot[0]] == 0


def test_two_headed_and_three_armed():
    two = creature("twoheaded")
    assert ncap(two, "head") == 2
    three = creature("threearmed")
    assert len(three.bodies_with("grasper")) == 3
    assert np.any(three.body_mirror < 0), "the three-armed creature is asymmetric"
    sides = three.body_side[three.bodies_with("grasper")]
    assert sorted(sides.tolist()) == [-1, 1, 1]


def test_long_necked_grazer():
    c = creature("grazer")
    assert c.nleg == 4
    head = c.bodies_with("head")[0]
    # The head is well above the withers: the neck is long.
    assert c.body_rest_pos[head, 2] > 1.5 * c.body_rest_pos[c.body("chest"), 2]


def test_tiny_and_giant():
    assert creature("tiny").height == pytest.approx(0.1, rel=0.05)
    assert creature("giant").height == pytest.approx(10.0, rel=0.05)


def test_branching_leg():
    c = creature("forkstrider")
    assert c.nleg >= 2
    first = [int(c.leg_path(k)[-1]) for k in range(c.nleg)]   # limb root of each leg
    shared = [b for b in set(first) if first.count(b) >= 2]
    assert shared, "two legs must share the same first limb body"
    for b in shared:
        assert c.has_cap(b, "limb") and not c.body_is_spine[b]
        assert c.body_child_num[b] >= 2


def test_mouth_directly_on_the_spine():
    c = creature("maw")
    mouths = c.bodies_with("mouth")
    assert len(mouths) >= 1
    assert any(c.body_is_spine[c.body_parent[m]] and not c.has_cap(int(c.body_parent[m]), "head")
               for m in mouths)


def test_grasper_on_a_tail():
    c = creature("prehensile")
    graspers = c.bodies_with("grasper")
    assert any(c.has_cap(int(g), "tail") for g in graspers)
    g = next(int(g) for g in graspers if c.has_cap(int(g), "tail"))
    chain = []
    while not c.body_is_spine[g]:
        chain.append(g)
        g = int(c.body_parent[g])
    assert len(chain) >= 4 and all(c.has_cap(b, "tail") for b in chain)


def test_prone_crawler_and_upright_long_spine():
    crawler = creature("crawler")
    assert crawler.nleg == 4
    assert crawler.size[0] > 5 * crawler.height, "prone: long and low"
    chain = crawler.body_rest_pos[crawler.spine_chain]
    assert np.ptp(chain[:, 0]) > 5 * np.ptp(chain[:, 2]), "the spine runs along X"
    tall = creature("longspine")
    assert len(tall.spine_chain) >= 10 and tall.nleg == 2
    chain = tall.body_rest_pos[tall.spine_chain]
    assert np.ptp(chain[:, 2]) > 5 * np.ptp(chain[:, 0]), "the spine runs up Z"


def test_mixed_leg_lengths():
    c = creature("mixedlegs")
    assert c.nleg == 6
    lengths = np.sort(c.leg_length)
    assert lengths[-1] / lengths[0] >= 1.8
    # Two short legs and four long ones: a clear gap between the two groups.
    assert lengths[1] * 1.5 <= lengths[2]


def test_more_creatures():
    """The creatures added beyond the required list keep the shapes they are named for."""
    elephant = creature("elephant")
    assert elephant.nleg == 4
    trunk = next(int(g) for g in elephant.bodies_with("grasper"))
    assert elephant.has_cap(int(elephant.body_spine_attach[trunk]), "head"), "trunk on the head"
    jelly = creature("jellyfish")
    assert jelly.nleg == 0 and jelly.bounds[0, 2] > 0.3 and ncap(jelly, "head") == 0
    scorpion = creature("scorpion")
    assert scorpion.nleg == 8 and len(scorpion.bodies_with("grasper")) == 2
    assert np.all(scorpion.body_is_spine[[b for b in scorpion.bodies_with("tail")
                                           if not scorpion.has_cap(b, "spike")]])
    bat = creature("bat")
    assert bat.nleg == 2 and ncap(bat, "wing") == 6 and len(bat.bodies_with("grasper")) == 2
    gorilla = creature("gorilla")
    assert gorilla.nleg == 4 and len(gorilla.bodies_with("grasper")) == 2
    assert all(gorilla.has_cap(int(g), "foot") for g in gorilla.bodies_with("grasper")), (
        "the knuckle-walker's hands are feet too")
    assert creature("minimal").nbody == 8
    inchworm = creature("inchworm")
    assert inchworm.nleg == 0 and len(inchworm.spine_chain) >= 10
    assert abs(inchworm.bounds[0, 2]) <= GROUND_TOL, "a footless crawler rests on the ground"


def test_spike_beast_is_the_largest_file():
    c = creature("spikebeast")
    assert c.nbody == 80 and ncap(c, "spike") >= 40


_FLOAT = re.compile(r"-?\d+\.\d+(?:[eE][-+]?\d+)?")


def _to_12_digits(text: str) -> str:
    """The text with every decimal number written to 12 significant digits: numpy's
    trigonometry may differ in the last bit between releases (numpy 2.4 changed a 17-digit
    repr in hexapod.yaml at its 16th digit), which says nothing about the generator."""
    return _FLOAT.sub(lambda m: format(float(m.group()), ".12g"), text)


def test_generator_reproduces_the_files():
    """creatures/_make.py regenerates every library file, character for character but for
    the last digits of floats (to 12 significant digits), and no more."""
    spec = importlib.util.spec_from_file_location("_menagerie_make_library",
                                                  os.path.join(LIBRARY, "_make.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    makers = module.build_all()
    assert sorted(m.name for m in makers) == NAMES
    for m in makers:
        with open(os.path.join(LIBRARY, m.name + ".yaml"), encoding="utf-8") as f:
            assert _to_12_digits(f.read()) == _to_12_digits(m.text()), (
                f"creatures/{m.name}.yaml differs from _make.py's output")
