#!/usr/bin/env bash
# Set up Menagerie in a virtual environment .venv at the repository root.
#   bash setup.sh          runtime + viewer (numpy, numba, pyyaml, pyglet)
#   bash setup.sh grid     + the validation grid's batch tools (dask, matplotlib, tqdm)
#   bash setup.sh author   + the authoring tool's UI (imgui-bundle, PyOpenGL)
#   bash setup.sh dev      + test tools (pytest, hypothesis, ruff, pillow) and everything the
#                            tests exercise (the grid and author extras; Debian's chromium for
#                            the report test and xvfb for the real-window tests)
#   bash setup.sh bench    + reference peers for the benchmarks (ikpy, mujoco, pybullet)
# Needs only Python 3.11+ and the package registries. Offscreen rendering uses EGL
# (Mesa); when its libraries are missing and we are root, they are installed with apt.
set -euo pipefail
cd "$(dirname "$0")"

extras=""
for arg in "$@"; do
  case "$arg" in
    dev|bench|media|grid|author) extras="${extras:+$extras,}$arg" ;;
    *) echo "setup.sh: unknown option '$arg' (use dev, grid, author, bench or media)" >&2; exit 2 ;;
  esac
done

python=""
for candidate in python3.11 python3.12 python3.13 python3; do
  if command -v "$candidate" >/dev/null 2>&1 && \
     "$candidate" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)'; then
    python="$candidate"; break
  fi
done
[ -n "$python" ] || { echo "setup.sh: Python 3.11 or newer is needed" >&2; exit 1; }

[ -x .venv/bin/python ] || "$python" -m venv .venv
.venv/bin/python -m pip install --quiet --upgrade pip
spec="."
[ -n "$extras" ] && spec=".[$extras]"
pip_log="$(mktemp)"
if ! .venv/bin/python -m pip install --quiet -e "$spec" 2>"$pip_log"; then
  cat "$pip_log" >&2; rm -f "$pip_log"; exit 1
fi
# setuptools prints a notice block on every editable install ("Editable installation ...
# folders with the same name as your package"); it says nothing about Menagerie. Drop
# that block and pass on anything else pip said.
.venv/bin/python - "$pip_log" <<'PY'
import re
import sys

text = open(sys.argv[1], encoding="utf-8", errors="replace").read()
text = re.sub(r"[^\n]*BuildBackendWarning: Editable installation\.\n\s*!!\n(?:.*\n)*?\s*!!\n[^\n]*\n", "", text)
sys.stderr.write(text)
PY
rm -f "$pip_log"

# EGL for headless rendering (pyglet's headless mode). Debian/Ubuntu package names.
if ! ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1' || \
   ! ls /usr/lib/*/dri/swrast_dri.so /usr/lib/*/dri/*_dri.so >/dev/null 2>&1; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup.sh: installing EGL/Mesa for offscreen rendering"
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
      libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 libgles2 >/dev/null) || \
      echo "setup.sh: could not install EGL; offscreen rendering will be unavailable" >&2
  else
    echo "setup.sh: EGL/Mesa not found; install libegl1 libegl-mesa0 libgl1-mesa-dri for offscreen rendering" >&2
  fi
fi
# Tests open the grid's report in a real browser: Debian's chromium (headless).
if [[ ",$extras," == *",dev,"* ]] && ! command -v chromium >/dev/null 2>&1; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup.sh: installing chromium for the browser tests"
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) || \
      echo "setup.sh: could not install chromium; the browser tests will be skipped" >&2
  else
    echo "setup.sh: chromium not found; install it (apt-get install chromium) for the browser tests" >&2
  fi
fi
# Tests check glTF exports with real clients: the Khronos glTF-Validator and three.js (npm,
# into tools/js/node_modules; three.js runs in the headless chromium above).
if [[ ",$extras," == *",dev,"* ]]; then
  if command -v npm >/dev/null 2>&1; then
    (cd tools/js && npm install --no-audit --no-fund --silent) || \
      echo "setup.sh: could not install gltf-validator/three; the glTF client tests will be skipped" >&2
  else
    echo "setup.sh: npm not found; install nodejs and npm for the glTF client tests" >&2
  fi
fi
# Tests open the viewer and the authoring tool in a real window: Debian's Xvfb (a virtual
# X server) and xauth for xvfb-run.
if [[ ",$extras," == *",dev,"* ]] && ! command -v xvfb-run >/dev/null 2>&1; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
    echo "setup.sh: installing xvfb for the real-window tests"
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq xvfb xauth >/dev/null) || \
      echo "setup.sh: could not install xvfb; the real-window tests will be skipped" >&2
  else
    echo "setup.sh: xvfb not found; install it (apt-get install xvfb) for the real-window tests" >&2
  fi
fi
echo "setup.sh: ready (.venv${extras:+ with $extras})"
