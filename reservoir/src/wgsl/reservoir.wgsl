// Weighted reservoir sampling / resampled importance sampling (RIS) for ReSTIR passes.
// Twin: reservoir::Reservoir (same operations in the same order, so results match bit for bit
// except the one division in reservoir_finalize). The constants (RESERVOIR_*) come from the
// header that reservoir::constants_wgsl() generates; reservoir::wgsl() prepends it.
//
// The sample payload belongs to the caller: every helper that can select a candidate returns
// true when it did, and the caller then copies its own payload. `sample` is an optional u32
// handle (slot / index) that reservoir_update_slot and reservoir_merge maintain for callers
// who identify samples by index.
//
// Numerical contract (see the Rust docs of reservoir::Reservoir for the full text):
// - weights outside [RESERVOIR_WEIGHT_MIN, f32 max] (NaN, +-Inf, negative, zero, subnormal or
//   tiny) count as exactly 0: the candidate is counted in m but never selected;
// - (w_sum, w_sum_err) is a renormalized float-float sum, ~1 ulp over 10^7 updates; it saturates at
//   RESERVOIR_SUM_MAX instead of overflowing;
// - finalize gives ucw = 0 when p_hat is not a positive normal finite f32, m is 0 or nothing
//   was accumulated; ucw is always finite;
// - every stored value is normal or zero, so denormal-flushing GPUs and the twin agree.

struct Reservoir {
    // Compensated sum of the accepted weights: the sum is w_sum + w_sum_err.
    w_sum: f32,
    w_sum_err: f32,
    // Confidence: number of candidates streamed in (saturates at 0xffffffff).
    m: u32,
    // Unbiased contribution weight W of the selected sample, set by reservoir_finalize.
    ucw: f32,
    // Caller's handle of the selected sample, RESERVOIR_NO_SAMPLE when none.
    sample: u32,
}

// Storage form of a finalized reservoir (8 bytes): W and M. The sample's payload is stored by
// the caller, usually at the same index.
struct PackedReservoir {
    ucw: f32,
    m: u32,
}

fn reservoir_empty() -> Reservoir {
    return Reservoir(0.0, 0.0, 0u, 0.0, RESERVOIR_NO_SAMPLE);
}

// x when x is a positive normal finite f32, else 0 (bit test: immune to fast-math NaN folding).
fn reservoir_positive_normal(x: f32) -> f32 {
    let b = bitcast<u32>(x);
    return select(0.0, x, b >= RESERVOIR_MIN_NORMAL_BITS && b < RESERVOIR_INF_BITS);
}

// x with subnormal values replaced by 0 (x is finite; either sign).
fn reservoir_flush(x: f32) -> f32 {
    return select(0.0, x, (bitcast<u32>(x) & 0x7fffffffu) >= RESERVOIR_MIN_NORMAL_BITS);
}

// A weight as the sum sees it: in [RESERVOIR_WEIGHT_MIN, f32 max], else 0.
fn reservoir_weight(x: f32) -> f32 {
    let w = reservoir_positive_normal(x);
    return select(0.0, w, w >= RESERVOIR_WEIGHT_MIN);
}

fn reservoir_total(r: Reservoir) -> f32 {
    return r.w_sum + r.w_sum_err;
}

fn reservoir_add_m(a: u32, b: u32) -> u32 {
    let s = a + b;
    return select(s, 0xffffffffu, s < a);
}

// Adds a weight already passed through reservoir_weight (or 0) to the compensated sum and
// decides whether it replaces the selection: true with probability w / total.
fn reservoir_accumulate(r: ptr<function, Reservoir>, w: f32, u: f32) -> bool {
    let s = (*r).w_sum;
    if w >= RESERVOIR_SUM_MAX - s {
        // The sum would leave the safe range: saturate (documented bias, never Inf).
        (*r).w_sum = RESERVOIR_SUM_MAX;
        (*r).w_sum_err = 0.0;
    } else {
        // Two-sum: t + e == s + w exactly. The max(.., 0.0) are identities here (every term
        // is >= 0 and |c| < ulp(t)) that stop compilers which treat float math as
        // reassociable (e.g. Mesa's NIR) from folding the error terms to 0.
        let t = max(s + w, 0.0);
        var e: f32;
        if s >= w {
            e = (s - t) + w;
        } else {
            e = (w - t) + s;
        }
        // Renormalize (fast two-sum) so the compensation stays below half an ulp of the sum.
        let c = (*r).w_sum_err + e;
        let hi = max(t + c, 0.0);
        (*r).w_sum_err = reservoir_flush(c - (hi - t));
        (*r).w_sum = hi;
    }
    let total = reservoir_total(*r);
    return w > 0.0 && u * total < w;
}

// Streams one candidate of resampling weight `weight` (p_hat / p for RIS); u uniform in [0, 1).
// Returns true when the candidate is now the selected one: the caller copies its payload.
fn reservoir_update(r: ptr<function, Reservoir>, weight: f32, u: f32) -> bool {
    (*r).m = reservoir_add_m((*r).m, 1u);
    return reservoir_accumulate(r, reservoir_weight(weight), u);
}

// reservoir_update that also records `slot` as the selected sample's handle.
fn reservoir_update_slot(r: ptr<function, Reservoir>, weight: f32, u: f32, slot: u32) -> bool {
    let selected = reservoir_update(r, weight, u);
    if selected {
        (*r).sample = slot;
    }
    return selected;
}

// Resampling weight of a finalized reservoir merged at a receiver: p_hat * W * M, with
// subnormal intermediates flushed, overflow saturated and tiny products counted as 0.
fn reservoir_merge_weight(other: Reservoir, p_hat_at_receiver: f32) -> f32 {
    let pw = reservoir_flush(reservoir_positive_normal(p_hat_at_receiver)
        * reservoir_positive_normal(other.ucw));
    let x = pw * f32(other.m);
    let b = bitcast<u32>(x);
    // m = 0 is tested on its own: an overflowed pw (+Inf) times 0 is NaN, not an overflow.
    let w = select(reservoir_weight(x), RESERVOIR_SUM_MAX, b >= RESERVOIR_INF_BITS);
    return select(w, 0.0, other.m == 0u);
}

// Merges the finalized reservoir `other` into r: weight p_hat(other's sample at r) * W * M,
// r.m += other.m. Returns true when other's sample is now selected (the caller copies its
// payload); r.sample becomes other.sample. A reservoir with m = 0 merges as a no-op.
fn reservoir_merge(r: ptr<function, Reservoir>, other: Reservoir, p_hat_at_receiver: f32,
                   u: f32) -> bool {
    let w = reservoir_merge_weight(other, p_hat_at_receiver);
    (*r).m = reservoir_add_m((*r).m, other.m);
    let selected = reservoir_accumulate(r, w, u);
    if selected {
        (*r).sample = other.sample;
    }
    return selected;
}

// W = (w_sum + w_sum_err) / (m * p_hat_selected); 0 when p_hat is not a positive normal finite
// f32, m is 0 or the sum is 0. Overflow gives the largest f32, underflow 0.
fn reservoir_finalize(r: ptr<function, Reservoir>, p_hat_selected: f32) {
    let p = reservoir_positive_normal(p_hat_selected);
    let total = reservoir_total(*r);
    var w = 0.0;
    if p > 0.0 && (*r).m > 0u && total > 0.0 {
        w = total / (f32((*r).m) * p);
    }
    let b = bitcast<u32>(w);
    (*r).ucw = select(reservoir_flush(w), RESERVOIR_F32_MAX, b >= RESERVOIR_INF_BITS);
}

// Caps the confidence at `cap` (e.g. 20x for temporal reuse). The sum is scaled by cap / m so
// that W = w_sum / (m * p_hat) is unchanged: a capped reservoir keeps its estimate and only
// weighs less in later merges. cap = 0 leaves an empty (no-op) reservoir with W kept.
fn reservoir_cap_m(r: ptr<function, Reservoir>, cap: u32) {
    if (*r).m > cap {
        let scale = f32(cap) / f32((*r).m);
        (*r).w_sum = reservoir_flush((*r).w_sum * scale);
        (*r).w_sum_err = reservoir_flush((*r).w_sum_err * scale);
        (*r).m = cap;
    }
}

// Storage form of a finalized reservoir.
fn reservoir_pack(r: Reservoir) -> PackedReservoir {
    return PackedReservoir(r.ucw, r.m);
}

// A finalized reservoir from storage whose sample has handle `slot`. Only m, ucw and sample are
// meaningful (w_sum is 0): merge it into a receiver with reservoir_merge rather than streaming
// into it.
fn reservoir_unpack(p: PackedReservoir, slot: u32) -> Reservoir {
    return Reservoir(0.0, 0.0, p.m, p.ucw, slot);
}
