"""The grid: every creature x every animation and variant, judged, serially or on Dask.

``run_grid(sources, animation_paths)`` plays and judges every cell of every creature
source (a library file, a random seed, any creature file or skeleton) and returns a
``GridRun``: the cells as JSON-ready dicts, the summary, and what the task functions
returned besides (pictures, for the report). The unit of work is one creature: its cells
share the creature's constants and the bindings, and a task of about a second keeps
Dask's per-task cost (~1.5 ms) negligible.

Where it runs:
- ``workers=0``, or Dask not installed: in this process, one creature after the other;
- otherwise on Dask (``distributed``): a ``LocalCluster`` of ``workers`` processes (default:
  one per core) with one thread each (Python holds the GIL; processes keep the cores
  busy), or the running scheduler at ``scheduler`` (or ``$DASK_SCHEDULER_ADDRESS``). Workers
  import Menagerie and load numba's compiled kernels from the checkout's cache (compiled
  once per machine). Work is sent with ``client.map`` and gathered with ``as_completed``,
  so a finished creature is counted (and the progress bar moves) as soon as it is done.

A cell that raises is a failed cell with its traceback; a creature that cannot be loaded
is one failed row naming the error; neither stops the run. Ctrl-C cancels what is left
and returns what is done (``GridRun.interrupted``).
"""

from __future__ import annotations

import logging
import os
import platform
import time
import traceback
from dataclasses import dataclass, field

import numpy as np

from engine.validation import thresholds as T

#: Worst cells listed in the summary.
WORST_LISTED = 25


@dataclass(frozen=True)
class Source:
    """Where a creature comes from: ``kind`` is ``file`` (``ref`` a path: a library or other
    creature file, a BVH skeleton, ...) or ``random`` (``ref`` a seed)."""

    kind: str
    ref: str
    label: str = ""

    @property
    def name(self) -> str:
        return self.label or (f"random_{self.ref}" if self.kind == "random" else
                              os.path.splitext(os.path.basename(self.ref))[0])

    def load(self):
        if self.kind == "random":
            from engine.model import build_creature
            from engine.model.random import random_creature_def

            return build_creature(random_creature_def(int(self.ref)))
        from engine.io.sources import creature_from_file

        return creature_from_file(self.ref)

    def reproduce(self) -> str:
        """The grid arguments that select this creature alone."""
        if self.kind == "random":
            return f"--random 1 --first-seed {self.ref}"
        return f"--creatures {self.ref}"


def library_sources() -> list[Source]:
    from engine.paths import LIBRARY_CREATURES

    return [Source("file", os.path.relpath(p) if _under_cwd(p) else str(p))
            for p in sorted(LIBRARY_CREATURES.glob("*.yaml"))]


def random_sources(count: int, first_seed: int = 0) -> list[Source]:
    return [Source("random", str(s)) for s in range(first_seed, first_seed + count)]


def file_sources(paths) -> list[Source]:
    """Creature sources from files, directories (every creature file or skeleton in a
    directory, sorted) and library names; raises naming a path that does not exist or
    holds none."""
    from engine.errors import MenagerieError
    from engine.io.sources import is_creature_source

    out = []
    for p in paths:
        p = os.fspath(p)
        if os.path.isdir(p):
            found = sorted(os.path.join(p, f) for f in os.listdir(p) if is_creature_source(f))
            if not found:
                raise MenagerieError(f"{p}: no creature files or skeletons in this directory")
            out += [Source("file", f) for f in found]
        elif os.path.isfile(p):
            if not is_creature_source(p):
                from engine.io.sources import CREATURE_SUFFIXES

                kinds = ", ".join(sorted(CREATURE_SUFFIXES))
                raise MenagerieError(f"{p}: not a creature source (known kinds: {kinds})")
            out.append(Source("file", p))
        elif not os.path.splitext(p)[1] and os.sep not in p:
            from engine.paths import creature_path

            out.append(Source("file", creature_path(p)))   # a library name (humanoid)
        else:
            raise MenagerieError(f"{p}: no such file or directory")
    return out


def library_animation_paths() -> list[str]:
    from engine.paths import LIBRARY_ANIMATIONS

    return [os.path.relpath(p) if _under_cwd(p) else str(p) for p in sorted(LIBRARY_ANIMATIONS.glob("*.yaml"))]


def animation_paths(paths) -> list[str]:
    """Animation files from files and directories (``*.yaml``, sorted)."""
    from engine.errors import MenagerieError

    out = []
    for p in paths:
        p = os.fspath(p)
        if os.path.isdir(p):
            found = sorted(os.path.join(p, f) for f in os.listdir(p) if f.endswith((".yaml", ".yml")))
            if not found:
                raise MenagerieError(f"{p}: no animation files (*.yaml) in this directory")
            out += found
        elif os.path.isfile(p):
            out.append(p)
        elif not os.path.splitext(p)[1] and os.sep not in p:
            from engine.paths import creature_path

            out.append(Source("file", creature_path(p)))   # a library name (humanoid)
        else:
            raise MenagerieError(f"{p}: no such file or directory")
    return out


def _under_cwd(p) -> bool:
    try:
        return not os.path.relpath(p).startswith("..")
    except ValueError:
        return False


# -- the task --------------------------------------------------------------------------

_ANIMATIONS: dict = {}


def _animations(paths: tuple[str, ...]):
    """The animations of ``paths``, loaded once per process (a worker runs many tasks)."""
    from engine.anim import load_animation

    key = tuple(paths)
    hit = _ANIMATIONS.get(key)
    if hit is None:
        hit = [load_animation(p) for p in paths]
        _ANIMATIONS.clear()
        _ANIMATIONS[key] = hit
    return hit


def judge_source(source: Source, paths: tuple[str, ...], variant: str | None = None, keep_poses: bool = False):
    """Load one creature and judge its cells: (results as CellResult objects, the creature,
    seconds). A creature that fails to load gives one failed ``CellResult``."""
    t0 = time.perf_counter()
    # One numba thread: the grid's parallelism is its worker processes (one per core); a
    # crowd's parallel IK inside each would oversubscribe the cores and wait on descheduled
    # threads (measured: 23 ms per parallel solve call under load, against 0.1 ms serial).
    import numba

    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        return _judge(source, paths, variant, keep_poses, t0)
    finally:
        numba.set_num_threads(threads)


def _judge(source: Source, paths: tuple[str, ...], variant: str | None, keep_poses: bool, t0: float):
    from engine.validation.cell import CellResult, run_creature

    try:
        creature = source.load()
    except Exception as exc:  # noqa: BLE001 - reported as a failed row
        return [CellResult(source.name, "(load)", -1, "", T.FAIL, reason=f"{type(exc).__name__}: {exc}",
                           error=traceback.format_exc(), source=source.ref)], None, time.perf_counter() - t0
    anims = _animations(paths)
    results = run_creature(creature, anims, keep_poses=keep_poses, variant=variant)
    for r in results:
        r.source = source.ref
    return results, creature, time.perf_counter() - t0


def cell_task(source: Source, paths: tuple[str, ...], variant: str | None = None) -> dict:
    """The plain task (no pictures): one creature's cells as JSON dicts."""
    results, _, seconds = judge_source(source, paths, variant)
    return {"source": source, "cells": [_cell_json(r, source) for r in results], "seconds": seconds, "files": {}}


def ik_task(task, ik, source: Source, paths: tuple[str, ...], variant: str | None = None) -> dict:
    """``task`` with every character it makes solving with the IKParams ``ik`` (the grid's
    ``--ik NAME=VALUE``; ``functools.partial(ik_task, task, ik)`` is a task too)."""
    from engine.ik.plan import ik_defaults

    with ik_defaults(ik):
        return task(source, paths, variant)


def _cell_json(result, source: Source) -> dict:
    d = result.to_json()
    d["source_kind"] = source.kind
    d["reproduce"] = reproduce_command(source, result)
    d["creature_args"] = source.reproduce()     # the same creature for other tools (menagerie author)
    return d


def reproduce_command(source: Source, result) -> str:
    """The one command that plays this cell again."""
    parts = ["menagerie grid", source.reproduce()]
    if result.animation_path:
        parts.append(f"--animations {result.animation_path}")
    if result.variant_id:
        parts.append(f"--variant {result.variant_id}")
    from engine.ik.plan import default_params, params_to_strings

    ik = params_to_strings(default_params())
    if ik:
        parts.append("--ik " + " ".join(ik))
    parts.append("--out out/grid-cell --force --workers 0")
    return " ".join(parts)


# -- running ---------------------------------------------------------------------------


@dataclass
class GridRun:
    """What a grid run produced (see ``run_grid``)."""

    cells: list = field(default_factory=list)       # JSON dicts, one per cell
    files: dict = field(default_factory=dict)       # relative path -> bytes the tasks made
    seconds: float = 0.0
    creatures: int = 0
    interrupted: bool = False
    workers: int = 0
    scheduler: str = "serial"
    task_seconds: list = field(default_factory=list)


def dask_available() -> bool:
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


def run_grid(sources: list[Source], paths: list[str], *, task=cell_task, workers: int | None = None,
             scheduler: str | None = None, variant: str | None = None, progress: bool = True,
             on_task=None) -> GridRun:
    """Judge every cell of ``sources`` x the animations at ``paths`` (see the module
    docstring). ``task(source, paths, variant)`` returns ``{"cells": [...], "files": {...}}``
    (``cell_task``, or one that also renders pictures); ``on_task(done, total, task_result)``
    is called as each creature finishes."""
    paths = tuple(paths)
    run = GridRun()
    t0 = time.perf_counter()
    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") or None
    serial = workers == 0 or (address is None and not dask_available())
    bar = _progress(len(sources), progress)
    try:
        if serial:
            run.scheduler, run.workers = "serial", 1
            for k, src in enumerate(sources):
                out = task(src, paths, variant)
                _collect(run, out)
                _advance(bar, run)
                if on_task:
                    on_task(k + 1, len(sources), out)
        else:
            _run_dask(run, sources, paths, task, workers, address, variant, bar, on_task)
    except KeyboardInterrupt:
        run.interrupted = True
    finally:
        bar.close()
    run.seconds = time.perf_counter() - t0
    run.creatures = len({c["source"] for c in run.cells})
    return run


def _collect(run: GridRun, out: dict) -> None:
    run.cells.extend(out["cells"])
    run.files.update(out.get("files") or {})
    run.task_seconds.append(float(out.get("seconds", 0.0)))


def _run_dask(run, sources, paths, task, workers, address, variant, bar, on_task) -> None:
    from distributed import Client, LocalCluster, as_completed

    cluster = None
    if address:
        client = Client(address)
        run.scheduler = address
    else:
        n = workers or os.cpu_count() or 1
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.CRITICAL)
        client = Client(cluster)
        run.scheduler = "LocalCluster"
    try:
        run.workers = len(client.scheduler_info().get("workers", {})) or (workers or 0)
        futures = client.map(task, sources, [paths] * len(sources), [variant] * len(sources), pure=False)
        done = 0
        try:
            for fut, out in as_completed(futures, with_results=True, raise_errors=False):
                done += 1
                if isinstance(out, BaseException):
                    src = sources[futures.index(fut)]
                    out = {"source": src, "files": {}, "seconds": 0.0, "cells": [{
                        "creature": src.name, "animation": "(task)", "variant": -1, "variant_id": "",
                        "status": T.FAIL, "reason": f"the task failed: {type(out).__name__}: {out}",
                        "error": "".join(traceback.format_exception(out)), "source": src.ref,
                        "source_kind": src.kind, "metrics": {}, "known": [], "plays": 0, "frames": 0,
                        "ms_per_tick": 0.0, "animation_path": "", "reproduce": ""}]}
                _collect(run, out)
                _advance(bar, run)
                if on_task:
                    on_task(done, len(sources), out)
        except KeyboardInterrupt:
            client.cancel(futures)
            raise
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _advance(bar, run: GridRun) -> None:
    bar.update(1)
    bar.set_postfix_str(f"{len(run.cells)} cells", refresh=False)


class _NoBar:
    def update(self, n: int) -> None:
        pass

    def set_postfix_str(self, s: str, refresh: bool = True) -> None:
        pass

    def close(self) -> None:
        pass


def _progress(total: int, enabled: bool):
    if not enabled:
        return _NoBar()
    try:
        from tqdm import tqdm
    except ImportError:
        return _NoBar()
    return tqdm(total=total, unit="creature", desc="grid", smoothing=0.05)


# -- the summary ------------------------------------------------------------------------


def severity(cell: dict) -> float:
    """How bad a cell is, for ordering: its worst metric's value over that metric's fail
    threshold (errors and non-finite output first)."""
    if cell["status"] == T.FAIL and ("error" in cell or not cell.get("metrics")):
        return 1e9
    w = cell.get("worst")
    if not w:
        return 0.0
    t = T.BY_METRIC.get(w["metric"])
    return float(w["value"]) / t.fail if t is not None and t.fail else 0.0


POPS = ("rotation_pop", "start_pop", "end_pop")


def is_flip(cell: dict) -> bool:
    """A body turned past the fail line in one frame (mid-clip, fading in or out): the
    summary's ``flips``."""
    return any(_metric_value(cell, m) > T.BY_METRIC[m].fail for m in POPS)


def flip_kind(cell: dict) -> str:
    """"twist" when the cell's worst flip is mostly its body spinning about its bone (the
    rebuild's reference near its singular chord), "swing" when the bone itself jumped (the
    solver took another solution); the continuity measures' ``swing``/``twist`` detail."""
    worst = max((cell.get("metrics", {}).get(m) or {} for m in POPS), key=lambda m: m.get("value") or 0.0)
    d = worst.get("detail") or {}
    return "twist" if float(d.get("twist", 0.0)) > float(d.get("swing", 0.0)) else "swing"


def summarize(cells: list[dict], seconds: float = 0.0) -> dict:
    """The summary object of ``grid.json``."""
    n = len(cells)
    na = sum(c["status"] == T.NA for c in cells)
    counts = {s: sum(c["status"] == s for c in cells) for s in (T.PASS, T.WARN, T.FAIL)}
    plays = n - na
    flips = [c for c in cells if is_flip(c)]
    nonfinite = [c for c in cells if "finite" in c.get("metrics", {}) or "non-finite" in c.get("reason", "")]
    failing = sorted((c for c in cells if c["status"] == T.FAIL), key=severity, reverse=True)
    known = [c for c in failing if c.get("known") and all(
        m.get("known") for m in c["metrics"].values() if m.get("verdict") == T.FAIL)]
    fail_by_metric: dict[str, int] = {}
    for c in cells:
        for k, m in c.get("metrics", {}).items():
            if m.get("verdict") == T.FAIL:
                fail_by_metric[k] = fail_by_metric.get(k, 0) + 1
    return {
        "cells": n, "plays": plays, "not_applicable": na, "pass": counts[T.PASS], "warn": counts[T.WARN],
        "fail": counts[T.FAIL], "pass_rate": round(counts[T.PASS] / plays, 6) if plays else 0.0,
        "pass_or_warn_rate": round((counts[T.PASS] + counts[T.WARN]) / plays, 6) if plays else 0.0,
        "known_fail": len(known), "flips": len(flips),
        "flips_twist": sum(flip_kind(c) == "twist" for c in flips), "nonfinite": len(nonfinite),
        "fail_by_metric": dict(sorted(fail_by_metric.items(), key=lambda kv: -kv[1])),
        "worst": [{"creature": c["creature"], "animation": c["animation"], "variant_id": c["variant_id"],
                   "reason": c["reason"], "severity": round(severity(c), 3)} for c in failing[:WORST_LISTED]],
        "seconds": round(seconds, 2), "cells_per_second": round(n / seconds, 2) if seconds > 0 else 0.0,
    }


def _metric_value(cell: dict, name: str) -> float:
    m = cell.get("metrics", {}).get(name)
    return float(m["value"]) if m and m.get("value") is not None else 0.0


def rates(cells: list[dict], key: str) -> dict:
    """Pass rate (pass / plays) per value of ``key`` (``creature`` or ``animation``)."""
    out: dict = {}
    for c in cells:
        if c["status"] == T.NA:
            continue
        e = out.setdefault(c[key], [0, 0])
        e[1] += 1
        e[0] += c["status"] == T.PASS
    return {k: round(p / n, 4) for k, (p, n) in sorted(out.items())}


def compare(previous: list[dict], current: list[dict]) -> dict:
    """What changed since a previous run's cells: regressions first (a cell whose status
    got worse), then improvements, then cells that appeared or went away."""
    key = lambda c: (c["creature"], c["animation"], c.get("variant_id", ""))  # noqa: E731
    rank = {T.NA: -1, T.PASS: 0, T.WARN: 1, T.FAIL: 2}
    old = {key(c): c for c in previous}
    new = {key(c): c for c in current}
    regressed, improved = [], []
    for k, c in new.items():
        o = old.get(k)
        if o is None:
            continue
        a, b = rank.get(o["status"], 0), rank.get(c["status"], 0)
        entry = {"creature": k[0], "animation": k[1], "variant_id": k[2], "was": o["status"], "now": c["status"],
                 "reason": c.get("reason", ""), "was_reason": o.get("reason", "")}
        if b > a:
            regressed.append(entry)
        elif b < a:
            improved.append(entry)
    return {"regressed": regressed, "improved": improved,
            "added": [list(k) for k in new if k not in old], "removed": [list(k) for k in old if k not in new],
            "pass_rate_was": summarize(previous)["pass_rate"], "pass_rate_now": summarize(current)["pass_rate"]}


def run_metadata() -> dict:
    """Where and with what a run was made (for grid.json)."""
    import numba

    meta = {"date": time.strftime("%Y-%m-%d %H:%M:%S"), "python": platform.python_version(),
            "numpy": np.__version__, "numba": numba.__version__, "machine": platform.machine(),
            "cores": os.cpu_count()}
    try:
        import subprocess

        from engine.paths import REPO_ROOT

        meta["commit"] = subprocess.run(["git", "-C", str(REPO_ROOT), "rev-parse", "--short", "HEAD"],
                                        capture_output=True, text=True, timeout=5).stdout.strip()
    except Exception:  # noqa: BLE001 - metadata only
        pass
    return meta
