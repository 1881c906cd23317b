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
