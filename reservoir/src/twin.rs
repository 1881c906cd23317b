//! The Rust twin of `reservoir.wgsl`: the same operations in the same order.

use crate::{INF_BITS, MIN_NORMAL_BITS, NO_SAMPLE, SUM_MAX, WEIGHT_MIN};

/// A weighted reservoir (the twin of the WGSL `Reservoir`, same layout, so GPU tests can read
/// reservoirs back directly).
///
/// # Numerical contract
///
/// Both the WGSL helpers and this twin follow it; the tests check each clause.
///
/// - **Invalid weights count as 0.** A weight enters the sum only if it is a finite f32 in
///   [[`WEIGHT_MIN`] = 2^-100, `f32::MAX`]. NaN, ±Inf, negative values, ±0, subnormals and
///   positive values below 2^-100 count as exactly 0: the candidate still counts in `m` (it was
///   drawn), it is never selected, and the state is never poisoned. The tests use bit patterns
///   (`bitcast<u32>` in WGSL), so this holds under fast-math compilers too.
/// - **`u`** must be in [0, 1). A candidate of weight `w > 0` is selected when
///   `u * total < w`, where `total` is the sum after adding `w`; the first positive weight is
///   always selected. (NaN `u` never selects.) A decision of probability `p` happens with
///   probability `P(u < p)`, so `u` must resolve the smallest `p` that matters: on a 2^-24 grid
///   (`rng_next_f32`) a decision of probability `p` happens with probability
///   `ceil(p 2^24) / 2^24`, which inflates `p < ~2^-12` (late candidates of long streams, tiny
///   weights next to huge ones). `rng_next_f32_fine` (grid 2^-48 near 0) keeps 10^7-long
///   streams within 2e-8 of the exact selection probabilities.
/// - **Compensated sum.** `(w_sum, w_sum_err)` is a float-float sum (Neumaier two-sum of each
///   weight, then renormalized so `|w_sum_err| <= ulp(w_sum) / 2`): its relative error stays
///   around one f32 ulp for any stream length (a naive f32 sum over 10^7 weights of very
///   different sizes loses whole percent of the mass, which skews the selection probabilities
///   of late candidates; see the crate's 10^7-update tests).
/// - **Overflow saturates.** When a weight would lift the sum to [`SUM_MAX`] = 2^127 or beyond,
///   the sum is set to exactly `SUM_MAX` (and the compensation to 0). From then on selections
///   are computed against `SUM_MAX`: biased, but finite. No Inf or NaN is ever stored. Keep
///   total weights below 2^127 (scale the target function) for unbiased results.
/// - **Subnormals never appear** in the stored state: every product or compensation term that
///   could be subnormal is flushed to 0, so GPUs that flush subnormals (FTZ/DAZ) and the twin
///   compute identical sums.
/// - **`m`** is a `u32` count (exact, saturating at `u32::MAX`). It enters products as
///   `m as f32`, exact up to 2^24. Fractional confidences are not supported.
/// - **Merge** (`merge(other, p_hat, u)`) uses weight `p_hat * other.ucw * other.m` (in that
///   order, the product of the first two flushed), with `p_hat` and `ucw` counted as 0 unless
///   positive normal finite; a product that overflows saturates at `SUM_MAX`, one below
///   `WEIGHT_MIN` counts as 0. `m += other.m`. A reservoir with `m = 0` (or `ucw = 0`, or
///   `p_hat = 0`) contributes weight 0; with `m = 0` the merge leaves the receiver bit for bit
///   unchanged.
/// - **Finalize** sets `ucw = total / (m * p_hat)`, and `ucw = 0` when `p_hat` is not a
///   positive normal finite f32, `m = 0` or `total = 0`. A quotient that overflows becomes
///   `f32::MAX`, one that underflows to a subnormal becomes 0.
/// - **M cap** (`cap_m(cap)`): when `m > cap`, the sum and its compensation are scaled by
///   `cap / m` and `m = cap`, so `total / (m * p_hat)`, i.e. W, is unchanged: a capped reservoir
///   keeps its estimate and only weighs less in later merges. `cap = 0` leaves a reservoir that
///   merges as a no-op.
///
/// Agreement with the GPU: additions, multiplications and comparisons are correctly rounded
/// in WGSL, so `w_sum`, `w_sum_err`, `m`, `sample` and every selection match bit for bit on
/// streams without exact ties; the divisions in `finalize` and `cap_m` may differ by a few ulp
/// (WGSL allows 2.5 ulp), which can flip a later selection only when `u * total` lies within
/// a few ulp of `w`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Reservoir {
    /// Compensated sum of the accepted weights: the sum is `w_sum + w_sum_err`.
    pub w_sum: f32,
    /// The compensation term of the sum.
    pub w_sum_err: f32,
    /// Confidence: number of candidates streamed in (merges add the other's `m`).
    pub m: u32,
    /// Unbiased contribution weight W of the selected sample (set by [`Reservoir::finalize`]).
    pub ucw: f32,
    /// The caller's handle of the selected sample, [`NO_SAMPLE`] when none.
    pub sample: u32,
}

/// The 8-byte storage form of a finalized reservoir (twin of the WGSL `PackedReservoir`):
/// W and M. The sample's payload lives in the caller's own buffer, usually at the same index.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PackedReservoir {
    /// Unbiased contribution weight W.
    pub ucw: f32,
    /// Confidence M.
    pub m: u32,
}

impl PackedReservoir {
    /// The finalized reservoir this stores, whose sample has handle `slot` (only `m`, `ucw`
    /// and `sample` are meaningful: merge it into a receiver rather than streaming into it).
    pub fn unpack(self, slot: u32) -> Reservoir {
        Reservoir {
            w_sum: 0.0,
            w_sum_err: 0.0,
            m: self.m,
            ucw: self.ucw,
            sample: slot,
        }
    }
}

impl Default for Reservoir {
    fn default() -> Self {
        Self::empty()
    }
}

/// `x` if it is a positive normal finite f32, else 0.
pub(crate) fn positive_normal(x: f32) -> f32 {
    let b = x.to_bits();
    if (MIN_NORMAL_BITS..INF_BITS).contains(&b) {
        x
    } else {
        0.0
    }
}

/// `x` with subnormals replaced by 0.
pub(crate) fn flush(x: f32) -> f32 {
    if x.to_bits() & 0x7fff_ffff >= MIN_NORMAL_BITS {
        x
    } else {
        0.0
    }
}

/// A weight as the sum sees it: in [`WEIGHT_MIN`, `f32::MAX`], else 0.
pub fn sanitize_weight(x: f32) -> f32 {
    let w = positive_normal(x);
    if w >= WEIGHT_MIN { w } else { 0.0 }
}

impl Reservoir {
    /// No candidates yet.
    pub const fn empty() -> Self {
        Self {
            w_sum: 0.0,
            w_sum_err: 0.0,
            m: 0,
            ucw: 0.0,
            sample: NO_SAMPLE,
        }
    }

    /// The compensated weight sum `w_sum + w_sum_err`.
    pub fn total(&self) -> f32 {
        self.w_sum + self.w_sum_err
    }

    /// Whether a candidate has been selected (a handle was recorded).
    pub fn has_sample(&self) -> bool {
        self.sample != NO_SAMPLE
    }

    fn accumulate(&mut self, w: f32, u: f32) -> bool {
        let s = self.w_sum;
        if w >= SUM_MAX - s {
            self.w_sum = SUM_MAX;
            self.w_sum_err = 0.0;
        } else {
            // Two-sum: t + e == s + w exactly. The max(.., 0.0) are identities (see the WGSL:
            // they keep GPU compilers from folding the error terms away).
            let t = (s + w).max(0.0);
            let e = if s >= w { (s - t) + w } else { (w - t) + s };
            // Renormalize (fast two-sum, |t| >= |c|) so the compensation stays below half an
            // ulp of the sum and never accumulates rounding of its own.
            let c = self.w_sum_err + e;
            let hi = (t + c).max(0.0);
            self.w_sum_err = flush(c - (hi - t));
            self.w_sum = hi;
        }
        let total = self.total();
        w > 0.0 && u * total < w
    }

    /// Streams one candidate of resampling weight `weight` (`p_hat / p` for RIS) with `u`
    /// uniform in [0, 1). Returns true when the candidate is now the selected one.
    pub fn update(&mut self, weight: f32, u: f32) -> bool {
        self.m = self.m.saturating_add(1);
        self.accumulate(sanitize_weight(weight), u)
    }

    /// [`Reservoir::update`] that also records `slot` as the selected sample's handle.
    pub fn update_slot(&mut self, weight: f32, u: f32, slot: u32) -> bool {
        let selected = self.update(weight, u);
        if selected {
            self.sample = slot;
        }
        selected
    }

    /// The resampling weight of the finalized reservoir `other` at a receiver where its
    /// sample has target value `p_hat_at_receiver`: `p_hat * W * M` (see the contract).
    pub fn merge_weight(other: &Reservoir, p_hat_at_receiver: f32) -> f32 {
        if other.m == 0 {
            // Tested first: Inf * 0 is NaN, which must not read as an overflow below.
            return 0.0;
        }
        let pw = flush(positive_normal(p_hat_at_receiver) * positive_normal(other.ucw));
        let x = pw * other.m as f32;
        if x.to_bits() >= INF_BITS {
            SUM_MAX
        } else {
            sanitize_weight(x)
        }
    }

    /// Merges the finalized reservoir `other` (weight `p_hat * W * M`, `m += other.m`).
    /// Returns true when `other`'s sample is now selected; `sample` becomes `other.sample`.
    pub fn merge(&mut self, other: &Reservoir, p_hat_at_receiver: f32, u: f32) -> bool {
        let w = Self::merge_weight(other, p_hat_at_receiver);
        self.m = self.m.saturating_add(other.m);
        let selected = self.accumulate(w, u);
        if selected {
            self.sample = other.sample;
        }
        selected
    }

    /// Sets W = `total / (m * p_hat_selected)` (0 when `p_hat` is invalid, `m = 0` or the sum
    /// is 0; overflow gives `f32::MAX`).
    pub fn finalize(&mut self, p_hat_selected: f32) {
        let p = positive_normal(p_hat_selected);
        let total = self.total();
        let w = if p > 0.0 && self.m > 0 && total > 0.0 {
            total / (self.m as f32 * p)
        } else {
            0.0
        };
        self.ucw = if w.to_bits() >= INF_BITS {
            f32::MAX
        } else {
            flush(w)
        };
    }

    /// Caps `m` at `cap`, scaling the sum by `cap / m` so that W stays the same.
    pub fn cap_m(&mut self, cap: u32) {
        if self.m > cap {
            let scale = cap as f32 / self.m as f32;
            self.w_sum = flush(self.w_sum * scale);
            self.w_sum_err = flush(self.w_sum_err * scale);
            self.m = cap;
        }
    }

    /// The storage form (W and M).
    pub fn pack(&self) -> PackedReservoir {
        PackedReservoir {
            ucw: self.ucw,
            m: self.m,
        }
    }
}
