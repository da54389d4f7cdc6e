//! What the scheduler is given: the array's resources and their checks,
//! paths and names made safe for the shell and for sbatch, the sbatch
//! scripts and `submit.sh`, and the submission itself.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{PreparedArray, RunError};
use crate::io::write_atomic;

/// Resources and submission settings of the array; none come from the design.
#[derive(Debug, Clone, PartialEq)]
pub struct SlurmOptions {
    /// CPUs per array task (`--cpus-per-task`). A job trains on one thread,
    /// as in a local run; more CPUs only reserve headroom.
    pub cpus: usize,
    /// Memory per array task (`--mem`), as Slurm writes it: digits and an
    /// optional unit K, M, G or T.
    pub mem: String,
    /// At most this many array tasks at once (`--array=...%N`).
    pub throttle: Option<usize>,
    /// Wall-time limit per task (`--time`), in one of Slurm's forms
    /// (`MM`, `MM:SS`, `HH:MM:SS`, `D-HH`, `D-HH:MM`, `D-HH:MM:SS`).
    pub time: Option<String>,
    /// Partition (`--partition`).
    pub partition: Option<String>,
    /// Account (`--account`).
    pub account: Option<String>,
    /// The crossaudit binary every task runs (absolute path).
    pub binary: PathBuf,
    /// Training jobs per array task (`--jobs-per-task`): task t runs jobs
    /// t x N to t x N + N - 1 of the array's job list, their networks
    /// trained together by the batched trainer on a GPU, one after another
    /// on the CPU.
    pub per_task: usize,
    /// Where each task trains (`--device`), resolved on the node that runs
    /// it; `cuda` asks Slurm for a GPU per task (`--gres=gpu:1`).
    pub device: crate::model::DeviceChoice,
}

impl SlurmOptions {
    /// One CPU and 1 GiB per task (a job of the paper's protocol on the
    /// NanoBench logs peaks at 110 MB resident), no throttle, time limit,
    /// partition or account, one job per task on the CPU; `binary` as
    /// given.
    pub fn new(binary: PathBuf) -> SlurmOptions {
        SlurmOptions {
            cpus: 1,
            mem: "1G".into(),
            throttle: None,
            time: None,
            partition: None,
            account: None,
            binary,
            per_task: 1,
            device: crate::model::DeviceChoice::Cpu,
        }
    }

    /// Refuses values that sbatch would misread.
    pub fn validate(&self) -> Result<(), RunError> {
        let bad = |option: &str, value: &str, expected: &str| RunError::SlurmOption {
            option: option.into(),
            value: value.into(),
            expected: expected.into(),
        };
        if self.cpus == 0 {
            return Err(bad("--cpus", "0", "at least 1"));
        }
        // sbatch reads both as 32-bit numbers; a job trains on one thread.
        if self.cpus > crate::run::MAX_WORKERS {
            return Err(bad("--cpus", &self.cpus.to_string(), &format!("at most {}", crate::run::MAX_WORKERS)));
        }
        if self.per_task == 0 {
            return Err(bad("--jobs-per-task", "0", "at least 1"));
        }
        if self.per_task > MAX_PER_TASK {
            return Err(bad("--jobs-per-task", &self.per_task.to_string(), &format!("at most {MAX_PER_TASK}")));
        }
        if self.throttle == Some(0) {
            return Err(bad("--throttle", "0", "at least 1"));
        }
        if let Some(t) = self.throttle.filter(|&t| t > MAX_THROTTLE) {
            return Err(bad("--throttle", &t.to_string(), &format!("at most {MAX_THROTTLE}")));
        }
        let digits = self.mem.trim_end_matches(['K', 'M', 'G', 'T']);
        if digits.is_empty()
            || !digits.bytes().all(|b| b.is_ascii_digit())
            || self.mem.len() > digits.len() + 1
            || digits.bytes().all(|b| b == b'0')
        {
            return Err(bad("--mem", &self.mem, "a positive size such as 4G, 1500M or 2048"));
        }
        if let Some(t) = &self.time {
            if !slurm_time(t) {
                return Err(bad("--time", t, "a Slurm time such as 30, 2:00:00 or 1-12:00:00"));
            }
        }
        for (option, value) in [("--partition", &self.partition), ("--account", &self.account)] {
            if let Some(v) = value {
                if v.is_empty() || !v.bytes().all(|b| b.is_ascii_alphanumeric() || b"_.,-".contains(&b)) {
                    return Err(bad(option, v, "letters, digits and _ . , -"));
                }
            }
        }
        Ok(())
    }
}

/// The largest `--throttle` (the array's `%N`, a 32-bit number to sbatch;
/// no study has this many jobs).
pub(super) const MAX_THROTTLE: usize = 1_000_000;

/// The most training jobs one array task runs: a study's every job, at
/// the largest size a plan allows, fits in far fewer.
pub(super) const MAX_PER_TASK: usize = 1_000_000;

/// One of Slurm's time forms: `M`, `M:S`, `H:M:S`, `D-H`, `D-H:M`, `D-H:M:S`.
pub(super) fn slurm_time(t: &str) -> bool {
    let number = |s: &str| !s.is_empty() && s.len() <= 6 && s.bytes().all(|b| b.is_ascii_digit());
    let (days, clock) = match t.split_once('-') {
        Some((d, c)) => (Some(d), c),
        None => (None, t),
    };
    let parts: Vec<&str> = clock.split(':').collect();
    days.is_none_or(number) && parts.iter().all(|p| number(p)) && parts.len() <= 3
}

/// A string as one single-quoted shell word: nothing in it is expanded.
pub fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

/// Refuses a run directory that Slurm or a script would misread (see
/// `prepare`); worth calling before anything is written into it.
pub fn check_dir(out: &Path) -> Result<(), RunError> {
    path_word(out).map(|_| ())
}

/// A path as a shell word, refused when Slurm or a script would misread it:
/// not UTF-8, a control character (a newline would end the command), or
/// `%` (sbatch expands `%j`, `%a`, ... in file names).
pub(super) fn path_word(p: &Path) -> Result<String, RunError> {
    let unsafe_path =
        |reason: &str| RunError::UnsafeClusterPath { path: p.display().to_string(), reason: reason.into() };
    let s = p.to_str().ok_or_else(|| unsafe_path("it is not UTF-8"))?;
    if s.chars().any(char::is_control) {
        return Err(unsafe_path("it holds a control character such as a newline"));
    }
    if s.contains('%') {
        return Err(unsafe_path("it holds `%`, which sbatch expands in log file names"));
    }
    Ok(shell_quote(s))
}

/// A Slurm job name from the study's name: letters, digits, `_`, `.` and
/// `-` kept, anything else `_`, at most 64 characters.
pub(super) fn job_name(study: &str) -> String {
    let name: String =
        study.chars().map(|c| if c.is_ascii_alphanumeric() || "_.-".contains(c) { c } else { '_' }).take(53).collect();
    format!("crossaudit-{name}")
}

/// Indices as a Slurm array spec: `0-4,7,9-12`.
pub(super) fn array_spec(indices: &[usize]) -> String {
    let mut out = String::new();
    let mut i = 0;
    while i < indices.len() {
        let mut j = i;
        while j + 1 < indices.len() && indices[j + 1] == indices[j] + 1 {
            j += 1;
        }
        if !out.is_empty() {
            out.push(',');
        }
        match j - i {
            0 => write!(out, "{}", indices[i]),
            _ => write!(out, "{}-{}", indices[i], indices[j]),
        }
        .ok();
        i = j + 1;
    }
    out
}

/// Writes `array.sbatch` and `gather.sbatch` into `slurm` and returns the
/// text of `submit.sh` for the array of `indices`.
pub(super) fn write_scripts(
    slurm: &Path,
    dir: &Path,
    binary: &Path,
    study: &str,
    indices: &[usize],
    options: &SlurmOptions,
) -> Result<String, RunError> {
    let (dir_q, binary_q) = (path_word(dir)?, path_word(binary)?);
    let task = |command: &str| {
        format!(
            "#!/bin/sh\n# Written by `crossaudit run --slurm` (crossaudit {}); submitted by submit.sh.\nset -eu\nexec {binary_q} {command}\n",
            crate::io::BUILD
        )
    };
    let array_script = slurm.join("array.sbatch");
    write_atomic(&array_script, task(&format!("job {dir_q} --index \"$SLURM_ARRAY_TASK_ID\"")).as_bytes())?;
    let gather_script = slurm.join("gather.sbatch");
    write_atomic(&gather_script, task(&format!("gather {dir_q}")).as_bytes())?;

    let name = job_name(study);
    let mut common = format!("--cpus-per-task={} --mem={} --chdir={dir_q}", options.cpus, options.mem);
    // A task's GPU, where its networks are to train on one; the gather
    // step trains nothing.
    let gres = if options.device == crate::model::DeviceChoice::Cuda { " --gres=gpu:1" } else { "" };
    for (flag, value) in [("time", &options.time), ("partition", &options.partition), ("account", &options.account)] {
        if let Some(v) = value {
            write!(common, " --{flag}={}", shell_quote(v)).ok();
        }
    }
    let logs = slurm.join("logs");
    path_word(&logs)?;
    let log_word = |file: &str| shell_quote(&format!("{}/{file}", logs.display()));
    let mut submit = submit_header(dir, indices.len(), options.per_task, &logs);
    let dependency = if indices.is_empty() {
        submit.push_str("echo 'no training job is pending: submitting the gather step alone' >&2\n");
        String::new()
    } else {
        let spec = match options.throttle {
            Some(t) => format!("{}%{t}", array_spec(indices)),
            None => array_spec(indices),
        };
        write!(
            submit,
            "array=$(sbatch --parsable --job-name={} --array={} {common}{gres} --output={} --open-mode=append {})\n\
             array=${{array%%;*}}\n\
             echo \"submitted array job $array ({} task(s))\" >&2\n",
            shell_quote(&name),
            shell_quote(&spec),
            log_word("task-%a.out"),
            path_word(&array_script)?,
            indices.len(),
        )
        .ok();
        " --dependency=\"afterok:$array\" --kill-on-invalid-dep=yes".to_string()
    };
    write!(
        submit,
        "gather=$(sbatch --parsable --job-name={}{dependency} {common} --output={} --open-mode=append {})\n\
         gather=${{gather%%;*}}\n\
         echo \"submitted gather job $gather\" >&2\n\
         echo \"${{array:-}} $gather\"\n",
        shell_quote(&format!("{name}-gather")),
        log_word("gather.out"),
        path_word(&gather_script)?,
    )
    .ok();
    Ok(submit)
}

/// The head of `submit.sh`: what it submits (an array of `tasks` tasks
/// of `per_task` jobs each) and where the logs go.
fn submit_header(dir: &Path, tasks: usize, per_task: usize, logs: &Path) -> String {
    format!(
        "#!/bin/sh\n\
         # Submits the study in {dir} to Slurm (written by `crossaudit run --slurm`, crossaudit {build}):\n\
         # an array of {n} {per} then a gather job that\n\
         # writes cells.csv and the report once every task has succeeded.\n\
         # Resubmitting is safe: a task verifies each of its jobs that finished and runs the rest.\n\
         # Logs: {logs}/task-INDEX.out (appended to by every attempt) and gather.out.\n\
         set -eu\n",
        dir = dir.display(),
        build = crate::io::BUILD,
        n = tasks,
        per = match per_task {
            1 => "training job(s), one per task,".to_string(),
            k => format!("task(s) of up to {k} training jobs each,"),
        },
        logs = logs.display(),
    )
}

/// The Slurm job IDs [`submit`] got back.
#[derive(Debug, Clone, PartialEq)]
pub struct Submitted {
    /// The array job (none when no training job was pending).
    pub array: Option<String>,
    /// The gather job.
    pub gather: String,
}

/// Runs `DIR/slurm/submit.sh` with `sh`: sbatch must be on the PATH.
pub fn submit(prepared: &PreparedArray) -> Result<Submitted, RunError> {
    let script = prepared.submit.display().to_string();
    let failed = |reason: String| RunError::Submit { script: script.clone(), reason };
    let sbatch_found =
        std::env::var_os("PATH").is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join("sbatch").is_file()));
    if !sbatch_found {
        return Err(failed(
            "sbatch is not on the PATH (is Slurm installed here?); the script is written, submit it where sbatch runs"
                .into(),
        ));
    }
    let output = std::process::Command::new("sh")
        .arg(&prepared.submit)
        .stdin(std::process::Stdio::null())
        .output()
        .map_err(|e| failed(format!("cannot run sh: {e}")))?;
    let stderr = String::from_utf8_lossy(&output.stderr).trim().to_string();
    if !output.status.success() {
        return Err(failed(format!("{} ({stderr})", output.status)));
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let ids: Vec<&str> = stdout.split_whitespace().collect();
    let numeric = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    match ids.as_slice() {
        [gather] if numeric(gather) => Ok(Submitted { array: None, gather: gather.to_string() }),
        [array, gather] if numeric(array) && numeric(gather) => {
            Ok(Submitted { array: Some(array.to_string()), gather: gather.to_string() })
        }
        _ => Err(failed(format!("unexpected output {:?} ({stderr})", stdout.trim()))),
    }
}
