"""Debug view of the Particle IK solver, as the paper's figures 7 and 8 draw it.

After a solve, ``ik_overlays(plan, scratch, out_pos, out_rot, goals)`` returns viewer
overlays read from the solver's own scratch (nothing is solved again):

- spine-phase particles (blue dots) and constraints: spine constraints between branch
  points (blue), simplified limbs from the spine to each goal (yellow, figure 7), the
  delegated goals' rigid chords (purple);
- limb-phase particles at every limb joint (red dots) and the limb constraints (green,
  figure 7), cross-constraints between sibling branches (cyan), tip particles (orange);
- the posed quintic spine splines (figure 8, green polylines);
- the goals (magenta dots) with a thin line from each goal body's origin to its goal.

``ik_scene(...)`` wraps that with an actor for the solved pose (free bodies placed
rigidly on their parents). ``python -m authoring.ik_debug`` renders the hard cases (out of
reach, conflicting goals, a buckling spine with and without anti-buckling) into
``.notes/ik_*.png``.
"""

from __future__ import annotations

import argparse
import math
import os

import numpy as np

from authoring import scene as sc
from engine.ik import IKParams, IKSolver, pose_free_rigid
from engine.ik import _kernels as K

SPINE_COLOR = (0.15, 0.35, 0.95)
CHORD_COLOR = (0.95, 0.85, 0.10)
DELEGATE_COLOR = (0.60, 0.20, 0.80)
LIMB_COLOR = (0.10, 0.75, 0.25)
CROSS_COLOR = (0.10, 0.80, 0.85)
TIP_COLOR = (1.00, 0.55, 0.10)
LIMB_PARTICLE_COLOR = (0.90, 0.10, 0.10)
SPLINE_COLOR = (0.20, 0.85, 0.30)
GOAL_COLOR = (0.95, 0.10, 0.85)


def _scratch_blocks(plan, scratch):
    a = plan.arrays
    lay = a.scratch_layout
    nsp, nlp = a.sp_kind.shape[0], a.lp_body.shape[0]
    sp_pos = scratch[lay[0]:lay[0] + nsp]
    lp_pos = scratch[lay[2]:lay[2] + nlp]
    return sp_pos, lp_pos, float(scratch[lay[7], 0])


def posed_splines(plan, scratch, out_rot, samples: int = 24) -> list[np.ndarray]:
    """Points along each posed spine spline (the same spline the solve transported the
    interior spine bodies along)."""
    a = plan.arrays
    sp_pos, _, _ = _scratch_blocks(plan, scratch)
    out = []
    for g in range(a.seg_a.shape[0]):
        ia, ib = int(a.seg_a[g]), int(a.seg_b[g])
        ra, rb = tuple(out_rot[a.sp_body[ia]]), tuple(out_rot[a.sp_body[ib]])
        p0, p1 = tuple(sp_pos[ia]), tuple(sp_pos[ib])
        chord = float(np.linalg.norm(np.subtract(p1, p0)))
        scale = chord / a.seg_rest_chord[g] if a.seg_rest_chord[g] > 1e-12 else 1.0
        v0 = K.vscale(K.qrot(ra, tuple(a.seg_v0[g])), scale)
        a0 = K.vscale(K.qrot(ra, tuple(a.seg_a0[g])), scale)
        v1 = K.vscale(K.qrot(rb, tuple(a.seg_v1[g])), scale)
        a1 = K.vscale(K.qrot(rb, tuple(a.seg_a1[g])), scale)
        pts = np.array([K.hermite5_point(p0, v0, a0, p1, v1, a1, t) for t in np.linspace(0.0, 1.0, samples)])
        out.append(pts)
    return out


def ik_overlays(plan, scratch, out_pos, out_rot, goals, offset=(0.0, 0.0, 0.0)) -> list:
    """Points, segments and polylines showing the last solve (see the module docstring)."""
    a = plan.arrays
    off = np.asarray(offset, float)
    sp_pos, lp_pos, _ = _scratch_blocks(plan, scratch)
    items = []
    spine_pts = sp_pos[(a.sp_kind == 0) | (a.sp_kind == 1)]
    items.append(sc.Points(spine_pts + off, color=SPINE_COLOR, size=10.0, name="spine particles"))
    for kind, color, name in ((0, SPINE_COLOR, "spine constraints"), (1, CHORD_COLOR, "simplified limbs"),
                              (2, DELEGATE_COLOR, "delegated goals")):
        sel = np.flatnonzero(a.sc_kind == kind)
        if sel.size:
            items.append(sc.Segments(sp_pos[a.sc_a[sel]] + off, sp_pos[a.sc_b[sel]] + off, color=color,
                                     width=3.0, name=name))
    if a.lp_body.shape[0]:
        tips = a.lp_mode == 3
        items.append(sc.Points(lp_pos[~tips] + off, color=LIMB_PARTICLE_COLOR, size=7.0, name="limb particles"))
        if np.any(tips):
            items.append(sc.Points(lp_pos[tips] + off, color=TIP_COLOR, size=7.0, name="tip particles"))
        tree = set(int(x) for x in a.lp_con if x >= 0)
        sel = np.array(sorted(tree), dtype=int)
        cross = np.array([k for k in range(a.lc_a.shape[0]) if k not in tree], dtype=int)
        if sel.size:
            items.append(sc.Segments(lp_pos[a.lc_a[sel]] + off, lp_pos[a.lc_b[sel]] + off, color=LIMB_COLOR,
                                     width=2.0, name="limb constraints"))
        if cross.size:
            items.append(sc.Segments(lp_pos[a.lc_a[cross]] + off, lp_pos[a.lc_b[cross]] + off, color=CROSS_COLOR,
                                     width=1.5, name="cross constraints"))
    for k, pts in enumerate(posed_splines(plan, scratch, out_rot)):
        items.append(sc.Polyline(pts + off, color=SPLINE_COLOR, width=3.0, name=f"spine spline {k}"))
    gb = [g for g in plan.goal_bodies if goals.goal_pos_weight[g] > 0]
    if gb:
        gp = goals.goal_pos[gb]
        items.append(sc.Points(gp + off, color=GOAL_COLOR, size=12.0, name="goals"))
        items.append(sc.Segments(out_pos[gb] + off, gp + off, color=GOAL_COLOR, width=1.0, name="goal error"))
    return items


def ik_scene(solver: IKSolver, offset=(0.0, 0.0, 0.0), label: str | None = None, scene: sc.Scene | None = None):
    """A scene (or ``scene`` extended) with the solved pose and its IK overlays."""
    scene = sc.Scene() if scene is None else scene
    pos, rot = solver.out_pos.copy(), solver.out_rot.copy()
    pose_free_rigid(solver.plan, pos, rot)
    scene.add(sc.Actor(solver.plan.creature, pos, rot, offset=offset, label=label))
    for item in ik_overlays(solver.plan, solver.scratch, pos, rot, solver.goals, offset):
        scene.add(item)
    return scene


# -- the hard cases ---------------------------------------------------------------------


def hard_cases(creature):
    """(name, [(label, solver)]) for the pictures of the note."""
    c = creature
    rp, rr = c.body_rest_pos[0].copy(), c.body_rest_rot[0].copy()
    limbs = ["hand_l", "hand_r", "foot_l", "foot_r"]
    cases = []

    def solver(goal_names, params=None):
        return IKSolver(c, [c.body(n) for n in goal_names], params or IKParams())

    # Reachable goals, and the same hand goals far out of reach.
    s1 = solver(limbs + ["head"])
    s1.goals.set(c.body("hand_l"), pos=c.body_rest_pos[c.body("hand_l")] + [0.35, 0.1, 0.45])
    s1.goals.set(c.body("hand_r"), pos=c.body_rest_pos[c.body("hand_r")] + [0.3, -0.05, 0.1])
    s1.goals.set(c.body("foot_l"), pos=c.body_rest_pos[c.body("foot_l")] + [0.25, 0.0, 0.25])
    s1.goals.set(c.body("foot_r"), pos=c.body_rest_pos[c.body("foot_r")])
    s1.goals.set(c.body("head"), pos=c.body_rest_pos[c.body("head")] + [0.1, 0.05, -0.05])
    s1.solve(rp, rr)
    s2 = solver(limbs)
    s2.goals.set(c.body("hand_l"), pos=c.body_rest_pos[c.body("hand_l")] + [1.2, 0.6, 1.0])
    s2.goals.set(c.body("hand_r"), pos=c.body_rest_pos[c.body("hand_r")] + [1.0, -0.4, -0.2])
    s2.goals.set(c.body("foot_l"), pos=c.body_rest_pos[c.body("foot_l")] + [0.9, 0.2, 0.2])
    s2.goals.set(c.body("foot_r"), pos=c.body_rest_pos[c.body("foot_r")])
    s2.solve(rp, rr)
    cases.append(("reach", [("in reach", s1), ("out of reach", s2)]))
    # Conflicting goals: both hands pulled far apart sideways; a hand up and a foot down.
    s3 = solver(["hand_l", "hand_r"])
    s3.goals.set(c.body("hand_l"), pos=(0.1, 1.6, 1.4))
    s3.goals.set(c.body("hand_r"), pos=(0.1, -1.6, 1.4))
    s3.solve(rp, rr)
    s4 = solver(["hand_l", "foot_l", "foot_r"])
    s4.goals.set(c.body("hand_l"), pos=(0.2, 0.3, 3.0))
    s4.goals.set(c.body("foot_l"), pos=(0.0, 0.1, -1.0))
    s4.goals.set(c.body("foot_r"), pos=c.body_rest_pos[c.body("foot_r")])
    s4.solve(rp, rr)
    cases.append(("conflict", [("hands apart", s3), ("hand up, foot down", s4)]))
    # Implausible: head goal behind and below the back, without and with anti-buckling.
    goal = c.body_rest_pos[0] + np.array([-0.7, 0.0, -0.25])
    for_case = []
    for anti in (False, True):
        s = solver(["head", "foot_l", "foot_r"], IKParams(anti_buckling=anti))
        s.goals.set(c.body("head"), pos=goal)
        s.goals.set(c.body("foot_l"), pos=c.body_rest_pos[c.body("foot_l")])
        s.goals.set(c.body("foot_r"), pos=c.body_rest_pos[c.body("foot_r")])
        s.solve(rp, rr)
        for_case.append(("anti-buckling " + ("on" if anti else "off"), s))
    cases.append(("buckling", for_case))
    return cases


def render_hard_cases(creature, out_dir: str, width: int = 1280, height: int = 720) -> list[str]:
    from authoring.render import render_png

    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for name, solvers in hard_cases(creature):
        scene = sc.Scene()
        front = name == "conflict"  # arms spread sideways: look from the front
        for k, (label, s) in enumerate(solvers):
            ik_scene(s, offset=(0.0, (4.0 if front else 1.6) * k, 0.0), label=label, scene=scene)
        scene.view_azimuth = math.radians(10.0 if front else -70.0)
        path = os.path.join(out_dir, f"ik_{name}.png")
        render_png(scene, path, width, height)
        paths.append(path)
    return paths


def main(argv=None) -> int:
    import engine

    ap = argparse.ArgumentParser(description="Render the Particle IK hard cases with debug overlays.")
    ap.add_argument("--creature", default=os.path.join("creatures", "humanoid.yaml"))
    ap.add_argument("--out", default=".notes")
    args = ap.parse_args(argv)
    for p in render_hard_cases(engine.load_creature(args.creature), args.out):
        print(p)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
