#!/usr/bin/env bash
# The whole protocol of a design (default: the shipped paper design, 80
# training jobs), by crossaudit (`run --workers 2`: two single-threaded
# workers, fused trainer) and by the PyTorch reference (two single-threaded
# worker processes, benches/reference/torch_protocol.py) on the same
# exported windows and standardizers, back to back on this machine.
# Installs torch into .venv-torch on first use. Prints a table; the
# committed output is results/benchmarks/protocol_vs_pytorch.txt.
#
#   bash benches/reference/protocol.sh [DESIGN]
set -euo pipefail
cd "$(dirname "$0")/../.."
design=${1:-designs/nanobench_confirmatory.design}
[ -d ../shared/nanobench/recordings ] || { echo "SKIPPED: ../shared/nanobench/recordings is absent"; exit 0; }
if [ ! -x .venv-torch/bin/python ]; then
  python3 -m venv .venv-torch
  .venv-torch/bin/pip install -q torch numpy
fi
cargo build --release -q
cargo build --release -q --example export_cell --example fma_peak
root=target/reference-export/protocol
rm -rf "$root"
seeds=$(target/release/crossaudit check "$design" --json | python3 -c 'import json,sys; print(",".join(str(s) for s in json.load(sys.stdin)["plan"]["seeds"]))')
first_seed=${seeds%%,*}
for model in world relative; do
  for arm in disjoint contaminated; do
    target/release/examples/export_cell "$design" $model $arm "$first_seed" "$root/${model}__${arm}" 2>/dev/null
  done
done
peak=$(target/release/examples/fma_peak)
echo "$peak"
out=$(mktemp -d)
echo "commit $(git rev-parse --short HEAD)$(git diff --quiet || echo " (with uncommitted changes)"); design: $design; seeds: $seeds; CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2)"
t0=$(date +%s.%N)
target/release/crossaudit run "$design" --out "$out" --workers 2 > "$out/stdout.txt" 2>&1
t1=$(date +%s.%N)
torch_json=$(.venv-torch/bin/python benches/reference/torch_protocol.py "$root" "$seeds" 2)
python3 - "$out" "$t0" "$t1" "$torch_json" "$root" "$peak" <<'PY'
import csv, glob, json, re, sys
out, t0, t1, torch, root = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), json.loads(sys.argv[4]), sys.argv[5]
found = re.search(r"avx512 f32 fma peak, one core: ([0-9.]+)", sys.argv[6])
peak = float(found.group(1)) if found else None
epochs, seconds = [], 0.0
for f in glob.glob(f"{out}/curves/*.csv"):
    rows = list(csv.DictReader(open(f)))
    epochs.append(len(rows))
    seconds += sum(float(r["seconds"]) for r in rows)
meta = json.load(open(glob.glob(f"{root}/*/cell.json")[0]))
w, n_fit = meta["widths"][0], meta["n_fit"]
macs = 18 * w + 2 * w * w + w * 14
per_epoch = seconds / sum(epochs)
ours = {"wall_seconds": t1 - t0, "mean_epochs": sum(epochs) / len(epochs), "seconds_per_epoch": per_epoch,
        "train_gflops": 6 * macs * n_fit / per_epoch / 1e9}
print(f"| | crossaudit (fused, gemm 0.19) | {torch['framework']} | ratio |")
print("|---|---:|---:|---:|")
print(f"| jobs x workers | {len(epochs)} x 2 | {torch['jobs']} x {torch['workers']} | |")
for key, label, fmt in [("wall_seconds", "whole protocol, wall s", "{:.0f}"),
                        ("mean_epochs", "mean epochs to early stopping", "{:.1f}"),
                        ("seconds_per_epoch", "seconds per epoch (one thread)", "{:.3f}"),
                        ("train_gflops", "training GFLOP/s per worker", "{:.1f}")]:
    a, b = ours[key], torch[key]
    print(f"| {label} | {fmt.format(a)} | {fmt.format(b)} | {a / b:.2f} |")
if peak:
    print(f"| training GFLOP/s as a share of the AVX-512 FMA peak ({peak:.0f}) | {ours['train_gflops'] / peak:.0%} | {torch['train_gflops'] / peak:.0%} | |")
PY
rm -rf "$out"
