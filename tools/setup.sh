#!/usr/bin/env bash
# Set up mapush from nothing: a virtual environment in .venv with mapush (editable) and its test tools.
# Needs only Python >= 3.11. Re-running it is cheap: pip skips what is installed.
#   PYTHON=python3.12 bash tools/setup.sh      # choose the interpreter
#   PIP_EXTRA="--extra-index-url URL" ...       # e.g. a CPU-only PyTorch index on machines without one locally
#   EXTRAS=test,ray bash tools/setup.sh          # mapush's extras (default: test); ray: launcher=ray, ~350 MB, ~35 s
#   TORCH=cpu|cuda bash tools/setup.sh           # PyTorch's build (default auto: CUDA where an NVIDIA driver answers)
#   bash tools/setup.sh --torch-build            # print the build auto would choose here, install nothing
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
TORCH_VERSION=2.13.0
CPU_INDEX=https://download.pytorch.org/whl/cpu  # PyTorch's own index of CPU builds (PyPI's Linux wheels are CUDA's)

# The PyTorch build for this machine: CUDA where `nvidia-smi -L` lists a GPU, else the CPU build, which is a
# tenth of the download; TORCH=cpu or TORCH=cuda decides instead.
torch_build() {
  case "${TORCH:-auto}" in
    cpu | cuda) echo "$TORCH" ;;
    auto) if command -v nvidia-smi >/dev/null 2>&1 && nvidia-smi -L >/dev/null 2>&1; then echo cuda; else echo cpu; fi ;;
    *) echo "setup: TORCH=${TORCH} is not valid; valid: auto, cpu, cuda" >&2; return 2 ;;
  esac
}
if [ "${1:-}" = "--torch-build" ]; then
  torch_build
  exit
fi
build=$(torch_build)
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
# torch first and pinned, in the chosen build: an unpinned torch makes pip pull several GB of CUDA packages on Linux.
# The CPU build (version +cpu) comes from where pip's own configuration finds it (a local wheel, a mirror), else
# from CPU_INDEX; its dependencies come from the usual index either way.
if [ "$build" = cuda ]; then
  .venv/bin/python -m pip install -q ${PIP_EXTRA:-} "torch==$TORCH_VERSION"
elif ! .venv/bin/python -m pip install -q ${PIP_EXTRA:-} "torch==$TORCH_VERSION+cpu" 2>/dev/null; then
  .venv/bin/python -m pip install -q --extra-index-url "$CPU_INDEX" ${PIP_EXTRA:-} "torch==$TORCH_VERSION+cpu"
fi
.venv/bin/python -m pip install -q ${PIP_EXTRA:-} -e ".[${EXTRAS:-test}]"
.venv/bin/python -c "import mujoco, rsl_rl, hydra, ompl, mcap, torch; print('mapush setup ok: torch', torch.__version__, '| mujoco', mujoco.__version__)"
