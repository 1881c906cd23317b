// vec4<u32> copy: reads n words and writes n words, the floor for any scan of n words.

override WORKGROUP_SIZE: u32 = 256u;

struct Params {
    n_vec4: u32,
}

@group(0) @binding(0) var<storage, read> src: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> dst: array<vec4<u32>>;
@group(0) @binding(2) var<uniform> params: Params;

@compute @workgroup_size(WORKGROUP_SIZE)
fn copy_vec4(@builtin(global_invocation_id) gid: vec3<u32>,
             @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * WORKGROUP_SIZE;
    if i < params.n_vec4 {
        dst[i] = src[i];
    }
}
