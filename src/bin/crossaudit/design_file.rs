//! `crossaudit check` and `crossaudit lock`: the design file's own
//! commands (validation, the compiled plan, the lock and its amendments).

use std::path::Path;

use crossaudit::design::{self, lock, LoadError};
use crossaudit::Error;

pub(crate) fn check(path: &Path, json: bool, data: Option<std::path::PathBuf>) -> Result<(), Error> {
    let file = match design::load(path) {
        Ok(f) => f,
        Err(LoadError::Design(d)) if json => {
            // The errors as JSON on standard output, the usual text on
            // standard error, exit 1.
            let value =
                serde_json::json!({"design": path.display().to_string(), "valid": false, "errors": d.to_json()});
            out!("{}", crossaudit::io::pretty_json(&value));
            return Err(LoadError::Design(d).into());
        }
        Err(e) => return Err(e.into()),
    };
    let status = lock::status(&file)?;
    let study = crossaudit::compile_study(&file.design);
    // What run would refuse about the data, found before anything is said
    // valid: the audit and each level's split built, nothing written.
    let data = crossaudit::run::check_data(&file, &study, data)?;
    if json {
        check_json(path, &file, &status, &study, &data)
    } else {
        check_text(path, &file, &status, &study, &data)
    }
}

/// `check --json`: the valid design, its plan and levels as JSON.
fn check_json(
    path: &Path,
    file: &crossaudit::DesignFile,
    status: &lock::LockStatus,
    study: &crossaudit::StudyPlan,
    data: &crossaudit::run::DataChecked,
) -> Result<(), Error> {
    let plan = &study.plan;
    let levels = Some(study.levels()).filter(|_| study.combines_levels());
    let mut value = serde_json::json!({
        "design": path.display().to_string(),
        "valid": true,
        "sha256": file.sha256,
        "lock": status,
        "plan": plan,
        "validated": file.design,
        "data": data.line(),
    });
    if let Some(levels) = &levels {
        let specs = file.design.multiverse.as_ref().map_or(1, |m| m.specs.len());
        value["outer"] = serde_json::json!({
            "specifications": specs,
            "levels": levels.iter().map(|l| serde_json::json!({
                "id": l.id,
                "shares_run_of": l.shares.map(|s| levels[s].id.clone()),
            })).collect::<Vec<_>>(),
            "jobs": study.job_count(),
        });
    }
    let seed_draws = file.design.seed_draws();
    if !seed_draws.is_empty() {
        value["seed_draws"] = serde_json::json!(seed_draws
            .iter()
            .map(|(seed, draw)| serde_json::json!({"seed": seed, "draw": draw, "folder": format!("draw-{draw}")}))
            .collect::<Vec<_>>());
    }
    out!("{}", crossaudit::io::pretty_json(&value));
    Ok(())
}

/// `check`: the valid design, its lock, plan, levels and data in words.
fn check_text(
    path: &Path,
    file: &crossaudit::DesignFile,
    status: &lock::LockStatus,
    study: &crossaudit::StudyPlan,
    data: &crossaudit::run::DataChecked,
) -> Result<(), Error> {
    let plan = &study.plan;
    outln!("{}: valid", path.display());
    outln!("sha256: {}", file.sha256);
    outln!("lock: {}", status.label());
    if let lock::LockStatus::LockedUnchanged { posthoc: Some(why), .. } = status {
        outln!(
            "  marked POST HOC: {} (every report of a run under this lock says POST HOC, never preregistered)",
            crossaudit::io::one_line(why)
        );
    }
    for a in status.amendment_warnings() {
        outln!("  {a}");
    }
    // What `run` would refuse about the lock, said here first.
    if status.changed() {
        outln!(
            "  run refuses this design as it stands: it changed after it was locked ({}); `lock --amend` records the change, or `run --exploratory` labels every output EXPLORATORY",
            crossaudit::io::one_line(&status.reason())
        );
    }
    out!("{}", plan.render_text());
    out!("{}", study.render_levels(&file.design));
    let seed_draws = file.design.seed_draws();
    if !seed_draws.is_empty() {
        let list: Vec<String> = seed_draws.iter().map(|(s, d)| format!("seed {s}: draw {d}")).collect();
        let folders =
            if file.design.multiverse.is_some() { "spec-ID/draw-K, shared by every specification" } else { "draw-K" };
        outln!(
            "draws per seed: each seed its own draw after the evaluation recordings (folders {folders}); {}",
            list.join(", ")
        );
    }
    outln!("{}", data.line());
    Ok(())
}

/// `crossaudit lock DESIGN --posthoc REASON`.
pub(crate) fn mark_posthoc(path: &Path, why: &str) -> Result<(), Error> {
    let file = design::load(path)?;
    let lock = lock::mark_posthoc(&file, std::time::SystemTime::now(), why)?;
    outln!(
        "{}: locked sha256 {} at {}, marked post hoc: {}",
        lock::lock_path(path).display(),
        lock.sha256,
        lock.locked_at_utc,
        crossaudit::io::one_line(why)
    );
    outln!("every report of a run under this lock says POST HOC, never preregistered");
    Ok(())
}

pub(crate) fn lock_design(path: &Path, amend: Option<&str>) -> Result<(), Error> {
    let file = design::load(path)?;
    if let Some(reason) = amend {
        let why = match (lock::read_lock(path)?, lock::status(&file)?) {
            (None, _) => Some("it has no lock"),
            (Some(_), lock::LockStatus::LockedUnchanged { .. }) => {
                Some("its lock holds (the design is unchanged since it was locked)")
            }
            _ if reason.trim().is_empty() => Some("the reason is empty"),
            _ => None,
        };
        if let Some(why) = why {
            let path = lock::lock_path(path).display().to_string();
            return Err(lock::LockError::NothingToAmend { path, why: why.to_string() }.into());
        }
    }
    let lock = lock::write_lock_amended(&file, std::time::SystemTime::now(), amend)?;
    outln!(
        "{}: locked sha256 {} at {} ({} {})",
        lock::lock_path(path).display(),
        lock.sha256,
        lock.locked_at_utc,
        lock.tool,
        lock.tool_version
    );
    if let Some(a) = lock.amendments.last().filter(|_| amend.is_some()) {
        outln!("amendment recorded: {}", a.describe());
    }
    Ok(())
}
