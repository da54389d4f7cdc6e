#!/usr/bin/env bash
# Regenerates every committed result that does not need a full training
# grid, in place, so that `git status results/` shows what a change altered.
# Wall-clock fields (curves' `seconds`, time.txt, stdout.txt) are not
# reproducible and are restored afterwards; the crossaudit build (version and
# commit) in run.json and the reports changes with every commit.
# Usage: bash scripts/regenerate.sh   (needs ../shared/nanobench beside the repo)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
ca=target/release/crossaudit
$ca analyze designs/nanobench_confirmatory.design --cells examples/cells/nanobench_synthetic.csv --out results/example --compare-intervals >/dev/null 2>&1
$ca coverage specs/coverage_paper.json --out results/coverage 2>/dev/null
$ca plan designs/nanobench_audited.design --cells results/nanobench_audited/cells.csv --recordings 8,13,26,52 --seeds 3,5,10,20,40 --out results/plan_audited >/dev/null
$ca data audit designs/nanobench_confirmatory.design --out results/nanobench_audit > results/nanobench_audit/summary.txt 2>/dev/null
$ca data audit designs/nanobench_audited.design --out results/nanobench_audit_hygiene > results/nanobench_audit_hygiene/summary.txt 2>/dev/null
$ca split designs/nanobench_confirmatory.design --out results/nanobench_split > results/nanobench_split/summary.txt 2>/dev/null
$ca split designs/nanobench_audited.design --out results/nanobench_split_audited > results/nanobench_split_audited/summary.txt 2>/dev/null
# The two 80-job runs (nanobench_confirmatory, nanobench_audited) are not
# regenerated here: each is a full rerun of about 11 minutes on a quiet
# machine (`crossaudit run designs/NAME.design --out DIR --workers 2`, then
# cells/, cells.csv, report/, run.json, audit/, curves/ and
# manifests/manifests.json copied over results/NAME; weights and job
# records are not committed, so the committed folders cannot be resumed).
# The small studies are retrained from scratch in a fresh directory, so
# that training itself is checked, then their outputs replace the committed ones.
fresh() {  # fresh DESIGN OUT
  tmp=$(mktemp -d)
  $ca run "$1" --out "$tmp" >/dev/null 2>&1
  for part in cells cells.csv report run.json audit manifests/manifests.json; do
    rm -rf "$2/$part"; mkdir -p "$(dirname "$2/$part")"; cp -r "$tmp/$part" "$2/$part"
  done
  rm -rf "$tmp"
}
fresh designs/quickstart.design results/quickstart
fresh designs/quickstart_nanobench.design results/quickstart_nanobench
fresh designs/simulated_control_0.design results/simulated_controls/strength_0
fresh designs/simulated_control_high.design results/simulated_controls/strength_high
rm -rf results/*/models results/*/simulated_data results/simulated_controls/*/models results/simulated_controls/*/simulated_data
# Wall-clock columns and logs are not reproducible: keep the committed ones.
git checkout -- results/*/curves results/simulated_controls/*/curves results/*/time.txt results/*/stdout.txt 2>/dev/null || true
git status --short results/
