//! The run folder read back as one typed value: the per-cell rows and the
//! evidence a run's folder holds beyond them (treatment strength,
//! condition coverage, warned invariants, unread logs, training curves,
//! the builds that trained the cells, the run's own notes, provenance).
//! `run::read` fills it from disk, each file through one of the serde
//! types below; the analysis ([`super::evidence::analyze_study`]) is a pure
//! function of it, so a run and a reanalysis of its folder give the same
//! report.
//!
//! A per-cell file alone is a record without run evidence
//! ([`Record::run`] is `None`): the analysis then says which sections it
//! cannot give instead of leaving them out silently.

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

use crate::cells::Cell;
use crate::design::LockStatus;

/// The design an analysis runs under, as its header states it.
#[derive(Debug, Clone)]
pub struct DesignLabel {
    /// The design's path as the user named it (the report quotes it).
    pub path: String,
    /// SHA-256 of the design file.
    pub sha256: String,
    /// Its lock state now.
    pub status: LockStatus,
}

impl DesignLabel {
    /// The label of design file `file` in lock state `status`.
    pub fn new(file: &crate::design::DesignFile, status: LockStatus) -> DesignLabel {
        DesignLabel { path: file.path.display().to_string(), sha256: file.sha256.clone(), status }
    }
}

/// A per-cell file or a run folder, read.
#[derive(Debug, Clone)]
pub struct Record {
    /// The design it is analysed under.
    pub design: DesignLabel,
    /// Every per-cell row, in file order.
    pub cells: Vec<Cell>,
    /// The per-cell file read (errors name it).
    pub cells_path: std::path::PathBuf,
    /// The per-cell file as the report names it, and its SHA-256.
    pub cells_file: (String, String),
    /// What the run folder holds beyond the cells; `None` for a per-cell
    /// file read alone.
    pub run: Option<RunEvidence>,
    /// Whether the per-cell file's last line ends without a line break, as
    /// a file cut short while it was written does (`cells::last_line_open`;
    /// never for a run's own file, whose recorded hash vouches for it).
    pub last_line_open: bool,
}

/// The run folder of a multiverse or draw-replicated study, read: each
/// unit's cells and level evidence, and what the run recorded beside them.
#[derive(Debug, Clone)]
pub struct MultiverseRecord {
    /// The design it is analysed under.
    pub design: DesignLabel,
    /// The run folder (analysis errors name it).
    pub dir: std::path::PathBuf,
    /// Per unit of the study (in the plan's unit order): its cells (its
    /// levels' in level order) and each level's evidence.
    pub units: Vec<(Vec<Cell>, Vec<LevelEvidence>)>,
    /// What the run recorded beside its levels; its `levels` is empty
    /// (each unit's are above).
    pub run: RunEvidence,
    /// Starts and windows each pair of specifications' splits share, as
    /// the run recorded them in `study.json`.
    pub shared: Vec<SharedDraws>,
}

/// What a run folder holds beyond its cells.
#[derive(Debug, Clone, Default)]
pub struct RunEvidence {
    /// Where the flight logs came from, in words (run.json's `data`).
    pub data: String,
    /// SHA-256 of the inclusion audit.
    pub audit_sha256: String,
    /// Whether the run was labelled EXPLORATORY.
    pub exploratory: bool,
    /// The design's lock state when the run began (run.json's `lock`; of
    /// several level folders or combined runs, the least preregistered):
    /// the analysis stands under the lower of it and the state now.
    /// `None` where no run recorded one.
    pub lock: Option<crate::design::LockStatus>,
    /// The build that wrote the folder (run.json's `crossaudit`).
    pub build: String,
    /// Builds other than [`RunEvidence::build`] that trained some of the
    /// cells (a resumed run).
    pub resumed_from: BTreeSet<String>,
    /// The run's own notes (jobs reused from an earlier run, external
    /// models' predictions), as run.json records them.
    pub notes: Vec<String>,
    /// One entry per level folder (one for a study of one run).
    pub levels: Vec<LevelEvidence>,
    /// Evidence the folder should hold and does not (or holds unreadable),
    /// each a sentence naming the file: warnings in the report.
    pub missing: Vec<String>,
}

/// What one level folder (or a single run's folder) holds beyond its cells.
#[derive(Debug, Clone, Default)]
pub struct LevelEvidence {
    /// The level's folder name (`draw-3`); empty for a single run.
    pub id: String,
    /// Its draw, under per-seed draws.
    pub draw: Option<u64>,
    /// Its one training seed, under per-seed draws.
    pub seed: Option<u64>,
    /// `audit/treatment.json`.
    pub treatment: Option<Treatment>,
    /// The split's invariants that hold with a warning (`audit/invariants.json`).
    pub warned: Vec<InvariantEntry>,
    /// The sentence naming the logs the audit could not read and excluded
    /// (`audit/recordings.csv`, worded by `data::unread_sentence`).
    pub unread: Option<String>,
    /// The inclusion audit's rows counted by status (`audit/recordings.csv`;
    /// `None` where it is absent or unreadable).
    pub inclusion: Option<Inclusion>,
    /// The validation-loss curve of every fitted job (`curves/STEM.csv`),
    /// in file-name order.
    pub curves: Vec<Curve>,
    /// Per arm of a distance-dose family, the distinct evaluation
    /// recordings its contaminating windows came from, and the evaluation
    /// recordings (`manifests/contaminating_ARM.csv`,
    /// `manifests/evaluation_recordings.csv`); empty for any other study.
    pub sources: BTreeMap<String, (usize, usize)>,
}

/// A fitted job's validation-loss curve.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve {
    /// The model's name.
    pub model: String,
    /// The arm the job was fitted on (it picks the colour).
    pub arm: String,
    /// The training seed.
    pub seed: u64,
    /// (epoch, validation loss).
    pub points: Vec<(f64, f64)>,
}

/// `audit/treatment.json` as the analysis reads it.
#[derive(Debug, Clone, Deserialize)]
pub struct Treatment {
    /// Rollout horizon, samples.
    pub horizon_samples: usize,
    /// One summary per arm, in design order.
    pub arms: Vec<ArmStrength>,
    /// Which evaluation conditions each arm's fit set covers (absent in
    /// folders written before coverage was measured).
    #[serde(default)]
    pub coverage: Option<CoverageRecord>,
}

/// One arm's treatment strength in `audit/treatment.json`.
#[derive(Debug, Clone, Deserialize)]
pub struct ArmStrength {
    /// The arm.
    pub arm: String,
    /// Its windows from the evaluation recordings.
    pub contaminating_windows: usize,
    /// Those inside an evaluated segment.
    pub inside_evaluated_segment: usize,
    /// Median distance to the nearest registered start, seconds.
    pub median_distance_s: f64,
    /// Quartiles of the distance to the nearest evaluated segment, seconds
    /// (absent in audits written before they were measured).
    #[serde(default)]
    pub segment_distance_quartiles_s: Option<[f64; 3]>,
}

/// Each arm's fit coverage of the evaluation conditions
/// (`audit/treatment.json`'s `coverage`).
#[derive(Debug, Clone, Deserialize)]
pub struct CoverageRecord {
    /// What a condition is: `trajectory` or `trajectory x speed`.
    pub condition: String,
    /// One row per evaluation recording.
    pub recordings: Vec<FitRow>,
}

/// One evaluation recording's coverage by each arm.
#[derive(Debug, Clone, Deserialize)]
pub struct FitRow {
    /// The recording.
    pub recording: String,
    /// Its condition.
    pub condition: String,
    /// Per arm: the other recordings of its condition the arm fits on.
    pub fit_recordings: BTreeMap<String, usize>,
}

impl CoverageRecord {
    /// The evaluation recordings of whose condition `arm` fits on no other
    /// recording.
    pub fn uncovered(&self, arm: &str) -> impl Iterator<Item = &FitRow> {
        let arm = arm.to_string();
        self.recordings.iter().filter(move |r| r.fit_recordings.get(&arm) == Some(&0))
    }
}

/// `audit/invariants.json` as the analysis reads it.
#[derive(Debug, Clone, Deserialize)]
pub struct InvariantsFile {
    /// Every invariant, in protocol order.
    pub invariants: Vec<InvariantEntry>,
}

/// One invariant of `audit/invariants.json`.
#[derive(Debug, Clone, Deserialize)]
pub struct InvariantEntry {
    /// Its number in the protocol.
    pub id: u64,
    /// Its short name.
    pub name: String,
    /// `pass`, `warn`, `fail` or `deferred`.
    pub status: String,
    /// What was checked, in words.
    pub detail: String,
    /// The counts behind it that the reports read (null for an invariant
    /// with none).
    #[serde(default)]
    pub numbers: Option<InvariantCounts>,
}

/// The counts of an invariant that the reports read (others are ignored).
#[derive(Debug, Clone, Default, Deserialize)]
pub struct InvariantCounts {
    /// Windows from byte-identical copies of evaluation recordings.
    #[serde(default)]
    pub from_duplicates: Option<usize>,
    /// Windows from evaluation recordings.
    #[serde(default)]
    pub from_evaluation: Option<usize>,
}

impl InvariantEntry {
    /// Windows of evaluation recordings or their copies it counts.
    pub fn from_evaluation(&self) -> usize {
        let n = self.numbers.as_ref();
        n.and_then(|n| n.from_duplicates).unwrap_or(0) + n.and_then(|n| n.from_evaluation).unwrap_or(0)
    }
}

impl RunEvidence {
    /// Every level's curves, in level order.
    pub fn curves(&self) -> Vec<Curve> {
        self.levels.iter().flat_map(|l| l.curves.iter().cloned()).collect()
    }
}

impl Record {
    /// The training curves the report draws (none for a per-cell file).
    pub fn curves(&self) -> Vec<Curve> {
        self.run.as_ref().map(RunEvidence::curves).unwrap_or_default()
    }
}

/// What two specifications' splits have in common.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SharedDraws {
    /// The two specifications.
    pub left: String,
    /// The other.
    pub right: String,
    /// Shared evaluation recordings / of the left's.
    pub recordings: (usize, usize),
    /// Shared rollout starts (recording name and row) / of the left's.
    pub starts: (usize, usize),
    /// Shared fit windows of the reference arm / of the left's.
    pub fit_windows: (usize, usize),
}

/// The inclusion audit's rows by status (`audit/recordings.csv`): every
/// file it listed, the recordings it included, those its rules excluded
/// (each with its rule), and recordings with metadata but no log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct Inclusion {
    /// Rows of the audit.
    pub listed: usize,
    /// Status `included`.
    pub included: usize,
    /// Status `excluded`.
    pub excluded: usize,
    /// Status `missing`: metadata without a log.
    pub missing: usize,
}

impl Inclusion {
    /// The counts as report.md gives them beside the audit's hash, with
    /// where each file's rule is: "`audit/recordings.csv`, each file with
    /// the rule that kept or dropped it: 107 listed, 99 included, 1
    /// excluded, 7 with metadata but no log".
    pub fn sentence(&self) -> String {
        let mut s = format!(
            "`audit/recordings.csv`, each file with the rule that kept or dropped it: {} listed, {} included, {} excluded",
            self.listed, self.included, self.excluded
        );
        if self.missing > 0 {
            s.push_str(&format!(", {} with metadata but no log", self.missing));
        }
        s
    }
}
