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
# The reanalysis step below runs the golden test: its binary is built now,
# from the committed tree, or its build label would say -dirty (the steps
# before it rewrite results/).
cargo test --release -p crossaudit --test main --no-run --quiet
ca=${CARGO_TARGET_DIR:-target}/release/crossaudit
[ -x "$ca" ] || { echo "regenerate.sh: no binary at $ca after cargo build" >&2; exit 1; }
$ca analyze designs/nanobench_confirmatory.design --cells examples/cells/nanobench_synthetic.csv --out results/example --compare-intervals >/dev/null 2>&1
$ca analyze designs/nanobench_divergence.design --cells results/nanobench_confirmatory/cells.csv --out results/nanobench_divergence >/dev/null 2>&1
$ca coverage specs/coverage_paper.json --out results/coverage 2>/dev/null
$ca coverage specs/coverage_decision.json --out results/coverage_decision 2>/dev/null
$ca coverage specs/coverage_missing.json --out results/coverage_missing 2>/dev/null
$ca coverage specs/coverage_power_paper.json --out results/coverage_power_paper 2>/dev/null
# rsimsum's check of this one (scripts/reference/rsimsum_check.R) needs R and rsimsum: rerun it by hand.
$ca coverage specs/coverage_rsimsum.json --out results/coverage_rsimsum --replications 2>/dev/null
$ca simsum results/coverage_rsimsum/replications.csv --by setting,true_mean --true true_mean --level level --ci ci_lower,ci_upper --rep rep --target-mcse cover=0.005,bias=0.02 --out results/simsum_rsimsum > results/simsum_rsimsum/summary.txt 2>/dev/null
$ca plan designs/nanobench_paper_audited.design --cells results/nanobench_paper_audited/cells.csv --recordings 8,13,26,52 --seeds 3,5,10,20,40 --out results/plan_audited >/dev/null
$ca plan designs/nanobench_dose_response.design --cells results/dose_response/cells.csv --recordings 8,13,24,26,52 --seeds 3,5,10,20,40 --out results/plan_dose_response >/dev/null
$ca plan designs/nanobench_multi_split.design --cells results/multi_split/cells.csv --splits 3,5,10,20 --recordings 13,26 --seeds 5,10,20 --out results/plan_multi_split >/dev/null
$ca plan designs/multiverse/paper_draws.design --cells results/multiverse/draws --recordings 13,24,52 --seeds 5,10,20,40 --draws 3,5,10 --out results/plan_draws >/dev/null
$ca plan designs/multiverse/paper_per_seed.design --cells results/multiverse/per_seed/cells.csv --recordings 24,48 --seeds 20,40,60,120 --out results/plan_per_seed >/dev/null
$ca plan designs/nanobench_paper.design --components recording=0.00791883,seed=6.98702e-05,residual=0.00495443 --effect=-0.0362 --reference-mean 0.299 --recordings 26,52,104,208 --seeds 5,10,20,40 --out results/plan_paper_declared >/dev/null
$ca plan designs/multiverse/paper_per_seed.design --components recording=0.00791883,seed=0.00183295,residual=0.00495443 --effect=-0.0362 --reference-mean 0.299 --recordings 26,52,104,208 --seeds 5,10,20,40 --out results/plan_paper_per_seed_declared >/dev/null
$ca data audit designs/nanobench_confirmatory.design --out results/nanobench_audit > results/nanobench_audit/summary.txt 2>/dev/null
$ca audit split ../shared/nanobench/upstream_task2_split_metadata.json --data ../shared/nanobench/recordings --out results/upstream_split_audit > results/upstream_split_audit/summary.txt 2>/dev/null
python3 scripts/window_splits.py ../shared/nanobench/recordings results/nanobench_window_split/splits >/dev/null
for k in random chronological embargo; do
  $ca audit split results/nanobench_window_split/splits/$k.csv --data ../shared/nanobench/recordings --out results/nanobench_window_split/$k > results/nanobench_window_split/$k/summary.txt 2>/dev/null
done
$ca data audit designs/nanobench_audited.design --out results/nanobench_audit_hygiene > results/nanobench_audit_hygiene/summary.txt 2>/dev/null
$ca split designs/nanobench_confirmatory.design --out results/nanobench_split > results/nanobench_split/summary.txt 2>/dev/null
$ca split designs/nanobench_audited.design --out results/nanobench_split_audited > results/nanobench_split_audited/summary.txt 2>/dev/null
# The full training grids are not regenerated here. The dose-response and
# multi-split runs (results/dose_response, results/multi_split; 5 and 13
# minutes) are rerun with `bash scripts/full_run.sh DESIGN RESULTS_DIR` as
# their COMMAND files say; scripts/reference/multi_split_reference.R then
# refits their pooled estimate with lme4. The paper's experiment
# (results/nanobench_paper, results/nanobench_paper_audited, the two
# results/paper_columns and the two results/paper_hygiene runs) is rerun
# with `bash scripts/full_run.sh DESIGN RESULTS_DIR` (each folder's COMMAND
# names its design; 3 to 5 minutes each on this machine), and so are the
# 80-job runs of nanobench_confirmatory and nanobench_audited (7 to 25
# minutes each).
# The multiverse runs (results/multiverse/paper, draws and holdout; 21, 6
# and 2 minutes) are rerun with `bash scripts/full_multiverse.sh DESIGN
# RESULTS_DIR`, which also reruns their R recomputation.
# The small studies are retrained from scratch in a fresh directory, so
# that training itself is checked, then their outputs replace the committed ones.
fresh() {  # fresh DESIGN OUT
  tmp=$(mktemp -d)
  $ca run "$1" --out "$tmp" >/dev/null 2>&1
  copy_parts "$tmp" "$2"
  # A multi-split study: each split's run directory, then its pooled cells.csv and report.
  for split in "$tmp"/split-*; do
    [ -d "$split" ] && copy_parts "$split" "$2/$(basename "$split")"
  done
  for part in cells.csv cells.parquet report study.json; do
    [ -e "$tmp/$part" ] && { rm -rf "${2:?}/$part"; cp -r "$tmp/$part" "$2/$part"; }
  done
  rm -rf "$tmp"
}
copy_parts() {  # copy_parts FROM TO: the committed parts of one run directory
  [ -f "$1/run.json" ] || return 0
  for part in cells cells.csv cells.parquet report run.json audit manifests/manifests.json curves; do
    # Training curves only where a folder commits them.
    [ "$part" = curves ] && [ ! -d "$2/curves" ] && continue
    rm -rf "${2:?}/$part"; mkdir -p "$(dirname "$2/$part")"; cp -r "$1/$part" "$2/$part"
  done
}
fresh designs/quickstart.design results/quickstart
fresh designs/quickstart_nanobench.design results/quickstart_nanobench
fresh designs/logs/rotorpy.design results/rotorpy
fresh designs/logs/rotorpy_wide.design results/rotorpy_wide
$ca simulate-lab --out designs/logs/lab_logs >/dev/null 2>&1
fresh designs/logs/lab.design results/lab
fresh designs/nanobench_paper_linear.design results/nanobench_paper_linear
fresh designs/simulated_control_0.design results/simulated_controls/strength_0
fresh designs/simulated_control_high.design results/simulated_controls/strength_high
for d in dose_0 dose_high splits_0 splits_high; do
  fresh designs/simulated_$d.design results/simulated_family/$d
done
# Every committed run folder's report/ rewritten by its reanalysis (the
# analysis is a pure function of the folder: what the run writes from the
# same cells and evidence); the golden test tests/reanalysis.rs then checks
# them against the current build.
CROSSAUDIT_REWRITE_REPORTS=1 cargo test --release -p crossaudit --test main --quiet -- \
    reanalysis::every_committed_run_folder_is_reproduced_by_its_reanalysis --exact >/dev/null 2>&1
# The pages built from committed full runs (docs/paper_comparison.md reads
# results/nanobench_paper*, results/paper_columns and results/paper_hygiene).
python3 scripts/paper_columns.py results/paper_columns > results/paper_columns/decision.md
python3 scripts/paper_comparison.py > docs/paper_comparison.md
# The committed paper and audited runs reanalysed by REML with Kenward-Roger
# df beside their preregistered MoM analyses (docs/reml_reanalysis.md).
for run in nanobench_paper nanobench_paper_audited; do
  $ca analyze designs/reanalysis/${run}_reml.design --cells results/$run/cells.csv \
      --out results/reanalysis/${run}_reml --compare-intervals >/dev/null 2>&1
done
python3 scripts/reml_reanalysis.py > docs/reml_reanalysis.md
# The multiverse runs' combined reports, rewritten by `analyze` from their
# committed level cells (each level's own report is the training run's).
for pair in "paper_multiverse paper" "paper_draws draws" "holdout_trajectory holdout" \
            "paper_multiverse_per_seed paper_per_seed" "sim_null sim_null"; do
  set -- $pair
  $ca analyze "designs/multiverse/$1.design" --cells "results/multiverse/$2" \
      --out "results/multiverse/$2/report" >/dev/null 2>&1
done
# The two committed 20-draw sets of the per-seed protocol as one 40-seed study.
$ca combine designs/multiverse/paper_per_seed_combined.design --out results/multiverse/per_seed_combined \
    --from designs/multiverse/paper_per_seed.design results/multiverse/per_seed 0 \
    --from designs/multiverse/paper_per_seed_uncoupled.design results/multiverse/per_seed_uncoupled 20 >/dev/null 2>&1
rm -rf results/*/models results/*/simulated_data results/simulated_controls/*/models results/simulated_controls/*/simulated_data
# Wall-clock columns and logs are not reproducible: keep the committed ones
# of the folders regenerated here, and only those (a full run copied into
# results/ but not yet committed keeps its own).
for d in results/quickstart results/quickstart_nanobench results/rotorpy results/rotorpy_wide results/lab results/nanobench_paper_linear results/simulated_controls/* results/simulated_family/*; do
  for f in time.txt stdout.txt; do
    [ -e "$d/$f" ] && { git checkout -- "$d/$f" 2>/dev/null || true; }
  done
  # A training curve whose every column but the last (seconds) is the
  # committed one's keeps the committed file; a changed curve is new.
  find "$d" -path '*/curves/*.csv' | while read -r c; do
    if git cat-file -e "HEAD:$c" 2>/dev/null &&
       [ "$(git show "HEAD:$c" | sed 's/,[^,]*$//')" = "$(sed 's/,[^,]*$//' "$c")" ]; then
      git checkout -- "$c"
    fi
  done
done
git status --short results/
