//! `data csv`: the columns of any CSV logs, declared clause by clause, and
//! the [`LogFormat`] they make.

use std::collections::BTreeMap;

use super::Validator;
use crate::design::ast::*;
use crate::design::*;

/// The column clauses of a `data csv` block as declared so far.
#[derive(Default)]
pub(super) struct CsvParts {
    time: Option<Ident>,
    position: Option<(Vec<Ident>, Span)>,
    velocity: Option<(Vec<Ident>, Span)>,
    attitude: Option<(Ident, Vec<Ident>, Span)>,
    /// `norm within T` after the attitude's columns.
    norm_within: Option<Number>,
    rates: Option<(Vec<Ident>, Span)>,
    predicted: Option<Vec<Ident>>,
    reference: Option<(Vec<Ident>, Span)>,
    extra: Option<(Vec<Ident>, bool)>,
    extrapolated: Option<Vec<Ident>>,
    controller: Option<Ident>,
    /// `folders nested`.
    nested: bool,
    conditions_table: Option<Spanned<String>>,
    conditions_name: Option<Spanned<String>>,
    /// `columns ROLE = COLUMN, ...` after the conditions table.
    conditions_columns: BTreeMap<String, String>,
    /// `conditions folder trajectory|speed`, and where.
    conditions_folder: Option<(Condition, Span)>,
    /// `action ... scale N`: the scale as written.
    pub(super) scale: Option<Number>,
    /// Every column declared so far, with the clause that declared it.
    declared: BTreeMap<String, &'static str>,
}

impl Validator {
    /// Records a column clause of `data csv` (and an action scale) in
    /// `csv`; returns the clause's keyword when it is one only `data csv`
    /// has, `None` for every other item (left to `data_item`).
    pub(super) fn csv_item(
        &mut self,
        item: &Spanned<DataItem>,
        seen: &mut BTreeMap<&'static str, Span>,
        csv: &mut CsvParts,
    ) -> Option<&'static str> {
        let span = item.span;
        // One column is one quantity: declared as two (a position and a
        // reference, an action and an extra), its values would be read as
        // both, silently.
        let (what, columns) = declared_columns(&item.node);
        self.declare_columns(what, &columns, csv);
        if let DataItem::Action { scale, .. } = &item.node {
            csv.scale = scale.clone();
            return None;
        }
        let key = column_clause(item, csv).or_else(|| self.layout_clause(&item.node, csv))?;
        self.once(seen, key, span);
        Some(key)
    }

    /// A clause of `data csv` on the folder's layout (nested folders, the
    /// conditions table, name pattern or folder) recorded in `csv`: its
    /// keyword, or `None` for any other item.
    fn layout_clause(&mut self, item: &DataItem, csv: &mut CsvParts) -> Option<&'static str> {
        Some(match item {
            DataItem::FoldersNested => {
                csv.nested = true;
                "folders nested"
            }
            DataItem::ConditionsTable { file, columns } => {
                self.conditions_table(file, columns, csv);
                "conditions table"
            }
            DataItem::ConditionsName(p) => {
                self.conditions_name(p, csv);
                "conditions name"
            }
            DataItem::ConditionsFolder(c) => {
                let condition = if c.node == "speed" { Condition::Speed } else { Condition::Trajectory };
                csv.conditions_folder = Some((condition, c.span));
                "conditions folder"
            }
            _ => return None,
        })
    }

    /// Records each column of a clause as declared by it (`what`: "a
    /// position", ...); one declared by an earlier clause is refused.
    fn declare_columns(&mut self, what: &'static str, columns: &[&Ident], csv: &mut CsvParts) {
        for c in columns {
            match csv.declared.get(&c.node) {
                Some(first) => self.err_help(
                    "column declared twice",
                    c.span,
                    format!("`{}` is declared as {first} and as {what}", c.node),
                    "a column holds one quantity: declare it once, in the clause it belongs to",
                ),
                None => {
                    csv.declared.insert(c.node.clone(), what);
                }
            }
        }
    }

    /// `conditions table "FILE" columns ROLE = COLUMN, ...`: each role
    /// mapped once, a file (a path from the data folder, or absolute), no
    /// name pattern too.
    fn conditions_table(&mut self, t: &Spanned<String>, columns: &[(Ident, Ident)], csv: &mut CsvParts) {
        for (role, column) in columns {
            if csv.conditions_columns.insert(role.node.clone(), column.node.clone()).is_some() {
                self.err_help(
                    "table column mapped twice",
                    role.span,
                    format!("`{}` is given a column twice", role.node),
                    "map each of recording, trajectory and speed at most once",
                );
            }
        }
        if t.node.trim().is_empty() {
            self.err_help(
                "empty conditions table",
                t.span,
                "no file named",
                "give a CSV file: a name in the data folder (`conditions table \"conditions.csv\"`), or a path from it (`\"../conditions.csv\"`) or an absolute one",
            );
        }
        if let Some(name) = &csv.conditions_name {
            self.conditions_twice(t.span, name.span);
        }
        csv.conditions_table = Some(t.clone());
    }

    /// `conditions name "PATTERN"`: a pattern that parses, no conditions
    /// table too.
    fn conditions_name(&mut self, p: &Spanned<String>, csv: &mut CsvParts) {
        if let Err(e) = crate::design::NamePattern::parse(&p.node) {
            self.err_help(
                "bad conditions pattern",
                p.span,
                e,
                "e.g. `conditions name \"{*}-{trajectory}-{speed}-{rep}\"`",
            );
        }
        if let Some(table) = &csv.conditions_table {
            self.conditions_twice(p.span, table.span);
        }
        csv.conditions_name = Some(p.clone());
    }

    /// A data block with both a conditions table and a name pattern.
    fn conditions_twice(&mut self, span: Span, first: Span) {
        let _ = first;
        self.err_help(
            "conditions declared twice",
            span,
            "the conditions come from a table or from the file names, not both",
            "keep `conditions table` or `conditions name`",
        );
    }

    /// The format a `data csv` block declares, or `None` (with errors) when
    /// a required clause is missing or a clause has the wrong number of
    /// columns. Sets the data's state columns to the slots' names (the
    /// quaternion's are `` when it comes from Euler angles): position,
    /// velocity and quaternion when declared, body rates, predicted
    /// columns, then the exogenous reference and extra columns.
    pub(super) fn csv_format(
        &mut self,
        block: &DataBlock,
        seen: &BTreeMap<&'static str, Span>,
        csv: &mut CsvParts,
        spec: &mut DataSpec,
    ) -> Option<LogFormat> {
        let at = block.source.span;
        self.csv_required(at, seen, csv);
        let position = self.three_columns(at, &csv.position, "position", "position x, y, z");
        let velocity = self.three_columns(at, &csv.velocity, "velocity", "");
        let reference = self.three_columns(at, &csv.reference, "reference", "");
        let rates = self.three_columns(at, &csv.rates, "body rates", "");
        let (quaternion, euler) = self.csv_attitude(csv);
        let quaternion_tolerance = self.quaternion_tolerance(csv, euler.is_some());
        self.conditions_folder(csv);
        let position = position?;
        let attitude = csv.attitude.is_some();
        if attitude && quaternion.is_none() && euler.is_none() {
            return None;
        }
        if position.len() != 3
            || velocity.as_ref().is_some_and(|v| v.len() != 3)
            || quaternion.as_ref().is_some_and(|q| q.len() != 4)
        {
            return None;
        }
        let has_velocity = velocity.is_some();
        let mut state: Vec<Option<String>> =
            position.into_iter().chain(velocity.into_iter().flatten()).map(Some).collect();
        match &quaternion {
            Some(q) => state.extend(q.iter().cloned().map(Some)),
            None if attitude => state.extend([None, None, None, None]),
            None => {}
        }
        if rates.as_ref().is_some_and(|r| r.len() != 3) || reference.as_ref().is_some_and(|r| r.len() != 3) {
            return None;
        }
        state.extend(rates.into_iter().flatten().map(Some));
        state.extend(csv.predicted.iter().flatten().map(|c| Some(c.node.clone())));
        let predicted = state.len();
        let has_reference = reference.is_some();
        state.extend(reference.into_iter().flatten().map(Some));
        let extra_start = state.len();
        let extras: &[Ident] = csv.extra.as_ref().map_or(&[], |(c, _)| c.as_slice());
        state.extend(extras.iter().map(|c| Some(c.node.clone())));
        let fill_zeros = match &csv.extra {
            Some((_, true)) => (extra_start..state.len()).collect(),
            _ => Vec::new(),
        };
        spec.state_columns = state.iter().map(|c| c.clone().unwrap_or_default()).collect();
        spec.state_preset = None;
        let action_scale = csv.scale.as_ref().map(|s| s.node).filter(|s| *s > 0.0 && s.is_finite())?;
        Some(LogFormat {
            nanobench_header: false,
            time: csv.time.as_ref().map(|t| t.node.clone()),
            state,
            velocity: has_velocity,
            attitude,
            euler,
            quaternion_tolerance,
            predicted,
            reference: has_reference,
            fill_zeros,
            actions: spec.action_columns.clone(),
            action_scale,
            extrapolated: csv.extrapolated.iter().flatten().map(|c| c.node.clone()).collect(),
            controller: csv.controller.as_ref().map(|c| c.node.clone()),
            nested_folders: csv.nested,
            conditions_table: csv.conditions_table.as_ref().map(|t| t.node.clone()),
            conditions_name: csv.conditions_name.as_ref().map(|t| t.node.clone()),
            conditions_columns: std::mem::take(&mut csv.conditions_columns),
            conditions_folder: csv.conditions_folder.map(|(c, _)| c),
        })
    }

    /// The clauses every `data csv` block needs (`rate`, `include
    /// active(...)`, `action ... scale`), and no `state` list.
    fn csv_required(&mut self, at: Span, seen: &BTreeMap<&'static str, Span>, csv: &CsvParts) {
        if let Some(span) = seen.get("state") {
            self.err_help(
                "`state` in `data csv`",
                *span,
                "`data csv` declares its state by meaning, not as a list of columns",
                "declare `position` (and `velocity`, `attitude`, `rates`, `predicted`, `reference`, `extra` if the logs have them)",
            );
        }
        if !seen.contains_key("rate") {
            self.csv_missing(at, "rate", "rate 100 Hz");
        }
        // Without it the reader fell back to NanoBench's motor column and
        // ended in "0 usable deployment units remain".
        if !seen.contains_key("include") {
            self.csv_missing(
                at,
                "include active(...)",
                "include active(m1 > 1000) >= 200 samples: the rows in flight, by an action column",
            );
        }
        if !seen.contains_key("action") {
            self.csv_missing(at, "action", "action m1, m2, m3, m4 scale 2500");
        } else if csv.scale.is_none() {
            self.csv_missing(
                at,
                "action ... scale",
                "action m1, m2, m3, m4 scale 2500 (each action is value / scale, clipped to [0, 1])",
            );
        }
    }

    /// A clause `data csv` needs and the block lacks, with an example.
    fn csv_missing(&mut self, at: Span, what: &str, example: &str) {
        self.err_help("incomplete csv data", at, format!("`data csv` needs `{what}`"), format!("e.g. `{example}`"));
    }

    /// A clause of three columns (a position, velocity, reference or body
    /// rates) as declared; when absent, `None`, missing if `example` is
    /// given (the clause is required).
    fn three_columns(
        &mut self,
        at: Span,
        part: &Option<(Vec<Ident>, Span)>,
        what: &str,
        example: &str,
    ) -> Option<Vec<String>> {
        match part {
            Some((cols, span)) => Some(self.columns(cols, 3, what, *span)),
            None => {
                if !example.is_empty() {
                    self.csv_missing(at, what, example);
                }
                None
            }
        }
    }

    /// The attitude's columns: a quaternion (stored scalar first) or Euler
    /// angles, neither when none is declared.
    fn csv_attitude(&mut self, csv: &CsvParts) -> (Option<Vec<String>>, Option<Euler>) {
        match &csv.attitude {
            None => (None, None),
            Some((kind, cols, span)) => match kind.node.as_str() {
                "quaternion_wxyz" => (Some(self.columns(cols, 4, "quaternion", *span)), None),
                "quaternion_xyzw" => {
                    let c = self.columns(cols, 4, "quaternion", *span);
                    // Stored scalar first, as the model reads it.
                    (c.get(3).map(|w| vec![w.clone(), c[0].clone(), c[1].clone(), c[2].clone()]), None)
                }
                other => {
                    let columns = self.columns(cols, 3, "Euler attitude (roll, pitch, yaw)", *span);
                    (None, Some(Euler { columns, degrees: other == "euler_degrees" }))
                }
            },
        }
    }

    /// `norm within T`: a quaternion's tolerance in (0, 0.5], refused on
    /// Euler angles.
    fn quaternion_tolerance(&mut self, csv: &CsvParts, euler: bool) -> Option<f64> {
        match &csv.norm_within {
            Some(t) if euler => {
                self.err_help(
                    "norm tolerance on Euler angles",
                    t.span,
                    "`norm within` applies to a quaternion's length; Euler angles have none",
                    "remove `norm within`, or declare the quaternion's columns (`attitude quaternion wxyz ...`)",
                );
                None
            }
            Some(t) if !(t.node > 0.0 && t.node <= 0.5) => {
                self.err_help(
                    "bad norm tolerance",
                    t.span,
                    format!("`norm within {}`: a quaternion's length must be within (0, 0.5] of 1", t.node),
                    "real logs are off by about 0.01 to 0.05, e.g. `norm within 0.05`",
                );
                None
            }
            Some(t) => Some(t.node),
            None => None,
        }
    }

    /// `conditions folder ...`: only with `folders nested`, and a condition
    /// the name pattern or the conditions table does not give too.
    fn conditions_folder(&mut self, csv: &CsvParts) {
        if let (Some((c, span)), false) = (&csv.conditions_folder, csv.nested) {
            self.err_help(
                "conditions folder without folders",
                *span,
                format!("`conditions folder {}` takes each recording's {} from the folder it sits in, and the data block reads only the data folder itself", c.name(), c.name()),
                "add `folders nested` to the data block",
            );
        }
        if let Some((c, span)) = &csv.conditions_folder {
            let by_pattern = csv
                .conditions_name
                .as_ref()
                .and_then(|p| crate::design::NamePattern::parse(&p.node).ok())
                .is_some_and(|p| p.gives(*c));
            let by_table = csv.conditions_columns.contains_key(c.name());
            if by_pattern || by_table {
                self.err_help(
                    "condition given twice",
                    *span,
                    format!(
                        "the {} comes from the folder here and from the {} too",
                        c.name(),
                        if by_pattern { "file-name pattern" } else { "conditions table" }
                    ),
                    format!("take the {} from one of them", c.name()),
                );
            }
        }
    }

    /// Refuses what needs a velocity or an attitude the data do not
    /// declare: the `constant_velocity` baseline, and endpoints on the
    /// velocity or attitude RMSE.
    pub(super) fn undeclared_state(&mut self, slots: &Slots, models: &[(Model, Span)], endpoints: &[(Endpoint, Span)]) {
        if !slots.velocity {
            for (m, span) in models.iter().filter(|(m, _)| m.kind == crate::design::ModelKind::ConstantVelocity) {
                self.err_help(
                    "constant velocity without a velocity",
                    *span,
                    format!("model `{}` advances the position by the velocity, and the data declare none", m.name),
                    "declare `velocity vx, vy, vz` in the data block, or use `persistence`",
                );
            }
        }
        for (e, span) in endpoints {
            let missing = match e.metric {
                Metric::VelocityRmse if !slots.velocity => ("a velocity", "velocity"),
                Metric::AttitudeRmse if !slots.attitude => ("an attitude", "attitude"),
                _ => continue,
            };
            self.err_help(
                "endpoint on an undeclared state",
                *span,
                format!("`{}` needs {}, and the data declare none", e.metric.name(), missing.0),
                format!("declare `{}` in the data block, or use `fa_position_rmse`", missing.1),
            );
        }
    }
}

/// The columns a clause declares, with what it declares them as ("a
/// position", ...); none for an item that declares no column.
fn declared_columns(item: &DataItem) -> (&'static str, Vec<&Ident>) {
    match item {
        DataItem::Action { columns, .. } => ("an action", columns.iter().collect()),
        DataItem::Time(c) => ("the time", vec![c]),
        DataItem::Position(c) => ("a position", c.iter().collect()),
        DataItem::Velocity(c) => ("a velocity", c.iter().collect()),
        DataItem::Attitude { columns, .. } => ("an attitude", columns.iter().collect()),
        DataItem::Reference(c) => ("a reference", c.iter().collect()),
        DataItem::Rates(c) => ("a body rate", c.iter().collect()),
        DataItem::Predicted(c) => ("a predicted column", c.iter().collect()),
        DataItem::Extra { columns, .. } => ("an extra", columns.iter().collect()),
        _ => ("", Vec::new()),
    }
}

/// A column clause of `data csv` (time, position, velocity, attitude,
/// reference, rates, predicted, extra, extrapolated, controller) recorded
/// in `csv`: its keyword, or `None` for any other item.
fn column_clause(item: &Spanned<DataItem>, csv: &mut CsvParts) -> Option<&'static str> {
    let span = item.span;
    Some(match &item.node {
        DataItem::Time(c) => {
            csv.time = Some(c.clone());
            "time"
        }
        DataItem::Position(c) => {
            csv.position = Some((c.clone(), span));
            "position"
        }
        DataItem::Velocity(c) => {
            csv.velocity = Some((c.clone(), span));
            "velocity"
        }
        DataItem::Attitude { kind, columns, norm_within } => {
            csv.attitude = Some((kind.clone(), columns.clone(), span));
            csv.norm_within = norm_within.clone();
            "attitude"
        }
        DataItem::Reference(c) => {
            csv.reference = Some((c.clone(), span));
            "reference"
        }
        DataItem::Rates(c) => {
            csv.rates = Some((c.clone(), span));
            "rates"
        }
        DataItem::Predicted(c) => {
            csv.predicted = Some(c.clone());
            "predicted"
        }
        DataItem::Extra { columns, fill_zeros } => {
            csv.extra = Some((columns.clone(), *fill_zeros));
            "extra"
        }
        DataItem::Extrapolated(c) => {
            csv.extrapolated = Some(c.clone());
            "extrapolated"
        }
        DataItem::Controller(c) => {
            csv.controller = Some(c.clone());
            "controller"
        }
        _ => return None,
    })
}
