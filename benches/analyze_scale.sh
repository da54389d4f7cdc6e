#!/usr/bin/env bash
# Analysis at scale: `crossaudit analyze` of a 1,000,000-row per-cell file
# (benches/scale/scale.design: 2,000 recordings x 250 seeds x 2 arms, one
# endpoint, B = 1,999 pigeonhole replicates, grouped by conditions,
# leave-one-out of every recording and every seed), whole process, wall
# time and peak memory, beside pandas reading the same file and grouping it
# by recording x seed x arm, in the same run. Median and min of RUNS each.
#
#   bash benches/analyze_scale.sh [RUNS] [I] [J]
#
# Installs pandas into .venv-bench (PyPI) on first use.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
rec=${2:-2000}
seeds=${3:-250}
if [ ! -x .venv-bench/bin/python ]; then
  python3 -m venv .venv-bench
  .venv-bench/bin/pip install -q pandas
fi
cargo build --release -q
ca=${CARGO_TARGET_DIR:-target}/release/crossaudit
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
design=benches/scale/scale.design
if [ "$rec" != 2000 ] || [ "$seeds" != 250 ]; then
  sed -e "s/evaluation 2000/evaluation $rec/" -e "s/seed = 1..250/seed = 1..$seeds/" "$design" > "$work/scale.design"
  design=$work/scale.design
fi
python3 benches/scale/cells.py "$work/cells.csv" "$rec" "$seeds"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, avx512f: $(grep -qo avx512f /proc/cpuinfo && echo yes || echo no); commit $(git rev-parse --short HEAD)"
echo "file: $(($(wc -l < "$work/cells.csv") - 1)) rows, $(du -m "$work/cells.csv" | cut -f1) MB ($rec recordings x $seeds seeds x 2 arms)"
.venv-bench/bin/python - "$runs" "$ca" "$design" "$work" <<'PY'
import statistics, subprocess, sys, time
import pandas as pd
runs, ca, design, work = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
cells = f"{work}/cells.csv"
def crossaudit():
    r = subprocess.run(["/usr/bin/time", "-f", "%M", ca, "analyze", design, "--cells", cells, "--out", f"{work}/report"],
                       check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return int(r.stderr.strip().splitlines()[-1]), r.stdout.strip().splitlines()[-1]
def pandas():
    df = pd.read_csv(cells)
    return df.groupby(["recording", "seed", "arm"])["fa_position_rmse_m"].mean().unstack("arm")
def timed(fn):
    t0 = time.perf_counter(); out = fn(); return time.perf_counter() - t0, out
crossaudit(); pandas()  # warm the page cache
ca_runs = [timed(crossaudit) for _ in range(runs)]
pd_runs = [timed(pandas) for _ in range(runs)]
ca_t = [t for t, _ in ca_runs]
pd_t = [t for t, _ in pd_runs]
mem = max(m for _, (m, _) in ca_runs)
print(f"{runs} runs each (median, min):")
print(f"  crossaudit analyze (whole process: read, full sensitivity set, reports): {statistics.median(ca_t):.2f} s, {min(ca_t):.2f} s; peak RSS {mem / 1024:.0f} MB")
print(f"  pandas {pd.__version__}: read_csv + groupby(recording, seed, arm).mean():    {statistics.median(pd_t):.2f} s, {min(pd_t):.2f} s")
print(f"  ratio (crossaudit / pandas, median): {statistics.median(ca_t) / statistics.median(pd_t):.2f}")
print(f"  {ca_runs[0][1][1]}")
PY
