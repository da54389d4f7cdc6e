#!/usr/bin/env bash
# One training cell of the paper's design (world, disjoint, seed 100), trained
# by crossaudit (dfdx) and by the PyTorch reference on the same exported
# windows and standardizer, with the same thread budget (1 thread each: one
# run worker). Installs torch into .venv-torch from PyPI on first use (~5 GB).
#
#   bash benches/reference/compare.sh [THREADS]
set -euo pipefail
cd "$(dirname "$0")/../.."
threads=${1:-1}
design=designs/nanobench_confirmatory.design
[ -d ../shared/nanobench/recordings ] || { echo "SKIPPED: ../shared/nanobench/recordings is absent"; exit 0; }
if [ ! -x .venv-torch/bin/python ]; then
  python3 -m venv .venv-torch
  .venv-torch/bin/pip install -q torch numpy
fi
cargo build --release -q --example export_cell
export_dir=target/reference-export
cargo run --release -q --example export_cell -- "$design" world disjoint 100 "$export_dir"
out=$(mktemp -d)
t0=$(date +%s.%N)
RAYON_NUM_THREADS=$threads target/release/crossaudit train "$design" --model world --arm disjoint --seed 100 --out "$out" > "$out/summary.txt" 2>/dev/null
t1=$(date +%s.%N)
torch_json=$(.venv-torch/bin/python benches/reference/torch_cell.py "$export_dir" "$threads")
python3 - "$out" "$t0" "$t1" "$torch_json" <<'PY'
import csv, json, sys
out, t0, t1, torch = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), json.loads(sys.argv[4])
rows = list(csv.DictReader(open(f"{out}/curves/world__disjoint__100.csv")))
epoch_s = sum(float(r["seconds"]) for r in rows) / len(rows)
summary = open(f"{out}/summary.txt").read()
timing = [l for l in summary.splitlines() if l.startswith("timing:")][0]
train_s = float(timing.split("training ")[1].split(" s")[0])
rollout_s = float(timing.split("rollouts ")[1].split(" s")[0])
n_fit, w = 16000, 256
macs = 18 * w + 2 * w * w + w * 14
ours = {"framework": "crossaudit (dfdx 0.13)", "epochs": len(rows), "seconds_per_epoch": epoch_s,
        "seconds_per_cell": train_s, "rollout_seconds": rollout_s,
        "train_gflops": 6 * macs * n_fit / epoch_s / 1e9,
        "best_val_loss": min(float(r["val_loss"]) for r in rows)}
print(f"threads per cell: {torch['threads']}; whole crossaudit train process: {t1 - t0:.1f} s")
print("| | crossaudit (dfdx) | PyTorch | ratio |")
print("|---|---:|---:|---:|")
for k, label, fmt in [("epochs", "epochs run (early stopping)", "{:.0f}"), ("seconds_per_epoch", "seconds per epoch", "{:.3f}"),
                      ("seconds_per_cell", "seconds per training cell (fit)", "{:.1f}"), ("rollout_seconds", "rollout seconds (1,300 starts x 200 steps)", "{:.3f}"),
                      ("train_gflops", "training GFLOP/s (6 x MACs x windows / epoch time)", "{:.1f}"), ("best_val_loss", "best validation loss", "{:.4f}")]:
    a, b = ours[k], torch[k]
    print(f"| {label} | {fmt.format(a)} | {fmt.format(b)} | {a / b:.2f} |")
PY
rm -rf "$out"
