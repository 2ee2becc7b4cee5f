"""Keep numba's on-disk cache honest across Menagerie's modules.

numba caches each ``@njit(cache=True)`` kernel keyed by its *own* source file. A kernel
that calls a kernel of another module (the runtime calls the IK solver, the IK calls
mathx...) keeps the callee's old machine code in its cache when only the callee's file
changes: a stale copy that can read a changed array layout out of bounds. So at import
Menagerie hashes every source file that defines numba kernels; when the hash differs
from the one stored beside the cache, it deletes Menagerie's cached kernels (all of
them: they are rebuilt on first use) and stores the new hash. Installed copies whose
cache directories cannot be written are left alone.
"""

from __future__ import annotations

import glob
import hashlib
import os

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_PACKAGES = ("engine", "authoring")
_STAMP = "menagerie_kernels.sha1"


def _kernel_sources() -> list[str]:
    out = []
    for pkg in _PACKAGES:
        for path in sorted(glob.glob(os.path.join(_ROOT, pkg, "**", "*.py"), recursive=True)):
            try:
                with open(path, "rb") as f:
                    if b"njit" in f.read():
                        out.append(path)
            except OSError:
                continue
    return out


def _cache_dirs(sources: list[str]) -> list[str]:
    """Where numba keeps this process's cached kernels: under ``NUMBA_CACHE_DIR`` when it
    is set (then, and only then: the ``__pycache__`` beside the sources belongs to the
    processes without it, and is not ours to drop), else beside each source."""
    cache_dir = os.environ.get("NUMBA_CACHE_DIR")
    if cache_dir:
        try:
            from numba.core.caching import UserProvidedCacheLocator

            return sorted({os.path.join(cache_dir, UserProvidedCacheLocator.get_suitable_cache_subpath(p))
                           for p in sources})
        except Exception:
            return [cache_dir]
    return sorted({os.path.join(os.path.dirname(p), "__pycache__") for p in sources})


#: Settings that change the machine code numba writes but not its cache key: a run with
#: bounds checks must not leave checked kernels for the next run, nor load unchecked ones.
_CODEGEN_ENV = ("NUMBA_BOUNDSCHECK", "NUMBA_OPT", "NUMBA_FASTMATH", "NUMBA_DEBUGINFO")


def refresh_stale_kernel_cache() -> bool:
    """Drop Menagerie's cached kernels if any kernel source changed; True if it did."""
    try:
        sources = _kernel_sources()
        digest = hashlib.sha1()
        for p in sources:
            with open(p, "rb") as f:
                digest.update(os.path.relpath(p, _ROOT).encode())
                digest.update(f.read())
        for name in _CODEGEN_ENV:
            digest.update(f"{name}={os.environ.get(name, '')}".encode())
        stamp = digest.hexdigest()
        dirs = _cache_dirs(sources)
        stamp_dir = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(_ROOT, "engine", "__pycache__")
        stamp_path = os.path.join(stamp_dir, _STAMP)
        try:
            with open(stamp_path) as f:
                if f.read().strip() == stamp:
                    return False
        except OSError:
            pass
        for d in dirs:
            for pattern in ("*.nbi", "*.nbc"):
                for f in glob.glob(os.path.join(d, pattern)):
                    try:
                        os.remove(f)
                    except OSError:
                        pass
        os.makedirs(stamp_dir, exist_ok=True)
        tmp = f"{stamp_path}.{os.getpid()}"
        with open(tmp, "w") as f:
            f.write(stamp)
        os.replace(tmp, stamp_path)
        return True
    except OSError:
        return False
