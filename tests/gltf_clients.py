"""The real glTF clients the exports are checked with (installed by ``setup.sh dev``):
the Khronos glTF-Validator under Node, and three.js in headless Chromium served on
127.0.0.1. Helpers for tests and ``benchmarks/gltf_export.py``; each ``*_available()``
says whether the client is installed so tests can skip with a reason."""

from __future__ import annotations

import contextlib
import functools
import html
import http.server
import json
import os
import re
import shutil
import subprocess
import threading

JS = os.path.join(os.path.dirname(__file__), "..", "tools", "js")


def validator_available() -> bool:
    return shutil.which("node") is not None and os.path.isdir(os.path.join(JS, "node_modules", "gltf-validator"))


def three_available() -> bool:
    return _chromium() is not None and os.path.isdir(os.path.join(JS, "node_modules", "three"))


def _chromium():
    return shutil.which("chromium") or shutil.which("chromium-browser")


def validate(path: str) -> dict:
    """The validator's report (a dict) for ``path``."""
    proc = subprocess.run(["node", os.path.join(JS, "validate.mjs"), os.path.abspath(path)],
                          capture_output=True, text=True, timeout=120)
    if proc.returncode not in (0, 1) or not proc.stdout.strip():
        raise RuntimeError(f"validator failed: {proc.stderr.strip()}")
    return json.loads(proc.stdout)


@contextlib.contextmanager
def _serve(directory_of_file: str):
    """Serve tools/js and the file's folder (as /files/) on 127.0.0.1, a free port."""
    files = os.path.abspath(directory_of_file)

    class Handler(http.server.SimpleHTTPRequestHandler):
        def translate_path(self, path):
            path = path.split("?", 1)[0]
            if path.startswith("/files/"):
                return os.path.join(files, os.path.basename(path))
            return os.path.join(os.path.abspath(JS), path.lstrip("/"))

        def log_message(self, *args):
            pass

    Handler.extensions_map = {**http.server.SimpleHTTPRequestHandler.extensions_map, ".mjs": "text/javascript",
                              ".js": "text/javascript", ".glb": "model/gltf-binary"}
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Handler))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


def three_pose(path: str, times, clip: int = 0, screenshot: str | None = None, shot_time: float | None = None,
               size=(800, 640)) -> dict:
    """Load ``path`` in three.js in headless Chromium, pose ``clip`` at ``times`` and return
    {clip, duration, names, frames: [{t, pos (nb, 3), rot (nb, 4) xyzw}]} in glTF axes;
    with ``screenshot`` also write a PNG of the pose at ``shot_time``."""
    chromium = _chromium()
    with _serve(os.path.dirname(os.path.abspath(path))) as base:
        url = (f"{base}/three_pose.html?file=/files/{os.path.basename(path)}&clip={clip}"
               f"&times={','.join(repr(float(t)) for t in times)}")
        flags = [chromium, "--headless", "--no-sandbox", "--disable-dev-shm-usage", "--use-angle=swiftshader",
                 "--enable-unsafe-swiftshader", "--virtual-time-budget=20000", f"--window-size={size[0]},{size[1]}"]
        proc = subprocess.run(flags + ["--dump-dom", url], capture_output=True, text=True, timeout=180)
        m = re.search(r'<pre id="out">(.*?)</pre>', proc.stdout, re.S)
        if not m:
            raise RuntimeError(f"chromium gave no result: {proc.stderr[-500:]}")
        text = html.unescape(m.group(1))
        if text.startswith("ERROR") or text == "pending":
            raise RuntimeError(f"three.js: {text}")
        if screenshot:
            shot = shot_time if shot_time is not None else float(list(times)[0])
            subprocess.run(flags + [f"--screenshot={os.path.abspath(screenshot)}", url + f"&shot={shot!r}"],
                           capture_output=True, text=True, timeout=180)
        return json.loads(text)
