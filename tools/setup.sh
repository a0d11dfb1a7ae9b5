#!/usr/bin/env bash
# Set up mapush from nothing: a virtual environment in .venv with mapush (editable) and its test tools.
# Needs only Python >= 3.11. Re-running it is cheap: pip skips what is installed.
#   PYTHON=python3.12 bash tools/setup.sh      # choose the interpreter
#   PIP_EXTRA="--extra-index-url URL" ...       # e.g. a CPU-only PyTorch index on machines without one locally
#   EXTRAS=test,ray bash tools/setup.sh          # mapush's extras (default: test); ray: launcher=ray, ~350 MB, ~35 s
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
# Headless OpenGL for MuJoCo's renderer (videos; README "Videos and the viewer"): Mesa's EGL, software or GPU.
GL_PACKAGES="libegl1 libegl-mesa0 libopengl0 libgl1-mesa-dri"
missing=$(for p in $GL_PACKAGES; do dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || echo "$p"; done)
if [ -n "$missing" ] && command -v apt-get >/dev/null; then
  if [ "$(id -u)" = 0 ]; then
    { apt-get update -qq >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $missing >/dev/null; } ||
      echo "setup: warning: could not install" $missing "(videos will not render)"
  else
    echo "setup: videos need the Debian packages" $missing "(not root: skipped; install them with sudo apt-get install)"
  fi
fi
if [ ! -x .venv/bin/python ]; then
  "$PYTHON" -m venv .venv
fi
# torch first and pinned: an unpinned torch makes pip pull several GB of CUDA packages on Linux.
.venv/bin/python -m pip install -q ${PIP_EXTRA:-} "torch==2.13.0"
.venv/bin/python -m pip install -q ${PIP_EXTRA:-} -e ".[${EXTRAS:-test}]"
.venv/bin/python -c "import mujoco, rsl_rl, hydra, ompl, mcap, torch; print('mapush setup ok: torch', torch.__version__, '| mujoco', mujoco.__version__)"
