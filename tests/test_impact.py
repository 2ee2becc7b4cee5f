"""Impact response (engine.response.impact): hits on library, random and captured
creatures, hits in series, determinism, bad input, the search against brute force."""

from __future__ import annotations

import os

import numpy as np
import pytest

import engine
from engine.model import build_creature, random_creature_def
from engine.physics.world import rotvec_between
from engine.response import search as S
from engine.response.impact import ImpactError, ImpactParams, _models
from engine.response.library import MotionLibrary, library_for
from engine.runtime import Character

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BOXING = os.path.join(ROOT, "..", "shared", "data", "mocap", "boxing_toes_punch_hit_fall.bvh")
DT = 1 / 60


def _creature(kind):
    if kind == "capture":
        from engine.io.bvh_creature import creature_from_bvh

        return creature_from_bvh(BOXING)
    if kind.startswith("random"):
        return build_creature(random_creature_def(int(kind[6:])))
    return engine.load_creature(os.path.join(ROOT, "creatures", f"{kind}.yaml"))


_CHARS: dict = {}


def _standing(kind):
    c = _CHARS.get(kind)
    if c is None:
        c = _CHARS[kind] = _creature(kind)
    ch = Character(c)
    ch.play(engine.load_animation(os.path.join(ROOT, "animations", "idle_breathe.yaml")))
    for _ in range(10):
        ch.tick(DT)
    return ch


def _run(ch, hits, seconds=3.0):
    """Tick through ``hits`` [(tick, body, impulse)]; return per-frame checks."""
    prev_rot = ch.world_rotations.copy()
    maxrot, minz, end_tick, finite = 0.0, np.inf, None, True
    p0 = ch.world_positions[0].copy()
    last_hit = max(t for t, _, _ in hits)
    for k in range(int(seconds / DT)):
        was_physical = ch.reacting and ch.response.phase in ("burst", "transition")
        for t, b, J in hits:
            if t == k:
                ch.hit(b, J)
        ch.tick(DT)
        finite &= bool(np.all(np.isfinite(ch.world_positions)) and np.all(np.isfinite(ch.world_rotations)))
        # the hand-offs: to physics (the impact tick from animation) and back (the blend);
        # in between the bodies move as the physics moves them
        handoff = (not was_physical) or not (ch.reacting and ch.response.phase in ("burst", "transition"))
        turn = float(np.linalg.norm(rotvec_between(prev_rot, ch.world_rotations), axis=1).max())
        if handoff:
            maxrot = max(maxrot, turn)
        prev_rot = ch.world_rotations.copy()
        minz = min(minz, float(ch.world_positions[:, 2].min() - 0.0))
        if k > last_hit and end_tick is None and not ch.reacting:
            end_tick = k
    return dict(maxrot=maxrot, minz=minz, back=None if end_tick is None else (end_tick - last_hit) * DT,
                finite=finite, disp=ch.world_positions[0] - p0)


def _lowest_rest(ch):
    # bodies' centres: the lowest centre of the rest pose less its half extent sits on the ground
    return -0.01 - float(np.max(ch.creature.body_extent))


# random4 was a strict xfail: it re-entered 'roar' and ended 0.25 m (3% of its 7.7 m height) against
# the push, cos -0.94. With its planted feet held (ground contacts through the tree, issue 13) the
# lookahead's root no longer drifts with sliding feet, the search finds 'idle_breathe', and it ends
# 0.009 m (0.1% of its height) from where it stood (the s28-slide8 note).
# The cause of the old failure, a search that does not look at where a clip takes the root, is still there.
@pytest.mark.parametrize("kind", ["humanoid", "dog", "random1", "capture", "random3", "random4"])
def test_a_hit_is_answered_and_the_character_is_back_on_animation(kind):
    ch = _standing(kind)
    c = ch.creature
    mass = _models(c, ImpactParams())[1].total_mass
    J = np.array([-1.0, 0.3, 0.0]) / np.hypot(1.0, 0.3) * 1.5 * mass      # 1.5 m/s to all of it: a shove
    r = _run(ch, [(0, 0, J)])
    assert r["finite"]
    assert r["back"] is not None and r["back"] <= 2.0, r
    assert r["maxrot"] < 0.5, r
    # a clip found, or a tap: the lookahead kept the root within 5% of the height (random1 and
    # random4: 1.5 m/s is a small shove for a 1.1 m and a 7.7 m creature on anchored stance legs)
    assert ch.response.clip is not None or ch.response.tap
    disp = r["disp"][:2]
    if np.linalg.norm(disp) > 0.02 * c.height:
        cos = disp @ J[:2] / (np.linalg.norm(disp) * np.linalg.norm(J[:2]))
        assert cos > 0.5, (disp, J)


def test_the_impact_tick_does_not_pop():
    """A hit of almost nothing: the first physical frame continues the animated motion."""
    ch = _standing("humanoid")
    ref = _standing("humanoid")
    ch.hit("spine2", (1e-6, 0, 0))
    ch.tick(DT)
    ref.tick(DT)
    h = ch.creature.height
    assert ch.reacting and ch.response.phase == "burst"
    assert np.abs(ch.world_positions - ref.world_positions).max() < 0.01 * h
    assert np.linalg.norm(rotvec_between(ref.world_rotations, ch.world_rotations), axis=1).max() < 0.05


# Both were strict xfails: the hand-back out of the found clip turned a body more than 0.5 rad in a
# frame (main: n=2 0.783 out of 'fall_left', n=5 0.686 out of 'lie_right', a body centre 0.015 m under
# the ground). With the planted feet held (issue 13) the hits no longer slide the humanoid's feet out
# from under it: n=5 stays up and re-enters 'stagger_right', 0.370 rad at most, body centres 0.020 m
# above the ground or higher; n=2 re-enters 'punch', 0.553 rad with 4 contact sweeps (the feet still crept
# sideways), 0.390 with 16 (CONTACT_SWEEPS; only measured, not traced further), minz 0.0024.
# The older history of this test: the s23-impact3 note (ears and eyes turning out of a found fall_left).
@pytest.mark.parametrize("n", [2, 5])
def test_hits_in_series(n):
    rng = np.random.default_rng(n)
    ch = _standing("humanoid")
    c = ch.creature
    t, hits = 0, []
    for _ in range(n):
        d = rng.normal(size=3)
        d[2] = 0
        hits.append((t, int(rng.integers(c.nbody)), d / np.linalg.norm(d) * rng.uniform(10, 60)))
        t += int(rng.integers(2, 37))            # 30-600 ms apart
    r = _run(ch, hits, seconds=t * DT + 2.5)
    assert r["finite"] and r["back"] is not None and r["back"] <= 2.0, r
    assert r["maxrot"] < 0.5, r
    assert r["minz"] > -0.03, r        # body centres; see the note: soft contacts let hard hits sink 2 cm
    assert ch.response.hits == n


def test_same_hits_same_poses_bit_for_bit():
    out = []
    for _ in range(2):
        ch = _standing("dog")
        _run(ch, [(0, 1, (0, 30, 0)), (12, 0, (-20, 0, 0))], seconds=1.5)
        out.append((ch.world_positions.tobytes(), ch.world_rotations.tobytes()))
    assert out[0] == out[1]


def test_prepare_leaves_the_response_as_it_was():
    # prepare_impacts builds the library and loads the kernels ahead of the first hit; the
    # hits after it must give the same poses as without it (it must not leave state behind)
    out = []
    for prep in (False, True):
        ch = _standing("dog")
        if prep:
            took = ch.prepare_impacts()
            assert took > 0.0 and ch.response._library is not None and not ch.reacting
        _run(ch, [(0, 1, (0, 30, 0)), (12, 0, (-20, 0, 0))], seconds=1.5)
        out.append((ch.world_positions.tobytes(), ch.world_rotations.tobytes()))
    assert out[0] == out[1]


@pytest.mark.parametrize("body,impulse,msg", [
    ("no_such_body", (1, 0, 0), "no body 'no_such_body'"),
    (99, (1, 0, 0), "out of range"),
    ("pelvis", (np.nan, 0, 0), "finite"),
    ("pelvis", (1e9, 0, 0), "absurd"),
    ("pelvis", (1, 0), "3 finite"),
])
def test_bad_hits_are_refused_and_nothing_is_applied(body, impulse, msg):
    ch = _standing("humanoid")
    before = ch.world_positions.copy()
    with pytest.raises(ImpactError, match=msg):
        ch.hit(body, impulse)
    assert not ch.reacting
    ch.tick(DT)
    assert not ch.reacting
    assert np.abs(ch.world_positions - before).max() < 0.05


def test_search_matches_brute_force_on_all_starts():
    c = _creature("minimal")
    clips = [engine.load_animation(os.path.join(ROOT, "animations", n)) for n in ("crouch.yaml", "wave.yaml")]
    lib = MotionLibrary(c, clips, speeds=(1.0,), gaits=False)
    lib.starts = np.flatnonzero(lib.valid)[::2]     # a small library so the reference runs fast
    lib.win_pos, lib.win_rot = S.library_windows(lib, lib.starts)
    lib.prefilter = S.build_prefilter(lib)
    rng = np.random.default_rng(0)
    k = 20
    sim_pos = lib.pos[10:10 + k] + rng.normal(scale=0.01, size=(k,) + lib.pos.shape[1:])
    sim_rot = lib.rot[10:10 + k]
    yaw = 0.7
    R = np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]])
    sim_pos = sim_pos @ R.T + np.array([1.0, -2.0, 0.0])
    hq = np.array([np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)])
    w, v = hq[0], hq[1:]
    sim_rot = np.concatenate([(w * sim_rot[..., :1] - sim_rot[..., 1:] @ v[:, None]),
                              w * sim_rot[..., 1:] + sim_rot[..., :1] * v + np.cross(v, sim_rot[..., 1:])], -1)
    f = S.window_features(c, sim_pos, sim_rot)
    old = S.SIM_STRIDE, S.PREFILTER_K
    S.SIM_STRIDE, S.PREFILTER_K = 1, 8              # every sim start; the prefilter keeps 8 of the windows
    try:
        assert len(lib.starts) > S.PREFILTER_K
        got = S.search(lib, f, 2, 8)
        exact = S.search(lib, f, 2, 8, exhaustive=True)
    finally:
        S.SIM_STRIDE, S.PREFILTER_K = old
    ref = S.search_brute(lib, f, 2, 8)
    assert exact.distance == pytest.approx(ref[0], rel=1e-9)
    # the coarse-to-fine search scores its candidates exactly, so it is never below the best and,
    # keeping 8 of 28 windows here, within 2% of it (the benchmark measures how often it is equal)
    assert ref[0] * (1 - 1e-9) <= got.distance <= ref[0] * 1.02
    # the yaw-and-translation alignment undoes the rotation we applied
    assert abs((got.place_yaw - yaw + np.pi) % (2 * np.pi) - np.pi) < 0.05


def test_the_search_prefers_clips_that_travel_with_the_push():
    """A window of a stagger that steps one way, searched with a push the other way, re-enters
    no clip that carries the body against the push (engine.response.search, the push term);
    with the push along its steps, or none, it finds itself."""
    c = _creature("humanoid")
    names = ["stagger_front", "stagger_back", "stagger_front_low", "stagger_back_low", "brace", "brace_low"]
    clips = [engine.load_animation(os.path.join(ROOT, "animations", "reactions", f"{n}.yaml")) for n in names]
    lib = MotionLibrary(c, clips, speeds=(1.0,), gaits=False, cache=False, progress=False)
    # the reaction clips' staggers step 3% of the height; as if they stepped 60% (the term
    # weighs travel against pose: a short step against the push can still be the best window)
    lib.travel = lib.travel * 20.0
    far = np.linalg.norm(lib.travel, axis=1)
    moving = np.flatnonzero(far > 0.5 * far.max())
    s0 = int(moving[len(moving) // 3])
    assert lib.valid[s0]
    f = S.window_features(c, lib.pos[s0:s0 + 20], lib.rot[s0:s0 + 20])
    along = np.r_[lib.travel[s0] @ _yaw_matrix(lib.yaw[s0]).T, 0.0]      # its steps, in the world
    for push, sign in ((None, 1), (along, 1), (-along, -1)):
        res = S.search(lib, f, 0, 2, exhaustive=True, push=push)
        t = lib.travel[res.lib_frame]
        j = _yaw_matrix(-f.yaw[res.sim_frame]) @ (sign * along[:2]) / np.linalg.norm(along[:2])
        if sign > 0:
            assert lib.clip_of[res.lib_frame] == lib.clip_of[s0]
        assert t @ j >= -0.1 * far.max(), (lib.clips[lib.clip_of[res.lib_frame]].name, t, j)
    # the term is zero for a clip played in place, at most 2 (sum w_i) |t| / h against the push
    assert res.distance > 0.0


@pytest.mark.parametrize("kind", ["humanoid", "dog", "random3"])
def test_the_library_knows_where_its_clips_go(kind):
    """``MotionLibrary.travel``: a stagger's first frame still has its whole step ahead of it,
    in the direction its name gives (animations/reactions: front +x, back -x, left +y,
    right -y in the character's heading); ``goes_down``: a fall and lying go down, a stagger,
    a brace and the idle clip do not."""
    c = _creature(kind)
    lib = library_for(c)
    dirs = {"front": (1, 0), "back": (-1, 0), "left": (0, 1), "right": (0, -1)}
    seen = set()
    for e, clip in enumerate(lib.clips):
        if clip is None:
            continue
        frames = np.flatnonzero(lib.clip_of == e)
        first = int(frames[0])
        name = clip.name.replace("_low", "")
        if name.startswith("stagger_"):
            t = lib.travel[first]
            d = np.array(dirs[name.split("_")[1]], float)
            assert t @ d > 0.5 * np.linalg.norm(t) > 0.0, (clip.name, t)
            assert not lib.goes_down(first), clip.name
            seen.add("stagger")
        elif name.startswith("fall_") or name.startswith("lie_"):
            assert lib.goes_down(first), clip.name
            seen.add("down")
        elif name in ("idle_breathe", "brace"):
            assert not lib.goes_down(first), clip.name
            assert np.linalg.norm(lib.travel[frames], axis=1).max() < 0.05 * c.height, clip.name
            seen.add("in place")
    assert seen == {"stagger", "down", "in place"}


def _yaw_matrix(yaw):
    return np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])


def test_library_of_a_random_creature_is_its_own():
    c = _creature("random11")
    lib = library_for(c)
    assert lib.frames > 100 and lib.pos.shape[1] == c.nbody
    assert np.all(np.isfinite(lib.pos)) and len(lib.starts) < lib.frames


def test_a_crowd_member_reacts_while_the_others_stay_batched():
    from engine.runtime import Crowd

    def crowd():
        chars = [_standing("humanoid") for _ in range(3)]
        for i, ch in enumerate(chars):
            ch.set_placement(position=(0.0, 2.0 * i, 0.0), teleport=True)
        return chars, Crowd(chars)

    a, ca = crowd()
    b, cb = crowd()
    for ch in a + b:
        ch.tick(DT)                      # the same history before the crowd ticks
    ca.tick(DT)
    cb.tick(DT)
    prev = a[1].world_rotations.copy()
    a[1].hit("spine2", (-50.0, 0.0, 0.0))
    ca.tick(DT)
    cb.tick(DT)
    assert a[1].reacting
    assert np.linalg.norm(rotvec_between(prev, a[1].world_rotations), axis=1).max() < 0.5
    ended = None
    pushed = 0.0
    for k in range(150):
        ca.tick(DT)
        cb.tick(DT)
        if ended is None and not a[1].reacting:
            ended = k
        pushed = max(pushed, float(np.abs(a[1].world_positions[0, :2] - b[1].world_positions[0, :2]).max()))
    assert ended is not None and ended * DT < 2.0
    for i in (0, 2):
        assert a[i].world_positions.tobytes() == b[i].world_positions.tobytes()
    # it was pushed: its root's largest offset from its unhit twin during the reaction (0.9 m/s on
    # 57 kg; measured 0.131 m with the stance servos anchored, ImpactParams.servo_anchor: it sways
    # back on stiff legs and recovers; 1.08 m with soft legs, toppled and lying at 0.83 s). Not the
    # offset at the end: the blend back stands it where it stood
    assert pushed > 0.05, pushed


def test_a_tap_goes_back_onto_the_clip_without_a_search():
    """A 1 mN s tap on a 15 cm creature whose rest stance leans 4.3 cm ahead of 1 cm feet: the
    lookahead holds (anchored stance servos, frequencies raised as 1/sqrt(height), the rest lean
    in the stand's reach), the response is a tap (no search) and it ends where it stood. Before
    (s31): the lookahead fell forward and the search chose fall_front_low for the tap."""
    ch = _standing("random3")
    p0 = ch.world_positions[0].copy()
    r = _run(ch, [(0, "detail0_r", (0.0, 0.001, 0.0))], seconds=1.5)
    assert ch.response.tap and ch.response.clip is None
    assert r["finite"] and r["back"] is not None and r["back"] < 0.8, r
    assert r["maxrot"] < 0.2, r
    assert np.linalg.norm(ch.world_positions[0] - p0) < 0.02 * ch.creature.height


def test_no_reentry_before_a_flip_of_the_clip_on_this_creature():
    """Some clips flip on the centipede (s31: stagger_right swung a leg past full reach and
    turned it 2.8 rad in a frame; since s32's mirror fix of the reaction clips it is
    stagger_front, stagger_back and perform): the library never re-enters an entry that
    flips, and a side hit (which re-entered stagger_right in s31: leg6_r 2.65 rad/frame in
    the blend) hands back with no flip."""
    from engine.response.library import FLIP_TURN

    ch = _standing("centipede")
    lib = library_for(ch.creature)
    assert lib.flipped.any()
    d = np.abs(np.einsum("fbk,fbk->fb", lib.rot[1:], lib.rot[:-1]))
    turn = 2.0 * np.arccos(np.minimum(d.min(axis=1), 1.0))
    for s in lib.starts[::7]:
        e = lib.clip_of[s]
        at = np.flatnonzero(lib.clip_of == e)
        assert turn[at[0]:at[-1]].max(initial=0.0) <= FLIP_TURN
    assert not lib.flipped[lib.clip_of[lib.starts]].any()
    J = 5.0 * np.array([np.cos(np.radians(-156)), np.sin(np.radians(-156)), 0.0])
    r = _run(ch, [(0, "trunk9", J)])
    assert r["finite"] and r["back"] is not None and r["back"] <= 2.0, r
    assert r["maxrot"] < 0.5, r


def test_a_hovering_creature_is_not_dropped():
    """A fish hovers in its rest pose: its response has no gravity (before, a 0.4 N s tap on a
    fin dropped it 0.2 m in 0.2 s and re-entered fall_left_low, ending 5 cm to one side)."""
    from engine.response.impact import hovers

    ch = _standing("fish")
    assert hovers(ch.creature) and not hovers(_CHARS.get("humanoid") or _creature("humanoid"))
    p0 = ch.world_positions[0].copy()
    r = _run(ch, [(0, "pectoralfin_l", (0.0, -0.4, 0.0))], seconds=1.5)
    assert ch.response.tap, ch.response.clip
    assert r["finite"] and r["back"] is not None and r["maxrot"] < 0.5, r
    assert np.linalg.norm(ch.world_positions[0] - p0) < 0.01 * ch.creature.height


def test_the_found_clip_is_placed_on_the_live_body():
    """A push slides the centipede 0.36 m in the live simulation (friction 0.5, no balance
    wrench there: stand_live=False) while the lookahead (friction 1.0) stands: the found clip is
    placed on the live root, so the centipede stays where it was pushed (before, the hand-off's
    offset slid it back, 0.41 m against the push, cos -0.94). With the default stand_live the
    live balance holds it (1.4 cm)."""
    from engine.response.impact import ImpactResponse

    ch = _standing("centipede")
    ch.response = ImpactResponse(ch, ImpactParams(stand_live=False))
    J = 4.4 * np.array([np.cos(np.radians(-116)), np.sin(np.radians(-116)), 0.0])
    r = _run(ch, [(0, "trunk7", J)])
    assert r["finite"] and r["back"] is not None and r["back"] <= 2.0 and r["maxrot"] < 0.5, r
    disp = r["disp"][:2]
    assert np.linalg.norm(disp) > 0.1, disp
    assert disp @ J[:2] / (np.linalg.norm(disp) * np.linalg.norm(J[:2])) > 0.9, disp


def test_a_hit_during_the_blend_starts_from_closed_joints():
    """The hand-off's blend offsets each body on its own, which opens the joints (a crawler's
    pelvis joint 4.5 cm, 40% of its height, in a train of hits). A hit in the blend starts the
    physics from the pose joined at its joints (rotations kept, placed where the pose's mass
    was) and shows the gaps decaying: the first physical frame neither snaps the joints shut
    nor jumps."""
    from engine.physics.world import joint_separation

    ch = _standing("crawler")
    h = ch.creature.height
    # A shove, on to the blend; then the blend's offsets open the pelvis joint by 40% of the
    # height (as a train of hits once did, benchmarks/impact.py's crawler: 4.5 cm; which
    # trains open it, and how far, moves with every change to the search and the physics,
    # so the opening is made here on the offset itself)
    ch.hit("pelvis", 9.2 * np.array([np.cos(np.radians(134)), np.sin(np.radians(134)), 0.0]))
    r = ch.response
    for _ in range(180):
        ch.tick(DT)
        if r.phase == "blend":
            break
    assert r.phase == "blend"
    r._off_pos[ch.creature.body("pelvis")] += (0.0, 0.0, 0.4 * h)
    ch.tick(DT)
    before = ch.world_positions.copy()         # an open pose, and the next: the motion it has
    ch.tick(DT)
    assert r.phase == "blend"
    p_, q_ = r._lock_leaves(ch.world_positions, ch.world_rotations)
    assert float(np.abs(p_ - r._joined(p_, q_)).max()) > 0.1 * h
    pos0, rot0 = ch.world_positions.copy(), ch.world_rotations.copy()
    ch.hit("tail4", (0.0, 0.2, 0.0))
    assert float(np.max(joint_separation(r.model2, r.sim2))) < 1e-6 * h
    gap = float(np.abs(r._entry_res).max())
    assert gap > 0.1 * h, gap                   # measured 0.045 m: the pose was open
    ch.tick(DT)
    # no body moves further in the frame than it did in the one before (the blend carries the
    # body at its own speed; the ground may stop it) by more than a twentieth of the height:
    # a joint snapped shut moves its body by the gap (0.045 m once) on top
    moved = np.linalg.norm(ch.world_positions - pos0, axis=1)
    was = np.linalg.norm(pos0 - before, axis=1)
    assert (moved - was).max() < 0.05 * h + 0.1 * gap, (gap, moved, was)
    assert np.linalg.norm(rotvec_between(rot0, ch.world_rotations), axis=1).max() < 0.3


def test_the_blend_back_does_not_take_a_body_into_the_ground():
    """The hand-off offset decays as (x0 + (v0 + w x0) t) e^(-w t): a foot still falling in the
    simulation while the found clip lifts it dipped the centipede's first foot 4.4 cm under
    the ground on the way into fall_right_low (it is 7 cm tall). No body is blended lower than
    it rests on the ground, or than the clip itself puts it."""
    from engine.channels.modes import ground_height
    from engine.response.impact import ImpactResponse

    ch = _standing("centipede")
    c = ch.creature
    r = ImpactResponse(ch)
    pos = ch.world_positions.copy()
    rot = ch.world_rotations.copy()
    clip_z = pos[:, 2].copy()
    clip_z[5] = -0.01                       # a clip that itself sinks one body is left alone
    pos[:, 2] = clip_z
    r._off_pos[:] = 0.0
    r._off_rot[:] = 0.0
    r._off_vel[:] = 0.0
    r._off_vel[:, 2] = -2.0                 # every body still falling at 2 m/s at the hand-off
    w, t = 10.0, 0.08
    e = np.exp(-w * t)
    out = pos.copy()
    r._blend_pose(out, rot, (1 + w * t) * e, t * e)
    floor = np.array([ground_height(c, b) for b in range(c.nbody)])
    assert np.all(out[:, 2] >= np.minimum(floor, clip_z) - 1e-12)
    assert out[5, 2] == pytest.approx(-0.01)
    # without the floor the same offset puts the feet well under the ground
    assert np.min(pos[:, 2] - 2.0 * t * e) < -0.05


def test_a_fall_goes_on_into_the_clips_that_follow_it():
    """A knock-down re-enters a fall; the response queues what continues it by the clips'
    own ``follows`` (lying, then getting up: ``engine.anim.chain``, animations/reactions),
    then what played before. Measured: a 2.5 m/s push back on the humanoid's root finds
    ``fall_back`` and queues lie_back, get_up_back, idle_breathe."""
    ch = _standing("humanoid")
    lib = library_for(ch.creature)
    for d in ("back", "front", "left", "right"):
        assert lib.followed_by[f"fall_{d}"].name == f"lie_{d}"
        assert lib.followed_by[f"lie_{d}"].name == f"get_up_{d}"
    queued = []
    own = ch.queue

    def record(animation, *args, **kwargs):
        queued.append(animation.name)
        return own(animation, *args, **kwargs)

    ch.queue = record
    mass = _models(ch.creature, ImpactParams())[1].total_mass
    ch.hit(0, np.array([-2.5 * mass, 0.0, 0.0]))
    for _ in range(int(1.5 / DT)):
        ch.tick(DT)
    found = ch.response.clip.name
    assert found.startswith("fall_"), found
    side = found[len("fall_"):]
    assert queued == [f"lie_{side}", f"get_up_{side}", "idle_breathe"], queued


def test_a_creature_lying_on_its_belly_is_not_balanced_and_does_not_thrash():
    """The standing controller keeps an inverted pendulum up: a creature standing on feet.
    The snake lies on its belly; the controller's balance wrench on its head segment (at the
    frequencies a 7.5 cm creature gets) thrashed the chain at 2.3-3.1 rad a tick after a
    side hit. It runs only for creatures on feet now (``Stander.on_feet``): 0.03 rad."""
    from engine.response.impact import ImpactResponse

    ch = _standing("snake")
    assert ch.creature.has_body("body10")
    ch.hit("body10", (-6.55, -1.23, 0.0))          # 0.85 m/s worth of the whole snake
    assert ch.response.stand1 is None and ch.response.stand2 is None
    prev, worst = ch.world_rotations.copy(), 0.0
    for _ in range(40):
        ch.tick(DT)
        if ch.reacting and ch.response.phase in ("burst", "transition"):
            worst = max(worst, float(np.linalg.norm(rotvec_between(prev, ch.world_rotations), axis=1).max()))
        prev = ch.world_rotations.copy()
    assert worst < 0.5, worst
    hum = ImpactResponse(_standing("humanoid"))
    assert hum.stand1 is not None and hum.stand1.on_feet
