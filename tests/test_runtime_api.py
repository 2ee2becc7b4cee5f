"""Every public ``Character`` and ``Crowd`` method at the runtime level, on real clips and
library and random creatures: queue, stop, layers and their weights, targets set and
cleared, skinning away from the rest pose, crowds of mixed creatures, and a tick that
allocates nothing once warm.

The player's bookkeeping is tested on its own in ``test_player.py``; here each method is
checked by what a game sees: the pose."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

import engine
from engine.anim import load_animation
from engine.anim.binding import BindError
from engine.model.builder import build_creature
from engine.model.random import random_creature_def
from engine.runtime import Character, Crowd

DT = 1 / 60


def run(char, seconds):
    for _ in range(int(round(seconds / DT))):
        char.tick(DT)


@pytest.fixture(scope="module")
def clips():
    return {n: load_animation(f"animations/{n}.yaml")
            for n in ("wave", "clap", "idle_breathe", "pick_fruit", "look_around", "shrug")}


def _same_pose(a: Character, b: Character, atol: float = 1e-9) -> bool:
    return (np.allclose(a.world_positions, b.world_positions, atol=atol)
            and np.allclose(np.abs(np.sum(a.world_rotations * b.world_rotations, axis=1)), 1.0, atol=atol))


def test_queue_starts_the_next_clip_when_the_first_ends(human, clips):
    """A queued clip takes over the layer when the clip before it ends, and then poses the
    character as if it had been played on its own from that moment (the crossfade over)."""
    wave = clips["wave"]
    ch = Character(human)
    first = ch.play(wave, loop=False, fade=0.2)
    second = ch.queue(clips["shrug"], fade=0.2)
    assert not second.playing
    run(ch, 1.0)
    assert first.playing and not second.playing
    # The queued clip fades in over the first's last 0.2 s, so it is in full at the end.
    run(ch, wave.length - 1.0 - 0.2 + 0.05)
    assert second.playing and first.playing
    run(ch, 0.2)
    assert second.playing and not first.playing and first.finished
    [(handle, t, _)] = ch.player.active()
    assert handle is second and t == pytest.approx(0.25, abs=1e-9)
    # Once its fade-in is over the pose is the shrug's at that clip time.
    run(ch, 0.5)
    [(_, t, weight)] = ch.player.active()
    assert weight == pytest.approx(1.0)
    ref = Character(human)
    ref.play(clips["shrug"], fade=0.0, start_time=t)
    ref.tick(1e-9)
    # Only the IK's warm start differs (it starts from last frame's pose): well under a mm.
    assert np.abs(ch.world_positions - ref.world_positions).max() < 1e-3


def test_stop_returns_to_the_rest_pose(human, clips):
    """After ``stop`` and its fade, the character stands exactly as one that never played."""
    ch, still = Character(human), Character(human)
    ch.play(clips["wave"])
    run(ch, 1.0)
    run(still, 1.0)
    assert np.abs(ch.world_positions - still.world_positions).max() > 0.3   # the hand is up
    ch.stop(fade=0.3)
    run(ch, 0.3)
    assert ch.player.active() == []
    run(ch, 0.7)                                 # jiggles settle
    run(still, 1.0)
    assert _same_pose(ch, still, atol=1e-6)


def test_stop_one_handle_keeps_the_other_layer(human, clips):
    ch = Character(human)
    breathe = ch.play(clips["idle_breathe"], layer=0)
    wave = ch.play(clips["wave"], layer=1)
    run(ch, 0.5)
    ch.stop(wave, fade=0.2)
    run(ch, 0.4)
    assert [h for h, _, _ in ch.player.active()] == [breathe]


def test_layer_weight_blends_a_layer_in_and_out(human, clips):
    """A layer at weight 0 leaves the pose of the layers below exactly; at weight 1 it
    poses what it owns; in between the hand lies between the two poses."""
    def pose(weight):
        ch = Character(human)
        ch.play(clips["idle_breathe"], layer=0, fade=0.0)
        ch.play(clips["wave"], layer=1, fade=0.0)
        ch.set_layer_weight(1, weight)
        run(ch, 0.8)
        return ch

    base = Character(human)
    base.play(clips["idle_breathe"], layer=0, fade=0.0)
    run(base, 0.8)
    off, half, on = pose(0.0), pose(0.5), pose(1.0)
    # The IK solves a plan with the hand's goal in it at weight 0: equal to 10 microns.
    assert _same_pose(off, base, atol=1e-5)
    hand = human.body("hand_l")
    p0, p1, ph = off.world_positions[hand], on.world_positions[hand], half.world_positions[hand]
    span = np.linalg.norm(p1 - p0)
    assert span > 0.3                                # the wave lifts the hand
    assert np.linalg.norm(ph - p0) > 0.2 * span      # half a layer moves it
    with pytest.raises(ValueError):
        on.set_layer_weight(1, float("nan"))


def test_clear_target_falls_back_to_the_animation_default(human, clips):
    """A target the game set moves the reach; cleared, the reach is the one the animation
    places by default, exactly as on a character whose game never set one."""
    pick = clips["pick_fruit"]
    hand = human.body("hand_l")
    moved, default = Character(human), Character(human)
    moved.play(pick)
    default.play(pick)
    moved.set_target("fruit", (0.5, -0.4, 1.2))
    run(moved, 1.1)
    run(default, 1.1)
    assert np.linalg.norm(moved.world_positions[hand] - default.world_positions[hand]) > 0.1
    moved.clear_target("fruit")
    moved.tick(DT)
    default.tick(DT)
    # The goals are the default's at once; the IK reaches them the same frame.
    assert np.linalg.norm(moved.world_positions[hand] - default.world_positions[hand]) < 1e-3
    moved.clear_target("never_set")                 # clearing an unknown target is harmless


def test_skinning_matrices_carry_rest_points_to_the_posed_bodies(human, clips):
    """Away from the rest pose, a point fixed to a body in the rest pose (character space,
    what a mesh is bound in) goes where the posed body carries it in the world."""
    ch = Character(human, position=(1.0, -2.0, 0.0), heading=0.7)
    ch.play(clips["wave"])
    run(ch, 0.9)
    skin = ch.skinning_matrices()
    rng = np.random.default_rng(3)
    local = rng.normal(size=(human.nbody, 3)) * 0.1          # a point per body, body frame
    rest_pts = human.body_rest_pos + _rotate(human.body_rest_rot, local)
    want = ch.world_positions + _rotate(ch.world_rotations, local)
    got = np.einsum("bij,bj->bi", skin[:, :3, :3], rest_pts) + skin[:, :3, 3]
    assert np.abs(got - want).max() < 1e-12
    moved = np.linalg.norm(want - (rest_pts + ch.position), axis=1)
    assert moved.max() > 0.3                                   # really away from rest
    # world_matrices agree with the pose.
    wm = ch.world_matrices()
    assert np.allclose(wm[:, :3, 3], ch.world_positions)
    out = np.empty_like(skin)
    assert ch.skinning_matrices(out) is out and np.array_equal(out, skin)


def _rotate(q, v):
    w, x, y, z = q[:, 0:1], q[:, 1:2], q[:, 2:3], q[:, 3:4]
    u = np.concatenate([x, y, z], axis=1)
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _mixed(seed_offset: int = 0) -> list[Character]:
    """Six creatures of different shapes: clips, variants, targets, walking and standing."""
    names = ("humanoid", "dog", "spider", "snake", "hexapod")
    creatures = [engine.load_creature(f"creatures/{n}.yaml") for n in names]
    creatures.append(build_creature(random_creature_def(7 + seed_offset)))
    clips = [load_animation(f"animations/{n}.yaml")
             for n in ("wave", "look_around", "pick_fruit", "tail_wag", "shake_head", "idle_breathe")]
    chars = []
    for k, c in enumerate(creatures):
        for j in range(2):
            ch = Character(c, position=(3.0 * k, 2.0 * j, 0.0), heading=0.3 * j)
            clip = clips[(k + j) % len(clips)]
            if bind_ok(ch, clip):
                ch.play(clip, variant=j % len(ch.binding(clip).variants), speed=1.0 + 0.1 * j)
            if clip.name == "pick_fruit" and ch.player.active():
                ch.set_target("fruit", ch.position + (0.4, 0.2, 0.6))
            if j == 1:
                ch.locomote((0.4, 0.0), 0.3)
            chars.append(ch)
    return chars


def bind_ok(ch: Character, clip) -> bool:
    try:
        return len(ch.binding(clip).variants) > 0
    except BindError:                   # a declined branch (the dog has no graspers)
        return False


def test_a_crowd_of_mixed_creatures_matches_them_ticked_alone():
    alone, members = _mixed(), _mixed()
    starts = {id(a): a.position for a in alone}
    crowd = Crowd(members)
    assert len(crowd) == len(members)
    for _ in range(45):
        crowd.tick(DT)
        for a in alone:
            a.tick(DT)
    walked = 0
    for a, b in zip(alone, members, strict=True):
        assert np.all(np.isfinite(b.world_positions))
        assert np.allclose(a.world_positions, b.world_positions, atol=1e-10), a.creature.name
        assert np.allclose(a.world_rotations, b.world_rotations, atol=1e-10), a.creature.name
        walked += a.gait is not None and np.linalg.norm(a.position - starts[id(a)]) > 0.1
    assert walked >= 5


def _tick_memory(ch: Character, ticks: int) -> tuple[int, int]:
    """(bytes kept over ``ticks`` ticks, the largest transient of one tick)."""
    tracemalloc.start()
    try:
        start, _ = tracemalloc.get_traced_memory()
        worst = 0
        for _ in range(ticks):
            base, _ = tracemalloc.get_traced_memory()
            tracemalloc.reset_peak()
            ch.tick(DT)
            worst = max(worst, tracemalloc.get_traced_memory()[1] - base)
        kept = tracemalloc.get_traced_memory()[0] - start
    finally:
        tracemalloc.stop()
    return kept, worst


@pytest.mark.parametrize("walking", [False, True], ids=["standing", "walking"])
def test_a_warm_tick_allocates_nothing_that_grows_with_the_creature(human, clips, walking):
    """Once warm, a tick keeps no memory (a leak or a growing cache shows within 300
    ticks), and its largest moment of passing allocation (the argument tuples of its
    kernel calls, the player's bookkeeping: about 4 kB) does not depend on the creature's
    size: a 65-body creature's tick peaks where a 25-body one's does. A per-frame array
    that outweighs those few kB (a scratch stack, (nbody, 50) floats: 10 kB against 26 kB,
    tried) grows with the bodies and fails; a small one hidden under the peak does not."""
    big = build_creature(random_creature_def(28))
    assert big.nbody >= 2.5 * human.nbody
    figures = {}
    for c in (human, big):
        ch = Character(c)
        ch.play(clips["wave"])                  # both have graspers
        if walking:
            ch.locomote((0.8, 0.0), 0.2)
        for _ in range(1500):      # numba keeps bounded bookkeeping over a kernel's first calls
            ch.tick(DT)
        figures[c.nbody] = _tick_memory(ch, 300)
    (kept_small, peak_small), (kept_big, peak_big) = figures[human.nbody], figures[big.nbody]
    assert kept_small <= 512 and kept_big <= 512, figures
    assert peak_big <= peak_small + 256, figures      # 40 more bodies: one (40, 3) array is 1 kB
    assert peak_small <= 16 * 1024, figures
def test_a_layer_at_half_weight_moves_the_hand_about_half_way(human, clips):
    """What a game sets as a weight is what it sees: a layer at weight w over one that does
    not pose the hand moves it roughly w of the way (a fade is then as long as it says)."""
    def hand_at(weight):
        ch = Character(human)
        ch.play(clips["idle_breathe"], layer=0, fade=0.0)
        ch.play(clips["wave"], layer=1, fade=0.0)
        ch.set_layer_weight(1, weight)
        run(ch, 0.8)
        return ch.world_positions[human.body("hand_l")].copy()
    p0, p1 = hand_at(0.0), hand_at(1.0)
    for w in (0.1, 0.25, 0.5, 0.75):
        f = np.linalg.norm(hand_at(w) - p0) / np.linalg.norm(p1 - p0)
        assert abs(f - w) < 0.2, (w, f)


@pytest.mark.parametrize("name", ["humanoid", "threearmed", "octopus"])
def test_fades_ease_in_and_out_without_a_step(name, clips):
    """A clip faded in over 0.3 s and stopped over 0.3 s moves every body along an eased
    path: its fastest frames are mid-fade, never at the fade's first or last frames (a goal
    whose weight is nearly 0 once moved a humanoid's hand 21 cm in the first frame of a
    fade and 19 cm in the last)."""
    c = engine.load_creature(f"creatures/{name}.yaml")
    ch = Character(c)
    run(ch, 0.2)
    def steps(frames):
        out = []
        for _ in range(frames):
            before = ch.world_positions.copy()
            ch.tick(DT)
            out.append(np.linalg.norm(ch.world_positions - before, axis=1).max())
        return np.array(out)
    ch.play(clips["wave"], fade=0.3)
    fade_in = steps(18)
    run(ch, 0.5)
    ch.stop(fade=0.3)
    fade_out = steps(18)
    for what, s in (("fade in", fade_in), ("fade out", fade_out)):
        assert s.max() > 0.01 * c.height, what                    # something moves
        edge = max(s[:2].max(), s[-2:].max())
        assert edge < 0.6 * s.max(), (what, np.round(s / c.height, 4))
