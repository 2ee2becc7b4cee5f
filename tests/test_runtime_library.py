"""Every library animation, in every variant, on every library creature and on 100 random
creatures, for its whole length: finite output, no exception (or a clear refusal from the
bind phase when a branch predicate excludes the creature)."""

from __future__ import annotations

import glob

import numpy as np
import pytest

import engine
from engine.anim import load_animation
from engine.anim.binding import branch_failures
from engine.model import build_creature
from engine.model.random import random_creature_def

DT = 0.1   # coarse frames keep this sweep fast; the runtime must be stable at any dt


@pytest.fixture(scope="module")
def animations():
    return [load_animation(p) for p in sorted(glob.glob("animations/*.yaml"))]


def _play_everything(creature, animations) -> int:
    played = 0
    for anim in animations:
        if branch_failures(anim, creature):
            with pytest.raises(engine.MenagerieError, match=creature.name):
                engine.Character(creature).play(anim)
            continue
        binding = engine.bind(anim, creature)
        for v in range(binding.nvariant):
            ch = engine.Character(creature, position=(1.0, -2.0, 0.0), heading=0.7)
            ch.set_target("fruit", (1.5, -1.6, 0.6 * creature.height))
            ch.play(anim, variant=v, fade=0.0, loop=False)
            for _ in range(int(np.ceil(anim.length / DT)) + 1):
                ch.tick(DT)
                assert np.all(np.isfinite(ch.world_positions)), (creature.name, anim.name, v)
                assert np.all(np.isfinite(ch.world_rotations)), (creature.name, anim.name, v)
            played += 1
    return played


@pytest.mark.parametrize("path", sorted(glob.glob("creatures/*.yaml")))
def test_library_creature(path, animations):
    c = engine.load_creature(path)
    assert _play_everything(c, animations) > 0


def test_random_creatures(animations):
    played = 0
    for seed in range(100):
        played += _play_everything(build_creature(random_creature_def(seed)), animations)
    assert played > 1000
