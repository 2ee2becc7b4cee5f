"""The impact response as the paper wrote it, offline (engine.response.paper): a knock-down
on the library humanoid, a captured skeleton and a random creature; the final blend's
error spreading; determinism; bad input."""

from __future__ import annotations

import numpy as np
import pytest

from engine.physics.world import rotvec_between
from engine.response.impact import ImpactError, chain_mass
from engine.response.library import library_for
from engine.response.paper import _placed, paper_response
from tests.test_impact import _standing

_RESULTS: dict = {}


def _knockdown(kind):
    """A hit on the trunk that gives the whole creature 2.5 m/s sideways (+Y)."""
    if kind not in _RESULTS:
        ch = _standing(kind)
        before = (ch.world_positions.tobytes(), ch.world_rotations.tobytes())
        J = np.array([0.0, 2.5 * chain_mass(ch.creature, 0), 0.0])
        res = paper_response(ch, 0, J)
        assert (ch.world_positions.tobytes(), ch.world_rotations.tobytes()) == before, "the character was changed"
        assert not ch.reacting
        _RESULTS[kind] = (ch, J, res)
    return _RESULTS[kind]


@pytest.mark.parametrize("kind", ["humanoid", "capture", "random1"])
def test_a_knockdown_answered_offline_starts_on_the_shown_pose_and_ends_on_the_clip(kind):
    ch, J, r = _knockdown(kind)
    h = ch.creature.height
    assert np.all(np.isfinite(r.pos)) and np.all(np.isfinite(r.rot))
    # the first frame is the pose shown at the impact; the match is in the paper's window
    assert np.abs(r.pos[0] - ch.world_positions).max() < 1e-3 * h
    assert 0.1 - 1e-9 <= r.handoff <= 1.0 + 1e-9
    assert r.pos.shape[0] == r.t.shape[0] and r.t[0] == 0.0 and np.all(np.diff(r.t) > 0)
    # at the match the shown pose is the found clip's, placed where the search aligned it
    K = r.sim2_pos.shape[0] - 1
    assert abs(r.t[K] - r.handoff) < 1e-9
    clip_p, clip_q = _placed(library_for(ch.creature), r.match.lib_frame, r.place_pos, r.place_yaw)
    assert np.array_equal(r.pos[K], clip_p) and np.array_equal(r.rot[K], clip_q)
    assert r.pos.shape[0] - (K + 1) == round(0.5 * r.rate)          # and the clip goes on for 0.5 s
    # no body turns more than 0.5 rad between two 60 Hz frames, the hand-back included
    turn = np.linalg.norm(rotvec_between(r.rot[:-1].reshape(-1, 4), r.rot[1:].reshape(-1, 4)), axis=1)
    assert turn.max() < 0.5, f"{kind}: a body turns {turn.max():.2f} rad in one frame"
    # nothing more than 1 cm under the ground, and the root goes the way of the hit
    assert r.pos[..., 2].min() > -0.01
    d = r.pos[-1, 0, :2] - r.pos[0, 0, :2]
    if np.linalg.norm(d) > 0.05 * h:
        cosang = float(d @ J[:2] / (np.linalg.norm(d) * np.linalg.norm(J[:2])))
        assert cosang > 0.5, f"{kind}: the root moved {np.degrees(np.arccos(cosang)):.0f} degrees off the hit"
    assert set(r.seconds) == {"sim1", "search", "sim2", "blend", "total"}
    assert all(v > 0.0 for v in r.seconds.values())


def test_the_final_blend_spreads_the_root_error_linearly():
    ch, J, r = _knockdown("humanoid")
    K = r.sim2_pos.shape[0] - 1
    err = r.pos[K, 0, :2] - r.sim2_pos[K, 0, :2]       # Simulation 2's miss of the clip at T
    assert np.linalg.norm(err) > 1e-4                   # there is something to spread
    for k in (K // 4, K // 2, 3 * K // 4):
        # ground-plane offset of the root: k / K of the end error (past the impact's gap decay)
        if r.t[k] < 0.5:
            continue
        np.testing.assert_allclose(r.pos[k, 0, :2] - r.sim2_pos[k, 0, :2], (k / K) * err, atol=1e-9)


def test_the_same_hit_gives_the_same_answer_bit_for_bit():
    a = paper_response(_standing("random1"), 0, (0.0, 2.0, 0.0), substep=1 / 480)
    b = paper_response(_standing("random1"), 0, (0.0, 2.0, 0.0), substep=1 / 480)
    assert a.pos.tobytes() == b.pos.tobytes() and a.rot.tobytes() == b.rot.tobytes()
    assert (a.match.lib_frame, a.match.sim_frame) == (b.match.lib_frame, b.match.sim_frame)


@pytest.mark.parametrize("kw,err,msg", [
    (dict(body="no_such_body", impulse=(1, 0, 0)), ImpactError, "no body 'no_such_body'"),
    (dict(body="pelvis", impulse=(np.inf, 0, 0)), ImpactError, "finite"),
    (dict(body="pelvis", impulse=(1, 0, 0), substep=0.5), ValueError, "substep"),
    (dict(body="pelvis", impulse=(1, 0, 0), rate=0), ValueError, "rate"),
])
def test_bad_input_is_refused_and_the_character_is_untouched(kw, err, msg):
    ch = _standing("humanoid")
    before = ch.world_positions.tobytes()
    body = kw.pop("body")
    impulse = kw.pop("impulse")
    with pytest.raises(err, match=msg):
        paper_response(ch, body, impulse, **kw)
    assert ch.world_positions.tobytes() == before and not ch.reacting
