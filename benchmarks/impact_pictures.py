"""Filmstrips of hit creatures and a Figure-1-style plot (Zordan et al. 2005 Fig. 1: root
height of Simulation 1, of the live response, and of the result, with the impact, the
reaction delay and the hand-off marked).

    .venv/bin/python benchmarks/impact_pictures.py OUT_DIR [--force]

Writes OUT_DIR/filmstrip_<creature>.png (one creature standing, shoved on its root along
-X at t = 0 with 1.5 m/s worth of its mass; frames from just before the hit to 1.5 s
after) for a humanoid, a dog and a random creature, OUT_DIR/figure1.png, and
OUT_DIR/strike_humanoids.png (a punch landing on another humanoid, engine.response.strike).
"""

from __future__ import annotations

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import numpy as np  # noqa: E402

import engine  # noqa: E402
from authoring import scene as sc  # noqa: E402
from authoring.render import render_png  # noqa: E402
from engine.model import build_creature, random_creature_def  # noqa: E402
from engine.response.impact import ImpactParams, _models  # noqa: E402
from engine.runtime import Character  # noqa: E402

DT = 1 / 60
TIMES = (-0.05, 0.05, 0.15, 0.25, 0.4, 0.6, 0.9, 1.5)


def filmstrip(c, out):
    ch = Character(c)
    ch.play(engine.load_animation(os.path.join(ROOT, "animations", "idle_breathe.yaml")))
    for _ in range(10):
        ch.tick(DT)
    mass = _models(c, ImpactParams())[1].total_mass
    actors = []
    k_hit = 3
    want = {k_hit + int(round(t / DT)): t for t in TIMES}
    for k in range(max(want) + 1):
        if k == k_hit:
            ch.hit(0, (-1.5 * mass, 0.0, 0.0))
        ch.tick(DT)
        if k in want:
            i = len(actors)
            ph = ch.response.phase if ch.response else "idle"
            a = sc.Actor(c, label=f"{want[k]:+.2f}s {ph}", offset=(0.0, 1.6 * max(c.size) * i, 0.0))
            a.set_pose(ch.world_positions, ch.world_rotations)
            actors.append(a)
    clip = ch.response.clip.name if ch.response.clip else "-"
    scene = sc.Scene(actors=actors, caption=f"{c.name}: shoved along -X at 0 s; re-entered '{clip}'")
    return render_png(scene, out, 1800, 520), ch.response


def strike_strip(out):
    """A humanoid's punch landing on another (engine.response.strike): both in one frame
    per time, the victim's reaction and the attacker's recoil."""
    from engine.response.strike import Strike

    hum = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    idle = engine.load_animation(os.path.join(ROOT, "animations", "idle_breathe.yaml"))
    a, v = Character(hum), Character(hum)
    v.set_placement(position=(0.6, 0, 0), heading=np.pi, teleport=True)
    a.play(idle)
    v.play(idle)
    for _ in range(5):
        a.tick(DT)
        v.tick(DT)
    a.set_target("foe", v.world_positions[hum.body("spine2")])
    a.play(engine.load_animation(os.path.join(ROOT, "animations", "punch.yaml")), fade=0.1)
    st = Strike(a, v, ["hand_r", "forearm_r"])
    actors, landed = [], None
    shots = (0.3, 0.45, 0.5, 0.6, 0.8, 1.1, 1.6, 2.4)
    for k in range(int(2.5 / DT)):
        a.tick(DT)
        v.tick(DT)
        if st.tick(DT) is not None and landed is None:
            landed = k * DT
        t = k * DT
        if any(abs(t - x) < DT / 2 for x in shots):
            i = len(actors) // 2
            off = (0.0, 1.6 * max(hum.size) * i, 0.0)
            ph = v.response.phase if v.response else "idle"
            for ch, lab in ((a, f"{t:.2f}s"), (v, ph)):
                actor = sc.Actor(hum, label=lab, offset=off)
                actor.set_pose(ch.world_positions, ch.world_rotations)
                actors.append(actor)
    clip = v.response.clip.name if v.response and v.response.clip else "-"
    scene = sc.Scene(actors=actors, caption=f"punch lands at {landed:.2f} s; the victim re-enters '{clip}', "
                                            f"the attacker recoils onto its punch")
    return render_png(scene, out, 1800, 520)


def figure1(resp, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r[0] for r in resp.root_trace])
    z = np.array([r[2] for r in resp.root_trace])
    ph = [r[1] for r in resp.root_trace]
    s1 = np.array(resp.sim1_trace)
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(s1[:, 0], s1[:, 1], label="Simulation 1 (lookahead, friction 1.0)", color="tab:blue")
    phys = np.array([p in ("burst", "transition") for p in ph])
    ax.plot(t[phys], z[phys], label="Simulation 2 (live, friction 0.5)", color="tab:green")
    ax.plot(t, z, label="displayed (blended)", color="tab:red", lw=1, ls="--")
    p = resp.params
    ax.axvline(0, color="k", lw=0.8)
    ax.axvline(p.reaction_delay, color="gray", ls=":", label="reaction delay")
    ax.axvline(resp._handoff, color="purple", ls="-.", label="hand-off")
    ax.set_xlabel("time after impact (s)")
    ax.set_ylabel("root height (m)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--force", action="store_true")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    creatures = [engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml")),
                 engine.load_creature(os.path.join(ROOT, "creatures", "dog.yaml")),
                 build_creature(random_creature_def(4))]
    first = None
    for c in creatures:
        path = os.path.join(a.out, f"filmstrip_{c.name}.png")
        if os.path.exists(path) and not a.force:
            sys.exit(f"{path} exists (use --force)")
        _, resp = filmstrip(c, path)
        first = first or resp
        print(path)
    print(figure1(first, os.path.join(a.out, "figure1.png")))
    print(strike_strip(os.path.join(a.out, "strike_humanoids.png")))


if __name__ == "__main__":
    main()
