//! Endpoints (metrics, horizons, caps, models) and the contrast.

use super::{known, limits, Validator, SAMPLE_EPS};
use crate::design::ast::*;
use crate::design::*;

impl Validator {
    /// `glmm binomial`: only on a secondary `divergence_rate` endpoint,
    /// whose cells count their diverged starts out of their starts.
    fn glmm(&mut self, e: &EndpointStmt, role: Role, metric: Option<Metric>) -> bool {
        let Some(family) = &e.glmm else { return false };
        if family.node != "binomial" {
            self.err_help(
                "unknown GLMM family",
                family.span,
                format!("`{}` is not a family of an endpoint's GLMM", family.node),
                "write `glmm binomial`: diverged starts out of the cell's starts",
            );
            return false;
        }
        if metric.is_some_and(|m| m != Metric::DivergenceRate) {
            self.err_help(
                "GLMM on a continuous metric",
                family.span,
                format!("`glmm binomial` analyses failures out of trials; `{}` is not a count", e.metric.node),
                "declare it on `divergence_rate`, whose cells count diverged starts out of their starts",
            );
            return false;
        }
        if role == Role::Primary {
            self.err_help(
                "GLMM on the primary endpoint",
                family.span,
                "the primary endpoint is the crossed contrast every report and sensitivity reads",
                "declare the GLMM on a secondary endpoint (`endpoint secondary divergence_rate at 1.0 s model world glmm binomial`) and decide on it with `decide NAME on divergence when ...`",
            );
            return false;
        }
        true
    }

    /// The endpoint statements, each with its metric, horizons, cap and
    /// models; exactly one primary, and every model in some endpoint.
    pub(super) fn endpoints(
        &mut self,
        stmts: &[&Spanned<Statement>],
        models: &[(Model, Span)],
        rate: f64,
        horizon_samples: Option<usize>,
        end: Span,
    ) -> Vec<(Endpoint, Span)> {
        let mut out: Vec<(Endpoint, Span)> = Vec::new();
        let mut primary_cap: Option<f64> = None;
        let mut primaries: Vec<Span> = Vec::new();
        let mut seen_cells: std::collections::BTreeSet<(Metric, u64, String)> = Default::default();
        // The primary's cap is the study's divergence cap; read it first.
        for s in stmts {
            if let Statement::Endpoint(e) = &s.node {
                if e.role.node == "primary" {
                    primary_cap = primary_cap.or(e.cap.as_ref().map(|c| c.node));
                }
            }
        }
        for s in stmts {
            let Statement::Endpoint(e) = &s.node else {
                continue;
            };
            let role = match e.role.node.as_str() {
                "primary" => Role::Primary,
                _ => Role::Secondary,
            };
            let metric = Metric::ALL.into_iter().find(|m| m.name() == e.metric.node);
            if metric.is_none() {
                self.err_help(
                    "unknown metric",
                    e.metric.span,
                    format!("`{}` is not a metric", e.metric.node),
                    known("metrics", Metric::ALL.iter().map(|m| m.name())),
                );
            }
            let horizons = self.horizons(&e.horizons, rate, horizon_samples);
            let glmm = self.glmm(e, role, metric);
            self.cap(e.cap.as_ref(), role, primary_cap);
            let names = self.endpoint_models(&e.models, models);
            if role == Role::Primary {
                self.primary(e, s.span, &mut primaries);
                self.primary_model_trains(e, models);
            }
            if let Some(metric) = metric {
                self.duplicate_cells(metric, &horizons, &names, s.span, &mut seen_cells);
                let cap = Meters(e.cap.as_ref().map(|c| c.node).or(primary_cap).unwrap_or(f64::NAN));
                out.push((Endpoint { role, metric, horizons, cap, models: names, glmm }, s.span));
            }
        }
        self.unscored_models(stmts, models, &out);
        if primaries.is_empty() && !stmts.is_empty() {
            self.err_help(
                "no primary endpoint",
                end,
                "the design ends here without a primary endpoint",
                "mark exactly one endpoint `endpoint primary ...`",
            );
        }
        out
    }

    /// Each (metric, horizon, model) cell of an endpoint, refused when an
    /// earlier endpoint already has it (`seen`: the cells so far).
    fn duplicate_cells(
        &mut self,
        metric: Metric,
        horizons: &[Seconds],
        names: &[String],
        span: Span,
        seen: &mut std::collections::BTreeSet<(Metric, u64, String)>,
    ) {
        for h in horizons {
            for m in names {
                let key = (metric, (h.0 * 1e9).round() as u64, m.clone());
                if !seen.insert(key) {
                    self.err(
                        "duplicate endpoint",
                        span,
                        format!("{} at {} s for model `{}` is already an endpoint", metric.name(), h.0, m),
                    );
                }
            }
        }
    }

    /// A model no endpoint names would be trained and never scored: its
    /// jobs would write per-cell files without rows. Checked when every
    /// endpoint statement was read.
    fn unscored_models(&mut self, stmts: &[&Spanned<Statement>], models: &[(Model, Span)], out: &[(Endpoint, Span)]) {
        for (m, span) in models {
            let all_read = !stmts.is_empty() && out.len() == stmts.len();
            if all_read && !out.iter().any(|(e, _)| e.models.contains(&m.name)) {
                self.err_help(
                    "model in no endpoint",
                    *span,
                    format!("model `{}` is named by no endpoint", m.name),
                    "name it in an endpoint (`models a, b`), or remove it",
                );
            }
        }
    }

    /// The horizons of one endpoint, each checked against the rate and the rollout.
    fn horizons(&mut self, horizons: &[Number], rate: f64, horizon_samples: Option<usize>) -> Vec<Seconds> {
        let mut out = Vec::new();
        let mut seen = std::collections::BTreeSet::new();
        for h in horizons {
            if h.node <= 0.0 {
                self.err("non-positive horizon", h.span, format!("the horizon must be > 0 s, found {} s", h.node));
                continue;
            }
            if !seen.insert(h.node.to_bits()) {
                self.err("duplicate horizon", h.span, format!("{} s is listed twice", h.node));
                continue;
            }
            let samples = h.node * rate;
            if samples.round() < 1.0 {
                // Zero samples would be a rollout that never moves: the
                // metrics at that horizon have nothing to average.
                self.err_help(
                    "horizon shorter than one sample",
                    h.span,
                    format!("{} s at {} Hz is {} samples", h.node, rate, samples),
                    format!("a horizon lasts at least one sample, {} s at {} Hz", 1.0 / rate, rate),
                );
                continue;
            }
            if (samples - samples.round()).abs() > SAMPLE_EPS {
                self.err(
                    "horizon between samples",
                    h.span,
                    format!("{} s at {} Hz is {} samples, not a whole number", h.node, rate, samples),
                );
            }
            if let Some(max) = horizon_samples {
                if samples.round() > max as f64 {
                    self.err_help(
                        "horizon beyond the rollout",
                        h.span,
                        format!("{} s is {} samples, but rollouts last {} samples", h.node, samples.round(), max),
                        "raise `horizon` in `factor recording` or shorten the endpoint",
                    );
                }
            }
            out.push(Seconds(h.node));
        }
        out
    }

    /// A cap must be positive and, on a secondary endpoint, equal the primary's.
    fn cap(&mut self, cap: Option<&Number>, role: Role, primary_cap: Option<f64>) {
        if let Some(c) = cap {
            if c.node <= 0.0 {
                self.err("non-positive cap", c.span, format!("the divergence cap must be > 0 m, found {} m", c.node));
            } else if c.node < limits::CAP_MIN_M {
                let found = if c.node < 1e-6 { format!("{:e}", c.node) } else { c.node.to_string() };
                self.err_help(
                    "value too small",
                    c.span,
                    format!("the divergence cap must be at least {} m, found {found} m", limits::CAP_MIN_M),
                    "a rollout whose error passes the cap is scored as diverged: below a millimetre every rollout diverges",
                );
            } else if c.node > limits::CAP_M {
                let found = if c.node >= 1e6 { format!("{:e}", c.node) } else { c.node.to_string() };
                self.err_help(
                    "value too large",
                    c.span,
                    format!("the divergence cap must be at most {} m, found {found} m", limits::CAP_M),
                    "a diverged rollout scores the cap: squared in the analysis, a cap this large overflows",
                );
            } else if let Some(p) = primary_cap {
                if role == Role::Secondary && c.node != p {
                    self.err_help(
                        "conflicting caps",
                        c.span,
                        format!("cap {} m differs from the primary endpoint's {} m", c.node, p),
                        "rollouts diverge at one cap; give every endpoint the same cap or leave it out",
                    );
                }
            }
        }
    }

    /// The models an endpoint names, each declared and listed once.
    fn endpoint_models(&mut self, listed: &[Ident], models: &[(Model, Span)]) -> Vec<String> {
        let mut names = Vec::new();
        self.no_duplicate_names(listed, "model");
        for m in listed {
            if !models.iter().any(|(x, _)| x.name == m.node) {
                self.err_help(
                    "unknown model",
                    m.span,
                    format!("no model named `{}`", m.node),
                    known("models", models.iter().map(|x| x.0.name.as_str())),
                );
            }
            names.push(m.node.clone());
        }
        names
    }

    /// The primary endpoint is unique, capped, and names one horizon and one model.
    fn primary(&mut self, e: &EndpointStmt, span: Span, primaries: &mut Vec<Span>) {
        primaries.push(span);
        if primaries.len() == 2 {
            self.err_help(
                "two primary endpoints",
                span,
                "a second primary endpoint",
                "a preregistration has exactly one primary endpoint; make this one `secondary`",
            );
        }
        if e.cap.is_none() {
            self.err(
                "primary endpoint without a cap",
                e.metric.span,
                "the primary endpoint must state `cap <metres> m`",
            );
        }
        if e.horizons.len() != 1 || e.models.len() != 1 {
            self.err_help(
                "ambiguous primary endpoint",
                span,
                format!("{} horizons x {} models", e.horizons.len(), e.models.len()),
                "the primary endpoint names exactly one horizon and one model",
            );
        }
    }

    /// The primary endpoint's model is fitted in each arm: a parameter-free
    /// baseline (persistence, constant velocity) is the same model in every
    /// arm, so its contrast is 0 by construction, which `run` would find
    /// only after training every job.
    fn primary_model_trains(&mut self, e: &EndpointStmt, models: &[(Model, Span)]) {
        for name in &e.models {
            if let Some((m, _)) = models.iter().find(|(m, _)| m.name == name.node).filter(|(m, _)| !m.kind.trains()) {
                self.err_help(
                    "parameter-free primary model",
                    name.span,
                    format!(
                        "`{}` is {}: it fits nothing, so it is the same model in every arm and `treated - reference` is 0 by construction",
                        m.name,
                        match m.kind {
                            ModelKind::ConstantVelocity => "constant velocity",
                            _ => "persistence",
                        }
                    ),
                    "decide on a model the arms train (an `mlp`, `linear` or `external` model); a baseline is the reference level of an interaction (`interaction MODEL - BASELINE`) or a secondary endpoint",
                );
            }
        }
    }

    pub(super) fn contrast(&mut self, treated: &Ident, reference: &Ident, arms: &[(Arm, Span)]) -> Option<Contrast> {
        // A dose-response family is contrasted by its name, dose by dose.
        let families = arms.iter().filter_map(|x| match &x.0.kind {
            ArmKind::Derived { family: Some(f), .. } => Some(f.as_str()),
            _ => None,
        });
        let mut declared: Vec<&str> = arms.iter().map(|x| x.0.name.as_str()).chain(families).collect();
        declared.dedup();
        let ok = self.two_declared(("arm", "arms", "contrast"), treated, reference, &declared);
        ok.then(|| Contrast { treated: treated.node.clone(), reference: reference.node.clone() })
    }
}
