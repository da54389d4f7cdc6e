//! The one standard-normal sampler every simulation and the training noise
//! draw from, so that a stream of uniforms maps to the same normals
//! everywhere.

use rand::Rng;

/// A standard normal draw by Box-Muller (cosine branch) from two uniforms:
/// u1 in [f64::MIN_POSITIVE, 1) so that ln(u1) is finite, u2 in [0, 1).
///
/// ```
/// use rand::SeedableRng;
/// let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
/// let n = 20_000;
/// let mean = (0..n).map(|_| crossaudit_stats::standard_normal(&mut rng)).sum::<f64>() / n as f64;
/// assert!(mean.abs() < 4.0 / (n as f64).sqrt()); // 4 standard errors
/// ```
pub fn standard_normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    let u1: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}
