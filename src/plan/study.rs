//! The study stage: a design compiled once into a [`StudyPlan`], every
//! outer level of it (a multiverse's specifications, replicate or per-seed
//! draws, whole splits) with the role that decides how the levels are
//! combined, each level's own [`Plan`], and the units the multiverse
//! analysis treats as one level. Front ends call [`compile_study`] once and
//! hand the result on; no later stage compiles a design again.
//!
//! A study is the product of its outer factors; each level is a complete
//! single run in its own folder named by its factors' values
//! (`spec-ID`, `draw-K`, `spec-ID_draw-K`, `spec-ID/draw-K` or `split-S`).
//! A level whose trained part (data, split, arms, models, training,
//! endpoints) is identical to an earlier one's shares that level's run and
//! differs only in its analysis. (A dose is not an outer factor: a
//! dose-response family's arms are trained in one run.)

use serde::Serialize;

use super::{compile, split_dir, Plan};
use crate::design::multiverse::run_key;
use crate::design::Design;

/// What an outer factor's levels are to each other, which decides how they
/// are combined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LevelRole {
    /// Alternative analyses of the same question (a multiverse's
    /// specifications): each reported, combined by the declared rule, their
    /// differences estimated pairwise.
    Specification,
    /// Replicates of the unpublished draws with the evaluation set fixed: a
    /// variance component beside recording and seed.
    Replicate,
    /// Whole redraws of the experiment, evaluation set included (splits):
    /// pooled by REML over split, recording and seed.
    Redraw,
    /// `draws per seed`: one level per seed, each its own draw with that
    /// seed alone; their cells together are one crossed recording x seed
    /// study, analysed as the design's own.
    PerSeed,
}

/// One level of the outer factors.
#[derive(Debug, Clone)]
pub struct Level {
    /// Its folder name.
    pub id: String,
    /// The specification's index, in a multiverse.
    pub spec: Option<usize>,
    /// The draw, under draw replication or per-seed draws.
    pub draw: Option<u64>,
    /// The split, in a multi-split study.
    pub split: Option<u64>,
    /// The complete single-run design of the level.
    pub design: Design,
    /// Its plan: a split's is the study plan's jobs of that split.
    pub plan: Plan,
    /// The earlier level whose run it shares, if its own would train the same jobs.
    pub shares: Option<usize>,
}

/// What the multiverse analysis treats as one level: a level, or under
/// per-seed draws in a multiverse a specification's seed levels together.
#[derive(Debug, Clone)]
pub struct Unit {
    /// Its folder (`spec-s1`, `draw-2`, `spec-s1_draw-2`).
    pub id: String,
    /// The specification's index, in a multiverse.
    pub spec: Option<usize>,
    /// The draw, under draw replication.
    pub draw: Option<u64>,
    /// The unit whose cells it shares, if it trained nothing of its own.
    pub shares: Option<String>,
    /// Its levels, by index into [`Outer::levels`].
    pub members: Vec<usize>,
    /// The design it analyses as one study.
    pub design: Design,
    /// That design's plan.
    pub plan: Plan,
}

/// A study's outer levels.
#[derive(Debug, Clone)]
pub struct Outer {
    /// How the levels are combined.
    pub role: LevelRole,
    /// Every level, in folder order.
    pub levels: Vec<Level>,
    /// The units of the multiverse analysis (each level its own, except a
    /// multiverse specification's per-seed levels, which form one).
    pub units: Vec<Unit>,
}

/// A design compiled once: its own plan and, for a study with outer
/// factors, every level's.
#[derive(Debug, Clone)]
pub struct StudyPlan {
    /// The design's own plan (a multi-split study's holds every split's
    /// jobs; a per-seed study's is the analysis of all its seeds together).
    pub plan: Plan,
    /// The outer levels, or None for a study of one run.
    pub outer: Option<Outer>,
}

impl StudyPlan {
    /// The outer levels (none for a study of one run).
    pub fn levels(&self) -> &[Level] {
        self.outer.as_ref().map_or(&[], |o| &o.levels)
    }

    /// The outer factors' role, or None for a study of one run.
    pub fn role(&self) -> Option<LevelRole> {
        self.outer.as_ref().map(|o| o.role)
    }

    /// True when the levels are combined by the multiverse analysis
    /// (specifications or replicate draws) into `multiverse_cells.csv`.
    pub fn combines_levels(&self) -> bool {
        matches!(self.role(), Some(LevelRole::Specification | LevelRole::Replicate))
    }

    /// The jobs the study trains: those of every level that does not share
    /// another's run, or the plan's own.
    pub fn job_count(&self) -> usize {
        match &self.outer {
            Some(o) => o.levels.iter().filter(|l| l.shares.is_none()).map(|l| l.plan.jobs.len()).sum(),
            None => self.plan.jobs.len(),
        }
    }

    /// What `crossaudit check` prints about the outer levels of a
    /// multiverse or draw-replicated study: the specifications, the draws
    /// and the jobs they train (empty for any other study).
    pub fn render_levels(&self, design: &Design) -> String {
        if !self.combines_levels() {
            return String::new();
        }
        let levels = self.levels();
        use std::fmt::Write as _;
        let mut s = String::new();
        if let Some(m) = &design.multiverse {
            let choices: Vec<String> =
                m.choices.iter().map(|c| format!("{} ({})", c.setting, c.alternatives.join(" | "))).collect();
            let _ = writeln!(s, "multiverse: {} specifications over {}", m.specs.len(), choices.join(", "));
            let _ = writeln!(s, "  primary specification {}: {}", m.specs[m.primary].id, m.label(m.primary));
            let _ = writeln!(s, "  decided {}", m.combine.describe());
            for (k, sp) in m.specs.iter().enumerate() {
                let _ = writeln!(s, "  {}: {}", sp.id, m.label(k));
            }
        }
        if !design.draws.is_empty() {
            let list: Vec<String> = design.draws.iter().map(|d| d.to_string()).collect();
            let _ = writeln!(
                s,
                "draws: {} ({}), the evaluation set fixed; draw k shifts every other draw's seed by k - 1",
                design.draws.len(),
                list.join(", ")
            );
        }
        let shared = levels.iter().filter(|l| l.shares.is_some()).count();
        let _ = writeln!(
            s,
            "runs: {} levels, {} trained ({} share another level's cells: only their analysis differs); jobs: {} in all",
            levels.len(),
            levels.len() - shared,
            shared,
            self.job_count()
        );
        if design.coupled {
            let _ =
                writeln!(s, "draws coupled: priority sampling after the evaluation draw (shared starts and windows)");
        }
        s
    }
}

/// Compiles a design and every outer level of it, once.
///
/// ```
/// use std::path::Path;
/// let file = crossaudit::design::load(Path::new("designs/multiverse/paper_per_seed.design")).unwrap();
/// let study = crossaudit::plan::compile_study(&file.design);
/// assert_eq!(study.role(), Some(crossaudit::plan::study::LevelRole::PerSeed));
/// assert_eq!(study.levels().len(), file.design.seeds.len());
/// ```
pub fn compile_study(design: &Design) -> StudyPlan {
    let plan = compile(design);
    let outer = outer(design, &plan);
    StudyPlan { plan, outer }
}

fn outer(design: &Design, plan: &Plan) -> Option<Outer> {
    let (levels, role) = if let Some(levels) = combined_levels(design) {
        (levels, if design.multiverse.is_some() { LevelRole::Specification } else { LevelRole::Replicate })
    } else if design.per_seed_draws {
        let levels = design
            .seed_draws()
            .into_iter()
            .map(|(seed, k)| level(format!("draw-{k}"), None, Some(k), design.for_seed_draw(seed, k)))
            .collect();
        (levels, LevelRole::PerSeed)
    } else if !plan.splits.is_empty() {
        let levels = plan
            .splits
            .iter()
            .map(|&s| Level {
                id: split_dir(s),
                spec: None,
                draw: None,
                split: Some(s),
                design: design.for_split(s),
                plan: plan.for_split(s),
                shares: None,
            })
            .collect();
        (levels, LevelRole::Redraw)
    } else {
        return None;
    };
    let units = units(design, &levels);
    Some(Outer { role, levels, units })
}

fn level(id: String, spec: Option<usize>, draw: Option<u64>, design: Design) -> Level {
    let plan = compile(&design);
    Level { id, spec, draw, split: None, design, plan, shares: None }
}

/// The levels of a multiverse or a draw-replicated design, or None.
fn combined_levels(design: &Design) -> Option<Vec<Level>> {
    let specs: Vec<(Option<usize>, String, &Design)> = match &design.multiverse {
        Some(m) => m.specs.iter().enumerate().map(|(k, s)| (Some(k), format!("spec-{}", s.id), &*s.design)).collect(),
        None if !design.draws.is_empty() => vec![(None, String::new(), design)],
        None => return None,
    };
    let mut out: Vec<Level> = Vec::new();
    for (spec, name, d) in specs {
        let mut plain = d.clone();
        plain.multiverse = None;
        if d.per_seed_draws && spec.is_some() {
            // Each seed of the specification its own level, in the
            // specification's folder: `spec-ID/draw-K`.
            for (seed, k) in d.seed_draws() {
                out.push(level(format!("{name}/draw-{k}"), spec, Some(k), plain.for_seed_draw(seed, k)));
            }
        } else if d.draws.is_empty() {
            out.push(level(name, spec, None, plain));
        } else {
            for &k in &d.draws {
                let id = if name.is_empty() { format!("draw-{k}") } else { format!("{name}_draw-{k}") };
                out.push(level(id, spec, Some(k), d.for_draw(k)));
            }
        }
    }
    let keys: Vec<String> = out.iter().map(|l| run_key(&l.design)).collect();
    for k in 0..out.len() {
        out[k].shares = keys[..k].iter().position(|o| *o == keys[k]);
    }
    Some(out)
}

/// The analysis units of `levels`: each level its own, except that under
/// per-seed draws in a multiverse a specification's seeds form one.
fn units(design: &Design, levels: &[Level]) -> Vec<Unit> {
    let (Some(m), true) = (&design.multiverse, design.per_seed_draws) else {
        return levels
            .iter()
            .enumerate()
            .map(|(k, l)| Unit {
                id: l.id.clone(),
                spec: l.spec,
                draw: l.draw,
                shares: l.shares.map(|s| levels[s].id.clone()),
                members: vec![k],
                design: l.design.clone(),
                plan: l.plan.clone(),
            })
            .collect();
    };
    let unit_id = |s: usize| format!("spec-{}", m.specs[s].id);
    m.specs
        .iter()
        .enumerate()
        .map(|(s, spec)| {
            let members: Vec<usize> = (0..levels.len()).filter(|&k| levels[k].spec == Some(s)).collect();
            // It shares a specification's cells when each of its seeds does.
            let shared: Vec<Option<usize>> =
                members.iter().map(|&k| levels[k].shares.and_then(|o| levels[o].spec)).collect();
            let shares = match shared.first() {
                Some(Some(o)) if shared.iter().all(|x| *x == Some(*o)) => Some(unit_id(*o)),
                _ => None,
            };
            let mut d = (*spec.design).clone();
            d.multiverse = None;
            d.per_seed_draws = false;
            let plan = compile(&d);
            Unit { id: unit_id(s), spec: Some(s), draw: None, shares, members, design: d, plan }
        })
        .collect()
}
