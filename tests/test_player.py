"""The animation player: time, loops, fades, cross-fades, the queue, layers and events."""

from __future__ import annotations

import numpy as np
import pytest

from engine.anim import animation_from_text
from engine.anim.player import Player, PlayerArrays, advance_arrays

CLIP = """\
format: 1
name: {name}
description: a test clip with events
length: {length}
loop: {loop}
channels:
  - name: body
    select: {{type: root}}
    position: {{mode: rest}}
    keys:
      position:
        - {{t: 0.0, v: [0, 0, 0]}}
        - {{t: {length}, v: [0, 0, 0.1]}}
      events:
        - {{t: 0.0, name: start}}
        - {{t: 0.5, name: half}}
"""


def clip(name="a", length=1.0, loop=False):
    return animation_from_text(CLIP.format(name=name, length=length, loop=str(loop).lower()))


def run(player, seconds, dt=1 / 60):
    for _ in range(int(round(seconds / dt))):
        player.advance(dt)


def test_time_and_loop():
    p = Player()
    h = p.play(clip(loop=True), fade=0.0)
    run(p, 2.25)
    (handle, t, w), = p.active()
    assert handle is h and abs(t - 0.25) < 1e-9 and w == 1.0


def test_non_looping_clip_fades_out_as_it_ends():
    p = Player()
    h = p.play(clip(length=1.0), fade=0.0, fade_out=0.25)
    weights = []
    for _ in range(70):
        p.advance(1 / 60)
        weights.append(p.active()[0][2] if p.active() else 0.0)
    assert weights[30] == 1.0                    # 0.5 s: playing fully
    assert 0.0 < weights[52] < 1.0               # 0.88 s: fading
    assert h.finished and not p.active()         # gone by the end
    assert all(b <= a + 1e-12 for a, b in zip(weights[45:], weights[46:], strict=False))


def test_crossfade_weights_sum_to_one_and_are_smooth():
    p = Player()
    p.play(clip("a", loop=True), fade=0.0)
    run(p, 0.5)
    p.play(clip("b", loop=True), fade=0.3)
    sums, prev = [], None
    for _ in range(30):
        p.advance(1 / 60)
        w = {h.animation.name: wt for h, _, wt in p.active()}
        sums.append(sum(w.values()))
        if prev is not None:
            assert abs(w.get("b", 0) - prev) < 0.1      # no jump
        prev = w.get("b", 0)
    assert np.allclose(sums, 1.0)
    assert [h.animation.name for h, _, _ in p.active()] == ["b"]


def test_queue_starts_when_the_current_clip_ends():
    p = Player()
    a = p.play(clip("a", length=0.5), fade=0.0, fade_out=0.1)
    b = p.queue(clip("b", length=0.5), fade=0.1)
    assert not b.playing
    run(p, 0.45)
    assert b.playing and a.playing          # overlapping cross-fade
    run(p, 0.2)
    assert a.finished and b.playing
    # Queue on an empty layer plays at once.
    c = p.queue(clip("c"), layer=2)
    assert c.playing


@pytest.mark.parametrize("fade_out", [None, 0.0, 0.05])
def test_queued_clip_cross_fades_with_a_clip_played_without_fade(fade_out):
    # play(fade=0) makes the clip's fade-out 0 too: the queued clip must still cross-fade
    # (the ending clip fades out over the queued clip's fade-in), never a frame of no weight
    p = Player()
    a = p.play(clip("a", length=0.5), fade=0.0, fade_out=fade_out)
    b = p.queue(clip("b", length=1.0), fade=0.2)
    sums, wb = [], []
    for _ in range(50):
        p.advance(1 / 60)
        w = {h.animation.name: wt for h, _, wt in p.active()}
        sums.append(sum(w.values()))
        wb.append(w.get("b", 0.0))
    assert min(sums) > 0.99, min(sums)
    assert a.finished and b.playing
    assert max(abs(x - y) for x, y in zip(wb, wb[1:], strict=False)) < 0.15   # b fades in, no jump


def test_loop_hands_over_to_a_queued_clip_over_its_fade_in():
    p = Player()
    p.play(clip("a", loop=True, length=0.5), fade=0.0)
    p.queue(clip("b", length=1.0), fade=0.2, fade_out=0.0)
    sums = []
    for _ in range(60):
        p.advance(1 / 60)
        sums.append(sum(wt for _, _, wt in p.active()))
    assert min(sums) > 0.99, min(sums)


def test_layers_and_weights():
    p = Player()
    base = p.play(clip("base", loop=True), fade=0.0)
    top = p.play(clip("top", loop=True), fade=0.0, layer=1, weight=0.5)
    p.set_layer_weight(1, 0.5)
    p.advance(1 / 60)
    w = {h.animation.name: wt for h, _, wt in p.active()}
    assert w == {"base": 1.0, "top": 0.25}
    p.stop(top, fade=0.0)
    assert not top.playing and base.playing


def test_events_fire_once_per_pass_even_when_looping():
    fired = []
    p = Player(on_event=lambda h, ch, e: fired.append(e.name))
    p.play(clip(loop=True), fade=0.0)
    run(p, 2.0 - 1e-6, dt=0.1)
    assert fired == ["start", "half", "start", "half"]


def test_events_with_big_steps_and_backwards():
    fired = []
    p = Player(on_event=lambda h, ch, e: fired.append(e.name))
    p.play(clip(loop=True), fade=0.0, speed=-1.0)
    p.advance(0.7)          # 1.0 -> 0.3 backwards: passes 0.5
    assert fired == ["half"]


def test_invalid_arguments():
    p = Player()
    a = clip()
    for kwargs in ({"weight": 1.5}, {"fade": -1}, {"speed": float("nan")}, {"layer": 9}):
        with pytest.raises(ValueError):
            p.play(a, **kwargs)
    with pytest.raises(ValueError):
        p.set_layer_weight(0, 2.0)


def test_slots_run_out_gracefully():
    p = Player(nslot=2)
    for name in "abc":
        p.play(clip(name, loop=True), crossfade=False)
    assert len(p.active()) == 2


def test_crowd_stack_is_one_call():
    # Rows of one stack advance together and match players advanced alone.
    players = [Player() for _ in range(3)]
    for k, pl in enumerate(players):
        pl.play(clip(loop=True), fade=0.1, speed=1.0 + k)
    alone = [Player() for _ in range(3)]
    for k, pl in enumerate(alone):
        pl.play(clip(loop=True), fade=0.1, speed=1.0 + k)
    stack = PlayerArrays.allocate(3, players[0].nslot, players[0].nlayer)
    for k, pl in enumerate(players):
        stack.rows(k, k + 1).copy_from(pl.arrays)
        pl.arrays = stack.rows(k, k + 1)
    for _ in range(20):
        advance_arrays(stack, 1 / 60)
        for pl in players:
            pl.after_advance()
        for pl in alone:
            pl.advance(1 / 60)
    for pl, ref in zip(players, alone, strict=True):
        assert np.array_equal(pl.arrays.time, ref.arrays.time)
        assert np.array_equal(pl.arrays.effective, ref.arrays.effective)
