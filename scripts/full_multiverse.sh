#!/usr/bin/env bash
# One multiverse or draw-replicated run, in a scratch directory and copied
# into results/:
#   bash scripts/full_multiverse.sh DESIGN RESULTS_DIR [BINARY]
# Runs `crossaudit run DESIGN --out /tmp/full_NAME/run --workers 2` under
# /usr/bin/time (a rerun resumes every finished job), then copies each
# level's committed parts (cells.csv, report/, run.json, audit/,
# curves/, manifests/manifests.json; a level that shares another's run has
# report/ only), the top-level multiverse_cells.csv and report/, stdout.txt
# and time.txt into RESULTS_DIR, and runs the R recomputation
# (scripts/reference/multiverse_check.R) into RESULTS_DIR/reference/.
# Model weights, job records and manifest CSVs are not committed.
set -euo pipefail
cd "$(dirname "$0")/.."
design=$1; dest=$2; ca=${3:-${CARGO_TARGET_DIR:-target}/release/crossaudit}
tmp=/tmp/full_$(basename "$dest")
mkdir -p "$tmp" "$dest"
/usr/bin/time -v -o "$tmp/time.txt" "$ca" run "$design" --out "$tmp/run" --workers 2 > "$tmp/stdout.txt" 2>&1
# A level: its committed parts. Under per-seed draws a specification's
# folder holds its seeds' levels (spec-ID/draw-K) beside its cells.csv and
# report/.
copy_level() {
  local from=$1 to=$2
  rm -rf "${to:?}"; mkdir -p "$to"
  for part in cells.csv report run.json audit curves; do
    [ -e "$from/$part" ] && cp -r "$from/$part" "$to/$part"
  done
  if [ -f "$from/manifests/manifests.json" ]; then
    mkdir -p "$to/manifests"; cp "$from/manifests/manifests.json" "$to/manifests/"
  fi
  for inner in "$from"/draw-*/; do
    [ -d "$inner" ] && copy_level "$inner" "$to/$(basename "$inner")"
  done
  return 0
}
for level in "$tmp"/run/*/; do
  name=$(basename "$level")
  [ "$name" = report ] && continue
  [ "$name" = simulated_data ] && continue
  copy_level "$level" "$dest/$name"
done
rm -rf "$dest/report"; cp -r "$tmp/run/report" "$dest/report"
for top in multiverse_cells.csv cells.csv study.json; do
  [ -f "$tmp/run/$top" ] && cp "$tmp/run/$top" "$dest/"
done
cp "$tmp/stdout.txt" "$tmp/time.txt" "$dest/"
# The R recomputation reads a multiverse's combined cells.
[ -f "$dest/multiverse_cells.csv" ] || exit 0
Rscript scripts/reference/multiverse_check.R "$dest"
