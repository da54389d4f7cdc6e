//! How the summaries print a number.

/// A number as the summaries print it: six decimals, as lme4's tables,
/// except a nonzero value those would show as 0.000000 (below 5e-7 in
/// magnitude), which is written with four significant decimals in
/// scientific notation; the width and alignment of the format are kept.
pub(super) struct Six(pub(super) f64);

impl std::fmt::Display for Six {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        let text = if x != 0.0 && x.abs() < 5e-7 { format!("{x:.4e}") } else { format!("{x:.6}") };
        f.pad(&text)
    }
}
