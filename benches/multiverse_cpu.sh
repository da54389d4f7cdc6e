#!/usr/bin/env bash
# The CPU share of whole multiverse runs with 2 workers (issue 40: at or
# above 185% on a quiet machine): `crossaudit run --workers 2` of
#   benches/scale/multiverse_cpu.design        (simulated logs, 4 specifications x 12 jobs)
#   benches/scale/paper_multiverse_cpu.design  (the NanoBench logs, 8 specifications x 8 jobs)
# wall time and CPU share (/usr/bin/time %P), RUNS runs each. With
# BASELINE=/path/to/an/older/crossaudit the same runs of that build go
# beside them, interleaved, and the cells of both are compared.
#
#   BASELINE=/tmp/crossaudit_before bash benches/multiverse_cpu.sh [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-1}
cargo build --release -q
ca=${CARGO_TARGET_DIR:-target}/release/crossaudit
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "machine: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores; commit $(git rev-parse --short HEAD)${BASELINE:+; baseline: $($BASELINE --version)}"
for design in benches/scale/multiverse_cpu.design benches/scale/paper_multiverse_cpu.design; do
  echo "## $design"
  for r in $(seq "$runs"); do
    for build in ${BASELINE:+baseline} this; do
      bin=$ca; [ "$build" = baseline ] && bin=$BASELINE
      rm -rf "$work/$build"
      t=$({ /usr/bin/time -f '%e s wall, CPU %P' "$bin" run "$design" --out "$work/$build" --workers 2 --exploratory >/dev/null; } 2>&1 | tail -1)
      echo "  $build: $t"
    done
    if [ -n "${BASELINE:-}" ]; then
      a=$(cd "$work/baseline" && find . -name cells.csv | sort | xargs cat | sha256sum | cut -c1-16)
      b=$(cd "$work/this" && find . -name cells.csv | sort | xargs cat | sha256sum | cut -c1-16)
      [ "$a" = "$b" ] && echo "  every level's cells.csv identical ($a)" || echo "  CELLS DIFFER: $a vs $b"
    fi
  done
done
