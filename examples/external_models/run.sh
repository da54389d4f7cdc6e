#!/usr/bin/env bash
# Bring your own model, end to end: export the paper design's windows, fit a
# GRU and a physics-residual model on them in PyTorch, score their rollouts
# with crossaudit. Run from the repository root:
#
#   bash examples/external_models/run.sh [OUT] [cpu|cuda]
#
# PyTorch and NumPy are installed into .venv-torch (ignored by git) the
# first time; crossaudit itself never depends on them. On a 2-core CPU the
# 40 trainings take about an hour; on one GPU about a minute.
set -euo pipefail
cd "$(dirname "$0")/../.."
out="${1:-out/paper_external}"
device="${2:-cpu}"
design=designs/external/paper_external.design
if [ ! -x .venv-torch/bin/python ]; then
  python3 -m venv .venv-torch
  .venv-torch/bin/pip install --quiet numpy torch
fi
cargo build --release --quiet
bin="${CARGO_TARGET_DIR:-target}/release/crossaudit"
"$bin" export "$design" --out "$out"
(cd examples/external_models && ../../.venv-torch/bin/python train.py "../../$out" --device "$device" --threads 1)
"$bin" score "$out"
