//! Finished runs of one protocol analysed as one study, with their
//! evidence: `crossaudit combine` writes a combined folder (the runs'
//! cells as one `cells.csv`, each run's seeds shifted so that they name
//! distinct levels, and `combined.json` recording every source), and the
//! record reader reads that folder back with every source run's level
//! evidence (treatment strength, condition coverage, warned invariants,
//! training curves), each read with its own design. The combined report
//! then carries the guards a run's own report carries (a reference arm
//! that is not disjoint, copies of evaluation flights in validation, early
//! stopping, condition coverage), not only what the cells say.
//!
//! The sources are verified each time the folder is read: each source
//! design has the SHA-256 recorded when combining, each run folder holds
//! a run of that design, and the combined `cells.csv` is the sources'
//! cells with their seeds shifted, byte for byte.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::read::{read_folder, read_levels, LevelFolder};
use super::RunError;
use crate::analysis::record::{DesignLabel, Record, RunEvidence};
use crate::design::DesignFile;
use crate::plan::study::LevelRole;
use crate::plan::StudyPlan;

/// `combined.json`: what a combined folder was made from.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CombinedRecord {
    /// The combined study's name.
    pub study: String,
    /// SHA-256 of the combined design.
    pub design_sha256: String,
    /// The crossaudit build that combined the runs.
    pub crossaudit: String,
    /// SHA-256 of the combined `cells.csv`.
    pub cells_sha256: String,
    /// The runs combined, in order.
    pub runs: Vec<CombinedSource>,
}

/// One run of a combined study.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CombinedSource {
    /// Its design file, as given to `combine` (relative to the folder
    /// `combine` ran in).
    pub design: String,
    /// SHA-256 of that design when combining.
    pub design_sha256: String,
    /// Its run folder, as given to `combine`.
    pub run: String,
    /// Added to each of its seeds in the combined cells.
    pub seed_shift: u64,
    /// SHA-256 of its `cells.csv` when combining.
    pub cells_sha256: String,
}

/// One run to combine: its design, its run folder and its seed shift.
#[derive(Debug, Clone)]
pub struct Source {
    /// The run's design file.
    pub design: PathBuf,
    /// The run's folder.
    pub run: PathBuf,
    /// Added to each of its seeds.
    pub seed_shift: u64,
}

/// A source run read: its record (cells and evidence) and its cells.csv
/// with the seeds shifted, as text.
struct ReadSource {
    record: Record,
    rows: Vec<csv::StringRecord>,
    header: csv::StringRecord,
    design_sha256: String,
}

fn fail(path: &Path, reason: impl Into<String>) -> RunError {
    RunError::Combine { path: path.display().to_string(), reason: reason.into() }
}

/// Reads the source run `s` (verified against its own design) with its
/// seeds shifted by `s.seed_shift`.
fn read_source(s: &Source) -> Result<ReadSource, RunError> {
    let file = crate::design::load(&s.design)
        .map_err(|e| fail(&s.design, format!("the design of a combined run cannot be loaded: {e}")))?;
    let study = crate::plan::compile_study(&file.design);
    if study.combines_levels() {
        return Err(fail(
            &s.design,
            "a multiverse or draw factor is combined by its own run; combine studies of one run or of per-seed draws",
        ));
    }
    if !s.run.is_dir() {
        return Err(fail(&s.run, "not a run folder (combine reads each run's folder, with its evidence)"));
    }
    let design = DesignLabel::new(&file, crate::design::lock::status(&file)?);
    let levels = study.outer.as_ref().filter(|o| matches!(o.role, LevelRole::PerSeed | LevelRole::Redraw));
    let mut record = match levels {
        Some(o) => read_levels(design, &s.run, &LevelFolder::of(o, &s.run))?,
        None => read_folder(design, &study.plan, &s.run)?,
    };
    let cells_path = s.run.join("cells.csv");
    // The rows as text from the bytes the record was verified on: a file
    // changed since it was read and checked is refused, not combined.
    let text = crate::io::read_input(&cells_path, crate::io::MAX_CELLS_FILE, "a per-cell CSV")
        .map_err(|e| fail(&cells_path, e.reason()))?;
    if crate::io::sha256_hex(&text) != record.cells_file.1 {
        return Err(fail(&cells_path, "changed while it was being read: combine again"));
    }
    let mut reader = csv::Reader::from_reader(text.as_slice());
    let header = reader.headers().map_err(|e| fail(&cells_path, e.to_string()))?.clone();
    let k = header.iter().position(|h| h == "seed").ok_or_else(|| fail(&cells_path, "no `seed` column"))?;
    let mut rows = Vec::new();
    for row in reader.records() {
        let row = row.map_err(|e| fail(&cells_path, e.to_string()))?;
        let seed: u64 =
            row.get(k).unwrap_or("").parse().map_err(|_| fail(&cells_path, "a seed that is not a whole number"))?;
        let shifted = seed.checked_add(s.seed_shift).ok_or_else(|| fail(&cells_path, "a seed shifted past 2^64"))?;
        let fields: Vec<String> =
            row.iter().enumerate().map(|(j, f)| if j == k { shifted.to_string() } else { f.to_string() }).collect();
        rows.push(csv::StringRecord::from(fields));
    }
    shift(&mut record, s.seed_shift);
    Ok(ReadSource { record, rows, header, design_sha256: file.sha256 })
}

/// Shifts every seed of `record` (its cells, its levels' seeds and its
/// training curves) by `by`.
fn shift(record: &mut Record, by: u64) {
    for c in &mut record.cells {
        c.seed += by;
    }
    for l in record.run.iter_mut().flat_map(|r| r.levels.iter_mut()) {
        l.seed = l.seed.map(|s| s + by);
        for c in &mut l.curves {
            c.seed += by;
        }
    }
}

/// The combined `cells.csv` of `sources` as bytes, after checking that
/// they share their columns and that their shifted seeds are distinct and
/// are the combined design's.
fn combined_cells(study: &StudyPlan, sources: &[(Source, ReadSource)]) -> Result<Vec<u8>, RunError> {
    let mut seen: BTreeSet<u64> = BTreeSet::new();
    for (s, r) in sources {
        let own: BTreeSet<u64> = r.record.cells.iter().map(|c| c.seed).collect();
        if let Some(twice) = own.intersection(&seen).next() {
            return Err(fail(
                &s.run,
                format!("its seeds, shifted by {}, include seed {twice}, which an earlier run already has: give each run a seed shift that keeps the seeds apart", s.seed_shift),
            ));
        }
        seen.extend(own);
        if r.header != sources[0].1.header {
            return Err(fail(&s.run.join("cells.csv"), "its columns differ from the first run's"));
        }
    }
    let declared: BTreeSet<u64> = study.plan.seeds.iter().map(|s| s.0).collect();
    if seen != declared {
        let list = |s: &BTreeSet<u64>| s.iter().map(u64::to_string).collect::<Vec<_>>().join(", ");
        return Err(RunError::Combine {
            path: "the combined runs".to_string(),
            reason: format!(
                "their shifted seeds ({}) are not the combined design's seeds ({}): declare `factor seed` as the shifted seeds, or change the shifts",
                list(&seen),
                list(&declared)
            ),
        });
    }
    same_models(sources)?;
    let mut w = csv::WriterBuilder::new().terminator(csv::Terminator::Any(b'\n')).from_writer(Vec::new());
    let err = |e: csv::Error| RunError::Combine { path: "cells.csv".to_string(), reason: e.to_string() };
    w.write_record(&sources[0].1.header).map_err(err)?;
    for (_, r) in sources {
        for row in &r.rows {
            w.write_record(row).map_err(err)?;
        }
    }
    w.into_inner().map_err(|e| RunError::Combine { path: "cells.csv".to_string(), reason: e.to_string() })
}

/// Refuses sources that hold the same trained models: a seed of one run
/// whose cells (every field but the seed) are a seed's cells in another
/// run, as the same run given twice, a copy of its folder, or two runs of
/// one design with overlapping seeds give. Counted twice, one model would
/// pass for two independent seeds and narrow the interval. Within one
/// run, seeds with the same cells are a model that does not vary with
/// the seed, and are not compared.
fn same_models(sources: &[(Source, ReadSource)]) -> Result<(), RunError> {
    let mut seen: std::collections::BTreeMap<String, (&Path, u64)> = std::collections::BTreeMap::new();
    for (s, r) in sources {
        let col = |name: &str| r.header.iter().position(|h| h == name).unwrap_or(usize::MAX);
        let (k, starts, diverged) = (col("seed"), col("n_starts"), col("n_divergent"));
        // A seed whose every start diverged everywhere has cells that two
        // models can share (every value the cap): not evidence of one model.
        let mut finite: BTreeSet<u64> = BTreeSet::new();
        let mut by_seed: std::collections::BTreeMap<u64, String> = std::collections::BTreeMap::new();
        for row in &r.rows {
            let seed = row.get(k).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0).saturating_sub(s.seed_shift);
            if row.get(starts) != row.get(diverged) {
                finite.insert(seed);
            }
            let text = by_seed.entry(seed).or_default();
            for (j, f) in row.iter().enumerate().filter(|&(j, _)| j != k) {
                text.push_str(if j == 0 { "" } else { "," });
                text.push_str(f);
            }
            text.push('\n');
        }
        let keys: Vec<(u64, String)> = by_seed
            .into_iter()
            .filter(|(seed, _)| finite.contains(seed))
            .map(|(seed, text)| (seed, crate::io::sha256_hex(text.as_bytes())))
            .collect();
        // Cells one run has for two of its seeds are a model that does not
        // vary with the seed (a closed-form fit), which the analysis reads
        // over recordings alone: no evidence of a run counted twice.
        let mut counts: std::collections::BTreeMap<&str, usize> = std::collections::BTreeMap::new();
        for (_, key) in &keys {
            *counts.entry(key).or_default() += 1;
        }
        let own: Vec<(u64, String)> = keys.iter().filter(|(_, key)| counts[key.as_str()] == 1).cloned().collect();
        for (seed, key) in own {
            if let Some((run, other)) = seen.get(&key) {
                return Err(fail(
                    &s.run,
                    format!(
                        "its seed {seed} has the same cells, value for value, as seed {other} of {}: the same trained models (one run given twice, a copy of its folder, or runs whose seeds overlap); counted twice they would pass for independent seeds",
                        run.display()
                    ),
                ));
            }
            seen.insert(key, (&s.run, seed));
        }
    }
    Ok(())
}

/// Combines the finished runs `sources` into the folder `out` for the
/// design `file` (a study of one run, whose seeds are the runs' shifted
/// seeds): writes `out/cells.csv` and `out/combined.json`, and returns the
/// combined folder's record, to be analysed as any run folder is.
pub fn combine(file: &DesignFile, study: &StudyPlan, sources: &[Source], out: &Path) -> Result<Record, RunError> {
    if study.outer.is_some() {
        return Err(fail(&file.path, "a combined study is analysed as one study: its design has no choices, draw factor, per-seed draws, splits or doses"));
    }
    if sources.len() < 2 {
        return Err(fail(&file.path, "combine takes at least two runs (--from DESIGN RUN_DIR SEED_SHIFT, once each)"));
    }
    if out.join("run.json").exists() || out.join("study.json").exists() {
        return Err(fail(out, "holds a run of its own; combine into a new folder"));
    }
    match CombinedRecord::read(out)? {
        Some(old) if old.design_sha256 != file.sha256 => {
            return Err(RunError::OtherDesign { dir: out.display().to_string(), sha256: old.design_sha256 });
        }
        Some(_) => {}
        // No combination here yet: a cells.csv or a report/ with files in
        // it is someone's own, which combining would replace.
        None => {
            let report = std::fs::read_dir(out.join("report")).map(|mut d| d.next().is_some()).unwrap_or(false);
            if out.join("cells.csv").exists() || report {
                return Err(fail(
                    out,
                    "holds a cells.csv or a report/ that no `combine` wrote (no combined.json): combine into a new folder",
                ));
            }
        }
    }
    let read: Vec<(Source, ReadSource)> =
        sources.iter().map(|s| read_source(s).map(|r| (s.clone(), r))).collect::<Result<_, _>>()?;
    let bytes = combined_cells(study, &read)?;
    let sha = crate::io::sha256_hex(&bytes);
    let record = CombinedRecord {
        study: study.plan.study.clone(),
        design_sha256: file.sha256.clone(),
        crossaudit: crate::io::BUILD.to_string(),
        cells_sha256: sha,
        runs: read
            .iter()
            .map(|(s, r)| CombinedSource {
                design: s.design.display().to_string(),
                design_sha256: r.design_sha256.clone(),
                run: s.run.display().to_string(),
                seed_shift: s.seed_shift,
                cells_sha256: r.record.cells_file.1.clone(),
            })
            .collect(),
    };
    crate::io::create_dir_all(out)?;
    // The record first: a combine killed between the two leaves a folder
    // this command recognises as its own and finishes on a rerun.
    crate::io::write_atomic(&out.join("combined.json"), crate::io::seal::sealed_json(&record).as_bytes())?;
    crate::io::write_atomic(&out.join("cells.csv"), &bytes)?;
    // The runs were read and verified above: the folder's record from them.
    let design = DesignLabel::new(file, crate::design::lock::status(file)?);
    folder_record(design, out, &record, &read, &bytes)
}

/// The record of the combined folder `dir` whose `combined.json` is
/// `combined` and whose runs `read` were verified against it: the cells
/// of `bytes`, its `cells.csv` as written or as verified, and the runs'
/// evidence.
fn folder_record(
    design: DesignLabel,
    dir: &Path,
    combined: &CombinedRecord,
    read: &[(Source, ReadSource)],
    bytes: &[u8],
) -> Result<Record, RunError> {
    let cells_path = dir.join("cells.csv");
    let cells = crate::cells::read_cells_from(&cells_path.display().to_string(), bytes)?;
    let run = evidence(combined, read.iter().map(|(s, r)| (s, &r.record)).collect());
    let sha = combined.cells_sha256.clone();
    let cells_file = ("cells.csv".to_string(), sha);
    Ok(Record { design, cells, cells_path, cells_file, run: Some(run), last_line_open: false })
}

impl CombinedRecord {
    /// `dir/combined.json`: `None` where absent, an error naming the file
    /// where unreadable.
    pub fn read(dir: &Path) -> Result<Option<CombinedRecord>, RunError> {
        let path = dir.join("combined.json");
        match crate::io::read_own(&path) {
            Ok(bytes) => crate::io::seal::open(&bytes).map(Some).map_err(|e| match e {
                crate::io::seal::SealError::Json(e) => {
                    fail(&path, format!("cannot be read as the record of combined runs ({e})"))
                }
                edited => super::record::opened(edited, &path, dir),
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(fail(&path, format!("cannot be read ({e})"))),
        }
    }
}

/// The record of the combined folder `dir` (one `combine` wrote) for the
/// combined design `design`: its cells, verified to be the sources' with
/// their seeds shifted, and every source run's evidence, its levels
/// numbered on from the previous run's.
pub fn read_combined(design: DesignLabel, study: &StudyPlan, dir: &Path) -> Result<Record, RunError> {
    let shown = dir.display().to_string();
    let combined = CombinedRecord::read(dir)?.ok_or_else(|| {
        fail(&dir.join("combined.json"), "is absent: the folder is not one `crossaudit combine` wrote")
    })?;
    if combined.design_sha256 != design.sha256 {
        return Err(RunError::ran_other(shown, combined.design_sha256, &design));
    }
    let mut read = Vec::new();
    for c in &combined.runs {
        let s = Source { design: PathBuf::from(&c.design), run: PathBuf::from(&c.run), seed_shift: c.seed_shift };
        let r = read_source(&s)?;
        if r.design_sha256 != c.design_sha256 {
            return Err(fail(
                &s.design,
                format!(
                    "changed since the runs were combined (sha256 {}, recorded {}): combine again",
                    r.design_sha256, c.design_sha256
                ),
            ));
        }
        if r.record.cells_file.1 != c.cells_sha256 {
            return Err(fail(&s.run.join("cells.csv"), "changed since the runs were combined: combine again"));
        }
        read.push((s, r));
    }
    let bytes = combined_cells(study, &read)?;
    // Read once, compared, and its cells taken from the bytes compared: a
    // file replaced after its check is never the one analysed.
    let path = dir.join("cells.csv");
    let on_disk = crate::io::read_own(&path)
        .map_err(|source| crate::cells::CellsError::Io { path: path.display().to_string(), source })?;
    if on_disk != bytes || crate::io::sha256_hex(&on_disk) != combined.cells_sha256 {
        return Err(RunError::LevelChanged {
            dir: shown,
            reason: "cells.csv is not the combined runs' cells with their seeds shifted, as combined.json records them: it was edited after combining; combine again".to_string(),
        });
    }
    folder_record(design, dir, &combined, &read, &on_disk)
}

/// The combined evidence of the source records: every run's levels in
/// order (draws numbered on from the previous run's, level ids prefixed by
/// the run's folder), what each lacks, their notes, and a note naming the
/// runs.
fn evidence(combined: &CombinedRecord, sources: Vec<(&Source, &Record)>) -> RunEvidence {
    let mut out = RunEvidence { build: combined.crossaudit.clone(), ..RunEvidence::default() };
    let mut said = Vec::new();
    for (s, r) in sources {
        let name = s.run.display().to_string();
        // A run whose design is not locked now, or was not when the run
        // began, leaves the combination no more preregistered than it.
        let began = r.run.as_ref().and_then(|run| run.lock.as_ref());
        let part = std::iter::once(&r.design.status).chain(began).min_by_key(|l| l.rank());
        out.lock = [out.lock.take().as_ref(), part].into_iter().flatten().min_by_key(|l| l.rank()).cloned();
        let Some(run) = &r.run else { continue };
        if out.levels.is_empty() {
            (out.data, out.audit_sha256) = (run.data.clone(), run.audit_sha256.clone());
        }
        out.exploratory |= run.exploratory;
        out.resumed_from.extend(run.resumed_from.iter().filter(|b| **b != run.build).cloned());
        out.notes.extend(run.notes.iter().cloned());
        out.missing.extend(run.missing.iter().cloned());
        let offset = out.levels.len() as u64;
        let first = offset + 1;
        for (k, l) in run.levels.iter().enumerate() {
            let mut l = l.clone();
            l.draw = Some(l.draw.unwrap_or(k as u64 + 1) + offset);
            l.id = if l.id.is_empty() { name.clone() } else { format!("{name}/{}", l.id) };
            out.levels.push(l);
        }
        let seeds: Vec<u64> = r.cells.iter().map(|c| c.seed).collect::<BTreeSet<_>>().into_iter().collect();
        let (lo, hi) = (seeds.first().copied().unwrap_or(0), seeds.last().copied().unwrap_or(0));
        said.push(format!(
            "{name} ({}, seeds {lo}..{hi}{}; draws {first}..{} here)",
            s.design.display(),
            if s.seed_shift > 0 { format!(", shifted by {}", s.seed_shift) } else { String::new() },
            out.levels.len()
        ));
    }
    // Parts all preregistered under their own locks leave the combined
    // design's lock to say where the combination stands.
    out.lock = out.lock.filter(|l| l.rank() < 3);
    out.notes.insert(
        0,
        format!(
            "combined from {} finished runs, each read with its own design and evidence: {}",
            said.len(),
            said.join("; ")
        ),
    );
    out
}
