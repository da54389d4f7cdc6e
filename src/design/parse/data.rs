//! The items of a `data` block, from their pest pairs.

use pest::iterators::Pair;

use super::pairs::{cmp, col, cols, ident, idents, int, kids, number, span_of, string, strings, Kids, Rule};
use crate::design::ast::*;
use crate::design::diagnostic::Diagnostic;

/// One item of a `data` block.
pub(super) fn data_item(p: Pair<Rule>) -> Result<DataItem, Diagnostic> {
    let rule = p.as_rule();
    let text_span = span_of(&p);
    let mut c = kids(p);
    Ok(match rule {
        Rule::data_path => DataItem::Path(string(c.next())),
        Rule::data_rate => DataItem::Rate(number(c.next())?),
        Rule::include_active => DataItem::IncludeActive {
            column: ident(c.next()),
            cmp: cmp(c.next()),
            threshold: number(c.next())?,
            min_samples: int(c.next())?,
        },
        Rule::exclude_implausible => DataItem::ExcludeImplausible(c.0.next().map(ident)),
        Rule::exclude_recordings => DataItem::ExcludeRecordings(strings(c.next())),
        Rule::exclude_frozen => DataItem::ExcludeFrozen(number(c.next())?),
        Rule::exclude_beyond => exclude_beyond(c.next())?,
        Rule::tails => DataItem::Tails(ident(c.next())),
        Rule::speed_labels => DataItem::Speed(speed_labels(c.next())?),
        Rule::universe => {
            let kind = ident(c.next());
            DataItem::Universe { kind, order: c.0.next().map(ident) }
        }
        Rule::missing_csv => DataItem::MissingCsv(ident(c.next())),
        Rule::duplicates => {
            let p = c.next();
            DataItem::Duplicates(Spanned::new(p.as_str().to_string(), span_of(&p)))
        }
        Rule::strict => DataItem::Strict,
        Rule::state_cols => DataItem::State(idents(c.next())),
        Rule::action_cols => {
            let columns = cols(c.next());
            let scale = c.0.next().map(number).transpose()?;
            DataItem::Action { columns, scale }
        }
        Rule::time_col => DataItem::Time(col(c.next())),
        Rule::position_cols => DataItem::Position(cols(c.next())),
        Rule::velocity_cols => DataItem::Velocity(cols(c.next())),
        Rule::attitude_cols => attitude(c, text_span)?,
        Rule::reference_cols => DataItem::Reference(cols(c.next())),
        Rule::rates_cols => DataItem::Rates(cols(c.next())),
        Rule::predicted_cols => DataItem::Predicted(cols(c.next())),
        Rule::extra_col => {
            let columns = cols(c.next());
            DataItem::Extra { columns, fill_zeros: c.0.next().is_some() }
        }
        Rule::extrapolated_cols => DataItem::Extrapolated(cols(c.next())),
        Rule::controller_name => DataItem::Controller(ident(c.next())),
        Rule::folders_nested => DataItem::FoldersNested,
        Rule::conditions_table => conditions_table(c),
        Rule::conditions_folder => DataItem::ConditionsFolder(ident(c.next())),
        Rule::missing_values => DataItem::MissingValues(ident(c.next())),
        Rule::gaps => {
            let over = number(c.next())?;
            DataItem::Gaps { over, policy: ident(c.next()) }
        }
        Rule::require_kept => DataItem::RequireKept(int(c.next())?),
        Rule::conditions_name => DataItem::ConditionsName(string(c.next())),
        Rule::sim_recordings => DataItem::SimRecordings(int(c.next())?),
        Rule::sim_seed => DataItem::SimSeed(int(c.next())?),
        Rule::sim_strength => DataItem::SimStrength(number(c.next())?),
        Rule::sim_duration => DataItem::SimDuration(number(c.next())?),
        other => return Err(Diagnostic::new("internal", text_span, format!("unexpected data rule {other:?}"))),
    })
}

/// `exclude beyond position L m`, `speed L m/s` or `rate L rad/s`.
fn exclude_beyond(what: Pair<Rule>) -> Result<DataItem, Diagnostic> {
    let quantity = match what.as_rule() {
        Rule::beyond_speed => crate::design::Bound::Speed,
        Rule::beyond_rate => crate::design::Bound::Rate,
        _ => crate::design::Bound::Position,
    };
    Ok(DataItem::ExcludeBeyond { quantity, limit: number(kids(what).next())? })
}

/// `speed from name`, or `speed from metadata a < t1 <= b ...`: the first
/// label, then each threshold with the label above it.
fn speed_labels(how: Pair<Rule>) -> Result<SpeedAst, Diagnostic> {
    if how.as_rule() == Rule::speed_name {
        return Ok(SpeedAst::Name);
    }
    let mut m = kids(how);
    let first = ident(m.next());
    let mut steps = Vec::new();
    for step in m.0 {
        let mut s = kids(step);
        steps.push((number(s.next())?, ident(s.next())));
    }
    Ok(SpeedAst::Metadata { first, steps })
}

/// `attitude KIND COLUMN, ... [norm within T]`, the kind named by its
/// grammar rule (`text_span`: the clause, where a missing kind is
/// reported).
fn attitude(mut c: Kids, text_span: Span) -> Result<DataItem, Diagnostic> {
    let kind = c.next();
    let inner = kind.into_inner().next();
    let kind = match inner {
        Some(k) => {
            let name = match k.as_rule() {
                Rule::quaternion_wxyz => "quaternion_wxyz",
                Rule::quaternion_xyzw => "quaternion_xyzw",
                Rule::euler_radians => "euler_radians",
                _ => "euler_degrees",
            };
            Spanned::new(name.to_string(), span_of(&k))
        }
        None => return Err(Diagnostic::new("internal", text_span, "attitude without a kind")),
    };
    let columns = cols(c.next());
    let norm_within = c.0.next().map(|n| number(kids(n).next())).transpose()?;
    Ok(DataItem::Attitude { kind, columns, norm_within })
}

/// `conditions table "FILE" [columns ROLE = COLUMN, ...]`.
fn conditions_table(mut c: Kids) -> DataItem {
    let file = string(c.next());
    let columns = match c.0.next() {
        Some(list) => kids(list)
            .0
            .map(|pair| {
                let mut m = kids(pair);
                let role = ident(m.next());
                (role, col(m.next()))
            })
            .collect(),
        None => Vec::new(),
    };
    DataItem::ConditionsTable { file, columns }
}
