#!/usr/bin/env bash
# The GPU checks of the batched trainer (issue 74), in one script for a
# machine with an NVIDIA GPU and nothing to download: binaries built
# elsewhere (this repository's `cargo build --release` and the test binary
# of `cargo test --release --no-run --test main`), run here.
#   1. the kernels compile with NVRTC and the trainer's parity test: a
#      batch of jobs on the GPU, twice (bit-identical), against the CPU's
#      lockstep trainer within tests/batched.rs's stated tolerance, and a
#      batch that a job leaves when it stops early, twice (bit-identical);
#   2. the quickstart run on the CPU and twice on the GPU: the two GPU runs'
#      cells byte-identical, the GPU's verdict the CPU's, its estimates
#      within 2% of the CPU's (benches/gpu/compare.py); and as one Slurm
#      array task of every job (`--jobs-per-task`, run by sh, no Slurm
#      needed), its cells the GPU run's byte for byte;
#   3. the benchmark (benches/gpu.sh), unless SKIP_BENCH=1.
# Fails at the first check that fails (the comparison of step 2 after the
# benchmark has run, so that its times are still measured).
#
#   bash scripts/gpu-check.sh BIN TEST_BIN
#
# From a machine without a GPU, for a lent one (its `run` tool copies the
# working tree and the ignored paths named in `carry`; both binaries come
# to about 50 MB):
#   cargo build --release && cargo test --release --no-run --test main
#   mkdir -p gpu-bin && cp target/release/crossaudit gpu-bin/ &&
#     cp "$(ls -t target/release/deps/main-* | grep -v '\.d$' | head -1)" gpu-bin/main
#   then, there: bash scripts/gpu-check.sh gpu-bin/crossaudit gpu-bin/main
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${1:?usage: bash scripts/gpu-check.sh BIN TEST_BIN}")
tests=$(realpath "${2:?usage: bash scripts/gpu-check.sh BIN TEST_BIN}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
nvidia-smi -L
echo "== 1. kernels and parity (tests/batched.rs)"
for t in the_gpu_kernels_compile_with_nvrtc on_a_gpu_the_batch_is_reproducible_and_within_tolerance_of_the_cpu; do
  CROSSAUDIT_REQUIRE_NVRTC=1 "$tests" --exact "batched::$t" --nocapture 2>&1 | tee "$work/test.log"
  if grep -q SKIPPED "$work/test.log"; then echo "gpu-check: batched::$t was skipped: no GPU found" >&2; exit 1; fi
done
echo "== 2. the quickstart on the CPU and twice on the GPU"
"$bin" run designs/quickstart.design --out "$work/cpu" --device cpu > /dev/null 2>&1
for r in 1 2; do
  "$bin" run designs/quickstart.design --out "$work/cuda$r" --device cuda 2>&1 | tail -1
done
cmp "$work/cuda1/cells.csv" "$work/cuda2/cells.csv" && echo "GPU reruns: cells.csv byte-identical"
grep -q '"device": "cuda' "$work/cuda1/run.json" && echo "run.json records the device"
echo "== 2b. the quickstart as one Slurm array task of every job on the GPU (run by sh, as Slurm would)"
"$bin" run designs/quickstart.design --out "$work/task" --slurm --jobs-per-task 1000000 --device cuda > /dev/null 2>&1
SLURM_ARRAY_TASK_ID=0 sh "$work/task/slurm/array.sbatch" 2>&1 | grep -E "at once|task 0:"
"$bin" gather "$work/task" > /dev/null 2>&1
cmp "$work/cuda1/cells.csv" "$work/task/cells.csv" && echo "the task's cells.csv is the GPU run's, byte for byte"
failed=0
python3 benches/gpu/compare.py "$work/cpu" "$work/cuda1" 0.02 || failed=1
if [ "${SKIP_BENCH:-0}" != 1 ]; then
  echo "== 3. benchmark"
  bash benches/gpu.sh "$bin"
fi
[ "$failed" = 0 ] || { echo "gpu-check: the GPU run's verdict or estimates are not the CPU's (above)" >&2; exit 1; }
echo "gpu-check: every check passed"
