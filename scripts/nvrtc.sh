#!/usr/bin/env bash
# NVIDIA's run-time compiler (NVRTC, CUDA 13) from PyPI into .venv-nvrtc,
# so that a machine without a GPU or CUDA toolkit can still compile the
# CUDA trainer's kernels (tests/batched.rs, the_gpu_kernels_compile_with_nvrtc).
# Prints the folder that holds libnvrtc.so.13, for LD_LIBRARY_PATH.
# About 70 MB to download; no GPU, driver or toolkit is needed or installed.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -x .venv-nvrtc/bin/python ]; then
  python3 -m venv .venv-nvrtc
fi
.venv-nvrtc/bin/python -c "import nvidia" 2>/dev/null || .venv-nvrtc/bin/pip install -q "nvidia-cuda-nvrtc==13.*" >&2
lib=$(dirname "$(find "$PWD/.venv-nvrtc" -name 'libnvrtc.so.13' | head -1)")
[ -f "$lib/libnvrtc.so.13" ] || { echo "nvrtc.sh: libnvrtc.so.13 was not installed" >&2; exit 1; }
echo "$lib"
