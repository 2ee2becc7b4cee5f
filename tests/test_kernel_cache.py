"""The kernel-cache guard: a change in any kernel source drops Menagerie's cached kernels."""

from __future__ import annotations

import os

from engine import _cache


def test_stale_cache_is_dropped_when_a_kernel_source_changes(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    sources = _cache._kernel_sources()
    assert any(p.endswith(os.path.join("ik", "_kernels.py")) for p in sources)
    assert _cache.refresh_stale_kernel_cache() in (True, False)
    assert _cache.refresh_stale_kernel_cache() is False          # unchanged: nothing to do
    # A cached kernel file of ours, and a changed stamp (as after editing a kernel).
    cache_dir = _cache._cache_dirs(sources)[-1]
    os.makedirs(cache_dir, exist_ok=True)
    fake = os.path.join(cache_dir, "_kernels.solve-1.py311.nbi")
    with open(fake, "w") as f:
        f.write("stale")
    with open(os.path.join(str(tmp_path), _cache._STAMP), "w") as f:
        f.write("an older hash")
    assert _cache.refresh_stale_kernel_cache() is True
    assert not os.path.exists(fake)
    assert _cache.refresh_stale_kernel_cache() is False


def test_a_private_cache_dir_leaves_the_shared_cache_alone(tmp_path, monkeypatch):
    """With NUMBA_CACHE_DIR set, only that directory's kernels are ours to drop."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    sources = _cache._kernel_sources()
    dirs = _cache._cache_dirs(sources)
    assert dirs and all(d.startswith(str(tmp_path)) for d in dirs)
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    assert all(d.endswith("__pycache__") and not d.startswith(str(tmp_path)) for d in _cache._cache_dirs(sources))


def test_bounds_checking_changes_the_stamp(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("NUMBA_BOUNDSCHECK", raising=False)
    _cache.refresh_stale_kernel_cache()
    assert _cache.refresh_stale_kernel_cache() is False
    monkeypatch.setenv("NUMBA_BOUNDSCHECK", "1")
    assert _cache.refresh_stale_kernel_cache() is True           # checked kernels are other kernels
    assert _cache.refresh_stale_kernel_cache() is False
