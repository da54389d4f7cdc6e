//! Progress on a terminal (indicatif) and the summary lines of finished
//! jobs, for `run` and `train`.

use std::io::IsTerminal;

use crossaudit::model::EpochLog;
use crossaudit::plan::TrainingJob;
use crossaudit::run::{JobOutcome, RunObserver};
use crossaudit::Error;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()).progress_chars("=> ")
}

/// `train`'s bar over the epochs of one job.
pub fn epoch_bar(epochs: u64, prefix: &str) -> ProgressBar {
    let bar = ProgressBar::new(epochs);
    bar.set_style(style("{prefix} [{bar:30}] epoch {pos}/{len} {msg} (eta {eta})"));
    bar.set_prefix(prefix.to_string());
    bar
}

/// What `train` prints about its job.
pub fn print_job(model: &str, arm: &str, seed: u64, job: &JobOutcome, out: &std::path::Path) -> Result<(), Error> {
    if let (Some(best), Some(last)) = (job.best_val_loss, job.epochs.last()) {
        outln!("{model}/{arm}/{seed}: {} epochs, best validation loss {best:.5}", last.epoch);
    }
    if !job.epochs.is_empty() {
        outln!(
            "timing: training {:.2} s ({} epochs, {:.3} s per epoch), rollouts {:.2} s",
            job.train_seconds,
            job.epochs.len(),
            job.train_seconds / job.epochs.len() as f64,
            job.rollout_seconds
        );
    }
    for (who, e) in &job.one_step {
        outln!("one-step validation error (standardized, world units of this arm): {who:<18} {e:.5}");
    }
    for (who, h, fa) in &job.mean_fa_rmse {
        outln!("mean failure-aware position RMSE at {h} s over evaluation recordings: {who:<18} {fa:.4} m");
    }
    for f in &job.files {
        note!("wrote {}", out.join(f).display());
    }
    Ok(())
}

/// Progress for `run`: one overall bar and one status line per worker on a
/// terminal; one summary line per finished job (with its count) either
/// way, printed straight to standard error when it is not a terminal
/// (nohup, CI, Slurm logs), where the bars are hidden.
pub struct RunProgress {
    bars: MultiProgress,
    overall: ProgressBar,
    workers: Vec<ProgressBar>,
    epochs: usize,
    terminal: bool,
    /// Jobs copied by `--reuse`, among those done at the start.
    copied: std::sync::atomic::AtomicUsize,
}

impl RunProgress {
    /// Bars for `workers` workers training up to `epochs` epochs.
    pub fn new(workers: usize, epochs: usize) -> RunProgress {
        let bars = MultiProgress::new();
        let terminal = std::io::stderr().is_terminal();
        if !terminal {
            bars.set_draw_target(ProgressDrawTarget::hidden());
        }
        let overall = bars.add(ProgressBar::new(0));
        overall.set_style(style("cells [{bar:30}] {pos}/{len} (eta {eta})"));
        let workers = (0..workers)
            .map(|w| {
                let b = bars.add(ProgressBar::new_spinner());
                b.set_style(
                    ProgressStyle::with_template(&format!("worker {w}: {{msg}}"))
                        .unwrap_or_else(|_| ProgressStyle::default_spinner()),
                );
                b.set_message("idle");
                b
            })
            .collect();
        RunProgress { bars, overall, workers, epochs, terminal, copied: Default::default() }
    }

    /// A line above the bars, or on standard error when they are hidden.
    fn say(&self, line: String) {
        if self.terminal {
            let _ = self.bars.println(line);
        } else {
            note!("{line}");
        }
    }

    /// Clears every bar.
    pub fn finish(&self) {
        self.overall.finish_and_clear();
        for w in &self.workers {
            w.finish_and_clear();
        }
    }
}

impl RunObserver for RunProgress {
    fn level(&self, index: usize, count: usize, label: &str) {
        self.say(format!("level {index} of {count}: {label}"));
    }

    fn batch_started(&self, jobs: usize, device: &str) {
        self.say(format!("training {jobs} networks at once on {device}; the workers roll them out after"));
    }

    fn batch_finished(&self, jobs: usize, seconds: f64) {
        self.say(format!("trained {jobs} networks on the GPU in {seconds:.1} s"));
    }

    fn start(&self, total: usize, done: usize) {
        self.overall.set_length(total as u64);
        self.overall.set_position(done as u64);
        let resumed = done.saturating_sub(self.copied.load(std::sync::atomic::Ordering::Relaxed));
        if resumed > 0 {
            self.say(format!("resuming: {resumed} of {total} cells already finished in this folder"));
        }
    }

    fn reused(&self, copied: usize, total: usize, from: &std::path::Path) {
        self.copied.store(copied, std::sync::atomic::Ordering::Relaxed);
        self.say(format!("reusing: {copied} of {total} cells copied from {} (--reuse), not trained", from.display()));
    }

    fn job_started(&self, w: usize, j: &TrainingJob) {
        self.workers[w].set_message(j.label());
    }

    fn epoch(&self, w: usize, j: &TrainingJob, e: &EpochLog) {
        self.workers[w].set_message(format!(
            "{} epoch {}/{} train {:.4} val {:.4}",
            j.label(),
            e.epoch,
            self.epochs,
            e.train_loss,
            e.val_loss
        ));
    }

    fn job_finished(&self, w: usize, j: &TrainingJob, o: &JobOutcome, secs: f64) {
        self.overall.inc(1);
        self.workers[w].set_message("idle");
        let val = o.best_val_loss.map(|v| format!("best val {v:.5}, ")).unwrap_or_default();
        // A closed-form fit has no epochs.
        let epochs = match &j.kind {
            k if k.has_curve() => format!("{} epochs, ", o.epochs.len()),
            k if k.trains() => "closed form, ".to_string(),
            _ => "parameter-free, ".to_string(),
        };
        let fa: Vec<String> = o
            .mean_fa_rmse
            .iter()
            .filter(|(who, _, _)| *who == j.model)
            .map(|(_, h, v)| format!("{h} s {v:.4} m"))
            .collect();
        self.say(format!(
            "done {} ({}/{}) in {secs:.1} s: {epochs}{val}mean FA RMSE {}",
            j.label(),
            self.overall.position(),
            self.overall.length().unwrap_or(0),
            fa.join(", ")
        ));
    }
}
