// World-space ReSTIR GI's pool parameters (world_pool.wgsl; Rust twin:
// restir_gi::world::PoolParams).

struct WgiPoolParams {
    pixels: u32,
    items: u32,
    capacity: u32,
    max_age: u32,
    reservoir_words: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}
