// Kernel: trace a buffer of rays (closest hit or any hit) and write one Hit per ray.
// Composed by `trace::kernel_source` (needs the trace library, its bindings at group 1, and
// the io bindings of `trace::io_bindings` at group 0).

struct TraceParams {
    count: u32,
    any_hit: u32,
    _pad0: u32,
    _pad1: u32,
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn trace_rays(id: Invocation) {
    let i = item_index(id);
    if i >= trace_params.count { return; }
    let ray = trace_rays_in[i];
    trace_hits_out[i] = bvh_traverse(ray, trace_params.any_hit != 0u);
}
