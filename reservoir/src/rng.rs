//! Random numbers shared by the GPU passes and their twins: a PCG generator (Jarzynski & Olano
//! 2020, "Hash Functions for GPU Rendering") with one `u32` of state, seeded from
//! (index, frame, pass). [`WGSL`] is the GPU side; [`Rng`] replays the same stream bit for bit.
//! `next_f32` has a 2^-24 grid; `next_f32_fine` (two words) is accurate for tiny probabilities.

/// WGSL source of `rng_pcg`, `rng_seed`, `rng_next_u32` and `rng_next_f32`.
pub const WGSL: &str = include_str!("wgsl/rng.wgsl");

/// The PCG hash (RXS-M-XS output of one LCG step).
pub fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The twin of the WGSL generator: same seed, same stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rng {
    pub state: u32,
}

impl Rng {
    /// The stream of invocation `index` (pixel or vertex) in `frame` and `pass`.
    pub fn seed(index: u32, frame: u32, pass: u32) -> Self {
        Self {
            state: pcg(index ^ pcg(frame ^ pcg(pass))),
        }
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        self.state = self
            .state
            .wrapping_mul(747_796_405)
            .wrapping_add(2_891_336_453);
        let s = self.state;
        let word = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277_803_737);
        (word >> 22) ^ word
    }

    /// Uniform in [0, 1), exactly as the WGSL `rng_next_f32`: 24 random bits.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in [0, 1) from two words, exactly as the WGSL `rng_next_f32_fine`: grid 2^-48
    /// below 2^-24 and full f32 precision elsewhere, so `P(u < p)` stays accurate for tiny `p`
    /// (reservoir decisions late in long streams). [`Rng::next_f32`]'s 2^-24 grid makes a
    /// decision of probability `p` happen with probability `ceil(p 2^24) / 2^24`.
    pub fn next_f32_fine(&mut self) -> f32 {
        let hi = self.next_u32() >> 8;
        let lo = self.next_u32() >> 8;
        let u = hi as f32 * (1.0 / 16_777_216.0) + lo as f32 * (1.0 / 281_474_976_710_656.0);
        u.min(0.999_999_94)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg_matches_published_reference_values() {
        // pcg_hash as published by Jarzynski & Olano, evaluated independently (Python,
        // arbitrary-precision integers masked to 32 bits).
        assert_eq!(pcg(0), 129_708_002);
        assert_eq!(pcg(1), 2_831_084_092);
        assert_eq!(pcg(0xdead_beef), 1_730_779_506);
    }

    #[test]
    fn floats_are_in_unit_interval_and_roughly_uniform() {
        let mut rng = Rng::seed(7, 3, 1);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.next_f32();
            assert!((0.0..1.0).contains(&u));
            sum += f64::from(u);
        }
        // Mean of n uniforms has sd 1/sqrt(12 n) ~ 0.0009: 5 sd.
        assert!((sum / f64::from(n) - 0.5).abs() < 0.0046);
    }

    #[test]
    fn fine_floats_are_in_unit_interval_and_resolve_tiny_probabilities() {
        let mut rng = Rng::seed(3, 1, 4);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.next_f32_fine();
            assert!((0.0..1.0).contains(&u));
            sum += f64::from(u);
        }
        assert!((sum / f64::from(n) - 0.5).abs() < 0.0033); // 5 sd
        // The largest value stays below 1; values below 2^-24 keep 2^-48 steps.
        let top = u32::MAX >> 8;
        let u = top as f32 * (1.0 / 16_777_216.0) + top as f32 * (1.0 / 281_474_976_710_656.0);
        assert_eq!(u, 1.0, "the clamp is needed");
        assert_eq!(3.0f32 * (1.0 / 281_474_976_710_656.0), 3.0 * 2f32.powi(-48));
    }

    #[test]
    fn streams_differ_by_index_frame_and_pass() {
        let a = Rng::seed(1, 2, 3).next_u32();
        assert_ne!(a, Rng::seed(2, 2, 3).next_u32());
        assert_ne!(a, Rng::seed(1, 3, 3).next_u32());
        assert_ne!(a, Rng::seed(1, 2, 4).next_u32());
    }
}
