// gpu-hash table, read-only lookup role (no bindings): find with plain loads in a table that
// no invocation of this dispatch writes, e.g. last frame's grid with its own eye and sizes.
// Needs the constants header, hash.wgsl and `gpu_hash::lookup_bindings_wgsl(group,
// first_binding)`, which declares hash_lookup_params, hash_lookup_checksums and
// hash_lookup_counters. Composes with table.wgsl in the same shader (different names).

fn hash_lookup_is_slot(slot: u32) -> bool {
    return slot < HASH_FIRST_SENTINEL;
}

// The slot holding `checksum`, or HASH_NOT_FOUND (stops at the first empty slot).
fn hash_lookup_find(bucket: u32, checksum: u32) -> u32 {
    let spb = hash_lookup_params.slots_per_bucket;
    var b = bucket;
    for (var step = 0u; step < hash_lookup_params.probe_buckets; step++) {
        let base = b * spb;
        for (var i = 0u; i < spb; i++) {
            let current = hash_lookup_checksums[base + i];
            if current == checksum {
                return base + i;
            }
            if current == 0u {
                return HASH_NOT_FOUND;
            }
        }
        b = select(b + 1u, 0u, b + 1u == hash_lookup_params.num_buckets);
    }
    return HASH_NOT_FOUND;
}

// The cell of `pos` under this table's parameters (its eye, its sizes).
fn hash_lookup_cell(pos: vec3<f32>) -> HashCell {
    return hash_cell(hash_lookup_params, pos);
}

// Slot of the cell of `pos`: a slot, HASH_NOT_FOUND or HASH_REJECTED.
fn hash_lookup_position(pos: vec3<f32>) -> u32 {
    let cell = hash_cell(hash_lookup_params, pos);
    if cell.status != HASH_STATUS_OK {
        return HASH_REJECTED;
    }
    return hash_lookup_find(cell.bucket, cell.checksum);
}

// Number of items appended to `slot` when the table was built.
fn hash_lookup_slot_count(slot: u32) -> u32 {
    return hash_lookup_counters[slot];
}
