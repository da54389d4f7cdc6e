//! The levels of a study opened and their jobs queued as one, then
//! finished: each level that trains is opened (its split, manifests and
//! run.json), its unfinished jobs are queued, except those an earlier run
//! (`--reuse`) or an earlier level with the same inputs (by content key)
//! already holds, whose files are copied instead; once the queue has run,
//! each level's copies are made, its job records stamped with their keys
//! and its cells gathered or finished.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::PathBuf;

use super::{copy_job, note_unread, ExternalNotes, Outer};
use crate::design::{DesignFile, LockStatus};
use crate::plan::study::Level;
use crate::plan::{Plan, TrainingJob};
use crate::run::reuse::ReuseIndex;
use crate::run::{finish, gather_recorded, open, pending, Data, Opened, RunError, RunObserver, RunOptions};

/// One level opened for the queue.
pub(super) struct Open {
    /// How messages name it: its folder, with a specification's choices.
    pub label: String,
    pub plan: Plan,
    pub dir: PathBuf,
    pub opened: Opened,
    done_builds: BTreeSet<String>,
    /// Jobs whose inputs equal a job queued in an earlier level: copied
    /// from it once the queue has run (job, its level, that job).
    copies: Vec<(TrainingJob, usize, TrainingJob)>,
    /// Every job's content key, written into its record once it ran.
    keyed: Vec<(TrainingJob, String)>,
}

/// Every level that trains, opened, and the one queue of their jobs.
pub(super) struct Queued {
    /// (index into the study's levels, the level opened).
    pub levels: Vec<(usize, Open)>,
    /// (index into `levels`, a job to run).
    pub queue: VecDeque<(usize, TrainingJob)>,
    /// What the report says of jobs not trained here (reused, copied,
    /// external) and of unreadable files.
    pub reused: Vec<String>,
    pub trained: usize,
    pub skipped: usize,
}

/// The first job with each content key: its level (in [`Queued::levels`]),
/// the job, and whether it is queued (not yet on disk).
type FirstByKey = BTreeMap<String, (usize, TrainingJob, bool)>;

/// Opens every level of `outer` that does not share another's run, in
/// order, and queues the jobs none of them holds yet.
pub(super) fn open_levels(
    file: &DesignFile,
    outer: &Outer,
    data: &Data,
    out: &std::path::Path,
    options: &RunOptions,
    observer: &dyn RunObserver,
    external: &ExternalNotes,
) -> Result<Queued, RunError> {
    let index = options.reuse.as_deref().map(ReuseIndex::read).transpose()?;
    let mut q = Queued { levels: Vec::new(), queue: VecDeque::new(), reused: Vec::new(), trained: 0, skipped: 0 };
    if let Some((_, notes)) = external.0.first() {
        // The same models in every level; each level's report names its export.
        q.reused.extend(
            notes.first().map(|n| format!("every level: {}", n.split(" (made from export").next().unwrap_or(n))),
        );
    }
    let mut first = FirstByKey::new();
    let levels = &outer.levels;
    for (k, level) in levels.iter().enumerate().filter(|(_, l)| l.shares.is_none()) {
        let label = match (&file.design.multiverse, level.spec) {
            (Some(m), Some(s)) => format!("{} ({})", level.id, m.label(s)),
            _ => level.id.clone(),
        };
        observer.level(k + 1, levels.len(), &label);
        let in_level = |e: RunError| RunError::InLevel { level: label.clone(), source: Box::new(e) };
        let level_file = DesignFile { design: level.design.clone(), ..file.clone() };
        let dir = out.join(&level.id);
        let mut opened =
            open(&level_file, &level.plan, data, &dir, options.exploratory, Some(&level.id)).map_err(in_level)?;
        opened.record_device(&options.device, &dir).map_err(in_level)?;
        if let Some((_, notes)) = external.0.iter().find(|(id, _)| *id == level.id) {
            opened.notes.extend(notes.iter().cloned());
        }
        let (todo, done_builds) = pending(&level.plan, &dir, &file.sha256).map_err(in_level)?;
        let keys: Vec<String> = crate::split::JobManifests::for_plan(&level.plan, &opened.prepared.manifests)
            .iter()
            .zip(&level.plan.jobs)
            .map(|(m, j)| crate::run::reuse::job_key(&level.design, &level.plan, j, m, &opened.record))
            .collect();
        let open = Open {
            label: label.clone(),
            plan: level.plan.clone(),
            dir,
            opened,
            done_builds,
            copies: Vec::new(),
            keyed: level.plan.jobs.iter().cloned().zip(keys).collect(),
        };
        queue_level(&mut q, (k, level, open), todo, (index.as_ref(), &file.sha256), &mut first).map_err(in_level)?;
    }
    Ok(q)
}

/// Queues `open`'s jobs in `todo` except those taken from the `--reuse`
/// index or equal (by content key) to an earlier level's: copied now if
/// that one is on disk, after the queue if it is queued.
fn queue_level(
    q: &mut Queued,
    (k, level, mut open): (usize, &Level, Open),
    mut todo: VecDeque<TrainingJob>,
    (index, sha256): (Option<&ReuseIndex>, &str),
    first: &mut FirstByKey,
) -> Result<(), RunError> {
    let here = q.levels.len();
    let jobs = open.plan.jobs.len();
    if let Some(index) = index {
        let mut taken = 0;
        for (j, key) in &open.keyed {
            if todo.contains(j) && index.take(key, &open.dir, j, sha256)? {
                todo.retain(|t| t != j);
                taken += 1;
            }
        }
        if taken > 0 {
            q.reused.push(format!("{}: {}", level.id, crate::run::reuse::reused_note(taken, jobs, index.from())));
        }
    }
    note_unread(&mut q.reused, &open.opened.prepared.audit);
    let mut copied = 0;
    for (j, key) in &open.keyed {
        if let (Some((from, earlier, queued)), true) = (first.get(key), todo.contains(j)) {
            if *queued {
                open.copies.push((j.clone(), *from, earlier.clone()));
            } else {
                copy_job(&q.levels[*from].1.dir, earlier, &open.dir, j)?;
            }
            todo.retain(|t| t != j);
            copied += 1;
        }
    }
    for (j, key) in &open.keyed {
        let queued = todo.contains(j);
        first.entry(key.clone()).or_insert_with(|| (here, j.clone(), queued));
    }
    if copied > 0 {
        q.reused.push(format!(
            "{}: {copied} job(s) whose inputs (manifests, data, model, training, seed) equal an earlier level's were not trained again: their files were copied, by content hash",
            level.id
        ));
    }
    q.skipped += jobs - todo.len();
    q.trained += todo.len();
    q.queue.extend(todo.into_iter().map(|j| (here, j)));
    q.levels.push((k, open));
    Ok(())
}

/// What finishing the levels gathered for the combined analysis.
pub(super) struct Finished {
    /// The lock state of the last level opened.
    pub status: LockStatus,
    /// Each study level's split (None for a level sharing another's run).
    pub splits: Vec<Option<crate::split::Split>>,
}

/// After the queue has run: each level's copies made, its records stamped,
/// then its cells gathered (`per_seed`: one seed alone is no crossed
/// study, so its cells are analysed with every other seed's later) or the
/// level finished with its own report.
pub(super) fn finish_opened(
    file: &DesignFile,
    levels: &[(usize, Open)],
    count: usize,
    per_seed: bool,
) -> Result<Finished, RunError> {
    let mut status = None;
    let mut splits: Vec<Option<crate::split::Split>> = vec![None; count];
    for (k, o) in levels {
        let in_level = |e: RunError| RunError::InLevel { level: o.label.clone(), source: Box::new(e) };
        for (j, from, earlier) in &o.copies {
            copy_job(&levels[*from].1.dir, earlier, &o.dir, j).map_err(in_level)?;
        }
        crate::run::reuse::stamp(&o.dir, &o.keyed).map_err(in_level)?;
        if per_seed {
            gather_recorded(&o.plan, &o.opened, &o.dir, &o.done_builds).map_err(in_level)?;
        } else {
            finish(
                crate::analysis::record::DesignLabel::new(file, o.opened.status.clone()),
                &o.plan,
                &o.opened,
                &o.dir,
                o.done_builds.clone(),
            )
            .map_err(in_level)?;
        }
        status = Some(o.opened.status.clone());
        splits[*k] = Some(o.opened.prepared.split.clone());
    }
    Ok(Finished { status: status.ok_or(RunError::NoWorkers)?, splits })
}
