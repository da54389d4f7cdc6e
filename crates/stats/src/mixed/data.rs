//! The data of a mixed model: the response, the fixed-effect columns and
//! the random factors, validated when built, and the size limits a fit
//! checks before allocating anything.

use super::{Inference, MixedError};

/// One random-intercept factor: a level code per observation.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Factor {
    pub(super) name: String,
    pub(super) codes: Vec<usize>,
    pub(super) levels: usize,
}

/// Response, fixed effects and random factors, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct MixedData {
    pub(super) y: Vec<f64>,
    /// Fixed-effect columns beside the intercept: R's name and values.
    pub(super) columns: Vec<(String, Vec<f64>)>,
    pub(super) factors: Vec<Factor>,
}

impl MixedData {
    /// `factors`: (name, level code per observation). Codes are relabelled
    /// densely in order of first appearance, so any integers will do; a
    /// nested factor is given with codes unique across its parent's levels.
    /// The fixed part is an intercept; [`MixedData::with_fixed`] adds
    /// categorical fixed effects.
    pub fn new(y: Vec<f64>, factors: Vec<(String, Vec<usize>)>) -> Result<MixedData, MixedError> {
        let n = y.len();
        if n < 2 {
            return Err(MixedError::TooFewObservations(n));
        }
        if let Some((row, &value)) = y.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(MixedError::NonFinite { row, value });
        }
        if y.iter().all(|v| *v == y[0]) {
            return Err(MixedError::ConstantResponse(y[0]));
        }
        if factors.is_empty() {
            return Err(MixedError::NoFactor);
        }
        let mut out = Vec::new();
        for (name, codes) in factors {
            if codes.len() != n {
                return Err(MixedError::Length { factor: name, found: codes.len(), expected: n });
            }
            let mut map = std::collections::HashMap::new();
            let dense: Vec<usize> = codes
                .iter()
                .map(|c| {
                    let next = map.len();
                    *map.entry(*c).or_insert(next)
                })
                .collect();
            if map.len() < 2 {
                return Err(MixedError::TooFewLevels { factor: name, levels: map.len() });
            }
            // lme4's check.nobs.vs.nlev: a factor with as many levels as
            // observations is confounded with the residual, and any split
            // of the variance between the two fits equally well.
            if map.len() >= n {
                return Err(MixedError::Unidentifiable {
                    factor: name,
                    reason: format!(
                        "it has {} levels for {n} observations, so it cannot be told apart from the residual (lme4 refuses this too: the number of levels of each grouping factor must be < the number of observations)",
                        map.len()
                    ),
                });
            }
            // Two factors that group the observations the same way (codes
            // relabelled by first appearance are then equal) share one
            // variance in any proportion.
            if let Some(other) = out.iter().find(|f: &&Factor| f.codes == dense) {
                return Err(MixedError::Unidentifiable {
                    factor: name,
                    reason: format!(
                        "it groups the observations exactly as factor {} does, so their variances cannot be told apart",
                        other.name
                    ),
                });
            }
            out.push(Factor { name, codes: dense, levels: map.len() });
        }
        Ok(MixedData { y, columns: Vec::new(), factors: out })
    }

    /// The response and fixed-effect columns of a generalized model, whose
    /// random terms are held apart (a factor with as many levels as
    /// observations is allowed there: an observation-level effect).
    pub(super) fn fixed_only(y: Vec<f64>, columns: Vec<(String, Vec<f64>)>) -> Result<MixedData, MixedError> {
        let n = y.len();
        if n < 2 {
            return Err(MixedError::TooFewObservations(n));
        }
        if let Some((row, &value)) = y.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(MixedError::NonFinite { row, value });
        }
        MixedData { y, columns: Vec::new(), factors: Vec::new() }.with_columns(columns)
    }

    /// Adds a categorical fixed effect with one label per observation. Its
    /// levels are sorted bytewise (R's order for ASCII labels in the C
    /// locale) and coded by treatment contrasts: the first level is the
    /// reference, and each other level gets a column named `name` followed
    /// by the level (R's `factorB`).
    pub fn with_fixed(mut self, name: &str, labels: &[String]) -> Result<MixedData, MixedError> {
        if labels.len() != self.y.len() {
            return Err(MixedError::Length { factor: name.into(), found: labels.len(), expected: self.y.len() });
        }
        let mut sorted: Vec<String> = labels.to_vec();
        sorted.sort();
        sorted.dedup();
        if sorted.len() < 2 {
            return Err(MixedError::TooFewLevels { factor: name.into(), levels: sorted.len() });
        }
        let codes: Vec<usize> = labels.iter().map(|l| sorted.binary_search(l).unwrap_or(0)).collect();
        for (level, label) in sorted.iter().enumerate().skip(1) {
            let column = codes.iter().map(|&c| if c == level { 1.0 } else { 0.0 }).collect();
            self.columns.push((format!("{name}{label}"), column));
        }
        Ok(self)
    }

    /// Adds fixed-effect columns of the design matrix as they are (a
    /// numeric covariate, a contrast or indicator column, a product of
    /// them for an interaction), each with its name. The intercept is
    /// always the first column and is not given here. Aliased columns are
    /// dropped when the model is fitted, as lme4 drops them
    /// ([`MixedFit::dropped`](super::MixedFit::dropped)).
    pub fn with_columns(mut self, columns: Vec<(String, Vec<f64>)>) -> Result<MixedData, MixedError> {
        for (name, values) in columns {
            if values.len() != self.y.len() {
                return Err(MixedError::Length { factor: name, found: values.len(), expected: self.y.len() });
            }
            if let Some((row, &value)) = values.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                return Err(MixedError::FixedEffects(format!(
                    "column {name}, observation {row}: {value} is not finite"
                )));
            }
            self.columns.push((name, values));
        }
        Ok(self)
    }

    /// The data with full-rank fixed effects, and the names of the columns
    /// dropped to get there ([`Self::without_aliased`]; borrowed, with no
    /// names, when X already has full rank).
    pub(super) fn full_rank(&self) -> (std::borrow::Cow<'_, MixedData>, Vec<String>) {
        match self.without_aliased() {
            Some((d, names)) => (std::borrow::Cow::Owned(d), names),
            None => (std::borrow::Cow::Borrowed(self), Vec::new()),
        }
    }

    /// The data without the fixed-effect columns that are linear
    /// combinations of earlier ones, and their names, as lme4's
    /// `chkRank.drop.cols` drops them (a missing cell of `A*B`, `a:b`
    /// without its margins): R's QR with limited column pivoting (LINPACK
    /// `dqrdc2`, tolerance 1e-7) moves a column to the end, out of the
    /// model, when what is left of it after the columns kept before it
    /// has a norm below 1e-7 of its own. That residual is computed here by
    /// Gram-Schmidt, orthogonalized twice. `None` when X has full rank.
    pub(super) fn without_aliased(&self) -> Option<(MixedData, Vec<String>)> {
        const TOL: f64 = 1e-7;
        let n = self.y.len();
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let mut basis: Vec<Vec<f64>> = vec![vec![1.0 / (n as f64).sqrt(); n]];
        let (mut kept, mut dropped) = (Vec::new(), Vec::new());
        for (name, values) in &self.columns {
            let norm = dot(values, values).sqrt();
            let mut v = values.clone();
            for _ in 0..2 {
                for q in &basis {
                    let d = dot(q, &v);
                    v.iter_mut().zip(q).for_each(|(x, q)| *x -= d * q);
                }
            }
            let left = dot(&v, &v).sqrt();
            if left < TOL * if norm > 0.0 { norm } else { 1.0 } {
                dropped.push(name.clone());
            } else {
                v.iter_mut().for_each(|x| *x /= left);
                basis.push(v);
                kept.push((name.clone(), values.clone()));
            }
        }
        if dropped.is_empty() {
            return None;
        }
        Some((MixedData { y: self.y.clone(), columns: kept, factors: self.factors.clone() }, dropped))
    }

    /// Number of observations.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// Whether there are no observations (never, once validated).
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Number of fixed-effect columns.
    pub(super) fn p(&self) -> usize {
        1 + self.columns.len()
    }

    /// Levels of every factor but `factor`: the dense block with it
    /// eliminated.
    pub(super) fn levels_but(&self, factor: usize) -> usize {
        self.factors.iter().enumerate().filter(|(j, _)| *j != factor).map(|(_, f)| f.levels).sum()
    }

    /// Names of the fixed-effect columns, R's way.
    pub(super) fn fixed_names(&self) -> Vec<String> {
        std::iter::once("(Intercept)".to_string()).chain(self.columns.iter().map(|(n, _)| n.clone())).collect()
    }

    /// The fixed-effect design, n x p row-major.
    pub(super) fn design(&self) -> Vec<f64> {
        let p = self.p();
        let mut x = vec![0.0; self.y.len() * p];
        for i in 0..self.y.len() {
            x[i * p] = 1.0;
            for (c, (_, values)) in self.columns.iter().enumerate() {
                x[i * p + 1 + c] = values[i];
            }
        }
        x
    }
}

/// The largest dense system a fit builds: the levels of every factor but
/// the largest, plus the fixed-effect columns (InstEval: 1,142). A 20,000
/// square matrix of f64 is 3.2 GB.
pub const MAX_DENSE: usize = 20_000;

/// The most values of the fixed-effect design (observations x columns).
pub const MAX_DESIGN_VALUES: usize = 100_000_000;

impl MixedData {
    /// Whether the intercept engine's dense reduced system (every factor's
    /// levels but the largest's, plus the fixed effects) is within
    /// [`MAX_DENSE`].
    pub(crate) fn dense_fits(&self) -> bool {
        let levels: Vec<usize> = self.factors.iter().map(|f| f.levels).collect();
        let largest = levels.iter().copied().max().unwrap_or(0);
        levels.iter().sum::<usize>() - largest + self.p() <= MAX_DENSE
    }

    /// Refuses an n x p design over [`MAX_DESIGN_VALUES`] values (what the
    /// sparse engine holds densely besides its factor).
    pub(crate) fn check_design(&self) -> Result<(), MixedError> {
        if self.len().saturating_mul(self.p()) > MAX_DESIGN_VALUES {
            return Err(MixedError::TooLarge(format!(
                "{} observations x {} fixed-effect columns is over the limit of {MAX_DESIGN_VALUES} values",
                self.len(),
                self.p()
            )));
        }
        Ok(())
    }

    /// Refuses a model whose dense matrices would not fit in memory, before
    /// any is allocated: the penalized system (every factor's levels but
    /// the largest's, plus the fixed effects), the n x p design, and for
    /// Kenward-Roger the q x q matrices over all levels.
    pub(super) fn check_size(&self, inference: Inference) -> Result<(), MixedError> {
        let levels: Vec<usize> = self.factors.iter().map(|f| f.levels).collect();
        let largest = levels.iter().copied().max().unwrap_or(0);
        let q: usize = levels.iter().sum();
        let dense = q - largest + self.p();
        let too_large = |what: String| Err(MixedError::TooLarge(what));
        if dense > MAX_DENSE {
            return too_large(format!(
                "the random factors but the largest have {} levels and there are {} fixed-effect columns: the dense system would be {dense} x {dense}, over the limit of {MAX_DENSE}",
                q - largest,
                self.p()
            ));
        }
        self.check_design()?;
        if inference == Inference::Full && q + self.p() > MAX_DENSE {
            return too_large(format!(
                "Kenward-Roger works with matrices over every level ({q} levels, {} fixed-effect columns), over the limit of {MAX_DENSE}; use Satterthwaite df",
                self.p()
            ));
        }
        Ok(())
    }
}
