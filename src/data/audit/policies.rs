//! The declared policies the audit applies beside its rules: `missing
//! values` and `gaps` (each a rule column of recordings.csv when declared),
//! and how few recordings it may keep.

use std::path::Path;

use super::row::{Audit, FileRow, Status};
use super::AuditError;
use crate::data::Recording;
use crate::design::DataSpec;

use crate::data::cuts::{self, Cut, CutReason};
use crate::design::CutPolicy;

/// The policies' labels, after the rules' (only those declared, so every
/// other audit keeps its columns).
pub(super) fn labels(spec: &DataSpec) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(p) = spec.missing_values {
        out.push(format!("`missing values {}`", p.word()));
    }
    if let Some(g) = spec.gaps {
        out.push(format!("`gaps over {} s {}`", g.over_s, g.policy.word()));
    }
    out
}

/// Each declared policy's verdict on `rec`, in the order of [`labels`].
pub(super) fn verdicts(spec: &DataSpec, rec: &Recording) -> Vec<(bool, String)> {
    let of = |missing: bool| -> Vec<&Cut> {
        rec.cuts.iter().filter(|c| matches!(c.why, CutReason::Missing { .. }) == missing).collect()
    };
    let mut out = Vec::new();
    if let Some(p) = spec.missing_values {
        out.push(cuts::verdict(&of(true), p));
    }
    if let Some(g) = spec.gaps {
        out.push(cuts::verdict(&of(false), g.policy));
    }
    out
}

/// The refusal a declared `refuse` policy makes of a load error, if it is
/// one: a missing value under `missing values refuse`, a gap under
/// `gaps over T s refuse`.
pub(super) fn refusal(spec: &DataSpec, e: &crate::data::LogError) -> Option<AuditError> {
    let policy = if spec.missing_values == Some(CutPolicy::Refuse) && e.is_missing_value() {
        "`missing values refuse`".to_string()
    } else if let Some(g) = spec.gaps.filter(|g| g.policy == CutPolicy::Refuse && e.kind() == "time_gap") {
        format!("`gaps over {} s refuse`", g.over_s)
    } else {
        return None;
    };
    Some(AuditError::Refused { policy, error: e.to_string() })
}

impl Audit {
    /// Whether the audit kept enough recordings: at least the design's
    /// `require at least N recordings`, or, without it, no more than half
    /// of the logs found unreadable (an audit that lost most files to a
    /// layout error looked like a result). `written` is where the audit is,
    /// for the error. An audit that kept none is [`AuditError::NoneIncluded`],
    /// checked by the caller first.
    pub fn kept_enough(&self, spec: &DataSpec, written: &Path) -> Result<(), AuditError> {
        let found = self.files.iter().filter(|f| f.status != Status::Missing).count();
        let kept = self.included().count();
        let unread: Vec<&FileRow> = self.unread().collect();
        let first = unread.first().map(|f| crate::io::one_line(&f.reason)).unwrap_or_default();
        let fail = |why: String| AuditError::TooFew {
            dir: self.data_dir.clone(),
            kept,
            found,
            why,
            written: written.display().to_string(),
        };
        match spec.require_kept {
            Some(n) if (kept as u64) < n => Err(fail(format!(
                "the design requires at least {n} (`require at least {n} recordings`){}",
                if unread.is_empty() { String::new() } else { format!("; {} unreadable, the first: {first}", unread.len()) }
            ))),
            None if 2 * unread.len() > found => Err(fail(format!(
                "{} of them could not be read, more than half (the first: {first}); fix the data block, or declare `require at least {kept} recordings` to accept this audit",
                unread.len()
            ))),
            _ => Ok(()),
        }
    }
}
