//! Why a run, a job, a Slurm step or a split of a run directory failed: one
//! error type for the orchestrator, each variant saying what to do next.

use crate::analysis::FileAnalysisError;
use crate::cells::CellsError;
use crate::design::lock;
use crate::io::WriteError;

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// `run`, `train` or Slurm was asked to fit a model crossaudit cannot fit.
    #[error("the design declares external models ({models}), which crossaudit does not train: write what they are fitted on with `crossaudit export DESIGN --out DIR`, fit them with your own code, write their rollouts to DIR/predictions/, then run `crossaudit score DIR` (docs/external.md)")]
    ExternalModels {
        /// The external models' names.
        models: String,
    },
    /// `export` of a design without an external model.
    #[error("the design declares no external model (`model NAME = external inputs world`), so there is nothing to export; `crossaudit run` trains its models itself")]
    NoExternalModels,
    /// `export` of a study of several runs.
    #[error("external models are exported for a study of one run; this design has {what}: write one design per level")]
    ExportOuter {
        /// The outer factors.
        what: String,
    },
    /// A file of `DIR/export/` is not what export wrote.
    #[error("{path} is not what `crossaudit export` wrote for this design and data ({reason}); predictions must be made from an unedited export: export again into a new directory")]
    ExportChanged {
        /// The file.
        path: String,
        /// What differs.
        reason: String,
    },
    /// A predictions file or its description is refused.
    #[error("{path}: {reason}")]
    BadPredictions {
        /// The file.
        path: String,
        /// Why, and what is expected.
        reason: String,
    },
    /// Prediction files refused, every one named (and any jobs without
    /// predictions), in one run.
    #[error("{refused} of {jobs} external jobs' predictions are refused{summary}; every problem found is listed (the {scored} valid ones are scored and kept):\n{list}")]
    PredictionsRefused {
        /// Jobs whose predictions are refused.
        refused: usize,
        /// External jobs.
        jobs: usize,
        /// Jobs scored (now or before).
        scored: usize,
        /// ", and N have none" where some are missing too.
        summary: String,
        /// One line per problem.
        list: String,
    },
    /// Some external jobs have no predictions yet.
    #[error("{missing} of {jobs} external jobs have no predictions in {dir}/predictions (the {scored} present are scored and kept; cells.csv and the report are written once all are there):\n{list}")]
    PredictionsMissing {
        /// The run directory.
        dir: String,
        /// Jobs without predictions.
        missing: usize,
        /// External jobs.
        jobs: usize,
        /// Jobs scored (now or before).
        scored: usize,
        /// One line per missing job: the file expected.
        list: String,
    },
    /// The design changed after it was locked and the run was not labelled exploratory.
    #[error("{path} changed after it was locked ({reason}); rerun with --exploratory to label every output EXPLORATORY, or lock an amended design")]
    LockChanged {
        /// The design file.
        path: String,
        /// What changed: the design's bytes, a file it refers to, or the language defaults.
        reason: String,
    },
    /// The output directory holds a run of another design.
    #[error("{dir} holds a run of a different design (sha256 {sha256}); use a new output directory")]
    OtherDesign {
        /// The output directory.
        dir: String,
        /// The other design's hash.
        sha256: String,
    },
    /// A run folder read back (to analyse, score or combine it) is the run
    /// of another design than the one given.
    #[error("{dir} is a run of another design (sha256 {sha256}), not of {design} (sha256 {given}): analyse it with the design it ran (a design amended since is another design: rerun it, or `run --reuse` this folder into a new one)")]
    RanOtherDesign {
        /// The run folder.
        dir: String,
        /// The design it ran, by hash.
        sha256: String,
        /// The design given.
        design: String,
        /// The given design's hash.
        given: String,
    },
    /// An analysis or plan would write into a folder a run wrote (the
    /// run's own report, its cells, a level folder): replacing it would
    /// lose what only the run knows (its warnings, its treatment audit).
    #[error("{dir} is {what} of the run in {run}, which only the run itself writes (a resume reads its data and audits back, and its report carries the run's warnings and audits, which a reanalysis of per-cell data does not have); write into a new folder, for example --out {suggest}")]
    RunsOwnFolder {
        /// The output directory, as given.
        dir: String,
        /// What it is: "the folder", "a folder".
        what: &'static str,
        /// The run's directory.
        run: String,
        /// A folder that may be used instead.
        suggest: String,
    },
    /// A run's output folder inside another run's folder.
    #[error("{dir} lies inside the run in {run}: a run is never written into another run's folder (its files would mix with that run's, and a resume, `--reuse` or reanalysis of {run} would read them); write into a new folder outside it, for example --out {suggest}")]
    RunInsideRun {
        /// The output directory, as given.
        dir: String,
        /// The run it lies in.
        run: String,
        /// A folder that may be used instead.
        suggest: String,
    },
    /// A run's record (run.json, study.json, combined.json) edited after
    /// crossaudit wrote it: its seal ([`crate::io::seal`]) no longer holds.
    #[error("{path} was edited after crossaudit wrote it (its content hashes to {now}, but its seal records {recorded}): a report quotes what it records (the data, the lock the run began under, its label, its notes), so nothing in {dir} is analysed or reused under it; restore it, or run again into a new output directory")]
    RecordEdited {
        /// The record.
        path: String,
        /// The run folder.
        dir: String,
        /// Its content's SHA-256 now.
        now: String,
        /// Its seal.
        recorded: String,
    },
    /// run.json cannot be read, or is missing beside a run's outputs.
    #[error("{path} cannot be read as the record of a run ({reason}), so nothing in {dir} can be verified for reuse; use a new output directory")]
    BadRunRecord {
        /// run.json.
        path: String,
        /// The output directory.
        dir: String,
        /// Why.
        reason: String,
    },
    /// What `check` found `run` would refuse about the data.
    #[error("run refuses this design on {data}: {source}")]
    DataRefused {
        /// The logs, in words (`the data in DIR`, `its simulated data`).
        data: String,
        /// The refusal.
        source: Box<RunError>,
    },
    /// Runs that cannot be combined, or a combined folder whose sources
    /// changed.
    #[error("{path}: {reason}")]
    Combine {
        /// The file or folder at fault.
        path: String,
        /// Why.
        reason: String,
    },
    /// The run being resumed used other data.
    #[error("{dir} holds a run on other data: its {what} was {was}, now {is}; use a new output directory")]
    OtherData {
        /// The output directory.
        dir: String,
        /// What differs.
        what: String,
        /// As recorded.
        was: String,
        /// Now.
        is: String,
    },
    /// A run folder given to `--reuse` cannot be reused.
    #[error("--reuse {path}: {reason}")]
    Reuse {
        /// The folder or file.
        path: String,
        /// Why.
        reason: String,
    },
    /// A job record cannot be read.
    #[error("{path} cannot be read as a job record ({reason}); delete it to train that job again")]
    BadJobRecord {
        /// The record.
        path: String,
        /// Why.
        reason: String,
    },
    /// A finished job's file changed after the job wrote it.
    #[error("{path} is not the file its job wrote ({reason}, see {record}); delete both to train that job again")]
    JobFileChanged {
        /// The file.
        path: String,
        /// The job record that lists it.
        record: String,
        /// Missing, or its SHA-256 against the recorded one.
        reason: String,
    },
    /// The job records contradict an invariant.
    #[error("invariants failed on what the jobs recorded (see {path}):\n{list}")]
    TrainedInvariants {
        /// `audit/invariants_trained.json`.
        path: String,
        /// The failures, one per line.
        list: String,
    },
    /// A run whose audit and manifests hash the logs' text, written before
    /// the content hashes were defined on the values read: this build
    /// cannot check them against the data.
    #[error(
        "{dir} was written by crossaudit {build}, whose content hashes of the logs (in its audit and manifests) are of their text; this build hashes the values read, so it cannot check that run against the data: finish it with the build that started it, or run into a new output directory (its cells.csv and report still read with `crossaudit analyze`)"
    )]
    OtherContentHashes {
        /// The output directory.
        dir: String,
        /// The build that wrote it.
        build: String,
    },
    /// The manifests differ from those of the run being resumed.
    #[error("the manifests differ from those of the run in {dir} (the data changed?); use a new output directory")]
    ManifestsChanged {
        /// The output directory.
        dir: String,
    },
    /// A level folder that holds another level of the study (two level
    /// folders swapped or renamed).
    #[error("{dir} holds the run of level {was}, not of {is}: level folders were renamed or swapped; put them back or rerun")]
    WrongLevel {
        /// The level's folder.
        dir: String,
        /// The level its run.json records.
        was: String,
        /// The level the folder's name says.
        is: String,
    },
    /// A reanalysis found a level whose files are not those its run wrote.
    #[error("cannot reanalyse {dir}: {reason}")]
    LevelChanged {
        /// The level's folder.
        dir: String,
        /// What differs.
        reason: String,
    },
    /// `--workers 0`.
    #[error("--workers must be at least 1")]
    NoWorkers,
    /// More workers than threads a process should start.
    #[error(
        "--workers {workers} is more than {max}: each worker is a thread training one job; use at most one per core"
    )]
    TooManyWorkers {
        /// As given.
        workers: usize,
        /// The most a run starts ([`super::MAX_WORKERS`]).
        max: usize,
    },
    /// A worker's thread pool could not start.
    #[error("worker pool: {0}")]
    WorkerPool(#[from] rayon::ThreadPoolBuildError),
    /// A parameter-free model scored differently on two arms.
    #[error("parameter-free model `{model}` scored differently on arms `{left}` and `{right}`: its rollouts depend on the arm, which they must not")]
    BaselineDependsOnArm {
        /// The model.
        model: String,
        /// One arm.
        left: String,
        /// The other.
        right: String,
    },
    /// A fitted model with no `train` block (validation prevents this).
    #[error("the design has no train block")]
    NoTraining,
    /// An arm without a fit set (validation prevents this).
    #[error("arm `{arm}` has no fit set")]
    NoFitSet {
        /// The arm.
        arm: String,
    },
    /// A job named on the command line is not in the plan.
    #[error("no training job {job} in the design ({known})")]
    UnknownJob {
        /// `model/arm/seed` as asked for.
        job: String,
        /// The design's models, arms and seeds.
        known: String,
    },
    /// `simulate` on a design whose data are not simulated.
    #[error("{path}: the data source is not `simulated`")]
    NotSimulated {
        /// The design file.
        path: String,
    },
    /// `--data` on a design whose data are simulated.
    #[error("the design's data are `simulated`: --data would train on other logs under the simulated study's name; remove --data, or write a design whose data block names a `path`")]
    DataOverride,
    /// A relative data path that names two different directories.
    #[error("the design's data path {path} names two different directories: {beside} (from the design's directory) and {path} (from the current directory); make it absolute or run from the design's directory")]
    AmbiguousDataPath {
        /// The path as written.
        path: String,
        /// Resolved from the design file's directory.
        beside: String,
    },
    /// The design has no data path and none was given.
    #[error("the design's data block has no `path`; pass --data DIR")]
    NoDataPath,
    /// The output folder is, or is inside, or holds the data folder.
    #[error("the output folder {out} {how} {data}: what crossaudit writes there would be read back as flight logs; choose an output folder outside the data folder")]
    OutInData {
        /// The output folder as given.
        out: String,
        /// The data folder as given.
        data: String,
        /// "is the data folder", "is inside the data folder" or "holds the data folder".
        how: &'static str,
    },
    /// Another crossaudit process holds the output folder's lock.
    #[error("{dir} is in use by another crossaudit process (a run, train, gather or job on it has not ended); wait for it to end, or use another output folder")]
    FolderBusy {
        /// The folder.
        dir: String,
    },
    /// The data directory does not exist, or is not a directory.
    #[error("data directory {dir} {}", if std::path::Path::new(dir).exists() { "is not a directory (give the folder that holds the logs)" } else { "does not exist" })]
    NoDataDir {
        /// The directory.
        dir: String,
    },
    /// Simulated recordings could not be written.
    #[error(transparent)]
    Simulate(#[from] crate::sim::SimulateError),
    /// A training curve could not be written or read.
    #[error("{path}: {source}")]
    Csv {
        /// The curve file.
        path: String,
        /// Why.
        source: csv::Error,
    },
    /// The lock file could not be read.
    #[error(transparent)]
    Lock(#[from] lock::LockError),
    /// The split could not be prepared or an invariant failed.
    #[error(transparent)]
    Split(#[from] crate::split::SplitError),
    /// Training or saving a network failed.
    #[error(transparent)]
    Net(#[from] crate::model::NetError),
    /// The device asked for cannot be used (`run --device`).
    #[error("{0}")]
    Device(String),
    /// A linear model could not be fitted.
    #[error("model `{model}`: {source}")]
    Linear {
        /// The model.
        model: String,
        /// Why.
        source: crate::model::LinearError,
    },
    /// A per-cell file could not be written or read back.
    #[error(transparent)]
    Cells(#[from] CellsError),
    /// The finished cells could not be analysed.
    #[error(transparent)]
    Analysis(#[from] FileAnalysisError),
    /// The report or its figures could not be written.
    #[error(transparent)]
    Report(#[from] crate::report::ReportError),
    /// A file could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// A Slurm option sbatch would misread.
    #[error("{option} {value:?}: expected {expected}")]
    SlurmOption {
        /// The flag.
        option: String,
        /// As given.
        value: String,
        /// What it may be.
        expected: String,
    },
    /// A path that cannot go into a Slurm script as it is.
    #[error("{path} cannot be used in a Slurm script: {reason}; choose another directory")]
    UnsafeClusterPath {
        /// The path.
        path: String,
        /// Why.
        reason: String,
    },
    /// A directory that `run --slurm` did not prepare, or whose records disagree.
    #[error(
        "{dir} is not a run prepared for Slurm ({reason}); prepare it with `crossaudit run DESIGN --out {dir} --slurm`"
    )]
    NotPrepared {
        /// The run directory.
        dir: String,
        /// What is missing or inconsistent.
        reason: String,
    },
    /// `score` on a directory that `export` did not prepare.
    #[error("{dir} is not an export of models fitted elsewhere ({reason}); run `crossaudit export DESIGN --out DIR` first and add your predictions to its predictions/")]
    NotExported {
        /// The directory.
        dir: String,
        /// What is missing or inconsistent.
        reason: String,
    },
    /// An array index beyond the job list.
    #[error("array index {index} is out of range: the study has {}", task_range(*jobs, *tasks, *per_task))]
    NoSuchTask {
        /// The index asked for.
        index: usize,
        /// Jobs in the study.
        jobs: usize,
        /// Array tasks in the study.
        tasks: usize,
        /// Jobs per task.
        per_task: usize,
    },
    /// Another process holds the job's lock.
    #[error("job {job} is being run by another process (it holds {lock}); wait for it, or cancel it first")]
    JobBusy {
        /// `model/arm/seed`.
        job: String,
        /// The lock file.
        lock: String,
    },
    /// The gather step found jobs without a record.
    #[error("{missing} of {jobs} jobs in {dir} have not finished, so cells.csv and the report were not written:\n{list}resubmit with `sh {dir}/slurm/submit.sh` (finished jobs are skipped), or run the missing ones with `crossaudit job {dir} --index N`")]
    JobsMissing {
        /// The run directory.
        dir: String,
        /// How many jobs have no record.
        missing: usize,
        /// Jobs in the study.
        jobs: usize,
        /// One line per missing job: index, job, Slurm log.
        list: String,
    },
    /// A level of a study with outer factors failed; its label says which.
    #[error("{level}: {source}")]
    InLevel {
        /// `spec-s3 (state=onboard, tails=keep)`, `draw-2`, `split-44`.
        level: String,
        /// What failed.
        source: Box<RunError>,
    },
    /// `split` or `train` was given a design whose study is several runs.
    #[error("{design}: a design with choices, a draw factor or per-seed draws is several runs; `crossaudit run` prepares and trains every one (`{command}` would do one level only)")]
    OuterOneLevel {
        /// The design.
        design: String,
        /// The command refused.
        command: &'static str,
    },
    /// `analyze --cells DIR` of a multiverse needs a design with outer levels and a run directory.
    #[error("{design}: a design with choices or a draw factor is analysed from its run directory: `crossaudit analyze DESIGN --cells RUN_DIR`")]
    NotOuter {
        /// The design.
        design: String,
    },
    /// Submitting to Slurm failed.
    #[error("submitting {script} failed: {reason}")]
    Submit {
        /// submit.sh.
        script: String,
        /// Why (sbatch's message).
        reason: String,
    },
}

/// A prepared array's tasks as [`RunError::NoSuchTask`] names them.
fn task_range(jobs: usize, tasks: usize, per_task: usize) -> String {
    let last = tasks.saturating_sub(1);
    match per_task {
        1 => format!("{jobs} jobs, indices 0 to {last}"),
        _ => format!("{jobs} jobs in {tasks} tasks of up to {per_task}, indices 0 to {last}"),
    }
}

impl RunError {
    /// The refusal of run folder `dir`, a run of the design with hash
    /// `sha256`, read back under the other design `design`.
    pub(crate) fn ran_other(dir: String, sha256: String, design: &crate::analysis::record::DesignLabel) -> RunError {
        RunError::RanOtherDesign { dir, sha256, design: design.path.clone(), given: design.sha256.clone() }
    }
}
