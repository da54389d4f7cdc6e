//! pest parse of a `.design` source into the owned [`Ast`]. The conversion
//! happens here, once; nothing outside this file sees a `Pair<Rule>`.

use pest::iterators::Pair;
use pest::Parser;

use super::ast::*;
use super::diagnostic::Diagnostic;

mod data;
mod pairs;
mod stray;
mod syntax;
use data::data_item;
use pairs::{cmp, ident, idents, int, kids, number, span_of, string, strings, DesignParser, Kids, Rule};
use syntax::syntax;

/// Parses design text into an [`Ast`]; the error is a located diagnostic.
/// A design file is text: a control character other than a line break, a
/// carriage return or a tab (an escape sequence, a bell, a NUL) would reach
/// the study's name, the reports and the terminal as structure, so the
/// first one is refused where it stands.
fn control_character(source: &str) -> Option<Diagnostic> {
    // The bidirectional overrides and isolates (U+202A-U+202E,
    // U+2066-U+2069) reorder what a reader sees: text that shows one
    // thing and says another.
    let bidi = |c: char| matches!(c, '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}');
    let (at, c) =
        source.char_indices().find(|(_, c)| (c.is_control() && !matches!(c, '\n' | '\r' | '\t')) || bidi(*c))?;
    let what = if bidi(c) { "a bidirectional override" } else { "a control character" };
    Some(
        Diagnostic::new(
            "control character in the design",
            Span { start: at, end: at + c.len_utf8() },
            format!("U+{:04X} is {what}, which a design file may not hold", c as u32),
        )
        .with_help("a design is plain text: delete the character (an editor may show it as ^[ or as nothing)"),
    )
}

pub fn parse(source: &str) -> Result<Ast, Vec<Diagnostic>> {
    if let Some(d) = control_character(source) {
        return Err(vec![d]);
    }
    let mut pairs = DesignParser::parse(Rule::design, source)
        .map_err(|e| vec![stray::stray_character(source, stray::offset(&e)).unwrap_or_else(|| syntax(e))])?;
    let design = pairs.next().expect("the design rule always yields one pair");
    let mut statements = Vec::new();
    let mut errors = Vec::new();
    for pair in design.into_inner() {
        if pair.as_rule() == Rule::EOI {
            continue;
        }
        let span = span_of(&pair);
        match statement(pair) {
            Ok(node) => statements.push(Spanned::new(node, span)),
            Err(d) => errors.push(d),
        }
    }
    if errors.is_empty() {
        Ok(Ast { statements })
    } else {
        Err(errors)
    }
}

fn statement(pair: Pair<Rule>) -> Result<Statement, Diagnostic> {
    let rule = pair.as_rule();
    let mut k = kids(pair.clone());
    Ok(match rule {
        Rule::study => Statement::Study(string(k.next())),
        Rule::data => {
            let source = ident(k.next());
            Statement::Data(DataBlock { source, items: spanned_items(k, data_item)? })
        }
        Rule::factor_recording => Statement::FactorRecording(spanned_items(k, recording_item)?),
        Rule::factor_seed => Statement::FactorSeed(seed_spec(k.next())?),
        Rule::factor_split => Statement::FactorSplit(seed_spec(k.next())?),
        Rule::factor_draw => Statement::FactorDraw(seed_spec(k.next())?),
        Rule::draws => Statement::Draws(ident(k.next())),
        Rule::draws_per_seed => Statement::DrawsPerSeed,
        Rule::choices => Statement::Choices(spanned_items(k, choice)?),
        Rule::primary_spec => Statement::PrimarySpec(
            k.0.map(|p| {
                let mut c = kids(p);
                let setting = ident(c.next());
                alternative(c.next()).map(|a| (setting, a))
            })
            .collect::<Result<_, _>>()?,
        ),
        Rule::validation => {
            let windows = int(k.next())?;
            let from = k.next();
            let recordings = match from.as_rule() {
                Rule::val_count => ValRecordings::Count(int(kids(from).next())?),
                Rule::val_split => ValRecordings::Split(span_of(&from)),
                _ => ValRecordings::List(strings(kids(from).next())),
            };
            Statement::Validation { windows, recordings, seed: int(k.next())? }
        }
        Rule::generator => Statement::Generator(ident(k.next())),
        Rule::published => {
            let first = k.next();
            let folders = first.as_rule() == Rule::pub_folders;
            let file = if folders { Spanned::new("folders".to_string(), span_of(&first)) } else { string(first) };
            Statement::Published { file, folders, items: spanned_items(k, published_item)? }
        }
        Rule::arm => Statement::Arm { name: ident(k.next()), body: arm_body(k.next())? },
        Rule::model => Statement::Model { name: ident(k.next()), kind: model_kind(k.next())? },
        Rule::train => Statement::Train(spanned_items(k, train_item)?),
        Rule::endpoint => Statement::Endpoint(endpoint(k)?),
        Rule::contrast => Statement::Contrast { treated: ident(k.next()), reference: ident(k.next()) },
        Rule::interaction => Statement::Interaction { left: ident(k.next()), right: ident(k.next()) },
        Rule::estimate => {
            let kind = ident(k.next());
            Statement::Estimate { kind, items: spanned_items(k, estimate_item)? }
        }
        Rule::sensitivity => Statement::Sensitivity(spanned_items(k, sensitivity_item)?),
        Rule::decide => {
            let name = ident(k.next());
            let on = if k.peek_rule() == Some(Rule::decide_on) { Some(ident(kids(k.next()).next())) } else { None };
            let mut conditions = Vec::new();
            let mut combine = None;
            for p in k.0 {
                let span = span_of(&p);
                if p.as_rule() == Rule::combine {
                    let inner = kids(p).next();
                    let node = match inner.as_rule() {
                        Rule::combine_primary => CombineAst::Primary,
                        Rule::combine_every => CombineAst::Every,
                        _ => CombineAst::AtLeast(number(kids(inner).next())?),
                    };
                    combine = Some(Spanned::new(node, span));
                } else {
                    conditions.push(Spanned::new(condition(p)?, span));
                }
            }
            Statement::Decide { name, on, conditions, combine }
        }
        other => unreachable!("statement rule {other:?} is not a statement"),
    })
}

fn published_item(p: Pair<Rule>) -> Result<PublishedItem, Diagnostic> {
    let rule = p.as_rule();
    let mut c = kids(p);
    let roles = |list: Pair<Rule>| -> Vec<Spanned<String>> {
        list.into_inner()
            .map(|name| {
                let inner = name.into_inner().next().expect("grammar guarantees a role name");
                if inner.as_rule() == Rule::string {
                    string(inner)
                } else {
                    ident(inner)
                }
            })
            .collect()
    };
    Ok(match rule {
        Rule::pub_evaluation => PublishedItem::Evaluation(roles(c.next())),
        Rule::pub_validation => PublishedItem::Validation(roles(c.next())),
        Rule::pub_fit => PublishedItem::Fit(roles(c.next())),
        Rule::pub_ignore => PublishedItem::Ignore(roles(c.next())),
        _ => PublishedItem::Leaked(ident(c.next())),
    })
}

/// The remaining children of a block, each converted by `item` and kept
/// with its span.
fn spanned_items<T>(
    k: Kids<'_>,
    item: impl Fn(Pair<Rule>) -> Result<T, Diagnostic>,
) -> Result<Vec<Spanned<T>>, Diagnostic> {
    k.0.map(|p| {
        let span = span_of(&p);
        item(p).map(|node| Spanned::new(node, span))
    })
    .collect()
}

fn recording_item(p: Pair<Rule>) -> Result<RecordingItem, Diagnostic> {
    let rule = p.as_rule();
    let mut c = kids(p);
    Ok(match rule {
        Rule::rec_evaluation => RecordingItem::Evaluation(int(c.next())?),
        Rule::rec_eval_list => RecordingItem::EvaluationList(strings(c.next())),
        Rule::rec_split_seed => RecordingItem::SplitSeed(int(c.next())?),
        Rule::rec_starts => {
            let n = int(c.next())?;
            let within = if c.peek_rule().is_some() { Some(number(c.next())?) } else { None };
            RecordingItem::Starts(n, within)
        }
        Rule::rec_horizon => RecordingItem::Horizon(int(c.next())?),
        Rule::rec_stratify => {
            let conditions = idents(c.next());
            let keep = if c.peek_rule() == Some(Rule::int) { Some(int(c.next())?) } else { None };
            RecordingItem::Stratify { conditions, keep }
        }
        _ => RecordingItem::Conditions(idents(c.next())),
    })
}

fn seed_spec(spec: Pair<Rule>) -> Result<SeedSpec, Diagnostic> {
    let rule = spec.as_rule();
    let mut c = kids(spec);
    if rule == Rule::seed_range {
        let first = int(c.next())?;
        let last = int(c.next())?;
        Ok(SeedSpec::Range { first, last })
    } else {
        Ok(SeedSpec::List(c.0.map(int).collect::<Result<_, _>>()?))
    }
}

fn arm_body(body: Pair<Rule>) -> Result<ArmBody, Diagnostic> {
    let rule = body.as_rule();
    let mut c = kids(body);
    if rule == Rule::arm_fit {
        let windows = int(c.next())?;
        let seed = if c.peek_rule() == Some(Rule::int) { Some(int(c.next())?) } else { None };
        let hold_out = match c.0.next() {
            Some(h) => idents(kids(h).next()),
            None => Vec::new(),
        };
        return Ok(ArmBody::Fit { windows, seed, hold_out });
    }
    let from = ident(c.next());
    let mut percents = Vec::new();
    while c.peek_rule() == Some(Rule::dose) {
        percents.push(number(kids(c.next()).next())?);
    }
    let exclude_starts = c.peek_rule() == Some(Rule::exclude_starts);
    if exclude_starts {
        c.next();
    }
    let distance = if c.peek_rule() == Some(Rule::window_distance) {
        let clause = c.next();
        let span = span_of(&clause);
        let form = kids(clause).next();
        let band = form.as_rule() == Rule::distance_band;
        if form.as_rule() == Rule::distance_after {
            Some(DistanceClause { least: Vec::new(), most: None, after: true, span })
        } else {
            let mut numbers = kids(form);
            let mut least = vec![number(numbers.next())?];
            let mut most = None;
            while numbers.peek_rule().is_some() {
                let n = number(numbers.next())?;
                if band {
                    most = Some(n);
                } else {
                    least.push(n);
                }
            }
            Some(DistanceClause { least, most, after: false, span })
        }
    } else {
        None
    };
    let seed = int(c.next())?;
    Ok(ArmBody::Derived { from, percents, exclude_starts, distance, seed })
}

fn model_kind(kind: Pair<Rule>) -> Result<ModelSyntax, Diagnostic> {
    if kind.as_rule() == Rule::external {
        let mut c = kids(kind);
        let inputs = c.next();
        let inputs = Spanned::new(inputs.as_str().to_string(), span_of(&inputs));
        let (mut actions, mut history) = (None, None);
        for p in c.0 {
            match p.as_rule() {
                Rule::model_actions => actions = Some(ident(kids(p).next())),
                _ => history = Some(int(kids(p).next())?),
            }
        }
        return Ok(ModelSyntax::External { inputs, actions, history });
    }
    if kind.as_rule() == Rule::linear {
        let mut c = kids(kind);
        let inputs = c.next();
        let inputs = Spanned::new(inputs.as_str().to_string(), span_of(&inputs));
        let (mut actions, mut ridge) = (None, None);
        for p in c.0 {
            match p.as_rule() {
                Rule::model_actions => actions = Some(ident(kids(p).next())),
                _ => {
                    let value = kids(p).next();
                    if value.as_rule() == Rule::number {
                        ridge = Some(number(value)?);
                    }
                }
            }
        }
        return Ok(ModelSyntax::Linear { inputs, actions, ridge });
    }
    if kind.as_rule() != Rule::mlp {
        return Ok(ModelSyntax::Baseline(Spanned::new(kind.as_str().to_string(), span_of(&kind))));
    }
    let mut c = kids(kind);
    let widths = c.next().into_inner().map(int).collect::<Result<_, _>>()?;
    let inputs = c.next();
    let (mut actions, mut restore) = (None, None);
    for p in c.0 {
        let word = kids(p.clone()).next();
        match p.as_rule() {
            Rule::restore => restore = Some(Spanned::new(word.as_str().to_string(), span_of(&word))),
            _ => actions = Some(ident(word)),
        }
    }
    let inputs = Spanned::new(inputs.as_str().to_string(), span_of(&inputs));
    Ok(ModelSyntax::Mlp { widths, inputs, actions, restore })
}

fn train_item(p: Pair<Rule>) -> Result<TrainItem, Diagnostic> {
    let span = span_of(&p);
    let rule = p.as_rule();
    let text = p.as_str().to_string();
    let mut c = kids(p);
    Ok(match rule {
        Rule::optimizer => TrainItem::Optimizer { kind: ident(c.next()), lr: number(c.next())? },
        Rule::batch => TrainItem::Batch(int(c.next())?),
        Rule::epochs => TrainItem::Epochs(int(c.next())?),
        Rule::patience => TrainItem::Patience(int(c.next())?),
        Rule::action_noise => TrainItem::ActionNoise(number(c.next())?),
        Rule::target => TrainItem::Target(ident(c.next())),
        Rule::actions => TrainItem::Actions(ident(c.next())),
        _ => TrainItem::Schedule(Spanned::new(text, span)),
    })
}

fn endpoint(mut k: Kids<'_>) -> Result<EndpointStmt, Diagnostic> {
    let role = ident(k.next());
    let metric = ident(k.next());
    let horizons = k
        .next()
        .into_inner()
        .map(|s| number(s.into_inner().next().expect("seconds has a number")))
        .collect::<Result<_, _>>()?;
    let cap = if k.peek_rule() == Some(Rule::cap) {
        Some(number(k.next().into_inner().next().expect("cap has a number"))?)
    } else {
        None
    };
    let models = idents(k.next().into_inner().next().expect("models has a list"));
    let glmm = (k.peek_rule() == Some(Rule::ep_glmm)).then(|| ident(kids(k.next()).next()));
    Ok(EndpointStmt { role, metric, horizons, cap, models, glmm })
}

fn estimate_item(p: Pair<Rule>) -> Result<EstimateItem, Diagnostic> {
    if p.as_rule() == Rule::est_level {
        return Ok(EstimateItem::Level(number(kids(p).next())?));
    }
    if p.as_rule() == Rule::est_missing {
        return Ok(EstimateItem::Missing(ident(kids(p).next())));
    }
    let rule_pair = kids(p).next();
    if rule_pair.as_rule() == Rule::df_factor_minus {
        let mut c = kids(rule_pair);
        Ok(EstimateItem::DfFactorMinus { factor: ident(c.next()), minus: int(c.next())? })
    } else {
        Ok(EstimateItem::DfNamed(ident(rule_pair)))
    }
}

fn sensitivity_item(p: Pair<Rule>) -> Result<SensitivityItem, Diagnostic> {
    let rule = p.as_rule();
    let mut c = kids(p);
    Ok(match rule {
        Rule::bootstrap => {
            SensitivityItem::Bootstrap { kind: ident(c.next()), replicates: int(c.next())?, seed: int(c.next())? }
        }
        Rule::grouped => SensitivityItem::Grouped,
        _ => SensitivityItem::LeaveOneOut(idents(c.next())),
    })
}

fn condition(p: Pair<Rule>) -> Result<ConditionAst, Diagnostic> {
    let mut c = kids(p);
    let quantity = ident(c.next());
    let op = cmp(c.next());
    let value = number(c.next())?;
    let percent = c.0.next().is_some();
    Ok(ConditionAst { quantity, cmp: op, value, percent })
}

fn choice(p: Pair<Rule>) -> Result<ChoiceAst, Diagnostic> {
    let mut c = kids(p);
    let setting = ident(c.next());
    Ok(ChoiceAst { setting, alternatives: c.0.map(alternative).collect::<Result<_, _>>()? })
}

/// A choice's alternative: a number keeps its text for labels, and must be
/// finite, as every number of the language.
fn alternative(p: Pair<Rule>) -> Result<Spanned<Alternative>, Diagnostic> {
    let span = span_of(&p);
    let inner = p.into_inner().next().expect("grammar guarantees an alternative");
    let text = inner.as_str().to_string();
    let node = if inner.as_rule() == Rule::alt_contrast {
        let names: Vec<String> = inner.into_inner().map(|p| p.as_str().to_string()).collect();
        Alternative::Name(names.join(" - "))
    } else if inner.as_rule() == Rule::number {
        let v = number(inner)?;
        Alternative::Number(v.node, text)
    } else {
        Alternative::Name(text)
    };
    Ok(Spanned::new(node, span))
}
