"""Keep numba's on-disk cache honest across Menagerie's modules.

numba caches each ``@njit(cache=True)`` kernel keyed by its *own* source file. A kernel
that calls a kernel of another module (the runtime calls the IK solver, the IK calls
its self-collision module, the channels call mathx...) keeps the callee's old machine
code in its cache when only the callee's file changes: a stale copy that can read a
changed array layout out of bounds. So at import Menagerie hashes, for every source file
that defines numba kernels, that file and every Menagerie module it imports, directly
or through others (constants and layouts frozen into the machine code come from those
too). The digests are stored beside the cache; a kernel file whose digest changed has
its cached kernels deleted (rebuilt on first use), the others keep theirs: a change to
the physics does not recompile the IK. Installed copies whose cache directories cannot
be written are left alone.
"""

from __future__ import annotations

import ast
import glob
import hashlib
import json
import os

_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_PACKAGES = ("engine", "authoring")
_STAMP = "menagerie_kernels.json"


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


def _module_file(name: str) -> str | None:
    """The source file of Menagerie module ``name`` (``engine.ik._kernels``), or None."""
    base = os.path.join(_ROOT, *name.split("."))
    for path in (base + ".py", os.path.join(base, "__init__.py")):
        if os.path.isfile(path):
            return path
    return None


def _imports(path: str) -> set[str]:
    """The Menagerie source files ``path`` imports by name. ``from a.b import c`` is the
    module ``a.b.c`` when that is a module, else ``a.b`` (a package's ``__init__`` only
    when a name is taken from it: importing a submodule runs the package, but none of
    its code goes into the submodule's kernels)."""
    try:
        with open(path, "rb") as f:
            tree = ast.parse(f.read(), filename=path)
    except (OSError, SyntaxError, ValueError):
        return set()
    pkg = os.path.relpath(os.path.dirname(path), _ROOT).replace(os.sep, ".")
    out = set()
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                parts = pkg.split(".")
                parts = parts[:len(parts) - (node.level - 1)] if node.level > 1 else parts
                mod = ".".join(parts + ([mod] if mod else []))
            for a in node.names:
                sub = _module_file(f"{mod}.{a.name}")
                names.append(f"{mod}.{a.name}" if sub else mod)
        for n in names:
            if n.split(".")[0] in _PACKAGES:
                f = _module_file(n)
                if f and f != path:
                    out.add(f)
    return out


def kernel_digests(sources: list[str] | None = None, known: dict | None = None) -> tuple[dict, dict]:
    """Per kernel source (path relative to the project): a digest of the file, of every
    Menagerie module it imports, transitively, and of the code-generation settings.
    Returns (digests, graph); ``graph`` (relative path -> [sha1 of the file, its imports])
    is kept in the stamp and given back as ``known``: a file whose content is unchanged
    is not parsed again (parsing is most of the cost, ~0.2 s at every import)."""
    sources = _kernel_sources() if sources is None else sources
    known = known or {}
    graph: dict[str, list] = {}
    files: dict[str, bytes] = {}
    todo = list(sources)
    while todo:
        p = todo.pop()
        rel = os.path.relpath(p, _ROOT)
        if rel in graph:
            continue
        try:
            with open(p, "rb") as f:
                files[rel] = f.read()
        except OSError:
            files[rel] = b""
        sha = hashlib.sha1(files[rel]).hexdigest()
        old = known.get(rel)
        if isinstance(old, list) and len(old) == 2 and old[0] == sha and isinstance(old[1], list):
            deps = [d for d in old[1] if isinstance(d, str)]
        else:
            deps = sorted(os.path.relpath(q, _ROOT) for q in _imports(p))
        graph[rel] = [sha, deps]
        todo.extend(os.path.join(_ROOT, d) for d in deps if d not in graph)
    env = "".join(f"{name}={os.environ.get(name, '')};" for name in _CODEGEN_ENV).encode()
    out = {}
    for p in sources:
        rel = os.path.relpath(p, _ROOT)
        seen, stack = {rel}, [rel]
        while stack:
            for q in graph[stack.pop()][1]:
                if q not in seen:
                    seen.add(q)
                    stack.append(q)
        digest = hashlib.sha1(env)
        for q in sorted(seen):
            digest.update(q.encode())
            digest.update(files[q])
        out[rel] = digest.hexdigest()
    return out, graph


def _cache_files(source: str, cache_dir: str) -> list[str]:
    stem = os.path.splitext(os.path.basename(source))[0]
    return [f for pattern in (f"{stem}.*.nbi", f"{stem}.*.nbc") for f in glob.glob(os.path.join(cache_dir, pattern))]


def refresh_stale_kernel_cache() -> bool:
    """Drop the cached kernels of every kernel source whose digest changed (the file or
    a module it imports); True if any were dropped or the stamp was rewritten."""
    try:
        sources = _kernel_sources()
        stamp_dir = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(_ROOT, "engine", "__pycache__")
        stamp_path = os.path.join(stamp_dir, _STAMP)
        try:
            with open(stamp_path) as f:
                stamp = json.load(f)
            if not isinstance(stamp, dict):
                stamp = {}
        except (OSError, ValueError):
            stamp = {}
        old = stamp.get("kernels") if isinstance(stamp.get("kernels"), dict) else {}
        digests, graph = kernel_digests(sources, stamp.get("graph") if isinstance(stamp.get("graph"), dict) else None)
        stale = [p for p in sources if old.get(os.path.relpath(p, _ROOT)) != digests[os.path.relpath(p, _ROOT)]]
        if not stale and set(old) == set(digests) and stamp.get("graph") == graph:
            return False
        for p in stale:
            for d in _cache_dirs([p]):
                for f in _cache_files(p, d):
                    try:
                        os.remove(f)
                    except OSError:
                        pass
        os.makedirs(stamp_dir, exist_ok=True)
        tmp = f"{stamp_path}.{os.getpid()}"
        with open(tmp, "w") as f:
            json.dump({"kernels": digests, "graph": graph}, f, indent=0, sort_keys=True)
        os.replace(tmp, stamp_path)
        return True
    except OSError:
        return False
