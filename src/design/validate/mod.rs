//! [`Ast`] -> [`Design`]: names resolve, counts and ranges make sense, and
//! every problem is reported at the span that caused it. All problems are
//! collected, not just the first.

mod analysis;
mod arms;
mod assemble;
mod csv;
mod data;
mod endpoints;
mod factors;
mod outer;
mod published;

pub use outer::validate;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::ast::*;
use super::diagnostic::Diagnostic;
use super::*;

/// More training seeds than anyone will train; bounds the memory a seed
/// range can ask for (found by fuzzing: `factor seed = 1..44444444444`).
const MAX_SEEDS: u64 = 100_000;

/// Limits on what a design may ask for, checked by `check` so that a run
/// never panics, aborts on an allocation or runs for ever on a value it
/// accepted. Each is far above any real study (the paper's design: 26
/// evaluation recordings, 20 seeds, 50 starts of 100 samples, 2,000
/// bootstrap replicates) and is named in the message that refuses it.
pub(super) mod limits {
    /// Statements in one design (the paper's has 17): name checks compare
    /// statements with each other.
    pub const STATEMENTS: usize = 10_000;
    /// Evaluation or validation recordings (drawn or listed).
    pub const RECORDINGS: u64 = 100_000;
    /// Rollout starts per recording.
    pub const STARTS: u64 = 100_000;
    /// Samples a rollout lasts.
    pub const HORIZON_SAMPLES: u64 = 1_000_000;
    /// Model steps one job's rollouts take (recordings x starts x horizon):
    /// the traces are held in memory.
    pub const ROLLOUT_STEPS: u64 = 100_000_000;
    /// Fit or validation windows.
    pub const WINDOWS: u64 = 10_000_000;
    /// Batch size.
    pub const BATCH: u64 = 1_000_000;
    /// Epochs (and early-stopping patience).
    pub const EPOCHS: u64 = 100_000;
    /// Splits of `factor split`: each is a complete run.
    pub const SPLITS: u64 = 1_000;
    /// Doses of one dose-response arm.
    pub const DOSES: usize = 100;
    /// The largest divergence cap, metres (the paper's is 2 m).
    pub const CAP_M: f64 = 1000.0;
    /// The smallest divergence cap, in metres: a millimetre. Below it every
    /// rollout diverges and the arm means are the cap (or underflow to 0).
    pub const CAP_MIN_M: f64 = 1e-3;
    /// Bootstrap replicates.
    pub const BOOTSTRAP: u64 = 100_000;
    /// Bootstrap work: replicates x recordings x seeds, each replicate a
    /// resampled matrix.
    pub const BOOTSTRAP_WORK: u64 = 2_000_000_000;
    /// Per-cell rows a study writes (models x arms x seeds x splits x
    /// recordings x horizons), all held by the analysis.
    pub const CELLS: u64 = 10_000_000;
}

/// Tolerance for "this many seconds is a whole number of samples".
const SAMPLE_EPS: f64 = 1e-9;

/// One specification: the design as written, every choice already in place.
fn validate_single(ast: &Ast, base: &Path) -> Result<Design, Vec<Diagnostic>> {
    let mut v = Validator { base: base.to_path_buf(), ..Validator::default() };
    let design = v.design(ast);
    match design {
        Some(d) if v.diags.is_empty() => Ok(d),
        _ => Err(v.diags),
    }
}

#[derive(Default)]
struct Validator {
    diags: Vec<Diagnostic>,
    /// Where a `split published` file is read from.
    base: PathBuf,
}

impl Validator {
    fn err(&mut self, title: &str, span: Span, label: impl Into<String>) {
        self.diags.push(Diagnostic::new(title, span, label));
    }

    fn err_help(&mut self, title: &str, span: Span, label: impl Into<String>, help: impl Into<String>) {
        self.diags.push(Diagnostic::new(title, span, label).with_help(help));
    }

    /// A non-negative integer (seeds).
    fn nonneg(&mut self, i: &Int, what: &str) -> u64 {
        if i.node < 0 {
            self.err("negative value", i.span, format!("{what} must be >= 0, found {}", i.node));
            0
        } else {
            i.node as u64
        }
    }

    /// A count that must be at least `min` and at most `max` (a limit of
    /// [`limits`]; `u64::MAX` where none is needed).
    fn count(&mut self, i: &Int, what: &str, min: i64, max: u64) -> usize {
        if i.node < min {
            let title = if min == 1 { "non-positive value" } else { "value too small" };
            self.err(title, i.span, format!("{what} must be >= {min}, found {}", i.node));
            min.max(0) as usize
        } else if i.node as u64 > max {
            self.too_large(i.span, what, i.node as u64, max);
            usize::try_from(max).unwrap_or(usize::MAX)
        } else {
            i.node as usize
        }
    }

    /// The per-cell rows of a study (`factors`: arms, seeds, splits,
    /// recordings, endpoint horizons x models) stay under [`limits::CELLS`].
    fn cells_limit(&mut self, span: Span, factors: [usize; 5]) {
        let cells = factors.iter().fold(1u64, |acc, &n| acc.saturating_mul(n as u64));
        if cells > limits::CELLS {
            let [a, s, sp, r, h] = factors;
            self.err_help(
                "study too large",
                span,
                format!("{a} arms x {s} seeds x {sp} splits x {r} recordings x {h} endpoint horizons and models is {cells} per-cell rows"),
                format!("a study may have at most {} per-cell rows (all held by the analysis); fewer seeds, recordings or arms", limits::CELLS),
            );
        }
    }

    /// A value above one of the [`limits`].
    fn too_large(&mut self, span: Span, what: &str, found: u64, max: u64) {
        self.err_help(
            "value too large",
            span,
            format!("{what} must be at most {max}, found {found}"),
            format!("crossaudit refuses more than {max} so that a run cannot run out of memory or time on it"),
        );
    }

    fn positive(&mut self, n: &Number, what: &str) -> f64 {
        if n.node <= 0.0 {
            self.err("non-positive value", n.span, format!("{what} must be > 0, found {}", n.node));
        }
        n.node
    }

    /// Remembers the first span of a clause and reports a second one.
    fn once(&mut self, seen: &mut BTreeMap<&'static str, Span>, key: &'static str, span: Span) {
        if let Some(first) = seen.get(key) {
            let _ = first;
            self.err_help(
                "declared twice",
                span,
                format!("a second `{key}`"),
                format!("`{key}` was already given earlier in this block; keep one"),
            );
        } else {
            seen.insert(key, span);
        }
    }

    /// `validation N windows from (K recordings | recordings "A", ... | split) seed S`.
    fn validation(
        &mut self,
        windows: &Int,
        recordings: &ValRecordings,
        seed: &Int,
        published: bool,
        pinned: Option<Vec<ListedName>>,
    ) -> ValidationSpec {
        let windows = self.count(windows, "validation windows", 1, limits::WINDOWS);
        let seed = self.nonneg(seed, "validation seed");
        match (recordings, published) {
            (ValRecordings::Split(_), true) => {
                let listed = pinned.unwrap_or_default();
                return ValidationSpec { windows, recordings: listed.len(), seed, listed };
            }
            (ValRecordings::Split(span), false) => {
                self.err_help(
                    "no published split",
                    *span,
                    "`from split` needs a `split published` statement",
                    "declare `split published \"FILE\" { evaluation ROLE; validation ROLE; fit ROLE }`, or draw: `from 8 recordings`",
                );
                return ValidationSpec { windows, recordings: 1, seed, listed: Vec::new() };
            }
            (ValRecordings::Count(Spanned { span, .. }), true) => {
                self.err_help(
                    "validation recordings given twice",
                    *span,
                    "the published split's validation roles give the validation recordings",
                    "write `validation N windows from split seed S`",
                );
            }
            (ValRecordings::List(names), true) => {
                let span = names.first().map(|n| n.span).unwrap_or_default();
                self.err_help(
                    "validation recordings given twice",
                    span,
                    "the published split's validation roles give the validation recordings",
                    "write `validation N windows from split seed S`",
                );
            }
            _ => {}
        }
        match recordings {
            ValRecordings::Count(n) => ValidationSpec {
                windows,
                recordings: self.count(n, "validation recordings", 1, limits::RECORDINGS),
                seed,
                listed: Vec::new(),
            },
            ValRecordings::List(names) => {
                let listed = self.listed(names, "validation");
                ValidationSpec { windows, recordings: listed.len(), seed, listed }
            }
            ValRecordings::Split(_) => ValidationSpec { windows, recordings: 1, seed, listed: Vec::new() },
        }
    }

    /// numpy's legacy RandomState takes seeds 0..=2^32-1 only: every seed
    /// the split draws with must fit.
    fn numpy_seeds(&mut self, ast: &Ast) {
        let mut seeds: Vec<&Int> = Vec::new();
        for s in &ast.statements {
            match &s.node {
                Statement::FactorRecording(items) => seeds.extend(items.iter().filter_map(|i| match &i.node {
                    RecordingItem::SplitSeed(n) => Some(n),
                    _ => None,
                })),
                Statement::Validation { seed, .. } => seeds.push(seed),
                Statement::Arm { body: ArmBody::Fit { seed: Some(seed), .. }, .. } => seeds.push(seed),
                Statement::Arm { body: ArmBody::Derived { seed, .. }, .. } => seeds.push(seed),
                _ => {}
            }
        }
        for seed in seeds {
            if seed.node > i64::from(u32::MAX) {
                self.err_help(
                    "seed out of range for numpy_legacy",
                    seed.span,
                    format!("{} does not fit in 32 bits", seed.node),
                    "numpy's RandomState takes seeds 0 to 4294967295",
                );
            }
        }
    }

    fn study(&mut self, name: &Spanned<String>) -> Option<String> {
        if name.node.trim().is_empty() {
            self.err("empty study name", name.span, "the study needs a name");
        }
        Some(name.node.clone())
    }

    /// The `train` block; a design with a trained model must have one.
    fn train_block(&mut self, stmt: Option<&Spanned<Statement>>, models: &[(Model, Span)]) -> Option<Training> {
        match stmt {
            Some(s) => match &s.node {
                Statement::Train(items) => self.training(items, s.span),
                _ => None,
            },
            None => {
                // A linear model reads its target and actions from the
                // train block too: without one it would fail only after the
                // audit and the split.
                let fitted = |k: &crate::design::ModelKind| {
                    matches!(k, crate::design::ModelKind::Mlp { .. } | crate::design::ModelKind::Linear { .. })
                };
                if let Some(m) = models.iter().find(|m| fitted(&m.0.kind)) {
                    self.err_help(
                        "missing statement",
                        m.1,
                        format!("model `{}` has parameters to fit, but the design has no `train` block", m.0.name),
                        "add `train { adam lr ... batch ... epochs ... cosine patience ... action_noise ... }` (a linear model reads its `target` and `actions` from it)",
                    );
                }
                None
            }
        }
    }

    fn no_duplicate_names(&mut self, names: &[Ident], what: &str) {
        let mut seen = std::collections::BTreeSet::new();
        for n in names {
            if !seen.insert(n.node.as_str()) {
                self.err("duplicate name", n.span, format!("{what} `{}` is listed twice", n.node));
            }
        }
    }
}

impl Validator {
    /// `left - right` of a contrast or an interaction: both names declared
    /// (`noun`s, `plural` in the help) and different. False after reporting
    /// every problem.
    fn two_declared(
        &mut self,
        (noun, plural, what): (&str, &str, &str),
        left: &Ident,
        right: &Ident,
        declared: &[&str],
    ) -> bool {
        let mut ok = true;
        for n in [left, right] {
            if !declared.contains(&n.node.as_str()) {
                let help = known(plural, declared.iter().copied());
                self.err_help(&format!("unknown {noun}"), n.span, format!("no {noun} named `{}`", n.node), help);
                ok = false;
            }
        }
        if left.node == right.node {
            let label = format!("the {what} needs two different {plural}");
            self.err(&format!("{noun} contrasted with itself"), right.span, label);
            ok = false;
        }
        ok
    }
}

fn known<'a>(what: &str, names: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<&str> = names.collect();
    if names.is_empty() {
        format!("no {what} are declared")
    } else {
        format!("declared {what}: {}", names.join(", "))
    }
}
