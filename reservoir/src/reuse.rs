//! Reuse: combining a receiver's own (canonical) reservoir with k neighbours' reservoirs, the
//! step every ReSTIR reuse pass shares. The twin of `reuse.wgsl`: the same operations in the
//! same order (see [`Reuse`] for the protocol and [`Combination`] for the modes).

use crate::twin::flush;
use crate::{PackedReservoir, Reservoir};

/// [`Reuse::selected`] when the receiver's own sample is selected (or nothing is).
pub const CANONICAL: u32 = u32::MAX;

/// How a reuse pass weighs the reservoirs it combines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Combination {
    /// The original paper's 1/M: W = w_sum / (M p_hat(y)). Biased (darker) where a neighbour
    /// could not have produced a sample the receiver can use.
    OneOverM = 0,
    /// 1/Z (Bitterli et al. 2020): W = w_sum / (Z p_hat(y)), Z = the M of the receiver and of
    /// every neighbour whose target at y is non-zero. Unbiased.
    OneOverZ = 1,
    /// Pairwise MIS with confidence weights (Bitterli 2022; Wyman et al. 2023): unbiased, and
    /// robust to a sample whose target is far larger at the receiver than where it was drawn.
    Pairwise = 2,
}

impl Combination {
    /// Every mode with its command-line name.
    pub const ALL: [(Combination, &'static str); 3] = [
        (Combination::OneOverM, "biased"),
        (Combination::OneOverZ, "one-over-z"),
        (Combination::Pairwise, "pairwise"),
    ];

    /// The command-line name (`biased`, `one-over-z`, `pairwise`).
    pub fn name(self) -> &'static str {
        Self::ALL[self as usize].1
    }
}

impl std::str::FromStr for Combination {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .iter()
            .find(|(_, n)| *n == s)
            .map(|(c, _)| *c)
            .ok_or_else(|| {
                format!("unknown combination {s:?}; known: biased, one-over-z, pairwise")
            })
    }
}

impl std::fmt::Display for Combination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// `min(m, cap)`: a reused reservoir's confidence, capped.
pub fn cap_m(m: u32, cap: u32) -> u32 {
    m.min(cap)
}

/// `a / (a + b)`, with 0 / 0 = 0, a subnormal quotient flushed to 0.
fn balance(a: f32, b: f32) -> f32 {
    if a + b > 0.0 { flush(a / (a + b)) } else { 0.0 }
}

/// The state of one combination at a receiver (the twin of the WGSL `Reuse`).
///
/// Protocol, for neighbour n's sample `y_n` and the receiver's own `y_c`:
/// 1. [`Reuse::begin`] with the receiver's finalized reservoir, `p_own = p_c(y_c)`, the number
///    k of neighbours to merge and their total capped confidence.
/// 2. [`Reuse::neighbour`] per neighbour, with `p_here = p_c(T(y_n))` (the receiver's target
///    at n's sample, for light samples, which need no shift), or [`Reuse::neighbour_shifted`]
///    with the target at the shifted sample and the shift's Jacobian `|J_n->c|` apart,
///    `p_n_y = p_n(y_n)` and `p_n_own = p_n(T^-1(y_c)) |J_c->n|` (pairwise only).
/// 3. 1/Z only: [`Reuse::count_z`] per neighbour with its target at the selected sample.
/// 4. [`Reuse::finish`]: W and the stored M (the sum of the merged, capped M); then
///    [`Reuse::selected`] names the winner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reuse {
    /// The combination's reservoir; `r.sample` is the selected neighbour's handle or
    /// [`CANONICAL`].
    pub r: Reservoir,
    pub mode: Combination,
    /// The stored confidence: the receiver's M plus the neighbours' capped M.
    pub m_total: u32,
    /// 1/Z: the receiver's M plus every neighbour's that could have produced the selection.
    pub z: u32,
    /// Pairwise: the canonical confidence per neighbour, M_c / k.
    pub m_c: f32,
    /// Pairwise: the canonical sample's MIS weight so far.
    pub canonical: f32,
    pub own_ucw: f32,
    /// The receiver's target at its own sample (0 when it has none).
    pub p_own: f32,
    /// Pairwise: the canonical's random number.
    pub u_own: f32,
    /// The receiver's target at the selected sample (without a shift's Jacobian).
    pub p_hat: f32,
}

impl Reuse {
    /// Starts combining at a receiver with finalized reservoir `own` and target `p_own` at its
    /// sample, `k` neighbours to merge of total confidence `m_neighbours`; `u_own` in [0, 1)
    /// decides the canonical sample. 1/M and 1/Z merge the canonical reservoir now; pairwise
    /// streams it in [`Reuse::finish`].
    pub fn begin(
        mode: Combination,
        own: PackedReservoir,
        p_own: f32,
        k: u32,
        m_neighbours: u32,
        u_own: f32,
    ) -> Self {
        let mut c = Self {
            r: Reservoir::empty(),
            mode,
            m_total: own.m.saturating_add(m_neighbours),
            z: own.m,
            m_c: own.m as f32 / k.max(1) as f32,
            canonical: if k == 0 { 1.0 } else { 0.0 },
            own_ucw: own.ucw,
            p_own: if own.m > 0 { p_own } else { 0.0 },
            u_own,
            p_hat: 0.0,
        };
        if mode != Combination::Pairwise {
            c.r.merge(&own.unpack(CANONICAL), c.p_own, u_own);
            c.p_hat = c.p_own;
        }
        c
    }

    /// Pairwise MIS weights of a neighbour of confidence `m_n`: (its sample's weight, its part
    /// of the canonical sample's weight).
    pub fn pairwise_weights(&self, m_n: f32, p_here: f32, p_n_y: f32, p_n_own: f32) -> [f32; 2] {
        // No confidence at all (every M = 0): no weight.
        let share = if self.m_total > 0 {
            (m_n + self.m_c) / self.m_total as f32
        } else {
            0.0
        };
        // Every product and quotient is flushed where it would be subnormal, as GPUs that
        // flush subnormals do (the WGSL flushes at the same places).
        let (a, b) = (flush(m_n * p_n_y), flush(self.m_c * p_here));
        let (a_own, b_own) = (flush(self.m_c * self.p_own), flush(m_n * p_n_own));
        [
            flush(share * balance(a, b)),
            flush(share * balance(a_own, b_own)),
        ]
    }

    /// Merges neighbour `n`'s finalized reservoir `other` (its W and capped M). Returns true
    /// when its sample is now selected. A neighbour with M = 0 is never selected (in pairwise
    /// mode it leaves its whole share to the canonical sample).
    pub fn neighbour(
        &mut self,
        n: u32,
        other: PackedReservoir,
        p_here: f32,
        p_n_y: f32,
        p_n_own: f32,
        u: f32,
    ) -> bool {
        self.neighbour_shifted(n, other, p_here, 1.0, p_n_y, p_n_own, u)
    }

    /// [`Reuse::neighbour`] for a sample shifted to the receiver with Jacobian `jacobian`
    /// (`|J_n->c|`): `p_target = p_c(T(y_n))` without it. The resampling and MIS weights take
    /// `p_target * jacobian`; the final W divides by `p_target` alone (GRIS: the Jacobian
    /// converts the neighbour's density, not the receiver's target).
    #[allow(clippy::too_many_arguments)]
    pub fn neighbour_shifted(
        &mut self,
        n: u32,
        other: PackedReservoir,
        p_target: f32,
        jacobian: f32,
        p_n_y: f32,
        p_n_own: f32,
        u: f32,
    ) -> bool {
        let p_here = p_target * jacobian;
        let selected = if self.mode == Combination::Pairwise {
            let w = self.pairwise_weights(other.m as f32, p_here, p_n_y, p_n_own);
            self.canonical += w[1];
            self.r.update_slot(flush(w[0] * p_here) * other.ucw, u, n)
        } else {
            self.r.merge(&other.unpack(n), p_here, u)
        };
        if selected {
            self.p_hat = p_target;
        }
        selected
    }

    /// 1/Z: counts a neighbour of capped confidence `m_n` into Z when its target at the
    /// selected sample is non-zero.
    pub fn count_z(&mut self, m_n: u32, p_n_selected: f32) {
        if m_n > 0 && p_n_selected > 0.0 {
            self.z = self.z.saturating_add(m_n);
        }
    }

    /// Pairwise: forgets the neighbours' candidates merged so far (their weights; the total
    /// confidence stays), so that [`Reuse::finish`] selects the canonical sample wherever it has
    /// weight. For a pass that tests the selected neighbour's sample after the merge (one
    /// visibility ray instead of one per neighbour) and finds that it contributes nothing:
    /// pairwise streams the canonical last, so the neighbours' part is a resampled estimate of
    /// its own whose sample, contributing nothing, counts as 0; the combination stays unbiased.
    /// Call it before [`Reuse::finish`].
    pub fn drop_neighbours(&mut self) {
        self.r.w_sum = 0.0;
        self.r.w_sum_err = 0.0;
        self.r.sample = CANONICAL;
        self.p_hat = 0.0;
    }

    /// Ends the combination: the reservoir to store (W, M = the total confidence).
    pub fn finish(&mut self) -> PackedReservoir {
        match self.mode {
            Combination::Pairwise => {
                let w = flush(self.canonical * self.p_own) * self.own_ucw;
                if self.r.update_slot(w, self.u_own, CANONICAL) {
                    self.p_hat = self.p_own;
                }
                self.r.m = 1;
            }
            Combination::OneOverZ if self.p_hat > 0.0 => self.r.m = self.z,
            _ => {}
        }
        self.r.finalize(self.p_hat);
        PackedReservoir {
            ucw: self.r.ucw,
            m: self.m_total,
        }
    }

    /// The selected sample: a neighbour's handle, or [`CANONICAL`].
    pub fn selected(&self) -> u32 {
        self.r.sample
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packed(ucw: f32, m: u32) -> PackedReservoir {
        PackedReservoir { ucw, m }
    }

    /// A selected neighbour dropped before the end leaves the receiver's own sample with its
    /// own weight (W = its pairwise MIS weight x W_own) and the total confidence.
    #[test]
    fn dropped_neighbours_leave_the_canonical_sample() {
        let mut c = Reuse::begin(Combination::Pairwise, packed(2.0, 1), 0.5, 1, 1, 0.99);
        assert!(c.neighbour(0, packed(4.0, 1), 1.0, 1.0, 1.0, 0.0));
        let canonical = c.canonical;
        assert!(canonical > 0.0 && canonical < 1.0);
        c.drop_neighbours();
        let stored = c.finish();
        assert_eq!(c.selected(), CANONICAL);
        assert_eq!(c.p_hat, 0.5);
        assert!((stored.ucw - canonical * 2.0).abs() < 1e-6, "{stored:?}");
        assert_eq!(stored.m, 2);
    }

    #[test]
    fn modes_round_trip_their_names() {
        for (mode, name) in Combination::ALL {
            assert_eq!(name.parse::<Combination>(), Ok(mode));
            assert_eq!(mode.name(), name);
        }
        assert!("bogus".parse::<Combination>().is_err());
    }

    /// A pairwise weight that would be subnormal is 0, as on GPUs that flush subnormals (an
    /// NVIDIA H200 dropped such a neighbour where the unflushed twin selected it).
    #[test]
    fn pairwise_weights_flush_subnormal_quotients() {
        let c = Reuse::begin(Combination::Pairwise, packed(1.0, 1), 1.0, 1, 1, 0.5);
        // Balance 1e-20 : 1e20 (a quotient of 1e-40) for the neighbour's sample.
        let w = c.pairwise_weights(1.0, 1e20, 1e-20, 1.0);
        assert_eq!(w[0], 0.0);
        assert!(w[1].is_normal(), "{}", w[1]);
    }

    /// With no neighbour every mode keeps the receiver's reservoir: W and M unchanged.
    #[test]
    fn no_neighbours_keep_the_canonical_reservoir() {
        for (mode, _) in Combination::ALL {
            let mut c = Reuse::begin(mode, packed(2.5, 16), 0.4, 0, 0, 0.3);
            let out = c.finish();
            assert_eq!(out.m, 16, "{mode}");
            assert!((out.ucw - 2.5).abs() < 1e-6, "{mode}: {}", out.ucw);
            assert_eq!(c.selected(), CANONICAL);
        }
    }

    /// Pairwise: with equal targets everywhere, the k neighbours' weights for a sample plus
    /// the canonical's add up to 1 (MIS weights partition unity).
    #[test]
    fn pairwise_weights_partition_unity() {
        let mut c = Reuse::begin(Combination::Pairwise, packed(1.0, 20), 1.0, 3, 60, 0.5);
        let w = c.pairwise_weights(20.0, 1.0, 1.0, 1.0);
        for n in 0..3 {
            c.neighbour(n, packed(1.0, 20), 1.0, 1.0, 1.0, 0.9);
        }
        // share = (20 + 20/3) / 80 = 1/3; balance 20 : 20/3.
        assert!((w[0] - 0.25).abs() < 1e-6, "{w:?}");
        assert!(
            (3.0 * w[0] + c.canonical - 1.0).abs() < 1e-6,
            "{}",
            c.canonical
        );
    }

    /// A neighbour whose target is zero at the receiver never wins; one whose own target is
    /// zero at its sample takes the whole pairwise weight.
    #[test]
    fn zero_targets_on_either_side() {
        let mut c = Reuse::begin(Combination::Pairwise, packed(1.0, 4), 1.0, 1, 4, 0.99);
        assert!(!c.neighbour(0, packed(5.0, 4), 0.0, 1.0, 1.0, 0.0));
        let d = Reuse::begin(Combination::Pairwise, packed(1.0, 4), 1.0, 1, 4, 0.99);
        let w = d.pairwise_weights(4.0, 1.0, 0.0, 0.0);
        assert_eq!(w, [0.0, 1.0]);
    }

    /// 1/Z counts only neighbours that could have produced the selection; 1/M all of them.
    #[test]
    fn one_over_z_normalizes_by_the_neighbours_that_could_produce_y() {
        let run = |mode, p_n_selected: f32| {
            let mut c = Reuse::begin(mode, packed(1.0, 10), 1.0, 1, 30, 0.5);
            c.neighbour(0, packed(1.0, 30), 1.0, 1.0, 1.0, 0.5);
            c.count_z(30, p_n_selected);
            c.finish().ucw
        };
        let m = run(Combination::OneOverM, 0.0);
        assert!((m - 1.0).abs() < 1e-6);
        assert!((run(Combination::OneOverZ, 1.0) - 1.0).abs() < 1e-6);
        // Z = 10 instead of 40: 4x the weight.
        assert!((run(Combination::OneOverZ, 0.0) - 4.0).abs() < 1e-5);
    }

    #[test]
    fn confidences_saturate_instead_of_wrapping() {
        let mut c = Reuse::begin(
            Combination::OneOverM,
            packed(1.0, u32::MAX - 1),
            1.0,
            1,
            5,
            0.5,
        );
        assert_eq!(c.m_total, u32::MAX);
        c.neighbour(0, packed(1.0, cap_m(5, 3)), 1.0, 0.0, 0.0, 0.5);
        assert_eq!(c.finish().m, u32::MAX);
        assert_eq!(cap_m(320, 20), 20);
    }
}

/// Statistical check of the combination (fixed seeds; the twin, which the GPU matches): a
/// receiver whose target is the integrand f(x) = 1 + x on [0, 1) and three neighbours whose
/// targets are f on [0, 1/2) only (they can never produce samples in [1/2, 1)), each with a
/// reservoir of 8 uniform RIS candidates. f(Y) W must estimate the integral 1.5 for pairwise
/// MIS and 1/Z; the paper's 1/M (the control) must be caught low by the same check.
#[cfg(test)]
mod statistics {
    use super::*;
    use crate::rng::Rng;

    const NEIGHBOURS: u32 = 3;
    const CANDIDATES: u32 = 8;

    fn f(x: f32) -> f32 {
        1.0 + x
    }

    fn p_neighbour(x: f32) -> f32 {
        if x < 0.5 { f(x) } else { 0.0 }
    }

    /// A finalized RIS reservoir of `candidates` uniform candidates for `target`: (W and M,
    /// the sample).
    pub(super) fn ris(
        target: fn(f32) -> f32,
        candidates: u32,
        rng: &mut Rng,
    ) -> (PackedReservoir, f32) {
        let mut r = Reservoir::empty();
        let mut y = 0.0;
        for _ in 0..candidates {
            let x = rng.next_f32();
            if r.update(target(x), rng.next_f32()) {
                y = x;
            }
        }
        r.finalize(target(y));
        (r.pack(), y)
    }

    /// (mean, standard error of the mean) of `trials` draws of `one`.
    pub(super) fn mean_and_error(trials: u32, mut one: impl FnMut() -> f64) -> (f64, f64) {
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..trials {
            let e = one();
            sum += e;
            sum2 += e * e;
        }
        let n = f64::from(trials);
        let mean = sum / n;
        (mean, ((sum2 / n - mean * mean) / n).sqrt())
    }

    /// (mean, standard error) of f(Y) W over `trials` combinations.
    fn estimate(mode: Combination, trials: u32) -> (f64, f64) {
        let mut rng = Rng::seed(7, 0, mode as u32);
        mean_and_error(trials, || {
            let (own, y_own) = ris(f, CANDIDATES, &mut rng);
            let neighbours: Vec<_> = (0..NEIGHBOURS)
                .map(|_| ris(p_neighbour, CANDIDATES, &mut rng))
                .collect();
            let m_n = neighbours.iter().map(|(r, _)| r.m).sum();
            let mut c = Reuse::begin(mode, own, f(y_own), NEIGHBOURS, m_n, rng.next_f32());
            let mut y = y_own;
            for (n, (r, y_n)) in neighbours.iter().enumerate() {
                let (p_here, p_n_y, p_n_own) = (f(*y_n), p_neighbour(*y_n), p_neighbour(y_own));
                if c.neighbour(n as u32, *r, p_here, p_n_y, p_n_own, rng.next_f32()) {
                    y = *y_n;
                }
            }
            for (r, _) in &neighbours {
                c.count_z(r.m, p_neighbour(y));
            }
            let out = c.finish();
            if c.selected() == CANONICAL {
                y = y_own;
            }
            f64::from(f(y) * out.ucw)
        })
    }

    #[test]
    fn unbiased_modes_estimate_the_integral_and_one_over_m_is_caught() {
        const TRIALS: u32 = 100_000;
        for mode in [
            Combination::Pairwise,
            Combination::OneOverZ,
            Combination::OneOverM,
        ] {
            let (mean, se) = estimate(mode, TRIALS);
            // Tolerance: 4 standard errors (about 0.4% here), and the check resolves 1%.
            let z = (mean - 1.5) / se;
            eprintln!("{mode}: mean {mean:.4} (integral 1.5), standard error {se:.4}, z {z:+.1}");
            assert!(4.0 * se < 0.015, "{mode}: too noisy to resolve 1% ({se})");
            match mode {
                Combination::OneOverM => assert!(z < -4.0, "1/M should be caught low: {mean}"),
                _ => assert!(z.abs() < 4.0, "{mode} is biased: {mean}"),
            }
        }
    }
}

/// Statistical check of a shifted reuse (fixed seeds, the twin): three neighbours draw their
/// samples u in [0, 1) in their own domain, which the shift x = T(u) = u^2 (|J| = 2u) maps onto
/// the receiver's; their target is the receiver's integrand carried back, f(u^2) 2u. Pairwise
/// MIS with [`Reuse::neighbour_shifted`] must estimate the integral 1.5 of f(x) = 1 + x; the
/// control, the same reuse with the Jacobian folded into the receiver's target (so W divides
/// by it too), must be caught by the same check.
#[cfg(test)]
mod shifted {
    use super::statistics::{mean_and_error, ris};
    use super::*;
    use crate::rng::Rng;

    const NEIGHBOURS: u32 = 3;
    const CANDIDATES: u32 = 4;

    fn f(x: f32) -> f32 {
        1.0 + x
    }

    fn p_neighbour(u: f32) -> f32 {
        f(u * u) * 2.0 * u
    }

    /// (mean, standard error) of f(Y) W; `folded`: the planted defect.
    fn estimate(folded: bool, trials: u32) -> (f64, f64) {
        let mut rng = Rng::seed(11, 0, u32::from(folded));
        mean_and_error(trials, || {
            let (own, x_own) = ris(f, CANDIDATES, &mut rng);
            let neighbours: Vec<_> = (0..NEIGHBOURS)
                .map(|_| ris(p_neighbour, CANDIDATES, &mut rng))
                .collect();
            let m_n = neighbours.iter().map(|(r, _)| r.m).sum();
            let mut c = Reuse::begin(
                Combination::Pairwise,
                own,
                f(x_own),
                NEIGHBOURS,
                m_n,
                rng.next_f32(),
            );
            let mut x = x_own;
            // The receiver's sample carried to a neighbour: u = sqrt(x), |J_c->n| = 1 / (2u).
            let u_own = x_own.sqrt();
            let p_n_own = if u_own > 0.0 {
                p_neighbour(u_own) / (2.0 * u_own)
            } else {
                0.0
            };
            for (n, (r, u_n)) in neighbours.iter().enumerate() {
                let (x_n, jacobian) = (u_n * u_n, 2.0 * u_n);
                let (target, jacobian) = match folded {
                    false => (f(x_n), jacobian),
                    true => (f(x_n) * jacobian, 1.0),
                };
                let u = rng.next_f32();
                if c.neighbour_shifted(
                    n as u32,
                    *r,
                    target,
                    jacobian,
                    p_neighbour(*u_n),
                    p_n_own,
                    u,
                ) {
                    x = x_n;
                }
            }
            let out = c.finish();
            if c.selected() == CANONICAL {
                x = x_own;
            }
            f64::from(f(x) * out.ucw)
        })
    }

    #[test]
    fn shifted_samples_estimate_the_integral_and_a_folded_jacobian_is_caught() {
        const TRIALS: u32 = 100_000;
        for folded in [false, true] {
            let (mean, se) = estimate(folded, TRIALS);
            // Tolerance: 4 standard errors, and the check resolves 1.5%.
            let z = (mean - 1.5) / se;
            eprintln!("folded {folded}: mean {mean:.4} (integral 1.5), se {se:.4}, z {z:+.1}");
            match folded {
                false => {
                    assert!(4.0 * se < 0.0225, "too noisy to resolve 1.5% ({se})");
                    assert!(z.abs() < 4.0, "shifted reuse is biased: {mean}");
                }
                true => assert!(z.abs() > 4.0, "the folded Jacobian was not caught: {mean}"),
            }
        }
    }
}
