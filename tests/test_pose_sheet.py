"""The pose sheet: one animation played through the runtime on several creatures."""

from __future__ import annotations

import numpy as np
import pytest

from authoring import pose_sheet as ps


def test_crouch_sheet_shows_a_different_pose_than_rest(tmp_path):
    from conftest import renderer_or_skip  # tests/ is on sys.path (pytest's rootdir mode)
    from PIL import Image

    renderer_or_skip()
    rest = ps.pose_sheet("animations/crouch.yaml", 0.0, str(tmp_path / "rest.png"), ["humanoid", "dog"],
                         width=320, height=160)
    low = ps.pose_sheet("animations/crouch.yaml", 1.0, str(tmp_path / "low.png"), ["humanoid", "dog"],
                        width=320, height=160)
    a = np.asarray(Image.open(rest), dtype=float)
    b = np.asarray(Image.open(low), dtype=float)
    assert a.shape == b.shape == (160, 320, 3) or a.shape[:2] == (160, 320)
    # The crouched creatures are drawn elsewhere than the standing ones.
    assert np.mean(np.any(np.abs(a - b) > 30, axis=-1)) > 0.005


def test_bad_time_is_refused(tmp_path):
    with pytest.raises(ValueError, match="t must be"):
        ps.pose_sheet("animations/crouch.yaml", float("nan"), str(tmp_path / "x.png"), ["dog"])


def test_cli_does_not_overwrite_without_force(tmp_path, capsys):
    out = tmp_path / "taken.png"
    out.write_bytes(b"the user's file")
    assert ps.main(["animations/crouch.yaml", "0.5", str(out), "dog"]) == 2
    assert out.read_bytes() == b"the user's file"
    assert "--force" in capsys.readouterr().err   # errors go to stderr, one line
