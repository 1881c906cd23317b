// Random numbers for ReSTIR passes: a PCG generator (Jarzynski & Olano 2020) whose state is one
// u32, seeded from (index, frame, pass) so GPU and Rust twins can replay the same stream.
// Twin: reservoir::rng::Rng. The multipliers and increments live here and in rng.rs only.

fn rng_pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// State for invocation `index` (pixel or vertex) of `frame`, in `pass`.
fn rng_seed(index: u32, frame: u32, pass_id: u32) -> u32 {
    return rng_pcg(index ^ rng_pcg(frame ^ rng_pcg(pass_id)));
}

fn rng_next_u32(state: ptr<function, u32>) -> u32 {
    *state = *state * 747796405u + 2891336453u;
    let s = *state;
    let word = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1): the top 24 bits, so the result is exact and never rounds up to 1.
fn rng_next_f32(state: ptr<function, u32>) -> f32 {
    return f32(rng_next_u32(state) >> 8u) * (1.0 / 16777216.0);
}

// Uniform in [0, 1) from two words: (hi >> 8) * 2^-24 + (lo >> 8) * 2^-48, rounded to f32 and
// kept below 1. Below 2^-24 its grid is 2^-48, elsewhere it has full f32 precision, so
// P(u < p) is accurate even for tiny p: use it for reservoir decisions in long streams (with
// rng_next_f32's 2^-24 grid, a decision of probability p happens with probability
// ceil(p 2^24) / 2^24, which inflates p < ~2^-12 noticeably).
fn rng_next_f32_fine(state: ptr<function, u32>) -> f32 {
    let hi = rng_next_u32(state) >> 8u;
    let lo = rng_next_u32(state) >> 8u;
    let u = f32(hi) * (1.0 / 16777216.0) + f32(lo) * (1.0 / 281474976710656.0);
    return min(u, 0.99999994);
}
