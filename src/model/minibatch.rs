//! What the fused trainer and dfdx's reference trainer share: the loss of
//! a prediction and the three steps of a minibatch loop that differ
//! between them ([`super::net`]'s early-stopped loop drives either).

/// Mean squared error of predictions against targets, in f64.
pub(super) fn mse_of(out: &[f32], y: &[f32]) -> f64 {
    out.iter().zip(y).map(|(a, b)| f64::from(a - b).powi(2)).sum::<f64>() / y.len() as f64
}

/// What the two trainers do differently; the early-stopped loop of
/// `model::net` does the rest.
pub(super) trait Minibatches {
    /// One optimizer step on `n` rows (x: n x 18, y: n x 14) at `lr`;
    /// returns the batch loss before the step.
    fn step(&mut self, x: &[f32], y: &[f32], n: usize, lr: f64) -> f32;
    /// Mean squared error of the current parameters on the validation set.
    fn val_loss(&mut self, x: &[f32], y: &[f32]) -> f64;
    /// Keeps the current parameters as the best so far.
    fn keep_best(&mut self);
}
