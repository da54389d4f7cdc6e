#!/usr/bin/env bash
# The README's test command (CI runs it too): every test of both crates,
# the ones marked `#[ignore = "needs ../shared/nanobench"]` included, built
# with the release profile, so that it shares every compiled dependency
# and the crate itself with `cargo install --path .` and the README's
# `cargo run --release` (one build for the first day; docs/usage.md,
# "Tests", gives the measured costs), then
# one summary line: how many tests passed and failed, and how many of the
# passed only printed SKIPPED because something they need is absent (the
# NanoBench recordings, Slurm, chromium, a generated data folder), by what
# they need. A skipped test passes; CI makes the ones it provides for fail
# instead (CROSSAUDIT_REQUIRE_SHARED, CROSSAUDIT_REQUIRE_BROWSER).
# Usage: bash scripts/test.sh [extra arguments for the test binaries]
set -uo pipefail
cd "$(dirname "$0")/.."
target=${CARGO_TARGET_DIR:-target}
skips="$target/tmp/skipped.txt"
log="$target/test-output.txt"
mkdir -p "$target/tmp"
rm -f "$skips"
cargo test --release -p crossaudit -p crossaudit-stats -- --include-ignored "$@" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
sum() { grep -oE "test result: [A-Za-z]+\. [0-9]+ passed; [0-9]+ failed" "$log" | awk -v k="$1" '{s += $k} END {print s + 0}'; }
passed=$(sum 4)
failed=$(sum 6)
skipped=0
by=""
if [ -f "$skips" ]; then
  skipped=$(wc -l < "$skips")
  by=$(cut -f1 "$skips" | sort | uniq -c | awk '{n = $1; $1 = ""; sub(/^ /, ""); printf "%s%s %s", (NR > 1 ? ", " : ""), n, $0}')
fi
echo
if [ "$skipped" -gt 0 ]; then
  echo "tests: $passed passed, $failed failed; $skipped of the passed only printed SKIPPED (needs: $by; the lines above say which)"
else
  echo "tests: $passed passed, $failed failed; none skipped"
fi
exit "$rc"
