// Reuse: combining a receiver's own (canonical) reservoir with k neighbours' reservoirs, the
// step every ReSTIR reuse pass shares (Bitterli et al. 2020; Bitterli 2022; Wyman et al. 2023).
// Twin: reservoir::reuse::Reuse (same operations in the same order). Needs reservoir.wgsl and
// the REUSE_* constants of reservoir::constants_wgsl().
//
// A pass writes only its target function, its neighbour selection and its shift:
//
//     var c = reuse_begin(mode, own, p_own, k, m_neighbours, u_own);
//     for each neighbour n (M capped with reuse_cap_m): shift its sample to the receiver, then
//         if reuse_neighbour(&c, n, packed_n, p_here, p_n_y, p_n_own, u) { keep n's payload }
//     [1/Z only: for each neighbour, reuse_count_z(&c, m_n, its target at the selected sample)]
//     let stored = reuse_finish(&c);   // W and the stored M
//     if reuse_selected(c) == REUSE_CANONICAL { keep the receiver's payload }
//
// The targets it takes, for neighbour n's sample y_n and the receiver's own sample y_c:
// - p_own   = p_c(y_c): the receiver's target at its own sample;
// - p_here  = p_c(T(y_n)) |J_n->c|: the receiver's target at n's sample shifted to it, times the
//             shift's Jacobian (1 for light samples, which need no shift; a shift with another
//             Jacobian merges with reuse_neighbour_shifted, which keeps the two apart);
// - p_n_y   = p_n(y_n): n's target at its own sample (pairwise only);
// - p_n_own = p_n(T^-1(y_c)) |J_c->n|: n's target at the receiver's sample shifted to n
//             (pairwise only).
//
// Combination modes (mode):
// - REUSE_ONE_OVER_M, the original paper's: W = w_sum / (M p_hat(y)). Biased (darker) where a
//   neighbour could not have produced a sample the receiver can use.
// - REUSE_ONE_OVER_Z (Bitterli et al. 2020): W = w_sum / (Z p_hat(y)), Z = the M of the
//   receiver and of every neighbour whose target at y is non-zero (reuse_count_z). Unbiased.
// - REUSE_PAIRWISE, pairwise MIS with confidence weights: neighbour n shares
//   s_n = (M_n + M_c / k) / T of the unit MIS mass with the canonical reservoir by a
//   two-strategy balance heuristic on confidences M_n and M_c / k (T = M_c + sum M_n). The
//   weights add up to 1 wherever the receiver's target is non-zero: unbiased, and robust to a
//   sample whose target is far larger at the receiver than where it was drawn.
// The stored confidence is always T, the sum of the merged (capped) M.

struct Reuse {
    // The combination's reservoir; r.sample is the selected neighbour's handle n, or
    // REUSE_CANONICAL for the receiver's own sample (and while nothing is selected).
    r: Reservoir,
    mode: u32,
    // T = M_c + sum of the neighbours' capped M: the stored confidence.
    m_total: u32,
    // 1/Z: the receiver's M plus every neighbour's that could have produced the selection.
    z: u32,
    // Pairwise: the canonical confidence per neighbour, M_c / k.
    m_c: f32,
    // Pairwise: the canonical sample's MIS weight so far (1 when k = 0).
    canonical: f32,
    own_ucw: f32,
    // The receiver's target at its own sample (0 when it has none: M_c = 0).
    p_own: f32,
    // Pairwise: the canonical's random number, used by reuse_finish.
    u_own: f32,
    // The receiver's target at the selected sample (without a shift's Jacobian).
    p_hat: f32,
}

// min(m, cap): a reused reservoir's confidence, capped.
fn reuse_cap_m(m: u32, cap: u32) -> u32 {
    return min(m, cap);
}

// a / (a + b), with 0 / 0 = 0, a subnormal quotient flushed to 0.
fn reuse_balance(a: f32, b: f32) -> f32 {
    return select(0.0, reservoir_flush(a / (a + b)), a + b > 0.0);
}

// Starts combining at a receiver whose own finalized reservoir is `own` (W, M) with target
// p_own at its sample, k neighbours to merge of total (capped) confidence m_neighbours, and
// u_own uniform in [0, 1) for the canonical sample's decision. 1/M and 1/Z merge the canonical
// reservoir first; pairwise streams it last, in reuse_finish, with its MIS weight.
fn reuse_begin(mode: u32, own: PackedReservoir, p_own: f32, k: u32, m_neighbours: u32,
               u_own: f32) -> Reuse {
    var c: Reuse;
    c.r = reservoir_empty();
    c.mode = mode;
    c.m_total = reservoir_add_m(own.m, m_neighbours);
    c.z = own.m;
    c.m_c = f32(own.m) / f32(max(k, 1u));
    c.canonical = select(0.0, 1.0, k == 0u);
    c.own_ucw = own.ucw;
    c.p_own = select(0.0, p_own, own.m > 0u);
    c.u_own = u_own;
    c.p_hat = 0.0;
    if mode != REUSE_PAIRWISE {
        var r = c.r;
        reservoir_merge(&r, reservoir_unpack(own, REUSE_CANONICAL), c.p_own, u_own);
        c.r = r;
        c.p_hat = c.p_own;
    }
    return c;
}

// Pairwise MIS weights of neighbour n (confidence m_n) against the canonical reservoir:
// (the weight of n's sample, n's part of the canonical sample's weight).
fn reuse_pairwise_weights(c: Reuse, m_n: f32, p_here: f32, p_n_y: f32, p_n_own: f32) -> vec2<f32> {
    // No confidence at all (every M = 0): no weight.
    // Every product and quotient is flushed where it would be subnormal, as GPUs that flush
    // subnormals do (the twin flushes at the same places).
    let share = select(0.0, (m_n + c.m_c) / f32(c.m_total), c.m_total > 0u);
    let a = reservoir_flush(m_n * p_n_y);
    let b = reservoir_flush(c.m_c * p_here);
    let a_own = reservoir_flush(c.m_c * c.p_own);
    let b_own = reservoir_flush(m_n * p_n_own);
    return vec2<f32>(reservoir_flush(share * reuse_balance(a, b)),
                     reservoir_flush(share * reuse_balance(a_own, b_own)));
}

// Merges neighbour n's finalized reservoir `other` (its W, its capped M), its sample shifted
// to the receiver (see the header for the targets); u uniform in [0, 1). Returns true when n's
// sample is now the selected one: the caller keeps its payload. A neighbour with M = 0 is
// never selected (in pairwise mode it leaves its whole share to the canonical sample).
fn reuse_neighbour(c: ptr<function, Reuse>, n: u32, other: PackedReservoir, p_here: f32,
                   p_n_y: f32, p_n_own: f32, u: f32) -> bool {
    return reuse_neighbour_shifted(c, n, other, p_here, 1.0, p_n_y, p_n_own, u);
}

// reuse_neighbour for a sample shifted to the receiver with Jacobian `jacobian` (|J_n->c|):
// p_target = p_c(T(y_n)) without it. The resampling and MIS weights take p_target * jacobian;
// the final W divides by p_target alone (GRIS: the Jacobian converts the neighbour's density,
// not the receiver's target).
fn reuse_neighbour_shifted(c: ptr<function, Reuse>, n: u32, other: PackedReservoir,
                           p_target: f32, jacobian: f32, p_n_y: f32, p_n_own: f32,
                           u: f32) -> bool {
    let p_here = p_target * jacobian;
    var r = (*c).r;
    var selected: bool;
    if (*c).mode == REUSE_PAIRWISE {
        let w = reuse_pairwise_weights(*c, f32(other.m), p_here, p_n_y, p_n_own);
        (*c).canonical += w.y;
        selected = reservoir_update_slot(&r, reservoir_flush(w.x * p_here) * other.ucw, u, n);
    } else {
        selected = reservoir_merge(&r, reservoir_unpack(other, n), p_here, u);
    }
    (*c).r = r;
    if selected {
        (*c).p_hat = p_target;
    }
    return selected;
}

// 1/Z: counts neighbour n (capped confidence m_n) into Z when its target at the selected
// sample (shifted to n), p_n_selected, is non-zero. Call it for every merged neighbour after
// the last reuse_neighbour; the other modes ignore it.
fn reuse_count_z(c: ptr<function, Reuse>, m_n: u32, p_n_selected: f32) {
    if m_n > 0u && p_n_selected > 0.0 {
        (*c).z = reservoir_add_m((*c).z, m_n);
    }
}

// Pairwise: forgets the neighbours' candidates merged so far (their weights; the confidence T
// stays), so that reuse_finish selects the canonical sample wherever it has weight. For a pass
// that tests the selected neighbour's sample after the merge (one visibility ray instead of
// one per neighbour) and finds that it contributes nothing: pairwise streams the canonical
// last, so the neighbours' part is a resampled estimate of its own whose sample, contributing
// nothing, counts as 0; the combination stays unbiased, and the receiver keeps its own sample
// (W = its weight / p_own) instead of none. Call it before reuse_finish.
fn reuse_drop_neighbours(c: ptr<function, Reuse>) {
    (*c).r.w_sum = 0.0;
    (*c).r.w_sum_err = 0.0;
    (*c).r.sample = REUSE_CANONICAL;
    (*c).p_hat = 0.0;
}

// Ends the combination: pairwise streams the canonical sample with its MIS weight; W is set
// by the mode's normalization. Returns the reservoir to store: W and M = T. The selection is
// then reuse_selected(*c).
fn reuse_finish(c: ptr<function, Reuse>) -> PackedReservoir {
    var r = (*c).r;
    if (*c).mode == REUSE_PAIRWISE {
        let w = reservoir_flush((*c).canonical * (*c).p_own) * (*c).own_ucw;
        if reservoir_update_slot(&r, w, (*c).u_own, REUSE_CANONICAL) {
            (*c).p_hat = (*c).p_own;
        }
        r.m = 1u;
    } else if (*c).mode == REUSE_ONE_OVER_Z && (*c).p_hat > 0.0 {
        r.m = (*c).z;
    }
    reservoir_finalize(&r, (*c).p_hat);
    (*c).r = r;
    return PackedReservoir(r.ucw, (*c).m_total);
}

// The selected sample: a neighbour's handle n, or REUSE_CANONICAL (the receiver's own, or
// nothing when W = 0).
fn reuse_selected(c: Reuse) -> u32 {
    return c.r.sample;
}
