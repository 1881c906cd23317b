//! An f64 reference of the reservoir math, **used only by tests**: no compensation tricks,
//! no saturation, so it tells what the f32 implementations should approximate.
//!
//! Weights pass through the same validity rule as the twin ([`crate::sanitize_weight`]:
//! finite and in [2^-100, f32::MAX], else 0), so comparisons test the
//! arithmetic, not the input filtering.

use crate::NO_SAMPLE;

/// A reservoir in f64.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefReservoir {
    pub w_sum: f64,
    pub m: u64,
    pub ucw: f64,
    pub sample: u32,
}

impl Default for RefReservoir {
    fn default() -> Self {
        Self {
            w_sum: 0.0,
            m: 0,
            ucw: 0.0,
            sample: NO_SAMPLE,
        }
    }
}

impl RefReservoir {
    fn accumulate(&mut self, w: f64, u: f64) -> bool {
        self.w_sum += w;
        w > 0.0 && u * self.w_sum < w
    }

    /// Streams a candidate (the f32 weight is validated as in the twin).
    pub fn update_slot(&mut self, weight: f32, u: f64, slot: u32) -> bool {
        self.m += 1;
        let selected = self.accumulate(f64::from(crate::sanitize_weight(weight)), u);
        if selected {
            self.sample = slot;
        }
        selected
    }

    /// Merges a finalized reservoir: weight `p_hat * W * M`.
    pub fn merge(&mut self, other: &RefReservoir, p_hat: f64, u: f64) -> bool {
        let p = if p_hat.is_finite() && p_hat > 0.0 {
            p_hat
        } else {
            0.0
        };
        let w = p * other.ucw * other.m as f64;
        self.m += other.m;
        let selected = self.accumulate(w, u);
        if selected {
            self.sample = other.sample;
        }
        selected
    }

    /// W = w_sum / (M p_hat), 0 when p_hat or M is 0.
    pub fn finalize(&mut self, p_hat: f64) {
        self.ucw = if p_hat.is_finite() && p_hat > 0.0 && self.m > 0 {
            self.w_sum / (self.m as f64 * p_hat)
        } else {
            0.0
        };
    }

    /// Caps M, scaling the sum so W is unchanged.
    pub fn cap_m(&mut self, cap: u64) {
        if self.m > cap {
            self.w_sum *= cap as f64 / self.m as f64;
            self.m = cap;
        }
    }
}

/// Exact f64 selection probabilities of a stream: `w_i / sum(w)` (invalid weights count 0).
pub fn selection_probabilities(weights: &[f32]) -> Vec<f64> {
    let w: Vec<f64> = weights
        .iter()
        .map(|&x| f64::from(crate::sanitize_weight(x)))
        .collect();
    let total: f64 = w.iter().sum();
    w.iter()
        .map(|&x| if total > 0.0 { x / total } else { 0.0 })
        .collect()
}

/// The probability, computed in f64, that a streaming reservoir ends with its selection in
/// each of `blocks` equal consecutive blocks of the stream, given the running totals it
/// actually used: candidate `i` replaces the selection with probability
/// `min(1, w_i / totals[i])` (totals after adding `w_i`), so
/// `P(final = i) = p_i * prod_{j > i} (1 - p_j)`. With exact totals this is `w_i / sum(w)`;
/// an inaccurate running sum skews it. Compare with [`block_masses`].
///
/// `u_bits`: the resolution of the uniform `u` near 0 (`None`: continuous). With `u` on a grid
/// of `2^-bits`, `P(u < p) = ceil(p 2^bits) / 2^bits`, which inflates small probabilities:
/// 24 bits ([`crate::rng::Rng::next_f32`]) are too coarse for 10^7-long streams, 32 bits
/// ([`crate::rng::Rng::next_f32_fine`]) are fine.
pub fn effective_block_probabilities(
    weights: &[f32],
    totals: &[f32],
    blocks: usize,
    u_bits: Option<i32>,
) -> Vec<f64> {
    assert_eq!(weights.len(), totals.len());
    let n = weights.len();
    let mut out = vec![0.0; blocks];
    let mut survive = 1.0f64; // probability that nothing after i replaces the selection
    for i in (0..n).rev() {
        let w = f64::from(crate::sanitize_weight(weights[i]));
        let t = f64::from(totals[i]);
        let mut p = if w > 0.0 { (w / t).min(1.0) } else { 0.0 };
        if let Some(bits) = u_bits {
            let scale = 2f64.powi(bits);
            p = ((p * scale).ceil() / scale).min(1.0);
        }
        out[i * blocks / n] += p * survive;
        survive *= 1.0 - p;
    }
    out
}

/// The exact f64 share of the total weight in each of `blocks` equal consecutive blocks.
pub fn block_masses(weights: &[f32], blocks: usize) -> Vec<f64> {
    let n = weights.len();
    let mut out = vec![0.0; blocks];
    for (i, &x) in weights.iter().enumerate() {
        out[i * blocks / n] += f64::from(crate::sanitize_weight(x));
    }
    let total: f64 = out.iter().sum();
    out.iter_mut().for_each(|x| *x /= total);
    out
}
