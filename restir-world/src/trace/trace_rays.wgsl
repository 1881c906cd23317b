// Kernel: trace a buffer of rays (closest hit or any hit) and write one Hit per ray.
// Composed as: constants header + bvh bindings header (group 1) + trace.wgsl + this file.

struct TraceParams {
    count: u32,
    any_hit: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<storage, read> trace_rays_in: array<Ray>;
@group(0) @binding(1) var<storage, read_write> trace_hits_out: array<Hit>;
@group(0) @binding(2) var<uniform> trace_params: TraceParams;

override WORKGROUP_SIZE: u32 = 64u;

@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_rays(@builtin(global_invocation_id) gid: vec3<u32>,
              @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * WORKGROUP_SIZE;
    if i >= trace_params.count {
        return;
    }
    let ray = trace_rays_in[i];
    trace_hits_out[i] = bvh_traverse(ray, trace_params.any_hit != 0u);
}
