//! Where an analysis stands with its preregistration: one state, computed
//! once from the design's lock (its post hoc mark included) and the run's
//! `--exploratory` label, and worded once for every view (the title, the
//! console line, the banner, results.json, the LaTeX macros, Python).

use serde::ser::{Serialize, SerializeStruct, Serializer};

use crate::design::LockStatus;

/// An analysis's preregistration status.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Standing {
    /// No lock state was given (an in-memory analysis of cells alone).
    #[default]
    Unrecorded,
    /// The design was never locked; `labelled` when the run was also
    /// labelled exploratory (`--exploratory`).
    NotLocked {
        /// The run was labelled exploratory.
        labelled: bool,
    },
    /// The design's lock says it was written after results were known
    /// (`crossaudit lock DESIGN --posthoc "why"`): not preregistered
    /// evidence.
    PostHoc {
        /// The design's reason.
        why: String,
    },
    /// The design was locked before the run and is unchanged (`amended`:
    /// since a declared amendment, re-locked).
    Preregistered {
        /// The lock records amendments.
        amended: bool,
    },
    /// The design is locked now, but its run recorded it unlocked when it
    /// began (run.json's `lock`; of combined runs, one whose design was
    /// not locked then, or is not now).
    LockedLater,
    /// The design's lock holds but the run was labelled exploratory.
    Labelled,
    /// The design's lock holds, but it is not the lock its run recorded
    /// when it began (rewritten since: amendments or when it was made).
    Relocked {
        /// How the two differ.
        reason: String,
    },
    /// The design, or a file it names, changed after it was locked.
    Changed {
        /// What changed, as the lock check says it.
        reason: String,
    },
}

impl Standing {
    /// The standing of an analysis under a design in lock state `status`,
    /// of a run labelled exploratory or not. A change after locking
    /// outranks every other state; a design never locked says so even when
    /// the run was labelled; a design whose lock is marked post hoc is
    /// never preregistered.
    pub fn of(status: &LockStatus, labelled: bool) -> Standing {
        match status {
            LockStatus::LockedChanged { .. } | LockStatus::LockedStale { .. } => {
                Standing::Changed { reason: status.reason() }
            }
            LockStatus::Unlocked => Standing::NotLocked { labelled },
            LockStatus::LockedUnchanged { .. } if labelled => Standing::Labelled,
            LockStatus::LockedUnchanged { posthoc: Some(why), .. } => Standing::PostHoc { why: why.clone() },
            LockStatus::LockedUnchanged { amendments, .. } => {
                Standing::Preregistered { amended: !amendments.is_empty() }
            }
        }
    }

    /// The standing of a run's analysis: [`Standing::of`] the lock state
    /// now, unless the state the run recorded when it began (`began`) was
    /// less preregistered. A design locked only after its run began is not
    /// preregistered for it; a post hoc mark or amendments dropped from the
    /// lock since, or a lock rewritten, cannot raise the label. `began` is
    /// `None` where the run recorded none (runs written before it was).
    pub fn of_run(now: &LockStatus, began: Option<&LockStatus>, labelled: bool) -> Standing {
        let current = Standing::of(now, labelled);
        let Some(began) = began.filter(|_| current.preregistered() == Some(true)) else { return current };
        match began {
            LockStatus::Unlocked => Standing::LockedLater,
            b if b.rank() < now.rank() => Standing::of(b, labelled),
            b if b != now => Standing::Relocked { reason: rewritten(b, now) },
            _ => current,
        }
    }

    /// True when the analysis is exploratory: the design changed after its
    /// lock, or the run of a locked design was labelled so.
    pub fn exploratory(&self) -> bool {
        matches!(self, Standing::Changed { .. } | Standing::Relocked { .. } | Standing::Labelled)
    }

    /// Whether the analysis is the preregistered one; `None` when no lock
    /// state was given.
    pub fn preregistered(&self) -> Option<bool> {
        match self {
            Standing::Unrecorded => None,
            Standing::Preregistered { .. } => Some(true),
            _ => Some(false),
        }
    }

    /// The tag set before a verdict or a decision line that is not the
    /// preregistered one: `EXPLORATORY`, `NOT PREREGISTERED`, `POST HOC`.
    pub fn tag(&self) -> Option<&'static str> {
        match self {
            Standing::Unrecorded | Standing::Preregistered { .. } => None,
            Standing::NotLocked { .. } | Standing::LockedLater => Some("NOT PREREGISTERED"),
            Standing::PostHoc { .. } => Some("POST HOC"),
            Standing::Labelled | Standing::Changed { .. } | Standing::Relocked { .. } => Some("EXPLORATORY"),
        }
    }

    /// The tag and why, short enough for a title: `NOT PREREGISTERED: the
    /// design was never locked`.
    pub fn short(&self) -> Option<String> {
        let why = match self {
            Standing::Unrecorded | Standing::Preregistered { .. } => return None,
            Standing::NotLocked { .. } => "the design was never locked",
            Standing::LockedLater => "the design was not locked when this run began",
            Standing::PostHoc { .. } => "the design was written after results were known",
            Standing::Labelled => "the run was labelled exploratory",
            Standing::Changed { .. } => "the design changed after it was locked",
            Standing::Relocked { .. } => "the design's lock changed after this run began",
        };
        self.tag().map(|t| format!("{t}: {why}"))
    }

    /// The standing as report.md's provenance line gives it, in every
    /// state but unrecorded: [`Standing::short`] where the analysis is not
    /// the preregistered one, the sentence where it is (which no tag
    /// says).
    pub fn line(&self) -> Option<String> {
        match self {
            Standing::Unrecorded => None,
            Standing::Preregistered { .. } => Some(self.sentence()),
            _ => self.short(),
        }
    }

    /// The status as one sentence (no final stop), for the banner, the
    /// report's status line and results.json.
    pub fn sentence(&self) -> String {
        match self {
            Standing::Unrecorded => "Preregistration status not recorded (an analysis without its design's lock)".into(),
            Standing::Preregistered { amended: false } => {
                "Preregistered: the design was locked before this run and is unchanged".into()
            }
            Standing::Preregistered { amended: true } => {
                "Preregistered: the design was locked before this run and is unchanged since its declared amendments (the warnings say how and why)".into()
            }
            Standing::NotLocked { labelled: false } => {
                "NOT PREREGISTERED: the design was never locked; lock a design (`crossaudit lock`) before running it to preregister it".into()
            }
            Standing::NotLocked { labelled: true } => {
                "NOT PREREGISTERED: the design was never locked, and the run was labelled exploratory".into()
            }
            Standing::LockedLater => {
                "NOT PREREGISTERED: the design was not locked when this run (or a run combined in it) began, as its run.json records; it is locked now, but not preregistered for this run".into()
            }
            Standing::PostHoc { why } => format!(
                "POST HOC: the design was written after results were known ({why}); not preregistered evidence"
            ),
            Standing::Labelled => {
                "EXPLORATORY: the run was labelled exploratory (`--exploratory`); the design's lock holds".into()
            }
            Standing::Changed { reason } => format!("EXPLORATORY: the design changed after it was locked ({reason})"),
            Standing::Relocked { reason } => format!("EXPLORATORY: the design's lock changed after this run began ({reason})"),
        }
    }

    /// The line an analysis's warnings give, where its standing is not the
    /// preregistered one (`path` is the design's).
    pub fn warning(&self, path: &str) -> Option<String> {
        match self {
            Standing::Unrecorded | Standing::Preregistered { .. } => None,
            _ => Some(format!("{path}: {}", self.sentence())),
        }
    }
}

/// The reason a lock that holds now is not the one a run recorded when it
/// began: when each was made and how many amendments each lists.
fn rewritten(began: &LockStatus, now: &LockStatus) -> String {
    let made = |s: &LockStatus| match s {
        LockStatus::LockedUnchanged { locked_at_utc, amendments, .. } => {
            format!("locked at {locked_at_utc} with {} amendment(s)", amendments.len())
        }
        other => other.label().to_string(),
    };
    format!("run.json recorded it {} when the run began; it is {} now", made(began), made(now))
}

/// Serialized flat into its analysis: `exploratory`, `preregistered`
/// (absent when unrecorded) and `standing` (the sentence), so results.json
/// keeps its two flags and says which state set them.
impl Serialize for Standing {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut s = serializer.serialize_struct("Standing", 3)?;
        s.serialize_field("exploratory", &self.exploratory())?;
        match self.preregistered() {
            Some(p) => s.serialize_field("preregistered", &p)?,
            None => s.skip_field("preregistered")?,
        }
        s.serialize_field("standing", &self.sentence())?;
        s.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unchanged(posthoc: Option<&str>) -> LockStatus {
        LockStatus::LockedUnchanged {
            locked_at_utc: "2026-12-05T00:00:00Z".into(),
            amendments: Vec::new(),
            posthoc: posthoc.map(String::from),
        }
    }

    #[test]
    fn each_state_has_one_true_label() {
        // A never-locked design run with --exploratory is not "changed after it was locked".
        let s = Standing::of(&LockStatus::Unlocked, true);
        assert_eq!(s.tag(), Some("NOT PREREGISTERED"));
        assert!(!s.sentence().contains("changed after"), "{}", s.sentence());
        // A design whose lock is marked post hoc is never preregistered.
        let s = Standing::of(&unchanged(Some("written after the results")), false);
        assert_eq!((s.tag(), s.preregistered()), (Some("POST HOC"), Some(false)));
        assert!(s.sentence().contains("written after the results"));
        assert_eq!(Standing::of(&unchanged(None), false).preregistered(), Some(true));
        // The preregistered analysis has no tag, but report.md's provenance
        // line still says where it stands.
        let s = Standing::of(&unchanged(None), false);
        assert_eq!(s.tag(), None);
        assert!(s.line().is_some_and(|l| l.starts_with("Preregistered: the design was locked before this run")));
        assert_eq!(
            Standing::of(&LockStatus::Unlocked, false).line(),
            Standing::of(&LockStatus::Unlocked, false).short()
        );
        assert_eq!(Standing::Unrecorded.line(), None);
        assert_eq!(
            Standing::of(&unchanged(None), true).short().as_deref(),
            Some("EXPLORATORY: the run was labelled exploratory")
        );
        let stale = LockStatus::LockedStale {
            locked_at_utc: "2026-12-05T00:00:00Z".into(),
            reason: "conditions.csv changed".into(),
        };
        let s = Standing::of(&stale, false);
        assert!(s.exploratory() && s.sentence().contains("conditions.csv changed"));
    }

    #[test]
    fn results_json_keeps_its_two_flags() -> Result<(), Box<dyn std::error::Error>> {
        let json = serde_json::to_value(Standing::of(&LockStatus::Unlocked, false))?;
        assert_eq!(json["exploratory"], false);
        assert_eq!(json["preregistered"], false);
        assert!(json["standing"].as_str().is_some_and(|s| s.starts_with("NOT PREREGISTERED")), "{json}");
        assert!(serde_json::to_value(Standing::Unrecorded)?.get("preregistered").is_none());
        Ok(())
    }
}

/// The header every analysis type carries (a single study's, a family's, a
/// multiverse's): the design it ran under and where it stands with its
/// preregistration, set by the one labelling routine
/// (`analysis::evidence::label`) and flattened into results.json
/// (`design_sha256`, then `exploratory`, `preregistered`, `standing`).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AnalysisHeader {
    /// SHA-256 of the design file, when the analysis came from one.
    pub design_sha256: Option<String>,
    /// Where the analysis stands with its preregistration.
    #[serde(flatten)]
    pub standing: Standing,
}

impl Default for AnalysisHeader {
    fn default() -> Self {
        AnalysisHeader { design_sha256: None, standing: Standing::Unrecorded }
    }
}
