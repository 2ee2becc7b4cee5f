"""Milliseconds per character per frame: ``Character.tick`` alone and in a ``Crowd``.

    .venv/bin/python benchmarks/tick.py [--frames 2000] [--crowd 1000] [--quick]

Prints a table and ends with one JSON line: bodies, channels, single_ms (median tick of
one 25-body humanoid playing the 12-channel ``perform`` animation), crowd_size,
crowd_ms_per_character (median crowd tick / crowd size; big crowds sample and solve on
all cores), crowd_serial_ms_per_character (the same crowd kept on one thread),
crowd_busy_core_ms_per_character (the crowd free to use all cores while a second process
keeps one busy: it must not exceed the serial figure),
mixed_crowd_ms_per_character (``--crowd`` characters of eight library creatures, varied
animations, half of them walking, one thread), mixed_walking_ms_per_character (the
same, all walking), crowd_vs_alone_max_m (largest pose difference between three crowd members and the same
characters ticked alone), threads (numba's thread count) and threading_layer, stages
(median ms per stage, single character), scaling (single tick median for 25, 51, 80,
120 and 165 bodies), scaling_fit (a least-squares line through them: ms per body,
intercept, worst relative distance of a point from the line), cold_start_s (first tick
in a fresh process with an empty numba cache; ``benchmarks/startup.py`` has the detail) and
warm_start_s (the same with the cache filled). The paper's figure: 0.2 ms per 25-body
character frame on a 1.7 GHz Pentium-M. The machine is shared: note ``uptime``'s load
with the figures (a core busy elsewhere costs the parallel crowd most).
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

import engine  # noqa: E402
from engine import runtime as R  # noqa: E402
from engine.anim import load_animation  # noqa: E402

DT = 1 / 60
#: The clock of the per-frame figures: wall time (default), or this process's CPU time
#: (``--cpu``: on a machine shared with other work, what a frame costs the core it runs on;
#: only meaningful for the one-thread figures).
CLOCK = [time.perf_counter]
FIRST_TICK = """
import time, sys
t0 = time.perf_counter()
sys.path.insert(0, {root!r})
import engine
from engine.anim import load_animation
c = engine.load_creature({root!r} + '/creatures/humanoid.yaml')
ch = engine.Character(c)
ch.play(load_animation({root!r} + '/animations/perform.yaml'))
ch.tick(1 / 60)
print(time.perf_counter() - t0)
"""


def start_time(cache_dir: str) -> float:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    out = subprocess.run([sys.executable, "-c", FIRST_TICK.format(root=ROOT)], env=env, capture_output=True,
                         text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


def dense_creature(nbody: int, tmp: str):
    """A capture-style human (``benchmarks/dense_skeletons.py``: fingers, toes, a face; 108
    bodies) with three-joint hair strands on the head until it has ``nbody`` bodies, as
    game rigs carry for secondary motion (the strands are left to the jiggle stage)."""
    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    from dense_skeletons import Joint, bvh_text, human

    from engine.io.bvh_creature import creature_def_from_bvh
    from engine.model import build_creature

    root = human("plain", 170.0, 1.0, np.random.default_rng(0), True, True)
    head = root.children[0].children[0].children[0].children[0].children[0]
    assert head.name == "Head", head.name
    k = 0
    while root.count() < nbody:
        left = nbody - root.count()
        a = 2.0 * np.pi * k / 12.0
        strand = None
        for n in range(min(3, left), 0, -1):
            strand = Joint(f"Hair{k}_{n}", (0.0, -2.5, 0.0), [strand] if strand else [])
        strand.offset = np.array([6.0 * np.cos(a), 14.0 - 0.5 * (k // 12), 6.0 * np.sin(a)])
        head.children.append(strand)
        k += 1
    path = os.path.join(tmp, f"dense_{nbody}.bvh")
    with open(path, "w") as f:
        f.write(bvh_text(root))
    return build_creature(creature_def_from_bvh(path, name=f"dense_{nbody}"))


def scaling_creatures() -> list:
    """Creatures of 25, 51, 80 bodies (library) and 120, 165 (capture-style skeletons)."""
    out = [engine.load_creature(os.path.join(ROOT, "creatures", f"{n}.yaml"))
           for n in ("humanoid", "scorpion", "spikebeast")]
    with tempfile.TemporaryDirectory() as tmp:
        out += [dense_creature(n, tmp) for n in (120, 165)]
    return out


STAGE_NAMES = ("prev_pose", "player", "sample_specialize", "blend", "gait_stand", "ik", "jiggle_output")


def timed_tick(ch: R.Character, times: dict[str, list[float]]) -> None:
    """One tick, stage by stage, as ``Character.tick`` runs them (every call it makes, so
    the stages add up to the tick)."""
    pc = CLOCK[0]
    s, r = ch._stack, ch._row
    t0 = pc()
    np.copyto(ch._prev_world_pos, ch.world_positions)
    np.copyto(ch._prev_world_rot, ch.world_rotations)
    s.last_dt = DT
    t1 = pc()
    ch.player.advance(DT)
    t2 = pc()
    R._sample_character(ch)
    t3 = pc()
    R._blend_stack(s, ch.player)
    t4 = pc()
    if ch.gait is not None:
        R._gait_character(ch, DT)
    else:
        R._stand_rows(s, R._row(r))     # standing: the feet the clips leave free held on the ground
    t5 = pc()
    R._solve_character(ch)
    if ch.gait is not None:
        ch.gait.observe(s.char_pos[r], s.char_rot[r])
    t6 = pc()
    R._output_stack(s, ch.jiggle_rig, DT, True)
    t7 = pc()
    ch._frame += 1
    for name, a, b in zip(STAGE_NAMES, (t0, t1, t2, t3, t4, t5, t6), (t1, t2, t3, t4, t5, t6, t7), strict=True):
        times[name].append((b - a) * 1e3)


GROUP_STAGES = ("prev_pose", "player", "sample_specialize", "blend", "gait", "stand", "ik", "observe",
                "jiggle_output")


def timed_group_tick(g, times: dict[str, list[float]]) -> None:
    """One tick of a crowd group (``engine.runtime._Group.tick``), stage by stage."""
    pc = CLOCK[0]
    s = g.stack
    ref = g.members[0]
    t0 = pc()
    np.copyto(s.prev_world_pos, s.world_pos)
    np.copyto(s.prev_world_rot, s.world_rot)
    s.last_dt = DT
    t1 = pc()
    g._player(DT)
    t2 = pc()
    g._sample()
    t3 = pc()
    R._blend_stack(s, ref.player)
    t4 = pc()
    gait = g._gait_batch()
    if gait is not None:
        gait.step(DT, gait.stack, gait.rows, gait.crows, R._gait_args(s), gait.call)
    t5 = pc()
    R._stand_rows(s, s.rows)
    t6 = pc()
    g._solve(True)
    t7 = pc()
    if gait is not None:
        gait.observe.call()
    t8 = pc()
    R._output_stack(s, ref.jiggle_rig, DT, True)
    t9 = pc()
    ts = (t0, t1, t2, t3, t4, t5, t6, t7, t8, t9)
    for k, name in enumerate(GROUP_STAGES):
        times[name][-1] += (ts[k + 1] - ts[k]) * 1e3


def single(creature, anim, frames: int) -> tuple[float, dict[str, float]]:
    ch = engine.Character(creature)
    ch.play(anim)
    for _ in range(200):
        ch.tick(DT)
    ticks = []
    for _ in range(frames):
        t = CLOCK[0]()
        ch.tick(DT)
        ticks.append(CLOCK[0]() - t)
    stages: dict[str, list[float]] = {k: [] for k in STAGE_NAMES}
    for _ in range(frames):
        timed_tick(ch, stages)
    return float(np.median(ticks) * 1e3), {k: float(np.median(v)) for k, v in stages.items()}


def crowd(creature, anim, n: int, frames: int) -> tuple[float, float]:
    """Median ms per character of a crowd tick, and the largest pose difference (m)
    between members 0-2 and the same characters ticked alone."""
    nvar = engine.bind(anim, creature).nvariant

    def make(k):
        ch = engine.Character(creature, position=(k % 40, k // 40, 0))
        ch.play(anim, variant=k % nvar, speed=0.8 + 0.4 * (k / n))
        return ch

    chars = [make(k) for k in range(n)]
    alone = [make(k) for k in range(3)]
    group = engine.Crowd(chars)
    ticks = []
    warm = 5 + 2 * R._ThreadChoice.PROBE     # and the frames that choose serial or parallel
    for _ in range(warm + frames):
        t = CLOCK[0]()
        group.tick(DT)
        ticks.append(CLOCK[0]() - t)
        for a in alone:
            a.tick(DT)
    diff = max(float(np.abs(a.world_positions - c.world_positions).max())
               for a, c in zip(alone, chars[:3], strict=True))
    return float(np.median(ticks[warm:]) * 1e3 / n), diff


def busy_core_crowd(creature, anim, n: int, frames: int) -> float:
    """``crowd`` (all threads allowed) while a second process keeps a core busy, as a
    game's other threads do: the crowd must then choose serial (``_ThreadChoice``)."""
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        time.sleep(0.2)
        return crowd(creature, anim, n, frames)[0]
    finally:
        busy.kill()
        busy.wait()


MIXED = ("humanoid", "dog", "spider", "snake", "hexapod", "trex", "octopus", "centipede")


def mixed_characters(n: int, walking: float) -> list:
    """``n`` characters of the eight ``MIXED`` library creatures, each playing one of the
    library animations its body can play (variants and speeds varied, targets set), and
    the share ``walking`` of them locomoting (gait) with it."""
    from engine.anim.binding import branch_failures

    anims = [load_animation(p) for p in sorted(glob.glob(os.path.join(ROOT, "animations", "*.yaml")))]
    creatures = [engine.load_creature(os.path.join(ROOT, "creatures", f"{m}.yaml")) for m in MIXED]
    playable = [[a for a in anims if not branch_failures(a, c)] for c in creatures]
    chars = []
    for k in range(n):
        c = creatures[k % len(creatures)]
        plist = playable[k % len(creatures)]
        a = plist[(k // len(creatures)) % len(plist)]
        ch = engine.Character(c, position=(k % 40, k // 40, 0), heading=0.1 * k)
        h = c.height
        for name in a.target_names:
            ch.set_target(name, (0.7 * h, 0.25 * h, 0.7 * h))
        ch.play(a, variant=k % ch.binding(a).nvariant, speed=0.8 + 0.4 * ((k * 37) % n) / n)
        if (k * 0.618034) % 1.0 < walking:
            ch.locomote(velocity=(0.5 * h, 0.0), turn_rate=0.2 * ((k % 5) - 2))
        chars.append(ch)
    return chars


def mixed_crowd(n: int, walking: float, frames: int, stages: bool = False):
    """Median ms per character of a crowd tick on one thread, as a game has it
    (``mixed_characters``); with ``stages``, also the median ms per character of each
    stage (``GROUP_STAGES``, summed over the creature groups; they add up to the tick)."""
    group = engine.Crowd(mixed_characters(n, walking))
    parallel_min = R.PARALLEL_MIN_ROWS
    R.PARALLEL_MIN_ROWS = 1 << 30   # one thread
    try:
        ticks = []
        for _ in range(5 + frames):
            t = CLOCK[0]()
            group.tick(DT)
            ticks.append(CLOCK[0]() - t)
        per_stage: dict[str, list[float]] = {k: [] for k in GROUP_STAGES}
        if stages:
            for _ in range(frames):
                for v in per_stage.values():
                    v.append(0.0)
                for g in group._groups:
                    timed_group_tick(g, per_stage)
    finally:
        R.PARALLEL_MIN_ROWS = parallel_min
    ms = float(np.median(ticks[5:]) * 1e3 / n)
    if not stages:
        return ms
    return ms, {k: float(np.median(v)) / n for k, v in per_stage.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=2000)
    ap.add_argument("--crowd", type=int, default=1000)
    ap.add_argument("--crowd-frames", type=int, default=20)
    ap.add_argument("--quick", action="store_true", help="fewer frames, no start-up measurement")
    ap.add_argument("--cpu", action="store_true", help="time frames by this process's CPU time, not wall time")
    args = ap.parse_args()
    if args.cpu:
        CLOCK[0] = time.process_time
    if args.quick:
        args.frames, args.crowd_frames = 300, 5

    anim = load_animation(os.path.join(ROOT, "animations", "perform.yaml"))
    human = engine.load_creature(os.path.join(ROOT, "creatures", "humanoid.yaml"))
    single_ms, stages = single(human, anim, args.frames)
    scaling = {}
    for c in scaling_creatures():
        scaling[str(c.nbody)] = single(c, anim, max(args.frames // 4, 100))[0]
    crowd_ms, crowd_diff = crowd(human, anim, args.crowd, args.crowd_frames)
    parallel_min = R.PARALLEL_MIN_ROWS
    R.PARALLEL_MIN_ROWS = 1 << 30   # the same crowd on one thread
    crowd_serial_ms = crowd(human, anim, args.crowd, args.crowd_frames)[0]
    R.PARALLEL_MIN_ROWS = parallel_min
    busy_ms = busy_core_crowd(human, anim, args.crowd, args.crowd_frames)
    mixed_ms, mixed_stages = mixed_crowd(args.crowd, 0.5, args.crowd_frames, stages=True)
    mixed_walk_ms = mixed_crowd(args.crowd, 1.0, args.crowd_frames)
    cold = warm = None
    if not args.quick:
        with tempfile.TemporaryDirectory() as cache:
            cold = start_time(cache)
            warm = start_time(cache)

    print(f"{'figure':<34}{'value':>12}")
    print("-" * 46)
    print(f"{'bodies':<34}{human.nbody:>12}")
    print(f"{'channels':<34}{anim.nchannel:>12}")
    print(f"{'single tick, ms (median)':<34}{single_ms:>12.4f}")
    for k, v in stages.items():
        print(f"{'  stage ' + k + ', ms':<34}{v:>12.4f}")
    print(f"{'  sum of the stages, ms':<34}{sum(stages.values()):>12.4f}")
    for k, v in scaling.items():
        print(f"{'  ' + k + ' bodies, ms':<34}{v:>12.4f}")
    print(f"{'crowd of ' + str(args.crowd) + ', ms per character':<34}{crowd_ms:>12.4f}")
    print(f"{'  on one thread, ms per character':<34}{crowd_serial_ms:>12.4f}")
    print(f"{'  other core busy, ms per char':<34}{busy_ms:>12.4f}")
    print(f"{'  busy / serial':<34}{busy_ms / crowd_serial_ms:>12.2f}")
    print(f"{'  crowd vs alone, max m':<34}{crowd_diff:>12.2e}")
    print(f"{'mixed crowd, half walking, ms/ch':<34}{mixed_ms:>12.4f}")
    for k, v in mixed_stages.items():
        print(f"{'  stage ' + k + ', ms/ch':<34}{v:>12.5f}")
    print(f"{'  sum of the stages, ms/ch':<34}{sum(mixed_stages.values()):>12.5f}")
    print(f"{'  mixed / uniform (one thread)':<34}{mixed_ms / crowd_serial_ms:>12.2f}")
    print(f"{'mixed crowd, all walking, ms/ch':<34}{mixed_walk_ms:>12.4f}")
    print(f"{'  threads (' + numba.threading_layer() + ')':<34}{numba.get_num_threads():>12}")
    if cold is not None:
        print(f"{'cold start (empty numba cache), s':<34}{cold:>12.2f}")
        print(f"{'warm start (numba cache), s':<34}{warm:>12.2f}")
    nb = np.array([float(k) for k in scaling])
    ms = np.array(list(scaling.values()))
    slope, icept = np.polyfit(nb, ms, 1)
    fit_dev = float(np.max(np.abs(ms - (slope * nb + icept)) / ms))
    print(f"{'  linear fit, us per body':<34}{slope * 1e3:>12.3f}")
    print(f"{'  intercept, ms':<34}{icept:>12.4f}")
    print(f"{'  worst distance from the line':<34}{fit_dev:>12.1%}")
    print(json.dumps({"bodies": human.nbody, "channels": anim.nchannel, "single_ms": round(single_ms, 5),
                      "crowd_size": args.crowd, "crowd_ms_per_character": round(crowd_ms, 5),
                      "crowd_serial_ms_per_character": round(crowd_serial_ms, 5),
                      "crowd_busy_core_ms_per_character": round(busy_ms, 5),
                      "mixed_crowd_ms_per_character": round(mixed_ms, 5),
                      "mixed_walking_ms_per_character": round(mixed_walk_ms, 5),
                      "mixed_stages_ms_per_character": {k: round(v, 6) for k, v in mixed_stages.items()},
                      "mixed_vs_uniform": round(mixed_ms / crowd_serial_ms, 2),
                      "crowd_vs_alone_max_m": crowd_diff, "threads": numba.get_num_threads(),
                      "threading_layer": numba.threading_layer(),
                      "stages": {k: round(v, 5) for k, v in stages.items()},
                      "scaling_ms_by_bodies": {k: round(v, 5) for k, v in scaling.items()},
                      "scaling_fit": {"us_per_body": round(slope * 1e3, 4), "intercept_ms": round(icept, 5),
                                      "worst_rel_dev": round(fit_dev, 3)},
                      "cold_start_s": None if cold is None else round(cold, 2),
                      "warm_start_s": None if warm is None else round(warm, 2),
                      "paper_ms": 0.2}))


if __name__ == "__main__":
    main()
