//! The `data` block: source, path, rate, inclusion rules, duplicates,
//! strictness, state and action columns, and `data simulated`.

use std::collections::BTreeMap;

use super::Validator;
use crate::design::ast::*;
use crate::design::*;

impl Validator {
    pub(super) fn data(&mut self, block: &DataBlock) -> Option<DataSpec> {
        let source = match block.source.node.as_str() {
            "nanobench" => Some(DataSource::Nanobench),
            "simulated" => Some(DataSource::Simulated),
            other => {
                self.err_help(
                    "unknown data source",
                    block.source.span,
                    format!("`{other}` is not a data source"),
                    "known sources: nanobench, simulated",
                );
                None
            }
        };
        let (mut sim_n, mut sim_seed, mut sim_strength, mut sim_duration) = (None, None, None, None);
        let mut seen = BTreeMap::new();
        let mut spec = DataSpec {
            source: DataSource::Nanobench,
            path: None,
            rate_hz: 100.0,
            rules: Vec::new(),
            duplicates: DuplicatePolicy::Keep,
            strictness: Strictness::Lenient,
            state_columns: DEFAULT_STATE_COLUMNS.iter().map(|s| s.to_string()).collect(),
            action_columns: DEFAULT_ACTION_COLUMNS.iter().map(|s| s.to_string()).collect(),
            simulated: None,
        };
        for item in &block.items {
            match &item.node {
                DataItem::Path(p) => {
                    self.once(&mut seen, "path", item.span);
                    if p.node.is_empty() {
                        self.err("empty path", p.span, "the data path is empty");
                    }
                    spec.path = Some(p.node.clone());
                }
                DataItem::Rate(r) => {
                    self.once(&mut seen, "rate", item.span);
                    spec.rate_hz = self.positive(r, "the sample rate");
                }
                DataItem::IncludeActive { column, cmp, threshold, min_samples } => {
                    self.once(&mut seen, "include", item.span);
                    spec.rules.push(InclusionRule::Active {
                        column: column.node.clone(),
                        cmp: cmp.node,
                        threshold: threshold.node,
                        min_samples: self.count(min_samples, "the active-sample minimum", 1) as u64,
                    });
                }
                DataItem::ExcludeImplausible => {
                    self.once(&mut seen, "exclude", item.span);
                    spec.rules.push(InclusionRule::Implausible);
                }
                DataItem::Duplicates(p) => {
                    self.once(&mut seen, "duplicates", item.span);
                    spec.duplicates = match p.node.as_str() {
                        "group" => DuplicatePolicy::Group,
                        "first" => DuplicatePolicy::First,
                        _ => DuplicatePolicy::Keep,
                    };
                }
                DataItem::Strict => {
                    self.once(&mut seen, "strict", item.span);
                    spec.strictness = Strictness::Strict;
                }
                DataItem::State(cols) => {
                    self.once(&mut seen, "state", item.span);
                    spec.state_columns = self.columns(cols, 14, "state", item.span);
                }
                DataItem::Action(cols) => {
                    self.once(&mut seen, "action", item.span);
                    spec.action_columns = self.columns(cols, 4, "action", item.span);
                }
                DataItem::SimRecordings(n) => {
                    self.once(&mut seen, "recordings", item.span);
                    sim_n = Some(self.count(n, "the number of simulated recordings", 2));
                }
                DataItem::SimSeed(n) => {
                    self.once(&mut seen, "seed", item.span);
                    sim_seed = Some(self.nonneg(n, "the simulation seed"));
                }
                DataItem::SimStrength(x) => {
                    self.once(&mut seen, "strength", item.span);
                    if x.node < 0.0 {
                        self.err("negative value", x.span, format!("strength must be >= 0, found {}", x.node));
                    }
                    sim_strength = Some(x.node);
                }
                DataItem::SimDuration(x) => {
                    self.once(&mut seen, "duration", item.span);
                    sim_duration = Some(self.positive(x, "the simulated duration"));
                }
            }
        }
        let sim_given = sim_n.is_some() || sim_seed.is_some() || sim_strength.is_some() || sim_duration.is_some();
        match source {
            Some(DataSource::Simulated) => match (sim_n, sim_seed, sim_strength, sim_duration) {
                (Some(recordings), Some(seed), Some(strength), Some(duration_s)) => {
                    spec.simulated = Some(SimSpec { recordings, seed, strength, duration_s });
                }
                _ => self.err_help(
                    "incomplete simulated data",
                    block.source.span,
                    "simulated data needs `recordings`, `seed`, `strength` and `duration`",
                    "e.g. `data simulated { recordings 40 seed 7 strength 1.0 duration 20 s }`",
                ),
            },
            Some(DataSource::Nanobench) if sim_given => self.err_help(
                "simulation settings on real data",
                block.source.span,
                "`recordings`, `seed`, `strength` and `duration` only apply to `data simulated`",
                "remove them, or switch the source to `simulated`",
            ),
            _ => {}
        }
        source.map(|source| DataSpec { source, ..spec })
    }

    pub(super) fn columns(&mut self, cols: &[Ident], want: usize, what: &str, span: Span) -> Vec<String> {
        if cols.len() != want {
            self.err("wrong number of columns", span, format!("the {what} has {want} columns, {} given", cols.len()));
        }
        self.no_duplicate_names(cols, "column");
        cols.iter().map(|c| c.node.clone()).collect()
    }
}
