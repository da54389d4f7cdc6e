//! What `run` would refuse about a design's data, found by `check` before
//! anyone locks: the inclusion audit, the conditions table, the
//! stratification and the split of each level built exactly as `run`
//! builds them ([`crate::split::rebuild`]), writing nothing.

use std::path::{Path, PathBuf};

use super::RunError;
use crate::design::DesignFile;
use crate::plan::StudyPlan;

/// What the data check read.
#[derive(Debug, Clone)]
pub enum DataChecked {
    /// The design's data are simulated: generated into a scratch folder
    /// (removed) and the splits built from them.
    Simulated {
        /// Recordings the first level's audit included.
        included: usize,
        /// Levels whose split was built.
        built: usize,
        /// Levels of the study (1 for a study of one run).
        levels: usize,
        /// The invariants a built split met only with a warning, as a
        /// run's warnings give them.
        warned: Vec<String>,
    },
    /// The data folder is not there (the design's `path`, from here).
    Absent {
        /// Where it was looked for.
        dir: String,
    },
    /// Every level's split was built.
    Built {
        /// The data folder.
        dir: PathBuf,
        /// Recordings the first level's audit included.
        included: usize,
        /// Levels whose split was built.
        built: usize,
        /// Levels of the study (1 for a study of one run).
        levels: usize,
        /// Files named like logs that the audit does not read, in words.
        not_read: Vec<String>,
        /// The invariants a built split met only with a warning, as a
        /// run's warnings give them.
        warned: Vec<String>,
    },
}

/// The refusal `run` would give about the data of a level.
fn refused(data: &str, level: Option<&str>, e: RunError) -> RunError {
    let e = match level {
        Some(l) => RunError::InLevel { level: l.to_string(), source: Box::new(e) },
        None => e,
    };
    RunError::DataRefused { data: data.to_string(), source: Box::new(e) }
}

/// Builds the split of the study, or of the first level of each of its
/// specifications (the other levels differ only in their draws or split
/// seeds), from the design's data, or from `data` when given, writing
/// nothing; the first refusal is returned as `run` would give it.
pub fn check_data(file: &DesignFile, study: &StudyPlan, data: Option<PathBuf>) -> Result<DataChecked, RunError> {
    let design = &file.design;
    let dir = match (data, &design.data.path, &design.data.simulated) {
        (Some(_), _, Some(_)) => return Err(RunError::DataOverride),
        (None, _, Some(sim)) => {
            let scratch = Scratch::new()?;
            crate::sim::simulate(sim, &scratch.0)?;
            let b = build(file, study, &scratch.0, "its simulated data")?;
            return Ok(DataChecked::Simulated {
                included: b.included,
                built: b.built,
                levels: b.levels,
                warned: b.warned,
            });
        }
        (Some(d), _, None) if !d.is_dir() => return Err(RunError::NoDataDir { dir: d.display().to_string() }),
        (Some(d), _, None) => d,
        (None, Some(p), None) => match super::design_data_path(&file.path, p) {
            Ok(d) => d,
            Err(RunError::NoDataDir { dir }) => return Ok(DataChecked::Absent { dir }),
            Err(e) => return Err(e),
        },
        (None, None, None) => return Err(RunError::NoDataPath),
    };
    if !dir.is_dir() {
        return Ok(DataChecked::Absent { dir: dir.display().to_string() });
    }
    let b = build(file, study, &dir, &format!("the data in {}", dir.display()))?;
    Ok(DataChecked::Built {
        dir,
        included: b.included,
        built: b.built,
        levels: b.levels,
        not_read: b.not_read,
        warned: b.warned,
    })
}

/// A folder of its own under the system's temporary folder, removed when
/// dropped: where `check` generates a simulated design's logs.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Scratch, RunError> {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        let dir = std::env::temp_dir().join(format!("crossaudit-check-{}-{nanos}", std::process::id()));
        crate::io::create_dir_all(&dir)?;
        Ok(Scratch(dir))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        // Best effort: a scratch folder left behind holds only simulated logs.
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Builds the split of the study (or of the first level of each
/// specification) from the logs in `dir`: the recordings the first audit
/// included, the levels built and the study's levels; `data` names the
/// logs in a refusal.
fn build(file: &DesignFile, study: &StudyPlan, dir: &Path, data: &str) -> Result<Built, RunError> {
    // Nothing is written: the folder only names where a run would write.
    let out = Path::new("OUT");
    let levels: Vec<&crate::plan::study::Level> = study.levels().iter().filter(|l| l.shares.is_none()).collect();
    if levels.is_empty() {
        let prepared = crate::split::rebuild(file, &study.plan, dir, out).map_err(|e| refused(data, None, e.into()))?;
        let warned = warned(&prepared.invariants, None);
        return Ok(Built {
            included: prepared.recordings.len(),
            built: 1,
            levels: 1,
            not_read: prepared.audit.not_read,
            warned,
        });
    }
    // The first level of each specification: the others differ only in
    // their draws or split seeds, and each costs a split.
    let mut seen_specs = std::collections::BTreeSet::new();
    let chosen: Vec<_> = levels.iter().copied().filter(|l| seen_specs.insert(l.spec)).collect();
    let (mut included, mut not_read, mut warned_all) = (0, Vec::new(), Vec::new());
    for (k, l) in chosen.iter().enumerate() {
        let level_file = DesignFile { design: l.design.clone(), ..file.clone() };
        let prepared = crate::split::rebuild(&level_file, &l.plan, dir, &out.join(&l.id))
            .map_err(|e| refused(data, Some(&l.id), e.into()))?;
        warned_all.extend(warned(&prepared.invariants, Some(&l.id)));
        if k == 0 {
            included = prepared.recordings.len();
            not_read = prepared.audit.not_read;
        }
    }
    Ok(Built { included, built: chosen.len(), levels: study.levels().len(), not_read, warned: warned_all })
}

/// The invariants of a split met only with a warning, worded as a run's
/// warnings word them (in `level`, where the study has several).
fn warned(report: &crate::split::InvariantReport, level: Option<&str>) -> Vec<String> {
    report
        .invariants
        .iter()
        .filter(|i| i.status == crate::split::InvariantStatus::Warn)
        .map(|i| {
            let line = crate::analysis::evidence::warned_invariant(i.id, i.name, &i.detail);
            match level {
                Some(l) => format!("{l}: {line}"),
                None => line,
            }
        })
        .collect()
}

/// What [`build`] found.
struct Built {
    /// The recordings the first level's audit included.
    included: usize,
    /// The levels built.
    built: usize,
    /// The study's levels.
    levels: usize,
    /// The files named like logs that the audit does not read, in words.
    not_read: Vec<String>,
    /// The invariants met only with a warning.
    warned: Vec<String>,
}

impl DataChecked {
    /// The line `check` prints.
    pub fn line(&self) -> String {
        // What every run of the design will warn beside its verdict: said
        // now, while the design can still change before its lock.
        let warnings = |w: &[String]| w.iter().map(|w| format!("\nwarning: {w}")).collect::<String>();
        let splits = |built: usize, levels: usize| {
            match (built, levels) {
            (_, 1) => "its split built as run builds it".to_string(),
            (b, l) if b == l => format!("the splits of its {l} levels built as run builds them"),
            (1, l) => format!(
                "the split of the first of its {l} levels built as run builds it (the others differ only in their draws or split seeds)"
            ),
            (b, l) => format!(
                "the splits of {b} of its {l} levels built as run builds them (the first of each specification; the others differ only in their draws)"
            ),
        }
        };
        match self {
            DataChecked::Simulated { included, built, levels, warned } => format!(
                "data: simulated, generated in a scratch folder (removed): {included} recordings included; {} (nothing written){}",
                splits(*built, *levels),
                warnings(warned)
            ),
            DataChecked::Absent { dir } => format!(
                "data: not read: no folder at {dir}; run refuses until it is there (check --data DIR reads another)"
            ),
            DataChecked::Built { dir, included, built, levels, not_read, warned } => format!(
                "data: {}: {included} recordings included; {} (nothing written){}{}",
                dir.display(),
                splits(*built, *levels),
                not_read.iter().map(|n| format!("\nnot read: {n}")).collect::<String>(),
                warnings(warned)
            ),
        }
    }
}
