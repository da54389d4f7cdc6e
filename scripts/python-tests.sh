#!/usr/bin/env bash
# The Python package's tests: a fresh virtual environment, the package
# built from python/ by maturin (PEP 517, through pip) and installed with
# its test extra, then pytest on python/tests (the simulated quickstart with
# a NumPy ridge model through export, score and analyze; no torch).
#
#   bash scripts/python-tests.sh            # venv in target/python-venv
#
# The wheel is built with the release profile, sharing scripts/test.sh's build (CARGO_TARGET_DIR
# is honoured); the venv lives under the target directory.
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
case "$target" in /*) ;; *) target="$PWD/$target" ;; esac
venv="$target/python-venv"
rm -rf "$venv"
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --upgrade pip
t0=$(date +%s)
"$venv/bin/pip" install --quiet "./python[test]"
echo "python-tests: built and installed the package in $(( $(date +%s) - t0 )) s"
# The command line built by `cargo test`, for comparisons: the newer of the
# debug and release builds (an older one may predate the package's source).
unset CROSSAUDIT_BIN
for b in "$target/debug/crossaudit" "$target/release/crossaudit"; do
  if [ -x "$b" ] && { [ -z "${CROSSAUDIT_BIN:-}" ] || [ "$b" -nt "$CROSSAUDIT_BIN" ]; }; then
    CROSSAUDIT_BIN="$b"
  fi
done
[ -n "${CROSSAUDIT_BIN:-}" ] && export CROSSAUDIT_BIN
"$venv/bin/python" -m pytest -q python/tests
