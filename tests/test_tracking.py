"""Motion capture replayed on physical bodies (engine.response.tracking, Wilke & Semwal).

Invalid inputs first, each with its error; then the pieces against plain references
(central-difference weights, Welford, Euler angles against the BVH reader's own
composition); then a tiny inline capture whose answer is known; then short runs on a
real CMU walk: modes, asymmetric scaling, under-controlling, the BVH written back, the
seeded Monte Carlo search, and the command line.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest

from engine.io import load_bvh, parse_bvh_text
from engine.paths import has_shared_data, shared_data
from engine.response._kernels import welford_update
from engine.response.tracking import (
    MODES,
    ControlOptions,
    MocapRig,
    TrackingError,
    TrackingParams,
    VelocityScale,
    central_difference,
    central_difference_weights,
    quat_to_euler,
    track,
    tune,
)

WALK = str(shared_data("mocap", "cmu_02_01_walk.bvh")) if has_shared_data() else ""
needs_walk = pytest.mark.skipif(not os.path.exists(WALK), reason="CMU walk capture not available")

# A three-joint arm whose root slides along +z (BVH axes: Menagerie +x) at 1 unit/frame
# and whose elbow bends steadily; the file unit is given explicitly (0.01 m).
TINY = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Upper
  {
    OFFSET 0 30 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    JOINT Lower
    {
      OFFSET 0 30 0
      CHANNELS 3 Zrotation Yrotation Xrotation
      End Site
      {
        OFFSET 0 30 0
      }
    }
  }
}
MOTION
Frames: 61
Frame Time: 0.0166667
""" + "".join(f"0 100 {f:.1f} 0 0 0 {0.5 * f:.2f} 0 0 {1.0 * f:.2f} 0 0\n" for f in range(61))


def tiny():
    return parse_bvh_text(TINY, "tiny.bvh")


# ---------------------------------------------------------------------------------------
# Invalid inputs
# ---------------------------------------------------------------------------------------

INVALID = [
    (dict(mode="floppy"), "unknown mode 'floppy'", "mode"),
    (dict(params=TrackingParams(order=4)), "order must be odd", "order"),
    (dict(params=TrackingParams(order=21)), "order must be odd", "order"),
    (dict(params=TrackingParams(k_f=0.0)), "k_f must be a positive number", "k_f"),
    (dict(params=TrackingParams(k_vc=float("nan"))), "k_vc must be a positive number", "k_vc"),
    (dict(params=TrackingParams(dt=-0.001)), "dt must be a positive number", "dt"),
    (dict(params=TrackingParams(substeps=0)), "substeps must be a positive integer", "substeps"),
    (dict(control=ControlOptions(uncontrolled=("Elbow",))), "no joint 'Elbow'", "uncontrolled"),
    (dict(control=ControlOptions(locked=("Lowr",))), "did you mean Lower", "locked"),
    (dict(control=ControlOptions(locked=("Hips",))), "the root has no joint", "locked"),
    (dict(mode="skeleton", control=ControlOptions(locked=("Lower",))), "only be locked in constrained", "locked"),
    (dict(control=ControlOptions(mass={"Upper": 0.0})), "mass must be a positive", "mass"),
    (dict(control=ControlOptions(mass={"Tail": 1.0})), "no joint 'Tail'", "mass"),
    (dict(frames=(10, 5)), "frame range", "frames"),
    (dict(frames=(0, 61)), "frame range", "frames"),
]


@pytest.mark.parametrize("kwargs,message,field", INVALID)
def test_invalid_rig_inputs(kwargs, message, field):
    with pytest.raises(TrackingError, match=message) as err:
        MocapRig(tiny(), scale=0.01, **kwargs)
    assert err.value.field == field


@pytest.mark.parametrize("text", ["RightFoot", "RightFoot:x", "RightFoot:1.2@200", "RightFoot:1.2@a-b", ":1.2"])
def test_invalid_scale_text(text):
    with pytest.raises(TrackingError, match="bad scale"):
        VelocityScale.parse(text)


def test_invalid_scale_in_run():
    rig = MocapRig(tiny(), scale=0.01)
    with pytest.raises(TrackingError, match="no joint 'Foot'"):
        track(rig, scales=["Foot:1.2"])
    with pytest.raises(TrackingError, match="empty"):
        track(rig, scales=[VelocityScale("Lower", 1.2, 30, 20)])
    with pytest.raises(TrackingError, match=">= 0"):
        track(rig, scales=[VelocityScale("Lower", -1.0)])
    with pytest.raises(TrackingError, match="points"):
        tune(rig, points=0)
    with pytest.raises(TrackingError, match="max_order"):
        tune(rig, max_order=21)


def test_scale_parse():
    s = VelocityScale.parse("RightFoot:1.2@200-600")
    assert (s.joint, s.k, s.f0, s.f1) == ("RightFoot", 1.2, 200, 600)
    s = VelocityScale.parse("LeftHand:0.5")
    assert (s.joint, s.k, s.f0) == ("LeftHand", 0.5, 0)


# ---------------------------------------------------------------------------------------
# Pieces against plain references
# ---------------------------------------------------------------------------------------

def test_central_difference_weights_by_hand_and_exactness():
    np.testing.assert_allclose(central_difference_weights(3), [-0.5, 0.0, 0.5], atol=1e-14)
    np.testing.assert_allclose(central_difference_weights(5), [1 / 12, -2 / 3, 0.0, 2 / 3, -1 / 12], atol=1e-13)
    rng = np.random.default_rng(1)
    for n in range(3, 20, 2):
        # exact for polynomials of degree n - 1: compare with numpy's polynomial derivative
        coeffs = rng.normal(size=n)
        t = np.arange(40) * 0.1
        x = np.polynomial.polynomial.polyval(t, coeffs)
        dx = np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyder(coeffs))
        m = (n - 1) // 2
        got = central_difference(x, n, 0.1)
        np.testing.assert_allclose(got[m:-m], dx[m:-m], rtol=1e-6, atol=1e-6 * np.abs(dx).max())


def test_welford_matches_numpy():
    rng = np.random.default_rng(2)
    data = rng.normal(3.0, 2.0, size=(500, 4)) ** 2
    count = np.zeros(4, np.int64)
    mean = np.zeros(4)
    m2 = np.zeros(4)
    for row in data:
        welford_update(count, mean, m2, row)
    np.testing.assert_allclose(mean, data.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(m2 / (count - 1), data.var(axis=0, ddof=1), rtol=1e-10)


@pytest.mark.parametrize("order", ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"])
def test_euler_round_trip_through_the_bvh_reader(order):
    rng = np.random.default_rng(3)
    q = rng.normal(size=(50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    angles = np.degrees(quat_to_euler(q, order))
    chans = " ".join(f"{a}rotation" for a in order)
    text = ("HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n CHANNELS 3 " + chans + "\n End Site\n {\n OFFSET 0 1 0\n }\n}\n"
            "MOTION\nFrames: 50\nFrame Time: 0.01\n" + "".join(" ".join(repr(float(v)) for v in row) + "\n"
                                                                for row in angles))
    back = parse_bvh_text(text).local_rotations()[:, 0]
    dots = np.abs(np.sum(back * q, axis=1))
    assert np.all(dots > 1 - 1e-12)


# ---------------------------------------------------------------------------------------
# A tiny capture with a known answer
# ---------------------------------------------------------------------------------------

def test_tiny_capture_bodies_and_targets():
    rig = MocapRig(tiny(), "constrained", scale=0.01)
    assert rig.model.nbody == 3 and rig.model.njoint == 2
    # Hips has a bone up to Upper (0.3 m), Lower to its end site
    assert np.all(rig.is_capsule)
    np.testing.assert_allclose(np.linalg.norm(rig.bone_local, axis=1), [0.3, 0.3, 0.3])
    # the root slides 1 cm per frame along BVH +z = Menagerie +x: 0.6 m/s
    v = rig.target_velocities(5)
    np.testing.assert_allclose(v[10, 0], [0.01 / rig.frame_time, 0.0, 0.0], atol=1e-9)
    # BVH +y up -> Menagerie +z: the root stands 1 m up
    assert rig.joint_pos[0, 0, 2] == pytest.approx(1.0)


def test_independent_bodies_follow_with_error_falling_as_gain_rises():
    clip = tiny()
    errors = {}
    for kf in (10.0, 100.0):
        rig = MocapRig(clip, "independent", scale=0.01, params=TrackingParams(ground=False, gravity_comp=True))
        errors[kf] = track(rig, TrackingParams(k_f=kf, ground=False, gravity_comp=True)).mse
    print(f"\ntiny capture, independent bodies: mse K_f=10 {errors[10.0]:.3e} m^2, K_f=100 {errors[100.0]:.3e} m^2")
    assert errors[100.0] < errors[10.0] / 10
    assert errors[100.0] < 1e-4


# ---------------------------------------------------------------------------------------
# A real walk, short
# ---------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def walk():
    return load_bvh(WALK)


#: What a user accepts of a tracked capture, as the rms of the tracking error (m), per mode
#: by what the mode measures (engine/response/tracking.py): ``independent`` measures each
#: sphere at its joint and ``constrained`` each capsule's joint end, held together by ball
#: joints: within 3 cm the body stays inside the captured limb (a human forearm is 6-8 cm
#: across), so the motion reads as the capture's. ``skeleton``'s capsules have no joints,
#: so their joint ends swing apart with every turn of a bone: within 6 cm (a limb's width)
#: the skeleton is still visibly the capture's pose. Measured (frames 0-120): walk 1.67 /
#: 4.80 / 2.38 cm, start-walk-stop 0.99 / 2.38 / 1.10 cm.
RMS_BOUND = {"independent": 0.03, "skeleton": 0.06, "constrained": 0.03}
CLIPS = ["cmu_02_01_walk", "cmu_131_01_start_walk_stop_3dsmax",
         pytest.param("cmu_01_01_playground_forward_jumps", marks=pytest.mark.xfail(
             strict=True, raises=AssertionError,
             reason="the jumps are not tracked: rms 71.5 / 77.1 / 38.9 cm (independent / skeleton / "
                    "constrained) over frames 0-120: the bodies fall behind the capture in the air (the "
                    "servos have nothing to push against) and never catch up"))]


@pytest.mark.parametrize("clip", CLIPS)
def test_three_modes_track_captures(clip):
    path = str(shared_data("mocap", f"{clip}.bvh")) if has_shared_data() else ""
    if not os.path.exists(path):
        pytest.skip(f"{clip}.bvh not available (../shared/data/mocap)")
    capture = load_bvh(path)
    rows = {}
    for mode in MODES:
        rig = MocapRig(capture, mode, frames=(0, 120), params=TrackingParams(gravity_comp=True))
        r = track(rig)
        rows[mode] = r
        assert len(r.report()["joints"]) == capture.njoint
    print(f"\n{clip} frames 0-120: " + ", ".join(f"{m} rms {np.sqrt(r.mse) * 100:.2f} cm" for m, r in rows.items())
          + f", constrained joint separation {rows['constrained'].max_joint_separation * 1000:.3f} mm")
    for mode, r in rows.items():
        assert np.isfinite(r.mse) and np.sqrt(r.mse) <= RMS_BOUND[mode], (mode, np.sqrt(r.mse))
    assert rows["constrained"].max_joint_separation < 1e-3
    assert rows["independent"].max_joint_separation == 0.0


@needs_walk
def test_asymmetric_scaling_changes_only_from_its_first_frame(walk):
    rig = MocapRig(walk, "constrained", frames=(0, 100))
    base = track(rig)
    scaled = track(rig, scales=["RightFoot:1.5@40-80"])
    foot = walk.joint("RightFoot")
    # frames before 40 are bit-identical (deterministic); the scaled run differs after
    assert np.array_equal(base.body_pos[:40], scaled.body_pos[:40])
    moved = np.linalg.norm(scaled.body_pos[80, foot] - base.body_pos[80, foot])
    print(f"\nRightFoot x1.5 over frames 40-80: the foot body is {moved * 100:.2f} cm from the unscaled run at 80")
    assert moved > 0.005


@needs_walk
def test_zombie_under_controlling(walk):
    control = ControlOptions(uncontrolled=("LeftHand", "LeftFoot"), locked=("LeftLeg",),
                             mass={"LeftFoot": 5.0, "LeftLeg": 10.0})
    rig = MocapRig(walk, "constrained", frames=(0, 120), control=control)
    assert rig.model.body_mass[walk.joint("LeftFoot")] == 5.0
    r = track(rig)
    # the locked knee keeps the first frame's relative rotation
    j = rig.model.body_joint[walk.joint("LeftLeg")]
    a, b = rig.model.joint_parent[j], rig.model.joint_child[j]
    qa, qb = r.body_rot[-1, a], r.body_rot[-1, b]
    w = qa[0] * qb[0] + qa[1:] @ qb[1:]
    v = qa[0] * qb[1:] - qb[0] * qa[1:] - np.cross(qa[1:], qb[1:])
    rel = np.concatenate([[w], v])
    angle = 2 * math.acos(min(1.0, abs(rel @ rig.model.joint_rest_rot[j])))
    print(f"\nzombie: locked knee drift {math.degrees(angle):.3f} deg, mse {r.mse:.4f} m^2")
    assert angle < math.radians(1.0)
    # under-controlled bodies track worse than under full control
    full = track(MocapRig(walk, "constrained", frames=(0, 120)))
    lf = walk.joint("LeftFoot")
    assert r.joint_mse[lf] > full.joint_mse[lf]


@needs_walk
def test_bvh_written_back_replays_the_simulation(walk, tmp_path):
    from engine.io import save_bvh
    from engine.io.bvh import to_menagerie_axes

    rig = MocapRig(walk, "constrained", frames=(0, 60))
    r = track(rig)
    path = tmp_path / "sim.bvh"
    save_bvh(r.to_bvh(), path, precision=None)
    back = load_bvh(path)
    assert back.nframe == 61 and back.joint_names == walk.joint_names
    pos, _ = back.forward_kinematics()
    fk = to_menagerie_axes(pos, rig.scale)
    sim = r.simulated_joint_positions()
    err = np.abs(fk - sim).max()
    print(f"\nBVH written back: FK of the file vs simulated joint points, worst {err * 1000:.3f} mm")
    assert err < 2e-3


@needs_walk
def test_tracking_and_tuning_are_deterministic(walk):
    rig = MocapRig(walk, "skeleton", frames=(0, 40))
    a = track(rig)
    b = track(rig)
    assert np.array_equal(a.body_pos, b.body_pos) and a.mse == b.mse
    t1 = tune(rig, points=2, max_order=5, seed=7)
    t2 = tune(rig, points=2, max_order=5, seed=7)
    assert t1.history == t2.history and len(t1.history) == 4
    assert t1.best_mse == min(h[3] for h in t1.history)
    t3 = tune(rig, points=2, max_order=5, seed=8)
    assert t3.history != t1.history


@needs_walk
def test_command_line(tmp_path, capsys):
    from engine.mocap_cli import main

    out = tmp_path / "o.bvh"
    rep = tmp_path / "r.json"
    assert main(["simulate", WALK, "--frames", "0-60", "--scale", "RightFoot:1.2@10-40", "--uncontrolled",
                 "LeftHand", "--lock", "LeftLeg", "--out", str(out), "--report", str(rep)]) == 0
    data = json.loads(rep.read_text())
    assert data["mode"] == "constrained" and data["locked"] == ["LeftLeg"] and "RightFoot" in data["joints"]
    assert load_bvh(out).nframe == 61
    assert main(["simulate", WALK, "--lock", "Knee"]) == 2
    assert "no joint 'Knee'" in capsys.readouterr().err
    assert main(["simulate", WALK, "--frames", "0-60", "--report", str(rep)]) == 2     # exists, no --force
    assert main(["tune", WALK, "--frames", "0-30", "--points", "1", "--max-order", "3", "--quiet"]) == 0
    assert "best: order 3" in capsys.readouterr().out
