#!/usr/bin/env bash
# One training cell of the paper's design (world, disjoint, seed 100), trained
# by crossaudit's fused trainer, by its dfdx reference trainer (bit-identical
# weights) and by the PyTorch reference on the same exported windows and
# standardizer, back to back, with the same thread budget (1 thread each: one
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
cargo build --release -q
cargo build --release -q --example export_cell
export_dir=target/reference-export
cargo run --release -q --example export_cell -- "$design" world disjoint 100 "$export_dir"
out=$(mktemp -d)
ref=$(mktemp -d)
t0=$(date +%s.%N)
RAYON_NUM_THREADS=$threads ${CARGO_TARGET_DIR:-target}/release/crossaudit train "$design" --model world --arm disjoint --seed 100 --out "$out" > "$out/summary.txt" 2>/dev/null
t1=$(date +%s.%N)
RAYON_NUM_THREADS=$threads ${CARGO_TARGET_DIR:-target}/release/crossaudit train "$design" --model world --arm disjoint --seed 100 --out "$ref" --engine reference > "$ref/summary.txt" 2>/dev/null
cmp "$out/models/world__disjoint__100.safetensors" "$ref/models/world__disjoint__100.safetensors" && cmp "$out/cells/world__disjoint__100.csv" "$ref/cells/world__disjoint__100.csv" && echo "fused and reference: weights and per-cell rows byte-identical"
torch_json=$(.venv-torch/bin/python benches/reference/torch_cell.py "$export_dir" "$threads")
python3 - "$out" "$ref" "$t0" "$t1" "$torch_json" <<'PY'
import csv, json, sys
out, ref, t0, t1, torch = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), json.loads(sys.argv[5])
def ours(d, name):
    rows = list(csv.DictReader(open(f"{d}/curves/world__disjoint__100.csv")))
    epoch_s = sum(float(r["seconds"]) for r in rows) / len(rows)
    summary = open(f"{d}/summary.txt").read()
    timing = [l for l in summary.splitlines() if l.startswith("timing:")][0]
    n_fit, w = 16000, 256
    macs = 18 * w + 2 * w * w + w * 14
    return {"framework": name, "epochs": len(rows), "seconds_per_epoch": epoch_s,
            "seconds_per_cell": float(timing.split("training ")[1].split(" s")[0]),
            "rollout_seconds": float(timing.split("rollouts ")[1].split(" s")[0]),
            "train_gflops": 6 * macs * n_fit / epoch_s / 1e9,
            "best_val_loss": min(float(r["val_loss"]) for r in rows)}
fused, dfdx = ours(out, "fused"), ours(ref, "dfdx")
print(f"threads per cell: {torch['threads']}; whole crossaudit train process (fused): {t1 - t0:.1f} s")
print(f"| | crossaudit fused | crossaudit dfdx reference | {torch['framework']} | fused / PyTorch |")
print("|---|---:|---:|---:|---:|")
for k, label, fmt in [("epochs", "epochs run (early stopping)", "{:.0f}"), ("seconds_per_epoch", "seconds per epoch", "{:.3f}"),
                      ("seconds_per_cell", "seconds per training cell (fit)", "{:.1f}"), ("rollout_seconds", "rollout seconds (1,300 starts x 200 steps)", "{:.3f}"),
                      ("train_gflops", "training GFLOP/s (6 x MACs x windows / epoch time)", "{:.1f}"), ("best_val_loss", "best validation loss", "{:.4f}")]:
    a, r, b = fused[k], dfdx[k], torch[k]
    print(f"| {label} | {fmt.format(a)} | {fmt.format(r)} | {fmt.format(b)} | {a / b:.2f} |")
PY
rm -rf "$out" "$ref"
