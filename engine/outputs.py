"""Checks of a command's output paths, made before any work starts.

Every command that writes calls ``output_file`` or ``output_dir`` for each of its outputs
first, so a wrong or existing path fails in one line before a minute of simulation or
rendering is spent (and lost), and the rule is the same everywhere: an existing file is
replaced only with ``--force``; a folder where a file is wanted (or the reverse) is named
as such; missing parent folders are made.
"""

from __future__ import annotations

import os

from engine.errors import MenagerieError


def _parent_ready(path: str, flag: str) -> None:
    parent = os.path.dirname(os.path.abspath(path))
    probe = parent
    while not os.path.exists(probe):
        probe = os.path.dirname(probe)
    if not os.path.isdir(probe):
        raise MenagerieError(f"{path}: cannot make its folder for {flag}: {probe} is a file")
    if not os.access(probe, os.W_OK):
        raise MenagerieError(f"{path}: cannot write there ({flag}): {probe} is not writable")


def output_file(path: str, force: bool, *, flag: str = "--out", suffixes: tuple[str, ...] = ()) -> str:
    """Check that ``path`` can be written as a file for ``flag``: not a folder, the right
    suffix, not an existing file unless ``force``; makes its folder. Returns the path."""
    if os.path.isdir(path):
        raise MenagerieError(f"{path}: is a folder; {flag} wants a file path "
                             f"(e.g. {os.path.join(path, 'out' + (suffixes[0] if suffixes else ''))})")
    if suffixes and not path.lower().endswith(tuple(s.lower() for s in suffixes)):
        raise MenagerieError(f"{path}: {flag} wants a {' or '.join(suffixes)} file")
    if os.path.exists(path) and not force:
        raise MenagerieError(f"{path} exists; pass --force to replace it")
    _parent_ready(path, flag)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    return path


def output_dir(path: str, force: bool, *, flag: str = "--out", writes: tuple[str, ...] = ()) -> str:
    """Check that ``path`` can be the folder ``flag`` writes into: not a file; when it
    already holds any of the file names (or glob patterns) in ``writes``, only with
    ``force``; makes it. Returns the path."""
    import glob

    if os.path.exists(path) and not os.path.isdir(path):
        raise MenagerieError(f"{path}: is a file; {flag} wants a folder")
    if os.path.isdir(path) and not force:
        taken = sorted({os.path.basename(p) for w in writes for p in glob.glob(os.path.join(path, w))})
        if taken:
            raise MenagerieError(f"{os.path.join(path, taken[0])} exists; pass --force to replace "
                                 f"the output in {path}")
    _parent_ready(os.path.join(path, "x"), flag)
    os.makedirs(path, exist_ok=True)
    return path
