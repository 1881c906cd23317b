// Random-access floors (the hash benchmark's): per item one random 128-byte line read
// (`random_read_128`, the find floor) or one random atomic add (`random_atomic`, the insert
// floor), each followed by one coalesced u32 write. Indices come from a pcg hash of the item.
// Composed after the workspace's WORKGROUP_SIZE / Invocation / item_index header.

struct RandomParams {
    n: u32,
    lines: u32,
    words: u32,
    seed: u32,
}

@group(0) @binding(0) var<storage, read> lines: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> words: array<atomic<u32>>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;
@group(0) @binding(3) var<uniform> params: RandomParams;

fn floor_pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn random_read_128(id: Invocation) {
    let i = item_index(id);
    if i >= params.n { return; }
    let base = (floor_pcg(i ^ params.seed) % params.lines) * 8u;
    var acc = vec4<u32>(0u);
    for (var k = 0u; k < 8u; k++) {
        acc ^= lines[base + k];
    }
    out[i] = acc.x ^ acc.y ^ acc.z ^ acc.w;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn random_atomic(id: Invocation) {
    let i = item_index(id);
    if i >= params.n { return; }
    out[i] = atomicAdd(&words[floor_pcg(i ^ params.seed) % params.words], 1u);
}
