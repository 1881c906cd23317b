// gpu-hash batch kernels: input/output bindings (group 1) shared by batch_insert.wgsl and
// batch_lookup.wgsl. Inputs are vec4<u32>: keys as (bitcast x, y, z, level), points as
// bitcast vec4<f32> (w ignored). Outputs are u32 words at a per-kernel stride.

override WORKGROUP_SIZE: u32 = 256u;

struct BatchParams {
    n: u32,
}

@group(1) @binding(0) var<uniform> batch_params: BatchParams;
@group(1) @binding(1) var<storage, read> batch_in: array<vec4<u32>>;
@group(1) @binding(2) var<storage, read_write> batch_out: array<u32>;

// What every batch kernel takes: where its invocation is in the (2D) grid of workgroups.
struct BatchInvocation {
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
}

// The item of an invocation (the grid is 2D when the items exceed one dimension's groups).
fn batch_index(id: BatchInvocation) -> u32 {
    return id.gid.x + id.gid.y * id.groups.x * WORKGROUP_SIZE;
}

fn batch_key(i: u32) -> HashKey {
    let k = batch_in[i];
    return HashKey(bitcast<vec3<i32>>(k.xyz), k.w);
}
