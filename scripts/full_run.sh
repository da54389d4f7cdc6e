#!/usr/bin/env bash
# One full training grid, run in a scratch directory and copied into results/:
#   bash scripts/full_run.sh DESIGN RESULTS_DIR [BINARY]
# Runs `crossaudit run DESIGN --out /tmp/full_NAME --workers 2` under
# /usr/bin/time, then copies cells/, cells.csv, report/, run.json, audit/,
# curves/, manifests/manifests.json, stdout.txt and time.txt into RESULTS_DIR
# (model weights, job records and manifest CSVs are not committed); a
# multi-split study's split-S/ directories likewise, with its pooled
# cells.csv, report/ and study.json.
# BINARY defaults to target/release/crossaudit; pass a copy when the tree is
# rebuilt while a long run goes on.
set -euo pipefail
cd "$(dirname "$0")/.."
design=$1; dest=$2; ca=${3:-${CARGO_TARGET_DIR:-target}/release/crossaudit}
tmp=/tmp/full_$(basename "$dest")
mkdir -p "$tmp" "$dest"
# FULL_RUN_COPY_ONLY=1 copies a finished run in $tmp without running it again.
if [ -z "${FULL_RUN_COPY_ONLY:-}" ]; then
  /usr/bin/time -v -o "$tmp/time.txt" "$ca" run "$design" --out "$tmp" --workers 2 > "$tmp/stdout.txt" 2>&1
fi
copy_run() {  # copy_run FROM TO: one run directory's committed parts
  for part in cells cells.csv report run.json audit curves; do
    rm -rf "${2:?}/$part"
    [ -e "$1/$part" ] || continue   # a per-seed draw's folder has no report
    cp -r "$1/$part" "$2/$part"
  done
  mkdir -p "$2/manifests"; cp "$1/manifests/manifests.json" "$2/manifests/manifests.json"
}
if [ -f "$tmp/run.json" ]; then
  copy_run "$tmp" "$dest"
else
  # A multi-split study (or one with per-seed draws): one run directory per
  # split (per draw), then the pooled cells.csv and report at the top.
  for split in "$tmp"/split-* "$tmp"/draw-*; do
    [ -d "$split" ] || continue
    mkdir -p "$dest/$(basename "$split")"; copy_run "$split" "$dest/$(basename "$split")"
  done
  for part in cells.csv report study.json; do
    [ -e "$tmp/$part" ] || continue   # study.json: runs since it was recorded
    rm -rf "${dest:?}/$part"; cp -r "$tmp/$part" "$dest/$part"
  done
fi
cp "$tmp/stdout.txt" "$tmp/time.txt" "$dest/"
cat > "$dest/COMMAND" <<CMD
bash scripts/full_run.sh $design $dest
# = crossaudit run $design --out $tmp --workers 2, then cells/, cells.csv, report/, run.json, audit/,
# curves/, manifests/manifests.json, stdout.txt and time.txt copied here (weights, job records and
# manifest CSVs are not committed). Built from commit $("$ca" --version | sed 's/.*commit //; s/)//').
CMD
