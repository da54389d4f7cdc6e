//! How one file's row of a data audit is built: blank (a name found),
//! unreadable, or judged by the declared rules and policies.

use std::path::{Path, PathBuf};

use super::row::{FileRow, Status, Verdict};
use super::{bounds, policies};
use crate::data::metadata::{parse_name, Metadata};
use crate::data::{recording_name, Recording};
use crate::design::{DataSpec, InclusionRule, Pooling, SpeedLabels, TailPolicy};

pub(crate) fn rule_label(rule: &InclusionRule) -> String {
    match rule {
        InclusionRule::Active { column, cmp, threshold, min_samples } => {
            format!("active({column} {} {threshold}) >= {min_samples} samples", cmp.symbol())
        }
        InclusionRule::Implausible => "plausible (upstream percentile bounds)".to_string(),
        InclusionRule::Named { .. } => "`exclude recordings`".to_string(),
        InclusionRule::Frozen { seconds } => format!("`exclude frozen position for {seconds} s`"),
        InclusionRule::Beyond { quantity, limit } => {
            let (what, unit) = quantity.words();
            format!("`exclude beyond {what} {limit} {unit}`")
        }
    }
}

pub(crate) fn labels(spec: &DataSpec) -> Vec<String> {
    let mut out: Vec<String> = spec.rules.iter().map(rule_label).collect();
    for (k, r) in spec.rules.iter().enumerate() {
        if *r == InclusionRule::Implausible {
            out[k] = match spec.plausibility {
                Pooling::Pooled => "plausible (upstream percentile bounds, motors pooled)".to_string(),
                Pooling::PerColumn => "plausible (upstream percentile bounds, per motor)".to_string(),
            };
        }
    }
    out.extend(policies::labels(spec));
    out
}

pub(crate) fn meta_path(csv: &Path) -> PathBuf {
    csv.with_file_name(format!("{}_metadata.yaml", recording_name(csv)))
}

pub(crate) fn blank(spec: &DataSpec, name: &str, file: &str, meta: Option<&Metadata>) -> FileRow {
    let parts = parse_name(name);
    let speed_mps = meta.and_then(|m| m.params.speed_mps);
    let speed = match &spec.speed {
        SpeedLabels::Name => parts.speed.clone(),
        SpeedLabels::Metadata { labels, thresholds } => SpeedLabels::label(labels, thresholds, speed_mps),
    };
    let count = |k: &str| meta.and_then(|m| m.row_counts.get(k).copied());
    FileRow {
        name: name.to_string(),
        file: file.to_string(),
        rows: 0,
        active_rows: 0,
        duration_s: 0.0,
        trajectory: meta.and_then(|m| m.trajectory_type.clone()).unwrap_or_else(|| parts.shape.clone()),
        speed,
        speed_mps,
        // Declared (`data csv`), or read from a name in NanoBench's form
        // (`B9_trefoil_slow_mell_rep3`): `_mell` for Mellinger, nothing
        // for its PID; a name of another form says nothing of it.
        controller: match spec.format.as_ref().and_then(|f| f.controller.clone()) {
            Some(declared) => declared,
            None if parts.id.is_empty() || parts.repetition.is_none() => "unknown".to_string(),
            None => parts.controller.name().to_string(),
        },
        // The file name's `repN` is the recording's identity; the metadata's
        // `repetition` sometimes disagrees (noted in `judged`).
        repetition: parts.repetition.or(meta.and_then(|m| m.repetition)),
        start_utc: meta.and_then(|m| m.recording_start_utc.clone()),
        battery_start_v: meta.and_then(|m| m.battery_voltage_start),
        battery_end_v: meta.and_then(|m| m.battery_voltage_end),
        duplicate_group: None,
        tail: None,
        rows_cut: 0,
        quaternion_deviation: None,
        onboard_row_counts: (count("estimator"), count("attitude")),
        content_hash: String::new(),
        verdicts: Vec::new(),
        broken_metadata: None,
        status: Status::Included,
        reason: String::new(),
    }
}

pub(crate) fn file_name(path: &Path) -> String {
    path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default()
}

pub(crate) fn unreadable(spec: &DataSpec, path: &Path, meta: Result<Metadata, String>, why: String) -> FileRow {
    let mut row = blank(spec, &recording_name(path), &file_name(path), meta.as_ref().ok());
    row.status = Status::Excluded;
    row.reason = why;
    row
}

pub(crate) fn judged(spec: &DataSpec, rec: &Recording, meta: Result<Metadata, String>) -> FileRow {
    let mut row = blank(spec, &rec.name, &file_name(&rec.path), meta.as_ref().ok());
    row.tail = rec.tail;
    row.rows_cut = rec.rows_cut;
    row.quaternion_deviation = rec.quaternion_deviation;
    row.rows = rec.rows;
    row.active_rows = rec.active_rows();
    row.duration_s = rec.duration_s();
    row.content_hash = rec.content_hash.clone();
    for (rule, label) in spec.rules.iter().zip(labels(spec)) {
        let (pass, detail) = match rule {
            InclusionRule::Active { min_samples, .. } => {
                let n = rec.active_rows() as u64;
                (n >= *min_samples, format!("{n} active rows"))
            }
            InclusionRule::Implausible => bounds::plausible(spec, rec),
            InclusionRule::Named { names } => match names.contains(&rec.name) {
                true => (false, "listed by name in the design".to_string()),
                false => (true, "not listed".to_string()),
            },
            InclusionRule::Frozen { seconds } => bounds::frozen(rec, *seconds),
            InclusionRule::Beyond { quantity, limit } => bounds::beyond(rec, *quantity, *limit),
        };
        if !pass && row.status == Status::Included {
            row.status = Status::Excluded;
            row.reason = format!("{label}: {detail}");
        }
        row.verdicts.push(Verdict { rule: label, pass, detail });
    }
    let policy_labels = labels(spec).into_iter().skip(spec.rules.len());
    for (label, (pass, detail)) in policy_labels.zip(policies::verdicts(spec, rec)) {
        if !pass && row.status == Status::Included {
            row.status = Status::Excluded;
            row.reason = format!("{label}: {detail}");
        }
        row.verdicts.push(Verdict { rule: label, pass, detail });
    }
    if let (Some(tail), TailPolicy::Exclude) = (rec.tail, spec.tails) {
        if row.status == Status::Included {
            row.status = Status::Excluded;
            row.reason = format!(
                "tails exclude: onboard streams end at row {} ({} extrapolated rows, {} active)",
                tail.start + 1,
                tail.rows,
                tail.active
            );
        }
    }
    let note = match &meta {
        Err(e) => Some(e.clone()),
        Ok(m) => match (m.repetition, parse_name(&rec.name).repetition) {
            (Some(a), Some(b)) if a != b => Some(format!("metadata says repetition {a}, the file name rep{b}")),
            _ => crate::data::clipped_actions(rec, spec.action_scale()),
        },
    };
    if let Some(note) = note {
        row.reason =
            if row.reason.is_empty() { format!("note: {note}") } else { format!("{}; note: {note}", row.reason) };
    }
    row
}
