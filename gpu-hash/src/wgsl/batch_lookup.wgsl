// gpu-hash batch kernels on the read-only lookup view (group 0): find keys or points, cell
// keys, raw hashes and jitter (the last three back the GPU-vs-twin tests).

// out[i] = find(key i): a slot or HASH_NOT_FOUND.
@compute @workgroup_size(WORKGROUP_SIZE)
fn find_keys(id: BatchInvocation) {
    let i = batch_index(id);
    if i >= batch_params.n { return; }
    let key = batch_key(i);
    batch_out[i] = hash_lookup_find(hash_bucket_of(key, hash_lookup_params.num_buckets), hash_checksum_of(key));
}

// out[2i] = slot of point i (or HASH_NOT_FOUND / HASH_REJECTED), out[2i + 1] = items in it.
@compute @workgroup_size(WORKGROUP_SIZE)
fn find_points(id: BatchInvocation) {
    let i = batch_index(id);
    if i >= batch_params.n { return; }
    let slot = hash_lookup_position(bitcast<vec4<f32>>(batch_in[i]).xyz);
    var count = 0u;
    if hash_lookup_is_slot(slot) {
        count = hash_lookup_slot_count(slot);
    }
    batch_out[2u * i] = slot;
    batch_out[2u * i + 1u] = count;
}

// out[8i..8i+8] = HashCell of point i (coords, level, bucket, checksum, cell_size bits, status).
@compute @workgroup_size(WORKGROUP_SIZE)
fn cells(id: BatchInvocation) {
    let i = batch_index(id);
    if i >= batch_params.n { return; }
    let c = hash_lookup_cell(bitcast<vec4<f32>>(batch_in[i]).xyz);
    let o = 8u * i;
    batch_out[o] = bitcast<u32>(c.coords.x);
    batch_out[o + 1u] = bitcast<u32>(c.coords.y);
    batch_out[o + 2u] = bitcast<u32>(c.coords.z);
    batch_out[o + 3u] = c.level;
    batch_out[o + 4u] = c.bucket;
    batch_out[o + 5u] = c.checksum;
    batch_out[o + 6u] = bitcast<u32>(c.cell_size);
    batch_out[o + 7u] = c.status;
}

// out[2i] = pcg(in[i].x), out[2i + 1] = xxhash32(in[i].x).
@compute @workgroup_size(WORKGROUP_SIZE)
fn hash_values(id: BatchInvocation) {
    let i = batch_index(id);
    if i >= batch_params.n { return; }
    let v = batch_in[i].x;
    batch_out[2u * i] = hash_pcg(v);
    batch_out[2u * i + 1u] = hash_xxhash32(v);
}

// Item i reads in[3i] = position, in[3i + 1] = normal, in[3i + 2] = (u.x, u.y, cell_size):
// out[4i..4i+3] = jittered position.
@compute @workgroup_size(WORKGROUP_SIZE)
fn jitter(id: BatchInvocation) {
    let i = batch_index(id);
    if i >= batch_params.n { return; }
    let p = bitcast<vec4<f32>>(batch_in[3u * i]).xyz;
    let n = bitcast<vec4<f32>>(batch_in[3u * i + 1u]).xyz;
    let u = bitcast<vec4<f32>>(batch_in[3u * i + 2u]).xyz;
    let j = hash_jitter(p, n, u.xy, u.z);
    batch_out[4u * i] = bitcast<u32>(j.x);
    batch_out[4u * i + 1u] = bitcast<u32>(j.y);
    batch_out[4u * i + 2u] = bitcast<u32>(j.z);
    batch_out[4u * i + 3u] = 0u;
}
