"""Where Menagerie's own files and the shared data live, in one place.

- ``REPO_ROOT``: the repository (the folder holding ``engine/``);
- ``LIBRARY_CREATURES``, ``LIBRARY_ANIMATIONS``, ``GAIT_STYLES``: the library folders;
- ``shared_dir()``: the team's shared folder (papers, real motion capture and rigs). It
  is ``$MENAGERIE_SHARED`` when that is set, else ``shared`` beside the repository
  (``REPO_ROOT/../shared``), so a clone in any folder with ``shared`` beside it works;
- ``shared_data(*parts)``: a path under ``shared_dir()/data``.

Nothing here reads a file; the functions raise ``MenagerieError`` naming the folder they
looked in when it is missing.
"""

from __future__ import annotations

import os
from pathlib import Path

from engine.errors import MenagerieError

REPO_ROOT = Path(__file__).resolve().parent.parent
LIBRARY_CREATURES = REPO_ROOT / "creatures"
LIBRARY_ANIMATIONS = REPO_ROOT / "animations"
GAIT_STYLES = LIBRARY_ANIMATIONS / "gaits"

#: The environment variable that points at the shared folder.
SHARED_ENV = "MENAGERIE_SHARED"


def shared_dir() -> Path:
    """The shared folder (``$MENAGERIE_SHARED``, else ``shared`` beside the repository)."""
    env = os.environ.get(SHARED_ENV, "").strip()
    path = Path(env).expanduser() if env else REPO_ROOT.parent / "shared"
    if not path.is_dir():
        how = f"${SHARED_ENV}" if env else f"the folder beside the repository (set ${SHARED_ENV} to move it)"
        raise MenagerieError(f"{path}: no shared data folder ({how})")
    return path


def shared_data(*parts: str) -> Path:
    """A path under the shared ``data`` folder (``shared_data("mocap", "cmu_02_01_walk.bvh")``);
    it need not exist (the caller's open names it when it does not)."""
    return shared_dir().joinpath("data", *parts)


def has_shared_data() -> bool:
    """Whether the shared data folder is there (tests skip what needs it otherwise)."""
    try:
        return shared_dir().joinpath("data").is_dir()
    except MenagerieError:
        return False


def library_creature(name: str) -> Path:
    """``creatures/NAME.yaml``; raises naming the library when there is no such creature."""
    path = LIBRARY_CREATURES / f"{name}.yaml"
    if not path.is_file():
        names = sorted(p.stem for p in LIBRARY_CREATURES.glob("*.yaml"))
        raise MenagerieError(f"no library creature '{name}' in {LIBRARY_CREATURES} (there are: {', '.join(names)})")
    return path


def creature_path(spec: str) -> str:
    """What a command's CREATURE argument names: a library creature (``humanoid``, no
    suffix) or a file (creature YAML, BVH skeleton). Raises naming both readings when it
    is neither."""
    spec = os.fspath(spec)
    if os.path.isfile(spec):
        return spec
    if not os.path.splitext(spec)[1] and os.sep not in spec:
        return str(library_creature(spec))
    if os.path.isdir(spec):
        raise MenagerieError(f"{spec}: is a folder; a creature file or a library name is wanted")
    raise MenagerieError(f"{spec}: no such file")
