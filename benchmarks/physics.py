"""Benchmark and validation of the rigid-body integrator (engine.physics) against MuJoCo.

    .venv/bin/python benchmarks/physics.py [--quick]

Prints a table and ends with one JSON line:
    bodies, dt, step_us            median us per step, the library humanoid (25 bodies:
                                   capsules and boxes, eyes of 20 g on a 6.7 kg head) lying
                                   on the ground after a drop, our integrator
    mujoco_step_us, ratio          the same model in MuJoCo (same masses, inertias, ball
                                   joints, body-floor contacts only), same run; ours / MuJoCo
    energy_drift_rel               passive 6-link chain (100:1 masses), 10 s at dt: (E_end -
                                   E_0) / its potential-energy swing (negative: it loses)
    energy_growth_max_rel          the largest rise of E over E_0 at any 0.1 s sample
    max_joint_error_mm             humanoid drop plus a 50 N s kick ((0, 40, -30) on the head): worst joint separation
    mocap_realtime_factor          simulated s per wall s tracking CMU 02_01 (walk),
                                   constrained skeleton (31 bodies), dt 0.0005
and the validation against MuJoCo (free fall, a pendulum's period, the ragdoll's resting
height and time to rest) with the differences.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import engine  # noqa: E402
from engine.paths import shared_data  # noqa: E402
from engine.physics import (  # noqa: E402
    BodySpec,
    PhysicsState,
    build_model,
    energy,
    joint_separation,
    model_from_creatures,
    step,
)
from engine.physics.model import SHAPE_BOX, SHAPE_SPHERE  # noqa: E402

DT = 0.0005
ID = np.array([1.0, 0.0, 0.0, 0.0])
WALK = str(shared_data("mocap", "cmu_02_01_walk.bvh"))  # $MENAGERIE_SHARED or ../shared


# ---------------------------------------------------------------------------------------
# The same model in MuJoCo
# ---------------------------------------------------------------------------------------

def _qconj(q):
    return np.array([q[0], -q[1], -q[2], -q[3]])


def _qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _qrot(q, v):
    u = q[1:]
    t = 2.0 * np.cross(u, v)
    return v + q[0] * t + np.cross(u, t)


def mjcf_from_model(model, pos, rot, *, friction=1.0, floor=True, timestep=DT) -> str:
    """MJCF of a PhysicsModel posed at (pos, rot): bodies nested by joint parent with
    explicit mass and principal inertia, ball joints at the joint points, free roots,
    fixed bodies welded to the world; geoms collide with the floor only."""
    n = model.nbody
    parent = np.full(n, -1)
    for j in range(model.njoint):
        parent[model.joint_child[j]] = model.joint_parent[j]
    children = [[] for _ in range(n)]
    for b in range(n):
        if parent[b] >= 0:
            children[parent[b]].append(b)

    def f(v):
        return " ".join(f"{x:.17g}" for x in v)

    def geom(b):
        shape, size = model.body_shape[b], model.body_size[b]
        common = f'contype="1" conaffinity="2" condim="3" friction="{friction:g} 0.005 0.0001"'
        if shape == SHAPE_SPHERE:
            return f'<geom type="sphere" size="{size[0]:.17g}" {common}/>'
        if shape == SHAPE_BOX:
            return f'<geom type="box" size="{f(size)}" {common}/>'
        e = np.zeros(3)
        e[int(size[2])] = size[1]
        if size[1] <= 0:
            return f'<geom type="sphere" size="{size[0]:.17g}" {common}/>'
        return f'<geom type="capsule" fromto="{f(-e)} {f(e)}" size="{size[0]:.17g}" {common}/>'

    def body_xml(b, depth):
        ind = "  " * depth
        p = parent[b]
        if p >= 0:
            lp = _qrot(_qconj(rot[p]), pos[b] - pos[p])
            lq = _qmul(_qconj(rot[p]), rot[b])
        else:
            lp, lq = pos[b], rot[b]
        out = [f'{ind}<body name="{model.body_names[b]}" pos="{f(lp)}" quat="{f(lq)}">']
        out.append(f'{ind}  <inertial pos="0 0 0" mass="{model.body_mass[b]:.17g}" '
                   f'diaginertia="{f(model.body_inertia[b])}"/>')
        if p >= 0:
            j = model.body_joint[b]
            out.append(f'{ind}  <joint type="ball" pos="{f(model.joint_anchor_child[j])}" damping="0"/>')
        elif not model.body_fixed[b]:
            out.append(f'{ind}  <freejoint/>')
        out.append(f"{ind}  {geom(b)}")
        for c in children[b]:
            out.extend(body_xml(c, depth + 1))
        out.append(f"{ind}</body>")
        return out

    lines = ['<mujoco model="menagerie">',
             f'  <option timestep="{timestep}" gravity="{f(model.settings.gravity)}" integrator="Euler"/>',
             '  <worldbody>']
    if floor:
        lines.append('    <geom type="plane" size="0 0 1" contype="2" conaffinity="1" '
                     f'friction="{friction} 0.005 0.0001"/>')
    for b in range(n):
        if parent[b] < 0:
            lines.extend(body_xml(b, 2))
    lines += ["  </worldbody>", "</mujoco>"]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------
# Scenes
# ---------------------------------------------------------------------------------------

def humanoid_drop(height=0.3):
    c = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    model = model_from_creatures(c)
    pos = np.array(model.body_rest_pos) + [0.0, 0.0, height]
    # tip it forward a little so it falls rather than lands on its feet
    tilt = np.array([math.cos(0.2), 0.0, math.sin(0.2), 0.0])
    centre = pos[0].copy()
    pos = centre + np.array([_qrot(tilt, p - centre) for p in pos])
    rot = np.array([_qmul(tilt, q) for q in model.body_rest_rot])
    return model, pos, rot


def time_ours(model, pos, rot, settle_steps, chunks=20, chunk=500):
    state = PhysicsState(model)
    state.set_pose(pos, rot)
    step(model, state, DT, steps=settle_steps)
    times = []
    for _ in range(chunks):
        t = time.perf_counter()
        step(model, state, DT, steps=chunk)
        times.append((time.perf_counter() - t) / chunk * 1e6)
    return float(np.median(times)), state


def time_mujoco(mj, xml, settle_steps, chunks=20, chunk=500):
    m = mj.MjModel.from_xml_string(xml)
    d = mj.MjData(m)
    mj.mj_step(m, d, nstep=settle_steps)
    times = []
    for _ in range(chunks):
        # one call of ``chunk`` steps, as ours is timed (mj_step's nstep loops in C): no
        # Python call overhead per step on either side
        t = time.perf_counter()
        mj.mj_step(m, d, nstep=chunk)
        times.append((time.perf_counter() - t) / chunk * 1e6)
    return float(np.median(times)), m, d


def rest_figures_ours(model, pos, rot, seconds=4.0):
    """Root height at the end and the first time total kinetic energy stays below
    1e-3 J per kg for the rest of the run."""
    state = PhysicsState(model)
    state.set_pose(pos, rot)
    n = int(seconds / DT)
    ke = np.empty(n // 20)
    for k in range(n // 20):
        step(model, state, DT, steps=20)
        ke[k] = energy(model, state)["kinetic"]
    return float(state.body_pos[0, 2]), _time_to_rest(ke, model.total_mass, 20 * DT)


def rest_figures_mujoco(mj, xml, model, seconds=4.0):
    m = mj.MjModel.from_xml_string(xml)
    d = mj.MjData(m)
    n = int(seconds / DT)
    ke = np.empty(n // 20)
    root = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, model.body_names[0])
    for k in range(n // 20):
        for _ in range(20):
            mj.mj_step(m, d)
        mj.mj_energyVel(m, d)
        ke[k] = d.energy[1]
    # (MuJoCo's fastest joint at the end: its 20 g eyes spin on their ball joints)
    rest_figures_mujoco.max_joint_speed = float(np.abs(d.qvel).max())
    return float(d.xpos[root, 2]), _time_to_rest(ke, model.total_mass, 20 * DT)


def _time_to_rest(ke, mass, sample_dt):
    moving = np.flatnonzero(ke > 1e-3 * mass)
    return float((moving[-1] + 1) * sample_dt) if moving.size else 0.0


def free_fall(mj):
    spec = [BodySpec("ball", "sphere", np.array([0.0, 0.0, 100.0]), ID, radius=0.1, contact="none")]
    model = build_model(spec)
    state = PhysicsState(model)
    step(model, state, DT, steps=2000)
    ours = float(state.body_pos[0, 2])
    theirs = float("nan")
    if mj is not None:
        m = mj.MjModel.from_xml_string(mjcf_from_model(model, model.body_rest_pos, model.body_rest_rot, floor=False))
        d = mj.MjData(m)
        for _ in range(2000):
            mj.mj_step(m, d)
        theirs = float(d.xpos[1, 2])
    return ours, theirs, 100.0 - 9.81 / 2


def pendulum(mj, angle=0.05, length=1.0):
    top = np.array([0.0, 0.0, 3.0])
    specs = [BodySpec("anchor", "sphere", top, ID, radius=0.05, fixed=True, contact="none"),
             BodySpec("rod", "capsule", top - [0, 0, length / 2], ID, radius=0.05, half_length=length / 2 - 0.05,
                      axis=2, parent=0, joint=top, contact="none")]
    model = build_model(specs)
    q = np.array([math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])
    pos = np.array([top, top + _qrot(q, np.array([0.0, 0.0, -length / 2]))])
    rot = np.array([ID, q])
    n = 8000

    def period(xs):
        t = (np.arange(n) + 1) * DT
        k = np.flatnonzero((xs[:-1] > 0) & (xs[1:] <= 0))
        return float(np.mean(np.diff(t[k] + xs[k] / (xs[k] - xs[k + 1]) * DT)))

    state = PhysicsState(model)
    state.set_pose(pos, rot)
    xs = np.empty(n)
    for i in range(n):
        step(model, state, DT)
        xs[i] = state.body_pos[1, 0]
    ours = period(xs)
    theirs = float("nan")
    if mj is not None:
        m = mj.MjModel.from_xml_string(mjcf_from_model(model, pos, rot, floor=False))
        d = mj.MjData(m)
        for i in range(n):
            mj.mj_step(m, d)
            xs[i] = d.xpos[2, 0]
        theirs = period(xs)
    mass, icom = model.body_mass[1], model.body_inertia[1, 0]
    analytic = 2 * math.pi * math.sqrt((icom + mass * (length / 2) ** 2) / (mass * 9.81 * length / 2))
    return ours, theirs, analytic


def chain_energy(seconds):
    top = np.array([0.0, 0.0, 3.0])
    q = np.array([math.cos(math.pi / 4), 0.0, math.sin(math.pi / 4), 0.0])
    masses = [10.0, 3.0, 1.0, 0.3, 0.1, 0.1]
    specs = [BodySpec("anchor", "sphere", top, ID, radius=0.03, fixed=True, contact="none")]
    for k in range(6):
        specs.append(BodySpec(f"link{k}", "capsule", top + [(k + 0.5) * 0.3, 0, 0], q, radius=0.03,
                              half_length=0.12, axis=2, parent=k, joint=top + [k * 0.3, 0, 0], contact="none",
                              mass=masses[k]))
    model = build_model(specs)
    state = PhysicsState(model)
    e0 = energy(model, state)["total"]
    swing = float(np.sum(model.body_mass[1:]) * 9.81 * 1.8)
    growth = -np.inf
    sep = 0.0
    for _ in range(int(seconds / 0.1)):
        step(model, state, DT, steps=200)
        growth = max(growth, energy(model, state)["total"] - e0)
        sep = max(sep, float(joint_separation(model, state).max()))
    return (energy(model, state)["total"] - e0) / swing, growth / swing, sep


def kick_joint_error():
    model, pos, rot = humanoid_drop(0.3)
    state = PhysicsState(model)
    state.set_pose(pos, rot)
    head = model.body("head")
    worst = 0.0
    for k in range(300):
        if k == 100:
            state.body_linvel[head] += np.array([0.0, 40.0, -30.0]) / model.body_mass[head]
        step(model, state, DT, steps=10)
        worst = max(worst, float(joint_separation(model, state).max()))
    return worst


def mocap_realtime():
    if not os.path.exists(WALK):
        return float("nan"), float("nan")
    from engine.io import load_bvh
    from engine.response.tracking import MocapRig, TrackingParams, track

    rig = MocapRig(load_bvh(WALK), "constrained", params=TrackingParams(dt=DT))
    r = track(rig)
    return r.realtime_factor, r.mse


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer timing chunks, 2 s chain")
    args = ap.parse_args(argv)
    try:
        import mujoco as mj
    except ImportError:
        mj = None
        print("mujoco not installed (pip install -e .[bench]): MuJoCo columns are NaN")

    chunks = 6 if args.quick else 20
    model, pos, rot = humanoid_drop(0.3)
    settle = 3000
    # warm up the JIT outside the timing
    time_ours(model, pos, rot, 10, chunks=1, chunk=10)
    ours_us, state = time_ours(model, pos, rot, settle, chunks=chunks)
    contacts = int(state.feat_active.sum())
    mj_us = float("nan")
    if mj is not None:
        xml = mjcf_from_model(model, pos, rot)
        mj_us, mm, md = time_mujoco(mj, xml, settle, chunks=chunks)
    ratio = ours_us / mj_us if mj is not None else float("nan")

    print(f"{'figure':<44}{'ours':>14}{'MuJoCo':>14}{'reference':>14}")
    print("-" * 86)
    print(f"{'humanoid 25 bodies, us/step (dt 0.0005)':<44}{ours_us:>14.2f}{mj_us:>14.2f}{'':>14}"
          f"   ({contacts} ground features touching)")
    ff = free_fall(mj)
    print(f"{'free fall 1 s from 100 m: z (m)':<44}{ff[0]:>14.5f}{ff[1]:>14.5f}{ff[2]:>14.5f}")
    pe = pendulum(mj)
    print(f"{'pendulum (1 m rod, 3 deg): period (s)':<44}{pe[0]:>14.5f}{pe[1]:>14.5f}{pe[2]:>14.5f}")
    rest_ours = rest_figures_ours(model, pos, rot)
    rest_mj = (float("nan"), float("nan"))
    if mj is not None:
        rest_mj = rest_figures_mujoco(mj, mjcf_from_model(model, pos, rot), model)
    print(f"{'humanoid drop: resting pelvis height (m)':<44}{rest_ours[0]:>14.4f}{rest_mj[0]:>14.4f}")
    print(f"{'humanoid drop: time to rest (s)':<44}{rest_ours[1]:>14.3f}{rest_mj[1]:>14.3f}"
          "   (4.0: not at rest within 4 s)")
    if mj is not None:
        print(f"{'humanoid drop: fastest joint at 4 s (rad/s)':<44}{'':>14}"
              f"{rest_figures_mujoco.max_joint_speed:>14.1f}")
    drift, growth, chain_sep = chain_energy(2.0 if args.quick else 10.0)
    print(f"{'passive chain 10 s: energy change / swing':<44}{drift:>14.2e}   max growth {growth:+.2e}, "
          f"joint separation {chain_sep * 1000:.3f} mm")
    kick = kick_joint_error()
    print(f"{'humanoid drop + 50 N s kick: joint error mm':<44}{kick * 1000:>14.3f}")
    rt, walk_mse = mocap_realtime()
    print(f"{'CMU 02_01 walk, constrained: x real time':<44}{rt:>14.2f}   mse {walk_mse:.4f} m^2")
    out = {
        "bodies": model.nbody, "dt": DT, "step_us": round(ours_us, 3), "mujoco_step_us": round(mj_us, 3),
        "ratio": round(ratio, 3), "energy_drift_rel": drift, "energy_growth_max_rel": growth,
        "max_joint_error_mm": round(kick * 1000, 4), "mocap_realtime_factor": round(rt, 3),
        "free_fall_z": [ff[0], ff[1], ff[2]], "pendulum_period_s": [pe[0], pe[1], pe[2]],
        "rest_height_m": [rest_ours[0], rest_mj[0]], "time_to_rest_s": [rest_ours[1], rest_mj[1]],
    }
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
