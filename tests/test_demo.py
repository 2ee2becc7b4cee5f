"""The demo's headless path: a short clip of the zoo, a contact sheet and the timing."""

from __future__ import annotations

import numpy as np

from authoring import demo


def test_headless_demo_writes_a_contact_sheet(tmp_path, capsys):
    from conftest import renderer_or_skip  # tests/ is on sys.path (pytest's rootdir mode)

    renderer_or_skip()
    zoo = demo.Zoo(demo.library_creatures(("humanoid", "spider", "octopus")), demo.library_animations())
    assert demo._headless(zoo, str(tmp_path), seconds=0.5, fps=10, sheet_frames=3) == 0
    sheet = tmp_path / "contact_sheet.png"
    assert sheet.exists() and sheet.stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "ms per character per frame" in out
    # Every character was animated and stayed finite.
    for ch in zoo.characters:
        assert np.all(np.isfinite(ch.world_positions))
        assert ch.player.active()
