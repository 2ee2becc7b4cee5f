"""Contacts between two characters (engine.response.strike): a humanoid's animated punch
meets another humanoid; the victim reacts, the attacker recoils onto its clip."""

from __future__ import annotations

import os

import numpy as np
import pytest

import engine
from engine.model import build_creature, random_creature_def
from engine.physics.world import rotvec_between
from engine.response.impact import ImpactError
from engine.response.strike import Strike

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
HUM = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
PUNCH = engine.load_animation(os.path.join(ROOT, "animations", "punch.yaml"))
IDLE = engine.load_animation(os.path.join(ROOT, "animations", "idle_breathe.yaml"))
DT = 1 / 60


def _bout(dist, victim_creature=HUM, frames=200):
    a, v = engine.Character(HUM), engine.Character(victim_creature)
    v.set_placement(position=(dist, 0, 0), heading=np.pi, teleport=True)
    a.play(IDLE)
    try:
        v.play(IDLE)
    except engine.MenagerieError:
        pass
    for _ in range(5):
        a.tick(DT)
        v.tick(DT)
    if victim_creature is not HUM:
        # its nearest body centre 0.3 m in front of the attacker
        front = float(v.world_positions[:, 0].min())
        v.set_placement(position=(dist + 0.3 - front, 0, 0), heading=np.pi, teleport=True)
        for _ in range(3):
            a.tick(DT)
            v.tick(DT)
    spine = np.flatnonzero(np.asarray(victim_creature.body_limb) < 0)
    zs = v.world_positions[spine, 2]
    shoulder = a.world_positions[HUM.body("upperarm_r"), 2]
    a.set_target("foe", v.world_positions[spine[np.argmin(np.abs(zs - shoulder))]])   # its spine body at shoulder height
    a.play(PUNCH, fade=0.1)
    st = Strike(a, v, ["hand_r", "forearm_r"])
    pa, pv = a.world_rotations.copy(), v.world_rotations.copy()
    turn_a = turn_v = 0.0
    landed = back_a = back_v = None
    v0 = v.world_positions[0].copy()
    reach = 0.0
    for k in range(frames):
        a.tick(DT)
        v.tick(DT)
        c = st.tick(DT)
        if c is not None and landed is None:
            landed = k
        turn_a = max(turn_a, float(np.linalg.norm(rotvec_between(pa, a.world_rotations), axis=1).max()))
        turn_v = max(turn_v, float(np.linalg.norm(rotvec_between(pv, v.world_rotations), axis=1).max()))
        pa, pv = a.world_rotations.copy(), v.world_rotations.copy()
        reach = max(reach, float(v.world_positions[0, 0] - v0[0]))
        assert np.all(np.isfinite(a.world_positions)) and np.all(np.isfinite(v.world_positions))
        if landed is not None and back_a is None and not a.reacting:
            back_a = (k - landed) * DT
        if landed is not None and back_v is None and not v.reacting:
            back_v = (k - landed) * DT
    return st, landed, back_a, back_v, turn_a, turn_v, v.world_positions[0] - v0, reach


def test_punch_lands_victim_reacts_attacker_recoils():
    st, landed, back_a, back_v, turn_a, turn_v, moved, reach = _bout(0.6)
    assert landed is not None and len(st.contacts) == 1          # one strike per approach
    c = st.contacts[0]
    assert HUM.body_names[c.attacker_body] in ("hand_r", "forearm_r")
    assert c.impulse[0] > 0 and c.speed > 1.0                     # along the punch, toward the victim
    assert back_a is not None and back_a < 0.8                    # measured 0.63 s (0.1 s recoil + blend)
    assert back_v is not None and back_v < 2.0
    assert turn_a < 0.5 and turn_v < 0.5                          # measured 0.33 / 0.25 rad per frame
    # pushed away from the attacker: the victim's root sways back during the reaction. 10.6 N s on
    # spine2 is 0.19 m/s on 57 kg: with the stance servos anchored (ImpactParams.servo_anchor) and
    # the balance wrench live too, the root sways 0.0074 m back (0.024 m with it in the lookahead
    # only) and the response is a tap that ends where it stood; with the feet held but the legs
    # soft, 0.064 m back and 0.011 m at the end; with sliding feet, more
    assert reach > 0.004, reach
    assert abs(moved[0]) < 0.02, moved


def test_out_of_reach_no_contact():
    st, landed, *_ = _bout(3.0, frames=80)
    assert landed is None and not st.contacts


@pytest.mark.parametrize("seed", [0, 6])     # 1.9 m and 1.2 m tall: in a humanoid's reach
def test_punch_on_a_random_creature(seed):
    c = build_creature(random_creature_def(seed))
    st, landed, back_a, back_v, turn_a, turn_v, moved, reach = _bout(0.55, victim_creature=c)
    assert landed is not None
    assert back_a is not None and back_v is not None and back_v < 2.0
    assert turn_a < 0.5


def test_bad_strikes():
    a, v = engine.Character(HUM), engine.Character(HUM)
    with pytest.raises(ImpactError, match="no body 'fist'"):
        Strike(a, v, ["fist"])
    with pytest.raises(ImpactError, match="same character"):
        Strike(a, a, ["hand_r"])
    with pytest.raises(ImpactError, match="at least one"):
        Strike(a, v, [])
    with pytest.raises(ImpactError, match="recoil"):
        a.hit("hand_r", (1.0, 0, 0))
        a.response.hit("hand_r", (1.0, 0, 0), recoil=5.0)
