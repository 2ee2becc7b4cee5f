"""The runtime: Character.tick through every stage, stage switches, placement, targets,
events, the crowd matching characters ticked alone, skinning, loading."""

from __future__ import annotations

import glob

import numpy as np
import pytest

import engine
from engine.anim import load_animation
from engine.anim.fileio import animation_from_text
from engine.runtime import Character, Crowd

DT = 1 / 60


@pytest.fixture(scope="module")
def wave():
    return load_animation("animations/wave.yaml")


def run(char, seconds):
    for _ in range(int(round(seconds / DT))):
        char.tick(DT)


def test_rest_without_animation_is_the_rest_pose(human):
    ch = Character(human, position=(2.0, 1.0, 0.0), heading=np.pi / 2)
    run(ch, 0.2)
    # Heading +90 degrees: rest x becomes world y, rest y becomes world -x.
    rest = human.body_rest_pos
    expected = np.stack([2.0 - rest[:, 1], 1.0 + rest[:, 0], rest[:, 2]], axis=1)
    # Standing: the feet are held at their rest spots by the IK, which eases the nearly
    # straight rest knees a little (soft reach); everything else is the rest pose exactly.
    legs = np.zeros(human.nbody, bool)
    for k in range(human.nleg):
        a, n = human.leg_body_adr[k], human.leg_body_num[k]
        legs[human.leg_bodies[a:a + n]] = True
    legs[0] = False
    feet = human.leg_foot
    assert np.allclose(ch.world_positions[~legs], expected[~legs], atol=1e-9)
    assert np.allclose(ch.world_positions[feet], expected[feet], atol=1e-6)
    assert np.all(np.linalg.norm(ch.world_positions[legs] - expected[legs], axis=1) < 0.02 * human.height)


def test_wave_moves_the_hand_and_only_what_it_should(human, wave):
    ch = Character(human)
    ch.play(wave, fade=0.0)
    run(ch, 0.5)
    hand = human.body("hand_l")
    assert np.linalg.norm(ch.world_positions[hand] - human.body_rest_pos[hand]) > 0.3
    assert ch.world_positions[hand, 2] > human.body_rest_pos[human.body("pelvis"), 2]
    foot = human.body("foot_r")
    assert np.allclose(ch.world_positions[foot], human.body_rest_pos[foot], atol=1e-3)
    assert np.all(np.isfinite(ch.world_positions)) and np.all(np.isfinite(ch.world_rotations))


def test_variant_and_mirror(human, wave):
    left, right = Character(human), Character(human)
    left.play(wave, variant=0, fade=0.0)
    right.play(wave, variant=1, fade=0.0)
    run(left, 0.5)
    run(right, 0.5)
    hl, hr = human.body("hand_l"), human.body("hand_r")
    mirrored = right.world_positions[hr] * np.array([1.0, -1.0, 1.0])
    assert np.allclose(left.world_positions[hl], mirrored, atol=2e-3)


def test_stage_switches(human, wave):
    ch = Character(human)
    ch.play(wave, fade=0.0)
    run(ch, 0.3)
    ch.stages.ik = False
    ch.tick(DT)
    # IK off: the rest pose carried by the root.
    assert np.allclose(ch.world_positions, human.body_rest_pos, atol=1e-9)
    ch.stages.ik = True
    ch.stages.player = False
    ch.tick(DT)
    before = ch.world_positions.copy()
    ch.tick(DT)
    assert np.allclose(ch.world_positions, before)   # time frozen, pose frozen


def test_jiggle_never_touches_driven_bodies(human, wave):
    on, off = Character(human), Character(human)
    off.stages.jiggle = False
    for ch in (on, off):
        ch.play(wave, fade=0.0)
        ch.set_placement((0, 0, 0))
    for k in range(30):
        for ch in (on, off):
            ch.set_placement((0.02 * k, 0.0, 0.0))
            ch.tick(DT)
    driven = on.ik_plan.has_ik
    assert np.array_equal(on.world_positions[driven], off.world_positions[driven])
    assert not np.array_equal(on.world_positions[~driven], off.world_positions[~driven])


def test_external_target_in_world_space(human):
    pick = load_animation("animations/pick_fruit.yaml")
    ch = Character(human, position=(5.0, 0.0, 0.0))
    fruit = np.array([5.55, 0.35, 1.3])
    ch.set_target("fruit", fruit)
    ch.play(pick, fade=0.0)
    run(ch, 1.15)     # the reach peaks at 1.0-1.3 s
    hand = ch.binding(pick).variants[0].bodies[0]
    # A hand picking a fruit must be at the fruit: the grid warns at a miss of 1% of the
    # arm's reach (under 1 cm on this human, well inside a fruit), so that is the bound.
    from engine.validation.thresholds import BY_METRIC

    reach = float(human.body_limb_length[hand] + np.linalg.norm(human.body_joint_offset[hand]))
    assert np.linalg.norm(ch.world_positions[hand] - fruit) < BY_METRIC["reach_miss"].warn * reach


def test_events_reach_the_game(human, wave):
    got = []
    ch = Character(human)
    ch.on_event = lambda handle, channel, event: got.append(event.name)
    ch.play(wave, fade=0.0)
    run(ch, 2.1)
    assert got.count("wave_peak") == 2


def test_crowd_matches_characters_alone(human, wave):
    alone = [Character(human, position=(k, 0, 0)) for k in range(3)]
    crowd_members = [Character(human, position=(k, 0, 0)) for k in range(3)]
    for k, (a, b) in enumerate(zip(alone, crowd_members, strict=True)):
        a.play(wave, variant=k % 2, speed=1 + 0.1 * k)
        b.play(wave, variant=k % 2, speed=1 + 0.1 * k)
    crowd = Crowd(crowd_members)
    for _ in range(40):
        crowd.tick(DT)
        for a in alone:
            a.tick(DT)
    for a, b in zip(alone, crowd_members, strict=True):
        assert np.allclose(a.world_positions, b.world_positions, atol=1e-12)
    # Members still work alone after joining.
    crowd_members[0].tick(DT)


def test_skinning_matrices_are_identity_at_rest(human):
    ch = Character(human)
    ch.stages.gait = False          # no standing IK on the legs: the exact rest pose
    ch.tick(DT)
    m = ch.skinning_matrices()
    assert m.shape == (human.nbody, 4, 4)
    assert np.allclose(m, np.eye(4), atol=1e-9)


def test_bad_input(human, wave):
    ch = Character(human)
    for dt in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="dt"):
            ch.tick(dt)
    with pytest.raises(ValueError, match="target"):
        ch.set_target("fruit", (0, float("inf"), 0))
    with pytest.raises(engine.MenagerieError, match="no variant"):
        ch.play(wave, variant="tentacle_3")
    with pytest.raises(engine.MenagerieError, match="snake"):
        Character(engine.load_creature("creatures/snake.yaml")).play(wave)
    with pytest.raises(TypeError):
        Character("creatures/humanoid.yaml")


def test_load_async_and_cache(tmp_path):
    from engine.loading import load, load_async

    f = load_async("creatures/spider.yaml")
    g = load_async("animations/wave.yaml")
    assert f.result(timeout=60).name == "spider"
    assert g.result(timeout=60).name == "wave"
    assert load("creatures/spider.yaml") is f.result()
    bad = tmp_path / "bad.yaml"
    bad.write_text("format: 1\nname: x\n")
    with pytest.raises(engine.DataError, match="neither"):
        load_async(bad).result(timeout=60)


#: Cells that fail a metric at 10 Hz only (they pass the 60 Hz sweep), with the figure:
#: the snake's jaw is a passive body (Jiggles) hanging from a head that sways at the
#: ground; a 0.1 s step swings it 3.2% of the height into the ground before its ground
#: contact lifts it (1.96% at 60 Hz, since stop 29; the same at 10 Hz before it).
KNOWN_10HZ: dict[tuple[str, str], dict[str, float]] = {("snake", "shake_head"): {"below_ground": 0.0315}}


@pytest.mark.parametrize("path", sorted(glob.glob("animations/*.yaml")))
def test_every_animation_every_variant_on_a_few_creatures_at_10_hz(path):
    """A game that drops to 10 frames a second still sees its creatures on the ground and
    their goals met: each variant on five library creatures, recorded at 10 Hz
    (``engine.validation.record``) and measured by the grid's ground and goal metrics
    against the grid's fail thresholds (below_ground: 2% of the height; reach_miss: 3% of
    the limb's reach). Flips are the 60 Hz sweep's (tests/test_runtime_library.py): a
    per-frame turn at 10 Hz is six frames' worth. Cells listed in that sweep's ``KNOWN``
    may fail the metrics listed there, and those in ``KNOWN_10HZ`` theirs."""
    from test_runtime_library import KNOWN  # tests/ is on sys.path (pytest's rootdir mode)

    from engine.anim.binding import branch_failures
    from engine.validation.cell import CellContext, cell_target_sets
    from engine.validation.goals import goal_error
    from engine.validation.ground import ground
    from engine.validation.record import record_cell
    from engine.validation.thresholds import FAIL, verdict

    anim = load_animation(path)
    for name in ("humanoid", "spider", "octopus", "snake", "threearmed"):
        c = engine.load_creature(f"creatures/{name}.yaml")
        if branch_failures(anim, c):
            continue
        ctx = CellContext.for_creature(c)
        b = engine.bind(anim, c)
        allowed = set(KNOWN.get((c.name, anim.name), ((), {}))[1]) | set(KNOWN_10HZ.get((c.name, anim.name), {}))
        for v in b.variants:
            rec = record_cell(c, anim, v.index, cell_target_sets(anim, c, b, v)[0], fps=10, settle=0.3)
            assert rec.error is None, (name, v.id, rec.error)
            assert np.all(np.isfinite(rec.world_pos)) and np.all(np.isfinite(rec.world_rot)), (name, v.id)
            for m in ground(rec, ctx) + goal_error(rec, ctx):
                if m.name in ("below_ground", "reach_miss", "beyond_reach") and m.name not in allowed:
                    assert verdict(m.name, m.value) != FAIL, (name, v.id, m.name, m.value, m.body, m.time)


def test_standing_feet_stay_on_the_ground_while_the_body_moves(human):
    """Without locomotion the gait stage holds the feet no clip drives at their rest spots:
    a crouch of the root alone (no foot channel) bends the knees instead of pushing the
    feet through the ground; with the gait stage off the feet sink with the root."""
    anim = animation_from_text(CROUCH_ROOT_ONLY)
    feet = human.leg_foot
    lowest = {}
    for gait_on in (True, False):
        ch = Character(human)
        ch.stages.gait = gait_on
        ch.play(anim, fade=0.0, loop=False)
        low = np.inf
        for k in range(45):
            ch.tick(DT)
            low = min(low, float(ch.world_positions[feet, 2].min()))
            assert np.all(np.isfinite(ch.world_positions))
            if gait_on:
                assert np.allclose(ch.world_positions[feet], human.body_rest_pos[feet], atol=1e-6), k
        lowest[gait_on] = low
        assert ch.world_positions[0, 2] < human.body_rest_pos[0, 2] - 0.15     # the root did crouch
    rest_low = float(human.body_rest_pos[feet, 2].min())
    assert lowest[True] >= rest_low - 1e-6
    assert lowest[False] < rest_low - 0.1


def test_standing_feet_hold_a_root_lifted_past_the_legs_reach(human):
    """A clip that lifts the root above the rest height (the legs nearly straight at rest)
    would pull the feet off their spots: the standing stage keeps every hip within its
    leg's chain of its planted foot, so the root stays where the legs can hold it and the
    feet do not move (the paper's planted feet; the grid's standing_slide)."""
    anim = animation_from_text(CROUCH_ROOT_ONLY.replace("crouch_root_only", "rise_root_only")
                               .replace("v: [0, 0, 0.3]", "v: [0, 0, -0.3]"))
    feet = human.leg_foot
    ch = Character(human)
    ch.play(anim, fade=0.0, loop=False)
    for k in range(30):
        ch.tick(DT)
        assert np.all(np.isfinite(ch.world_positions))
        assert np.allclose(ch.world_positions[feet], human.body_rest_pos[feet], atol=1e-4), k
    # the root rose only as far as the legs reach (not the 30% of its height asked)
    assert ch.world_positions[0, 2] < human.body_rest_pos[0, 2] + 0.01 * human.size[2]


def test_pivot_feet_stay_planted_while_the_root_sways():
    """The centipede's 24 knee-less legs end in long tibiae (pivot feet, engine.gait.rig):
    ``perform`` sways and yaws the root, which the planted legs cannot follow. Standing turns
    each tibia about its contact point and turns the root back as far as the legs need, so
    no contact point slides (it slid 0.94 of a leg before)."""
    from engine.validation.cell import CellContext
    from engine.validation.ground import ground
    from engine.validation.record import record_cell
    from engine.validation.thresholds import FAIL, verdict

    c = engine.load_creature("creatures/centipede.yaml")
    rec = record_cell(c, load_animation("animations/perform.yaml"), 0, settle=0.2)
    m = {x.name: x for x in ground(rec, CellContext.for_creature(c))}["standing_slide"]
    assert verdict("standing_slide", m.value) != FAIL, (m.value, m.body, m.time)


CROUCH_ROOT_ONLY = """\
format: 1
name: crouch_root_only
length: 1.0
channels:
  - name: root
    select: {type: root}
    position: {mode: rest, ground: true}
    keys:
      position:
        - {t: 0.0, v: [0, 0, 0.3]}
        - {t: 1.0, v: [0, 0, 0.3]}
"""


def test_goals_above_ground_by_hand():
    """``goals_above_ground`` on numbers worked out by hand: a 0.2 m cube's goal at
    z = -0.5 rises to 0.1 (its lowest face on the ground); turned 45 degrees about x its
    lowest edge is 0.1 * sqrt(2) below its centre; a body whose box dips 0.03 m into the
    ground at rest may go that deep; a goal of weight 0, the root, and a row whose gait set
    the terrain are left alone."""
    from engine import _runtime_kernels as RK

    nb = 5
    extent = np.full((nb, 3), 0.1)
    rest_rot = np.tile([1.0, 0.0, 0.0, 0.0], (nb, 1))
    floor = np.array([0.0, 0.0, 0.0, -0.03, 0.0])
    s45 = np.sin(np.pi / 8)
    pos = np.zeros((2, nb, 3))
    pos[:, :, 2] = -0.5
    rot = np.tile([1.0, 0.0, 0.0, 0.0], (2, nb, 1))
    rot[:, 2] = [np.cos(np.pi / 8), s45, 0.0, 0.0]
    pw = np.ones((2, nb))
    pw[:, 4] = 0.0
    rw = np.ones((2, nb))
    ground_set = np.array([False, True])
    RK.goals_above_ground(np.arange(2, dtype=np.int64), ground_set, pos, rot, pw, rw, rest_rot, extent, floor)
    np.testing.assert_allclose(pos[0, :, 2], [-0.5, 0.1, 0.1 * np.sqrt(2.0), 0.07, -0.5], atol=1e-12)
    assert np.all(pos[1, :, 2] == -0.5)
