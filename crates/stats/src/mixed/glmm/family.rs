//! A GLMM's response distribution and its canonical link (`Family`).

use serde::Serialize;

/// The response's distribution, with its canonical link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Family {
    /// Successes out of trials (or 0/1), logit link.
    Binomial,
    /// Counts, log link.
    Poisson,
}

impl Family {
    /// R's name and link, as `glmer`'s summary prints them.
    pub fn label(self) -> &'static str {
        match self {
            Family::Binomial => "binomial  ( logit )",
            Family::Poisson => "poisson  ( log )",
        }
    }
}
