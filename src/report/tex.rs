//! results.tex: `\newcommand` macros for every reported number, so a paper
//! can `\input` them instead of copying digits by hand.

use std::fmt::Write as _;

use super::f;
use crate::analysis::Analysis;
use crate::design::Factor;
use crossaudit_stats::CrossedEstimate;

/// LaTeX macro names are letters only: digits become words, other
/// characters split words, and each word is capitalised.
pub fn macro_name(parts: &[&str]) -> String {
    const DIGITS: [&str; 10] = ["Zero", "One", "Two", "Three", "Four", "Five", "Six", "Seven", "Eight", "Nine"];
    let mut out = String::from("ca");
    for part in parts {
        let mut upper = true;
        for ch in part.chars() {
            if let Some(d) = ch.to_digit(10) {
                out.push_str(DIGITS[d as usize]);
                upper = true;
            } else if ch == '.' {
                out.push_str("Point");
                upper = true;
            } else if ch.is_ascii_alphabetic() {
                if upper {
                    out.push(ch.to_ascii_uppercase());
                } else {
                    out.push(ch);
                }
                upper = false;
            } else {
                upper = true;
            }
        }
    }
    out
}

struct Macros {
    text: String,
    names: Vec<String>,
}

impl Macros {
    fn add(&mut self, parts: &[&str], value: String) {
        let mut name = macro_name(parts);
        // Distinct inputs can collide after sanitising (e.g. `a_b` and `aB`);
        // keep every macro by suffixing.
        let base = name.clone();
        let mut k = 0;
        while self.names.contains(&name) {
            k += 1;
            name = format!("{base}{}", macro_name(&[&"x".repeat(k)]).trim_start_matches("ca"));
        }
        self.names.push(name.clone());
        let _ = writeln!(self.text, "\\newcommand{{\\{name}}}{{{value}}}");
    }

    fn estimate(&mut self, prefix: &[&str], e: &CrossedEstimate) {
        self.add(&with(prefix, "mean"), f(e.mean, 4));
        self.add(&with(prefix, "se"), f(e.se, 4));
        self.add(&with(prefix, "lower"), f(e.lower, 4));
        self.add(&with(prefix, "upper"), f(e.upper, 4));
        self.add(&with(prefix, "df"), if e.df.is_infinite() { "\\infty".into() } else { f(e.df, 1) });
        self.add(&with(prefix, "share recording"), f(100.0 * e.share_recording, 1));
        self.add(&with(prefix, "share seed"), f(100.0 * e.share_seed, 1));
        self.add(&with(prefix, "share residual"), f(100.0 * e.share_residual, 1));
    }
}

fn with<'a>(prefix: &[&'a str], q: &'a str) -> Vec<&'a str> {
    let mut v = prefix.to_vec();
    v.push(q);
    v
}

/// results.tex: one LaTeX macro per reported number.
pub fn render_tex(a: &Analysis) -> String {
    let mut m = Macros { text: String::new(), names: Vec::new() };
    let _ = writeln!(m.text, "% crossaudit results for study \"{}\"; \\input this file.", a.study);
    if let Some(s) = a.header.standing.line() {
        let _ = writeln!(m.text, "% {s}.");
    }
    if let Some(h) = &a.header.design_sha256 {
        let _ = writeln!(m.text, "% design sha256 {h}");
    }
    let p = &a.provenance;
    if let Some(d) = &p.data {
        let _ =
            writeln!(m.text, "% data: {d}; inclusion audit sha256 {}", p.audit_sha256.as_deref().unwrap_or("unknown"));
    }
    if let Some((path, sha)) = &p.cells {
        let _ = writeln!(m.text, "% per-cell data: {path} (sha256 {sha})");
    }
    let _ = writeln!(m.text, "% crossaudit {}", p.crossaudit);
    m.add(&["exploratory"], if a.header.standing.exploratory() { "yes".to_string() } else { "no".to_string() });
    if let Some(p) = a.header.standing.preregistered() {
        m.add(&["preregistered"], if p { "yes".to_string() } else { "no".to_string() });
    }
    // The standing's tag (`post hoc`, `exploratory`, `not preregistered`),
    // or `preregistered`: the two flags above cannot say post hoc.
    match (a.header.standing.tag(), a.header.standing.preregistered()) {
        (Some(tag), _) => m.add(&["standing"], tag.to_lowercase()),
        (None, Some(true)) => m.add(&["standing"], "preregistered".to_string()),
        _ => {}
    }
    let decision = match (&a.decision.member_of, a.decision.holds) {
        (Some(_), _) => "descriptive".to_string(),
        (None, true) => a.decision.name.clone(),
        (None, false) => format!("not {}", a.decision.name),
    };
    m.add(&["decision"], decision);
    m.add(&["recordings"], a.recordings.len().to_string());
    m.add(&["seeds"], a.seeds.len().to_string());
    for u in &a.units {
        let h = format!("{}s", u.horizon_s);
        let base = [u.model.as_str(), u.metric.name(), h.as_str()];
        m.add(&with(&base, "treated"), f(u.mean_treated, 4));
        m.add(&with(&base, "reference"), f(u.mean_reference, 4));
        m.add(&with(&base, "optimism"), f(u.optimism_pct, 1));
        m.estimate(&base, &u.estimate);
        if let Some(b) = u.bootstrap {
            m.add(&with(&base, "boot lower"), f(b.lower, 4));
            m.add(&with(&base, "boot upper"), f(b.upper, 4));
        }
        if let Some(g) = &u.grouped {
            m.estimate(&with(&base, "grouped"), &g.estimate);
        }
        for l in &u.leave_one_out {
            let who = match l.factor {
                Factor::Seed => "loso",
                Factor::Recording => "loro",
            };
            m.add(&with(&base, &format!("{who} optimism min")), f(l.optimism_min, 1));
            m.add(&with(&base, &format!("{who} optimism max")), f(l.optimism_max, 1));
            m.add(&with(&base, &format!("{who} upper max")), f(l.upper_max, 4));
        }
    }
    for ix in &a.interactions {
        let h = format!("{}s", ix.horizon_s);
        let base = ["interaction", ix.left.as_str(), ix.right.as_str(), ix.metric.name(), h.as_str()];
        m.estimate(&base, &ix.estimate);
    }
    m.text
}
