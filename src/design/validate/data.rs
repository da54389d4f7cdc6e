//! The `data` block: source, path, rate, inclusion rules, duplicates,
//! strictness, state and action columns, and `data simulated`.

use std::collections::BTreeMap;

use super::csv::CsvParts;
use super::Validator;
use crate::design::ast::*;
use crate::design::*;

impl Validator {
    /// The data block: its items read one by one, then the checks that
    /// need them all (gaps against the rate, rules against a csv layout,
    /// the simulator's settings).
    pub(super) fn data(&mut self, block: &DataBlock) -> Option<DataSpec> {
        let source = self.data_source(&block.source);
        let mut sim = SimParts::default();
        let mut csv = CsvParts::default();
        let mut seen = BTreeMap::new();
        let mut spec = DataSpec::nanobench_defaults();
        for item in &block.items {
            if let Some(what) = self.csv_item(item, &mut seen, &mut csv) {
                if source.is_some_and(|s| s != DataSource::Csv) {
                    self.err_help(
                        "column declaration outside `data csv`",
                        item.span,
                        format!("`{what}` declares a column of `data csv`; `data {}` reads NanoBench's columns", block.source.node),
                        "use `state`/`action` to pick NanoBench columns, or switch the source to `csv` and declare every column",
                    );
                }
            } else {
                self.data_item(item, source == Some(DataSource::Csv), &mut seen, &mut spec, &mut sim);
            }
        }
        if source == Some(DataSource::Csv) {
            spec.format = self.csv_format(block, &seen, &mut csv, &mut spec);
            self.rules_against_layout(block, &spec);
        } else if let Some(scale) = &csv.scale {
            self.err_help(
                "action scale outside `data csv`",
                scale.span,
                "NanoBench's actions are motor PWM / 65535",
                "remove `scale`, or switch the source to `csv`",
            );
        }
        self.gaps_against_rate(block, &spec);
        self.simulated(block, source, &sim, &mut spec);
        source.map(|source| DataSpec { source, ..spec })
    }

    /// A gap shorter than two steps at the declared rate would cut the
    /// recording at every row: refused.
    fn gaps_against_rate(&mut self, block: &DataBlock, spec: &DataSpec) {
        for item in &block.items {
            // Gaps are read from the time column: a layout without one
            // places row k at k / rate, where there is no gap to find.
            if let (DataItem::Gaps { .. }, None) = (&item.node, spec.log_format().time) {
                self.err_help(
                    "gaps without a time column",
                    item.span,
                    "`gaps` finds gaps in the time column, and this block declares none: row k is at k / rate, so no gap could ever be found",
                    "declare the time column (`time COLUMN`), or remove the `gaps` clause",
                );
                continue;
            }
            if let (DataItem::Gaps { over, .. }, Some(g)) = (&item.node, spec.gaps) {
                if spec.rate_hz > 0.0 && g.over_s * spec.rate_hz < 1.5 {
                    self.err_help(
                        "gap shorter than a step",
                        over.span,
                        format!(
                            "`gaps over {} s` is shorter than 1.5 steps at {} Hz ({} s), so every step would be a gap",
                            over.node,
                            spec.rate_hz,
                            1.5 / spec.rate_hz
                        ),
                        "give the longest step that is not a gap, e.g. `gaps over 0.1 s segment` at 100 Hz",
                    );
                }
            }
        }
    }

    /// The inclusion rules a `data csv` layout cannot serve: a bound on the
    /// rate without an attitude, NanoBench's percentile rule without its
    /// columns.
    fn rules_against_layout(&mut self, block: &DataBlock, spec: &DataSpec) {
        // Upstream's percentile rules read NanoBench's battery and
        // setpoint columns; a lab's layout has other names.
        let needed = ["pwr_pm_vbat", "sp_ctrltarget_z"];
        let lacking: Vec<&str> = needed
            .into_iter()
            .filter(|n| spec.format.is_some() && !spec.state_columns.iter().any(|c| c == n))
            .collect();
        let no_attitude = spec.format.as_ref().is_some_and(|f| !f.attitude);
        for item in
            block.items.iter().filter(|i| matches!(i.node, DataItem::ExcludeBeyond { quantity: Bound::Rate, .. }))
        {
            if no_attitude {
                self.err_help(
                    "rate without an attitude",
                    item.span,
                    "`exclude beyond rate` bounds how fast the attitude turns, and this layout declares no attitude",
                    "declare `attitude quaternion ...` or `attitude euler ...`, or bound the position or speed instead",
                );
            }
        }
        for item in block.items.iter().filter(|i| matches!(i.node, DataItem::ExcludeImplausible(_))) {
            if !lacking.is_empty() {
                self.err_help(
                    "implausible without NanoBench's columns",
                    item.span,
                    format!("`exclude implausible` is NanoBench's percentile rule on {}, which this layout does not declare", lacking.join(" and ")),
                    "for any layout: `exclude frozen position for 2 s`, `exclude beyond position 10 m`, `exclude beyond speed 5 m/s`",
                );
            }
        }
    }

    /// The simulator's settings: all four for `data simulated` (within
    /// [`MAX_SIM_SECONDS`] of flight), recorded in `spec`; none for
    /// NanoBench's data.
    fn simulated(&mut self, block: &DataBlock, source: Option<DataSource>, sim: &SimParts, spec: &mut DataSpec) {
        let sim_given =
            sim.recordings.is_some() || sim.seed.is_some() || sim.strength.is_some() || sim.duration.is_some();
        match source {
            Some(DataSource::Simulated) => match (sim.recordings, sim.seed, sim.strength, sim.duration) {
                (Some(recordings), Some(seed), Some(strength), Some(duration_s)) => {
                    let seconds = recordings as f64 * duration_s;
                    let each_ok = recordings <= MAX_SIM_RECORDINGS && duration_s <= MAX_SIM_DURATION_S;
                    if each_ok && seconds > MAX_SIM_SECONDS {
                        self.err_help(
                            "simulated data too large",
                            block.source.span,
                            format!("{recordings} recordings x {duration_s} s is {seconds} s of flight; at most {MAX_SIM_SECONDS} s can be simulated (about 1 GB of logs)"),
                            "simulate fewer or shorter recordings",
                        );
                    }
                    spec.simulated = Some(SimSpec { recordings, seed, strength, duration_s });
                    self.no_missing_csv_in_simulated(block);
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
    }

    /// `missing csv allow` lets a recording that metadata lists go without
    /// its log; simulated data write every log they list, so the clause
    /// could change nothing: refused at its line rather than accepted as
    /// if it did something.
    fn no_missing_csv_in_simulated(&mut self, block: &DataBlock) {
        for item in &block.items {
            if matches!(&item.node, DataItem::MissingCsv(p) if p.node == "allow") {
                self.err_help(
                    "declaration that cannot apply",
                    item.span,
                    "`missing csv allow` under `data simulated`: the simulator writes every log it lists, so no recording can be missing",
                    "remove the clause (it applies to real logs whose metadata lists a recording without its file)",
                );
            }
        }
    }

    fn data_source(&mut self, source: &Ident) -> Option<DataSource> {
        match source.node.as_str() {
            "nanobench" => Some(DataSource::Nanobench),
            "simulated" => Some(DataSource::Simulated),
            "csv" => Some(DataSource::Csv),
            other => {
                self.err_help(
                    "unknown data source",
                    source.span,
                    format!("`{other}` is not a data source"),
                    "known sources: nanobench, simulated, csv",
                );
                None
            }
        }
    }

    /// One item of the data block, recorded in `spec` (or `sim` for the
    /// simulator's settings).
    fn data_item(
        &mut self,
        item: &Spanned<DataItem>,
        csv: bool,
        seen: &mut BTreeMap<&'static str, Span>,
        spec: &mut DataSpec,
        sim: &mut SimParts,
    ) {
        if let Some(key) = once_key(&item.node) {
            self.once(seen, key, item.span);
        }
        match &item.node {
            DataItem::Path(p) => {
                if p.node.is_empty() {
                    self.err("empty path", p.span, "the data path is empty");
                }
                spec.path = Some(p.node.clone());
            }
            DataItem::Rate(r) => spec.rate_hz = self.positive(r, "the sample rate"),
            DataItem::IncludeActive { .. }
            | DataItem::ExcludeRecordings(_)
            | DataItem::ExcludeFrozen(_)
            | DataItem::ExcludeBeyond { .. }
            | DataItem::ExcludeImplausible(_) => self.inclusion_rule(&item.node, spec),
            DataItem::Tails(p) => spec.tails = tail_policy(p),
            DataItem::Speed(how) => spec.speed = self.speed_labels(how),
            DataItem::Universe { kind, order } => {
                spec.universe = Universe {
                    metadata: kind.node == "metadata",
                    bytewise: order.as_ref().is_some_and(|o| o.node == "bytewise"),
                };
            }
            DataItem::MissingCsv(p) => spec.missing_csv_allowed = p.node == "allow",
            DataItem::Duplicates(p) => spec.duplicates = duplicate_policy(p),
            DataItem::Strict => spec.strictness = Strictness::Strict,
            DataItem::State(cols) => self.state(cols, item.span, spec),
            DataItem::Action { columns, scale } => {
                spec.action_columns = self.action_columns(columns, scale.as_ref(), csv, item.span);
            }
            DataItem::Time(_)
            | DataItem::Position(_)
            | DataItem::Velocity(_)
            | DataItem::Attitude { .. }
            | DataItem::Rates(_)
            | DataItem::Predicted(_)
            | DataItem::Reference(_)
            | DataItem::Extra { .. }
            | DataItem::Extrapolated(_)
            | DataItem::Controller(_)
            | DataItem::FoldersNested
            | DataItem::ConditionsTable { .. }
            | DataItem::ConditionsName(_)
            | DataItem::ConditionsFolder(_) => {}
            DataItem::MissingValues(p) => spec.missing_values = Some(cut_policy(p)),
            DataItem::Gaps { over, policy } => {
                let over_s = self.positive(over, "the longest step");
                spec.gaps = Some(GapPolicy { over_s, policy: cut_policy(policy) });
            }
            DataItem::RequireKept(n) => {
                spec.require_kept = Some(self.count(n, "the fewest recordings kept", 1, u64::MAX) as u64);
            }
            DataItem::SimRecordings(n) => sim.recordings = Some(self.sim_recordings(n)),
            DataItem::SimSeed(n) => sim.seed = Some(self.nonneg(n, "the simulation seed")),
            DataItem::SimStrength(x) => sim.strength = Some(self.sim_strength(x)),
            DataItem::SimDuration(x) => sim.duration = Some(self.sim_duration(x)),
        }
    }

    /// An inclusion rule (`include active`, `exclude ...`), added to the
    /// data's rules; every other item is left to `data_item`.
    fn inclusion_rule(&mut self, item: &DataItem, spec: &mut DataSpec) {
        let rule = match item {
            DataItem::IncludeActive { column, cmp, threshold, min_samples } => InclusionRule::Active {
                column: column.node.clone(),
                cmp: cmp.node,
                threshold: threshold.node,
                min_samples: self.count(min_samples, "the active-sample minimum", 1, u64::MAX) as u64,
            },
            DataItem::ExcludeRecordings(names) => {
                // Checked as every pinned list of names is: none empty, none twice.
                let listed = self.listed(names, "excluded");
                InclusionRule::Named { names: listed.into_iter().map(|n| n.name).collect() }
            }
            DataItem::ExcludeFrozen(t) => InclusionRule::Frozen { seconds: self.positive(t, "the frozen time") },
            DataItem::ExcludeBeyond { quantity, limit } => {
                InclusionRule::Beyond { quantity: *quantity, limit: self.positive(limit, "the bound") }
            }
            DataItem::ExcludeImplausible(pooling) => {
                if pooling.as_ref().is_some_and(|p| p.node == "per_column") {
                    spec.plausibility = Pooling::PerColumn;
                }
                InclusionRule::Implausible
            }
            _ => return,
        };
        spec.rules.push(rule);
    }

    /// `state onboard|motion_capture` (a preset) or the 14 state columns,
    /// recorded in `spec`.
    fn state(&mut self, cols: &[Ident], span: Span, spec: &mut DataSpec) {
        let preset = match cols {
            [one] if one.node == "onboard" => Some(StatePreset::Onboard),
            [one] if one.node == "motion_capture" => Some(StatePreset::MotionCapture),
            _ => None,
        };
        spec.state_preset = preset;
        spec.state_columns = match preset {
            Some(p) => p.columns().iter().map(|c| c.to_string()).collect(),
            None if cols.len() == 1 => {
                self.err_help(
                    "unknown state preset",
                    cols[0].span,
                    format!("`{}` is not a state preset", cols[0].node),
                    "presets: onboard, motion_capture; or list the 14 columns",
                );
                Vec::new()
            }
            None => self.columns(cols, 14, "state", span),
        };
    }

    /// `action COLUMN, ... [scale N]`: NanoBench's four action columns, or
    /// any number in `data csv`, and a positive scale.
    fn action_columns(&mut self, columns: &[Ident], scale: Option<&Number>, csv: bool, span: Span) -> Vec<String> {
        let columns = if csv {
            // Any number of actions; the count is checked for NanoBench's four only.
            self.columns(columns, columns.len().max(1), "action", span)
        } else {
            self.columns(columns, 4, "action", span)
        };
        if let Some(scale) = scale {
            // Refused outside `data csv` by the caller.
            self.positive(scale, "the action scale");
        }
        columns
    }

    /// `recordings N` of `data simulated`: at least 2, at most
    /// [`MAX_SIM_RECORDINGS`].
    fn sim_recordings(&mut self, n: &Int) -> usize {
        let count = self.count(n, "the number of simulated recordings", 2, u64::MAX);
        if count > MAX_SIM_RECORDINGS {
            let message = format!("at most {MAX_SIM_RECORDINGS} recordings can be simulated, found {count}");
            self.err("too many recordings", n.span, message);
        }
        count
    }

    /// `strength X` of `data simulated`: from 0 to [`MAX_SIM_STRENGTH`].
    fn sim_strength(&mut self, x: &Number) -> f64 {
        if x.node < 0.0 {
            self.err("negative value", x.span, format!("strength must be >= 0, found {}", x.node));
        } else if x.node > MAX_SIM_STRENGTH {
            let found = if x.node >= 1e6 { format!("{:e}", x.node) } else { x.node.to_string() };
            self.err_help(
                "value too large",
                x.span,
                format!("strength must be at most {MAX_SIM_STRENGTH}, found {found}"),
                "above it the simulated wind and biases leave too few flyable samples (at 1000 every rollout diverges)",
            );
        }
        x.node
    }

    /// `duration T s` of `data simulated`: positive, at most
    /// [`MAX_SIM_DURATION_S`].
    fn sim_duration(&mut self, x: &Number) -> f64 {
        let duration = self.positive(x, "the simulated duration");
        if duration > MAX_SIM_DURATION_S {
            let message = format!("a simulated recording lasts at most {MAX_SIM_DURATION_S} s, found {duration}");
            self.err("duration too long", x.span, message);
        }
        duration
    }

    /// `speed from metadata a < t1 <= b < t2 <= c`: thresholds ascending,
    /// labels distinct.
    fn speed_labels(&mut self, how: &SpeedAst) -> SpeedLabels {
        let SpeedAst::Metadata { first, steps } = how else { return SpeedLabels::Name };
        let mut labels = vec![first.node.clone()];
        let mut thresholds = Vec::new();
        let mut names = vec![first.clone()];
        for (t, label) in steps {
            if thresholds.last().is_some_and(|last| t.node <= *last) {
                self.err("thresholds out of order", t.span, "speed thresholds must increase from left to right");
            }
            if t.node < 0.0 {
                self.err("negative value", t.span, format!("a speed threshold must be >= 0, found {}", t.node));
            }
            thresholds.push(t.node);
            labels.push(label.node.clone());
            names.push(label.clone());
        }
        self.no_duplicate_names(&names, "speed label");
        if let Some(l) = names.iter().find(|n| n.node == "unknown") {
            self.err("reserved label", l.span, "`unknown` is the label of a recording without a metadata speed");
        }
        SpeedLabels::Metadata { labels, thresholds }
    }

    pub(super) fn columns(&mut self, cols: &[Ident], want: usize, what: &str, span: Span) -> Vec<String> {
        if cols.len() != want {
            self.err("wrong number of columns", span, format!("the {what} has {want} columns, {} given", cols.len()));
        }
        self.no_duplicate_names(cols, "column");
        cols.iter().map(|c| c.node.clone()).collect()
    }
}

/// The key under which a data item may be given only once (`None` for
/// the column clauses of `data csv`, which `csv_item` counts).
fn once_key(item: &DataItem) -> Option<&'static str> {
    Some(match item {
        DataItem::Path(_) => "path",
        DataItem::Rate(_) => "rate",
        DataItem::IncludeActive { .. } => "include",
        DataItem::ExcludeRecordings(_) => "exclude recordings",
        DataItem::ExcludeFrozen(_) => "exclude frozen",
        DataItem::ExcludeBeyond { quantity: Bound::Position, .. } => "exclude beyond position",
        DataItem::ExcludeBeyond { quantity: Bound::Speed, .. } => "exclude beyond speed",
        DataItem::ExcludeBeyond { quantity: Bound::Rate, .. } => "exclude beyond rate",
        DataItem::ExcludeImplausible(_) => "exclude",
        DataItem::Tails(_) => "tails",
        DataItem::Speed(_) => "speed",
        DataItem::Universe { .. } => "universe",
        DataItem::MissingCsv(_) => "missing",
        DataItem::Duplicates(_) => "duplicates",
        DataItem::Strict => "strict",
        DataItem::State(_) => "state",
        DataItem::Action { .. } => "action",
        DataItem::MissingValues(_) => "missing values",
        DataItem::Gaps { .. } => "gaps",
        DataItem::RequireKept(_) => "require",
        DataItem::SimRecordings(_) => "recordings",
        DataItem::SimSeed(_) => "seed",
        DataItem::SimStrength(_) => "strength",
        DataItem::SimDuration(_) => "duration",
        DataItem::Time(_)
        | DataItem::Position(_)
        | DataItem::Velocity(_)
        | DataItem::Attitude { .. }
        | DataItem::Rates(_)
        | DataItem::Predicted(_)
        | DataItem::Reference(_)
        | DataItem::Extra { .. }
        | DataItem::Extrapolated(_)
        | DataItem::Controller(_)
        | DataItem::FoldersNested
        | DataItem::ConditionsTable { .. }
        | DataItem::ConditionsName(_)
        | DataItem::ConditionsFolder(_) => return None,
    })
}

/// `exclude`, `truncate` or `keep`, as the grammar allows.
fn tail_policy(p: &Ident) -> TailPolicy {
    match p.node.as_str() {
        "exclude" => TailPolicy::Exclude,
        "truncate" => TailPolicy::Truncate,
        _ => TailPolicy::Keep,
    }
}

/// `group`, `first` or `keep`, as the grammar allows.
fn duplicate_policy(p: &Spanned<String>) -> DuplicatePolicy {
    match p.node.as_str() {
        "group" => DuplicatePolicy::Group,
        "first" => DuplicatePolicy::First,
        _ => DuplicatePolicy::Keep,
    }
}

/// `refuse`, `exclude` or `segment`, as the grammar allows.
fn cut_policy(p: &Ident) -> CutPolicy {
    match p.node.as_str() {
        "exclude" => CutPolicy::Exclude,
        "segment" => CutPolicy::Segment,
        _ => CutPolicy::Refuse,
    }
}

/// The most recordings a design may simulate.
const MAX_SIM_RECORDINGS: usize = 2_000;
/// The strongest recording-specific structure the simulator is asked for
/// (the shipped designs use 0 to 2; at 100 no recording keeps a valid start).
const MAX_SIM_STRENGTH: f64 = 10.0;
/// The longest simulated recording, in seconds.
const MAX_SIM_DURATION_S: f64 = 3_600.0;
/// The most seconds of flight (recordings x duration) a design may
/// simulate: about 1 GB of logs at 100 Hz.
const MAX_SIM_SECONDS: f64 = 20_000.0;

/// The simulator's settings as declared so far.
#[derive(Default)]
struct SimParts {
    recordings: Option<usize>,
    seed: Option<u64>,
    strength: Option<f64>,
    duration: Option<f64>,
}
