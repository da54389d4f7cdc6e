//! The analysis statements: estimator, sensitivity analyses, the model
//! interaction and the decision rule.

use std::collections::BTreeMap;

use super::{limits, Validator};
use crate::design::ast::*;
use crate::design::*;

impl Validator {
    /// `estimate KIND { level L; df RULE; missing allow|refuse }`.
    pub(super) fn estimator(&mut self, kind: &Ident, items: &[Spanned<EstimateItem>]) -> Option<Estimator> {
        let estimator = self.estimator_kind(kind);
        let mut seen = BTreeMap::new();
        let mut level = 0.95;
        let mut df = match estimator {
            EstimatorKind::CrossedMom => DfRule::SeedsMinusOne,
            EstimatorKind::Reml => DfRule::KenwardRoger,
        };
        let mut missing_allowed = false;
        for item in items {
            match &item.node {
                EstimateItem::Level(l) => {
                    self.once(&mut seen, "level", item.span);
                    level = self.confidence_level(l);
                }
                EstimateItem::DfFactorMinus { factor, minus } => {
                    self.once(&mut seen, "df", item.span);
                    match factor.node.as_str() {
                        "seed" => df = DfRule::SeedsMinusOne,
                        "recording" => df = DfRule::RecordingsMinusOne,
                        other => self.err_help(
                            "unknown factor",
                            factor.span,
                            format!("`{other}` is not a factor"),
                            "df rules: seed - 1, recording - 1, satterthwaite, kenward_roger, z",
                        ),
                    }
                    if minus.node != 1 {
                        self.err("unsupported df rule", minus.span, format!("only `{} - 1` is supported", factor.node));
                    }
                }
                EstimateItem::DfNamed(n) => {
                    self.once(&mut seen, "df", item.span);
                    df = match n.node.as_str() {
                        "z" => DfRule::Normal,
                        "kenward_roger" => DfRule::KenwardRoger,
                        _ => DfRule::Satterthwaite,
                    };
                    if df == DfRule::KenwardRoger && estimator == EstimatorKind::CrossedMom {
                        self.err_help(
                            "df rule needs a likelihood",
                            n.span,
                            "Kenward-Roger df come from the REML likelihood; the method of moments has none",
                            "write `estimate reml ... df kenward_roger`, or keep crossed_mom with `df satterthwaite`",
                        );
                    }
                }
                EstimateItem::Missing(p) => {
                    self.once(&mut seen, "missing", item.span);
                    missing_allowed = p.node == "allow";
                    if missing_allowed && estimator == EstimatorKind::CrossedMom {
                        self.err_help(
                            "missing cells need REML",
                            p.span,
                            "the method of moments needs every cell of the recording x seed array",
                            "write `estimate reml ... missing allow` to analyse per-cell files with missing cells",
                        );
                    }
                }
            }
        }
        Some(Estimator { kind: estimator, level, df, missing_allowed })
    }

    /// `crossed_mom` or `reml` (an unknown name is refused, read as
    /// `crossed_mom`).
    fn estimator_kind(&mut self, kind: &Ident) -> EstimatorKind {
        match kind.node.as_str() {
            "crossed_mom" => EstimatorKind::CrossedMom,
            "reml" => EstimatorKind::Reml,
            _ => {
                self.err_help(
                    "unknown estimator",
                    kind.span,
                    format!("`{}` is not an estimator", kind.node),
                    "known estimators: crossed_mom, reml",
                );
                EstimatorKind::CrossedMom
            }
        }
    }

    /// `level L`: a confidence level in (0, 1), not so close to 1 that its
    /// quantile is infinite.
    fn confidence_level(&mut self, l: &Number) -> f64 {
        if !(l.node > 0.0 && l.node < 1.0) {
            self.err_help(
                "level out of range",
                l.span,
                format!("{} is outside (0, 1)", l.node),
                "write the confidence level as a fraction, e.g. 0.95",
            );
        } else if 1.0 - l.node < 1e-9 {
            self.err_help(
                "level out of range",
                l.span,
                format!(
                    "{} leaves {:.1e} outside the interval: its quantile would be infinite in double precision",
                    l.node,
                    1.0 - l.node
                ),
                "a confidence level may be at most 0.999999999",
            );
        }
        l.node
    }

    /// `sensitivity { bootstrap ...; grouped; leave_one_out ... }`.
    pub(super) fn sensitivity(
        &mut self,
        items: &[Spanned<SensitivityItem>],
        conditions: &[Condition],
        (n_seeds, level): (Option<usize>, f64),
        recording: Option<&RecordingFactor>,
    ) -> Option<Sensitivity> {
        let mut seen = BTreeMap::new();
        let mut out = Sensitivity { bootstrap: None, grouped: Grouped::Off, leave_one_out: Vec::new() };
        for item in items {
            match &item.node {
                SensitivityItem::Bootstrap { kind, replicates, seed } => {
                    self.once(&mut seen, "bootstrap", item.span);
                    out.bootstrap = Some(self.bootstrap(kind, (replicates, level), seed, n_seeds, recording));
                }
                SensitivityItem::Grouped => {
                    self.once(&mut seen, "grouped", item.span);
                    if conditions.is_empty() && recording.is_some() {
                        self.err_help(
                            "grouped sensitivity without conditions",
                            item.span,
                            "there are no condition labels to group by",
                            "declare `conditions trajectory, speed` in `factor recording`",
                        );
                    }
                    out.grouped = Grouped::ByConditions;
                }
                SensitivityItem::LeaveOneOut(factors) => {
                    self.once(&mut seen, "leave_one_out", item.span);
                    self.no_duplicate_names(factors, "factor");
                    self.leave_one_out(factors, n_seeds, recording, &mut out.leave_one_out);
                }
            }
        }
        Some(out)
    }

    /// `bootstrap pigeonhole R seed S`, its work (replicates x recordings
    /// x seeds) within [`limits::BOOTSTRAP_WORK`], and at least the
    /// replicates whose percentile interval at the design's `level` has a
    /// replicate beyond each bound ([`min_replicates`]).
    fn bootstrap(
        &mut self,
        kind: &Ident,
        (replicates, level): (&Int, f64),
        seed: &Int,
        n_seeds: Option<usize>,
        recording: Option<&RecordingFactor>,
    ) -> BootstrapSpec {
        if kind.node != "pigeonhole" {
            self.err_help(
                "unknown bootstrap",
                kind.span,
                format!("`{}` is not a bootstrap scheme", kind.node),
                "known schemes: pigeonhole (rows and columns resampled independently)",
            );
        }
        let reps = self.count(replicates, "bootstrap replicates", 1, limits::BOOTSTRAP);
        let least = min_replicates(level);
        // A level outside (0, 1 - 1e-9), or no replicates, has its own error.
        if replicates.node >= 1 && reps < least && level > 0.0 && 1.0 - level >= 1e-9 {
            self.err_help(
                "too few bootstrap replicates",
                replicates.span,
                format!(
                    "{reps} replicates leave each {:.1}% tail of a {}% percentile interval without a replicate beyond its bound: the interval would be the extreme replicates, or one point",
                    (1.0 - level) * 50.0,
                    level * 100.0
                ),
                format!("at least {least} replicates for a {}% interval (999 or more are usual)", level * 100.0),
            );
        }
        if let (Some(s), Some(r)) = (n_seeds, recording) {
            let work = (reps as u64).saturating_mul(s as u64).saturating_mul(r.evaluation as u64);
            if work > limits::BOOTSTRAP_WORK {
                self.err_help(
                    "bootstrap too large",
                    replicates.span,
                    format!("{reps} replicates of {} recordings x {s} seeds is {work} resampled cells", r.evaluation),
                    format!(
                        "the bootstrap may resample at most {} cells in all; lower the replicates",
                        limits::BOOTSTRAP_WORK
                    ),
                );
            }
        }
        BootstrapSpec { replicates: reps, seed: self.nonneg(seed, "the bootstrap seed") }
    }

    /// `leave_one_out seed, recording`: each factor known and with at
    /// least 3 levels, added to `out` once.
    fn leave_one_out(
        &mut self,
        factors: &[Ident],
        n_seeds: Option<usize>,
        recording: Option<&RecordingFactor>,
        out: &mut Vec<Factor>,
    ) {
        for f in factors {
            let factor = match f.node.as_str() {
                "seed" => Factor::Seed,
                "recording" => Factor::Recording,
                other => {
                    self.err_help(
                        "unknown factor",
                        f.span,
                        format!("`{other}` is not a factor"),
                        "leave_one_out takes: seed, recording",
                    );
                    continue;
                }
            };
            let n = match factor {
                Factor::Seed => n_seeds,
                Factor::Recording => recording.map(|r| r.evaluation),
            };
            if let Some(n) = n {
                if n < 3 {
                    self.err(
                        "too few levels to leave one out",
                        f.span,
                        format!("leaving one of {n} {}s out leaves fewer than 2", f.node),
                    );
                }
            }
            if !out.contains(&factor) {
                out.push(factor);
            }
        }
    }

    pub(super) fn interaction(
        &mut self,
        left: &Ident,
        right: &Ident,
        models: &[(Model, Span)],
        endpoints: &[(Endpoint, Span)],
    ) -> Option<Interaction> {
        let declared: Vec<&str> = models.iter().map(|x| x.0.name.as_str()).collect();
        let mut ok = self.two_declared(("model", "models", "interaction"), left, right, &declared);
        if ok {
            let covers = |name: &str| {
                endpoints
                    .iter()
                    .flat_map(|(e, _)| e.horizons.iter().map(move |h| (e.metric, h.0, e.models.clone())))
                    .any(|(metric, h, ms)| {
                        ms.iter().any(|m| m == name)
                            && endpoints.iter().any(|(f, _)| {
                                f.metric == metric
                                    && f.horizons.iter().any(|g| g.0 == h)
                                    && f.models.contains(&right.node)
                            })
                    })
            };
            if !covers(&left.node) {
                self.err_help(
                    "interaction without a shared endpoint",
                    Span { start: left.span.start, end: right.span.end },
                    format!("no endpoint measures both `{}` and `{}` at the same horizon", left.node, right.node),
                    "add both models to an endpoint, e.g. `model world, relative`",
                );
                ok = false;
            }
        }
        ok.then(|| Interaction { left: left.node.clone(), right: right.node.clone() })
    }

    pub(super) fn decision(&mut self, name: &Ident, conditions: &[Spanned<ConditionAst>]) -> Option<DecisionRule> {
        let mut out = Vec::new();
        for c in conditions {
            let c = &c.node;
            let quantity = match c.quantity.node.as_str() {
                "optimism" => Quantity::Optimism,
                "mean" => Quantity::Mean,
                "lower" => Quantity::Lower,
                "upper" => Quantity::Upper,
                other => {
                    self.err_help(
                        "unknown quantity",
                        c.quantity.span,
                        format!("`{other}` is not a quantity of the primary endpoint"),
                        "a decision rule may use: optimism (%), mean, lower, upper",
                    );
                    continue;
                }
            };
            if c.percent && quantity != Quantity::Optimism {
                self.err_help(
                    "percent on a non-percentage",
                    c.value.span,
                    format!("`{}` is a difference in the metric's unit, not a percentage", quantity.name()),
                    "only optimism is a percentage",
                );
            }
            let v = c.value.node;
            if quantity == Quantity::Optimism && !c.percent && v != 0.0 && v.abs() < 1.0 {
                // `0.1` is a fraction to most readers and 0.1 % to the rule.
                self.err_help(
                    "optimism threshold without `%`",
                    c.value.span,
                    format!("optimism is a percentage, so `{v}` would be read as {v}%"),
                    // Rounded to 9 decimals: 0.1 x 100 is 10.000000000000002 in floating point.
                    format!(
                        "write `{}%` for a fraction of {v}, or `{v}%` if {v} percent is meant",
                        (v * 1e11).round() / 1e9
                    ),
                );
            }
            out.push(DecisionCondition { quantity, cmp: c.cmp.node, value: v });
        }
        Some(DecisionRule { name: name.node.clone(), on: DecisionTarget::Primary, conditions: out })
    }
}

/// The fewest bootstrap replicates whose percentile interval at `level`
/// has at least one replicate in each tail, `ceil(2 / (1 - level))`: 40
/// at 95%, 200 at 99%.
fn min_replicates(level: f64) -> usize {
    let tails = 1.0 - level;
    if tails > 0.0 && tails < 1.0 {
        (2.0 / tails - 1e-9).ceil() as usize
    } else {
        1
    }
}
