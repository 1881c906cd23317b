// gpu-hash batch kernels on the read-write table (group 0): insert keys or points, table stats.

// out[i] = find_or_insert(key i): a slot or HASH_FULL.
@compute @workgroup_size(WORKGROUP_SIZE)
fn insert_keys(id: BatchInvocation) {
    let i = batch_index(id);
    if i >= batch_params.n { return; }
    let key = batch_key(i);
    batch_out[i] = hash_find_or_insert(hash_bucket_of(key, hash_params.num_buckets), hash_checksum_of(key));
}

// out[2i] = slot of point i (or HASH_FULL / HASH_REJECTED), out[2i + 1] = its index in the
// slot (Algorithm 2's atomic counter), HASH_NOT_FOUND when there is no slot.
@compute @workgroup_size(WORKGROUP_SIZE)
fn insert_points(id: BatchInvocation) {
    let i = batch_index(id);
    if i >= batch_params.n { return; }
    let slot = hash_insert_position(bitcast<vec4<f32>>(batch_in[i]).xyz);
    var index = HASH_NOT_FOUND;
    if hash_is_slot(slot) {
        index = hash_slot_append(slot);
    }
    batch_out[2u * i] = slot;
    batch_out[2u * i + 1u] = index;
}

var<workgroup> stats_used: atomic<u32>;
var<workgroup> stats_max_fill: atomic<u32>;
var<workgroup> stats_full: atomic<u32>;

// One invocation per bucket: used slots, fullest bucket, number of full buckets.
@compute @workgroup_size(WORKGROUP_SIZE)
fn table_stats(id: BatchInvocation, @builtin(local_invocation_index) local: u32) {
    let bucket = batch_index(id);
    let spb = hash_params.slots_per_bucket;
    if bucket < hash_params.num_buckets {
        var fill = 0u;
        for (var s = 0u; s < spb; s++) {
            if atomicLoad(&hash_checksums[bucket * spb + s]) != 0u {
                fill += 1u;
            }
        }
        atomicAdd(&stats_used, fill);
        atomicMax(&stats_max_fill, fill);
        if fill == spb {
            atomicAdd(&stats_full, 1u);
        }
    }
    workgroupBarrier();
    if local == 0u {
        atomicAdd(&hash_stats.used_slots, atomicLoad(&stats_used));
        atomicMax(&hash_stats.max_bucket_fill, atomicLoad(&stats_max_fill));
        atomicAdd(&hash_stats.full_buckets, atomicLoad(&stats_full));
    }
}
