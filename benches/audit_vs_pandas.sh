#!/usr/bin/env bash
# Loading and auditing all shared NanoBench recordings: crossaudit's whole
# process against pandas.read_csv reading the same files, in the same run.
#
#   bash benches/audit_vs_pandas.sh [RUNS]
#
# Installs pandas into .venv-bench (PyPI) on first use.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
data=../shared/nanobench/recordings
[ -d "$data" ] || { echo "SKIPPED: $data is absent"; exit 0; }
if [ ! -x .venv-bench/bin/python ]; then
  python3 -m venv .venv-bench
  .venv-bench/bin/pip install -q pandas
fi
cargo build --release -q
out=$(mktemp -d)
.venv-bench/bin/python - "$runs" "$data" "$out" <<'PY'
import glob, statistics, subprocess, sys, time
import pandas as pd
runs, data, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
files = sorted(glob.glob(f"{data}/*.csv.gz"))
def crossaudit():
    subprocess.run(["target/release/crossaudit", "data", "audit", "designs/nanobench_confirmatory.design",
                    "--data", data, "--out", out], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
def pandas():
    rows = 0
    for f in files:
        rows += len(pd.read_csv(f))
    return rows
def timed(fn):
    t0 = time.perf_counter(); fn(); return time.perf_counter() - t0
crossaudit(); pandas()  # warm the page cache
ca = [timed(crossaudit) for _ in range(runs)]
pdt = [timed(pandas) for _ in range(runs)]
print(f"{len(files)} files, {pandas()} rows, {runs} runs each (median, min):")
print(f"  crossaudit data audit (whole process, load + audit): {statistics.median(ca):.3f} s, {min(ca):.3f} s")
print(f"  pandas.read_csv (load only, {pd.__version__}):            {statistics.median(pdt):.3f} s, {min(pdt):.3f} s")
print(f"  speed-up (median): {statistics.median(pdt) / statistics.median(ca):.1f}x")
PY
rm -rf "$out"
