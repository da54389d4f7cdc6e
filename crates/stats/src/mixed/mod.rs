//! Linear mixed models with a fixed intercept and any number of
//! random-intercept factors, crossed or nested, fitted by REML or ML through
//! the profiled deviance of lme4 (Bates, Maechler, Bolker and Walker 2015,
//! "Fitting linear mixed-effects models using lme4", section 3).
//!
//! The model is y = X beta + Z b + e with b ~ N(0, sigma^2 Lambda Lambda'),
//! e ~ N(0, sigma^2 I), X an intercept and optional categorical fixed
//! effects (treatment contrasts, as R codes them), Lambda diagonal with the
//! relative standard deviation theta_k of factor k on each of its levels.
//! For a given theta the penalized least-squares system
//!
//! ```text
//! [ Lambda'Z'Z Lambda + I   Lambda'Z'X ] [u   ]   [ Lambda'Z'y ]
//! [ X'Z Lambda              X'X        ] [beta] = [ X'y        ]
//! ```
//!
//! is factored as [L 0; R' R_X] after eliminating the levels of the factor
//! with the most levels, whose block is diagonal (see `system`), so the
//! dense Cholesky factorization (faer) is over the other factors' levels
//! and the fixed effects only. The penalized residual sum of squares
//! r^2 = |y - X beta - Z Lambda u|^2 + |u|^2 is computed from the solution
//! itself (y centred first), not as y'y - |c|^2, which loses digits to
//! cancellation. With p fixed effects the profiled deviances are
//!
//! ```text
//! ML:   log|L|^2 + n (1 + log(2 pi r^2 / n))
//! REML: log|L|^2 + log|R_X|^2 + (n - p) (1 + log(2 pi r^2 / (n - p)))
//! ```
//!
//! minimised over theta >= 0 by Nelder-Mead, Newton steps on a
//! finite-difference gradient and Hessian, and a check of every boundary
//! face; sigma^2 = r^2 / n (ML) or r^2 / (n - p) (REML), the factor
//! variances are sigma^2 theta_k^2 and Var(beta) = sigma^2 (R_X'R_X)^-1. A
//! factor whose theta is below 1e-4 makes the fit singular, as lme4's
//! `isSingular` says. Unbalanced data and missing cells need nothing
//! special: the data are rows, not a matrix.
//!
//! ```
//! use crossaudit_stats::mixed::{fit, Criterion, MixedData};
//! // Two crossed factors, balanced 3 x 2, one observation per cell.
//! let y = vec![1.0, 2.0, 2.5, 3.0, 4.0, 6.5];
//! let rows = vec![0, 0, 1, 1, 2, 2];
//! let cols = vec![0, 1, 0, 1, 0, 1];
//! let data = MixedData::new(y, vec![("row".into(), rows), ("col".into(), cols)]).unwrap();
//! let f = fit(&data, Criterion::Reml).unwrap();
//! assert!((f.intercept - 19.0 / 6.0).abs() < 1e-9); // balanced: the grand mean
//! ```

mod data;
mod exact;
pub mod formula;
pub mod glmm;
mod inference;
mod levels;
pub(crate) mod optimize;
mod profile;
pub mod slopes;
pub(crate) mod sparse;
mod system;
mod types;

pub use data::{MixedData, MAX_DENSE, MAX_DESIGN_VALUES};
pub use profile::{profile_intervals, ProfileInterval};
pub use sparse::MAX_FACTOR_NONZEROS;
pub use types::{Certificate, Criterion, FixedEffect, Inference, KenwardRoger, MixedError, MixedFit};

/// Fits the model by REML or ML, with every inference ([`Inference::Full`]).
pub fn fit(data: &MixedData, criterion: Criterion) -> Result<MixedFit, MixedError> {
    fit_with(data, criterion, Inference::Full)
}

/// Fits the model by REML or ML, with the inference `inference` asks for.
pub fn fit_with(data: &MixedData, criterion: Criterion, inference: Inference) -> Result<MixedFit, MixedError> {
    data.check_size(inference)?;
    // Aliased columns are dropped first, as lme4 drops them.
    let (data, dropped) = data.full_rank();
    let data: &MixedData = &data;
    let p = data.p();
    if data.len() <= p {
        return Err(MixedError::FixedEffects(format!("{} observations for {p} fixed-effect columns", data.len())));
    }
    exact::refuse_exact_fit(data)?;
    let mut fit = fit_system(&system::System::new(data), data, criterion, inference)?;
    if !dropped.is_empty() {
        fit.notes.insert(0, rank_message(&dropped));
        fit.dropped = dropped;
    }
    Ok(fit)
}

/// lme4's message for dropped columns, with their names.
fn rank_message(dropped: &[String]) -> String {
    let (k, what) =
        if dropped.len() == 1 { (1, "column / coefficient") } else { (dropped.len(), "columns / coefficients") };
    format!("fixed-effect model matrix is rank deficient so dropping {k} {what}: {}", dropped.join(", "))
}

/// [`fit_with`] on the products of `data` already computed.
fn fit_system(
    s: &system::System,
    data: &MixedData,
    criterion: Criterion,
    inference: Inference,
) -> Result<MixedFit, MixedError> {
    let p = data.p();
    // Rank of X: a Cholesky pivot below 1e-10 of its column's X'X diagonal
    // (exact aliasing leaves a rounding residue, positive or negative).
    let aliased = match s.xtx.llt(faer::Side::Lower) {
        Err(_) => true,
        Ok(llt) => (0..p).any(|c| llt.L()[(c, c)].powi(2) <= 1e-10 * s.xtx[(c, c)]),
    };
    if aliased {
        return Err(MixedError::FixedEffects(format!("the columns {:?} are linearly dependent", data.fixed_names())));
    }
    let (mut best, _, evaluations, mut certificate) = optimize::optimum(s, criterion)?;
    // The reduced system is exact in the eliminated factor whatever its
    // variance; another factor's large variance still costs digits in the
    // dense Cholesky factor (log10(theta^2 n) of them). Where another
    // factor's theta dominates, the optimum is polished, certified and
    // the inference computed with that factor eliminated instead.
    let dominant = (0..best.len()).max_by(|&a, &b| best[a].total_cmp(&best[b])).unwrap_or(s.first);
    let rebuilt;
    let s = if dominant != s.first
        && best[dominant] > 10.0
        && best[dominant] > 2.0 * best[s.first]
        && s.factors() > 1
        && data.levels_but(dominant) + p <= MAX_DENSE
    {
        rebuilt = system::System::eliminating(data, dominant);
        let mut dev = |theta: &[f64]| rebuilt.evaluate(theta, criterion).map(|e| e.deviance).unwrap_or(f64::INFINITY);
        let d0 = dev(&best);
        let (t, _, _) = optimize::newton_one_by_one(&mut dev, best.clone(), d0, 8);
        best = t;
        let d = dev(&best);
        let c = optimize::certify(&mut |xs: &[Vec<f64>]| xs.iter().map(|x| dev(x)).collect(), &best, d);
        certificate = Certificate {
            gradient: c.gradient,
            predicted_decrease: c.predicted_decrease,
            boundary: c.boundary,
            certified: c.certified,
            restarts: certificate.restarts,
        };
        &rebuilt
    } else {
        s
    };
    let e = s.evaluate(&best, criterion)?;
    // The standardized response has variance 1: the total is its scale's square.
    let total = s.y_scale * s.y_scale;
    if e.sigma2 <= 1e-20 * total {
        return Err(MixedError::ZeroResidual { residual: e.sigma2, total });
    }
    let mut notes = Vec::new();
    let names = data.fixed_names();
    // Where a df cannot be computed reliably the fit says so and uses a
    // stated, conservative df: the fewest levels of any random factor
    // less one (the df of the intercept's test when that factor's
    // variance dominates, at most the containment df of any effect).
    let fallback = (data.factors.iter().map(|f| f.levels).min().unwrap_or(2) as f64 - 1.0).max(1.0);
    let mut resolve = |method: &str, c: usize, df: inference::Df| -> (f64, bool) {
        match df {
            inference::Df::Value(v) => (v, false),
            inference::Df::NotPositiveDefinite => {
                notes.push(format!("{method} df of {}: the Hessian of the REML criterion is not positive definite at the optimum, so the df cannot be computed; using {fallback} (the fewest levels of a random factor less one)", names[c]));
                (fallback, true)
            }
            inference::Df::Unreliable(v) => {
                notes.push(format!("{method} df of {}: the difference derivatives do not agree between step sizes (estimate {v:.4e}), so the df cannot be computed reliably; using {fallback} (the fewest levels of a random factor less one)", names[c]));
                (fallback, true)
            }
        }
    };
    let (kr, shares, df) = match (criterion, inference) {
        (Criterion::Reml, Inference::Full) => {
            let (kr, shares) = inference::kenward_roger(s, &best, e.sigma2)?;
            let kr: Vec<Option<KenwardRoger>> = kr
                .into_iter()
                .enumerate()
                .map(|(c, (kr, verdict))| {
                    let (df, fallback) = resolve("Kenward-Roger", c, verdict);
                    Some(KenwardRoger { se: kr.se, df, fallback })
                })
                .collect();
            let df = inference::satterthwaite(s, &best, e.sigma2)?;
            let df = df.into_iter().enumerate().map(|(c, d)| Some(resolve("Satterthwaite", c, d))).collect();
            (kr, shares, df)
        }
        (Criterion::Reml, Inference::Satterthwaite) => {
            let df = inference::satterthwaite(s, &best, e.sigma2)?;
            let df = df.into_iter().enumerate().map(|(c, d)| Some(resolve("Satterthwaite", c, d))).collect();
            (vec![None; p], Vec::new(), df)
        }
        _ => (vec![None; p], Vec::new(), vec![None; p]),
    };
    let fixed: Vec<FixedEffect> = data
        .fixed_names()
        .into_iter()
        .enumerate()
        .map(|(c, name)| FixedEffect {
            name,
            estimate: e.beta[c],
            se: (e.sigma2 * e.rx_inv[(c, c)]).sqrt(),
            df_satterthwaite: df[c].map(|d: (f64, bool)| d.0),
            satterthwaite_fallback: df[c].is_some_and(|d| d.1),
            kenward_roger: kr[c],
        })
        .collect();
    Ok(MixedFit {
        shares,
        df_satterthwaite: df[0].map(|d| d.0),
        kenward_roger: kr[0],
        notes,
        criterion,
        factors: data.factors.iter().map(|f| f.name.clone()).collect(),
        levels: data.factors.iter().map(|f| f.levels).collect(),
        variances: best.iter().map(|t| e.sigma2 * t * t).collect(),
        singular: best.iter().any(|t| *t < 1e-4),
        theta: best,
        residual: e.sigma2,
        intercept: fixed[0].estimate,
        se: fixed[0].se,
        fixed,
        deviance: e.deviance,
        certificate,
        evaluations,
        dropped: Vec::new(),
        n: data.len(),
    })
}
