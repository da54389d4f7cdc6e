#!/usr/bin/env bash
# Issue 56, class 2: the three algorithms a hostile corpus made super-linear,
# each at the documented limits, whole process (wall time and peak memory,
# /usr/bin/time), with the release build:
#   1. a `conditions name` pattern with four `{*}a` pieces against a file
#      name of 250 characters that it does not match (was over 100 s:
#      backtracking; now one pass per piece);
#   2. `grouped conditions` over 100,000 evaluation recordings (the most
#      `check` allows) x 3 seeds, every recording its own condition group
#      (20,000 took 28 s and 100,000 timed out: a search per group);
#   3. the per-cell reader on a 500 MB file of blank lines after its header
#      (needed 3.8 GB: 8 bytes per line kept).
#
#   bash benches/limits.sh > results/benchmarks/limits.txt
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
ca=$PWD/${CARGO_TARGET_DIR:-target}/release/crossaudit
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, avx512f: $(grep -qo avx512f /proc/cpuinfo && echo yes || echo no); commit $(git rev-parse --short HEAD)"
# Runs a command, expecting `want` (0: success, 1: a refusal); prints its
# wall time, peak memory and last line.
measure() {
  local what=$1 want=$2
  shift 2
  local rc=0
  /usr/bin/time -f "%e %M" -o "$work/time" "$@" > "$work/out" 2> "$work/err" || rc=$?
  read -r secs kb < <(tail -1 "$work/time")
  if [ "$rc" != "$want" ]; then
    echo "$what: exit $rc, expected $want" >&2
    cat "$work/err" >&2
    exit 1
  fi
  printf '%-58s %8.2f s %8d MB   %s\n' "$what" "$secs" $((kb / 1024)) "$(tail -1 "$work/err" | cut -c1-90)"
}

# 1. The pattern matcher.
mkdir -p "$work/logs"
name=$(printf 'a%.0s' $(seq 1 240))
cp tests/fixtures/rotorpy/logs/R1_circle_slow_rep1.csv.gz "$work/logs/${name}_x.csv.gz"
sed -e "s|path      \"../../tests/fixtures/rotorpy/logs\"|path \"$work/logs\"|" \
    -e 's|  controller se3|  controller se3\n  conditions name "{*}a{*}a{*}a{*}a{trajectory}-{speed}_take{rep}"|' \
    designs/logs/rotorpy.design > "$work/pattern.design"
measure "pattern, 4 x {*}a against a 250-character name" 1 \
  "$ca" data audit "$work/pattern.design" --out "$work/audit"

# 2. Grouped sensitivity at 100,000 recordings, one group each.
python3 benches/scale/cells.py "$work/cells.csv" 100000 3
python3 - "$work/cells.csv" <<'PY'
import sys
p = sys.argv[1]
lines = open(p).read().splitlines()
out = [lines[0]]
for l in lines[1:]:
    f = l.split(",")
    f[4] = "t" + f[3]  # every recording its own trajectory: 100,000 groups
    out.append(",".join(f))
open(p, "w").write("\n".join(out) + "\n")
PY
sed -e "s/evaluation 2000/evaluation 100000/" -e "s/cap 2 m/cap 10 m/" -e "s/seed = 1..250/seed = 1..3/" \
    -e "s/bootstrap pigeonhole 1999 seed 5; //" -e "s/leave_one_out seed, recording/leave_one_out recording/" \
    benches/scale/scale.design > "$work/grouped.design"
measure "grouped conditions, 100,000 groups x 3 seeds (600,000 rows)" 0 \
  "$ca" analyze "$work/grouped.design" --cells "$work/cells.csv" --out "$work/report"

# 3. The per-cell reader on 500 MB of blank lines.
head -1 "$work/cells.csv" > "$work/blank.csv"
head -c 524288000 /dev/zero | tr '\0' '\n' >> "$work/blank.csv"
measure "per-cell reader, 500 MB of blank lines" 1 \
  "$ca" analyze "$work/grouped.design" --cells "$work/blank.csv" --out "$work/report2"
