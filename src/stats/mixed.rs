//! Linear mixed models with a fixed intercept and any number of
//! random-intercept factors, crossed or nested, fitted by REML or ML through
//! the profiled deviance of lme4 (Bates, Maechler, Bolker and Walker 2015,
//! "Fitting linear mixed-effects models using lme4", section 3).
//!
//! The model is y = 1 mu + Z b + e with b ~ N(0, sigma^2 Lambda Lambda'),
//! e ~ N(0, sigma^2 I), Lambda diagonal with the relative standard deviation
//! theta_k of factor k on each of its levels. For a given theta the
//! penalized least-squares system
//!
//! ```text
//! [ Lambda'Z'Z Lambda + I   Lambda'Z'1 ] [u ]   [ Lambda'Z'y ]
//! [ 1'Z Lambda              n          ] [mu] = [ 1'y        ]
//! ```
//!
//! is factored as [L 0; r' R_X] (faer's Cholesky of the q x q block, q the
//! number of levels of all factors together; a triangular solve for r). The
//! penalized residual sum of squares r^2 = |y - 1 mu - Z Lambda u|^2 + |u|^2
//! is computed from the solution itself (y centred first), not as
//! y'y - |c|^2, which loses digits to cancellation. The profiled deviances
//! are
//!
//! ```text
//! ML:   log|L|^2 + n (1 + log(2 pi r^2 / n))
//! REML: log|L|^2 + log R_X^2 + (n - 1) (1 + log(2 pi r^2 / (n - 1)))
//! ```
//!
//! minimised over theta >= 0 by Nelder-Mead with restarts, Newton steps on
//! a finite-difference gradient and Hessian, and a check of
//! every boundary face; sigma^2 = r^2 / n (ML) or r^2 / (n - 1) (REML), the
//! factor variances are sigma^2 theta_k^2 and Var(mu) = sigma^2 / R_X^2. A
//! factor whose theta is below 1e-4 makes the fit singular, as lme4's
//! `isSingular` says. Unbalanced data and missing cells need nothing
//! special: the data are rows, not a matrix.
//!
//! ```
//! use crossaudit::stats::mixed::{fit, Criterion, MixedData};
//! // Two crossed factors, balanced 3 x 2, one observation per cell.
//! let y = vec![1.0, 2.0, 2.5, 3.0, 4.0, 6.5];
//! let rows = vec![0, 0, 1, 1, 2, 2];
//! let cols = vec![0, 1, 0, 1, 0, 1];
//! let data = MixedData::new(y, vec![("row".into(), rows), ("col".into(), cols)]).unwrap();
//! let f = fit(&data, Criterion::Reml).unwrap();
//! assert!((f.intercept - 19.0 / 6.0).abs() < 1e-9); // balanced: the grand mean
//! ```

use faer::linalg::solvers::{DenseSolveCore, Solve};
use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::{Mat, Par, Side};
use serde::Serialize;

/// REML (restricted) or ML (full) likelihood.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// Restricted maximum likelihood (lme4's default).
    Reml,
    /// Maximum likelihood.
    Ml,
}

/// Why a model cannot be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MixedError {
    /// Fewer than two observations.
    #[error("a mixed model needs at least 2 observations, found {0}")]
    TooFewObservations(usize),
    /// A response that is not finite.
    #[error("observation {row}: the response {value} is not finite")]
    NonFinite {
        /// 0-based row.
        row: usize,
        /// The value.
        value: f64,
    },
    /// A factor whose codes do not match the response.
    #[error("factor {factor}: {found} codes for {expected} observations")]
    Length {
        /// Factor name.
        factor: String,
        /// Codes given.
        found: usize,
        /// Observations.
        expected: usize,
    },
    /// Every observation equal: there is no variance to partition.
    #[error("every observation is {0}: a constant response has no variance to partition")]
    ConstantResponse(f64),
    /// The factors explain the response exactly: REML's optimum is at a
    /// zero residual variance, where the likelihood is unbounded.
    #[error("the random factors reproduce the response exactly (residual variance {residual:e} of a total {total:e}): the likelihood has no finite optimum")]
    ZeroResidual {
        /// The residual variance where the optimizer stopped.
        residual: f64,
        /// The response's sample variance.
        total: f64,
    },
    /// No random factor.
    #[error("a mixed model needs at least one random factor")]
    NoFactor,
    /// A factor with a single level carries no variance.
    #[error("factor {factor} has {levels} level(s); a random factor needs at least 2")]
    TooFewLevels {
        /// Factor name.
        factor: String,
        /// Its number of levels.
        levels: usize,
    },
    /// The penalized system could not be factored (it is positive definite
    /// for every theta, so this means non-finite input slipped through).
    #[error("the penalized least-squares system is not positive definite at theta = {theta:?}")]
    NotPositiveDefinite {
        /// Where.
        theta: Vec<f64>,
    },
}

/// One random-intercept factor: a level code per observation.
#[derive(Debug, Clone, PartialEq)]
struct Factor {
    name: String,
    codes: Vec<usize>,
    levels: usize,
}

/// Response and random factors, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct MixedData {
    y: Vec<f64>,
    factors: Vec<Factor>,
}

impl MixedData {
    /// `factors`: (name, level code per observation). Codes are relabelled
    /// densely in order of first appearance, so any integers will do; a
    /// nested factor is given with codes unique across its parent's levels.
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
            out.push(Factor { name, codes: dense, levels: map.len() });
        }
        Ok(MixedData { y, factors: out })
    }

    /// Number of observations.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// Whether there are no observations (never, once validated).
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }
}

/// A fitted model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MixedFit {
    /// REML or ML.
    pub criterion: Criterion,
    /// Factor names, in the order given.
    pub factors: Vec<String>,
    /// Levels per factor.
    pub levels: Vec<usize>,
    /// Relative standard deviations theta_k (factor SD / residual SD).
    pub theta: Vec<f64>,
    /// Factor variances sigma^2 theta_k^2.
    pub variances: Vec<f64>,
    /// Residual variance sigma^2.
    pub residual: f64,
    /// The fixed intercept.
    pub intercept: f64,
    /// Its standard error, sqrt(sigma^2 / R_X^2).
    pub se: f64,
    /// The profiled deviance at the optimum (-2 log-likelihood, REML or ML).
    pub deviance: f64,
    /// A factor's theta below 1e-4: a boundary fit, as lme4 flags it.
    pub singular: bool,
    /// Satterthwaite degrees of freedom of the intercept (REML fits; `None`
    /// for ML), as lmerTest computes them: 2 Var(mu)^2 / (g' A g), with g
    /// the gradient of Var(mu) in the variance parameters and A their
    /// asymptotic covariance, twice the inverse Hessian of the REML
    /// deviance (both by central differences). Components estimated at
    /// zero are held there. Also `None` where that Hessian is not positive
    /// definite.
    pub df_satterthwaite: Option<f64>,
    /// Kenward-Roger (1997) inference for the intercept (REML fits; `None`
    /// for ML), as pbkrtest computes it.
    pub kenward_roger: Option<KenwardRoger>,
    /// Var(mu) split by source: factors in order, then the residual. Var(mu)
    /// is homogeneous of degree 1 in the variances, so by Euler's theorem
    /// the terms phi_k dVar(mu)/dphi_k add up to it; on a balanced crossed
    /// array they are sa/I, sb/J and se/(IJ). Fractions of Var(mu).
    pub shares: Vec<f64>,
    /// Deviance evaluations used.
    pub evaluations: usize,
    /// Observations.
    pub n: usize,
}

/// Kenward-Roger inference for the intercept: the small-sample adjusted
/// variance and the denominator df (pbkrtest's `vcovAdj` and `Lb_ddf`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KenwardRoger {
    /// sqrt of the adjusted Var(mu): Phi + 2 Phi U Phi (Kenward and Roger
    /// 1997, eq. 4; no second-derivative term, since V is linear in the
    /// variances).
    pub se: f64,
    /// The denominator df. With one fixed effect the KR scaling factor is 1
    /// and the df reduce to 2 / A, A = Phi^2 sum_ij W_ij P_i P_j (W twice
    /// the inverse expected REML information): Satterthwaite's formula
    /// with the expected rather than the observed information.
    pub df: f64,
}

/// The cross-products the deviance needs, computed once.
struct Cross {
    /// Z'Z, q x q, dense.
    ztz: Mat<f64>,
    /// Z'y and Z'1 (level sums and counts).
    zty: Vec<f64>,
    zt1: Vec<f64>,
    sum_y: f64,
    n: f64,
    /// Factor of each of the q columns.
    factor_of: Vec<usize>,
    /// The response, centred at `y_mean` (the intercept is shifted back).
    y: Vec<f64>,
    y_mean: f64,
    /// The q-column of each observation for each factor, row-major (n x k).
    columns: Vec<usize>,
}

fn cross(d: &MixedData) -> Cross {
    let offsets: Vec<usize> = d
        .factors
        .iter()
        .scan(0, |acc, f| {
            let o = *acc;
            *acc += f.levels;
            Some(o)
        })
        .collect();
    let q: usize = d.factors.iter().map(|f| f.levels).sum();
    let mut ztz = Mat::<f64>::zeros(q, q);
    let mut zty = vec![0.0; q];
    let mut zt1 = vec![0.0; q];
    // Centring y keeps the penalized residual sum of squares from being a
    // small difference of large sums.
    let y_mean = d.y.iter().sum::<f64>() / d.y.len() as f64;
    let y: Vec<f64> = d.y.iter().map(|v| v - y_mean).collect();
    let k = d.factors.len();
    let mut columns = Vec::with_capacity(y.len() * k);
    for (i, &yi) in y.iter().enumerate() {
        let cols: Vec<usize> = d.factors.iter().enumerate().map(|(k, f)| offsets[k] + f.codes[i]).collect();
        for &a in &cols {
            zty[a] += yi;
            zt1[a] += 1.0;
            for &b in &cols {
                ztz[(a, b)] += 1.0;
            }
        }
        columns.extend(cols);
    }
    let factor_of = d.factors.iter().enumerate().flat_map(|(k, f)| std::iter::repeat_n(k, f.levels)).collect();
    Cross { ztz, zty, zt1, sum_y: y.iter().sum(), n: y.len() as f64, factor_of, y, y_mean, columns }
}

/// The deviance and the estimates at one theta.
#[derive(Debug, Clone, Copy)]
struct Eval {
    deviance: f64,
    intercept: f64,
    sigma2: f64,
    rx2: f64,
    log_det_l2: f64,
    r2: f64,
}

fn evaluate(c: &Cross, theta: &[f64], criterion: Criterion) -> Result<Eval, MixedError> {
    let q = c.zty.len();
    let lambda: Vec<f64> = c.factor_of.iter().map(|&k| theta[k]).collect();
    let a = Mat::<f64>::from_fn(q, q, |i, j| lambda[i] * c.ztz[(i, j)] * lambda[j] + if i == j { 1.0 } else { 0.0 });
    let llt = a.llt(Side::Lower).map_err(|_| MixedError::NotPositiveDefinite { theta: theta.to_vec() })?;
    let l = llt.L();
    // Forward solves: cu = L^-1 Lambda Z'y, rzx = L^-1 Lambda Z'1.
    let mut rhs = Mat::<f64>::from_fn(q, 2, |i, j| lambda[i] * if j == 0 { c.zty[i] } else { c.zt1[i] });
    solve_lower_triangular_in_place(l, rhs.as_mut(), Par::Seq);
    let (mut rzx2, mut rzx_cu) = (0.0, 0.0);
    let mut log_det_l2 = 0.0;
    for i in 0..q {
        let (cu, rzx) = (rhs[(i, 0)], rhs[(i, 1)]);
        rzx2 += rzx * rzx;
        rzx_cu += rzx * cu;
        log_det_l2 += 2.0 * l[(i, i)].ln();
    }
    let rx2 = c.n - rzx2;
    let c_beta = (c.sum_y - rzx_cu) / rx2.sqrt();
    let beta = c_beta / rx2.sqrt();
    // The penalized RSS from the solution itself, |y - mu - Z Lambda u|^2 +
    // |u|^2, with L'u = cu - rzx mu; y'y - |cu|^2 - c_beta^2 is the same
    // number in exact arithmetic but loses digits to cancellation.
    let mut u = Mat::<f64>::from_fn(q, 1, |i, _| rhs[(i, 0)] - rhs[(i, 1)] * beta);
    solve_upper_triangular_in_place(l.transpose(), u.as_mut(), Par::Seq);
    let b: Vec<f64> = (0..q).map(|i| lambda[i] * u[(i, 0)]).collect();
    let k = theta.len();
    let mut r2: f64 = (0..q).map(|i| u[(i, 0)] * u[(i, 0)]).sum();
    for (i, yi) in c.y.iter().enumerate() {
        let fitted = beta + c.columns[i * k..(i + 1) * k].iter().map(|&a| b[a]).sum::<f64>();
        r2 += (yi - fitted).powi(2);
    }
    let r2 = r2.max(f64::MIN_POSITIVE);
    let intercept = beta + c.y_mean;
    let two_pi = 2.0 * std::f64::consts::PI;
    let (deviance, sigma2) = match criterion {
        Criterion::Ml => (log_det_l2 + c.n * (1.0 + (two_pi * r2 / c.n).ln()), r2 / c.n),
        Criterion::Reml => {
            let m = c.n - 1.0;
            (log_det_l2 + rx2.ln() + m * (1.0 + (two_pi * r2 / m).ln()), r2 / m)
        }
    };
    Ok(Eval { deviance, intercept, sigma2, rx2, log_det_l2, r2 })
}

/// Minimises `f` over the non-negative orthant by Nelder-Mead (reflections
/// clamped at zero), from `start`, until the simplex's deviances agree to a
/// relative 1e-13, its vertices to 1e-10, or 20,000 iterations.
fn nelder_mead(f: &mut dyn FnMut(&[f64]) -> f64, start: &[f64], step: f64) -> (Vec<f64>, f64) {
    let k = start.len();
    let clamp = |v: Vec<f64>| -> Vec<f64> { v.into_iter().map(|x| x.max(0.0)).collect() };
    let mut simplex: Vec<Vec<f64>> = vec![start.to_vec()];
    for i in 0..k {
        let mut v = start.to_vec();
        v[i] += step;
        simplex.push(v);
    }
    let mut values: Vec<f64> = simplex.iter().map(|v| f(v)).collect();
    for _ in 0..20_000 {
        let mut order: Vec<usize> = (0..=k).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        simplex = order.iter().map(|&i| simplex[i].clone()).collect();
        values = order.iter().map(|&i| values[i]).collect();
        let spread = values[k] - values[0];
        let size =
            simplex[1..].iter().flat_map(|v| v.iter().zip(&simplex[0]).map(|(a, b)| (a - b).abs())).fold(0.0, f64::max);
        if spread <= 1e-13 * (1.0 + values[0].abs()) || size < 1e-10 {
            break;
        }
        let centroid: Vec<f64> = (0..k).map(|j| simplex[..k].iter().map(|v| v[j]).sum::<f64>() / k as f64).collect();
        let towards =
            |t: f64| -> Vec<f64> { clamp((0..k).map(|j| centroid[j] + t * (simplex[k][j] - centroid[j])).collect()) };
        let reflected = towards(-1.0);
        let fr = f(&reflected);
        if fr < values[0] {
            let expanded = towards(-2.0);
            let fe = f(&expanded);
            (simplex[k], values[k]) = if fe < fr { (expanded, fe) } else { (reflected, fr) };
        } else if fr < values[k - 1] {
            (simplex[k], values[k]) = (reflected, fr);
        } else {
            let contracted = if fr < values[k] { towards(-0.5) } else { towards(0.5) };
            let fc = f(&contracted);
            if fc < values[k].min(fr) {
                (simplex[k], values[k]) = (contracted, fc);
            } else {
                for i in 1..=k {
                    simplex[i] = clamp((0..k).map(|j| simplex[0][j] + 0.5 * (simplex[i][j] - simplex[0][j])).collect());
                    values[i] = f(&simplex[i]);
                }
            }
        }
    }
    let best = (0..=k).min_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap_or(0);
    (simplex[best].clone(), values[best])
}

/// Newton steps from the Nelder-Mead optimum `x` on the coordinates not at
/// zero, with gradient and Hessian by central differences, each step taken
/// only if the deviance does not rise. A derivative-free search stops where
/// the deviance is flat to its rounding, which leaves theta about
/// sqrt(1e-13) from the optimum; the gradient's root is a thousand times
/// sharper.
fn polish(f: &mut dyn FnMut(&[f64]) -> f64, mut x: Vec<f64>, mut fx: f64) -> (Vec<f64>, f64) {
    for _ in 0..8 {
        let free: Vec<usize> = (0..x.len()).filter(|&i| x[i] > 0.0).collect();
        let m = free.len();
        if m == 0 {
            break;
        }
        let h: Vec<f64> = free.iter().map(|&i| (1e-4 * x[i].max(1.0)).min(0.5 * x[i])).collect();
        let at = |f: &mut dyn FnMut(&[f64]) -> f64, d: &[(usize, f64)]| {
            let mut y = x.clone();
            for &(j, s) in d {
                y[free[j]] += s;
            }
            f(&y)
        };
        let mut g = Mat::<f64>::zeros(m, 1);
        let mut hess = Mat::<f64>::zeros(m, m);
        for a in 0..m {
            let (fp, fm) = (at(f, &[(a, h[a])]), at(f, &[(a, -h[a])]));
            g[(a, 0)] = (fp - fm) / (2.0 * h[a]);
            hess[(a, a)] = (fp - 2.0 * fx + fm) / (h[a] * h[a]);
            for b in 0..a {
                let pp = at(f, &[(a, h[a]), (b, h[b])]);
                let pm = at(f, &[(a, h[a]), (b, -h[b])]);
                let mp = at(f, &[(a, -h[a]), (b, h[b])]);
                let mm = at(f, &[(a, -h[a]), (b, -h[b])]);
                hess[(a, b)] = (pp - pm - mp + mm) / (4.0 * h[a] * h[b]);
                hess[(b, a)] = hess[(a, b)];
            }
        }
        let Ok(llt) = hess.llt(Side::Lower) else { break };
        let step = llt.solve(&g);
        let mut y = x.clone();
        for (j, &i) in free.iter().enumerate() {
            y[i] = (x[i] - step[(j, 0)]).max(0.0);
        }
        let fy = f(&y);
        let size = (0..m).map(|j| step[(j, 0)].abs()).fold(0.0, f64::max);
        if fy > fx {
            break;
        }
        (x, fx) = (y, fy);
        if size < 1e-12 {
            break;
        }
    }
    (x, fx)
}

/// The REML deviance, not profiled, at `p` = (theta_1..theta_k, sigma),
/// lmerTest's parameterization, and Var(mu) there. The deviance depends on
/// each theta only through theta^2, so it is smooth and even at zero and a
/// difference step may cross it.
fn reml_at(c: &Cross, p: &[f64]) -> Result<(f64, f64), MixedError> {
    let k = p.len() - 1;
    let s2 = p[k] * p[k];
    let e = evaluate(c, &p[..k], Criterion::Reml)?;
    let m = c.n - 1.0;
    let dev = e.log_det_l2 + e.rx2.ln() + m * (2.0 * std::f64::consts::PI * s2).ln() + e.r2 / s2;
    Ok((dev, s2 / e.rx2))
}

/// Satterthwaite df of the intercept at the REML optimum `theta`, `sigma2`,
/// as lmerTest computes them: 2 Var(mu)^2 / (g' A g) with g the gradient of
/// Var(mu) and A = 2 H^-1, H the Hessian of the REML deviance, both in
/// (theta, sigma) and both by central differences. The df do not depend on
/// the parameterization, but the differences do: in the variances
/// sigma^2 theta^2 a small component makes them ill-conditioned, in theta
/// they are not. `None` when H is not positive definite.
fn satterthwaite(c: &Cross, theta: &[f64], sigma2: f64) -> Result<Option<f64>, MixedError> {
    let mut par: Vec<f64> = theta.to_vec();
    par.push(sigma2.sqrt());
    // Free parameters: sigma and every theta not at zero (a singular
    // component is held at zero, as lmerTest holds it).
    let free: Vec<usize> = (0..par.len()).filter(|&i| i == par.len() - 1 || theta[i] >= 1e-4).collect();
    let m = free.len();
    let at = |delta: &[(usize, f64)]| -> Result<(f64, f64), MixedError> {
        let mut p = par.clone();
        for &(j, d) in delta {
            p[free[j]] += d;
        }
        reml_at(c, &p)
    };
    let (f0, v0) = at(&[])?;
    // Central differences with steps of a relative 4e-3 and 2e-3 (of
    // theta, or of 0.1 for theta below 0.1; of sigma), combined by
    // Richardson extrapolation (the O(h^2) errors cancel); smaller steps
    // drown in the rounding of the deviance.
    let derivatives = |rel: f64| -> Result<(Vec<f64>, Mat<f64>), MixedError> {
        let h: Vec<f64> =
            free.iter().map(|&i| if i == par.len() - 1 { rel * par[i] } else { rel * par[i].max(0.1) }).collect();
        let mut grad = vec![0.0; m];
        let mut hess = Mat::<f64>::zeros(m, m);
        for a in 0..m {
            let (fp, vp) = at(&[(a, h[a])])?;
            let (fm, vm) = at(&[(a, -h[a])])?;
            grad[a] = (vp - vm) / (2.0 * h[a]);
            hess[(a, a)] = (fp - 2.0 * f0 + fm) / (h[a] * h[a]);
            for b in 0..a {
                let pp = at(&[(a, h[a]), (b, h[b])])?.0;
                let pm = at(&[(a, h[a]), (b, -h[b])])?.0;
                let mp = at(&[(a, -h[a]), (b, h[b])])?.0;
                let mm = at(&[(a, -h[a]), (b, -h[b])])?.0;
                hess[(a, b)] = (pp - pm - mp + mm) / (4.0 * h[a] * h[b]);
                hess[(b, a)] = hess[(a, b)];
            }
        }
        Ok((grad, hess))
    };
    let (g1, h1) = derivatives(4e-3)?;
    let (g2, h2) = derivatives(2e-3)?;
    let grad: Vec<f64> = g1.iter().zip(&g2).map(|(a, b)| (4.0 * b - a) / 3.0).collect();
    let hess = Mat::<f64>::from_fn(m, m, |i, j| (4.0 * h2[(i, j)] - h1[(i, j)]) / 3.0);
    // A = 2 H^-1 (the deviance is -2 log L); g' A g by a Cholesky solve.
    let Ok(llt) = hess.llt(Side::Lower) else { return Ok(None) };
    let mut g = Mat::<f64>::from_fn(m, 1, |i, _| grad[i]);
    solve_lower_triangular_in_place(llt.L(), g.as_mut(), Par::Seq);
    let gag = 2.0 * (0..m).map(|i| g[(i, 0)] * g[(i, 0)]).sum::<f64>();
    Ok(Some(2.0 * v0 * v0 / gag))
}

/// Kenward-Roger inference for the intercept at the REML optimum, in the
/// q-dimensional space of random-effect levels rather than pbkrtest's n x n
/// matrices. With V = sum_k phi_k Z_k Z_k' + phi_e I, the penalized block
/// C = Lambda'Z'Z Lambda + I, B = Lambda C^-1 Lambda, K = Z'Z and t = Z'1,
/// Woodbury gives
/// V^-1 = (I - Z B Z') / phi_e, hence with w = V^-1 1:
///
/// ```text
/// Z'w = (I - K B) t / phi_e =: u / phi_e       1'w = (n - t'Bt) / phi_e = 1 / Phi
/// Z'V^-1 Z = (K - K B K) / phi_e =: M1 / phi_e  (V^-1 Z)'(V^-1 Z) = (I - K B) M1 / phi_e^2
/// ```
///
/// and every quantity of pbkrtest's `vcovAdj` (P_i = -X'V^-1 G_i V^-1 X,
/// Q_ij = X'V^-1 G_i V^-1 G_j V^-1 X, tr(V^-1 G_i V^-1 G_j), G_k = Z_k Z_k'
/// and G_e = I) follows from q x q products.
///
/// Also returns the shares of Var(mu) = Phi by source, -phi_k Phi P_k
/// (dPhi/dphi_k = -Phi^2 P_k).
fn kenward_roger(c: &Cross, theta: &[f64], sigma2: f64) -> Result<(KenwardRoger, Vec<f64>), MixedError> {
    let q = c.zty.len();
    let k = theta.len();
    let m = k + 1;
    let pe = sigma2;
    let lambda: Vec<f64> = c.factor_of.iter().map(|&f| theta[f]).collect();
    let a = Mat::<f64>::from_fn(q, q, |i, j| lambda[i] * c.ztz[(i, j)] * lambda[j] + if i == j { 1.0 } else { 0.0 });
    let llt = a.llt(Side::Lower).map_err(|_| MixedError::NotPositiveDefinite { theta: theta.to_vec() })?;
    let cinv = llt.inverse();
    let b = Mat::<f64>::from_fn(q, q, |i, j| lambda[i] * cinv[(i, j)] * lambda[j]);
    let kb = &c.ztz * &b;
    let m1 = &c.ztz - &kb * &c.ztz;
    let m2 = &m1 - &kb * &m1;
    let col = |v: &[f64]| Mat::<f64>::from_fn(v.len(), 1, |i, _| v[i]);
    let dot = |x: &Mat<f64>, y: &Mat<f64>| (0..x.nrows()).map(|i| x[(i, 0)] * y[(i, 0)]).sum::<f64>();
    let t = col(&c.zt1);
    let bt = &b * &t;
    let tbt = dot(&t, &bt);
    let u = &t - &kb * &t;
    let bu = &b * &u;
    let kbu = &kb * &u;
    let n = c.n;
    // v = 1 - Z B t, so v'v = n - 2 t'Bt + (Bt)'K(Bt) and (V^-1 w) = (v - Z B u) / phi_e^2.
    let vv = n - 2.0 * tbt + dot(&bt, &(&c.ztz * &bt));
    let ubu = dot(&u, &bu);
    let phi = pe / (n - tbt);
    let block: Vec<Vec<usize>> = (0..k).map(|f| (0..q).filter(|&i| c.factor_of[i] == f).collect()).collect();
    let (pe2, pe3) = (pe * pe, pe * pe * pe);
    let mut p = vec![0.0; m];
    let mut qm = Mat::<f64>::zeros(m, m);
    let mut kt = Mat::<f64>::zeros(m, m);
    for i in 0..k {
        p[i] = -block[i].iter().map(|&a| u[(a, 0)] * u[(a, 0)]).sum::<f64>() / pe2;
        for j in 0..k {
            let mut quad = 0.0;
            let mut frob = 0.0;
            for &a in &block[i] {
                for &b2 in &block[j] {
                    quad += u[(a, 0)] * m1[(a, b2)] * u[(b2, 0)];
                    frob += m1[(a, b2)] * m1[(a, b2)];
                }
            }
            qm[(i, j)] = quad / pe3;
            kt[(i, j)] = frob / pe2;
        }
        let qie = block[i].iter().map(|&a| u[(a, 0)] * (u[(a, 0)] - kbu[(a, 0)])).sum::<f64>() / pe3;
        qm[(i, k)] = qie;
        qm[(k, i)] = qie;
        let tr = block[i].iter().map(|&a| m2[(a, a)]).sum::<f64>() / pe2;
        kt[(i, k)] = tr;
        kt[(k, i)] = tr;
    }
    p[k] = -vv / pe2;
    qm[(k, k)] = (vv - ubu) / pe3;
    let tr_bk: f64 = (0..q).map(|i| kb[(i, i)]).sum();
    let tr_bkbk: f64 = (0..q).flat_map(|i| (0..q).map(move |j| (i, j))).map(|(i, j)| kb[(i, j)] * kb[(j, i)]).sum();
    kt[(k, k)] = (n - 2.0 * tr_bk + tr_bkbk) / pe2;
    // Expected REML information (times 2) and W = 2 IE2^-1; pbkrtest takes
    // a generalized inverse when IE2 is numerically singular.
    let ie2 = Mat::<f64>::from_fn(m, m, |i, j| kt[(i, j)] - 2.0 * phi * qm[(i, j)] + phi * phi * p[i] * p[j]);
    let evd =
        ie2.self_adjoint_eigen(Side::Lower).map_err(|_| MixedError::NotPositiveDefinite { theta: theta.to_vec() })?;
    let (s, vecs) = (evd.S().column_vector(), evd.U());
    let largest = (0..m).map(|i| s[i].abs()).fold(0.0, f64::max);
    let smallest = (0..m).map(|i| s[i].abs()).fold(f64::INFINITY, f64::min);
    let keep = |x: f64| if smallest > 1e-10 { true } else { x.abs() > f64::EPSILON.sqrt() * largest };
    let w = Mat::<f64>::from_fn(m, m, |i, j| {
        2.0 * (0..m).filter(|&l| keep(s[l])).map(|l| vecs[(i, l)] * vecs[(j, l)] / s[l]).sum::<f64>()
    });
    let mut uu = 0.0;
    let mut aa = 0.0;
    for i in 0..m {
        for j in 0..m {
            uu += w[(i, j)] * (qm[(i, j)] - p[i] * phi * p[j]);
            aa += w[(i, j)] * p[i] * p[j];
        }
    }
    let adjusted = phi + 2.0 * phi * uu * phi;
    let variances: Vec<f64> = theta.iter().map(|t| pe * t * t).chain([pe]).collect();
    let shares = (0..m).map(|i| -variances[i] * phi * p[i]).collect();
    Ok((KenwardRoger { se: adjusted.sqrt(), df: 2.0 / (phi * phi * aa) }, shares))
}

/// Fits the model by REML or ML.
pub fn fit(data: &MixedData, criterion: Criterion) -> Result<MixedFit, MixedError> {
    let c = cross(data);
    let k = data.factors.len();
    // Check once that the system factors (it always does for finite data).
    evaluate(&c, &vec![1.0; k], criterion)?;
    let mut evaluations = 0usize;
    let mut dev = |theta: &[f64]| -> f64 {
        evaluations += 1;
        evaluate(&c, theta, criterion).map(|e| e.deviance).unwrap_or(f64::INFINITY)
    };
    let (mut best, mut best_dev) = nelder_mead(&mut dev, &vec![1.0; k], 0.5);
    // Restart from the optimum with a smaller simplex until it stops improving.
    for step in [0.1, 0.03, 0.01, 3e-3, 1e-3, 3e-4, 1e-4] {
        let (t, d) = nelder_mead(&mut dev, &best, step);
        if d < best_dev {
            (best, best_dev) = (t, d);
        }
    }
    (best, best_dev) = polish(&mut dev, best, best_dev);
    // Boundary faces: a theta at exactly zero is where lme4's bounded
    // optimizer stops when the optimum is on the boundary.
    for j in 0..k {
        let mut t = best.clone();
        t[j] = 0.0;
        let d = dev(&t);
        if d <= best_dev {
            (best, best_dev) = (t, d);
        }
    }
    let e = evaluate(&c, &best, criterion)?;
    let total = c.y.iter().map(|v| v * v).sum::<f64>() / (c.n - 1.0);
    if e.sigma2 <= 1e-10 * total {
        return Err(MixedError::ZeroResidual { residual: e.sigma2, total });
    }
    let (kr, shares) = kenward_roger(&c, &best, e.sigma2)?;
    let (df_satterthwaite, kenward_roger) = match criterion {
        Criterion::Reml => (satterthwaite(&c, &best, e.sigma2)?, Some(kr)),
        Criterion::Ml => (None, None),
    };
    Ok(MixedFit {
        shares,
        df_satterthwaite,
        kenward_roger,
        criterion,
        factors: data.factors.iter().map(|f| f.name.clone()).collect(),
        levels: data.factors.iter().map(|f| f.levels).collect(),
        variances: best.iter().map(|t| e.sigma2 * t * t).collect(),
        singular: best.iter().any(|t| *t < 1e-4),
        theta: best,
        residual: e.sigma2,
        intercept: e.intercept,
        se: (e.sigma2 / e.rx2).sqrt(),
        deviance: e.deviance,
        evaluations,
        n: data.len(),
    })
}
