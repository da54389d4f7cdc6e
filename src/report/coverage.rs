//! Condition coverage in report.md: the sentence beside the verdict and the
//! section with the covered-only row.

use std::fmt::Write as _;

use super::format::{f, fieller_cell, level_pct};
use super::{md_text, MdTable};
use crate::analysis::coverage::ConditionCoverage;
use crate::analysis::Analysis;

/// The Condition coverage section: the primary contrast over every
/// recording and over the covered ones, and the uncovered recordings.
pub(super) fn section(a: &Analysis, s: &mut String) {
    let Some(c) = a.coverage.as_ref().filter(|c| c.mixes_novelty()) else { return };
    let Some(u) = a.units.first() else { return };
    let level = level_pct(a.level);
    let _ = writeln!(s, "## Condition coverage\n");
    let _ = writeln!(
        s,
        "The primary endpoint over every evaluation recording and over the recordings whose {} the reference arm (`{}`) also fits on other recordings of (the preregistered estimator; a sensitivity row, not the decision).\n",
        c.condition, c.arm
    );
    let (ci, oci) = (format!("{level} CI"), format!("optimism {level} CI"));
    let unit = super::format::unit_label(&a.decision.value_unit).to_string();
    let mut t = MdTable::new(&["recordings", "n", "unit", "d mean", &ci, "optimism %", &oci, "rule"], "lrlrlrll");
    let e = &u.estimate;
    t.row([
        "all".to_string(),
        a.recordings.len().to_string(),
        unit.clone(),
        f(e.mean, 4),
        format!("[{}, {}]", f(e.lower, 4), f(e.upper, 4)),
        f(u.optimism_pct, 1),
        fieller_cell(u.optimism_interval),
        if u.rule_holds { "holds" } else { "fails" }.to_string(),
    ]);
    if let Some(k) = &c.covered_only {
        let e = &k.estimate;
        t.row([
            "covered only".to_string(),
            k.recordings.to_string(),
            unit.clone(),
            f(e.mean, 4),
            format!("[{}, {}]", f(e.lower, 4), f(e.upper, 4)),
            f(k.optimism_pct, 1),
            fieller_cell(k.optimism_interval),
            if k.rule_holds { "holds" } else { "fails" }.to_string(),
        ]);
    }
    let _ = writeln!(s, "{}", t.render());
    let mut list = MdTable::new(&["uncovered recording", "condition", "draws uncovered"], "llr");
    for r in &c.uncovered {
        list.row([md_text(&r.recording), md_text(&r.condition), format!("{} of {}", r.draws, c.draws)]);
    }
    let _ = writeln!(s, "{}", list.render());
}

/// The statement as one line for a console or a combined report.
pub fn summary(c: &ConditionCoverage) -> Option<String> {
    c.mixes_novelty().then(|| {
        format!(
            "the reference arm `{}` fits on no other recording of the {} of {} evaluation recording(s) ({}% of the summed d)",
            c.arm,
            c.condition,
            c.uncovered.len(),
            f(100.0 * c.share_of_d, 1)
        )
    })
}
