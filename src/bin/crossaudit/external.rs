//! `crossaudit export` and `crossaudit score`: models fitted outside
//! crossaudit (`model NAME = external ...`).

use std::path::{Path, PathBuf};

use crossaudit::design;
use crossaudit::Error;

use crate::progress;

pub(crate) fn export(design: &Path, data: Option<PathBuf>, out: &Path, exploratory: bool) -> Result<(), Error> {
    let file = design::load(design)?;
    let study = crossaudit::compile_study(&file.design);
    let started = std::time::Instant::now();
    let o = crossaudit::run::external::export_into(&file, &study, data, out, exploratory)?;
    note!(
        "exported {} external jobs in {:.1} s ({:.1} MB) to {}",
        o.jobs,
        started.elapsed().as_secs_f64(),
        o.bytes as f64 / 1e6,
        o.dir.display()
    );
    if o.levels > 0 {
        note!(
            "{} levels, each exported to {}/LEVEL/export (listed in {}/levels.json): fit each level's jobs on that level's windows, write their rollouts to {}/LEVEL/predictions/MODEL__ARM__SEED.npy with a .json description, then run: crossaudit score {}",
            o.levels,
            out.display(),
            o.dir.display(),
            out.display(),
            out.display()
        );
    } else {
        note!(
            "fit each job on its arm's windows, write its rollouts to {}/predictions/MODEL__ARM__SEED.npy with a .json description, then run: crossaudit score {}",
            out.display(),
            out.display()
        );
    }
    if crossaudit::design::lock::status(&file)? == crossaudit::design::LockStatus::Unlocked {
        note!(
            "warning: {} is not locked, so the scores will be NOT PREREGISTERED; lock it (`crossaudit lock {}`) and export again before fitting to preregister them",
            design.display(),
            design.display()
        );
    }
    outln!("export sha256 {}", o.sha256);
    Ok(())
}

pub(crate) fn score(dir: &Path, workers: Option<usize>) -> Result<(), Error> {
    let workers = workers.unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1));
    // Before the progress display, which has a line per worker.
    crossaudit::run::check_workers(workers)?;
    let progress = progress::RunProgress::new(workers, 0);
    let result = crossaudit::run::external::score(dir, workers, &progress, &mut |line| note!("{line}"));
    progress.finish();
    let o = result?;
    note!(
        "{} external jobs scored now, {} before; {} built-in cells trained, {:.1} s; wrote {} and {}",
        o.scored,
        o.resumed,
        o.run.trained,
        o.run.seconds,
        o.run.cells_csv.display(),
        o.run.report_dir.display()
    );
    for (job, n, of) in &o.non_finite {
        note!(
            "warning: {job}: {n} of {of} predicted trajectories have a non-finite state (divergent from that step on)"
        );
    }
    crate::output::warnings(&o.run.analysis);
    crate::output::verdict(&o.run.analysis)?;
    Ok(())
}
