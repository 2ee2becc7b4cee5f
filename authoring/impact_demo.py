"""The impact demo (issue 13): ``menagerie demo --impacts``. A humanoid, a dog, a spider, a
snake and two random creatures stand in a row and are hit from several directions, twice
in quick succession (hits in series), while a humanoid's punch lands on another humanoid
(``engine.response.strike``). Headless it writes ``OUT/impacts_frame_*.png``,
``OUT/impacts_contact_sheet.png``, ``OUT/impacts.gif`` (pillow) and
``OUT/impacts_figure1.png``: the paper's Figure 1 (root height of Simulation 1, of the live
simulation and of the displayed result, with the impact, the reaction delay and the
hand-off marked; matplotlib), with the same first hit answered the paper's way offline
(``engine.response.paper``) in a second panel.
"""

from __future__ import annotations

import os
import time

import numpy as np

from engine.paths import LIBRARY_CREATURES

CREATURES = ("humanoid", "dog", "spider", "snake", "random:0", "random:6")
#: (seconds, body: "root" or a fraction into the body list, direction (x, y), m/s times chain_mass)
HITS = ((0.4, "root", (-1.0, 0.0), 3.0), (1.8, 0.5, (0.0, 1.0), 1.5), (1.95, 0.8, (0.0, 1.0), 1.5),
        (3.2, "root", (1.0, 0.3), 0.6))
OUTPUTS = ("impacts_frame_*.png", "impacts_contact_sheet.png", "impacts.gif", "impacts_figure1.png")


def _load(name):
    import engine
    from engine.model import build_creature, random_creature_def

    if name.startswith("random:"):
        return build_creature(random_creature_def(int(name.split(":")[1])))
    return engine.load_creature(os.path.join(LIBRARY_CREATURES, f"{name}.yaml"))


def build(seconds: float):
    """The characters, their hits, the strike pair; returns (characters, labels, step)."""
    import engine
    from engine.response.impact import chain_mass
    from engine.response.library import library_for
    from engine.response.paper import paper_response
    from engine.response.strike import Strike

    idle = engine.load_animation(os.path.join(os.path.dirname(LIBRARY_CREATURES), "animations",
                                              "idle_breathe.yaml"))
    punch = engine.load_animation(os.path.join(os.path.dirname(LIBRARY_CREATURES), "animations", "punch.yaml"))
    chars, labels, y = [], [], 0.0
    for name in CREATURES:
        c = _load(name)
        library_for(c)                       # at load time, as a game would
        ch = engine.Character(c)
        w = float(max(c.size))
        y += 0.6 * w
        ch.set_placement(position=(0.0, y, 0.0), teleport=True)
        y += 0.6 * w + 0.4
        try:
            ch.play(idle)
        except engine.MenagerieError:
            pass
        chars.append(ch)
        labels.append(c.name)
    # the strike pair
    hum = _load("humanoid")
    a, v = engine.Character(hum), engine.Character(hum)
    y += 0.8
    a.set_placement(position=(0.0, y, 0.0), teleport=True)
    v.set_placement(position=(0.6, y, 0.0), heading=np.pi, teleport=True)
    for ch in (a, v):
        ch.play(idle)
    chars += [a, v]
    labels += ["attacker", "victim"]
    strike = Strike(a, v, ["hand_r", "forearm_r"])
    state = {"t": 0.0, "punched": False, "first": None, "fig": None, "paper": None}

    def step(dt):
        t0 = state["t"]
        state["t"] = t1 = t0 + dt
        for ch in chars[:-2]:
            c = ch.creature
            for when, body, d, speed in HITS:
                if t0 <= when < t1:
                    b = 0 if body == "root" else min(int(body * c.nbody), c.nbody - 1)
                    if c.name == "humanoid" and ch.response is not None and state["fig"] is None:
                        state["fig"] = _trace(ch.response)      # the first response, before the next hit
                    d = np.array([d[0], d[1], 0.0]) / np.hypot(*d)
                    if c.name == "humanoid" and state["paper"] is None:
                        # the same first hit answered as the paper wrote it, offline (Figure 1's
                        # second panel): nothing of it is shown in the scene
                        state["paper"] = paper_response(ch, b, d * speed * chain_mass(c, b))
                    ch.hit(b, d * speed * chain_mass(c, b))
                    if state["first"] is None and c.name == "humanoid":
                        state["first"] = ch.response
        if not state["punched"] and t1 >= 0.5:
            a.set_target("foe", v.world_positions[hum.body("spine2")])
            a.play(punch, fade=0.1)
            state["punched"] = True
        for ch in chars:
            ch.tick(dt)
        strike.tick(dt)

    return chars, labels, step, state


def _trace(resp):
    # a tap blends back at the end of the reaction delay, with no clip found
    handoff = resp.params.reaction_delay if resp.tap else resp._handoff
    clip = "a tap: back onto its clip" if resp.tap else (f"re-entered '{resp.clip.name}'" if resp.clip
                                                          else "re-entered its gait")
    return {"root": list(resp.root_trace), "sim1": list(resp.sim1_trace), "handoff": handoff,
            "delay": resp.params.reaction_delay, "name": resp.char.creature.name, "clip": clip}


def _figure1(tr, out, paper=None):
    """The paper's Figure 1 for the live response ``tr`` (``_trace``) and, below it, for the
    same hit answered the paper's way offline (``paper``: an ``engine.response.paper``
    result), on one time axis."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([r[0] for r in tr["root"]])
    z = np.array([r[2] for r in tr["root"]])
    phys = np.array([r[1] in ("burst", "transition") for r in tr["root"]])
    s1 = np.array(tr["sim1"]).reshape(-1, 2)
    if paper is None:
        fig, ax = plt.subplots(figsize=(8, 4))
    else:
        fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 7), sharex=True, sharey=True)
        K = paper.sim2_pos.shape[0] - 1
        bx.plot(paper.sim1_t, paper.sim1_pos[:, 0, 2], label="Simulation 1 (friction 1.0)", color="tab:blue")
        bx.plot(paper.t[: K + 1], paper.sim2_pos[:, 0, 2], label="Simulation 2 (friction 0.5)", color="tab:green")
        bx.plot(paper.t, paper.pos[:, 0, 2], label="final blend, then the clip", color="tab:red", lw=1, ls="--")
        bx.axvline(0, color="k", lw=0.8, label="impact")
        bx.axvline(tr["delay"], color="gray", ls=":", label="reaction delay")
        bx.axvline(paper.handoff, color="purple", ls="-.", label="match (end of the blend)")
        name = f"'{paper.clip.name}'" if paper.clip is not None else "its gait"
        bx.set_title(f"the paper's way, offline ({paper.substep * 1e3:g} ms step): {name}, "
                     f"{paper.seconds['total']:.2f} s to compute before the first frame", fontsize=9)
        bx.set_xlabel("time after the impact (s)")
        bx.set_ylabel("root height (m)")
        bx.legend(fontsize=8)
    ax.plot(s1[:, 0], s1[:, 1], label="Simulation 1 (lookahead, friction 1.0)", color="tab:blue")
    ax.plot(t[phys], z[phys], ".", ms=3, label="Simulation 2 (live, friction 0.5)", color="tab:green")
    ax.plot(t, z, label="displayed (blended)", color="tab:red", lw=1, ls="--")
    ax.axvline(0, color="k", lw=0.8, label="impact")
    ax.axvline(tr["delay"], color="gray", ls=":", label="reaction delay")
    ax.axvline(tr["handoff"], color="purple", ls="-.", label="hand-off")
    ax.set_xlabel("time after the impact (s)")
    ax.set_ylabel("root height (m)")
    ax.set_title(f"{tr['name']}: hit on the root at {HITS[0][3]:g} m/s, {tr['clip']}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def run_impact_demo(headless: bool = True, out_dir: str = "out/demo", seconds: float = 4.5, fps: int = 30) -> int:
    from authoring import render as rd
    from authoring import scene as sc
    from authoring.demo import _contact_sheet

    t0 = time.perf_counter()
    chars, labels, step, state = build(seconds)
    print(f"menagerie impact demo: {len(chars)} characters set up in {time.perf_counter() - t0:.1f} s")
    os.makedirs(out_dir, exist_ok=True)
    scene = sc.Scene(actors=[sc.Actor(ch.creature, label=lab) for ch, lab in zip(chars, labels, strict=True)])
    nframe = max(int(round(seconds * fps)), 1)
    keep = set(np.linspace(0, nframe - 1, 8).round().astype(int).tolist())
    sheet, gif = [], []
    with rd.Renderer(960, 540) as renderer:
        camera = None
        for f in range(nframe):
            step(1.0 / fps)
            for actor, ch, lab in zip(scene.actors, chars, labels, strict=True):
                actor.set_pose(ch.world_positions, ch.world_rotations)
                r = ch.response
                actor.label = f"{lab}\n{r.phase if r is not None and r.reacting else ''}"
            scene.caption = f"impact response  t={state['t']:.2f} s  (hits at {', '.join(f'{h[0]:g}' for h in HITS)} s)"
            if camera is None:
                camera = renderer.frame(scene)
            renderer.draw(scene, camera)
            rgb = renderer.read_pixels()
            if f in keep:
                rd.write_png(os.path.join(out_dir, f"impacts_frame_{f:03d}.png"), rgb)
                sheet.append(rgb.copy())
            if f % 2 == 0:
                gif.append(rgb[::2, ::2].copy())
    rd.write_png(os.path.join(out_dir, "impacts_contact_sheet.png"), _contact_sheet(sheet, columns=4))
    try:
        from PIL import Image

        images = [Image.fromarray(g) for g in gif]
        images[0].save(os.path.join(out_dir, "impacts.gif"), save_all=True, append_images=images[1:],
                       duration=int(2000 / fps), loop=0)
    except ImportError:
        print("menagerie impact demo: pillow is not installed (pip install -e '.[media]'): no GIF")
    fig = state["fig"] or (_trace(state["first"]) if state["first"] is not None else None)
    if fig is not None and fig["sim1"]:
        _figure1(fig, os.path.join(out_dir, "impacts_figure1.png"), state["paper"])
    print(f"menagerie impact demo: wrote {out_dir}/impacts_contact_sheet.png, impacts.gif, impacts_figure1.png "
          f"in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    import sys

    raise SystemExit(run_impact_demo(out_dir=sys.argv[1] if len(sys.argv) > 1 else "out/demo"))
