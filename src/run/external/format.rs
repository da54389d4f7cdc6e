//! The export's format and how it is built: its files and constants,
//! `ExportJob`, `ExportIndex`, `ExportSource`, `Built` (the arrays of
//! one run's split), and the writing of `export/`; shared by the export
//! of one run or of every level, and by scoring.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::data::Recording;
use crate::design::{ActionScaling, DesignFile, InputMap, TargetKind};
use crate::io::{create_dir_all, pretty_json, sha256_hex, write_atomic};
use crate::model::{Action, FeatureMap, Slots, State, ACTION, STATE};
use crate::plan::{Plan, TrainingJob};
use crate::run::job::triples;
use crate::run::{Data, DataOrigin, RunError};
use crate::split::{Prepared, Window};

/// `DIR/export`: everything the user's code reads.
pub const EXPORT_DIR: &str = "export";
/// `DIR/predictions`: what the user's code writes.
pub const PREDICTIONS_DIR: &str = "predictions";
/// The index's format name.
pub const FORMAT: &str = "crossaudit-export 1";

/// NanoBench's 14 state columns, in the order of every state array.
pub const STATE_COLUMNS: [&str; STATE] =
    ["x", "y", "z", "vx", "vy", "vz", "qw", "qx", "qy", "qz", "ref_x", "ref_y", "ref_z", "battery"];
/// NanoBench's 4 action columns (motor commands in [0, 1]).
pub const ACTION_COLUMNS: [&str; ACTION] = ["u1", "u2", "u3", "u4"];

/// One external job of the export.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExportJob {
    /// The model.
    pub model: String,
    /// The arm whose fit windows it is fitted on.
    pub arm: String,
    /// The seed its training must use.
    pub seed: u64,
    /// The input map of `inputs`.
    pub inputs: InputMap,
    /// How the actions enter `inputs`.
    pub actions: ActionScaling,
    /// Samples of history the model declared (the last `history` of the
    /// exported histories; 0: none).
    pub history: usize,
    /// Horizons (s) it is evaluated at.
    pub horizons_s: Vec<f64>,
    /// Steps its predictions must cover.
    pub steps: usize,
    /// The predictions file expected, relative to the run directory.
    pub predictions: String,
    /// Its description, relative to the run directory.
    pub description: String,
    /// The shape `predictions` must have: [starts, steps, state] (state 14
    /// for NanoBench).
    pub shape: [usize; 3],
    /// Files of this job's inputs and targets (`fit_inputs`,
    /// `fit_targets`, `validation_inputs`, `validation_targets`).
    pub files: BTreeMap<String, String>,
    /// The standardizers of its inputs and targets, fitted on its arm's
    /// fit windows exactly as a built-in MLP's (invariant 6 checks them).
    pub standardizers: FeatureMap,
}

impl ExportJob {
    /// `model__arm__seed`.
    pub fn stem(&self) -> String {
        format!("{}__{}__{}", self.model, self.arm, self.seed)
    }
}

/// `DIR/export/export.json`: the index of the export. Its SHA-256 names the
/// export; every predictions description must quote it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExportIndex {
    /// [`FORMAT`].
    pub format: String,
    /// The study's name.
    pub study: String,
    /// SHA-256 of the design.
    pub design_sha256: String,
    /// Sample rate (Hz): one step is 1 / rate_hz seconds.
    pub rate_hz: f64,
    /// Names of the state columns (NanoBench: [`STATE_COLUMNS`]; `data
    /// csv`: the declared columns, a quaternion from Euler angles as
    /// `qw`, `qx`, `qy`, `qz`).
    pub state_columns: Vec<String>,
    /// Names of the action columns (NanoBench: [`ACTION_COLUMNS`]).
    pub action_columns: Vec<String>,
    /// State columns the rollout overwrites with measured values after
    /// every step (NanoBench: reference and battery): a model need not
    /// predict them.
    pub exogenous_columns: Vec<usize>,
    /// The target of the exported `*_targets` arrays.
    pub target: TargetKind,
    /// Samples in every exported history (the largest `history` declared).
    pub history: usize,
    /// Registered starts: the first dimension of every prediction.
    pub starts: usize,
    /// Steps of the starts' action and exogenous arrays.
    pub steps: usize,
    /// Per arm: its fit windows' files (`states`, `actions`,
    /// `next_states`, `history`).
    pub fit: BTreeMap<String, BTreeMap<String, String>>,
    /// The shared validation windows' files.
    pub validation: BTreeMap<String, String>,
    /// The starts' files (`states`, `actions`, `exogenous`, `history`,
    /// `table`).
    pub start_files: BTreeMap<String, String>,
    /// The external jobs, in plan order.
    pub jobs: Vec<ExportJob>,
    /// SHA-256 of every other file of the export.
    pub files: BTreeMap<String, String>,
}

/// `DIR/export/source.json`: where `score` finds the design and the data.
/// Not part of the export's hash; anything it points at must rebuild the
/// export byte for byte.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExportSource {
    /// The design as the user named it (the report quotes it).
    pub design_path: String,
    /// The design file's absolute path (its lock and referenced files are
    /// found beside it).
    pub design_file: PathBuf,
    /// The flight-log directory, absolute.
    pub data_dir: PathBuf,
    /// Where the logs came from, as run.json says.
    pub data: DataOrigin,
    /// In a study with outer levels (choices, draws, splits): the level
    /// this folder holds, by its folder name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub level: Option<String>,
}

/// An export built in memory: file name (relative to `DIR/export`) and
/// bytes, the index last.
pub struct Built {
    /// The arrays and tables.
    pub files: Vec<(String, Vec<u8>)>,
    /// The index.
    pub index: ExportIndex,
    /// `export.json`'s bytes.
    pub index_bytes: Vec<u8>,
}

impl Built {
    /// SHA-256 of `export.json`: the export's name.
    pub fn sha256(&self) -> String {
        sha256_hex(&self.index_bytes)
    }
}

/// The external jobs of `plan`.
pub fn external_jobs(plan: &Plan) -> Vec<&TrainingJob> {
    plan.jobs.iter().filter(|j| j.kind.is_external()).collect()
}

/// Refuses a design `export` cannot serve: one without an external model.
/// A design with outer levels (choices, draws, splits) is exported level
/// by level (`levels`).
pub fn check_exportable(_file: &DesignFile, plan: &Plan) -> Result<(), RunError> {
    if external_jobs(plan).is_empty() {
        return Err(RunError::NoExternalModels);
    }
    Ok(())
}

/// The names of the design's external models, for refusals.
pub fn external_names(plan: &Plan) -> Option<String> {
    let names: Vec<&str> = plan.models.iter().filter(|m| m.kind.is_external()).map(|m| m.name.as_str()).collect();
    (!names.is_empty()).then(|| names.join(", "))
}

/// What `export` wrote.
#[derive(Debug, Clone)]
pub struct ExportOutcome {
    /// `DIR/export`.
    pub dir: PathBuf,
    /// SHA-256 of `export.json`.
    pub sha256: String,
    /// External jobs.
    pub jobs: usize,
    /// Bytes written.
    pub bytes: u64,
    /// Outer levels exported, each in `OUT/LEVEL/export` (0: a single run).
    pub levels: usize,
}

/// Writes `out/export/` for the prepared split of `plan` (one level's, in
/// a study with outer levels: `level` names it in `source.json`).
pub(super) fn write_export(
    file: &DesignFile,
    plan: &Plan,
    prepared: &Prepared,
    data: &Data,
    out: &Path,
    level: Option<&str>,
) -> Result<ExportOutcome, RunError> {
    let built = build(&file.sha256, plan, prepared)?;
    let dir = out.join(EXPORT_DIR);
    create_dir_all(&dir)?;
    let mut bytes = 0u64;
    for (name, b) in &built.files {
        write_atomic(&dir.join(name), b)?;
        bytes += b.len() as u64;
    }
    let design_bytes =
        crate::io::read_own(&file.path).map_err(|e| RunError::Write(crate::io::WriteError::new(&file.path, e)))?;
    if sha256_hex(&design_bytes) != file.sha256 {
        return Err(RunError::NotPrepared {
            dir: out.display().to_string(),
            reason: format!("{} changed while it was being exported", file.path.display()),
        });
    }
    let absolute = |p: &Path| p.canonicalize().map_err(|e| RunError::Write(crate::io::WriteError::new(p, e)));
    let source = ExportSource {
        design_path: file.path.display().to_string(),
        design_file: absolute(&file.path)?,
        data_dir: absolute(&data.dir)?,
        data: data.origin.clone(),
        level: level.map(String::from),
    };
    write_atomic(&dir.join("design.design"), &design_bytes)?;
    write_atomic(&dir.join("source.json"), pretty_json(&source).as_bytes())?;
    write_atomic(&dir.join("export.json"), &built.index_bytes)?;
    bytes += built.index_bytes.len() as u64;
    Ok(ExportOutcome { dir, sha256: built.sha256(), jobs: built.index.jobs.len(), bytes, levels: 0 })
}

/// The export of `plan`'s external jobs on the prepared split, in memory.
pub fn build(design_sha256: &str, plan: &Plan, prepared: &Prepared) -> Result<Built, RunError> {
    let jobs = external_jobs(plan);
    let recs = &prepared.recordings;
    let split = &prepared.split;
    let history = jobs.iter().map(|j| history_of(j)).max().unwrap_or(0);
    let target = plan.training.as_ref().map(|t| t.target).unwrap_or(TargetKind::StateScaled);
    let steps = jobs.iter().map(|j| max_steps(j, plan.rate_hz)).max().unwrap_or(0);
    let slots = plan.slots;
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();

    // Windows: fit per arm, then validation.
    let mut fit = BTreeMap::new();
    // Per arm: its fit windows and its fit manifest's SHA-256.
    let mut arm_triples: BTreeMap<String, (Vec<Triple>, String)> = BTreeMap::new();
    for (arm, windows) in &split.fits {
        let prefix = format!("fit_{arm}");
        fit.insert(arm.clone(), window_files(&mut files, &prefix, recs, windows, history, &slots)?);
        let sha = prepared.manifests.sha256(&format!("fit_{arm}.csv")).to_string();
        arm_triples.insert(arm.clone(), (triples(recs, windows), sha));
    }
    let validation = window_files(&mut files, "validation", recs, &split.validation, history, &slots)?;
    let validation_triples = triples(recs, &split.validation);

    let start_files = start_files(&mut files, prepared, steps, history, &slots)?;
    let windows = (&arm_triples, validation_triples.as_slice());
    let out_jobs = export_jobs(&mut files, plan, &jobs, windows, target, split.starts.len())?;
    let index = ExportIndex {
        format: FORMAT.to_string(),
        study: plan.study.clone(),
        design_sha256: design_sha256.to_string(),
        rate_hz: plan.rate_hz,
        state_columns: column_names(plan).0,
        action_columns: column_names(plan).1,
        exogenous_columns: slots.exogenous().collect(),
        target,
        history,
        starts: split.starts.len(),
        steps,
        fit,
        validation,
        start_files,
        jobs: out_jobs,
        files: files.iter().map(|(n, b)| (n.clone(), sha256_hex(b))).collect(),
    };
    let index_bytes = pretty_json(&index).into_bytes();
    Ok(Built { files, index, index_bytes })
}

/// The starts' files: their states, the `steps` actions and exogenous
/// values after each, their histories (when a job declares one) and the
/// table naming each start's recording and sample.
fn start_files(
    files: &mut Vec<(String, Vec<u8>)>,
    prepared: &Prepared,
    steps: usize,
    history: usize,
    slots: &Slots,
) -> Result<BTreeMap<String, String>, RunError> {
    let recs = &prepared.recordings;
    let split = &prepared.split;
    let (state_dim, action_dim, exo) = (slots.state, slots.action, slots.exogenous());
    let starts = &split.starts;
    let s = starts.len();
    let mut start_files = BTreeMap::new();
    let states: Vec<f64> = starts.iter().flat_map(|w| recs[w.recording].state[w.t].iter().copied()).collect();
    start_files.insert("states".into(), put(files, "starts_states.npy".into(), &[s, state_dim], &states)?);
    let mut actions = Vec::with_capacity(s * steps * action_dim);
    let mut exogenous = Vec::with_capacity(s * steps * exo.len());
    for w in starts {
        let r = &recs[w.recording];
        for k in 1..=steps {
            actions.extend(&r.action[w.t + k - 1]);
            exogenous.extend(&r.state[w.t + k][exo.clone()]);
        }
    }
    let shape = [s, steps, action_dim];
    start_files.insert("actions".into(), put(files, "starts_actions.npy".into(), &shape, &actions)?);
    let shape = [s, steps, exo.len()];
    start_files.insert("exogenous".into(), put(files, "starts_exogenous.npy".into(), &shape, &exogenous)?);
    if history > 0 {
        let h = histories(recs, starts, history);
        let shape = [s, history, slots.input()];
        start_files.insert("history".into(), put(files, "starts_history.npy".into(), &shape, &h)?);
    }
    let mut table = String::from("index,recording,sample_index,trajectory,speed\n");
    for (i, w) in starts.iter().enumerate() {
        let info = &split.recordings[w.recording];
        table.push_str(&format!("{i},{},{},{},{}\n", info.name, w.t, info.trajectory, info.speed));
    }
    files.push(("starts.csv".into(), table.into_bytes()));
    start_files.insert("table".into(), "starts.csv".into());
    Ok(start_files)
}

/// Per arm, its fit windows and its fit manifest's SHA-256; and the
/// validation windows.
type Windows<'a> = (&'a BTreeMap<String, (Vec<Triple>, String)>, &'a [Triple]);

/// Per external job: its standardizers, fitted on its arm's fit windows,
/// and its entry of the index; the inputs and targets of each (model, arm)
/// written once. `starts`: the number of registered starts.
fn export_jobs(
    files: &mut Vec<(String, Vec<u8>)>,
    plan: &Plan,
    jobs: &[&TrainingJob],
    (arm_triples, validation_triples): Windows<'_>,
    target: TargetKind,
    starts: usize,
) -> Result<Vec<ExportJob>, RunError> {
    let slots = plan.slots;
    let mut out_jobs = Vec::new();
    let mut written: BTreeMap<(String, String), BTreeMap<String, String>> = BTreeMap::new();
    for j in jobs {
        let crate::design::ModelKind::External { inputs, actions, .. } = j.kind else { continue };
        let (fit_triples, fit_sha) =
            arm_triples.get(&j.arm).ok_or_else(|| RunError::NoFitSet { arm: j.arm.clone() })?;
        let features = FeatureMap::fit(slots, inputs, actions, target, fit_triples, fit_sha);
        let key = (j.model.clone(), j.arm.clone());
        if !written.contains_key(&key) {
            let f =
                model_files(files, j, (&features, &slots), [("fit", fit_triples), ("validation", validation_triples)])?;
            written.insert(key.clone(), f);
        }
        let job_steps = max_steps(j, plan.rate_hz);
        let stem = j.stem();
        out_jobs.push(ExportJob {
            model: j.model.clone(),
            arm: j.arm.clone(),
            seed: j.seed.0,
            inputs,
            actions,
            history: history_of(j),
            horizons_s: j.horizons_s.clone(),
            steps: job_steps,
            predictions: format!("{PREDICTIONS_DIR}/{stem}.npy"),
            description: format!("{PREDICTIONS_DIR}/{stem}.json"),
            shape: [starts, job_steps, slots.state],
            files: written[&key].clone(),
            standardizers: features,
        });
    }
    Ok(out_jobs)
}

/// The standardized inputs and targets (by `features`) of job `j`'s
/// (model, arm) on each part's windows (`fit`, `validation`), as `PART_ARM__MODEL_inputs.npy`
/// and `_targets.npy`.
fn model_files(
    files: &mut Vec<(String, Vec<u8>)>,
    j: &TrainingJob,
    (features, slots): (&FeatureMap, &Slots),
    parts: [(&str, &[Triple]); 2],
) -> Result<BTreeMap<String, String>, RunError> {
    let mut f = BTreeMap::new();
    for (part, windows) in parts {
        let n = windows.len();
        let (x, z) = inputs_targets(features, windows);
        let stem = format!("{part}_{}__{}", j.arm, j.model);
        let inputs_file = put(files, format!("{stem}_inputs.npy"), &[n, slots.input()], &x)?;
        f.insert(format!("{part}_inputs"), inputs_file);
        let targets_file = put(files, format!("{stem}_targets.npy"), &[n, slots.state], &z)?;
        f.insert(format!("{part}_targets"), targets_file);
    }
    Ok(f)
}

/// The names of the state and action columns in the export: NanoBench's
/// [`STATE_COLUMNS`] and [`ACTION_COLUMNS`], or a `data csv` block's own
/// (a quaternion computed from Euler angles as `qw`, `qx`, `qy`, `qz`).
fn column_names(plan: &Plan) -> (Vec<String>, Vec<String>) {
    match &plan.declared_columns {
        None => (
            STATE_COLUMNS.iter().map(|c| c.to_string()).collect(),
            ACTION_COLUMNS.iter().map(|c| c.to_string()).collect(),
        ),
        Some((state, actions)) => {
            let q = ["qw", "qx", "qy", "qz"];
            let state =
                state.iter().enumerate().map(|(k, c)| if c.is_empty() { q[k - 6].to_string() } else { c.clone() });
            (state.collect(), actions.clone())
        }
    }
}

/// A job's declared history (0 for none).
fn history_of(j: &TrainingJob) -> usize {
    match j.kind {
        crate::design::ModelKind::External { history, .. } => history,
        _ => 0,
    }
}

/// The steps a job's predictions cover: its longest horizon.
fn max_steps(j: &TrainingJob, rate_hz: f64) -> usize {
    crate::rollout::horizon_steps(&j.horizons_s, rate_hz).into_iter().max().unwrap_or(0)
}

/// One (x_t, u_t, x_{t+1}) window.
type Triple = (State, Action, State);

/// Adds `data`, of `shape`, to `files` as the `.npy` file `name`; the
/// name back, for the index.
fn put(files: &mut Vec<(String, Vec<u8>)>, name: String, shape: &[usize], data: &[f64]) -> Result<String, RunError> {
    let bytes = super::npy::write(shape, data)?;
    files.push((name.clone(), bytes));
    Ok(name)
}

/// `PREFIX_states.npy`, `_actions`, `_next_states` (and `_history`).
fn window_files(
    files: &mut Vec<(String, Vec<u8>)>,
    prefix: &str,
    recs: &[Recording],
    windows: &[Window],
    history: usize,
    slots: &Slots,
) -> Result<BTreeMap<String, String>, RunError> {
    let n = windows.len();
    let t = triples(recs, windows);
    let mut out = BTreeMap::new();
    let x: Vec<f64> = t.iter().flat_map(|w| w.0.iter().copied()).collect();
    let u: Vec<f64> = t.iter().flat_map(|w| w.1.iter().copied()).collect();
    let y: Vec<f64> = t.iter().flat_map(|w| w.2.iter().copied()).collect();
    out.insert("states".into(), put(files, format!("{prefix}_states.npy"), &[n, slots.state], &x)?);
    out.insert("actions".into(), put(files, format!("{prefix}_actions.npy"), &[n, slots.action], &u)?);
    out.insert("next_states".into(), put(files, format!("{prefix}_next_states.npy"), &[n, slots.state], &y)?);
    if history > 0 {
        let h = histories(recs, windows, history);
        let shape = [n, history, slots.input()];
        out.insert("history".into(), put(files, format!("{prefix}_history.npy"), &shape, &h)?);
    }
    Ok(out)
}

/// The `history` samples (state, action) before each window, oldest
/// first; before a recording's first sample, its first sample repeated.
fn histories(recs: &[Recording], windows: &[Window], history: usize) -> Vec<f64> {
    let mut out = Vec::new();
    for w in windows {
        let r = &recs[w.recording];
        for back in (1..=history).rev() {
            let t = w.t.saturating_sub(back);
            out.extend(&r.state[t]);
            out.extend(&r.action[t]);
        }
    }
    out
}

/// Standardized inputs and targets of `windows` (as a built-in MLP sees
/// them, in single precision).
fn inputs_targets(features: &FeatureMap, windows: &[(State, Action, State)]) -> (Vec<f64>, Vec<f64>) {
    let slots = &features.slots;
    let (mut x, mut z) = (Vec::new(), Vec::new());
    let (mut xi, mut zi) = (vec![0f32; slots.input()], vec![0f32; slots.state]);
    for (s, u, n) in windows {
        features.input(s, u, &mut xi);
        features.target(s, n, &mut zi);
        x.extend(xi.iter().map(|v| f64::from(*v)));
        z.extend(zi.iter().map(|v| f64::from(*v)));
    }
    (x, z)
}
