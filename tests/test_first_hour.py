"""The first hour of a new user (issue 19), kept fixed from the command line.

Each test runs the ``menagerie`` command (or Python) in a subprocess the way a user
would, and checks the exit status, the one line printed and the files left behind.
Commands that would compile kernels run with ``MENAGERIE_QUIET=1`` except where the
compile line is what is tested.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
import tomllib
import warnings

import numpy as np
import pytest

import engine
from engine.paths import REPO_ROOT, has_shared_data, shared_data, shared_dir

ROOT = str(REPO_ROOT)
WALK = str(shared_data("mocap", "cmu_02_01_walk.bvh")) if has_shared_data() else ""
needs_walk = pytest.mark.skipif(not os.path.exists(WALK), reason="shared data (../shared/data) not here")


def cli(*args, cwd=None, env=None, quiet=True, timeout=600):
    """Run ``menagerie ARGS`` (as ``python -m authoring.cli``); returns (status, stdout, stderr)."""
    e = dict(os.environ, MENAGERIE_HEADLESS="1")
    if quiet:
        e["MENAGERIE_QUIET"] = "1"
    e.update(env or {})
    # The code of the repository these tests are in (what ``menagerie`` runs when it is
    # installed from here), wherever the command runs.
    e["PYTHONPATH"] = ROOT + os.pathsep + e.get("PYTHONPATH", "")
    cmd = [sys.executable, "-m", "authoring.cli"]
    p = subprocess.run([*cmd, *map(str, args)], cwd=cwd or ROOT, env=e, capture_output=True, text=True,
                       timeout=timeout)
    return p.returncode, p.stdout, p.stderr


def one_error(status, out, err, *words):
    """Exit status 2, exactly one line on stderr, no traceback, and it says ``words``."""
    assert status == 2, (status, out, err)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


# -- 1. portability: the shared data found relative to the repository --------------------


def _tracked_files():
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    if out.returncode != 0:
        pytest.skip("not a git checkout")
    return [f for f in out.stdout.splitlines() if os.path.isfile(os.path.join(ROOT, f))]


def test_no_absolute_path_to_the_shared_folder_in_the_repository():
    if not has_shared_data():
        pytest.skip("no shared folder here")
    needles = {str(shared_dir().resolve()), str(shared_dir().absolute())}
    offenders = []
    for f in _tracked_files():
        try:
            text = open(os.path.join(ROOT, f), encoding="utf-8").read()
        except (UnicodeDecodeError, OSError):
            continue
        for n in needles:
            if n + "/" in text or n + '"' in text:
                offenders.append(f)
    assert not offenders, offenders


@needs_walk
def test_a_copy_in_another_folder_with_shared_beside_it_finds_the_captures(tmp_path):
    repo = tmp_path / "anywhere" / "menagerie"
    for f in _tracked_files():
        if f.endswith((".py", ".toml")) or f.startswith(("tests/", "benchmarks/")):
            dst = repo / f
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(os.path.join(ROOT, f), dst)
    os.symlink(shared_dir(), tmp_path / "anywhere" / "shared")
    code = ("import sys; sys.path.insert(0, '.'); import tests.test_bvh as b, tests.test_tracking as t; "
            "import engine.paths as p; print(p.REPO_ROOT); print(len(b.FILES)); print(t.WALK)")
    env = {k: v for k, v in os.environ.items() if k != "MENAGERIE_SHARED"}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "cache")
    p = subprocess.run([sys.executable, "-c", code], cwd=repo, env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    root, nfiles, walk = p.stdout.split()
    assert root == str(repo)
    assert int(nfiles) >= 5
    assert walk.startswith(str(tmp_path / "anywhere" / "shared")) and os.path.isfile(walk)


def test_the_shared_folder_moves_with_MENAGERIE_SHARED(tmp_path):
    (tmp_path / "data" / "mocap").mkdir(parents=True)
    code = "from engine.paths import shared_data; print(shared_data('mocap'))"
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       env=dict(os.environ, MENAGERIE_SHARED=str(tmp_path)))
    assert p.stdout.strip() == str(tmp_path / "data" / "mocap")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       env=dict(os.environ, MENAGERIE_SHARED=str(tmp_path / "nowhere")))
    assert p.returncode != 0 and "no shared data folder" in p.stderr


# -- 2. silence on first run ---------------------------------------------------------------


def test_a_cold_cache_is_announced_once_with_a_rough_time(tmp_path):
    code = ("from engine import compiling; print(compiling.notice('runtime')); "
            "print(compiling.notice('runtime')); print(compiling.notice('physics')); "
            "from numba import njit; njit(lambda x: x + 1)(1)")   # the line is written when numba compiles
    env = {k: v for k, v in os.environ.items() if k != "MENAGERIE_QUIET"}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "empty")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    assert p.stdout.split() == ["True", "False", "False"]
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "compiling" in lines[0] and " s" in lines[0] and "first run" in lines[0], p.stderr
    # Announced but nothing compiled (all needed was cached after all): nothing said.
    p = subprocess.run([sys.executable, "-c", code.split("; from numba")[0]], cwd=ROOT, env=env, capture_output=True,
                       text=True)
    assert p.stdout.split() == ["True", "False", "False"] and p.stderr == "", p.stderr
    # Quiet when asked.
    env["MENAGERIE_QUIET"] = "1"
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    assert p.stdout.split() == ["False", "False", "False"] and p.stderr == ""


def test_the_compiling_line_shows_progress_and_ends_once(tmp_path):
    """A dot every few seconds while numba compiles, " done in N s" and the line's end when
    the compile is over: at the first tick's end (``end_line``) or, without one, after
    a quiet moment (the watcher thread); in a fresh process with an empty cache."""
    code = ("import sys, time\n"
            "from numba import njit\n"
            "from engine import compiling\n"
            "compiling.Progress.DOT_S = 0.3\n"
            "assert compiling.notice('runtime') and compiling.line_open\n"
            "print('between', file=sys.stderr)\n"   # before numba compiles: its own line
            "def f(x):\n"
            "    s = 0.0\n"
            "    for i in range(x):\n"
            "        s += i ** 0.5\n"
            "    return s\n"
            "njit(f)(3); time.sleep(0.8)\n"       # dots while the watcher waits
            "compiling.end_line(); print('after', compiling.line_open)\n"
            "compiling.end_line()\n"              # once
            "njit(lambda x: x + 1)(1)\n")        # later compiles are silent
    env = {k: v for k, v in os.environ.items() if k != "MENAGERIE_QUIET"}
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "empty")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert p.stdout.split() == ["after", "False"]
    lines = p.stderr.splitlines()
    assert len(lines) == 2 and lines[0] == "between", p.stderr
    assert lines[1].startswith("menagerie: compiling") and ".." in lines[1], p.stderr
    assert re.search(r" done in \d+ s$", lines[1]), p.stderr
    # Without a tick to end it, the watcher ends the line once the compiles are over.
    code2 = code.replace("compiling.end_line(); print('after', compiling.line_open)\n", "time.sleep(2.5)\n"
                         "print('after', compiling.line_open)\n")
    p = subprocess.run([sys.executable, "-c", code2], cwd=ROOT, env=env, capture_output=True, text=True)
    assert p.returncode == 0 and p.stdout.split() == ["after", "False"], p.stderr
    assert re.search(r" done in \d+ s$", p.stderr.splitlines()[1]) and len(p.stderr.splitlines()) == 2, p.stderr


def test_a_warm_cache_says_nothing(tmp_path, monkeypatch):
    from engine import compiling

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    cold = compiling.cold_sources("runtime")
    assert cold and compiling.estimate_seconds("runtime") == pytest.approx(compiling.AREAS["runtime"][2])
    for src in cold:   # what numba leaves behind: one index per kernel
        d = compiling._cache_dir_of(src)
        os.makedirs(d, exist_ok=True)
        stem = os.path.splitext(os.path.basename(src))[0]
        open(os.path.join(d, f"{stem}.kernel-10.py311.nbi"), "w").close()
    assert compiling.cold_sources("runtime") == []
    assert compiling.estimate_seconds("runtime") == 0.0
    monkeypatch.setattr(compiling, "_announced", False)
    monkeypatch.setattr(compiling, "_checked", set())
    assert compiling.notice("runtime") is False


def test_a_second_run_says_nothing_about_compiling(tmp_path):
    """What one run compiled, the next loads: no line (no file the command never calls
    may keep the area looking cold)."""
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    status, out, first = cli("view", "humanoid", "--snapshot", tmp_path / "a.png", quiet=False, env=env)
    assert status == 0 and "compiling the viewer's numba kernels" in first, first
    status, out, second = cli("view", "humanoid", "--snapshot", tmp_path / "b.png", quiet=False, env=env)
    assert status == 0 and "compiling" not in second, second


@needs_walk
def test_the_real_time_factor_leaves_the_first_call_out(monkeypatch):
    """A first step that costs a second (what numba's compile does) is not simulation time."""
    from engine.io import load_bvh
    from engine.response import tracking

    real_step = tracking.step
    calls = []

    def slow_first(*a, **k):
        if not calls:
            time.sleep(1.0)
        calls.append(1)
        return real_step(*a, **k)

    rig = tracking.MocapRig(load_bvh(WALK), "constrained", frames=(0, 12))
    tracking.track(rig)   # warm
    monkeypatch.setattr(tracking, "step", slow_first)
    result = tracking.track(rig)
    assert calls and result.wall_seconds < 0.8, result.wall_seconds


# -- 4. a line, not a traceback, for outputs of the wrong kind -----------------------------


def test_view_snapshot_into_a_folder_is_one_line(tmp_path):
    one_error(*cli("view", "creatures/spider.yaml", "--snapshot", f"{tmp_path}/"), "is a folder", "--snapshot")
    one_error(*cli("view", "creatures/spider.yaml", "--snapshot", tmp_path / "a.jpg"), "wants a .png")


def test_from_bvh_out_a_folder_is_one_line(tmp_path):
    if not WALK:
        pytest.skip("no shared data")
    one_error(*cli("creatures", "from-bvh", WALK, "--out", tmp_path, "--force"), "is a folder", "--out")
    assert list(tmp_path.iterdir()) == []


@needs_walk
def test_mocap_outputs_of_the_wrong_kind_fail_before_the_simulation(tmp_path):
    started = time.perf_counter()
    one_error(*cli("mocap", "simulate", WALK, "--frames", "0-30", "--out", tmp_path, "--force"), "is a folder")
    one_error(*cli("mocap", "simulate", WALK, "--frames", "0-30", "--report", tmp_path, "--force"), "is a folder",
              "--report")
    one_error(*cli("mocap", "tune", WALK, "--frames", "0-30", "--report", tmp_path, "--force"), "is a folder")
    assert list(tmp_path.iterdir()) == []
    assert time.perf_counter() - started < 60


def test_demo_out_a_file_and_bad_seconds_are_one_line_and_leave_nothing(tmp_path):
    f = tmp_path / "file.txt"
    f.write_text("mine")
    one_error(*cli("demo", "--headless", "--out", f), "is a file", "--out")
    assert f.read_text() == "mine"
    for seconds in ("0", "-1", "0.01"):
        out = tmp_path / f"demo{seconds}"
        one_error(*cli("demo", "--headless", "--out", out, "--seconds", seconds), "--seconds")
        assert not out.exists()


# -- 5. nothing lost: every output checked before the work ---------------------------------


@needs_walk
def test_mocap_simulate_with_an_existing_report_writes_nothing(tmp_path):
    report = tmp_path / "existing.json"
    report.write_text("{}")
    new = tmp_path / "new.bvh"
    started = time.perf_counter()
    one_error(*cli("mocap", "simulate", WALK, "--out", new, "--report", report), "existing.json exists", "--force")
    assert not new.exists() and report.read_text() == "{}"
    one_error(*cli("mocap", "tune", WALK, "--points", "2", "--report", report), "existing.json exists")
    assert report.read_text() == "{}"
    assert time.perf_counter() - started < 60   # no simulation ran


def test_view_snapshot_and_demo_out_do_not_overwrite_without_force(tmp_path):
    png = tmp_path / "a.png"
    png.write_bytes(b"mine")
    one_error(*cli("view", "creatures/spider.yaml", "--snapshot", png), "a.png exists", "--force")
    assert png.read_bytes() == b"mine"
    (tmp_path / "demo").mkdir()
    (tmp_path / "demo" / "contact_sheet.png").write_bytes(b"mine")
    one_error(*cli("demo", "--headless", "--out", tmp_path / "demo"), "contact_sheet.png exists", "--force")
    assert (tmp_path / "demo" / "contact_sheet.png").read_bytes() == b"mine"


# -- 6. errors that say what is wrong ------------------------------------------------------


def test_snapshot_into_a_missing_folder_is_made_and_a_file_in_the_way_is_named(tmp_path):
    blocker = tmp_path / "blocker"
    blocker.write_text("x")
    line = one_error(*cli("view", "creatures/spider.yaml", "--snapshot", blocker / "dir" / "a.png"), "--snapshot")
    assert "is a file" in line and "no such file" not in line
    status, out, err = cli("view", "creatures/spider.yaml", "--snapshot", tmp_path / "missing" / "dir" / "a.png")
    assert status == 0, err
    assert (tmp_path / "missing" / "dir" / "a.png").stat().st_size > 1000
    assert out.strip() == f"wrote {tmp_path / 'missing' / 'dir' / 'a.png'}"


def test_creatures_list_takes_a_file_and_says_one_creature():
    status, out, err = cli("creatures", "list", "creatures/humanoid.yaml")
    assert status == 0, err
    assert out.strip().splitlines()[-1] == "1 creature"
    assert "humanoid" in out


def test_an_animation_passed_as_a_creature_says_so(tmp_path):
    line = one_error(*cli("view", "animations/wave.yaml", "--snapshot", tmp_path / "x.png"), "wave.yaml")
    assert "looks like an animation" in line and "unknown top-level field" not in line
    line = one_error(*cli("play", "humanoid", "creatures/dog.yaml", "--snapshot", tmp_path / "y.png"))
    assert "looks like a creature" in line
    assert not list(tmp_path.iterdir())


@needs_walk
def test_a_bvh_where_a_creature_file_is_read_points_at_from_bvh():
    with pytest.raises(engine.CreatureError, match="creatures from-bvh"):
        engine.load_creature(WALK)


def test_generate_bad_seed_and_existing_files_speak_command_line(tmp_path):
    line = one_error(*cli("creatures", "generate", "--seed", "-1", "--out", tmp_path), "--seed")
    assert "generate_creatures" not in line and "function" not in line
    status, out, err = cli("creatures", "generate", "--seed", "3", "--count", "1", "--out", tmp_path)
    assert status == 0 and out.strip() == f"wrote 1 creature to {tmp_path}", err
    line = one_error(*cli("creatures", "generate", "--seed", "3", "--out", tmp_path), "random_3.yaml exists",
                     "--force")
    assert "overwrite=True" not in line


def test_mode_ground_hints_at_the_ground_flag(tmp_path):
    text = open(os.path.join(ROOT, "animations", "crouch.yaml")).read().replace(
        "{mode: rest, ground: true}", "{mode: ground}", 1)
    (tmp_path / "bad.yaml").write_text(text)
    line = one_error(*cli("play", "humanoid", tmp_path / "bad.yaml", "--snapshot", tmp_path / "x.png"))
    assert "ground: true" in line and "bad.yaml:" in line


def test_a_bad_display_on_demo_suggests_headless():
    status, out, err = cli("demo", env={"MENAGERIE_HEADLESS": "0", "DISPLAY": ":4321"})
    line = one_error(status, out, err, "--headless")
    assert "view FILE --snapshot" not in line


def test_a_command_group_alone_says_what_to_choose():
    one_error(*cli("creatures"), "list, generate or from-bvh")
    one_error(*cli("mocap"), "simulate or tune")


# -- 7. one vocabulary -------------------------------------------------------------------


def test_version():
    status, out, err = cli("--version")
    assert status == 0 and out.strip() == f"menagerie {tomllib.load(open(os.path.join(ROOT, 'pyproject.toml'), 'rb'))['project']['version']}"


@needs_walk
def test_from_bvh_takes_unit_scale_like_mocap(tmp_path):
    status, out, err = cli("creatures", "from-bvh", WALK, "--out", tmp_path / "a.yaml", "--unit-scale", "0.05")
    assert status == 0 and err == "", err
    status, out, err = cli("creatures", "from-bvh", WALK, "--out", tmp_path / "b.yaml", "--scale", "0.05")
    assert status == 0 and "--unit-scale" in err   # the old name still works, and says the new one
    assert (tmp_path / "a.yaml").read_text().replace("name: b", "") == (tmp_path / "b.yaml").read_text().replace(
        "name: b", "")


def test_view_takes_library_names(tmp_path):
    status, out, err = cli("view", "humanoid", "--snapshot", tmp_path / "h.png")
    assert status == 0 and (tmp_path / "h.png").exists(), err
    one_error(*cli("view", "nosuchbeast", "--snapshot", tmp_path / "n.png"), "nosuchbeast", "library")


def test_the_grid_takes_library_names_too():
    from engine.validation.grid import file_sources

    assert [os.path.basename(s.ref) for s in file_sources(["humanoid", "creatures/dog.yaml"])] == [
        "humanoid.yaml", "dog.yaml"]
    with pytest.raises(engine.MenagerieError, match="no library creature 'nosuchbeast'"):
        file_sources(["nosuchbeast"])


# -- 8. files where the user expects them --------------------------------------------------


def test_view_without_a_display_writes_into_out_and_says_so_once(tmp_path):
    status, out, err = cli("view", os.path.join(ROOT, "creatures", "spider.yaml"), cwd=tmp_path)
    assert status == 0, err
    assert out.strip().splitlines() == [out.strip()] and "out/spider.png" in out and "no display" in out
    status, out, err = cli("view", os.path.join(ROOT, "creatures", "spider.yaml"), cwd=tmp_path)
    assert "out/spider_2.png" in out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["spider.png", "spider_2.png"]


# -- 9. numbers with their meaning -------------------------------------------------------


@needs_walk
def test_mocap_says_what_its_error_is_and_checks_scale_windows(tmp_path):
    status, out, err = cli("mocap", "simulate", WALK, "--frames", "0-40")
    assert status == 0, err
    assert "--gravity-comp" in out and "cm RMS" in out and "gravity" in out
    one_error(*cli("mocap", "simulate", WALK, "--frames", "0-40", "--scale", "RightFoot:1.2@2000-3000"),
              "outside the simulated frames 0-40")
    status, out, err = cli("mocap", "simulate", WALK, "--frames", "0-40", "--scale", "RightFoot:1.2@20-600")
    assert status == 0
    assert err.strip().splitlines() == ["menagerie: warning: scale RightFoot:1.2@20-600 reaches past the simulated "
                                        "frames 0-40; it scales frames 20-40"]


# -- 10. small things --------------------------------------------------------------------


def test_pyproject_license_is_a_string():
    meta = tomllib.load(open(os.path.join(ROOT, "pyproject.toml"), "rb"))
    assert isinstance(meta["project"]["license"], str)


def test_a_play_handle_prints_short(human):
    ch = engine.Character(human)
    h = ch.play(engine.load_animation("animations/wave.yaml"))
    assert repr(h) == "<PlayHandle 'wave' layer 0 playing>"


def test_creatures_list_goes_past_a_bad_file_and_keeps_its_columns(tmp_path):
    shutil.copy(os.path.join(ROOT, "animations", "wave.yaml"), tmp_path / "a_wave.yaml")
    long = "a_creature_with_a_rather_long_name_indeed"
    text = open(os.path.join(ROOT, "creatures", "humanoid.yaml")).read().replace("name: humanoid", f"name: {long}", 1)
    (tmp_path / "b.yaml").write_text(text)
    shutil.copy(os.path.join(ROOT, "creatures", "dog.yaml"), tmp_path / "c.yaml")
    status, out, err = cli("creatures", "list", tmp_path)
    assert status == 0, err
    lines = out.splitlines()
    assert lines[-1] == "2 creatures"
    assert "a_wave.yaml" in err and "looks like an animation" in err
    col = lines[0].index("bodies")
    rows = lines[2:-1]
    assert [r.split()[0] for r in rows] == [long, "dog"]
    assert all(r[col - 1] == " " for r in rows)   # the name never runs into the numbers


def test_queue_behind_a_looping_clip_starts_at_the_end_of_its_cycle(human):
    wave = engine.load_animation("animations/wave.yaml")
    nxt = engine.load_animation("animations/shrug.yaml")
    ch = engine.Character(human)
    a = ch.play(wave, loop=True, fade=0.0)
    b = ch.queue(nxt, fade=0.2)
    t = 0.0
    while not b.playing and t < wave.length + 0.5:
        ch.tick(1 / 60)
        t += 1 / 60
    assert b.playing and abs(t - wave.length) < 2 / 60, (t, wave.length)
    for _ in range(30):
        ch.tick(1 / 60)
    assert a.finished and b.playing
    assert np.isfinite(ch.world_positions).all()


def test_warnings_print_as_one_line_without_python_source(tmp_path):
    text = open(os.path.join(ROOT, "creatures", "humanoid.yaml")).read()
    text = text.replace("rot: [1.0, 0.0, 0.0, 0.0]", "rot: [1.1, 0.0, 0.0, 0.0]", 1)
    if "rot: [1.1" not in text:
        text = text.replace("    caps: [spine]", "    caps: [spine]\n    rot: [1.1, 0.0, 0.0, 0.0]", 1)
    (tmp_path / "c.yaml").write_text(text)
    with warnings.catch_warnings(record=True):
        status, out, err = cli("view", tmp_path / "c.yaml", "--snapshot", tmp_path / "c.png")
    assert status == 0, err
    lines = err.strip().splitlines()
    assert lines and all(ln.startswith("menagerie: warning: ") for ln in lines), err
    assert "warnings.warn" not in err and ".py:" not in err


def test_readme_says_how_to_activate_and_every_command_has_its_path():
    readme = open(os.path.join(ROOT, "README.md")).read()
    assert "source .venv/bin/activate" in readme
    n = len([f for f in os.listdir(os.path.join(ROOT, "animations")) if f.endswith(".yaml")])
    assert f"({n} files" in readme
