//! A random-slope model's exact-fit refusal.

use super::super::MixedError;

/// y = a_g + b_g x exactly, 40 groups of 10: refused before a
/// random-slope fit (`y ~ x + (x | g)`), as the fit refuses it; with
/// noise added, not refused.
#[test]
fn a_response_a_slope_term_reproduces_is_refused_before_the_fit() -> Result<(), MixedError> {
    use super::{fit_slopes, refuse_exact, SlopeData, Term};
    let model = |noise: f64| -> Result<SlopeData, MixedError> {
        let (mut y, mut x, mut g) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..40 {
            for k in 0..10 {
                let xv = ((i * 7 + k * 3) % 11) as f64 - 5.0;
                let (a, b) = (((i * 5) % 9) as f64 * 0.4 - 1.6, ((i * 3) % 7) as f64 * 0.3 - 0.9);
                y.push(a + b * xv + noise * (((i * 31 + k * 17) % 23) as f64 - 11.0));
                x.push(xv);
                g.push(i);
            }
        }
        let base = super::super::MixedData::new(y, vec![("g".into(), g.clone())])?
            .with_columns(vec![("x".into(), x.clone())])?;
        let term = Term {
            group: "g".into(),
            factor: "g".into(),
            codes: g,
            levels: 40,
            names: vec!["(Intercept)".into(), "x".into()],
            columns: vec![vec![1.0; 400], x],
        };
        SlopeData::new(base, vec![term])
    };
    let exact = model(0.0)?;
    assert!(matches!(refuse_exact(&exact.base, &exact.terms), Err(MixedError::ZeroResidual { .. })));
    assert!(matches!(fit_slopes(&exact, super::super::Criterion::Reml, true), Err(MixedError::ZeroResidual { .. })));
    let noisy = model(0.01)?;
    assert!(refuse_exact(&noisy.base, &noisy.terms).is_ok());
    Ok(())
}
