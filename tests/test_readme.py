"""Every fenced code block of the README runs, so the README cannot drift (issue 19).

- ``python`` blocks run in order in one namespace, from the repository root, with a
  three-frame ``running``, a ``draw`` that checks the arrays it gets, and the names the
  snippets leave to the reader (``anim``, ``next_anim``) bound to library animations;
- ``yaml`` blocks parse (the creature block builds, once its "# ..." is left out);
- shell blocks (``bash``, or unlabelled blocks of commands): every command is written with
  its ``.venv/bin/`` path, parses with the real ``menagerie`` parser, and runs with small
  inputs (``SMALL`` says how each is cut down: fewer frames, a temporary ``--out``,
  ``--headless`` for the window commands). A command the table does not know fails the
  test, so a new README command comes with its small run. The ones that render many
  frames are marked ``slow`` (they run unless ``-m 'not slow'`` deselects them);
- the command-line synopsis: every subcommand and flag it lists exists.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys

import numpy as np
import pytest

import engine
from engine.paths import REPO_ROOT, has_shared_data

ROOT = str(REPO_ROOT)
README = os.path.join(ROOT, "README.md")


def blocks() -> list[tuple[str, str, int]]:
    """(language, text, line) of every fenced block."""
    out, lang, buf, start = [], None, [], 0
    for n, line in enumerate(open(README, encoding="utf-8").read().splitlines(), 1):
        if line.startswith("```"):
            if lang is None:
                lang, buf, start = line[3:].strip(), [], n + 1
            else:
                out.append((lang, "\n".join(buf) + "\n", start))
                lang = None
        elif lang is not None:
            buf.append(line)
    assert lang is None, "an unclosed fence in the README"
    return out


def shell_commands() -> list[tuple[str, int]]:
    """(command, line) of every command in the README's shell blocks (continuations joined,
    ``&&`` chains split, comments dropped)."""
    out = []
    for lang, text, start in blocks():
        lines = text.splitlines()
        is_cmds = lang in ("bash", "sh") or (lang == "" and lines and all(
            ln.startswith((".venv/bin/", "bash ")) or ln.startswith("    ") for ln in lines if ln.strip()))
        if not is_cmds:
            continue
        joined, first = "", None
        for k, ln in enumerate(lines):
            if first is None:
                first = start + k
            joined += ln.rstrip()
            if joined.endswith("\\"):
                joined = joined[:-1] + " "
                continue
            for part in " ".join(shlex.split(joined, comments=True)).split(" && "):
                if part.strip():
                    out.append((part.strip(), first))
            joined, first = "", None
    return out


# -- python ---------------------------------------------------------------------------


class _Frames:
    """``while running:`` for three frames."""

    def __init__(self, n: int) -> None:
        self.n = n

    def __bool__(self) -> bool:
        self.n -= 1
        return self.n >= 0


def test_the_python_blocks_run(monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    drawn = []

    def draw(positions, rotations):
        assert positions.shape[1] == 3 and rotations.shape[1] == 4
        assert np.isfinite(positions).all() and np.isfinite(rotations).all()
        drawn.append(positions.copy())

    ns = {"running": _Frames(3), "draw": draw, "dt": 1 / 60,
          "anim": engine.load_animation("animations/shrug.yaml"),
          "next_anim": engine.load_animation("animations/nod_at_target.yaml")}
    py = [(text, start) for lang, text, start in blocks() if lang == "python"]
    assert len(py) >= 3
    for text, start in py:
        try:
            exec(compile(text, f"README.md:{start}", "exec"), ns)
        except Exception as exc:
            raise AssertionError(f"README.md:{start}: the python block fails: {type(exc).__name__}: {exc}") from exc
    assert len(drawn) == 3
    printed = capsys.readouterr().out
    assert "[0.6 0.3 1.2] 1.0" in printed      # what its comment says it prints


def test_the_yaml_blocks_parse():
    import yaml

    from engine.model import creature_from_text

    ys = [(text, start) for lang, text, start in blocks() if lang == "yaml"]
    assert ys
    for text, start in ys:
        assert isinstance(yaml.safe_load(text), dict), start
        if "bodies:" in text:
            creature = creature_from_text(text, f"README.md:{start}")
            assert creature.nbody >= 2


# -- shell ----------------------------------------------------------------------------


def _menagerie_parser():
    from authoring.cli import build_parser

    return build_parser()


def _small(cmd: str, tmp: str) -> tuple[list[str] | None, bool]:
    """The small run of a README command: (argv to run or None for parse-only, slow)."""
    a = shlex.split(cmd)
    walk = "../shared/data/mocap/cmu_02_01_walk.bvh"
    if a[:2] == ["bash", "setup.sh"]:
        # Running it would reinstall the environment: check its syntax and that it runs
        # far enough to read its arguments.
        return ["bash", "-n", "setup.sh"], False
    if a[:3] == [".venv/bin/python", "-m", "pytest"]:
        return [sys.executable, "-m", "pytest", "--collect-only", "-q", "tests/test_readme.py"], False
    assert a[0] == ".venv/bin/menagerie", f"'{cmd}': README commands start with .venv/bin/ (or say how to activate)"
    sub = a[1]
    rest = a[2:]
    out = []
    skip = False
    for k, x in enumerate(rest):   # outputs into the temporary folder
        if skip:
            skip = False
            continue
        if x in ("--out", "--report", "--snapshot", "--gif") and k + 1 < len(rest):
            out += [x, os.path.join(tmp, os.path.basename(rest[k + 1]) or "out")]
            skip = True
        else:
            out.append(x)
    rest = out
    if sub == "demo":
        return [*a[:2], *rest, "--headless", "--seconds", "0.2", "--out", os.path.join(tmp, "demo"), "--force"], True
    if sub == "author":
        if "--snapshot" not in rest:
            rest += ["--headless", "--snapshot", os.path.join(tmp, "author.png")]
        return [*a[:2], *rest, "--samples", "0", "--width", "480", "--height", "300", "--force"], True
    if sub == "play":
        return [*a[:2], *rest, "--force"], False
    if sub == "mocap":
        if walk not in rest or not has_shared_data():
            return None, False
        # 40 frames, or enough to reach into the command's --scale windows.
        starts = [int(m) for m in re.findall(r"@(\d+)-", " ".join(rest))]
        rest += ["--frames", f"0-{max([40] + [f + 20 for f in starts])}", "--force"]
        if rest[0] == "tune":
            rest += ["--points", "2"]
        return [*a[:2], *rest], False
    if sub == "grid":
        if "--workers" in rest and "--random" in rest:   # the one-cell command: as written
            return [*a[:2], *rest], True
        return None, False   # the library-sized grids: parsed only (the one-cell run covers the command)
    raise AssertionError(f"'{cmd}': no small run for 'menagerie {sub}' in tests/test_readme.py")


def _commands(mark_slow: bool = False):
    out = []
    for c, line in shell_commands():
        slow = mark_slow and _small(c, "TMP")[1]
        out.append(pytest.param(c, line, id=f"README.md:{line}:{c.split()[1] if len(c.split()) > 1 else c}",
                                marks=[pytest.mark.slow] if slow else []))
    return out


def test_the_readme_has_shell_commands():
    cmds = [c for c, _ in shell_commands()]
    assert len(cmds) >= 12 and any("mocap simulate" in c for c in cmds)


@pytest.mark.parametrize("cmd,line", _commands())
def test_a_readme_command_parses(cmd, line):
    a = shlex.split(cmd)
    if a[0] == ".venv/bin/menagerie":
        try:
            _menagerie_parser().parse_args(a[1:])
        except SystemExit as exc:
            raise AssertionError(f"README.md:{line}: '{cmd}' does not parse") from exc


@pytest.mark.parametrize("cmd,line", _commands(mark_slow=True))
def test_a_readme_command_runs_small(cmd, line, tmp_path):
    argv, _ = _small(cmd, str(tmp_path))
    if argv is None:
        return   # parse-only (see _small); test_a_readme_command_parses checked it
    if argv[0] == ".venv/bin/menagerie":
        argv = [os.path.join(os.path.dirname(sys.executable), "menagerie"), *argv[1:]]
    env = dict(os.environ, MENAGERIE_HEADLESS="1", MENAGERIE_QUIET="1")
    p = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, f"README.md:{line}: {' '.join(argv)}\n{p.stdout}\n{p.stderr}"
    assert "Traceback" not in p.stderr


def test_the_command_line_synopsis_lists_real_commands_and_flags():
    parser = _menagerie_parser()
    synopsis = next(text for lang, text, _ in blocks() if lang == "" and text.startswith("menagerie --version"))
    entries, cur = [], None
    for ln in synopsis.splitlines():
        if ln.startswith("menagerie ") or ln.startswith(".venv/bin/python -m authoring.pose_sheet"):
            cur = [ln]
            entries.append(cur)
        elif cur is not None and ln.startswith(" "):
            cur.append(ln)
    assert len(entries) >= 10
    for entry in entries:
        text = " ".join(entry)
        words = text.split()
        if words[0] != "menagerie":
            from authoring.pose_sheet import main as _pose_main  # noqa: F401  (it exists)

            continue
        p = parser
        for w in words[1:]:
            subs = [a for a in p._actions if a.__class__.__name__ == "_SubParsersAction"]
            if not subs or w not in subs[0].choices:
                break
            p = subs[0].choices[w]
        known = {o for a in p._actions for o in a.option_strings}
        for flag in re.findall(r"(?<![\w-])--[a-z][a-z-]*", text):
            assert flag in known, f"the README's synopsis '{entry[0].strip()}' lists {flag}, which {p.prog} lacks"
