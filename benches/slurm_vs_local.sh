#!/usr/bin/env bash
# Wall time of the quickstart study (designs/quickstart.design: 20 training
# jobs on simulated data) run locally (`crossaudit run --workers 2`) and
# through the real single-node Slurm of scripts/slurm-local.sh (`run --slurm
# --submit`, timed from the command to the end of the gather job: preparing,
# queueing, the 20 array tasks on the 2 CPUs, and gathering), interleaved
# pair by pair. Each pair also checks that cells.csv and the report are
# byte-identical. Needs root and the Debian packages slurm-wlm and munge.
#
#   bash benches/slurm_vs_local.sh [PAIRS] > results/benchmarks/slurm_vs_local.txt
set -euo pipefail
pairs=${1:-3}
cd "$(dirname "$0")/.."
cargo build --release --quiet
bin=$PWD/target/release/crossaudit
design=designs/quickstart.design
export CROSSAUDIT_SLURM_DIR=/tmp/crossaudit-slurm-bench
export PATH="/usr/sbin:/sbin:$PATH"
bash scripts/slurm-local.sh start 2> /dev/null
export SLURM_CONF=$CROSSAUDIT_SLURM_DIR/slurm.conf
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"; bash scripts/slurm-local.sh stop 2> /dev/null' EXIT
now() { date +%s.%N; }
echo "# benches/slurm_vs_local.sh $pairs on $(nproc) cores, crossaudit $($bin --version | cut -d' ' -f2-)"
echo "# $(sbatch --version); one node, $(sinfo -h -o '%c CPUs, %m MB')"
echo "pair local_s slurm_s ratio identical"
for k in $(seq 1 "$pairs"); do
  t0=$(now); $bin run $design --out "$tmp/local$k" --workers 2 > /dev/null 2>&1; t1=$(now)
  ids=$($bin run $design --out "$tmp/slurm$k" --slurm --submit --mem 2G 2> /dev/null)
  while squeue -h -j "${ids// /,}" 2> /dev/null | grep -q .; do sleep 0.1; done
  t2=$(now)
  same=yes
  for f in cells.csv report/report.md report/results.json report/results.tex; do
    cmp -s "$tmp/local$k/$f" "$tmp/slurm$k/$f" || same="no ($f)"
  done
  python3 -c "import sys; a,b,c=map(float,sys.argv[1:4]); print(f'{sys.argv[4]} {b-a:.2f} {c-b:.2f} {(c-b)/(b-a):.1f} {sys.argv[5]}')" \
    "$t0" "$t1" "$t2" "$k" "$same"
done
# Where the Slurm time goes: each task's own work against the scheduler's.
echo "# per task in the last pair: seconds of work reported by 'crossaudit job' (mean, max)"
grep -h "finished in" "$tmp/slurm$pairs"/slurm/logs/task-*.out \
  | sed 's/.*finished in \([0-9.]*\) s.*/\1/' \
  | python3 -c "import sys; v=[float(x) for x in sys.stdin]; print(f'{len(v)} tasks: mean {sum(v)/len(v):.2f} s, max {max(v):.2f} s')"
