//! The profile-likelihood interval for the grand mean of a complete
//! crossed array under the crossed normal model y = mu + a_i + b_j + e_ij,
//! as lme4's `confint(fit, parm = "(Intercept)", method = "profile")`
//! defines it: lme4 profiles the ML deviance for a fixed effect whatever
//! the fit (its `devfun2` refits with ML), so a REML fit's profile interval
//! for the mean is this one.
//!
//! On a balanced complete array the covariance has four eigenvalues:
//! l_e = s_e (multiplicity (I-1)(J-1)), l_r = s_e + J s_a (I - 1),
//! l_c = s_e + I s_b (J - 1) and l_0 = l_r + l_c - l_e (1, the mean's
//! direction), so the ML deviance less n log(2 pi) is
//!
//! ```text
//! D = (I-1)(J-1) log l_e + (I-1) log l_r + (J-1) log l_c + log l_0
//!     + SS_e / l_e + SS_r / l_r + SS_c / l_c + n (mean - mu)^2 / l_0.
//! ```
//!
//! Writing l = s (1, r, c, r + c - 1) with r, c >= 1, the scale s
//! profiles out in closed form (s = W / n, W the weighted sum of squares),
//! leaving two parameters, searched by Nelder-Mead on r = 1 + x^2,
//! c = 1 + y^2 (even in x and y, so a component at zero is an interior
//! point). The interval is where D_p(mu) - D_min <= z^2, z the normal
//! quantile of the level; D_p depends on mu through (mean - mu)^2 only, so
//! it is symmetric about the mean and one root (found by the Illinois
//! method to a relative 1e-12) gives both limits.

use super::intervals::{IntervalEstimate, IntervalMethod};
use super::mixed::optimize::nelder_mead_even;
use super::{critical_value, mean_squares, CrossedMatrix, StatsError};

/// The sums of squares and sizes the profile needs.
struct Profile {
    n: f64,
    rows: f64,
    cols: f64,
    ss_rows: f64,
    ss_cols: f64,
    ss_error: f64,
}

impl Profile {
    /// The deviance (less n log 2 pi) at ratios r = 1 + x^2, c = 1 + y^2,
    /// the scale profiled out, with q = n (mean - mu)^2.
    fn at(&self, q: f64, x: &[f64]) -> f64 {
        let (r, c) = (1.0 + x[0] * x[0], 1.0 + x[1] * x[1]);
        let l0 = r + c - 1.0;
        let w = self.ss_error + self.ss_rows / r + self.ss_cols / c + q / l0;
        let n = self.n;
        n * (w / n).ln() + n + (self.rows - 1.0) * r.ln() + (self.cols - 1.0) * c.ln() + l0.ln()
    }

    /// The profiled deviance at q, from `start`: (its value, the optimum).
    fn profiled(&self, q: f64, start: &[f64]) -> (f64, Vec<f64>) {
        let mut f = |x: &[f64]| self.at(q, x);
        let step = 0.1 * (1.0 + start[0].abs().max(start[1].abs()));
        let (x, _) = nelder_mead_even(&mut f, start, step, 1e-15);
        // A second search from the first's optimum, with a smaller simplex.
        let (x, fx) = nelder_mead_even(&mut f, &x, 0.01 * step, 1e-15);
        (fx, x)
    }
}

/// The ML profile-likelihood interval for the grand mean of `m` at
/// `level` (see the module's documentation). Its SE is the half-width over
/// z, its df infinite (the cutoff is chi2(1)'s); `boundary` when the ML
/// fit at the mean puts a component at zero. Undefined (every field NaN)
/// when the array has no residual variation.
pub fn profile_interval(m: &CrossedMatrix, level: f64) -> Result<IntervalEstimate, StatsError> {
    let z = critical_value(level, f64::INFINITY)?;
    let ms = mean_squares(m);
    let method = IntervalMethod::ProfileMl;
    if !(ms.ss_error > 0.0 && ms.ss_error.is_finite()) {
        return Ok(IntervalEstimate::undefined(method));
    }
    let p = Profile {
        n: (m.rows() * m.cols()) as f64,
        rows: m.rows() as f64,
        cols: m.cols() as f64,
        ss_rows: ms.ss_rows,
        ss_cols: ms.ss_cols,
        ss_error: ms.ss_error,
    };
    // Start at the ANOVA ratios: l_r / l_e = MS_r / MS_e, l_c / l_e = MS_c / MS_e.
    let ratio = |msx: f64| (msx / ms.ms_error - 1.0).max(0.0).sqrt();
    let (d_min, at_min) = p.profiled(0.0, &[ratio(ms.ms_rows), ratio(ms.ms_cols)]);
    let boundary = at_min.iter().any(|x| x.abs() < 1e-6);
    let excess = |delta: f64, start: &[f64]| -> (f64, Vec<f64>) {
        let (d, x) = p.profiled(p.n * delta * delta, start);
        (d - d_min - z * z, x)
    };
    // Bracket the root in delta = |mu - mean|: from 0 (excess -z^2) out.
    let mom = (ms.ms_rows + ms.ms_cols - ms.ms_error).max(ms.ms_error) / p.n;
    let (mut lo, mut f_lo) = (0.0, -z * z);
    let mut hi = z * mom.sqrt();
    let mut start = at_min.clone();
    let mut f_hi;
    let mut doublings = 0;
    loop {
        let (f, x) = excess(hi, &start);
        f_hi = f;
        if f > 0.0 {
            break;
        }
        (lo, f_lo, start) = (hi, f, x);
        hi *= 2.0;
        doublings += 1;
        if doublings > 200 || !hi.is_finite() {
            return Ok(IntervalEstimate::undefined(method));
        }
    }
    // Illinois: regula falsi, halving the stale end's value.
    let mut side = 0;
    for _ in 0..200 {
        let mid = hi - f_hi * (hi - lo) / (f_hi - f_lo);
        let (f, x) = excess(mid, &start);
        start = x;
        if f > 0.0 {
            (hi, f_hi) = (mid, f);
            if side == 1 {
                f_lo /= 2.0;
            }
            side = 1;
        } else {
            (lo, f_lo) = (mid, f);
            if side == -1 {
                f_hi /= 2.0;
            }
            side = -1;
        }
        if (hi - lo) <= 1e-12 * hi {
            break;
        }
    }
    let delta = 0.5 * (lo + hi);
    let mean = ms.grand_mean;
    Ok(IntervalEstimate {
        method,
        estimate: mean,
        se: delta / z,
        df: f64::INFINITY,
        lower: mean - delta,
        upper: mean + delta,
        boundary,
    })
}
