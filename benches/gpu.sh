#!/usr/bin/env bash
# The batched trainer on a GPU beside the CPU and PyTorch, in one run (issue
# 74), on the built-in simulator (no NanoBench logs needed):
#   - benches/scale/gpu_paper_sim.design, the paper's protocol: 80 jobs
#     (20 seeds x 2 arms x 2 models), `run --device cuda` and `run --device
#     cpu --workers $(nproc)`;
#   - the same with 80 seeds: 320 jobs, the size of a per-seed multiverse's
#     training, on the GPU (the CPU's time for it is 4 times the 80 jobs');
#   - PyTorch training the same shapes batched on the same GPU
#     (benches/gpu/torch_batched.py), K = 80 and 320, fp32 and TF32.
# crossaudit's times are whole runs (data, split, training, rollouts,
# cells, report); PyTorch's are training and validation only.
#
#   bash benches/gpu.sh BIN        # BIN: a release crossaudit binary
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${1:?usage: bash benches/gpu.sh BIN}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores; $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null | head -1); crossaudit $("$bin" --version | cut -d' ' -f2-)"
timed() { # LABEL COMMAND...
  local t0 t1
  t0=$(date +%s%N)
  "${@:2}" > "$work/last.log" 2>&1 || { tail -20 "$work/last.log"; return 1; }
  t1=$(date +%s%N)
  awk -v l="$1" -v ns=$((t1 - t0)) 'BEGIN { printf "%-48s %7.1f s\n", l, ns / 1e9 }'
}
sed 's/factor seed = 1..20/factor seed = 1..80/' benches/scale/gpu_paper_sim.design > "$work/gpu_paper_sim_320.design"
timed "crossaudit 80 jobs, --device cuda" "$bin" run benches/scale/gpu_paper_sim.design --out "$work/cuda80" --device cuda --exploratory
timed "crossaudit 320 jobs, --device cuda" "$bin" run "$work/gpu_paper_sim_320.design" --out "$work/cuda320" --device cuda --exploratory
timed "crossaudit 80 jobs, --device cpu --workers $(nproc)" "$bin" run benches/scale/gpu_paper_sim.design --out "$work/cpu80" --device cpu --workers "$(nproc)" --exploratory
if python3 -c "import torch; assert torch.cuda.is_available()" 2>/dev/null; then
  for k in 80 320; do
    python3 benches/gpu/torch_batched.py "$k" 100
    python3 benches/gpu/torch_batched.py "$k" 100 --tf32
  done
else
  echo "PyTorch with CUDA is not installed here: its times are not measured"
fi
echo "verdicts (80 jobs): cuda: $(grep -m1 '^decision' "$work/cuda80/report/report.md" || true)"
echo "                    cpu:  $(grep -m1 '^decision' "$work/cpu80/report/report.md" || true)"
