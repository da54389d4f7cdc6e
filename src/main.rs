//! The `crossaudit` command line: argument parsing, one library call per
//! subcommand, error rendering and exit codes. No logic lives here.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use crossaudit::design::{self, lock, LoadError};
use crossaudit::{AnalyzeOptions, Error};

#[derive(Parser)]
#[command(name = "crossaudit", version, about = "Preregistered, leakage-aware evaluation of learned dynamics models")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Validate a design and print its compiled plan.
    Check {
        design: PathBuf,
        /// Print the plan (and the validated design) as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Record the design's SHA-256, tool version and UTC time in FILE.design.lock.
    Lock { design: PathBuf },
    /// Flight-log data commands.
    Data {
        #[command(subcommand)]
        command: DataCommand,
    },
    /// Build the shared experiment: manifests, invariants, treatment audit.
    Split {
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
        design: PathBuf,
        #[arg(long)]
        model: String,
        #[arg(long)]
        arm: String,
        #[arg(long)]
        seed: u64,
        /// Data directory [default: the design's `path`].
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output directory (manifests/, audit/, models/, cells/, curves/).
        #[arg(long)]
        out: PathBuf,
    },
    /// Run a locked design end to end: audit, manifests, invariants, every
    /// training cell, cells.csv and the report. Resumes a partial run.
    Run {
        design: PathBuf,
        /// Data directory [default: the design's `path`].
        #[arg(long)]
        data: Option<PathBuf>,
        #[arg(long)]
        out: PathBuf,
        /// Parallel training workers, one thread each [default: one per core].
        #[arg(long)]
        workers: Option<usize>,
        /// Allow a design changed after locking; every output is labelled EXPLORATORY.
        #[arg(long)]
        exploratory: bool,
    },
    /// Monte Carlo coverage of the interval estimators over a grid of crossed
    /// settings (JSON spec).
    Coverage {
        spec: PathBuf,
        /// Override the spec's replications per setting.
        #[arg(long)]
        reps: Option<usize>,
        /// Output directory for coverage.csv, coverage.md, coverage.svg.
        #[arg(long, default_value = "coverage")]
        out: PathBuf,
    },
    /// Predict SE, interval width and the probability the decision rule holds
    /// for other numbers of recordings and seeds, from pilot per-cell data.
    Plan {
        design: PathBuf,
        /// Pilot per-cell CSV analysable under the design.
        #[arg(long)]
        cells: PathBuf,
        /// Numbers of recordings to consider.
        #[arg(long, value_delimiter = ',', default_value = "13,26,52")]
        recordings: Vec<usize>,
        /// Numbers of seeds to consider.
        #[arg(long, value_delimiter = ',', default_value = "3,5,10,20,40")]
        seeds: Vec<usize>,
        /// Output directory for plan.md, plan.json, plan.svg.
        #[arg(long, default_value = "plan")]
        out: PathBuf,
    },
    /// Generate the recordings of a `data simulated` design (NanoBench schema).
    Simulate {
        design: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
    /// Run the design's analysis on a per-cell CSV.
    Analyze {
        design: PathBuf,
        /// The per-cell CSV (header: see README).
        #[arg(long)]
        cells: PathBuf,
        /// Output directory for report.md, results.json and results.tex
        /// [default: report/ next to the cells file].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Add every interval estimator side by side for each contrast.
        #[arg(long)]
        compare_intervals: bool,
    },
}

#[derive(Subcommand)]
enum DataCommand {
    /// Load every recording, apply the design's inclusion rules in order,
    /// write recordings.csv and print a summary.
    Audit {
        design: PathBuf,
        /// Data directory [default: the design's `path`, relative to the current directory].
        #[arg(long)]
        data: Option<PathBuf>,
        /// Output directory for recordings.csv.
        #[arg(long, default_value = "audit")]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let color = std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none();
    let result = match cli.command {
        Command::Check { design, json } => check(&design, json),
        Command::Lock { design } => lock_design(&design),
        Command::Data { command: DataCommand::Audit { design, data, out } } => data_audit(&design, data, &out),
        Command::Split { design, data, out } => split(&design, data, &out),
        Command::Train { design, model, arm, seed, data, out } => train(&design, &model, &arm, seed, data, &out),
        Command::Run { design, data, out, workers, exploratory } => run(&design, data, &out, workers, exploratory),
        Command::Coverage { spec, reps, out } => coverage(&spec, reps, &out),
        Command::Plan { design, cells, recordings, seeds, out } => plan(&design, &cells, &recordings, &seeds, &out),
        Command::Simulate { design, out } => simulate(&design, &out),
        Command::Analyze { design, cells, out, compare_intervals } => {
            analyze(&design, &cells, out, AnalyzeOptions { compare_intervals })
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprint!("{}", render(&e, color));
            ExitCode::FAILURE
        }
    }
}

fn data_audit(design: &std::path::Path, data: Option<PathBuf>, out: &std::path::Path) -> Result<(), Error> {
    let file = design::load(design)?;
    let dir = crossaudit::data_dir(&file.design, data, out)?;
    let audit = crossaudit::data::audit(&file.design.data, &dir)?;
    let path = audit.write(out)?;
    print!("{}", audit.summary());
    eprintln!("wrote {}", path.display());
    Ok(())
}

fn split(design: &std::path::Path, data: Option<PathBuf>, out: &std::path::Path) -> Result<(), Error> {
    let file = design::load(design)?;
    let dir = crossaudit::data_dir(&file.design, data, out)?;
    let outcome = crossaudit::split_stage(&file, &dir, out)?;
    print!("{}", outcome.treatment.render_text());
    for i in &outcome.invariants.invariants {
        println!("invariant {} [{:?}]: {}: {}", i.id, i.status, i.name, i.detail);
    }
    for (name, m) in &outcome.manifests.files {
        println!("manifest {name}: {} rows, sha256 {}", m.rows, m.sha256);
    }
    eprintln!("wrote {}", out.display());
    Ok(())
}

fn train(
    design: &std::path::Path,
    model: &str,
    arm: &str,
    seed: u64,
    data: Option<PathBuf>,
    out: &std::path::Path,
) -> Result<(), Error> {
    let file = design::load(design)?;
    let dir = crossaudit::data_dir(&file.design, data, out)?;
    let split = crossaudit::split_stage(&file, &dir, out)?;
    let epochs = file.design.training.as_ref().map(|t| t.epochs as u64).unwrap_or(0);
    let bar = indicatif::ProgressBar::new(epochs);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{prefix} [{bar:30}] epoch {pos}/{len} {msg} (eta {eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(format!("{model}/{arm}/{seed}"));
    let result = crossaudit::cell::run_cell(&file, &split, model, arm, seed, out, &mut |e| {
        bar.set_position(e.epoch as u64);
        bar.set_message(format!("train {:.4} val {:.4}", e.train_loss, e.val_loss));
    });
    bar.finish_and_clear();
    let cell = result?;
    if let (Some(best), Some(last)) = (cell.best_val_loss, cell.epochs.last()) {
        println!("{model}/{arm}/{seed}: {} epochs, best validation loss {best:.5}", last.epoch);
    }
    if !cell.epochs.is_empty() {
        println!(
            "timing: training {:.2} s ({} epochs, {:.3} s per epoch), rollouts {:.2} s",
            cell.train_seconds,
            cell.epochs.len(),
            cell.train_seconds / cell.epochs.len() as f64,
            cell.rollout_seconds
        );
    }
    for (who, e) in &cell.one_step {
        println!("one-step validation error (standardized, world units of this arm): {who:<18} {e:.5}");
    }
    for (who, h, fa) in &cell.mean_fa_rmse {
        println!("mean failure-aware position RMSE at {h} s over evaluation recordings: {who:<18} {fa:.4} m");
    }
    for f in &cell.files {
        eprintln!("wrote {f}");
    }
    Ok(())
}

/// Progress for `run`: one overall bar and one status line per worker on a
/// terminal; one summary line per finished cell either way.
struct RunProgress {
    bars: indicatif::MultiProgress,
    overall: indicatif::ProgressBar,
    workers: Vec<indicatif::ProgressBar>,
    epochs: usize,
}

impl crossaudit::run::RunObserver for RunProgress {
    fn start(&self, total: usize, done: usize) {
        self.overall.set_length(total as u64);
        self.overall.set_position(done as u64);
        if done > 0 {
            let _ = self.bars.println(format!("resuming: {done} of {total} cells already finished"));
        }
    }
    fn cell_started(&self, w: usize, c: &crossaudit::pipeline::TrainingCell) {
        self.workers[w].set_message(format!("{}/{}/{}", c.model, c.arm, c.seed.0));
    }
    fn epoch(&self, w: usize, c: &crossaudit::pipeline::TrainingCell, e: &crossaudit::model::EpochLog) {
        self.workers[w].set_message(format!(
            "{}/{}/{} epoch {}/{} train {:.4} val {:.4}",
            c.model, c.arm, c.seed.0, e.epoch, self.epochs, e.train_loss, e.val_loss
        ));
    }
    fn cell_finished(
        &self,
        w: usize,
        c: &crossaudit::pipeline::TrainingCell,
        o: &crossaudit::cell::CellOutcome,
        secs: f64,
    ) {
        self.overall.inc(1);
        self.workers[w].set_message("idle");
        let val = o.best_val_loss.map(|v| format!("best val {v:.5}, ")).unwrap_or_default();
        let fa: Vec<String> = o
            .mean_fa_rmse
            .iter()
            .filter(|(who, _, _)| *who == c.model)
            .map(|(_, h, v)| format!("{h} s {v:.4} m"))
            .collect();
        let _ = self.bars.println(format!(
            "done {}/{}/{} in {secs:.1} s: {} epochs, {val}mean FA RMSE {}",
            c.model,
            c.arm,
            c.seed.0,
            o.epochs.len(),
            fa.join(", ")
        ));
    }
}

fn run(
    design: &std::path::Path,
    data: Option<PathBuf>,
    out: &std::path::Path,
    workers: Option<usize>,
    exploratory: bool,
) -> Result<(), Error> {
    let file = design::load(design)?;
    let dir = crossaudit::data_dir(&file.design, data, out)?;
    let workers = workers.unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)).max(1);
    let bars = indicatif::MultiProgress::new();
    if !std::io::stderr().is_terminal() {
        bars.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let overall = bars.add(indicatif::ProgressBar::new(0));
    overall.set_style(
        indicatif::ProgressStyle::with_template("cells [{bar:30}] {pos}/{len} (eta {eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let worker_bars = (0..workers)
        .map(|w| {
            let b = bars.add(indicatif::ProgressBar::new_spinner());
            b.set_style(
                indicatif::ProgressStyle::with_template(&format!("worker {w}: {{msg}}"))
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
            );
            b.set_message("idle");
            b
        })
        .collect();
    let epochs = file.design.training.as_ref().map(|t| t.epochs).unwrap_or(0);
    let progress = RunProgress { bars, overall, workers: worker_bars, epochs };
    let options = crossaudit::run::RunOptions { workers, exploratory };
    let result = crossaudit::run::run(&file, &dir, out, options, &progress);
    progress.overall.finish_and_clear();
    for w in &progress.workers {
        w.finish_and_clear();
    }
    let o = result?;
    eprintln!(
        "{} cells trained, {} resumed, {:.1} s; wrote {} and {}",
        o.trained,
        o.skipped,
        o.seconds,
        o.cells_csv.display(),
        o.report_dir.display()
    );
    println!("{}", o.analysis.decision.summary());
    Ok(())
}

fn coverage(spec: &std::path::Path, reps: Option<usize>, out: &std::path::Path) -> Result<(), Error> {
    let mut spec = crossaudit::workbench::CoverageSpec::load(spec)?;
    if let Some(r) = reps {
        spec.reps = r.max(2);
    }
    let started = std::time::Instant::now();
    let rows = crossaudit::workbench::run_coverage(&spec, &mut |k, n, s| {
        eprintln!("[{k}/{n}] {} ({:.1} s)", s.label(), started.elapsed().as_secs_f64());
    })?;
    for p in crossaudit::workbench::write(out, &spec, &rows)? {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

fn plan(
    design: &std::path::Path,
    cells: &std::path::Path,
    recordings: &[usize],
    seeds: &[usize],
    out: &std::path::Path,
) -> Result<(), Error> {
    if let Some(n) = recordings.iter().chain(seeds).find(|n| **n < 2) {
        return Err(Error::Usage(format!("--recordings and --seeds need values of at least 2, found {n}")));
    }
    let file = design::load(design)?;
    let analysis = crossaudit::analyze_files(design, cells, AnalyzeOptions::default())?;
    let report = crossaudit::workbench::plan(&analysis, &file.design, recordings, seeds)?;
    std::fs::create_dir_all(out).map_err(|e| Error::Usage(format!("cannot create {}: {e}", out.display())))?;
    crossaudit::report::write_atomic(&out.join("plan.md"), report.to_markdown().as_bytes())?;
    let json = serde_json::to_string_pretty(&report).expect("a plan serializes");
    crossaudit::report::write_atomic(&out.join("plan.json"), json.as_bytes())?;
    report.draw(&out.join("plan.svg"))?;
    print!("{}", report.to_markdown());
    Ok(())
}

fn simulate(design: &std::path::Path, out: &std::path::Path) -> Result<(), Error> {
    let file = design::load(design)?;
    let Some(sim) = file.design.data.simulated else {
        return Err(Error::Usage(format!("{}: the data source is not `simulated`", design.display())));
    };
    let files = crossaudit::data::simulate::simulate(&sim, out)
        .map_err(|e| Error::Usage(format!("cannot write simulated recordings to {}: {e}", out.display())))?;
    eprintln!("wrote {} simulated recordings (CSV + metadata) to {}", files.len(), out.display());
    Ok(())
}

fn render(e: &Error, color: bool) -> String {
    match e {
        Error::Design(LoadError::Design(d)) => d.render(color),
        other => format!("error: {other}\n"),
    }
}

fn check(path: &std::path::Path, json: bool) -> Result<(), Error> {
    let file = design::load(path)?;
    let status = lock::status(path, &file.sha256)?;
    let plan = crossaudit::compile(&file.design);
    if json {
        let value = serde_json::json!({
            "design": path.display().to_string(),
            "sha256": file.sha256,
            "lock": status,
            "plan": plan,
            "validated": file.design,
        });
        println!("{}", serde_json::to_string_pretty(&value).expect("JSON values serialize"));
    } else {
        println!("{}: valid", path.display());
        println!("sha256: {}", file.sha256);
        println!("lock: {}", status.label());
        print!("{}", plan.render_text(&file.design));
    }
    Ok(())
}

fn lock_design(path: &std::path::Path) -> Result<(), Error> {
    let file = design::load(path)?;
    let lock = lock::write_lock(path, &file.sha256, std::time::SystemTime::now())?;
    println!(
        "{}: locked sha256 {} at {} ({} {})",
        lock::lock_path(path).display(),
        lock.sha256,
        lock.locked_at_utc,
        lock.tool,
        lock.tool_version
    );
    Ok(())
}

fn analyze(
    design: &std::path::Path,
    cells: &std::path::Path,
    out: Option<PathBuf>,
    options: AnalyzeOptions,
) -> Result<(), Error> {
    let analysis = crossaudit::analyze_files(design, cells, options)?;
    let dir = out.unwrap_or_else(|| cells.parent().unwrap_or(std::path::Path::new(".")).join("report"));
    let written = crossaudit::report::write_all(&analysis, &dir)?;
    for w in &analysis.warnings {
        eprintln!("warning: {w}");
    }
    for p in written {
        eprintln!("wrote {}", p.display());
    }
    println!("{}", analysis.decision.summary());
    Ok(())
}
