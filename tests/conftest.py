"""Test settings shared by the suite.

Property tests (hypothesis) run *derandomized* by default: the examples a test draws are
fixed by the test's own code, so CI on a clean clone passes or fails on the code, never on
the luck of the draw (a random draw once failed CI on a rounding difference of 4.5e-10 m).
To explore fresh examples while developing, run with the ``explore`` profile:

    .venv/bin/python -m pytest --hypothesis-profile=explore tests/test_channels.py

and pin whatever it finds as an ``@example`` or a plain test.
"""

import pytest
from hypothesis import settings

import engine

settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile("ci")


@pytest.fixture(scope="module")
def human():
    """The library humanoid (a test module may define its own ``human``)."""
    return engine.load_creature("creatures/humanoid.yaml")


def renderer_or_skip() -> None:
    """Skip the calling test when this machine truly cannot render offscreen (no OpenGL
    context: ``authoring.render.Renderer`` says so with a ViewerError naming what to
    install, or pyglet is not installed); any other error from the renderer is a failure,
    never a skip."""
    try:
        from authoring import render as rd
    except ImportError as exc:                   # pragma: no cover - no pyglet
        pytest.skip(f"the renderer cannot be imported: {exc}")
    try:
        with rd.Renderer(64, 64):
            pass
    except rd.ViewerError as exc:
        if not str(exc).startswith("cannot create an OpenGL context"):
            raise
        pytest.skip(f"no OpenGL context on this machine: {exc}")
