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
for level in "$tmp"/run/*/; do
  name=$(basename "$level")
  [ "$name" = report ] && continue
  [ "$name" = simulated_data ] && continue
  rm -rf "${dest:?}/$name"; mkdir -p "$dest/$name"
  if [ -f "$level/run.json" ]; then
    for part in cells.csv report run.json audit curves; do cp -r "$level/$part" "$dest/$name/$part"; done
    mkdir -p "$dest/$name/manifests"; cp "$level/manifests/manifests.json" "$dest/$name/manifests/"
  else
    cp -r "$level/report" "$dest/$name/report"
  fi
done
rm -rf "$dest/report"; cp -r "$tmp/run/report" "$dest/report"
cp "$tmp/run/multiverse_cells.csv" "$tmp/stdout.txt" "$tmp/time.txt" "$dest/"
Rscript scripts/reference/multiverse_check.R "$dest"
