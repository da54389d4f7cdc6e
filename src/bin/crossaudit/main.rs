//! The `crossaudit` command line: argument parsing, one library call per
//! subcommand, error rendering and exit codes. No logic lives here.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::Parser;
use crossaudit::design::{self, LoadError};
use crossaudit::model::Engine;
use crossaudit::run::lock_folder;
use crossaudit::{AnalyzeOptions, Error};

#[macro_use]
mod output;
mod args;
mod design_file;
mod external;
mod folders;
mod methods;
mod progress;

use args::{AuditCommand, Cli, Command, DataCommand, SlurmArgs};

fn main() -> ExitCode {
    let color = std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_exit(&e, color),
    };
    if let Err(said) = prepare(&cli, color) {
        output::note_raw(&said);
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Audit { command: AuditCommand::Split { split, data, design, out, min_run, gap, fail_on } } => {
            let options = crossaudit::split_audit::AuditOptions { min_run_rows: min_run, gap_s: gap };
            match audit_split(&split, &data, design.as_deref(), &out, options) {
                Ok((leak, close)) if (leak && fail_on.is_some()) || (close && fail_on.as_deref() == Some("gap")) => {
                    let what = if leak { "exact leakage found" } else { "windows within the gap found" };
                    note!("{what}: exiting with status 3 (--fail-on {})", fail_on.as_deref().unwrap_or_default());
                    if let Err(e) = output::flush() {
                        output::note_raw(&render(&e, color));
                    }
                    return ExitCode::from(3);
                }
                other => other.map(|_| ()),
            }
        }
        Command::Check { design, json, data } => design_file::check(&design, json, data),
        Command::Lock { design, amend, posthoc: None } => design_file::lock_design(&design, amend.as_deref()),
        Command::Lock { design, posthoc: Some(why), .. } => design_file::mark_posthoc(&design, &why),
        Command::Data { command: DataCommand::Audit { design, data, out } } => data_audit(&design, data, &out),
        Command::Split { design, data, out } => split(&design, data, &out),
        Command::Train { design, model, arm, seed, data, out, engine, exploratory } => {
            let engine = if engine == "reference" { Engine::Reference } else { Engine::Fused };
            train(&design, (&model, &arm, seed), data, &out, (engine, exploratory))
        }
        Command::Run { design, data, out, exploratory, slurm, device, .. } if slurm.slurm => {
            slurm_prepare(&design, data, &out, (exploratory, &device), slurm)
        }
        Command::Run { design, data, out, workers, device, exploratory, reuse, .. } => {
            run(&design, data, &out, (workers, &device), (exploratory, reuse))
        }
        Command::Export { design, data, out, exploratory } => external::export(&design, data, &out, exploratory),
        Command::Score { dir, workers } => external::score(&dir, workers),
        Command::Job { dir, index } => slurm_job(&dir, index),
        Command::Gather { dir } => slurm_gather(&dir),
        Command::Coverage { spec, reps, out, replications } => methods::coverage(&spec, reps, &out, replications),
        Command::Simsum(args) => methods::simsum(args),
        Command::Plan { design, cells, components, effect, reference_mean, recordings, seeds, splits, draws, out } => {
            methods::plan_command(
                &design,
                (cells, components, effect, reference_mean),
                (recordings, seeds, splits, draws),
                &out,
            )
        }
        Command::Simulate { design, out } => methods::simulate(&design, &out),
        Command::SimulateLab { out, seed } => methods::simulate_lab(&out, seed),
        Command::Mixed(args) => methods::mixed_command(args),
        Command::Analyze { design, cells, out, compare_intervals } => {
            analyze(&design, &cells, out, AnalyzeOptions { compare_intervals })
        }
        Command::Combine { design, from, out } => combine(&design, &from, &out),
    };
    // Text printed without a final newline is still buffered.
    let result = result.and_then(|()| output::flush());
    match result {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of a pipe has gone (`crossaudit check X | head -1`):
        // nothing is left to tell it, so end quietly, with the status a
        // shell gives a command ended by SIGPIPE. Every file was written.
        Err(Error::Stdout(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::from(141),
        Err(e) => {
            output::note_raw(&render(&e, color));
            ExitCode::FAILURE
        }
    }
}

/// `--help` and `--version` (to standard output, through [`output`], so a
/// closed pipe or a full disk is handled as for any output) and usage
/// errors (to standard error, status 2).
fn clap_exit(e: &clap::Error, color: bool) -> ExitCode {
    if e.use_stderr() || std::io::stdout().is_terminal() {
        let _ = e.print();
        return ExitCode::from(e.exit_code().clamp(0, 255) as u8);
    }
    match output::print(format_args!("{}", e.render())).and_then(|()| output::flush()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Error::Stdout(io)) if io.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::from(141),
        Err(err) => {
            output::note_raw(&render(&err, color));
            ExitCode::FAILURE
        }
    }
}

fn data_audit(design: &Path, data: Option<PathBuf>, out: &Path) -> Result<(), Error> {
    let file = design::load(design)?;
    crossaudit::run::check_output_dir(out, &file.sha256)?;
    let _lock = lock_folder(out, false)?;
    let dir = crossaudit::run::data_dir(&file.design, &file.path, data, out)?.dir;
    let audit = crossaudit::data::audit(&file.design.data, &dir)?;
    let path = audit.write(out)?;
    out!("{}", audit.summary());
    if let Some(w) = audit.unread_warning() {
        note!("warning: {}", crossaudit::io::one_line(&w));
    }
    note!("wrote {}", path.display());
    // Exit 0 with nothing kept looked like a result: refused, after the
    // audit with every file's reason was written.
    if audit.included().next().is_none() {
        let nested = file.design.data.format.as_ref().is_some_and(|f| f.nested_folders);
        let hint =
            if nested { None } else { crossaudit::io::walk::nested_logs_hint(&dir, file.design.data.format.is_some()) };
        return Err(crossaudit::data::AuditError::NoneIncluded {
            dir: dir.display().to_string(),
            files: audit.files.len(),
            written: path.display().to_string(),
            hint: hint.unwrap_or_default(),
        }
        .into());
    }
    audit.kept_enough(&file.design.data, &path)?;
    Ok(())
}

/// Returns whether exact leakage (copies or overlapping windows across
/// roles) was found, and whether a window lies within the gap.
fn audit_split(
    split: &Path,
    data: &Path,
    design: Option<&Path>,
    out: &Path,
    options: crossaudit::split_audit::AuditOptions,
) -> Result<(bool, bool), Error> {
    // A split published as folders (train/, test/ under one folder) or as a file.
    let published =
        if split.is_dir() { crossaudit::published::from_folders(split)? } else { crossaudit::published::read(split)? };
    let (spec, from) = match design {
        Some(d) => (design::load(d)?.design.data, format!("data rules of {}", d.display())),
        None => (crossaudit::design::DataSpec::upstream_task2(), "upstream NanoBench task-2 loader".to_string()),
    };
    if !data.is_dir() {
        return Err(crossaudit::run::RunError::NoDataDir { dir: data.display().to_string() }.into());
    }
    crossaudit::run::check_out_dir(data, out)?;
    let _lock = lock_folder(out, false)?;
    let audit = crossaudit::split_audit::audit(&published, &spec, &from, data, options)?;
    let written = audit.write(out)?;
    out!("{}", audit.summary());
    for p in &written {
        note!("wrote {}", p.display());
    }
    // No listed recording found: an audit that classified nothing, refused
    // after it was written (most often logs in subfolders not read).
    let listed = audit.recordings.iter().filter(|r| !r.role.is_empty()).count();
    let found = audit
        .recordings
        .iter()
        .filter(|r| !r.role.is_empty() && r.presence == crossaudit::split_audit::Presence::Csv)
        .count();
    if listed > 0 && found == 0 {
        let hint = crossaudit::io::walk::nested_logs_hint(data, design.is_some()).unwrap_or_else(|| {
            "; a recording is named by its log's file name without the suffix (.csv, .csv.gz or .parquet)".into()
        });
        return Err(crossaudit::data::AuditError::NoneListedFound {
            dir: data.display().to_string(),
            listed,
            written: written.first().map(|p| p.display().to_string()).unwrap_or_default(),
            hint,
        }
        .into());
    }
    // Every log there, dropped: an audit of nothing, refused after it was
    // written (without --design, most often logs in another layout).
    let present = audit.recordings.iter().filter(|r| r.presence == crossaudit::split_audit::Presence::Csv).count();
    let kept = audit.recordings.iter().filter(|r| r.effect == crossaudit::split_audit::Effect::Kept).count();
    if present > 0 && kept == 0 {
        let first = audit.recordings.iter().find(|r| r.presence == crossaudit::split_audit::Presence::Csv);
        let hint = match (design, first) {
            (None, Some(r)) => format!(
                " (the first: {}); without --design the logs are read as NanoBench's task-2 loader reads them: give `--design DESIGN` whose data block declares their columns",
                crossaudit::io::one_line(&r.reason)
            ),
            _ => String::new(),
        };
        return Err(crossaudit::data::AuditError::NoneIncluded {
            dir: data.display().to_string(),
            files: present,
            written: written.first().map(|p| p.display().to_string()).unwrap_or_default(),
            hint,
        }
        .into());
    }
    Ok((audit.has_exact_leak(), audit.has_gap_violation()))
}

fn split(design: &Path, data: Option<PathBuf>, out: &Path) -> Result<(), Error> {
    let file = design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    if study.combines_levels() || file.design.per_seed_draws {
        let design = file.path.display().to_string();
        return Err(crossaudit::run::RunError::OuterOneLevel { design, command: "split" }.into());
    }
    let plan = study.plan;
    crossaudit::run::check_out_plan(out, &plan, &file.sha256)?;
    let _lock = lock_folder(out, false)?;
    let data = crossaudit::run::data_dir(&file.design, &file.path, data, out)?;
    let prepared = crossaudit::run::split_into(&file, &plan, &data, out)?;
    out!("{}", prepared.treatment.render_text());
    if let Some(w) = prepared.audit.unread_warning() {
        note!("warning: {}", crossaudit::io::one_line(&w));
    }
    for i in &prepared.invariants.invariants {
        outln!("invariant {} [{:?}]: {}: {}", i.id, i.status, i.name, i.detail);
    }
    for (name, m) in &prepared.manifests.files {
        outln!("manifest {name}: {} rows, sha256 {}", m.rows, m.sha256);
    }
    note!("wrote {}", out.display());
    Ok(())
}

fn train(
    design: &Path,
    (model, arm, seed): (&str, &str, u64),
    data: Option<PathBuf>,
    out: &Path,
    (engine, exploratory): (Engine, bool),
) -> Result<(), Error> {
    let file = design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    if study.combines_levels() || file.design.per_seed_draws {
        let design = file.path.display().to_string();
        return Err(crossaudit::run::RunError::OuterOneLevel { design, command: "train" }.into());
    }
    let plan = study.plan;
    crossaudit::run::refuse_external(&plan)?;
    let job = plan
        .jobs
        .iter()
        .find(|j| j.model == model && j.arm == arm && j.seed.0 == seed)
        .ok_or_else(|| unknown_job(&plan, model, arm, seed))?;
    // Before anything (simulated data included) is written into `out`.
    crossaudit::run::check_lock(&file, exploratory)?;
    crossaudit::run::check_out_plan(out, &plan, &file.sha256)?;
    let _lock = lock_folder(out, false)?;
    let data = crossaudit::run::data_dir(&file.design, &file.path, data, out)?;
    let epochs = plan.training.as_ref().map(|t| t.epochs as u64).unwrap_or(0);
    let bar = progress::epoch_bar(epochs, &job.label());
    let result = crossaudit::run::train_job(&file, &plan, &data, out, job, (engine, exploratory), &mut |e| {
        bar.set_position(e.epoch as u64);
        bar.set_message(format!("train {:.4} val {:.4}", e.train_loss, e.val_loss));
    });
    bar.finish_and_clear();
    match result? {
        crossaudit::run::TrainOutcome::AlreadyFinished => {
            note!("job {} had finished in {}: files verified, nothing run", job.label(), out.display());
            Ok(())
        }
        crossaudit::run::TrainOutcome::Ran(outcome) => progress::print_job(model, arm, seed, &outcome, out),
    }
}

fn unknown_job(plan: &crossaudit::Plan, model: &str, arm: &str, seed: u64) -> crossaudit::run::RunError {
    let join = |v: Vec<String>| v.join(", ");
    crossaudit::run::RunError::UnknownJob {
        job: format!("{model}/{arm}/{seed}"),
        known: format!(
            "models: {}; arms: {}; seeds: {}",
            join(plan.models.iter().map(|m| m.name.clone()).collect()),
            join(plan.arms.iter().map(|a| a.name.clone()).collect()),
            join(plan.seeds.iter().map(|s| s.0.to_string()).collect())
        ),
    }
}

fn run(
    design: &Path,
    data: Option<PathBuf>,
    out: &Path,
    (workers, device): (Option<usize>, &str),
    (exploratory, reuse): (bool, Option<PathBuf>),
) -> Result<(), Error> {
    let file = design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    let plan = &study.plan;
    let workers = workers.unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1));
    // Before the progress display, which has a line per worker.
    crossaudit::run::check_workers(workers)?;
    let choice: crossaudit::model::DeviceChoice = device.parse().map_err(crossaudit::run::RunError::Device)?;
    let (device, said) =
        crossaudit::model::device::resolve(choice).map_err(|e| crossaudit::run::RunError::Device(e.to_string()))?;
    if let Some(said) = said {
        note!("{said}");
    }
    let epochs = plan.training.as_ref().map(|t| t.epochs).unwrap_or(0);
    let progress = progress::RunProgress::new(workers, epochs);
    let options = crossaudit::run::RunOptions { workers, exploratory, reuse, device };
    let result = crossaudit::run::run_into(&file, &study, data, out, options, &progress);
    progress.finish();
    let o = result?;
    let copied = if o.copied > 0 { format!(", {} copied (--reuse)", o.copied) } else { String::new() };
    note!(
        "{} cells trained, {} resumed{copied}, {:.1} s; wrote {} and {}",
        o.trained,
        o.skipped,
        o.seconds,
        o.cells_csv.display(),
        o.report_dir.display()
    );
    output::warnings(&o.analysis);
    output::verdict(&o.analysis)?;
    Ok(())
}

fn slurm_prepare(
    design: &Path,
    data: Option<PathBuf>,
    out: &Path,
    (exploratory, device): (bool, &str),
    a: SlurmArgs,
) -> Result<(), Error> {
    use crossaudit::run::slurm;
    // Recorded for the tasks, which look for a GPU on their own nodes.
    let device: crossaudit::model::DeviceChoice = device.parse().map_err(crossaudit::run::RunError::Device)?;
    let file = design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    let plan = &study.plan;
    // A design with external models runs on Slurm from the folder its
    // export and predictions are in (their jobs are scored, the rest queued).
    if !out.join(crossaudit::run::external::EXPORT_DIR).is_dir() {
        crossaudit::run::refuse_external(plan)?;
    }
    let binary = std::env::current_exe().map_err(|e| crossaudit::run::RunError::Submit {
        script: "(not written)".into(),
        reason: format!("cannot locate the crossaudit binary: {e}"),
    })?;
    let options = slurm::SlurmOptions {
        cpus: a.cpus,
        mem: a.mem,
        throttle: a.throttle,
        time: a.time,
        partition: a.partition,
        account: a.account,
        per_task: a.jobs_per_task,
        device,
        ..slurm::SlurmOptions::new(binary)
    };
    // Before anything (simulated data included) is written into `out`.
    options.validate()?;
    crossaudit::run::check_lock(&file, exploratory)?;
    slurm::check_dir(out)?;
    crossaudit::run::check_out_plan(out, plan, &file.sha256)?;
    let lock = lock_folder(out, false)?;
    let data = crossaudit::run::data_dir(&file.design, &file.path, data, out)?;
    let prepared = slurm::prepare(&file, &study, &data, out, exploratory, &options)?;
    // The array's jobs take the folder's shared lock: free it before any can start.
    drop(lock);
    if a.submit {
        let ids = slurm::submit(&prepared)?;
        match &ids.array {
            Some(array) => note!(
                "submitted array job {array} ({} of {} jobs) and gather job {}",
                prepared.pending,
                prepared.jobs,
                ids.gather
            ),
            None => note!("every job had finished: submitted gather job {}", ids.gather),
        }
        note!(
            "logs: {}/slurm/logs; results: {}/cells.csv and report/ once the gather job ends",
            prepared.dir.display(),
            prepared.dir.display()
        );
        outln!("{}", [ids.array.clone().unwrap_or_default(), ids.gather].join(" ").trim());
    } else {
        out!("{}", prepared.submit_text);
        note!(
            "prepared {} ({} of {} jobs pending); submit with: sh {}",
            prepared.dir.display(),
            prepared.pending,
            prepared.jobs,
            prepared.submit.display()
        );
    }
    Ok(())
}

fn slurm_job(dir: &Path, index: usize) -> Result<(), Error> {
    use crossaudit::run::slurm::{self, TaskOutcome};
    let var = |k: &str| std::env::var(k).unwrap_or_else(|_| "-".into());
    note!(
        "crossaudit {}: task {index} of {} (Slurm job {}, array job {}, host {})",
        crossaudit::BUILD,
        dir.display(),
        var("SLURM_JOB_ID"),
        var("SLURM_ARRAY_JOB_ID"),
        var("SLURMD_NODENAME"),
    );
    let started = std::time::Instant::now();
    let mut last = std::time::Instant::now();
    let outcome = slurm::run_task(dir, index, &mut |e| {
        // A line every 10 s at most: enough to see progress in a log.
        if last.elapsed().as_secs() >= 10 {
            note!("  epoch {}: train {:.4} val {:.4}", e.epoch, e.train_loss, e.val_loss);
            last = std::time::Instant::now();
        }
    })?;
    if let Some(n) = &outcome.device_note {
        note!("{n}");
    }
    if let Some((networks, device, seconds)) = &outcome.batched {
        note!("trained {networks} networks at once on {device} in {seconds:.1} s");
    }
    let (mut ran, jobs) = (0, outcome.jobs.len());
    for job in outcome.jobs {
        match job {
            TaskOutcome::AlreadyFinished { job } => note!("job {job} had finished: files verified, nothing run"),
            TaskOutcome::Ran { job, outcome } => {
                ran += 1;
                note!("job {job} finished: wrote {}", outcome.files.join(", "));
            }
        }
    }
    note!("task {index}: {ran} of its {jobs} job(s) ran, finished in {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

fn slurm_gather(dir: &Path) -> Result<(), Error> {
    // A folder that is not there is the library's to name.
    let _lock = if dir.is_dir() { Some(lock_folder(dir, false)?) } else { None };
    let o = crossaudit::run::slurm::gather(dir)?;
    note!(
        "gathered {} jobs in {:.1} s; wrote {} and {}",
        o.skipped,
        o.seconds,
        o.cells_csv.display(),
        o.report_dir.display()
    );
    output::warnings(&o.analysis);
    output::verdict(&o.analysis)?;
    Ok(())
}

/// `crossaudit combine`: the runs `from` (design, run folder, seed shift,
/// three words each) combined into `out` and analysed there.
fn combine(design: &Path, from: &[String], out: &Path) -> Result<(), Error> {
    let file = crossaudit::design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    let mut sources = Vec::new();
    for w in from.chunks(3) {
        let [d, run, shift] = w else {
            let reason = "--from takes three values: DESIGN RUN_DIR SEED_SHIFT".to_string();
            return Err(crossaudit::run::RunError::Combine { path: w.join(" "), reason }.into());
        };
        let seed_shift = shift.parse::<u64>().map_err(|_| crossaudit::run::RunError::Combine {
            path: run.clone(),
            reason: format!("seed shift {shift:?} is not a whole number of 0 or more"),
        })?;
        sources.push(crossaudit::run::combine::Source { design: d.into(), run: run.into(), seed_shift });
    }
    // Checked before the combined cells are written.
    crossaudit::run::check_output_dir(&out.join("report"), &file.sha256)?;
    let _lock = lock_folder(out, false)?;
    let record = crossaudit::run::combine::combine(&file, &study, &sources, out)?;
    note!("combined {} runs into {} ({} cells)", sources.len(), out.join("cells.csv").display(), record.cells.len());
    let analysis = crossaudit::analysis::analyze_study(&study.plan, &record, AnalyzeOptions::default())
        .map_err(crossaudit::run::RunError::from)?;
    let written = crossaudit::report::write_study(&analysis, &out.join("report"))?;
    output::warnings(&analysis);
    for p in written {
        note!("wrote {}", p.display());
    }
    output::verdict(&analysis)?;
    Ok(())
}

/// Before any subcommand: its inputs protected from its outputs, the
/// thread pool of `--threads`, and an `--out` in a run's own folders
/// refused ([`folders`]); the error as it is printed.
fn prepare(cli: &Cli, color: bool) -> Result<(), String> {
    folders::protect_inputs(&cli.command);
    // Rayon reads RAYON_NUM_THREADS where --threads is not given: a number
    // past --threads' own bound starts threads for minutes before any work.
    let env = std::env::var("RAYON_NUM_THREADS").ok().and_then(|v| v.trim().parse::<u64>().ok());
    if let Some(n) = env.filter(|&n| cli.threads.is_none() && n > u64::from(args::MAX_THREADS)) {
        return Err(output::visible(format!(
            "error: RAYON_NUM_THREADS={n}: at most {} threads (`--threads N` sets them for one command)\n",
            args::MAX_THREADS
        )));
    }
    if let Some(n) = cli.threads {
        // The first use of the global pool: it cannot have been built yet.
        if let Err(e) = rayon::ThreadPoolBuilder::new().num_threads(usize::from(n)).build_global() {
            return Err(output::visible(format!("error: --threads {n}: {e}\n")));
        }
    }
    folders::refuse_runs_own(&cli.command).map_err(|e| render(&e, color))
}

fn render(e: &Error, color: bool) -> String {
    match e {
        Error::Design(LoadError::Design(d)) => d.render(color),
        other => output::visible(format!("error: {other}\n")),
    }
}

fn analyze(design: &Path, cells: &Path, out: Option<PathBuf>, options: AnalyzeOptions) -> Result<(), Error> {
    let file = crossaudit::design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    let outer = study.combines_levels();
    // Per-cell data is read from a file, never a stream: the report quotes
    // its path and SHA-256.
    // (A pipe or a device by name is refused by the reader, which names it.)
    if cells == Path::new("-") {
        let why = "standard input is not read: per-cell data is read from a file, whose path and SHA-256 the report quotes; save it to a file first (`... > cells.csv`) and give that file";
        let source = std::io::Error::other(why);
        return Err(crossaudit::cells::CellsError::Io { path: cells.display().to_string(), source }.into());
    }
    // A run folder given whole (of any study): its reanalysis goes into
    // it, beside its report; never into the folder above it.
    let beside = if cells.is_dir() { cells } else { cells.parent().unwrap_or(Path::new(".")) };
    let dir = match out {
        Some(dir) => dir,
        // A per-cell file in a run's folder: its `report/` is the run's
        // own, so the reanalysis goes beside it, into `reanalysis/`.
        None if (outer && cells.is_dir())
            || (!outer && crossaudit::run::check_not_runs_own(&beside.join("report"), None).is_err()) =>
        {
            let dir = beside.join("reanalysis");
            note!(
                "{} is the run's own report; writing the reanalysis to {}",
                beside.join("report").display(),
                dir.display()
            );
            dir
        }
        None if !cells.is_dir()
            && (!std::fs::metadata(cells).is_ok_and(|m| m.is_file())
                || cells.starts_with("/dev")
                || cells.starts_with("/proc")) =>
        {
            return Err(crossaudit::io::WriteError::new(
                &beside.join("report"),
                std::io::Error::other(format!(
                    "{} is not a file in a folder (a pipe, a device, standard input), so there is no folder beside it for the report: give --out DIR (nothing was written)",
                    cells.display()
                )),
            )
            .into())
        }
        None => beside.join("report"),
    };
    // A run's report is never replaced by another design's analysis, nor
    // by a reanalysis of its per-cell data.
    crossaudit::run::check_output_dir(&dir, &file.sha256)?;
    crossaudit::run::check_not_runs_own(&dir, outer.then_some(cells))?;
    folders::refuse_others_report(&dir)?;
    // Any study: a single one, a dose or split family, or (for a
    // multiverse or draw-replicated design) the run directory `cells`.
    let analysis = crossaudit::analyze_study(&file, &study, cells, options)?;
    let _lock = lock_folder(&dir, false)?;
    let written = crossaudit::report::write_study(&analysis, &dir)?;
    output::warnings(&analysis);
    for p in written {
        note!("wrote {}", p.display());
    }
    output::verdict(&analysis)?;
    Ok(())
}
