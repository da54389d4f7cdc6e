#!/usr/bin/env bash
# Analysis at scale: `crossaudit analyze` of a per-cell file of
# I x J x 2 rows (benches/scale/scale.design: by default 2,000 recordings x
# 250 seeds x 2 arms = 1,000,000 rows, one endpoint, B = 1,999 pigeonhole
# replicates, grouped by conditions, leave-one-out of every recording and
# every seed), whole process, wall time, CPU share and peak memory, at
# each thread count (`--threads`), beside, in the same run and at the same
# thread counts:
#   - pandas reading the file and grouping it by recording x seed x arm,
#     with its C engine (one thread) and with engine="pyarrow"
#     (pyarrow.set_cpu_count and set_io_thread_count to the thread count);
#   - polars read_csv + group_by (POLARS_MAX_THREADS, in its own process);
# and the same cells written as Parquet by pyarrow: crossaudit analyze of
# that file beside pandas read_parquet + groupby.
# Median and min of RUNS each. Also checks that every thread count wrote
# the same report bytes.
#
#   bash benches/analyze_scale.sh [RUNS] [I] [J] [THREADS...]
#
# Installs pandas, pyarrow and polars into .venv-bench (PyPI) on first use.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-5}
rec=${2:-2000}
seeds=${3:-250}
shift $(($# < 3 ? $# : 3))
threads=("$@")
[ ${#threads[@]} -gt 0 ] || threads=(1 $(nproc))
if [ ! -x .venv-bench/bin/python ] || ! .venv-bench/bin/python -c "import pandas, pyarrow, polars" 2>/dev/null; then
  python3 -m venv .venv-bench
  .venv-bench/bin/pip install -q pandas pyarrow polars
fi
cargo build --release -q
ca=${CARGO_TARGET_DIR:-target}/release/crossaudit
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
design=benches/scale/scale.design
if [ "$rec" != 2000 ] || [ "$seeds" != 250 ]; then
  # At most the design limit of 2e9 resampled cells: B x I x J.
  b=$(( 2000000000 / (rec * seeds) < 1999 ? 2000000000 / (rec * seeds) : 1999 ))
  sed -e "s/evaluation 2000/evaluation $rec/" -e "s/seed = 1..250/seed = 1..$seeds/" \
    -e "s/pigeonhole 1999/pigeonhole $b/" "$design" > "$work/scale.design"
  design=$work/scale.design
  echo "B = $b pigeonhole replicates (the design limit of 2e9 resampled cells)"
fi
python3 benches/scale/cells.py "$work/cells.csv" "$rec" "$seeds"
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, avx512f: $(grep -qo avx512f /proc/cpuinfo && echo yes || echo no); commit $(git rev-parse --short HEAD)"
echo "file: $(($(wc -l < "$work/cells.csv") - 1)) rows, $(du -m "$work/cells.csv" | cut -f1) MB ($rec recordings x $seeds seeds x 2 arms)"
.venv-bench/bin/python - "$runs" "$ca" "$design" "$work" "${threads[@]}" <<'PY'
import os, statistics, subprocess, sys, time
import pandas as pd, pyarrow, polars
runs, ca, design, work = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
threads = [int(t) for t in sys.argv[5:]]
cells = f"{work}/cells.csv"
def crossaudit(n, cells=cells, out="report"):
    def run():
        r = subprocess.run(["/usr/bin/time", "-f", "%M %P", ca, "--threads", str(n), "analyze", design, "--cells", cells,
                            "--out", f"{work}/{out}-{n}"], check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        kb, cpu = r.stderr.strip().splitlines()[-1].split()
        return int(kb), cpu, r.stdout.strip().splitlines()[-1]
    return run
def pandas(engine, n):
    def run():
        if engine == "pyarrow":
            pyarrow.set_cpu_count(n); pyarrow.set_io_thread_count(n)
        df = pd.read_csv(cells, engine=engine)
        return df.groupby(["recording", "seed", "arm"])["fa_position_rmse_m"].mean().unstack("arm")
    return run
POLARS = """
import sys, time, polars as pl
t0 = time.perf_counter()
df = pl.read_csv(sys.argv[1])
g = df.group_by(["recording", "seed", "arm"]).agg(pl.col("fa_position_rmse_m").mean())
print(time.perf_counter() - t0, pl.thread_pool_size())
"""
def polars_in(n):
    def run():
        r = subprocess.run([sys.executable, "-c", POLARS, cells], env={**os.environ, "POLARS_MAX_THREADS": str(n)},
                           check=True, stdout=subprocess.PIPE, text=True)
        t, size = r.stdout.split()
        assert int(size) == n, (size, n)
        return float(t)
    return run
def timed(fn):
    t0 = time.perf_counter(); out = fn(); return time.perf_counter() - t0, out
print(f"{runs} runs each (median, min); crossaudit and polars as whole processes, pandas in one process")
for n in threads:
    crossaudit(n)(); pandas("pyarrow", n)()  # warm the page cache
    ca_runs = [timed(crossaudit(n)) for _ in range(runs)]
    pa_runs = [timed(pandas("pyarrow", n))[0] for _ in range(runs)]
    pc_runs = [timed(pandas("c", n))[0] for _ in range(runs)] if n == threads[0] else None
    pl_runs = [polars_in(n)() for _ in range(runs)]
    ca_t = [t for t, _ in ca_runs]
    mem = max(m for _, (m, _, _) in ca_runs)
    cpu = statistics.median(int(c.rstrip("%")) for _, (_, c, _) in ca_runs)
    med = statistics.median
    print(f"{n} thread(s):")
    print(f"  crossaudit analyze --threads {n} (read, full sensitivity set, reports): {med(ca_t):.2f} s, {min(ca_t):.2f} s; CPU {cpu}%; peak RSS {mem / 1024:.0f} MB")
    print(f"  pandas {pd.__version__} engine=pyarrow ({pyarrow.__version__}), read_csv + groupby mean: {med(pa_runs):.2f} s, {min(pa_runs):.2f} s")
    if pc_runs:
        print(f"  pandas {pd.__version__} C engine (one thread), read_csv + groupby mean:      {med(pc_runs):.2f} s, {min(pc_runs):.2f} s")
    print(f"  polars {polars.__version__} read_csv + group_by mean (own process):            {med(pl_runs):.2f} s, {min(pl_runs):.2f} s")
    print(f"  ratio crossaudit / pandas-pyarrow: {med(ca_t) / med(pa_runs):.2f}; crossaudit / polars: {med(ca_t) / med(pl_runs):.2f}")
print(f"  {ca_runs[0][1][2]}")
# The same cells as Parquet, written by pyarrow (as a user's own per-cell
# table would be): crossaudit reads its columns; pandas reads it with
# pyarrow.
import pyarrow.csv, pyarrow.parquet
parquet = f"{work}/cells.parquet"
pyarrow.parquet.write_table(pyarrow.csv.read_csv(cells), parquet)
def pandas_parquet(n):
    def run():
        pyarrow.set_cpu_count(n); pyarrow.set_io_thread_count(n)
        df = pd.read_parquet(parquet)
        return df.groupby(["recording", "seed", "arm"])["fa_position_rmse_m"].mean().unstack("arm")
    return run
print(f"the same cells as Parquet (pyarrow {pyarrow.__version__}, {os.path.getsize(parquet) // 2**20} MB):")
for n in threads:
    crossaudit(n, parquet, "parquet")()
    cq = [timed(crossaudit(n, parquet, "parquet")) for _ in range(runs)]
    pq = [timed(pandas_parquet(n))[0] for _ in range(runs)]
    cq_t = [t for t, _ in cq]
    mem = max(m for _, (m, _, _) in cq)
    cpu = statistics.median(int(c.rstrip("%")) for _, (_, c, _) in cq)
    print(f"{n} thread(s):")
    print(f"  crossaudit analyze --threads {n} --cells cells.parquet: {med(cq_t):.2f} s, {min(cq_t):.2f} s; CPU {cpu}%; peak RSS {mem / 1024:.0f} MB")
    print(f"  pandas {pd.__version__} read_parquet + groupby mean:              {med(pq):.2f} s, {min(pq):.2f} s")
    same = open(f"{work}/parquet-{n}/estimates.csv", "rb").read() == open(f"{work}/report-{n}/estimates.csv", "rb").read()
    print(f"  estimates.csv the same as the CSV file's: {'yes' if same else 'NO'}")
PY
python3 benches/scale/same_reports.py "$work" "${threads[@]}"
