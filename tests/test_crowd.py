"""The crowd on all cores: the parallel IK and sampling kernels give the poses of the
serial ones (each member ticked alone), for crowds big enough to go parallel, crowds of
one and two, members on different variants, speeds and goal sets, and bad input in one
row of a parallel solve."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import engine
from engine import _runtime_kernels as RK
from engine import runtime as R
from engine.anim import load_animation
from engine.ik._kernels import borrow
from engine.runtime import Character, Crowd

DT = 1 / 60


@pytest.fixture(scope="module")
def perform():
    return load_animation("animations/perform.yaml")


@pytest.fixture(scope="module")
def wave():
    return load_animation("animations/wave.yaml")


def _pair(human, n, setup):
    alone = [Character(human, position=(k % 5, k // 5, 0)) for k in range(n)]
    members = [Character(human, position=(k % 5, k // 5, 0)) for k in range(n)]
    for k, (a, b) in enumerate(zip(alone, members, strict=True)):
        setup(k, a)
        setup(k, b)
    return alone, members, Crowd(members)


def test_parallel_crowd_matches_members_alone(human, perform, wave):
    """A crowd past the parallel threshold, members on different variants, speeds and
    animations (so two IK plans and several bound variants): every pose equals the same
    character ticked alone (the serial kernels) to rounding."""
    n = R.PARALLEL_MIN_ROWS + 9
    nvar = engine.bind(perform, human).nvariant

    def setup(k, ch):
        if k % 5 == 4:
            ch.play(wave, variant=k % 2, speed=0.9 + 0.02 * k)
        else:
            ch.play(perform, variant=k % nvar, speed=0.8 + 0.4 * k / n)

    alone, members, crowd = _pair(human, n, setup)
    group = crowd._groups[0]
    for _ in range(30):
        crowd.tick(DT)
        for a in alone:
            a.tick(DT)
    # The big plan group and the big variant groups really ran in parallel.
    assert any(sc is not None for _, _, _, sc in group._plan_groups())
    assert any(p[2] is not None for p in group._pair_groups())     # a parallel sampling kernel
    for a, b in zip(alone, members, strict=True):
        assert np.all(np.isfinite(b.world_positions))
        assert np.allclose(a.world_positions, b.world_positions, atol=1e-12, rtol=0)
        assert np.allclose(a.world_rotations, b.world_rotations, atol=1e-12, rtol=0)


@pytest.mark.parametrize("n", [1, 2])
def test_small_crowds_stay_serial_and_match(human, perform, n):
    alone, members, crowd = _pair(human, n, lambda k, ch: ch.play(perform, speed=1.0 + 0.1 * k))
    for _ in range(10):
        crowd.tick(DT)
        for a in alone:
            a.tick(DT)
    group = crowd._groups[0]
    assert all(sc is None for _, _, _, sc in group._plan_groups())
    assert all(p[2] is None for p in group._pair_groups())     # no parallel sampling kernel
    for a, b in zip(alone, members, strict=True):
        assert np.array_equal(a.world_positions, b.world_positions)


def test_parallel_ik_kernel_equals_serial_whatever_the_chunks(human, perform):
    """Same inputs through the serial kernel and the parallel one cut into 1, 3 and 40
    chunks (more chunks than rows too): bit-identical poses."""
    n = 24
    chars = [Character(human) for _ in range(n)]
    for k, ch in enumerate(chars):
        ch.play(perform, speed=0.7 + 0.05 * k)
    crowd = Crowd(chars)
    for _ in range(7):
        crowd.tick(DT)
    s = crowd._groups[0].stack
    plan, scratch, idx, _ = crowd._groups[0]._plan_groups()[0]
    b = plan.blobs
    ref_pos, ref_rot = s.char_pos.copy(), s.char_rot.copy()
    ref_pos[idx] = 0.0
    ref_rot[idx] = 0.0
    bad = np.zeros(n, np.int64)
    assert RK.solve_indexed(*b, idx, s.root_pos, s.root_rot, s.goal_pos, s.goal_rot, s.goal_pw, s.goal_rw, ref_pos,
                            ref_rot, scratch, bad, s.ground_set) == 0
    for chunks in (1, 3, 40):
        pos = np.zeros_like(ref_pos)
        rot = np.zeros_like(ref_rot)
        scratches = np.zeros((chunks,) + plan.scratch_shape)
        with numba.parallel_chunksize(1):
            nbad = RK.solve_indexed_parallel(*b, idx, s.root_pos, s.root_rot, s.goal_pos, s.goal_rot, s.goal_pw,
                                             s.goal_rw, pos, rot, scratches, bad, s.ground_set)
        assert nbad == 0
        assert np.array_equal(pos[idx], ref_pos[idx])
        assert np.array_equal(rot[idx], ref_rot[idx])


def test_bad_goal_in_a_parallel_crowd_names_the_character(human, perform):
    n = R.PARALLEL_MIN_ROWS + 2
    chars = [Character(human) for _ in range(n)]
    for ch in chars:
        ch.play(perform)
    crowd = Crowd(chars)
    crowd.tick(DT)
    group = crowd._groups[0]
    assert group._plan_groups()[0][3] is not None
    s = group.stack
    before = s.char_pos[5].copy()
    s.char_pos[4] = 0.0
    s.goal_pw[5, human.body("hand_l")] = np.nan
    with pytest.raises(engine.MenagerieError, match="hand_l"):
        group._solve(True)
    # The kernels check before writing: row 5 keeps its pose, the others are solved.
    assert np.array_equal(s.char_pos[5], before)
    assert np.allclose(s.char_pos[4], before, atol=1e-12)


def test_borrowed_views_share_memory():
    @numba.njit
    def write_through(a, t):
        v = borrow(a[1])
        w = borrow((a, t))
        v[2] = 7.0
        w[0][0, 0] = w[1][1]
        return v.sum()

    a = np.zeros((3, 4))
    assert write_through(a, (1.0, 5.0)) == 7.0
    assert a[1, 2] == 7.0 and a[0, 0] == 5.0


def test_a_member_far_down_a_big_crowd_can_be_ticked_alone(human, wave):
    """Row indices past the first 64 (the runtime's one-element index arrays grow)."""
    def setup(k, ch):
        ch.play(wave, variant=k % 2)

    alone, members, crowd = _pair(human, 70, setup)
    crowd.tick(DT)
    alone[69].tick(DT)
    members[69].tick(DT)            # alone, though it lives in row 69 of the crowd's stack
    alone[69].tick(DT)
    assert np.allclose(members[69].world_positions, alone[69].world_positions, atol=1e-12)


def test_thread_choice_measures_and_falls_back(monkeypatch):
    """The crowd runs its big stages on all cores only while that is faster: it probes
    both, keeps the faster, and drops to serial on a late parallel frame."""
    monkeypatch.setattr(numba, "get_num_threads", lambda: 2)
    tc = R._ThreadChoice()
    modes = []
    for _ in range(2 * tc.PROBE):
        p = tc.choose()
        modes.append(p)
        tc.record(p, 0.010 if p else 0.006)     # parallel slower: a busy core
    assert modes.count(True) == modes.count(False) == tc.PROBE
    assert tc.choose() is False
    tc = R._ThreadChoice()
    for _ in range(2 * tc.PROBE):
        p = tc.choose()
        tc.record(p, 0.004 if p else 0.008)
    assert tc.choose() is True
    tc.record(True, 0.020)                      # a late frame
    assert tc.choose() is False
    for _ in range(tc.REPROBE):
        tc.choose()
    assert tc.mode is None                      # measured again


def test_serial_and_parallel_frames_give_the_same_poses(human, perform):
    """Switching between the two paths never shows: both give the same poses."""
    n = R.PARALLEL_MIN_ROWS + 9
    runs = []
    for force in (True, False):
        alone, members, crowd = _pair(human, n, lambda k, ch: ch.play(perform, speed=0.9 + 0.02 * k))
        group = crowd._groups[0]
        group._threads.mode = force
        for _ in range(12):
            crowd.tick(DT)
        runs.append([m.world_positions.copy() for m in members])
    for a, b in zip(*runs, strict=True):
        assert np.array_equal(a, b)


def test_a_clip_change_rebuilds_only_the_variants_it_touches(human, perform, wave):
    """Members on three bound variants (wave 0, wave 1, perform); one wave-0 member starts
    performing: the wave-1 entry (its views and bound kernels) is kept as it was,
    the two variants the switch touched are rebuilt, and every pose still equals the
    member ticked alone."""
    assert engine.bind(wave, human).nvariant >= 2

    def setup(k, ch):
        ch.play(wave, variant=k % 2) if k < 4 else ch.play(perform)

    alone, members, crowd = _pair(human, 6, setup)
    group = crowd._groups[0]

    def run(frames):
        for _ in range(frames):
            crowd.tick(DT)
            for a in alone:
                a.tick(DT)

    run(5)

    before = [e[1] for e in group._pair_groups()]
    assert len(before) == 3
    for ch in (alone[0], members[0]):   # wave variant 0 -> perform
        ch.play(perform)
    run(40)
    after = [e[1] for e in group._pair_groups()]
    kept = [b for b in after if any(b is a for a in before)]
    assert len(after) == 3 and len(kept) == 1
    assert kept[0].args[4].shape[0] == 2                      # wave variant 1: members 1 and 3
    for a, b in zip(alone, members, strict=True):
        assert np.allclose(a.world_positions, b.world_positions, atol=1e-12, rtol=0)
        assert np.allclose(a.world_rotations, b.world_rotations, atol=1e-12, rtol=0)
