//! CPU tests of the numerical contract documented on [`Reservoir`], against the f64
//! reference where a reference value exists.

use crate::reference::{self, RefReservoir};
use crate::rng::Rng;
use crate::{NO_SAMPLE, PackedReservoir, Reservoir, SUM_MAX, WEIGHT_MIN};

fn assert_clean(r: &Reservoir) {
    for (name, x) in [
        ("w_sum", r.w_sum),
        ("w_sum_err", r.w_sum_err),
        ("ucw", r.ucw),
    ] {
        assert!(x.is_finite(), "{name} = {x} in {r:?}");
        assert!(
            x == 0.0 || x.is_normal(),
            "{name} = {x} is subnormal in {r:?}"
        );
    }
    assert!(r.w_sum >= 0.0 && r.ucw >= 0.0, "{r:?}");
}

const INVALID: [f32; 9] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    -1.0,
    -0.0,
    0.0,
    1e-40,             // subnormal
    f32::MIN_POSITIVE, // normal but below WEIGHT_MIN
    7.0e-31,           // just below WEIGHT_MIN
];

#[test]
fn invalid_weights_count_as_zero_and_never_poison_the_state() {
    let mut r = Reservoir::empty();
    for (i, &w) in INVALID.iter().enumerate() {
        assert!(!r.update_slot(w, 0.0, i as u32), "weight {w} selected");
        assert_clean(&r);
        assert_eq!(r.total(), 0.0);
    }
    assert_eq!(r.m, INVALID.len() as u32);
    assert_eq!(r.sample, NO_SAMPLE);
    // The first valid weight is selected whatever u is.
    assert!(r.update_slot(2.0, 0.999_999_94, 100));
    for &w in &INVALID {
        assert!(!r.update_slot(w, 0.0, 7));
    }
    assert_eq!((r.total(), r.sample, r.m), (2.0, 100, 19));
    r.finalize(2.0);
    assert_eq!(r.ucw, 1.0 / 19.0);
    assert_clean(&r);
    assert!(!r.update(WEIGHT_MIN * 0.99, 0.0));
    assert!(r.update(WEIGHT_MIN, 0.0));
}

#[test]
fn invalid_p_hat_gives_zero_w() {
    for &p in &INVALID[..7] {
        let mut r = Reservoir::empty();
        r.update(1.0, 0.5);
        r.finalize(p);
        assert_eq!(r.ucw, 0.0, "p_hat = {p}");
    }
    // p_hat must only be a positive normal: tiny but normal p_hat is allowed and gives a
    // large finite W.
    let mut r = Reservoir::empty();
    r.update(1.0, 0.5);
    r.finalize(f32::MIN_POSITIVE);
    assert_eq!(r.ucw, 1.0 / f32::MIN_POSITIVE);
    // A quotient past f32::MAX saturates instead of becoming Inf.
    let mut big = Reservoir::empty();
    big.update(1e30, 0.5);
    big.finalize(f32::MIN_POSITIVE);
    assert_eq!(big.ucw, f32::MAX);
    // All-zero stream: W = 0 whatever p_hat.
    let mut z = Reservoir::empty();
    for _ in 0..10 {
        z.update(0.0, 0.1);
    }
    z.finalize(1.0);
    assert_eq!((z.ucw, z.m, z.sample), (0.0, 10, NO_SAMPLE));
    // m = 0: W = 0.
    let mut e = Reservoir::empty();
    e.finalize(1.0);
    assert_eq!(e.ucw, 0.0);
}

#[test]
fn overflowing_sums_saturate_and_stay_finite() {
    let mut r = Reservoir::empty();
    assert!(r.update(f32::MAX, 0.5));
    assert_eq!(r.total(), SUM_MAX);
    r.update(f32::MAX, 0.5);
    r.update(1e38, 0.9);
    assert_eq!((r.w_sum, r.w_sum_err), (SUM_MAX, 0.0));
    r.finalize(1e-30);
    assert_eq!(r.ucw, f32::MAX);
    assert_clean(&r);
    // Merging it with a large p_hat overflows the product: saturates too.
    let mut s = Reservoir::empty();
    assert!(s.merge(&r, 1e30, 0.3));
    assert_eq!(s.total(), SUM_MAX);
    assert_eq!(s.m, 3);
    s.finalize(1e30);
    assert_clean(&s);
    // Sums just below the limit stay exact.
    let mut t = Reservoir::empty();
    t.update(SUM_MAX / 4.0, 0.5);
    t.update(SUM_MAX / 4.0, 0.5);
    assert_eq!(t.total(), SUM_MAX / 2.0);
}

#[test]
fn tiny_weights_sum_exactly_and_below_the_minimum_count_zero() {
    let mut r = Reservoir::empty();
    let mut rf = RefReservoir::default();
    let mut rng = Rng::seed(1, 2, 3);
    for i in 0..10_000 {
        let w = 1e-30 * (1.0 + rng.next_f32());
        r.update_slot(w, 0.5, i);
        rf.update_slot(w, 0.5, i);
        assert_clean(&r);
    }
    let rel = (f64::from(r.total()) - rf.w_sum).abs() / rf.w_sum;
    assert!(rel < 1e-7, "relative error {rel}");
    let mut lo = Reservoir::empty();
    lo.update(WEIGHT_MIN / 2.0, 0.0);
    assert_eq!(lo.total(), 0.0);
}

#[test]
fn merging_an_m_zero_reservoir_is_a_bitwise_no_op() {
    let mut rng = Rng::seed(5, 0, 0);
    let mut r = Reservoir::empty();
    for i in 0..17 {
        r.update_slot(rng.next_f32() * 3.0, rng.next_f32(), i);
    }
    let before = r;
    for ucw in [0.0, 1.0, f32::NAN, f32::INFINITY, f32::MAX] {
        let zero = Reservoir {
            w_sum: 5.0,
            w_sum_err: 0.0,
            m: 0,
            ucw,
            sample: 999,
        };
        assert!(!r.merge(&zero, 1.0, 0.0));
        assert_eq!(bytemuck::bytes_of(&r), bytemuck::bytes_of(&before));
    }
    // Also into an empty receiver.
    let mut e = Reservoir::empty();
    assert!(!e.merge(&PackedReservoir { ucw: 3.0, m: 0 }.unpack(1), 2.0, 0.0));
    assert_eq!(e, Reservoir::empty());
}

/// Issue 13.1: `p_hat * W` overflowing to +Inf times `m = 0` is NaN, which must not read as an
/// overflow (weight 2^127, the empty reservoir's sample selected): m = 0 contributes 0.
#[test]
fn merging_an_m_zero_reservoir_with_overflowing_p_hat_w_is_a_no_op() {
    let mut a = Reservoir::empty();
    a.update_slot(2.5, 0.1, 3);
    let before = a;
    let zero = Reservoir {
        m: 0,
        ucw: 1e30,
        sample: 9,
        ..Reservoir::empty()
    };
    assert_eq!(Reservoir::merge_weight(&zero, 1e30), 0.0);
    assert!(!a.merge(&zero, 1e30, 0.0));
    assert_eq!(bytemuck::bytes_of(&a), bytemuck::bytes_of(&before));
    assert_eq!(a.sample, 3);

    // The documented chain: W = f32::MAX from finalize, cap_m(0), merge.
    let mut b = Reservoir::empty();
    b.update_slot(1e30, 0.5, 9);
    b.finalize(1e-30);
    assert_eq!(b.ucw, f32::MAX);
    b.cap_m(0);
    assert_eq!(b.m, 0);
    let mut c = before;
    assert!(!c.merge(&b, 1e30, 0.0));
    assert_eq!(bytemuck::bytes_of(&c), bytemuck::bytes_of(&before));
    // The packed form too.
    let mut d = before;
    let packed = PackedReservoir {
        ucw: f32::MAX,
        m: 0,
    };
    assert!(!d.merge(&packed.unpack(9), f32::MAX, 0.0));
    assert_eq!(bytemuck::bytes_of(&d), bytemuck::bytes_of(&before));
}

#[test]
fn merge_with_very_different_m_weighs_by_confidence() {
    // A: m = 1, B: m = 10^6. Merge weights are p_hat * W * M; check the exact weights and the
    // selection frequency of A over many u against the f64 reference probability.
    let a = Reservoir {
        w_sum: 0.0,
        w_sum_err: 0.0,
        m: 1,
        ucw: 3.0,
        sample: 0,
    };
    let b = Reservoir {
        w_sum: 0.0,
        w_sum_err: 0.0,
        m: 1_000_000,
        ucw: 2.5e-6,
        sample: 1,
    };
    let wa = Reservoir::merge_weight(&a, 2.0);
    let wb = Reservoir::merge_weight(&b, 1.5);
    assert_eq!(wa, 6.0);
    assert_eq!(wb, (1.5f32 * 2.5e-6) * 1e6);
    let p_a = 6.0 / (6.0 + f64::from(wb));
    let mut rng = Rng::seed(9, 9, 9);
    let n = 200_000;
    let mut hits = 0;
    for _ in 0..n {
        let mut r = Reservoir::empty();
        r.merge(&b, 1.5, rng.next_f32());
        r.merge(&a, 2.0, rng.next_f32());
        assert_eq!(r.m, 1_000_001);
        hits += u32::from(r.sample == 0);
    }
    let freq = f64::from(hits) / f64::from(n);
    let sigma = (p_a * (1.0 - p_a) / f64::from(n)).sqrt();
    assert!((freq - p_a).abs() < 4.0 * sigma, "{freq} vs {p_a}");
}

#[test]
fn cap_keeps_w_and_scales_the_sum() {
    for cap in [1u32, 20] {
        let mut rng = Rng::seed(cap, 1, 0);
        let mut r = Reservoir::empty();
        for i in 0..1000 {
            r.update_slot(0.1 + rng.next_f32(), rng.next_f32(), i);
        }
        let p = 0.7;
        let mut capped = r;
        capped.cap_m(cap);
        assert_eq!(capped.m, cap);
        assert_eq!(capped.sample, r.sample);
        r.finalize(p);
        capped.finalize(p);
        let rel = ((capped.ucw - r.ucw) / r.ucw).abs();
        assert!(
            rel < 4.0 * f32::EPSILON,
            "cap {cap}: {} vs {}",
            capped.ucw,
            r.ucw
        );
        // Capping below the current m again is a no-op for m <= cap.
        let again = capped;
        capped.cap_m(cap + 5);
        assert_eq!(capped, again);
    }
    let mut r = Reservoir::empty();
    r.update(1.0, 0.5);
    r.cap_m(0);
    assert_eq!((r.m, r.total()), (0, 0.0));
}

#[test]
fn twin_matches_the_f64_reference_away_from_ties() {
    // Streams of weights spanning 1e-30..1e30 plus invalid values; u values too close to a
    // decision boundary (relative margin 1e-4) are redrawn, so f32 and f64 must agree on every
    // selection, and W within 1e-5 relative.
    let mut rng = Rng::seed(11, 0, 0);
    for stream in 0..200 {
        let mut r = Reservoir::empty();
        let mut rf = RefReservoir::default();
        let n = 1 + stream % 64;
        for i in 0..n {
            let w = match rng.next_u32() % 16 {
                0 => INVALID[(rng.next_u32() % 9) as usize],
                _ => 10f32.powf(rng.next_f32() * 60.0 - 30.0),
            };
            let sw = f64::from(crate::sanitize_weight(w));
            let mut u = rng.next_f32();
            let total = rf.w_sum + sw;
            while sw > 0.0 && (f64::from(u) * total - sw).abs() < 1e-4 * sw {
                u = rng.next_f32();
            }
            let a = r.update_slot(w, u, i);
            let b = rf.update_slot(w, f64::from(u), i);
            assert_eq!(a, b, "stream {stream} candidate {i}");
        }
        assert_eq!(r.sample, rf.sample);
        let rel = (f64::from(r.total()) - rf.w_sum).abs() / rf.w_sum.max(1e-300);
        assert!(rel < 1e-6, "stream {stream}: sum rel error {rel}");
        let p = 0.5 + rng.next_f32();
        r.finalize(p);
        rf.finalize(f64::from(p));
        let rel = (f64::from(r.ucw) - rf.ucw).abs() / rf.ucw.max(1e-300);
        assert!(rel < 1e-5, "stream {stream}: W rel error {rel}");
    }
}

/// A 10^7-long stream of weights `x^4` (x uniform): many weights far below the running sum's
/// ulp, where a naive f32 sum drops mass.
fn long_stream(n: usize) -> Vec<f32> {
    let mut rng = Rng::seed(77, 0, 0);
    (0..n)
        .map(|_| {
            let x = rng.next_f32();
            (x * x) * (x * x)
        })
        .collect()
}

fn running_totals(weights: &[f32], naive: bool) -> Vec<f32> {
    let mut r = Reservoir::empty();
    let mut naive_sum = 0.0f32;
    weights
        .iter()
        .map(|&w| {
            if naive {
                naive_sum += crate::sanitize_weight(w);
                naive_sum
            } else {
                r.update(w, 0.5);
                r.total()
            }
        })
        .collect()
}

/// Largest relative error of the effective probability that the selection falls in each of 10
/// blocks of the stream, against the f64 block masses.
fn worst_block_error(weights: &[f32], totals: &[f32], u_bits: Option<i32>) -> f64 {
    let blocks = 10;
    let eff = reference::effective_block_probabilities(weights, totals, blocks, u_bits);
    let exact = reference::block_masses(weights, blocks);
    eff.iter()
        .zip(&exact)
        .map(|(e, x)| (e - x).abs() / x)
        .fold(0.0, f64::max)
}

#[test]
fn ten_million_updates_keep_selection_probabilities() {
    let n = 10_000_000;
    let weights = long_stream(n);
    let exact: f64 = weights.iter().map(|&w| f64::from(w)).sum();
    let totals = running_totals(&weights, false);
    let rel_sum = (f64::from(totals[n - 1]) - exact).abs() / exact;
    assert!(
        rel_sum < 2.0 * f64::from(f32::EPSILON),
        "sum rel error {rel_sum}"
    );
    // Tolerance 1e-7 relative per block (each block holds ~10% of the mass); the float-float
    // sum achieves ~4e-11, a naive f32 sum ~1e-2.
    let err = worst_block_error(&weights, &totals, None);
    assert!(err < 1e-7, "block probability rel error {err}");

    // Negative control: a naive f32 running sum drops the small weights once the sum is large
    // and over-selects late candidates; the same check must catch it.
    let naive = running_totals(&weights, true);
    let naive_err = worst_block_error(&weights, &naive, None);

    // The resolution of u matters as much: late candidates are selected with probability
    // ~1e-7, and u on a 2^-24 grid (Rng::next_f32) turns that into ceil(p 2^24) / 2^24. With
    // the 2^-48 grid of Rng::next_f32_fine the error stays below 1e-6; the 24-bit grid is
    // detected (~0.36).
    let err_fine = worst_block_error(&weights, &totals, Some(48));
    let err24 = worst_block_error(&weights, &totals, Some(24));
    eprintln!("u grid 2^-48: {err_fine:.3e}, 2^-24: {err24:.3e}");
    assert!(err_fine < 1e-6, "fine u: {err_fine}");
    assert!(err24 > 1e-2, "24-bit u not detected: {err24}");
    eprintln!(
        "sum rel error {rel_sum:.3e}, block error {err:.3e}, naive block error {naive_err:.3e}"
    );
    assert!(naive_err > 1e-3, "naive sum not detected: {naive_err}");
}

#[test]
fn pack_round_trip_keeps_w_and_m() {
    let mut r = Reservoir::empty();
    r.update_slot(2.0, 0.3, 4);
    r.update_slot(1.0, 0.9, 5);
    r.finalize(2.0);
    let p = r.pack();
    assert_eq!(size_of::<PackedReservoir>(), 8);
    let u = p.unpack(r.sample);
    assert_eq!((u.ucw, u.m, u.sample), (r.ucw, r.m, r.sample));
    // Merging the unpacked form equals merging the original.
    let (mut a, mut b) = (Reservoir::empty(), Reservoir::empty());
    a.merge(&r, 1.5, 0.2);
    b.merge(&u, 1.5, 0.2);
    assert_eq!(a, b);
}
