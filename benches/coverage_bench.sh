#!/usr/bin/env bash
# 10,000 replications x all 7 interval estimators, B = 999 pigeonhole
# bootstraps each, at I = 26, J = 20: whole process.
#
#   bash benches/coverage_bench.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q
out=$(mktemp -d)
start=$(date +%s.%N)
target/release/crossaudit coverage specs/coverage_bench.json --out "$out" 2>/dev/null
end=$(date +%s.%N)
python3 -c "import sys; print(f'coverage: 10000 reps x 7 estimators, B = 999, I = 26, J = 20: {float(sys.argv[2]) - float(sys.argv[1]):.2f} s whole process')" "$start" "$end"
rm -rf "$out"
