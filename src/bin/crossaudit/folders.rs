//! The folders a command may write into and the files it must not
//! replace, checked before anything is written.

use std::path::Path;

use crate::args::{AuditCommand, Command, DataCommand};
use crossaudit::Error;

/// Refuses, before anything is written, an `--out` inside a folder a run
/// wrote (its `simulated_data/`, `audit/`, `report/`, ...), for the
/// commands whose outputs are no run's: written there they would change
/// what the run's resume reads (its data, its audit) or replace its own
/// files; and the commands that write a run (`run`, `split`, `train`,
/// `export`) into a folder below another run's. `analyze`, `plan` and
/// `power` check their folders themselves.
pub(crate) fn refuse_runs_own(command: &Command) -> Result<(), Error> {
    let (out, what) = match command {
        Command::Run { out, .. }
        | Command::Split { out, .. }
        | Command::Train { out, .. }
        | Command::Export { out, .. } => return Ok(crossaudit::run::check_not_inside_run(out)?),
        Command::Audit { command: AuditCommand::Split { out, .. } } => (out, "split-audit"),
        Command::Data { command: DataCommand::Audit { out, .. } } => (out, "data-audit"),
        Command::Coverage { out, .. } => (out, "coverage"),
        Command::Simulate { out, .. } | Command::SimulateLab { out, .. } => (out, "simulated"),
        Command::Combine { out, .. } => (out, "combined"),
        Command::Simsum(args) => (&args.out, "simsum"),
        _ => return Ok(()),
    };
    Ok(crossaudit::run::check_not_in_run(out, what)?)
}

/// The files a command reads that its outputs must never replace (an
/// `--out` folder holding one under an output's name).
pub(crate) fn protect_inputs(command: &Command) {
    let files: Vec<&std::path::Path> = match command {
        Command::Audit { command: AuditCommand::Split { split, design, .. } } => {
            std::iter::once(split.as_path()).chain(design.as_deref()).collect()
        }
        Command::Analyze { design, cells, .. } => vec![design, cells],
        Command::Plan { design, cells, .. } => std::iter::once(design.as_path()).chain(cells.as_deref()).collect(),
        Command::Simsum(args) => vec![&args.file],
        Command::Mixed(args) => vec![&args.data],
        Command::Coverage { spec, .. } => vec![spec],
        Command::Data { command: DataCommand::Audit { design, .. } }
        | Command::Split { design, .. }
        | Command::Run { design, .. }
        | Command::Export { design, .. }
        | Command::Combine { design, .. } => vec![design],
        _ => Vec::new(),
    };
    for f in files {
        crossaudit::io::protect_input(f);
    }
}

/// Refuses, before anything is written, a folder whose `report.md` or
/// `results.json` no crossaudit report wrote: a report's folder holds a
/// `results.json` (or a multiverse's `multiverse.json`) naming its study,
/// written with it; without one, those files are someone's own, which the
/// report would replace. Not for a run's own `report/`, which a run
/// refuses by its `run.json` (`run::check_out`).
pub(crate) fn refuse_others_report(dir: &Path) -> Result<(), Error> {
    let names_a_study = |name: &str| {
        std::fs::read(dir.join(name))
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .is_some_and(|v| v.get("study").is_some_and(serde_json::Value::is_string))
    };
    if names_a_study("results.json") || names_a_study("multiverse.json") {
        return Ok(());
    }
    for name in ["report.md", "results.json"] {
        let path = dir.join(name);
        if path.exists() {
            return Err(crossaudit::io::WriteError::new(
                &path,
                std::io::Error::other(
                    "it is no crossaudit report's (no results.json naming a study beside it), and the report would replace it: give another --out (nothing was written)",
                ),
            )
            .into());
        }
    }
    Ok(())
}
