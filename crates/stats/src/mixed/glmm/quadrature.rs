//! Adaptive Gauss-Hermite quadrature of a GLMM with one scalar random
//! effect (glmer's `nAGQ > 1`): each level's integral over its spherical
//! random effect u, centred at the conditional mode u* and scaled by the
//! conditional standard deviation 1 / L_gg (L_gg^2 = 1 + theta^2 sum of
//! the level's GLM weights times z^2, the level's diagonal of
//! Lambda'Z'W Z Lambda + I), is
//!
//! ```text
//! integral of exp(-h_g(u) / 2) du / sqrt(2 pi)
//!   = exp(-h_g(u*) / 2) / L_gg * E_{z ~ N(0,1)} exp(-(h_g(u* + z / L_gg) - h_g(u*)) / 2 + z^2 / 2)
//! ```
//!
//! with h_g(u) = -2 log p(y_g | u) + u^2, and the expectation is taken by
//! the K-point Gauss-Hermite rule for the standard normal (Golub and
//! Welsch's eigenvalues of the Jacobi matrix of the probabilists' Hermite
//! polynomials, lme4's `GHrule`). So -2 log L is the Laplace value less
//! 2 sum_g log M_g, M_g the level's quadrature sum; K = 1 (one node at
//! 0, weight 1) is the Laplace approximation itself.

use faer::{Mat, Side};

/// The most nodes, as glmer allows.
pub const MAX_NAGQ: usize = 25;

/// The K-point Gauss-Hermite rule for E f(z), z ~ N(0, 1): nodes and
/// weights (summing to 1), nodes increasing.
pub(super) fn rule(k: usize) -> Vec<(f64, f64)> {
    if k <= 1 {
        return vec![(0.0, 1.0)];
    }
    // The Jacobi matrix of He_n: x He_n = He_{n+1} + n He_{n-1}.
    let jacobi =
        Mat::<f64>::from_fn(k, k, |i, j| if i == j + 1 || j == i + 1 { (i.max(j) as f64).sqrt() } else { 0.0 });
    let Ok(evd) = jacobi.self_adjoint_eigen(Side::Lower) else {
        return vec![(0.0, 1.0)];
    };
    let (nodes, vectors) = (evd.S().column_vector(), evd.U());
    let mut out: Vec<(f64, f64)> = (0..k).map(|i| (nodes[i], vectors[(0, i)].powi(2))).collect();
    // The middle node of an odd rule is 0 (symmetry), not its rounding.
    if k % 2 == 1 {
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out[k / 2].0 = 0.0;
    }
    let total: f64 = out.iter().map(|w| w.1).sum();
    out.iter_mut().for_each(|w| w.1 /= total);
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rule integrates the normal's moments exactly up to degree
    /// 2K - 1: E z^2 = 1, E z^4 = 3, E z^6 = 15 (closed forms), and its
    /// 3-point nodes are +-sqrt(3) with weights 1/6 and 2/3 (lme4's
    /// GHrule(3)).
    #[test]
    fn the_rule_integrates_normal_moments() {
        let three = rule(3);
        assert!((three[0].0 + 3f64.sqrt()).abs() < 1e-14 && three[1].0 == 0.0);
        assert!((three[0].1 - 1.0 / 6.0).abs() < 1e-14 && (three[1].1 - 2.0 / 3.0).abs() < 1e-14);
        for k in [4, 9, 25] {
            let r = rule(k);
            let moment = |d: i32| r.iter().map(|(z, w)| w * z.powi(d)).sum::<f64>();
            assert!((moment(0) - 1.0).abs() < 1e-13, "{k}");
            assert!(moment(1).abs() < 1e-13, "{k}");
            assert!((moment(2) - 1.0).abs() < 1e-12, "{k}");
            assert!((moment(4) - 3.0).abs() < 1e-11, "{k}");
            assert!((moment(6) - 15.0).abs() < 1e-10, "{k}");
        }
    }
}
