//! Invariants 1, 3, 6 and 7 checked after training on what each job
//! recorded it used (`jobs/STEM.json`), not on the plan: the manifests each
//! job read, its seed, and the standardizers it fitted, recomputed here
//! from the fit manifest on disk. Written to `audit/invariants_trained.json`.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::json;

use super::record::JobRecord;
use super::RunError;
use crate::io::{sha256_hex, write_atomic};
use crate::model::{Action, FeatureMap, State};
use crate::plan::Plan;
use crate::split::{Invariant, InvariantReport, InvariantStatus, Prepared};

/// One (x_t, u_t, x_{t+1}) window.
type Triple = (State, Action, State);

fn inv(id: u8, name: &'static str, failures: Vec<String>, checked: usize) -> Invariant {
    let ok = failures.is_empty();
    Invariant {
        id,
        name,
        status: if ok { InvariantStatus::Pass } else { InvariantStatus::Fail },
        detail: if ok { format!("{checked} job records agree") } else { failures.join("; ") },
        numbers: json!({"job_records": checked, "failures": failures}),
    }
}

/// Checks the job records of every job of `plan` in `out` against the
/// manifests the run prepared; writes `audit/invariants_trained.json` and
/// fails the run if any invariant fails.
pub fn check(plan: &Plan, prepared: &Prepared, out: &Path) -> Result<InvariantReport, RunError> {
    let mut records = Vec::new();
    let mut missing = Vec::new();
    for j in &plan.jobs {
        match JobRecord::read(out, j)? {
            Some(r) => records.push(r),
            None => missing.push(j.stem()),
        }
    }
    let m = &prepared.manifests;
    let same = |id: u8, name: &'static str, pick: &dyn Fn(&JobRecord) -> Vec<(&'static str, &str)>| {
        let mut failures = Vec::new();
        for r in &records {
            for (file, sha) in pick(r) {
                if sha != m.sha256(file) {
                    failures.push(format!(
                        "{}/{}/{} read {file} with sha256 {sha}, the run's has {}",
                        r.model,
                        r.arm,
                        r.seed,
                        m.sha256(file)
                    ));
                }
            }
        }
        inv(id, name, failures, records.len())
    };
    let same_evaluation = same(1, "evaluation recordings and starts identical across arms, models and seeds", &|r| {
        vec![
            ("evaluation_recordings.csv", &r.manifests.evaluation_sha256),
            ("evaluation_starts.csv", &r.manifests.starts_sha256),
        ]
    });
    let same_validation = same(3, "validation windows identical across arms", &|r| {
        vec![("validation_windows.csv", &r.manifests.validation_sha256)]
    });
    let invariants = vec![
        same_evaluation,
        same_validation,
        standardizers(&records, prepared, out),
        inv(
            7,
            "all seeds present for every model and arm",
            missing.iter().map(|s| format!("no job record for {s}")).collect(),
            records.len(),
        ),
    ];
    let report = InvariantReport { all_pass: invariants.iter().all(|i| i.status != InvariantStatus::Fail), invariants };
    let path = out.join("audit").join("invariants_trained.json");
    write_atomic(&path, report.to_json().as_bytes())?;
    if !report.all_pass {
        let list =
            report.failures().iter().map(|i| format!("  ({}) {}: {}", i.id, i.name, i.detail)).collect::<Vec<_>>();
        return Err(RunError::TrainedInvariants { path: path.display().to_string(), list: list.join("\n") });
    }
    Ok(report)
}

/// Invariant 6: each fitted model's standardizers were fitted on its own
/// arm's fit set. Its recorded fit manifest is the arm's, the manifest file
/// on disk still has that hash, and standardizers fitted again on the
/// windows it lists equal the recorded ones.
fn standardizers(records: &[JobRecord], prepared: &Prepared, out: &Path) -> Invariant {
    let index: BTreeMap<&str, usize> =
        prepared.split.recordings.iter().enumerate().map(|(i, r)| (r.name.as_str(), i)).collect();
    let mut refit: BTreeMap<(String, String), Result<Vec<Triple>, String>> = BTreeMap::new();
    let mut failures = Vec::new();
    let mut checked = 0;
    for r in records {
        let Some(recorded) = &r.standardizers else { continue };
        checked += 1;
        let job = format!("{}/{}/{}", r.model, r.arm, r.seed);
        let file = format!("fit_{}.csv", r.arm);
        if r.manifests.fit_sha256 != prepared.manifests.sha256(&file) || recorded.fitted_on != r.manifests.fit_sha256 {
            failures.push(format!("{job}: fitted on a manifest other than its arm's {file}"));
            continue;
        }
        let windows = refit.entry((file.clone(), r.manifests.fit_sha256.clone())).or_insert_with(|| {
            fit_windows(&out.join("manifests").join(&file), &r.manifests.fit_sha256, &index, prepared)
        });
        match windows {
            Err(e) => failures.push(format!("{job}: {e}")),
            Ok(w) => {
                if FeatureMap::fit(
                    recorded.slots,
                    recorded.map,
                    recorded.actions,
                    recorded.target_kind,
                    w,
                    &r.manifests.fit_sha256,
                ) != *recorded
                {
                    failures.push(format!("{job}: its standardizers differ from those fitted on {file}"));
                }
            }
        }
    }
    let mut i = inv(6, "standardizers fitted on their own arm's fit set", failures, checked);
    if i.status == InvariantStatus::Pass {
        i.detail = format!("{checked} fitted models' standardizers recomputed from their fit manifests and equal");
    }
    i
}

/// The (x_t, u_t, x_{t+1}) windows a fit manifest lists, after checking
/// the file still has the hash the job recorded.
fn fit_windows(
    path: &Path,
    sha: &str,
    index: &BTreeMap<&str, usize>,
    prepared: &Prepared,
) -> Result<Vec<Triple>, String> {
    let name = path.display();
    let bytes = crate::io::read_own(path).map_err(|e| format!("{name}: {e}"))?;
    if sha256_hex(&bytes) != sha {
        return Err(format!("{name} no longer has the sha256 the job recorded"));
    }
    let mut rdr = csv::Reader::from_reader(bytes.as_slice());
    let mut windows = Vec::new();
    for (k, row) in rdr.records().enumerate() {
        let row = row.map_err(|e| format!("{name}: {e}"))?;
        let (rec, t) = (row.get(0).unwrap_or(""), row.get(1).unwrap_or(""));
        let r = *index.get(rec).ok_or_else(|| format!("{name} line {}: unknown recording {rec}", k + 2))?;
        let t: usize = t.parse().map_err(|_| format!("{name} line {}: sample_index {t}", k + 2))?;
        let data = &prepared.recordings[r];
        if t + 1 >= data.state.len() {
            return Err(format!("{name} line {}: sample_index {t} beyond {rec}", k + 2));
        }
        windows.push((data.state[t].clone(), data.action[t].clone(), data.state[t + 1].clone()));
    }
    Ok(windows)
}
