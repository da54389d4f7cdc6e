//! Syntax errors in the reader's words: pest's rule names replaced by what
//! a user of the language would call them.

use super::pairs::Rule;
use crate::design::ast::Span;
use crate::design::diagnostic::Diagnostic;

/// The rules of a clause of a `data` block.
fn data_clause(rule: &Rule) -> bool {
    matches!(
        rule,
        Rule::data_path
            | Rule::data_rate
            | Rule::include_active
            | Rule::exclude_implausible
            | Rule::duplicates
            | Rule::strict
            | Rule::state_cols
            | Rule::action_cols
            | Rule::time_col
            | Rule::position_cols
            | Rule::velocity_cols
            | Rule::attitude_cols
            | Rule::reference_cols
            | Rule::rates_cols
            | Rule::predicted_cols
            | Rule::extra_col
            | Rule::extrapolated_cols
            | Rule::controller_name
            | Rule::exclude_frozen
            | Rule::exclude_beyond
            | Rule::folders_nested
            | Rule::conditions_table
            | Rule::conditions_name
            | Rule::conditions_folder
            | Rule::missing_values
            | Rule::gaps
            | Rule::require_kept
            | Rule::tails
            | Rule::speed_labels
            | Rule::universe
            | Rule::missing_csv
            | Rule::sim_recordings
            | Rule::sim_seed
            | Rule::sim_strength
            | Rule::sim_duration
    )
}

/// Names users read in "expected ..." messages instead of rule names.
fn rule_name(rule: &Rule) -> String {
    match clause_name(rule).or_else(|| value_name(rule)) {
        Some(name) => name.to_string(),
        None => format!("{rule:?}"),
    }
}

/// The reader's name of a statement or of a clause inside one (and of the
/// end of the file).
fn clause_name(rule: &Rule) -> Option<&'static str> {
    let name = match rule {
        Rule::EOI => "end of file",
        Rule::statement
        | Rule::design
        | Rule::study
        | Rule::data
        | Rule::factor_recording
        | Rule::factor_seed
        | Rule::factor_split
        | Rule::factor_draw
        | Rule::draws
        | Rule::draws_per_seed
        | Rule::choices
        | Rule::primary_spec
        | Rule::validation
        | Rule::arm
        | Rule::model
        | Rule::train
        | Rule::endpoint
        | Rule::contrast
        | Rule::estimate
        | Rule::sensitivity
        | Rule::interaction
        | Rule::decide
        | Rule::generator
        | Rule::published => {
            "a statement (study, data, factor, validation, split, arm, model, train, endpoint, contrast, estimate, sensitivity, interaction, decide, generator, draws, choices, primary specification)"
        }
        Rule::pub_evaluation | Rule::pub_validation | Rule::pub_fit | Rule::pub_ignore | Rule::pub_leaked => {
            "a published-split clause (evaluation, validation, fit, ignore, leaked)"
        }
        Rule::rec_evaluation
        | Rule::rec_eval_list
        | Rule::rec_split_seed
        | Rule::rec_starts
        | Rule::rec_horizon
        | Rule::rec_conditions
        | Rule::rec_stratify => "a recording factor clause (evaluation, split_seed, starts, horizon, conditions, stratify)",
        Rule::batch
        | Rule::epochs
        | Rule::schedule
        | Rule::patience
        | Rule::action_noise
        | Rule::target
        | Rule::actions => {
            "a training clause (adam, batch, epochs, cosine, constant, patience, action_noise, target, actions)"
        }
        Rule::choice => "a choice (`SETTING ALTERNATIVE | ALTERNATIVE ...`)",
        Rule::combine | Rule::combine_primary | Rule::combine_every | Rule::combine_share => {
            "`in primary`, `in every specification` or `in at least P% of specifications`"
        }
        Rule::val_count | Rule::val_list | Rule::val_split => {
            "`N recordings`, `recordings \"NAME\", ...` or `split`"
        }
        r if data_clause(r) => {
            "a data clause (path, rate, include, exclude, duplicates, strict, state, action, tails, speed, universe, missing, gaps, require; time, position, velocity, attitude, reference, extra, extrapolated, controller, conditions table, conditions name, conditions folder or folders nested for `data csv`; recordings, seed, strength, duration for simulated data)"
        }
        Rule::arm_fit | Rule::arm_derived => "an arm body (`fit N windows` or `from ARM replace P% ...`)",
        Rule::est_level | Rule::est_df | Rule::est_missing => "an estimator clause (level, df, missing)",
        Rule::bootstrap | Rule::grouped | Rule::leave_one_out => {
            "a sensitivity (bootstrap, grouped, leave_one_out)"
        }
        _ => return None,
    };
    Some(name)
}

/// The reader's name of a value a clause takes: a name, a number, a kind,
/// a policy.
fn value_name(rule: &Rule) -> Option<&'static str> {
    let name = match rule {
        Rule::role_list | Rule::role_name => "a role of the split file",
        Rule::leaked_policy => "`refuse` or `drop`",
        Rule::ident | Rule::ident_list => "a name",
        Rule::string | Rule::string_inner | Rule::string_list => "a quoted string",
        Rule::int | Rule::int_list => "an integer",
        Rule::number => "a number",
        Rule::seconds => "a duration in seconds (e.g. `1.0 s`)",
        Rule::cap => "`cap <metres> m`",
        Rule::ep_models => "`model <name>` or `models <names>`",
        Rule::ep_glmm => "`glmm binomial`",
        Rule::optimizer | Rule::optimizer_kind => "an optimizer (`adam lr <rate>`)",
        Rule::target_kind => "a target (state_scaled, standardized)",
        Rule::action_scaling => "an action scaling (raw, standardized)",
        Rule::model_actions => "`actions raw` or `actions standardized`",
        Rule::generator_kind => "a generator (chacha8, numpy_legacy)",
        Rule::draws_kind => "`coupled` or `independent`",
        Rule::alternative | Rule::alt_contrast => "an alternative (a name, a number or `treated - reference`)",
        Rule::spec_value => "a choice and its alternative (`state onboard`)",
        Rule::tails_policy => "a tails policy (keep, exclude, truncate)",
        Rule::attitude_kind
        | Rule::quaternion_wxyz
        | Rule::quaternion_xyzw
        | Rule::euler_radians
        | Rule::euler_degrees => "an attitude (`quaternion wxyz`, `quaternion xyzw`, `euler radians`, `euler degrees`)",
        Rule::col_list => "a column name",
        Rule::fill_zeros => "`fill zeros`",
        Rule::pooling => "`pooled` or `per_column`",
        Rule::speed_name | Rule::speed_metadata | Rule::speed_step => {
            "`name` or `metadata LABEL < THRESHOLD <= LABEL ...`"
        }
        Rule::universe_kind => "a universe (csv, metadata)",
        Rule::sort_order => "an order (natural, bytewise)",
        Rule::missing_policy => "`allow` or `refuse`",
        Rule::dup_policy => "a duplicates policy (group, first, keep)",
        Rule::window_distance | Rule::distance_at_least | Rule::distance_band | Rule::distance_after => {
            "a distance (`at least G s from segments`, `G1 s to G2 s from segments` or `after segments`)"
        }
        Rule::mlp | Rule::baseline => "a model kind (mlp(...), persistence, constant_velocity)",
        Rule::input_kind => "an input map (world, relative)",
        Rule::role => "an endpoint role (primary, secondary)",
        Rule::df_factor_minus | Rule::df_named => {
            "a df rule (seed - 1, recording - 1, satterthwaite, kenward_roger, z)"
        }
        Rule::condition => "a condition (e.g. `optimism >= 10%`)",
        Rule::cmp => "a comparison (>=, <=, >, <)",
        Rule::seed_range | Rule::seed_list => "seeds (`100..119` or `1, 2, 3`)",
        _ => return None,
    };
    Some(name)
}

/// The word the parser stopped at: letters, digits and `_` from the error's
/// column of its line.
fn found_word(line: &str, at: pest::error::LineColLocation) -> String {
    let col = column(at);
    line.chars().skip(col.saturating_sub(1)).take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect()
}

/// A keyword the expected names list (`an input map (world, relative)`,
/// `` `cosine` ``) within two edits of `found` but not equal to it: a typo
/// such as `relativ` for `relative`.
fn did_you_mean(names: &[String], found: String) -> Option<String> {
    if found.len() < 3 {
        return None;
    }
    let mut words: Vec<String> = Vec::new();
    for n in names {
        let listed = n.split_once('(').map(|(_, r)| r.split(')').next().unwrap_or("")).unwrap_or("");
        words.extend(listed.split(", ").map(|w| w.trim().to_string()));
        words.extend(n.split('`').skip(1).step_by(2).map(|w| w.split_whitespace().next().unwrap_or("").to_string()));
    }
    words
        .into_iter()
        .filter(|w| !w.is_empty() && w.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') && *w != found)
        .map(|w| (edits(&w, &found), w))
        .filter(|(d, _)| *d <= 2)
        .min()
        .map(|(_, w)| w)
}

/// The 1-based column where an error starts.
fn column(at: pest::error::LineColLocation) -> usize {
    match at {
        pest::error::LineColLocation::Pos((_, c)) | pest::error::LineColLocation::Span((_, c), _) => c,
    }
}

/// Levenshtein distance between two short words.
fn edits(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// Where `cap` is written with another unit than metres (`cap 50 cm`),
/// the cap in metres to write instead; empty otherwise.
fn cap_unit_hint(line: &str, at: pest::error::LineColLocation) -> String {
    let col = column(at);
    let rest: String = line.chars().skip(col.saturating_sub(1)).collect();
    let words: Vec<&str> = rest.split_whitespace().collect();
    let ["cap", value, unit, ..] = words.as_slice() else { return String::new() };
    let positive = "; a cap is a positive distance in metres, as `cap 0.5 m`".to_string();
    let Some(x) = value.parse::<f64>().ok().filter(|x| *x > 0.0 && x.is_finite()) else { return positive };
    let metres = match *unit {
        "cm" => x / 100.0,
        "mm" => x / 1000.0,
        "km" => x * 1000.0,
        _ => return positive,
    };
    format!("; a cap is written in metres: `cap {metres} m` for {value} {unit}")
}

const CAP_UNIT: &str = "; a cap needs its unit, metres: `cap 2 m`";

/// What the words just before the error say the writer meant, where a
/// mistake is common and the grammar's expectation alone misleads: a cap
/// without its unit, a horizon in seconds in the recording factor, a
/// range written with a hyphen.
fn context_hint(line: &str, at: pest::error::LineColLocation) -> Option<&'static str> {
    let col = column(at);
    let before: String = line.chars().take(col.saturating_sub(1)).collect();
    let rest: String = line.chars().skip(col.saturating_sub(1)).collect();
    let words: Vec<&str> = before.split_whitespace().collect();
    let number = |w: &str| w.parse::<f64>().is_ok();
    match words.as_slice() {
        [.., "cap", v] if number(v) && !before.ends_with(v) => Some(CAP_UNIT),
        // `cap 2 model`: the unit `m` read as the start of `model`.
        [.., "cap", v, "m"] if number(v) && before.ends_with('m') && rest.starts_with(char::is_alphanumeric) => {
            Some(CAP_UNIT)
        }
        [.., "horizon", v] if number(v) && rest.starts_with(['s', 'S']) => Some(
            "; the recording factor's `horizon` counts samples (rows of the log), as `horizon 100`; an endpoint's time in seconds is its `at 1.0 s`",
        ),
        [.., "=", v] if v.chars().all(|c| c.is_ascii_digit()) && rest.starts_with('-') => {
            Some("; a range of values is written with two dots, as `1..5`")
        }
        _ => None,
    }
}

/// A pest error as a located diagnostic in the reader's words.
pub(super) fn syntax(e: pest::error::Error<Rule>) -> Diagnostic {
    let span = match e.location {
        pest::error::InputLocation::Pos(p) => Span { start: p, end: p },
        pest::error::InputLocation::Span((s, e)) => Span { start: s, end: e },
    };
    let message = match &e.variant {
        pest::error::ErrorVariant::ParsingError { positives, negatives } => {
            // Several rules often share one reader-facing name; say each once.
            let mut names: Vec<String> = Vec::new();
            for r in positives {
                let n = rule_name(r);
                if !names.contains(&n) {
                    names.push(n);
                }
            }
            let mut text = match names.len() {
                0 => "unexpected input".to_string(),
                1 => format!("expected {}", names[0]),
                n => format!("expected {}, or {}", names[..n - 1].join(", "), names[n - 1]),
            };
            if !negatives.is_empty() {
                let unexpected: Vec<String> = negatives.iter().map(rule_name).collect();
                text.push_str(&format!("; unexpected {}", unexpected.join(", ")));
            }
            match context_hint(e.line(), e.line_col.clone()) {
                Some(hint) => text.push_str(hint),
                None => {
                    if let Some(word) = did_you_mean(&names, found_word(e.line(), e.line_col.clone())) {
                        text.push_str(&format!("; did you mean `{word}`?"));
                    }
                }
            }
            if names.iter().any(|n| n == &rule_name(&Rule::cap)) {
                text.push_str(&cap_unit_hint(e.line(), e.line_col.clone()));
            }
            text
        }
        pest::error::ErrorVariant::CustomError { message } => message.clone(),
    };
    Diagnostic::new("syntax error", span, message)
}
