"""The gait stage as one kernel over many characters (engine.gait._step_kernels) and the
crowd's batched bookkeeping: the same output as the characters ticked alone, bit for bit."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

import engine
from engine.anim.binding import branch_failures
from engine.gait import _step_kernels as SK
from engine.gait import controller as C
from engine.runtime import Character, Crowd

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


_CREATURES: dict = {}


def _creature(name):
    """One Creature per name (a crowd groups characters by creature object)."""
    if name not in _CREATURES:
        _CREATURES[name] = engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))
    return _CREATURES[name]


def _anim(name):
    return engine.load_animation(os.path.join(ROOT, "animations", f"{name}.yaml"))


def test_python_float_semantics_reproduced_exactly():
    """The kernel's min, max, hypot, % and remainder are Python's, bit for bit (the C
    library's hypot differs from math.hypot in the last bit for ~0.3 % of inputs)."""
    rng = np.random.default_rng(7)
    n = 20000
    for scale in (1e-300, 1e-6, 1.0, 1e6, 1e300):
        x = rng.normal(size=n) * scale
        y = rng.normal(size=n) * scale * rng.choice([1e-12, 1e-3, 1.0, 30.0], size=n)
        y[:50] = 0.0
        x[50:100] = -0.0
        for a, b in zip(x.tolist(), y.tolist(), strict=True):
            assert SK._pyhypot(a, b) == math.hypot(a, b), (a, b)
    for a, b in [(math.inf, 1.0), (1.0, -math.inf), (0.0, 0.0), (5e-324, 5e-324), (3.0, 4.0)]:
        assert SK._pyhypot(a, b) == math.hypot(a, b)
    assert math.isnan(SK._pyhypot(math.nan, 1.0))
    assert SK._pyhypot(math.nan, math.inf) == math.inf
    v = rng.normal(size=5000) * 10
    for a in v.tolist():
        assert SK._pymod(a, 1.0) == a % 1.0
        assert math.copysign(1.0, SK._pymod(a, 1.0)) == math.copysign(1.0, a % 1.0)
        r = SK._pyremainder(a, 2 * math.pi)
        assert r == math.remainder(a, 2 * math.pi)
    assert SK._pymod(-0.0, 1.0) == 0.0 and math.copysign(1.0, SK._pymod(-0.0, 1.0)) == 1.0
    for a, b in [(0.0, -0.0), (-0.0, 0.0), (1.0, 1.0), (2.0, 1.0)]:
        assert math.copysign(1.0, SK._pymin(a, b)) == math.copysign(1.0, min(a, b))
        assert math.copysign(1.0, SK._pymax(a, b)) == math.copysign(1.0, max(a, b))


def test_kernel_constants_are_the_controllers():
    for name in ("HEIGHT_TAU", "TILT_TAU", "FOOT_TILT_TAU", "BOB_TAU", "IDLE_SPEED", "IDLE_TURN"):
        assert getattr(SK, name) == getattr(C, name), name


def _walkers(names, per):
    chars = []
    for k in range(per * len(names)):
        c = _creature(names[k % len(names)])
        ch = Character(c, position=(2.0 * (k % 4), 2.0 * (k // 4), 0.0), heading=0.4 * k)
        playable = [a for a in (_anim("wave"), _anim("perform"), _anim("roar")) if not branch_failures(a, c)]
        if playable:
            ch.play(playable[k % len(playable)])
        ch.locomote(velocity=(0.4 * c.height, 0.05 * c.height * (k % 3 - 1)), turn_rate=0.3 * ((k % 3) - 1))
        chars.append(ch)
    return chars


def _script(chars, frame):
    """Stops, restarts and a teleport (a row planted afresh inside the batch)."""
    if frame == 25:
        chars[0].locomote(velocity=(0.0, 0.0))
    if frame == 40:
        chars[0].locomote(velocity=(0.6 * chars[0].creature.height, 0.0), turn_rate=-0.5)
        chars[-1].set_placement(position=(7.0, -3.0, 0.0), heading=2.0)


@pytest.mark.parametrize("names", [("humanoid", "dog"), ("centipede", "snake", "octopus")])
def test_walking_crowd_equals_members_alone(names):
    """Walkers (legged, crawling, floating) stepped in one kernel call per creature give
    exactly the poses of the same characters ticked one by one."""
    crowd_chars = _walkers(names, 3)
    alone = _walkers(names, 3)
    crowd = Crowd(crowd_chars)
    for f in range(60):
        _script(crowd_chars, f)
        _script(alone, f)
        crowd.tick(1 / 60)
        for ch in alone:
            ch.tick(1 / 60)
    for a, b in zip(alone, crowd_chars, strict=True):
        assert np.array_equal(a.world_positions, b.world_positions)
        assert np.array_equal(a.world_rotations, b.world_rotations)
        assert np.array_equal(a.gait.step_state, b.gait.step_state)
        assert a.gait.turn_rate == b.gait.turn_rate and a.gait.speed_limit == b.gait.speed_limit
    # the controllers now live in the crowd's gait stack, one row each
    stacks = {id(ch.gait._gs) for ch in crowd_chars}
    assert len(stacks) == len(names)


def test_member_that_starts_walking_inside_a_crowd_joins_the_batch():
    chars = [Character(_creature("dog"), position=(2.0 * k, 0.0, 0.0)) for k in range(4)]
    alone = [Character(_creature("dog"), position=(2.0 * k, 0.0, 0.0)) for k in range(4)]
    crowd = Crowd(chars)
    for f in range(40):
        if f == 10:
            for group in (chars, alone):
                group[2].locomote(velocity=(0.5, 0.0), turn_rate=0.2)
        crowd.tick(1 / 60)
        for ch in alone:
            ch.tick(1 / 60)
    assert chars[2].gait._gs is crowd._groups[0]._gait.stack
    for a, b in zip(alone, chars, strict=True):
        assert np.array_equal(a.world_positions, b.world_positions)
    assert np.linalg.norm(chars[2].position[:2] - np.array([4.0, 0.0])) > 0.05     # it walked


def test_terrain_rows_go_through_python_and_match():
    """A row on a Python terrain function (heights and a normal) inside a batch of flat
    ones: sampled between the kernel's two halves, the same poses as alone."""
    hill = lambda x, y: 0.08 * np.sin(0.9 * np.asarray(x)) + 0.04 * np.asarray(y)   # noqa: E731
    normal = lambda x, y: np.array([-0.072 * np.cos(0.9 * x), -0.04, 1.0])          # noqa: E731

    def make():
        out = [Character(_creature("hexapod"), position=(1.5 * k, 0.0, 0.0)) for k in range(3)]
        out[1].set_terrain(hill, normal)
        out[2].set_terrain(hill)
        for ch in out:
            ch.locomote(velocity=(0.3, 0.0), turn_rate=0.2)
        return out

    crowd_chars, alone = make(), make()
    crowd = Crowd(crowd_chars)
    for _ in range(45):
        crowd.tick(1 / 60)
        for ch in alone:
            ch.tick(1 / 60)
    for a, b in zip(alone, crowd_chars, strict=True):
        assert np.array_equal(a.world_positions, b.world_positions)
        assert np.array_equal(a.gait.ground_plane, b.gait.ground_plane)
    assert crowd_chars[1].gait.ground_plane[0] != 0.0      # the sloped ground was used


def test_style_layers_beyond_the_stack_capacity():
    """More style layers than a stack holds: the controller moves to a larger stack of its
    own, the crowd re-gathers, and the output still equals the character alone."""
    def make():
        ch = Character(_creature("dog"))
        ch.locomote(velocity=(0.5, 0.0))
        return ch

    a, b = make(), make()
    crowd = Crowd([b, Character(_creature("dog"), position=(3.0, 0.0, 0.0))])
    for f in range(50):
        if f == 5:
            for ch in (a, b):
                for k, st in enumerate(("trot", "limp", "sneak", "heavy", "run")):
                    ch.gait.set_style(st, layer=True, weight=0.2 + 0.1 * k)
        crowd.tick(1 / 60)
        a.tick(1 / 60)
    assert b.gait._tab.shape[1] > C.STACK_LAYERS
    assert np.array_equal(a.world_positions, b.world_positions)


def test_crowd_fires_the_same_events_as_members_alone():
    """The crowd calls the players' Python only for rows where a key may fire; every key
    still fires, once, on the frame it fires alone."""
    clips = [_anim(n) for n in ("clap", "punch", "dance", "wave")]
    fired = {"crowd": [], "alone": []}

    def make(tag):
        out = []
        for k in range(8):
            ch = Character(_creature("humanoid"), position=(k, 0.0, 0.0))
            ch.on_event = lambda h, channel, event, k=k, tag=tag: fired[tag].append((frame[0], k, channel, event.t))
            ch.play(clips[k % 4], speed=0.7 + 0.15 * k, start_time=0.0 if k % 3 else 0.1)
            out.append(ch)
        return out

    frame = [0]
    crowd_chars, alone = make("crowd"), make("alone")
    crowd = Crowd(crowd_chars)
    for f in range(240):
        frame[0] = f
        if f == 100:
            for group in (crowd_chars, alone):
                group[1].play(clips[2], speed=-1.0, start_time=1.0)
        crowd.tick(1 / 60)
        for ch in alone:
            ch.tick(1 / 60)
    assert fired["alone"], "the clips have key events"
    assert fired["crowd"] == fired["alone"]
