//! The guards beside a multiverse's verdict: a reference arm that is not
//! disjoint and its condition coverage (the primary specification's, or
//! over the draws). Computed with the combined analysis and worded once;
//! its report, banner, console line, multiverse.json and Python read them
//! from [`MultiverseAnalysis::guards`]. Each specification's own guards
//! (its margin, a fragile decision; from its level folders, early
//! stopping, a reference arm that is not disjoint and its coverage) are
//! its own [`super::SpecResult::guards`] ([`attach_unit_guards`]).

use super::{MultiverseAnalysis, ReferenceCopies};
use crate::analysis::{Guard, GuardKind};
use crate::io::md_line;

/// The guards beside a multiverse's verdict: a reference arm that is not
/// disjoint, then its condition coverage (the primary specification's, or
/// every unit's).
pub fn guards(a: &MultiverseAnalysis) -> Vec<Guard> {
    let mut out = Vec::new();
    // Beside the verdict: a reference arm that is not disjoint (the
    // primary specification's; under draw replication, over the draws).
    let primary = a.specs.iter().find(|r| r.primary).map(|r| format!("spec-{}", r.id));
    let decided: Vec<&ReferenceCopies> = a
        .notes
        .iter()
        .filter(|n| a.choices.is_empty() || Some(&n.id) == primary.as_ref())
        .filter_map(|n| n.reference_copies.as_ref())
        .collect();
    if !decided.is_empty() {
        let all = ReferenceCopies {
            fewest: decided.iter().map(|c| c.fewest).min().unwrap_or(0),
            most: decided.iter().map(|c| c.most).max().unwrap_or(0),
            levels_with: decided.iter().map(|c| c.levels_with).sum(),
            levels: if a.choices.is_empty() { a.notes.len() } else { decided[0].levels },
        };
        out.push(Guard::new(GuardKind::NotDisjoint, format!(
            "**The reference arm is not disjoint** ({}): {}; allowed only because duplicates are kept (`duplicates keep`; table: the reference arm and the training).",
            primary.as_deref().filter(|_| !a.choices.is_empty()).unwrap_or("every draw"),
            copies_text(&all)
        )));
    }
    // Beside the verdict: the reference arm's condition coverage (the
    // primary specification's, or every unit's).
    for n in a.notes.iter().filter(|n| a.choices.is_empty() || Some(&n.id) == primary.as_ref()) {
        if let Some(c) = &n.coverage {
            let who = if a.notes.len() > 1 && a.choices.is_empty() { format!("{}: ", n.id) } else { String::new() };
            out.push(Guard::new(GuardKind::Coverage, format!("{who}{}", c.sentence())));
        }
    }
    out
}

/// Adds to each specification's own guards what its level folders say
/// of it (its unit's notes): early stopping, a reference arm that is not
/// disjoint, and its condition coverage. Only where specifications are
/// declared: without choices the one row's guards are the verdict's.
pub fn attach_unit_guards(a: &mut MultiverseAnalysis) {
    if a.choices.is_empty() {
        return;
    }
    for r in a.specs.iter_mut() {
        let Some(n) = a.notes.iter().find(|n| n.id == format!("spec-{}", r.id)) else { continue };
        if let Some(w) = n.early.as_ref().and_then(|e| e.warning()) {
            r.guards.push(Guard::new(GuardKind::EarlyStopping, format!("**Early stopping**: {}.", md_line(&w))));
        }
        if let Some(c) = &n.reference_copies {
            r.guards.push(Guard::new(
                GuardKind::NotDisjoint,
                format!(
                    "**The reference arm is not disjoint**: {}; allowed only because duplicates are kept (`duplicates keep`).",
                    copies_text(c)
                ),
            ));
        }
        if let Some(c) = &n.coverage {
            r.guards.push(Guard::new(GuardKind::Coverage, c.sentence()));
        }
    }
}

/// How many reference-arm fit windows come from evaluation recordings or
/// their copies.
fn copies_text(c: &ReferenceCopies) -> String {
    let n = if c.fewest == c.most { c.most.to_string() } else { format!("{} to {}", c.fewest, c.most) };
    let draws = if c.levels > 1 { format!(" (in {} of its {} draws)", c.levels_with, c.levels) } else { String::new() };
    format!("{n} of its fit windows come from identical copies of evaluation recordings{draws}")
}
