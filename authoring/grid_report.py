"""``menagerie grid``: the validation grid's command and its report (pictures, plots, HTML).

The judging is ``engine.validation`` (no window, no OpenGL); this module adds what a
person looks at, and the command line:

    menagerie grid [--library] [--random N --first-seed S] [--creatures PATH...]
                   [--animations PATH...] [--variant ID] [--out DIR] [--scheduler ADDRESS]
                   [--workers N] [--ik NAME=VALUE...] [--compare PREVIOUS.json] [--no-pictures] [--force]

writes into DIR (default ``out/grid``):

- ``grid.json``: the run (metadata, thresholds), every cell with its metrics, the
  ``summary`` (cells, plays, not_applicable, pass, warn, fail, pass_rate = pass / plays,
  the worst cells, ...) and, when a previous run is known, ``comparison`` (regressions
  first);
- ``grid.csv``: one row per cell, a column per metric (the testers' spreadsheet);
- ``index.html``: the matrix of creatures x animations, each cell a thumbnail of the pose
  at its worst frame framed in the colour of its verdict, pass rates per row, per column
  and overall; a page per failing cell (``cells/``) with a filmstrip, plots of the failing
  metrics over time and the one command that reproduces it.

Pictures are rendered where the cells are played (each Dask worker keeps an offscreen
renderer), and travel back as PNG bytes, so a remote cluster needs no shared disk.
"""

from __future__ import annotations

import argparse
import csv
import functools
import html
import io
import json
import os
import re
import shutil
import sys
import time

import numpy as np

from engine.errors import MenagerieError
from engine.validation import grid as G
from engine.validation import thresholds as T

THUMB = 64            # thumbnail side, px
FILM = 150            # filmstrip frame side, px
PLOTTED = 4           # failing metrics plotted per cell page
#: Failing cells of one creature that get a filmstrip and plots (its flips, and its worst up to six): a
#: matplotlib figure costs ~0.1-0.3 s, and a creature whose every cell fails should not
#: cost a minute of pictures; the other failing cells' pages carry the numbers and the
#: command that reproduces them.
PICTURED = 6

# -- pictures (in the worker) ---------------------------------------------------------------

_RENDERER = None


def _renderer():
    """One offscreen renderer per process (a Dask worker keeps it for all its tasks)."""
    global _RENDERER
    if _RENDERER is None:
        from authoring import render as rd

        rd.load_pyglet(headless=True)
        _RENDERER = rd.Renderer(FILM, FILM, samples=4)
    return _RENDERER


def _draw_pose(creature, pos, rot, size: int, *, grid: bool = True) -> np.ndarray:
    from authoring import scene as sc

    r = _renderer()
    if (r.width, r.height) != (size, size):
        r.resize(size, size)
    s = sc.Scene(show_labels=False, show_grid=grid)
    a = sc.Actor(creature)
    a.set_pose(pos, rot)
    s.add(a)
    r.draw(s)
    return r.read_pixels().copy()


def _png(rgb: np.ndarray) -> bytes:
    from authoring.render import png_bytes

    return png_bytes(rgb)


def cell_id(cell: dict) -> str:
    """A file name for a cell: creature__animation__variant, safe characters only."""
    raw = f"{cell['creature']}__{cell['animation']}__{cell.get('variant_id') or 'cell'}"
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", raw)


def _plot(cell: dict, series: dict, t: np.ndarray) -> bytes | None:
    """Plots of the failing metrics over time (matplotlib, Agg), one panel each."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    names = [k for k, m in cell["metrics"].items() if m.get("verdict") == T.FAIL and k in series][:PLOTTED]
    if not names:
        return None
    height = 0.8 + 1.6 * len(names)           # inches: a panel each, a title and an axis label
    fig, axes = plt.subplots(len(names), 1, figsize=(6.4, height), squeeze=False)
    fig.subplots_adjust(left=0.16, right=0.97, top=1.0 - 0.35 / height, bottom=0.45 / height, hspace=0.5)
    for ax, name in zip(axes[:, 0], names, strict=True):
        y = np.asarray(series[name], float)
        x = t[: len(y)]
        ax.plot(x, y, lw=1.2, color="#33507a")
        th = T.BY_METRIC.get(name)
        if th is not None:
            if th.fail is not None:
                ax.axhline(th.fail, color="#c0392b", lw=0.8, ls="--", label=f"fail {th.fail:g}")
            if th.warn is not None:
                ax.axhline(th.warn, color="#d68910", lw=0.8, ls=":", label=f"warn {th.warn:g}")
        m = cell["metrics"][name]
        if m.get("time") is not None:
            ax.axvline(m["time"], color="#888", lw=0.8)
        ax.set_ylabel(f"{name}\n({m['unit']})", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("time since play (s)", fontsize=8)
    fig.suptitle(f"{cell['creature']} / {cell['animation']} / {cell.get('variant_id') or ''}", fontsize=9)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    plt.close(fig)
    return buf.getvalue()


def picture_task(source: G.Source, paths: tuple[str, ...], variant: str | None = None) -> dict:
    """The grid's task with pictures: judge one creature (``engine.validation.grid``) and
    render its thumbnail strip (one tile per animation: the worst variant's pose at its
    worst frame) and, per failing cell, a filmstrip and the plots."""
    from engine.validation.record import FPS

    results, creature, seconds = G.judge_source(source, paths, variant, keep_poses=True)
    cells = [G._cell_json(r, source) for r in results]
    files: dict[str, bytes] = {}
    if creature is None:
        return {"source": source, "cells": cells, "files": files, "seconds": seconds}
    t_pic = time.perf_counter()
    try:
        # thumbnail strip: tile k is animation k's worst variant
        order = {os.path.splitext(os.path.basename(p))[0]: k for k, p in enumerate(paths)}
        strip = np.full((THUMB, THUMB * max(len(paths), 1), 3), 236, np.uint8)
        best: dict[int, tuple[float, object]] = {}
        for res, cell in zip(results, cells, strict=True):
            k = _column(res, order)
            if k is None or "worst" not in res.poses:
                continue
            sev = (T.RANK.get(res.status, -1), G.severity(cell))
            if k not in best or sev > best[k][0]:
                best[k] = (sev, res)
        for k, (_, res) in best.items():
            _, pos, rot = res.poses["worst"]
            strip[:, k * THUMB:(k + 1) * THUMB] = _draw_pose(creature, pos, rot, THUMB, grid=False)
        files[f"thumbs/{_safe(source.name)}.png"] = _png(strip)
        # filmstrips and plots of the worst failing cells
        failing = sorted((k for k, (res, cell) in enumerate(zip(results, cells, strict=True))
                          if res.status == T.FAIL and "film" in res.poses), key=lambda k: -G.severity(cells[k]))
        # every flip, then the worst of the rest up to PICTURED (random 4247's pound_ground
        # flip ranked seventh behind six boxes overlapping and had no pictures)
        flips = [k for k in failing if G.is_flip(cells[k])]
        pictured = flips + [k for k in failing if k not in flips][:max(PICTURED - len(flips), 0)]
        for k in pictured:
            res, cell = results[k], cells[k]
            cid = cell_id(cell)
            frames = res.poses["film"]
            worst_frame = res.poses.get("worst_frame")
            tiles = []
            for (t, pos, rot) in frames:
                img = _draw_pose(creature, pos, rot, FILM)
                if worst_frame is not None and abs(t - (worst_frame + 1) / FPS) < 0.5 / FPS:
                    img[:4], img[-4:], img[:, :4], img[:, -4:] = (200, 40, 40), (200, 40, 40), (200, 40, 40), \
                        (200, 40, 40)
                tiles.append(img)
            files[f"cells/{cid}_film.png"] = _png(np.concatenate(tiles, axis=1))
            cell["film_times"] = [round(float(t), 3) for (t, _, _) in frames]
            series = {k: m.series for k, m in res.measures.items() if m.series is not None and len(m.series)}
            n = max((len(v) for v in series.values()), default=0)
            plot = _plot(cell, series, (np.arange(n) + 1) / FPS)
            if plot is not None:
                files[f"cells/{cid}_plot.png"] = plot
    except Exception as exc:  # noqa: BLE001 - pictures are a report's extra, never a lost run
        for cell in cells:
            cell.setdefault("picture_error", f"{type(exc).__name__}: {exc}")
    return {"source": source, "cells": cells, "files": files, "seconds": seconds,
            "picture_seconds": time.perf_counter() - t_pic}


def _column(res, order: dict) -> int | None:
    name = os.path.splitext(os.path.basename(res.animation_path))[0] if res.animation_path else res.animation
    return order.get(name, order.get(res.animation))


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", name)


# -- the report --------------------------------------------------------------------------

STATUS_COLOR = {T.PASS: "#2e8b57", T.WARN: "#d68910", T.FAIL: "#c0392b", T.NA: "#b0b0b0"}


def write_report(out: str, run: G.GridRun, *, animations: list[str], command: str, previous: list | None = None,
                 pictures: bool = True) -> dict:
    """Write grid.json, grid.csv, index.html and the cell pages into ``out``; returns the
    summary."""
    os.makedirs(out, exist_ok=True)
    for rel, data in run.files.items():
        path = os.path.join(out, rel)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(data)
    cells = run.cells
    summary = G.summarize(cells, run.seconds)
    summary["creatures"] = run.creatures
    summary["workers"] = run.workers
    summary["scheduler"] = run.scheduler
    summary["interrupted"] = run.interrupted
    comparison = G.compare(previous, cells) if previous is not None else None
    doc = {"format": 1, "command": command, "meta": G.run_metadata(), "animations": animations,
           "thresholds": T.table(), "summary": summary,
           "rates": {"creature": G.rates(cells, "creature"), "animation": G.rates(cells, "animation")},
           "cells": cells}
    if comparison is not None:
        doc["comparison"] = comparison
    _write_text(os.path.join(out, "grid.json"), json.dumps(doc, indent=1, default=_json_default))
    _write_csv(os.path.join(out, "grid.csv"), cells)
    _write_html(out, doc, pictures)
    return summary


def _json_default(o):
    if isinstance(o, G.Source):
        return o.ref
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o).__name__)


def _write_text(path: str, text: str) -> None:
    tmp = f"{path}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


def _write_csv(path: str, cells: list[dict]) -> None:
    metrics = [t.metric for t in T.THRESHOLDS]
    extra = sorted({k for c in cells for k in c.get("metrics", {})} - set(metrics))
    cols = ["creature", "source", "animation", "variant_id", "status", "reason", "worst_metric", "worst_value",
            "worst_body", "worst_time", "known", "ms_per_tick"] + metrics + extra
    tmp = f"{path}.tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for c in cells:
            wo = c.get("worst") or {}
            row = [c["creature"], c.get("source", ""), c["animation"], c.get("variant_id", ""), c["status"],
                   c.get("reason", ""), wo.get("metric", ""), wo.get("value", ""), wo.get("body", ""),
                   wo.get("time", ""), ";".join(c.get("known", [])), c.get("ms_per_tick", "")]
            ms = c.get("metrics", {})
            row += [ms[m]["value"] if m in ms else "" for m in metrics + extra]
            w.writerow(row)
    os.replace(tmp, path)


_CSS = """
body{font-family:system-ui,sans-serif;margin:16px;color:#222;background:#fafafa}
h1{font-size:20px;margin:0 0 8px} h2{font-size:16px;margin:18px 0 6px}
.num{font-variant-numeric:tabular-nums}
#summary{display:flex;flex-wrap:wrap;gap:6px;margin:6px 0}
#summary div{background:#fff;border:1px solid #ddd;border-radius:4px;padding:3px 8px;font-size:12px}
#summary div b{display:block;font-size:15px}
.columns{display:flex;flex-wrap:wrap;gap:24px;align-items:flex-start} .side{max-width:760px}
table.matrix{border-collapse:collapse;font-size:11px}
table.matrix th{position:sticky;top:0;background:#fafafa;z-index:1;padding:2px;vertical-align:bottom}
table.matrix th.col div{writing-mode:vertical-rl;transform:rotate(180deg);white-space:nowrap;max-height:120px}
table.matrix th.row{position:sticky;left:0;background:#fafafa;text-align:left;white-space:nowrap;
padding-right:6px;z-index:0}
table.matrix td{padding:1px}
.cell{display:block;width:64px;height:64px;border:3px solid #ccc;box-sizing:content-box;overflow:hidden}
.cell img.thumb{width:64px;height:64px;object-fit:none;display:block}
.pass{border-color:#2e8b57}.warn{border-color:#d68910}.fail{border-color:#c0392b}.na{border-color:#ddd;background:#eee}
.rate{color:#555;font-size:10px}
.badge{display:inline-block;padding:1px 6px;border-radius:3px;color:#fff;font-size:12px}
table.list{border-collapse:collapse;font-size:12px}
table.list td,table.list th{border-bottom:1px solid #ddd;padding:2px 8px;text-align:left}
code,pre{background:#eee;padding:1px 4px;border-radius:3px;font-size:12px}
pre{padding:8px;overflow:auto}
"""


def _badge(status: str) -> str:
    return f'<span class="badge" style="background:{STATUS_COLOR.get(status, "#777")}">{status}</span>'


def _write_html(out: str, doc: dict, pictures: bool) -> None:
    e = html.escape
    cells = doc["cells"]
    s = doc["summary"]
    anims = [os.path.splitext(os.path.basename(p))[0] for p in doc["animations"]]
    # the worst cell of each (creature, animation)
    by = {}
    rank = {T.NA: -1, T.PASS: 0, T.WARN: 1, T.FAIL: 2}
    creatures = []
    for c in cells:
        if c["creature"] not in by:
            by[c["creature"]] = {}
            creatures.append(c["creature"])
        k = c["animation"]
        old = by[c["creature"]].get(k)
        if old is None or (rank.get(c["status"], 0), G.severity(c)) > (rank.get(old["status"], 0), G.severity(old)):
            by[c["creature"]][k] = c
    rc, ra = doc["rates"]["creature"], doc["rates"]["animation"]
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>Menagerie validation grid</title>"
             f"<style>{_CSS}</style></head><body>",
             "<h1>Menagerie validation grid</h1>",
             f"<p><code>{e(doc['command'])}</code> &middot; {e(doc['meta'].get('date', ''))} &middot; commit "
             f"{e(doc['meta'].get('commit', '?'))}</p>",
             "<div id='summary'>"]
    for key in ("pass_rate", "plays", "pass", "warn", "fail", "known_fail", "flips", "flips_twist", "nonfinite",
                "not_applicable",
                "cells", "creatures", "seconds", "cells_per_second", "workers"):
        parts.append(f"<div>{key.replace('_', ' ')}<b class='num' id='summary-{key}'>{e(str(s.get(key, '')))}</b>"
                     "</div>")
    parts.append("</div>")
    by_metric = s.get("fail_by_metric") or {}
    if by_metric:
        parts.append("<p>Failing cells by metric: " + ", ".join(
            f"{e(m)} {n}" for m, n in sorted(by_metric.items(), key=lambda kv: -kv[1])) + "</p>")
    if s.get("interrupted"):
        parts.append("<p><b>Interrupted:</b> the run was stopped; these are the cells that finished.</p>")
    cmp_ = doc.get("comparison")
    if cmp_:
        parts.append(f"<h2>Since the previous run</h2><p>pass rate {cmp_['pass_rate_was']} &rarr; "
                     f"{cmp_['pass_rate_now']}; {len(cmp_['regressed'])} regressed, {len(cmp_['improved'])} "
                     f"improved, {len(cmp_['added'])} new, {len(cmp_['removed'])} gone.</p>")
        for title, rows in (("Regressed", cmp_["regressed"]), ("Improved", cmp_["improved"])):
            if rows:
                parts.append(f"<h2>{title}</h2><table class='list'><tr><th>creature</th><th>animation</th>"
                             "<th>variant</th><th>was</th><th>now</th><th>reason</th></tr>")
                for r in rows[:500]:
                    parts.append(f"<tr><td>{e(r['creature'])}</td><td>{e(r['animation'])}</td>"
                                 f"<td>{e(r['variant_id'])}</td><td>{_badge(r['was'])}</td><td>{_badge(r['now'])}"
                                 f"</td><td>{e(r['reason'] or r['was_reason'])}</td></tr>")
                parts.append("</table>")
    parts.append("<div class='columns'><div>")
    parts.append(f"<h2>Matrix</h2><p>Each cell: the pose at its worst frame (the worst variant), framed by its "
                 f"verdict: {_badge(T.PASS)} {_badge(T.WARN)} {_badge(T.FAIL)} {_badge(T.NA)}. Overall pass "
                 f"rate <b id='overall'>{s['pass_rate']}</b>.</p>")
    parts.append("<table class='matrix' id='matrix'><tr><th></th>")
    for a in anims:
        parts.append(f"<th class='col'><div>{e(a)} <span class='rate'>{ra.get(a, '')}</span></div></th>")
    parts.append("</tr>")
    for name in creatures:
        row = by[name]
        parts.append(f"<tr><th class='row'>{e(name)}<br><span class='rate'>{rc.get(name, '')}</span></th>")
        thumb = f"thumbs/{_safe(name)}.png"
        have = pictures and os.path.exists(os.path.join(out, thumb))
        for k, a in enumerate(anims):
            c = row.get(a)
            if c is None:
                parts.append("<td></td>")
                continue
            st = c["status"]
            tip = e(f"{name} / {a} / {c.get('variant_id', '')}: {st}" + (f": {c['reason']}" if c.get("reason") else ""))
            img = (f"<img class='thumb' loading='lazy' alt='{e(name)} {e(a)}' src='{e(thumb)}' "
                   f"style='object-position:-{k * THUMB}px 0'>") if have and st != T.NA else ""
            inner = f"<span class='cell {st}' title='{tip}' data-status='{st}'>{img}</span>"
            if st == T.FAIL:
                inner = f"<a href='cells/{e(cell_id(c))}.html'>{inner}</a>"
            parts.append(f"<td>{inner}</td>")
        parts.append("</tr>")
    parts.append("</table>")
    parts.append("</div><div class='side'>")
    if s["worst"]:
        parts.append("<h2>Worst cells</h2><table class='list'><tr><th>creature</th><th>animation</th>"
                     "<th>variant</th><th>reason</th></tr>")
        for w in s["worst"]:
            link = cell_id(w) + ".html"
            parts.append(f"<tr><td>{e(w['creature'])}</td><td>{e(w['animation'])}</td><td>{e(w['variant_id'])}</td>"
                         f"<td><a href='cells/{e(link)}'>{e(w['reason'])}</a></td></tr>")
        parts.append("</table>")
    parts.append("</div></div>")
    parts.append("<h2>Thresholds</h2><table class='list'><tr><th>metric</th><th>unit</th><th>warn</th><th>fail</th>"
                 "<th>why</th></tr>")
    for t in doc["thresholds"]:
        parts.append(f"<tr><td>{e(t['metric'])}</td><td>{e(t['unit'])}</td><td>{t['warn']}</td><td>{t['fail']}</td>"
                     f"<td>{e(t['why'])}</td></tr>")
    # the page counts the thumbnails the browser could show (a test reads it back)
    parts.append("</table><script>window.addEventListener('load',function(){var t=document.querySelectorAll("
                 "'img.thumb'),n=0;for(var i=0;i<t.length;i++){if(t[i].complete&&t[i].naturalWidth>0){n++;}}"
                 "document.body.dataset.thumbs=t.length;document.body.dataset.thumbsLoaded=n;});</script>"
                 "</body></html>")
    _write_text(os.path.join(out, "index.html"), "\n".join(parts))
    os.makedirs(os.path.join(out, "cells"), exist_ok=True)
    for c in cells:
        if c["status"] == T.FAIL:
            _write_cell_page(out, c)


def _write_cell_page(out: str, c: dict) -> None:
    e = html.escape
    cid = cell_id(c)
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{e(cid)}</title><style>{_CSS}</style>"
             "</head><body>", "<p><a href='../index.html'>&larr; the grid</a></p>",
             f"<h1>{e(c['creature'])} / {e(c['animation'])} / {e(c.get('variant_id', ''))} {_badge(c['status'])}</h1>",
             f"<p>{e(c.get('reason', ''))}</p>"]
    if c.get("known"):
        parts.append(f"<p>Known defects among its failures (waiting for other work): {e('; '.join(c['known']))}</p>")
    parts.append(f"<h2>Reproduce</h2><pre>{e(c.get('reproduce', ''))}</pre>")
    from authoring.author import author_command

    tool = author_command(c)
    if tool:
        parts.append(f"<h2>Open in the authoring tool at the worst frame</h2><pre>{e(tool)}</pre>")
    if os.path.exists(os.path.join(out, "cells", f"{cid}_film.png")):
        times = ", ".join(f"{t:g}" for t in c.get("film_times", []))
        parts.append(f"<h2>Filmstrip</h2><p>t = {e(times)} s (the worst frame framed in red)</p>"
                     f"<img class='film' src='{e(cid)}_film.png' alt='filmstrip'>")
    if os.path.exists(os.path.join(out, "cells", f"{cid}_plot.png")):
        parts.append(f"<h2>Failing metrics over time</h2><img class='plot' src='{e(cid)}_plot.png' alt='plot'>")
    parts.append("<h2>Metrics</h2><table class='list'><tr><th>metric</th><th>value</th><th>unit</th><th>verdict</th>"
                 "<th>body</th><th>time (s)</th><th>detail</th></tr>")
    for k, m in sorted(c.get("metrics", {}).items(), key=lambda kv: -T.RANK.get(kv[1].get("verdict"), 0)):
        det = ", ".join(f"{a}={b}" for a, b in (m.get("detail") or {}).items())
        parts.append(f"<tr><td>{e(k)}</td><td class='num'>{m.get('value')}</td><td>{e(m.get('unit', ''))}</td>"
                     f"<td>{_badge(m.get('verdict', T.PASS))}</td><td>{e(str(m.get('body', '')))}</td>"
                     f"<td>{m.get('time', '')}</td><td>{e(det)}</td></tr>")
    parts.append("</table>")
    if c.get("target_sets"):
        parts.append(f"<h2>Targets</h2><pre>{e(json.dumps(c['target_sets']))}</pre>")
    if c.get("error"):
        parts.append(f"<h2>Error</h2><pre>{e(c['error'])}</pre>")
    parts.append("</body></html>")
    _write_text(os.path.join(out, "cells", f"{cid}.html"), "\n".join(parts))


# -- the command -------------------------------------------------------------------------


def add_grid_parser(sub) -> None:
    p = sub.add_parser("grid", help="the validation grid: every creature x animation, judged",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("--library", action="store_true", help="the library's creatures (the default with nothing else)")
    p.add_argument("--random", type=int, default=0, metavar="N", help="N random creatures")
    p.add_argument("--first-seed", type=int, default=0, metavar="S", help="first random seed (default 0)")
    p.add_argument("--creatures", nargs="+", default=[], metavar="PATH",
                   help="creature files, skeletons (BVH) or directories of them")
    p.add_argument("--animations", nargs="+", default=[], metavar="PATH",
                   help="animation files or directories (default: the library's animations)")
    p.add_argument("--variant", help="only the variant with this id (hand_l; 'default' without variants)")
    p.add_argument("--out", default="out/grid", help="report folder (default out/grid)")
    p.add_argument("--scheduler", help="address of a running Dask scheduler (default: $DASK_SCHEDULER_ADDRESS, "
                                       "else a LocalCluster)")
    p.add_argument("--workers", type=int, default=None,
                   help="LocalCluster worker processes (default: one per core; 0 runs in this process)")
    p.add_argument("--ik", nargs="+", default=[], metavar="NAME=VALUE",
                   help="IK parameters for every character of the run (engine.ik.IKParams fields: "
                        "--ik self_collision=true limb_outer=8)")
    p.add_argument("--compare", metavar="PREVIOUS.json", help="a previous grid.json to compare with")
    p.add_argument("--no-pictures", action="store_true", help="skip thumbnails, filmstrips and plots")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--force", action="store_true",
                   help="write into an existing report folder (its grid.json is kept as grid.previous.json "
                        "and compared with)")
    p.set_defaults(func=cmd_grid)


def _sources(args) -> list[G.Source]:
    out = []
    if args.library or not (args.random or args.creatures):
        out += G.library_sources()
    if args.random < 0:
        raise MenagerieError(f"--random must be 0 or more, got {args.random}")
    if args.random:
        if args.first_seed < 0:
            raise MenagerieError(f"--first-seed must be 0 or more, got {args.first_seed}")
        out += G.random_sources(args.random, args.first_seed)
    if args.creatures:
        out += G.file_sources(args.creatures)
    return out


def cmd_grid(args: argparse.Namespace) -> int:
    out = args.out
    grid_json = os.path.join(out, "grid.json")
    if os.path.exists(out) and not os.path.isdir(out):
        raise MenagerieError(f"{out}: exists and is not a directory (--out wants a folder)")
    if os.path.exists(grid_json) and not args.force:
        raise MenagerieError(f"{grid_json} exists: pass --force to write over this report (the old grid.json "
                             f"is kept as grid.previous.json and compared with)")
    if args.workers is not None and args.workers < 0:
        raise MenagerieError(f"--workers must be 0 or more, got {args.workers}")
    sources = _sources(args)
    paths = G.animation_paths(args.animations) if args.animations else G.library_animation_paths()
    # check every animation loads before any work starts
    from engine.anim import load_animation

    for p in paths:
        load_animation(p)
    previous = None
    compare_path = args.compare
    if compare_path is None and os.path.exists(grid_json):
        keep = os.path.join(out, "grid.previous.json")
        shutil.copyfile(grid_json, keep)
        compare_path = keep
    if compare_path:
        try:
            with open(compare_path, encoding="utf-8") as f:
                previous = json.load(f)["cells"]
        except (OSError, ValueError, KeyError) as exc:
            raise MenagerieError(f"{compare_path}: not a grid.json to compare with ({exc})") from None
    command = "menagerie grid " + " ".join(sys.argv[2:]) if sys.argv[1:2] == ["grid"] else "menagerie grid"
    task = G.cell_task if args.no_pictures else picture_task
    if args.ik:
        from engine.ik.plan import params_from_strings

        task = functools.partial(G.ik_task, task, params_from_strings(args.ik))
    print(f"grid: {len(sources)} creatures x {len(paths)} animations -> {out}", file=sys.stderr)
    run = G.run_grid(sources, paths, task=task, workers=args.workers, scheduler=args.scheduler,
                     variant=args.variant, progress=not args.quiet)
    if os.path.isdir(out) and args.force:
        for sub in ("cells", "thumbs"):
            shutil.rmtree(os.path.join(out, sub), ignore_errors=True)
    s = write_report(out, run, animations=paths, command=command, previous=previous,
                     pictures=not args.no_pictures)
    print(f"{s['cells']} cells ({s['plays']} played, {s['not_applicable']} not applicable): {s['pass']} pass, "
          f"{s['warn']} warn, {s['fail']} fail; pass rate {s['pass_rate']:.4f}; {s['flips']} with flips "
          f"({s.get('flips_twist', 0)} a body spinning about its bone); "
          f"{s['seconds']:.1f} s ({s['cells_per_second']:.1f} cells/s)")
    if previous is not None:
        with open(grid_json, encoding="utf-8") as f:
            cmp_ = json.load(f).get("comparison", {})
        print(f"since the previous run: {len(cmp_.get('regressed', []))} regressed, "
              f"{len(cmp_.get('improved', []))} improved")
    for w in s["worst"][:5]:
        print(f"  worst: {w['creature']} / {w['animation']} / {w['variant_id']}: {w['reason']}")
    print(f"report: {os.path.join(out, 'index.html')}")
    if run.interrupted:
        print("interrupted: the report holds the cells that finished", file=sys.stderr)
        return 130
    return 0
