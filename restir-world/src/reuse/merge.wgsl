// The one merge loop of every reuse (module reuse-merge): restir-di's and world-restir's
// light reservoirs, world-restir's path-vertex reservoirs, restir-gi's and world-restir-gi's
// path samples and the sub-path pass all merge their neighbours here, on the reservoir crate's
// protocol. The stage begins the combination with its canonical reservoir (reuse_begin, with
// reuse_confidence's k and M), calls reuse_merge, and finishes it (reuse_finish or its own
// wrapper). What differs between methods is supplied by the kernel that includes this module,
// for its own receiver type:
// - `struct ReuseReceiver`: what a merge at one receiver needs (its vertex, its own sample,
//   where its neighbours come from);
// - `fn reuse_visit_count(r: ptr<function, ReuseReceiver>) -> u32`: the neighbours the
//   neighbour choice visits;
// - `fn reuse_visited(r: ptr<function, ReuseReceiver>, n: u32) -> ReuseNeighbour`: the n-th
//   (m = 0: visited, not merged);
// - `fn reuse_merge_one(c: ptr<function, Reuse>, n: u32, r: ptr<function, ReuseReceiver>,
//   nb: ReuseNeighbour, u: f32) -> bool`: merges it: the stage's target at the receiver and
//   its shift (the shifted sample, its Jacobian, the visibility it needs), by reuse_neighbour
//   or reuse_neighbour_shifted; true when it is selected;
// - `fn reuse_z_target(r: ptr<function, ReuseReceiver>, nb: ReuseNeighbour, chosen: u32)
//   -> f32`: 1/Z's target at the neighbour's vertex of the selected sample (neighbour
//   `chosen`'s, or the receiver's own for REUSE_NO_NEIGHBOUR).

// A visited neighbour: its source index and its confidence as merged (0: not merged).
struct ReuseNeighbour {
    j: u32,
    m: u32,
}

// reuse_merge's result when no neighbour was selected.
const REUSE_NO_NEIGHBOUR: u32 = 0xffffffffu;

// The merged neighbours' count k and their total confidence (saturating): reuse_begin's.
struct ReuseConfidence {
    k: u32,
    m_sum: u32,
}

fn reuse_confidence(r: ptr<function, ReuseReceiver>) -> ReuseConfidence {
    var s = ReuseConfidence(0u, 0u);
    let count = reuse_visit_count(r);
    for (var n = 0u; n < count; n++) {
        let m = reuse_visited(r, n).m;
        s.k += select(0u, 1u, m > 0u);
        s.m_sum = reservoir_add_m(s.m_sum, m);
    }
    return s;
}

// Merges the receiver's neighbours into c, in the neighbour choice's order, one random number
// each whether it is merged or not (so that what it skips does not move the others' numbers);
// with 1/Z, then counts Z. Returns the source index of the neighbour last selected, or
// REUSE_NO_NEIGHBOUR (the canonical sample may still lose in reuse_finish: pairwise streams it
// last).
fn reuse_merge(c: ptr<function, Reuse>, r: ptr<function, ReuseReceiver>,
               rng: ptr<function, u32>) -> u32 {
    var chosen = REUSE_NO_NEIGHBOUR;
    let count = reuse_visit_count(r);
    for (var n = 0u; n < count; n++) {
        let u = rng_next_f32(rng);
        let nb = reuse_visited(r, n);
        if nb.m > 0u && reuse_merge_one(c, n, r, nb, u) {
            chosen = nb.j;
        }
    }
    if (*c).mode == REUSE_ONE_OVER_Z && (*c).p_hat > 0.0 {
        // Z: the receiver and every merged neighbour whose own vertex could have produced y.
        for (var n = 0u; n < count; n++) {
            let nb = reuse_visited(r, n);
            if nb.m > 0u {
                reuse_count_z(c, nb.m, reuse_z_target(r, nb, chosen));
            }
        }
    }
    return chosen;
}
