"""Planted feet during an impact response: how fast a foot that was on the ground at the hit
slides along the ground while it stays in contact, and how far the root drifts sideways
(perpendicular to the push).

    .venv/bin/python benchmarks/impact_slide.py [--creatures humanoid random2] [--sizes 0.3 0.8]

For each creature, hits on the root in 8 horizontal directions, each of ``size`` m/s worth of
the whole creature's mass (``chain_mass`` of the root). Every substep of Simulation 1 (the
lookahead) and of Simulation 2 (live) is sampled: for each ground feature of a foot body that
touched the ground when the hit landed (its surface within 5 mm), while it carries load
(normal impulse > 0), the slip speed of its contact point (the tangential part of
v + w x r at the point on the surface nearest the ground). Printed per creature and
simulation: the median and mean of the samples, their p95, and the share of samples where
friction was saturated (|tangential impulse| >= 0.999 mu normal impulse: the push exceeds
friction there, a slide is the right answer) and the mean slip where it was and where not.
Drift: Simulation 1's root, the ground-plane
component perpendicular to the push, largest |.| over the lookahead; and along the push.
"""

from __future__ import annotations

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

import engine  # noqa: E402
from engine.model import build_creature, random_creature_def  # noqa: E402
from engine.physics import _kernels as PK  # noqa: E402
from engine.response import impact as I  # noqa: E402
from engine.runtime import Character  # noqa: E402

DT = 1 / 60
IDLE = os.path.join(ROOT, "animations", "idle_breathe.yaml")
PLANTED = 0.005        # m: a foot feature this close to the ground at the hit is planted


def creature(name):
    if name.startswith("random"):
        return build_creature(random_creature_def(int(name[6:])))
    return engine.load_creature(os.path.join(ROOT, "creatures", f"{name}.yaml"))


class Probe:
    """Wraps impact.step: every call is run substep by substep and sampled."""

    def __init__(self):
        self.orig = I.step
        self.resp = None
        self.planted = {}          # id(state) -> feature indices planted at the hit
        self.samples = {1: [], 2: []}
        self.saturated = {1: [], 2: []}
        self.sim1_iterations = 1   # solver iterations per substep in Simulation 1 (an experiment)

    def __enter__(self):
        I.step = self
        return self

    def __exit__(self, *exc):
        I.step = self.orig

    def plant(self, model, state):
        """Foot features touching the ground in this state."""
        f = self._features(model, state)
        self.planted[id(state)] = f
        return f

    @staticmethod
    def _features(model, state):
        feet = np.flatnonzero(np.asarray(model.body_contact_kind) == PK.KIND_FOOT)
        out = []
        for f in range(model.feat_body.shape[0]):
            b = int(model.feat_body[f])
            if b not in feet:
                continue
            p = _world_point(state, b, model.feat_local[f])
            if p[2] - model.feat_radius[f] < PLANTED:
                out.append(f)
        return np.array(out, int)

    def __call__(self, model, state, dt, *, substeps=1, **kw):
        r = self.resp
        which = 1 if (r is not None and state is r.sim1) else 2 if (r is not None and state is r.sim2) else 0
        if which == 0 or id(state) not in self.planted:
            return self.orig(model, state, dt, substeps=substeps, **kw)
        if which == 1 and self.sim1_iterations != 1:
            kw["iterations"] = self.sim1_iterations
        h = dt / substeps
        mu = model.settings.foot.mu
        for _ in range(substeps):
            self.orig(model, state, h, substeps=1, **kw)
            for f in self.planted[id(state)]:
                if state.feat_active[f] == 0 or state.feat_imp[f, 0] <= 0.0:
                    continue
                b = int(model.feat_body[f])
                c = _world_point(state, b, model.feat_local[f]) - np.array([0, 0, model.feat_radius[f]])
                v = state.body_linvel[b] + np.cross(state.body_angvel[b], c - state.body_pos[b])
                self.samples[which].append(float(np.hypot(v[0], v[1])))
                t = float(np.hypot(state.feat_imp[f, 1], state.feat_imp[f, 2]))
                self.saturated[which].append(t >= 0.999 * mu * state.feat_imp[f, 0])
        return None


def _world_point(state, b, local):
    q = state.body_rot[b]
    w, v = q[0], q[1:]
    t = 2.0 * np.cross(v, local)
    return state.body_pos[b] + local + w * t + np.cross(v, t)


def run(name, sizes, ndir=8, sim1_iterations=1):
    c = creature(name)
    m = I.chain_mass(c, 0)
    drift, along = [], []
    with Probe() as probe:
        probe.sim1_iterations = sim1_iterations
        for size in sizes:
            for k in range(ndir):
                a = 2 * np.pi * (k + 0.5) / ndir
                d = np.array([np.cos(a), np.sin(a), 0.0])
                ch = Character(c)
                ch.play(engine.load_animation(IDLE))
                for _ in range(10):
                    ch.tick(DT)
                ch.hit(0, d * size * m)
                r = ch.response
                probe.resp = r
                probe.planted.clear()
                probe.plant(r.model1, r.sim1)
                probe.plant(r.model2, r.sim2)
                root0 = r.sim1.body_pos[0].copy()
                for _ in range(int(1.3 / DT)):
                    ch.tick(DT)
                    if not ch.reacting:
                        break
                path = r._sim1_pos[: r._sim1_count, 0, :2] - root0[:2]
                side = np.array([-d[1], d[0]])
                drift.append(float(np.abs(path @ side).max()))
                along.append(float((path @ d[:2])[-1]))
    out = {"creature": name}
    for which in (1, 2):
        s = np.array(probe.samples[which])
        sat = np.array(probe.saturated[which])
        out[f"sim{which}"] = dict(n=len(s), median=float(np.median(s)) if len(s) else np.nan,
                                  mean=float(s.mean()) if len(s) else np.nan,
                                  p95=float(np.percentile(s, 95)) if len(s) else np.nan,
                                  saturated=float(sat.mean()) if len(sat) else np.nan,
                                  mean_unsat=float(s[~sat].mean()) if (~sat).any() else np.nan,
                                  mean_sat=float(s[sat].mean()) if sat.any() else np.nan)
    out["drift_side_max"] = float(np.max(drift))
    out["drift_side_median"] = float(np.median(drift))
    out["along_median"] = float(np.median(along))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--creatures", nargs="*", default=["humanoid", "random2"])
    ap.add_argument("--sizes", nargs="*", type=float, default=[0.3, 0.8])
    ap.add_argument("--directions", type=int, default=8)
    ap.add_argument("--sim1-iterations", type=int, default=1, help="solver iterations in Simulation 1 (experiment)")
    args = ap.parse_args()
    for name in args.creatures:
        o = run(name, args.sizes, args.directions, args.sim1_iterations)
        for which in (1, 2):
            s = o[f"sim{which}"]
            print(f"{name:10s} sim{which}: planted-foot slip median {s['median']:.4f} mean {s['mean']:.4f} "
                  f"p95 {s['p95']:.4f} m/s over {s['n']} samples; friction saturated {s['saturated']:.2f} "
                  f"(mean slip where not {s['mean_unsat']:.4f}, where saturated {s['mean_sat']:.4f})")
        print(f"{name:10s} sim1 root: sideways drift max {o['drift_side_max']:.3f} median "
              f"{o['drift_side_median']:.3f} m; along the push (end) median {o['along_median']:.3f} m")


if __name__ == "__main__":
    main()
