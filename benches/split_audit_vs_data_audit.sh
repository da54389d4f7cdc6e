#!/usr/bin/env bash
# Speed of `crossaudit audit split` on NanoBench's upstream task-2 split
# (107 files) against the plain data audit of the same folder under the same
# rules (designs/nanobench_upstream_split.design), interleaved run by run so
# that the machine's noise hits both alike. The split audit does everything
# the data audit does plus per-row hashes, the shared-run search and the
# reports, so the ratio is its overhead.
#
#   bash benches/split_audit_vs_data_audit.sh [RUNS] > results/benchmarks/split_audit_vs_data_audit.txt
set -euo pipefail
runs=${1:-11}
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=target/release/crossaudit
design=designs/nanobench_upstream_split.design
split=../shared/nanobench/upstream_task2_split_metadata.json
data=../shared/nanobench/recordings
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
now() { date +%s.%N; }
# One warm-up each (page cache).
$bin data audit $design --data $data --out "$tmp/a" > /dev/null 2>&1
$bin audit split $split --data $data --design $design --out "$tmp/s" > /dev/null 2>&1
: > "$tmp/times"
for k in $(seq 1 "$runs"); do
  t0=$(now); $bin data audit $design --data $data --out "$tmp/a" > /dev/null 2>&1; t1=$(now)
  $bin audit split $split --data $data --design $design --out "$tmp/s" > /dev/null 2>&1; t2=$(now)
  echo "$t0 $t1 $t2" >> "$tmp/times"
done
python3 - "$tmp/times" "$runs" <<'PY'
import statistics, sys
rows = [list(map(float, l.split())) for l in open(sys.argv[1])]
audit = [b - a for a, b, _ in rows]
split = [c - b for _, b, c in rows]
ratio = [s / a for a, s in zip(audit, split)]
print(f"runs: {sys.argv[2]} interleaved pairs (after one warm-up each); wall seconds, whole process")
print(f"data audit  (crossaudit data audit, 107 files):  median {statistics.median(audit):.3f} s  min {min(audit):.3f} s")
print(f"split audit (crossaudit audit split, same rules): median {statistics.median(split):.3f} s  min {min(split):.3f} s")
print(f"split / data, median of per-pair ratios: {statistics.median(ratio):.3f}  (range {min(ratio):.3f}..{max(ratio):.3f})")
PY
