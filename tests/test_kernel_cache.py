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


def _tree(root, files):
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def test_a_change_drops_only_the_kernels_that_see_it(tmp_path, monkeypatch):
    """Editing a kernel module drops its cached kernels and those of the modules that
    import it (directly or through another module), and no others."""
    src = tmp_path / "src"
    _tree(src, {
        "engine/__init__.py": "",
        "engine/a/__init__.py": "from engine.a import helpers\n",
        "engine/a/_dep.py": "from numba import njit\nK = 1\n",
        "engine/a/layout.py": "from engine.a._dep import K\n",               # a plain module between
        "engine/a/_kernels.py": "from numba import njit\nfrom engine.a.layout import K\n",
        "engine/a/helpers.py": "X = 1\n",
        "engine/b/__init__.py": "",
        "engine/b/_kernels.py": "from numba import njit\nfrom engine.a import helpers\n",
    })
    monkeypatch.setattr(_cache, "_ROOT", str(src))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    sources = _cache._kernel_sources()
    assert sorted(os.path.relpath(p, src) for p in sources) == [
        os.path.join("engine", "a", "_dep.py"), os.path.join("engine", "a", "_kernels.py"),
        os.path.join("engine", "b", "_kernels.py")]
    assert _cache.refresh_stale_kernel_cache() is True
    parse = _cache._imports
    monkeypatch.setattr(_cache, "_imports", None)   # unchanged files are not parsed again (the stamp keeps the graph)
    assert _cache.refresh_stale_kernel_cache() is False
    monkeypatch.setattr(_cache, "_imports", parse)

    def fake_cache(rel):
        path = str(src / rel)
        d = _cache._cache_dirs([path])[0]
        os.makedirs(d, exist_ok=True)
        stem = os.path.splitext(os.path.basename(path))[0]
        f = os.path.join(d, f"{stem}.kernel-12.py311.nbi")
        with open(f, "w") as fh:
            fh.write("compiled")
        return f

    dep, a, b = (fake_cache(os.path.join("engine", *r)) for r in (("a", "_dep.py"), ("a", "_kernels.py"),
                                                                 ("b", "_kernels.py")))
    (src / "engine" / "a" / "_dep.py").write_text("from numba import njit\nK = 2\n")
    assert _cache.refresh_stale_kernel_cache() is True
    assert not os.path.exists(dep) and not os.path.exists(a)     # the changed file and its importer
    assert os.path.exists(b)                                      # b imports helpers, not _dep
    (src / "engine" / "a" / "helpers.py").write_text("X = 2\n")
    a = fake_cache(os.path.join("engine", "a", "_kernels.py"))
    assert _cache.refresh_stale_kernel_cache() is True
    assert not os.path.exists(b) and os.path.exists(a)           # a's kernels never import helpers
    assert _cache.refresh_stale_kernel_cache() is False
