// vec4<u32> copy: reads n words and writes n words, the floor for any scan of n words.
// Composed after the workspace's WORKGROUP_SIZE / Invocation / item_index header.

struct Params {
    n_vec4: u32,
}

@group(0) @binding(0) var<storage, read> src: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> dst: array<vec4<u32>>;
@group(0) @binding(2) var<uniform> params: Params;

@compute @workgroup_size(WORKGROUP_SIZE)
fn copy_vec4(id: Invocation) {
    let i = item_index(id);
    if i < params.n_vec4 {
        dst[i] = src[i];
    }
}
