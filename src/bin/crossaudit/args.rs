//! The command line's arguments: every subcommand and its options, as
//! clap parses them. `main.rs` makes one library call per subcommand.

use std::path::PathBuf;

use clap::{Parser, Subcommand};

/// The most threads `--threads` (or `RAYON_NUM_THREADS`) may ask for:
/// more start for minutes before any work.
pub(crate) const MAX_THREADS: u16 = 1024;

#[derive(Parser)]
#[command(name = "crossaudit", version = crossaudit::BUILD, about = "Preregistered, leakage-aware evaluation of learned dynamics models")]
pub(crate) struct Cli {
    /// Threads for everything but the training workers: reading per-cell
    /// files and logs, the analysis, the audits [default: one per core].
    /// Results are the same, bit for bit, at any number (at most 1024).
    #[arg(long, global = true, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=MAX_THREADS as i64))]
    pub(crate) threads: Option<u16>,
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Validate a design and print its compiled plan.
    Check {
        /// The design file (.design).
        design: PathBuf,
        /// Print the plan (and the validated design) as JSON.
        #[arg(long)]
        json: bool,
        /// Read these logs instead of the design's data `path`: the
        /// inclusion audit and each level's split are built as `run` builds
        /// them, writing nothing.
        #[arg(long)]
        data: Option<PathBuf>,
    },
    /// Record the design's SHA-256, tool version and UTC time in FILE.design.lock.
    Lock {
        /// The design file (.design); the lock is written beside it.
        design: PathBuf,
        /// Re-lock a design changed after it was locked, recording the
        /// replaced lock and this reason: every report of a run under the
        /// new lock states the amendment.
        #[arg(long, value_name = "REASON")]
        amend: Option<String>,
        /// Mark the design post hoc: written (or locked) after results were
        /// known, with this reason. Every report of a run under the lock
        /// says POST HOC, never preregistered; locks the design if it has
        /// no lock, and no command removes the mark.
        #[arg(long, value_name = "REASON", conflicts_with = "amend")]
        posthoc: Option<String>,
    },
    /// Audits: of a benchmark's published split.
    Audit {
        #[command(subcommand)]
        command: AuditCommand,
    },
    /// Flight-log data commands.
    Data {
        #[command(subcommand)]
        command: DataCommand,
    },
    /// Build the shared experiment: manifests, invariants, treatment audit.
    Split {
        /// The design file (.design).
        design: PathBuf,
        /// Data directory [default: the design's `path`].
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output directory (manifests/, audit/).
        #[arg(long)]
        out: PathBuf,
    },
    /// Run one training cell end to end: split, fit, rollouts, per-cell rows.
    Train {
        /// The design file (.design).
        design: PathBuf,
        /// The job's model, as `crossaudit check` lists it.
        #[arg(long)]
        model: String,
        /// The job's arm.
        #[arg(long)]
        arm: String,
        /// The job's training seed.
        #[arg(long)]
        seed: u64,
        /// Data directory [default: the design's `path`].
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output directory (manifests/, audit/, models/, cells/, curves/).
        #[arg(long)]
        out: PathBuf,
        /// Trainer: `fused` (default) or `reference` (dfdx's own; bit-identical
        /// results, about half the speed).
        #[arg(long, default_value = "fused", value_parser = ["fused", "reference"])]
        engine: String,
        /// Allow a design changed after locking; every output is labelled EXPLORATORY.
        #[arg(long)]
        exploratory: bool,
    },
    /// Run a design end to end: audit, manifests, invariants, every training
    /// cell, cells.csv and the report. Resumes a partial run. Lock the design
    /// first (`crossaudit lock`) for a preregistered run; a design never
    /// locked runs labelled as not preregistered.
    Run {
        /// The design file (.design).
        design: PathBuf,
        /// Data directory [default: the design's `path`].
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Parallel training workers, one thread each [default: one per core].
        #[arg(long)]
        workers: Option<usize>,
        /// Where the networks train: `cpu` (the reference, bit-identical to
        /// every committed run), `cuda` (every network of the study batched
        /// on the first NVIDIA GPU; refused where none is found) or `auto`
        /// (the GPU where one is found, else the CPU). Recorded in run.json
        /// and each job's record; not part of the lock. With --slurm, each
        /// array task looks on its own node (`cuda` asks Slurm for a GPU
        /// per task).
        #[arg(long, default_value = "cpu", value_parser = ["cpu", "cuda", "auto"])]
        device: String,
        /// Allow a design changed after locking; every output is labelled EXPLORATORY.
        #[arg(long)]
        exploratory: bool,
        /// An earlier run folder: its finished jobs whose inputs are
        /// identical (same content key, model, arm and seed) are copied
        /// instead of trained. With `lock --amend`, this extends a locked
        /// per-seed study with further seeds.
        #[arg(long, conflicts_with = "slurm")]
        reuse: Option<PathBuf>,
        #[command(flatten)]
        slurm: SlurmArgs,
    },
    /// Open a run directory as `run` does and write, for every external
    /// model's job, the windows, standardizers and rollout starts its
    /// trainer needs (DIR/export/: .npy arrays indexed by export.json).
    Export {
        /// The design file (.design).
        design: PathBuf,
        /// Data directory [default: the design's `path`].
        #[arg(long)]
        data: Option<PathBuf>,
        /// The run directory (DIR/export/ is written in it; predictions go in DIR/predictions/).
        #[arg(long)]
        out: PathBuf,
        /// Allow a design changed after locking; every output is labelled EXPLORATORY.
        #[arg(long)]
        exploratory: bool,
    },
    /// Score the external models' predictions in DIR/predictions/
    /// (MODEL__ARM__SEED.npy with its .json description) with the built-in
    /// rollouts' code, run the built-in models, write cells.csv and the
    /// report. Resumes; names the jobs still missing.
    Score {
        /// The run directory written by `crossaudit export`.
        dir: PathBuf,
        /// Parallel training workers for the built-in models, one thread each [default: one per core].
        #[arg(long)]
        workers: Option<usize>,
    },
    /// Run one training job of a run prepared with `run --slurm` (what each
    /// Slurm array task runs); a finished job is verified and skipped.
    Job {
        /// The run directory.
        dir: PathBuf,
        /// The job's array index (SLURM_ARRAY_TASK_ID).
        #[arg(long)]
        index: usize,
    },
    /// Write cells.csv and the report of a run prepared with `run --slurm`
    /// (what the dependent gather job runs); refuses while any job is
    /// unfinished, naming each with its Slurm log.
    Gather {
        /// The run directory.
        dir: PathBuf,
    },
    /// Monte Carlo coverage of the interval estimators over a grid of crossed
    /// settings (JSON spec).
    Coverage {
        /// The coverage spec (JSON): settings, estimators, replications.
        spec: PathBuf,
        /// Override the spec's replications per setting.
        #[arg(long)]
        reps: Option<usize>,
        /// Output directory for coverage.csv, coverage.md, coverage.svg.
        #[arg(long, default_value = "coverage")]
        out: PathBuf,
        /// Also write replications.csv: every replication's estimate, SE,
        /// interval and df, tidy, as R's rsimsum reads it.
        #[arg(long)]
        replications: bool,
    },
    /// Anyone's simulation study in: rsimsum's performance measures with
    /// their Monte Carlo SEs from a replications CSV or Parquet file (one row per method
    /// and replication), methods paired by replication id, and each method
    /// against the reference with paired MCSEs. Writes simsum.csv (tidy, as
    /// rsimsum's `tidy()`), simsum.md and simsum.svg (coverage per group and
    /// method with 2-MCSE bars).
    Simsum(SimsumArgs),
    /// Predict SE, interval width and the probability the decision rule holds
    /// for other numbers of recordings and seeds (and splits, or draws), from
    /// pilot per-cell data; for a dose-response design, of the slope over
    /// doses; for a design with `factor draw`, of d pooled over draws and
    /// with per-seed draws. Or, with no pilot, from declared variance
    /// components (`--components`, `--effect`, `--reference-mean`).
    Plan {
        /// The design file (.design).
        design: PathBuf,
        /// Pilot per-cell CSV analysable under the design (or, for a
        /// design with `factor draw`, its run directory).
        #[arg(long, required_unless_present = "components", conflicts_with = "components")]
        cells: Option<PathBuf>,
        /// Plan from declared variance components instead of a pilot:
        /// `recording=V,seed=V,residual=V`, the components of the primary
        /// contrast d, SE^2 = recording/I + seed/J + residual/(IJ) (as
        /// plan.json's sigma2_recording, sigma2_seed, sigma2_residual). A
        /// single crossed contrast only.
        #[arg(long, requires_all = ["effect", "reference_mean"])]
        components: Option<String>,
        /// With --components: the true effect d, in the endpoint's unit.
        #[arg(long, allow_hyphen_values = true, requires = "components")]
        effect: Option<f64>,
        /// With --components: the reference arm's mean, for an
        /// `optimism >= c%` rule.
        #[arg(long, allow_hyphen_values = true, requires = "components")]
        reference_mean: Option<f64>,
        /// Numbers of recordings to consider.
        #[arg(long, value_delimiter = ',', default_value = "13,26,52")]
        recordings: Vec<usize>,
        /// Numbers of seeds to consider.
        #[arg(long, value_delimiter = ',', default_value = "3,5,10,20,40")]
        seeds: Vec<usize>,
        /// Numbers of splits to consider (a design with a split factor).
        /// [default: 3,5,10]
        #[arg(long, value_delimiter = ',')]
        splits: Option<Vec<usize>>,
        /// Numbers of draws to pool over (a design with `factor draw`,
        /// whose `--cells` is its run directory).
        /// [default: 3,5,10]
        #[arg(long, value_delimiter = ',')]
        draws: Option<Vec<usize>>,
        /// Output directory for plan.md, plan.json, plan.svg.
        #[arg(long, default_value = "plan")]
        out: PathBuf,
    },
    /// Fit a linear mixed model with random intercepts and slopes (crossed
    /// or nested) to any tidy CSV, as lme4's lmer with lmerTest's and
    /// pbkrtest's small-sample df: `y ~ 1 + x + f + (1|a) + (1|b) + (1|a:c)`,
    /// `y ~ x + (x | g)`.
    Mixed(MixedArgs),
    /// Generate the recordings of a `data simulated` design (NanoBench schema).
    Simulate {
        /// The design file (.design).
        design: PathBuf,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Write a simulated lab's folder as a lab publishes it: 21 Parquet
    /// logs in train/ and test/, quaternions 1.5% long, NaN motion-capture
    /// columns, a flight whose motion capture freezes and one with a 5 s
    /// gap (the fixture of designs/logs/lab.design and docs/own-logs.md).
    SimulateLab {
        /// Output directory (its train/ and test/ are written).
        #[arg(long)]
        out: PathBuf,
        /// The simulator's seed.
        #[arg(long, default_value_t = 7)]
        seed: u64,
    },
    /// Run the design's analysis on a run folder (its cells and the evidence
    /// beside them: the same report the run wrote) or on a per-cell CSV alone.
    Analyze {
        /// The design file (.design).
        design: PathBuf,
        /// The run folder (a run's --out), or a per-cell CSV alone (its
        /// columns: docs/usage.md, "Per-cell CSV"; the report then names the
        /// evidence only a run folder holds). A multiverse or draw-replicated
        /// design needs its run folder.
        #[arg(long)]
        cells: PathBuf,
        /// Output directory for report.md, results.json and results.tex
        /// [default: report/ next to the cells file; for a run folder, or a
        /// cells file in one, reanalysis/ in the run folder, beside the
        /// run's own report/].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Add every interval estimator side by side for each contrast.
        #[arg(long)]
        compare_intervals: bool,
    },
    /// Analyse finished runs of one protocol as one study (for example two
    /// sets of per-seed draws), with every run's evidence: writes
    /// OUT/cells.csv (each run's seeds shifted), OUT/combined.json (the runs
    /// and their hashes) and OUT/report. `analyze DESIGN --cells OUT`
    /// reads the folder back, verifying every run again.
    Combine {
        /// The combined design: the runs' protocol, with `factor seed`
        /// declaring the shifted seeds (docs/usage.md, "Combining runs").
        design: PathBuf,
        /// A run to combine: its design, its run folder and the number
        /// added to each of its seeds (0 for none); once per run.
        #[arg(long = "from", num_args = 3, value_names = ["DESIGN", "RUN_DIR", "SEED_SHIFT"], action = clap::ArgAction::Append, required = true, allow_hyphen_values = true)]
        from: Vec<String>,
        /// The combined folder.
        #[arg(long)]
        out: PathBuf,
    },
}

/// `run --slurm`: prepare the run directory for a Slurm job array.
#[derive(clap::Args)]
pub(crate) struct SlurmArgs {
    /// Prepare DIR (audit, manifests, invariants, job list) and write
    /// DIR/slurm/submit.sh: a job array with one task per training job (or
    /// per --jobs-per-task jobs) and a dependent gather job. Nothing trains
    /// here.
    #[arg(long, conflicts_with = "workers")]
    pub(crate) slurm: bool,
    /// Submit with sbatch after writing the scripts.
    #[arg(long, requires = "slurm")]
    pub(crate) submit: bool,
    /// CPUs per array task.
    #[arg(long, default_value_t = 1, requires = "slurm")]
    pub(crate) cpus: usize,
    /// Training jobs per array task: task t runs jobs t x N to t x N + N - 1
    /// of the array, their networks trained together on a GPU
    /// (--device cuda or auto), one after another on the CPU.
    #[arg(long, default_value_t = 1, requires = "slurm")]
    pub(crate) jobs_per_task: usize,
    /// Memory per array task (sbatch --mem); a job of the paper's protocol
    /// peaks at 110 MB.
    #[arg(long, default_value = "1G", requires = "slurm")]
    pub(crate) mem: String,
    /// At most N array tasks at once (the array's %N).
    #[arg(long, requires = "slurm")]
    pub(crate) throttle: Option<usize>,
    /// Wall-time limit per task (sbatch --time).
    #[arg(long, requires = "slurm")]
    pub(crate) time: Option<String>,
    /// Slurm partition.
    #[arg(long, requires = "slurm")]
    pub(crate) partition: Option<String>,
    /// Slurm account.
    #[arg(long, requires = "slurm")]
    pub(crate) account: Option<String>,
}

#[derive(Subcommand)]
pub(crate) enum DataCommand {
    /// Load every recording, apply the design's inclusion rules in order,
    /// write recordings.csv and print a summary.
    Audit {
        /// The design file (.design).
        design: PathBuf,
        /// Data directory [default: the design's `path`, read from the design file's
        /// directory, or from the current directory when it exists only there].
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output directory for recordings.csv.
        #[arg(long, default_value = "audit")]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
pub(crate) enum AuditCommand {
    /// Audit a published split (NanoBench split_metadata.json, a
    /// recording,role CSV, a fold list, or a per-window CSV with start_s and
    /// end_s): declared vs effective membership, identical recordings
    /// across roles, shared runs of rows, each window's distance in time to
    /// the nearest window of another role in the same recording, and each
    /// role's trajectory x speed composition.
    Split {
        /// The split file (.json or .csv).
        split: PathBuf,
        /// Data directory holding the recordings.
        #[arg(long)]
        data: PathBuf,
        /// Apply this design's data rules [default: upstream NanoBench task-2
        /// loader's: active motor_motor_m1 > 1000, plausibility bounds pooled].
        #[arg(long)]
        design: Option<PathBuf>,
        /// Output directory for split_audit.md, split_audit.json,
        /// split_recordings.csv, split_windows.csv.
        #[arg(long, default_value = "split_audit")]
        out: PathBuf,
        /// Shortest run of identical rows reported between non-identical recordings.
        #[arg(long, default_value_t = crossaudit::split_audit::DEFAULT_MIN_RUN_ROWS,
              value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..))]
        min_run: usize,
        /// The gap, in seconds, a window should keep from every window of
        /// another role in the same recording; the audit counts the windows
        /// closer than that.
        #[arg(long, default_value_t = crossaudit::split_audit::DEFAULT_GAP_S, value_name = "SECONDS",
              value_parser = positive_seconds, allow_hyphen_values = true)]
        gap: f64,
        /// `leak`: exit with status 3 when two roles hold byte-identical
        /// recordings or overlapping windows; `gap`: also when a window
        /// lies within `--gap` of another role's (after writing every
        /// output), for a benchmark's CI.
        #[arg(long, value_parser = ["leak", "gap"])]
        fail_on: Option<String>,
    },
}

/// A gap in seconds: a finite number above 0.
fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("\"{s}\" is not a number of seconds above 0")),
    }
}

/// `crossaudit simsum`'s arguments.
#[derive(clap::Args)]
pub(crate) struct SimsumArgs {
    /// The replications file: CSV, or Parquet (`.parquet`, read by column
    /// as its CSV twin reads: a null is a missing value).
    pub(crate) file: PathBuf,
    /// The estimate column.
    #[arg(long, default_value = "estimate")]
    pub(crate) estimate: String,
    /// The standard-error column.
    #[arg(long, default_value = "se")]
    pub(crate) se: String,
    /// The method column.
    #[arg(long, default_value = "method")]
    pub(crate) method: String,
    /// The replication-id column (methods are paired by it; without
    /// one, by row order within each group, as rsimsum pairs them).
    #[arg(long)]
    pub(crate) rep: Option<String>,
    /// By-factor columns, comma-separated: one group per combination.
    #[arg(long, value_delimiter = ',')]
    pub(crate) by: Vec<String>,
    /// The true value: a number (negative ones too: `--true -1`), or the
    /// column holding it.
    #[arg(long = "true", value_name = "VALUE|COLUMN", allow_hyphen_values = true)]
    pub(crate) truth: String,
    /// The intervals' level: a number, or the column holding it.
    #[arg(long, default_value = "0.95", value_name = "VALUE|COLUMN")]
    pub(crate) level: String,
    /// Interval-limit columns, `LOWER,UPPER` [default: estimate +/- the
    /// t (with --df) or normal quantile times the SE].
    #[arg(long, value_name = "LOWER,UPPER")]
    pub(crate) ci: Option<String>,
    /// The df column (for intervals computed from the SE; refused with
    /// --ci, whose limits are given, as rsimsum refuses the pair).
    #[arg(long, conflicts_with = "ci")]
    pub(crate) df: Option<String>,
    /// The reference method [default: each group's first].
    #[arg(long = "ref")]
    pub(crate) reference: Option<String>,
    /// Target MCSEs, `MEASURE=VALUE,...` (e.g. `cover=0.005,bias=0.01`):
    /// the replications each method needs for each, n (MCSE / target)^2
    /// from these replications as a pilot.
    #[arg(long, value_name = "MEASURE=VALUE,...")]
    pub(crate) target_mcse: Option<String>,
    /// Output directory for simsum.csv and simsum.md.
    #[arg(long, default_value = "simsum")]
    pub(crate) out: PathBuf,
}

/// `crossaudit mixed`'s arguments.
#[derive(clap::Args)]
pub(crate) struct MixedArgs {
    /// The CSV file: a header row of column names, one row per observation.
    pub(crate) data: PathBuf,
    /// The model, in lme4's formula language. Random terms: `(1|g)`,
    /// `(1|g:h)`, `(1|g/h)`; slopes `(x|g)` = `(1 + x|g)` (intercept
    /// and slope correlated), `(x||g)` (uncorrelated: `(1|g) +
    /// (0 + x|g)`), `(0 + x|g)` (slope only), for numeric and
    /// categorical x (a factor's columns), up to 8 columns per term.
    /// --profile is for random intercepts and generalized models; a
    /// generalized model reports Wald z tests, without df.
    /// A binomial response is `cbind(successes, failures)` (two columns),
    /// `cbind(successes, trials - successes)` or one 0/1 column (or a
    /// proportion with --weights). `offset(col)` or `offset(log(col))`
    /// adds a term with its coefficient fixed at 1 (a Poisson exposure:
    /// `offset(log(t))`).
    #[arg(long)]
    pub(crate) formula: String,
    /// The response's family: gaussian (a linear mixed model, lmer),
    /// binomial (logit link) or poisson (log link), generalized models
    /// fitted by maximum likelihood under the Laplace approximation as
    /// lme4's glmer fits them (nAGQ = 1), with Wald z tests.
    #[arg(long, default_value = "gaussian", value_parser = ["gaussian", "binomial", "poisson"])]
    pub(crate) family: String,
    /// Maximum likelihood instead of REML (a generalized model is
    /// always fitted by maximum likelihood).
    #[arg(long)]
    pub(crate) ml: bool,
    /// Denominator df of the fixed-effect t tests (REML fits).
    #[arg(long, default_value = "satterthwaite", value_parser = ["satterthwaite", "kenward-roger"])]
    pub(crate) df: String,
    /// Profile-likelihood intervals at this level (e.g. 0.95): of the
    /// standard deviations (random intercepts), of the fixed effects (a
    /// generalized model, as lme4's confint(method = "profile")).
    #[arg(long)]
    pub(crate) profile: Option<f64>,
    /// Print every number as JSON instead of the summary.
    #[arg(long)]
    pub(crate) json: bool,
    /// A second formula: print the likelihood-ratio test of the two
    /// (nested) models, both refitted by ML, as lme4's anova(m1, m2).
    #[arg(long, value_name = "FORMULA2", conflicts_with = "profile")]
    pub(crate) compare: Option<String>,
    /// A column added to the linear predictor with its coefficient fixed
    /// at 1, as `offset(COL)` in the formula (of both formulas with
    /// --compare).
    #[arg(long, value_name = "COL")]
    pub(crate) offset: Option<String>,
    /// Prior weights: lmer's for a linear model (observation i's residual
    /// variance sigma^2 / w_i; Satterthwaite df, no --profile), glmer's for
    /// a binomial model (the trials behind a response of proportions, each
    /// proportion x weight a whole number of successes).
    #[arg(long, value_name = "COL")]
    pub(crate) weights: Option<String>,
    /// Quadrature nodes per level for a generalized model with one scalar
    /// random effect `(1|g)`: glmer's nAGQ, adaptive Gauss-Hermite
    /// quadrature (1, the default, is the Laplace approximation; at most
    /// 25).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub(crate) nagq: usize,
}
