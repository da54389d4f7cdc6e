#!/usr/bin/env bash
# The README's install, checked from a fresh clone of this repository's
# HEAD, as a new user meets it:
#   1. `cargo install --locked --path . --root ROOT` must build with the
#      versions in Cargo.lock (no "Locking N packages to latest compatible
#      versions", and Cargo.lock unchanged afterwards);
#   2. the README's main job, `cargo run --release -- run
#      designs/quickstart.design --out out/quickstart`, must then compile
#      nothing: `cargo install --path` builds in the clone's target/ with the
#      release profile, which `cargo run --release` reuses;
#   3. the installed `crossaudit` writes the same cells.csv as `cargo run`;
#   4. with --python, `pip install ./python` (the optional package) is timed;
#   5. with --tests, the README's test command, `bash scripts/test.sh`, is
#      timed from the same clone (its build shares the release profile with
#      step 1), with ../shared linked beside the clone when this checkout
#      has it, so the tests that need the NanoBench logs run.
# Prints each step's wall time and the CPU, for results/install/.
#
#   bash scripts/fresh_clone.sh [--python] [--tests] > results/install/fresh_clone.txt
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
python=no
tests=no
for a in "$@"; do
  case "$a" in
    --python) python=yes ;;
    --tests) tests=yes ;;
    *) echo "fresh_clone.sh: unknown option $a" >&2; exit 2 ;;
  esac
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
unset CARGO_TARGET_DIR
fail() { echo "fresh_clone.sh: FAILED: $*" >&2; exit 1; }

echo "commit: $(git -C "$repo" rev-parse --short HEAD)"
echo "cpu: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ //'), $(nproc) cores, avx512f: $(grep -qo avx512f /proc/cpuinfo && echo yes || echo no)"
echo "cargo: $(cargo --version)"
git clone --quiet "$repo" "$work/crossaudit"
cd "$work/crossaudit"
lock_before=$(sha256sum Cargo.lock)

t0=$(date +%s)
cargo install --locked --path . --root "$work/root" 2> "$work/install.log" || { tail -20 "$work/install.log"; fail "cargo install"; }
t1=$(date +%s)
compiled=$(grep -c '^ *Compiling ' "$work/install.log" || true)
echo "cargo install --locked --path .: $((t1 - t0)) s, $compiled crates compiled"
grep -q 'Locking .* latest compatible' "$work/install.log" && fail "cargo install re-resolved the dependencies"
[ "$(sha256sum Cargo.lock)" = "$lock_before" ] || fail "Cargo.lock changed"
echo "Cargo.lock: used as committed (no re-resolution)"

t0=$(date +%s)
cargo run --release -- run designs/quickstart.design --out out/quickstart > "$work/run.out" 2> "$work/run.log" ||
  { tail -20 "$work/run.log"; fail "cargo run --release"; }
t1=$(date +%s)
recompiled=$(grep -c '^ *Compiling ' "$work/run.log" || true)
echo "cargo run --release -- run designs/quickstart.design: $((t1 - t0)) s, $recompiled crates compiled"
[ "$recompiled" = 0 ] || { grep '^ *Compiling ' "$work/run.log"; fail "cargo run --release compiled again"; }
tail -1 "$work/run.out"

"$work/root/bin/crossaudit" run designs/quickstart.design --out out/installed > /dev/null 2>&1 || fail "installed crossaudit run"
cmp -s out/quickstart/cells.csv out/installed/cells.csv || fail "the installed binary's cells.csv differs from cargo run's"
cmp -s out/quickstart/cells.csv results/quickstart/cells.csv || fail "the fresh clone's cells.csv differs from the committed one"
echo "installed crossaudit: the same cells.csv as cargo run and as results/quickstart/cells.csv"

if [ "$python" = yes ]; then
  python3 -m venv "$work/venv"
  "$work/venv/bin/pip" install --quiet --upgrade pip
  t0=$(date +%s)
  "$work/venv/bin/pip" install --quiet ./python || fail "pip install ./python"
  t1=$(date +%s)
  echo "pip install ./python (maturin, the release profile cargo install built): $((t1 - t0)) s"
  "$work/venv/bin/python" -c 'import crossaudit; print("import crossaudit: build", crossaudit.build())'
fi
if [ "$tests" = yes ]; then
  [ -d "$repo/../shared" ] && ln -s "$(cd "$repo/../shared" && pwd)" "$work/shared"
  t0=$(date +%s)
  bash scripts/test.sh > "$work/test.out" 2>&1 || { tail -30 "$work/test.out"; fail "bash scripts/test.sh"; }
  t1=$(date +%s)
  built=$(grep -c '^ *Compiling ' "$work/test.out" || true)
  build_s=$(grep -oE 'Finished .* in [0-9.]+(s|m [0-9]+s)' "$work/test.out" | head -1)
  echo "bash scripts/test.sh (build and run): $((t1 - t0)) s, $built crates compiled ($build_s)"
  tail -1 "$work/test.out"
fi
echo "fresh_clone.sh: OK"
