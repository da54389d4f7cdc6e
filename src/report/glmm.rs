//! report.md's section on the divergence endpoints declared `glmm
//! binomial`: each unit's odds ratio of a diverged rollout from the
//! crossed binomial GLMM, beside the failure-aware RMSE of the endpoints
//! table, with what that ratio measures.

use std::fmt::Write as _;

use super::format::{f, level_pct};
use super::MdTable;
use crate::analysis::Analysis;

/// A unit's diverged starts held by few recordings, as a list item.
fn concentrated(u: &crate::analysis::UnitResult, g: &crate::analysis::GlmmEndpoint) -> Option<String> {
    if g.concentrated.is_empty() {
        return None;
    }
    let held: u64 = g.concentrated.iter().map(|(_, n)| n).sum();
    let names: Vec<String> = g.concentrated.iter().map(|(r, n)| format!("{} ({n})", super::md_text(r))).collect();
    Some(format!(
        "- {} {} at {} s: {held} of the {} diverged starts are on {}.",
        u.model,
        u.metric.name(),
        u.horizon_s,
        g.diverged_treated + g.diverged_reference,
        names.join(", ")
    ))
}

/// The section, when some unit has a GLMM.
pub(super) fn section(a: &Analysis, s: &mut String) {
    let units: Vec<_> = a.units.iter().filter_map(|u| u.glmm.as_ref().map(|g| (u, g))).collect();
    let Some((_, first)) = units.first() else { return };
    let (t, r) = (&a.treated, &a.reference);
    let level = level_pct(a.level);
    let _ = writeln!(s, "## Divergence by binomial GLMM\n");
    let _ = writeln!(
        s,
        "`{}`, fitted by maximum likelihood under the Laplace approximation as lme4's `glmer` fits it. The odds ratio compares the odds that a rollout diverges (its position error passes the cap, or becomes non-finite, before the horizon), {t} over {r}, for the same recording and seed: a conditional odds ratio, not the ratio of the arms' divergence rates. {level} Wald interval; the SE is lme4's, from the Hessian in the variance parameters and the fixed effects.\n",
        first.model
    );
    let ci_h = format!("OR {level} CI");
    let (dt, dr) = (format!("diverged {t}"), format!("diverged {r}"));
    let cols = [
        "model",
        "metric",
        "horizon",
        &dt,
        &dr,
        "odds ratio",
        &ci_h,
        "log OR (SE)",
        "p",
        "SD recording",
        "SD seed",
        "SD recording x seed",
        "optimizer",
    ];
    let mut table = MdTable::new(&cols, "lllrrrlrrrrrl");
    let few: Vec<String> = units.iter().filter_map(|(u, g)| concentrated(u, g)).collect();
    for (u, g) in units {
        let head = format!("{} | {} | {} s", u.model, u.metric.name(), u.horizon_s);
        let counts = [
            format!("{}/{}", g.diverged_treated, g.starts_treated),
            format!("{}/{}", g.diverged_reference, g.starts_reference),
        ];
        let rest: Vec<String> = match (&g.estimate, &g.not_estimable) {
            (Some(e), _) => vec![
                f(e.odds_ratio, 4),
                format!("[{}, {}]", f(e.odds_ratio_lower, 4), f(e.odds_ratio_upper, 4)),
                format!("{} ({})", f(e.log_odds_ratio, 4), f(e.se, 4)),
                format!("{:.3e}", e.p),
                f(e.sd_recording, 4),
                f(e.sd_seed, 4),
                f(e.sd_recording_seed, 4),
                match (e.certified, e.singular) {
                    (false, _) => "NOT CERTIFIED".to_string(),
                    (true, true) => "certified (singular)".to_string(),
                    (true, false) => "certified".to_string(),
                },
            ],
            (None, reason) => {
                let why = reason.as_deref().map(crate::io::md_line).unwrap_or_default();
                let mut v = vec!["NA".to_string(), format!("(not estimable: {why})")];
                v.extend(std::iter::repeat_n("NA".to_string(), 6));
                v
            }
        };
        table.row(std::iter::once(head).chain(counts).chain(rest));
    }
    let _ = writeln!(s, "{}", table.render());
    if !few.is_empty() {
        let _ = writeln!(
            s,
            "Diverged starts held by few recordings (at most a fifth of them hold nine tenths): each such odds ratio is decided by those recordings, not spread over the study.\n\n{}\n",
            few.join("\n")
        );
    }
}
