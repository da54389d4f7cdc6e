//! The paragraphs beside a multiverse's verdict, as its report, its
//! banner, the console and Python give them.

use crate::analysis::multiverse::MultiverseAnalysis;

/// The paragraphs beside a multiverse's verdict: a reference arm that is
/// not disjoint and its condition coverage (the primary specification's,
/// or over the draws), then each specification's margin where it has one.
pub(in crate::report) fn guards(a: &MultiverseAnalysis) -> Vec<String> {
    let mut out = Vec::new();
    // Beside the verdict: a reference arm that is not disjoint (the
    // primary specification's; under draw replication, over the draws).
    let primary = a.specs.iter().find(|r| r.primary).map(|r| format!("spec-{}", r.id));
    let decided: Vec<&crate::analysis::multiverse::ReferenceCopies> = a
        .notes
        .iter()
        .filter(|n| a.choices.is_empty() || Some(&n.id) == primary.as_ref())
        .filter_map(|n| n.reference_copies.as_ref())
        .collect();
    if !decided.is_empty() {
        let all = crate::analysis::multiverse::ReferenceCopies {
            fewest: decided.iter().map(|c| c.fewest).min().unwrap_or(0),
            most: decided.iter().map(|c| c.most).max().unwrap_or(0),
            levels_with: decided.iter().map(|c| c.levels_with).sum(),
            levels: if a.choices.is_empty() { a.notes.len() } else { decided[0].levels },
        };
        out.push(format!(
            "**The reference arm is not disjoint** ({}): {}; allowed only because the design declares `duplicates keep` (table: the reference arm and the training).",
            primary.as_deref().filter(|_| !a.choices.is_empty()).unwrap_or("every draw"),
            copies_text(&all)
        ));
    }
    // Beside the verdict: the reference arm's condition coverage (the
    // primary specification's, or every unit's).
    for n in a.notes.iter().filter(|n| a.choices.is_empty() || Some(&n.id) == primary.as_ref()) {
        if let Some(c) = &n.coverage {
            let who = if a.notes.len() > 1 && a.choices.is_empty() { format!("{}: ", n.id) } else { String::new() };
            out.push(format!("{who}{}", super::super::coverage::note_sentence(c)));
        }
    }
    out
}

/// How many reference-arm fit windows come from evaluation recordings or
/// their copies.
fn copies_text(c: &crate::analysis::multiverse::ReferenceCopies) -> String {
    let n = if c.fewest == c.most { c.most.to_string() } else { format!("{} to {}", c.fewest, c.most) };
    let draws = if c.levels > 1 { format!(" (in {} of its {} draws)", c.levels_with, c.levels) } else { String::new() };
    format!("{n} of its fit windows come from byte-identical copies of evaluation recordings{draws}")
}
