#!/usr/bin/env bash
# A large multiverse's analysis: `crossaudit analyze` of a synthetic run
# directory of 256 specifications (benches/scale/multiverse.design: eight
# two-way choices), each 200 evaluation recordings x 50 seeds x 2 arms,
# 5,120,000 cells in all. Every specification's full analysis (B = 1,999
# pigeonhole replicates, grouped, leave-one-out both ways), the choice
# effects, the joint bootstrap with simultaneous bands and the curve under
# the null, and the reports. Whole process, wall time, CPU share and peak
# memory, median and min of RUNS, at each thread count (`--threads`;
# default 1 and every core), and whether every count wrote the same bytes.
#
#   bash benches/multiverse_scale.sh [RUNS] [THREADS...]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
shift $(($# < 1 ? $# : 1))
threads=("$@")
[ ${#threads[@]} -gt 0 ] || threads=(1 $(nproc))
cargo build --release -q
ca=${CARGO_TARGET_DIR:-target}/release/crossaudit
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 benches/scale/multiverse.py "$work/run" benches/scale/multiverse.design
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, avx512f: $(grep -qo avx512f /proc/cpuinfo && echo yes || echo no); commit $(git rev-parse --short HEAD)"
echo "run: $(ls -d "$work"/run/spec-* | wc -l) specifications, $(cat "$work"/run/spec-*/cells.csv | grep -vc '^model,') cells, $(du -sm "$work/run" | cut -f1) MB"
python3 - "$runs" "$ca" "$work" "${threads[@]}" <<'PY'
import statistics, subprocess, sys, time
runs, ca, work = int(sys.argv[1]), sys.argv[2], sys.argv[3]
threads = [int(t) for t in sys.argv[4:]]
def once(n):
    t0 = time.perf_counter()
    r = subprocess.run(["/usr/bin/time", "-f", "%M %P", ca, "--threads", str(n), "analyze", "benches/scale/multiverse.design",
                        "--cells", f"{work}/run", "--out", f"{work}/report-{n}"],
                       check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    kb, cpu = r.stderr.strip().splitlines()[-1].split()
    return time.perf_counter() - t0, int(kb), cpu, r.stdout.strip().splitlines()[-1]
once(threads[-1])  # warm the page cache
medians = {}
print(f"{runs} runs each (median, min):")
for n in threads:
    out = [once(n) for _ in range(runs)]
    ts = [o[0] for o in out]
    medians[n] = statistics.median(ts)
    print(f"  crossaudit --threads {n} analyze (whole process: read 256 level folders, every analysis, joint bootstrap, reports): "
          f"{statistics.median(ts):.2f} s, {min(ts):.2f} s; peak RSS {max(o[1] for o in out) // 1024} MB; CPU {out[-1][2]}")
print(f"  speed-up at {threads[-1]} threads over {threads[0]}: {medians[threads[0]] / medians[threads[-1]]:.2f}x")
print(f"  {out[-1][3]}")
PY
python3 benches/scale/same_reports.py "$work" "${threads[@]}"
