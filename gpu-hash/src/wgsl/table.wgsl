// gpu-hash table, read-write role (no bindings): find_or_insert, find, per-slot counters.
// Needs the constants header, hash.wgsl and `gpu_hash::bindings_wgsl(group, first_binding)`,
// which declares hash_params, hash_checksums, hash_counters and hash_stats.
// Slots are numbered bucket * slots_per_bucket + i; checksum 0 marks an empty slot.

// The stats buffer as the kernels update it (Rust twin: gpu_hash::HashStats).
struct HashStatsAtomic {
    overflows: atomic<u32>,
    rejected_nonfinite: atomic<u32>,
    rejected_out_of_range: atomic<u32>,
    max_spill_probe: atomic<u32>,
    used_slots: atomic<u32>,
    max_bucket_fill: atomic<u32>,
    full_buckets: atomic<u32>,
    reserved: u32,
}

fn hash_is_slot(slot: u32) -> bool {
    return slot < HASH_FIRST_SENTINEL;
}

// Records a probe that left its home bucket (only with probe_buckets > 1).
fn hash_note_spill(bucket_step: u32, i: u32) {
    if bucket_step > 0u {
        atomicMax(&hash_stats.max_spill_probe, bucket_step * hash_params.slots_per_bucket + i + 1u);
    }
}

// The slot holding `checksum` in its probe sequence (bucket, then up to probe_buckets - 1
// following buckets), claiming the first empty slot when it is not there yet. A spurious
// compare-exchange failure retries the same slot. When every probed slot holds another
// checksum: returns HASH_FULL, counts an overflow, changes nothing else.
fn hash_find_or_insert(bucket: u32, checksum: u32) -> u32 {
    let spb = hash_params.slots_per_bucket;
    var b = bucket;
    for (var step = 0u; step < hash_params.probe_buckets; step++) {
        let base = b * spb;
        var i = 0u;
        loop {
            if i >= spb {
                break;
            }
            let idx = base + i;
            let current = atomicLoad(&hash_checksums[idx]);
            if current == checksum {
                hash_note_spill(step, i);
                return idx;
            }
            if current == 0u {
                let r = atomicCompareExchangeWeak(&hash_checksums[idx], 0u, checksum);
                if r.exchanged || r.old_value == checksum {
                    hash_note_spill(step, i);
                    return idx;
                }
                if r.old_value == 0u {
                    continue; // spurious failure: retry the same slot
                }
            }
            i += 1u;
        }
        b = select(b + 1u, 0u, b + 1u == hash_params.num_buckets);
    }
    atomicAdd(&hash_stats.overflows, 1u);
    return HASH_FULL;
}

// The slot holding `checksum`, or HASH_NOT_FOUND (stops at the first empty slot).
fn hash_find(bucket: u32, checksum: u32) -> u32 {
    let spb = hash_params.slots_per_bucket;
    var b = bucket;
    for (var step = 0u; step < hash_params.probe_buckets; step++) {
        let base = b * spb;
        for (var i = 0u; i < spb; i++) {
            let current = atomicLoad(&hash_checksums[base + i]);
            if current == checksum {
                return base + i;
            }
            if current == 0u {
                return HASH_NOT_FOUND;
            }
        }
        b = select(b + 1u, 0u, b + 1u == hash_params.num_buckets);
    }
    return HASH_NOT_FOUND;
}

// find_or_insert of the cell of `pos` (jitter it first if wanted). Non-finite and out-of-range
// positions are counted in hash_stats and answer HASH_REJECTED.
fn hash_insert_position(pos: vec3<f32>) -> u32 {
    return hash_insert_cell(hash_cell(hash_params, pos));
}

// find_or_insert of `cell` (hash_cell's, or one whose key the caller changed and re-hashed:
// its bucket and checksum are used as they are). A cell whose status is not HASH_STATUS_OK is
// counted in hash_stats by kind and answers HASH_REJECTED.
fn hash_insert_cell(cell: HashCell) -> u32 {
    if cell.status == HASH_STATUS_NONFINITE {
        atomicAdd(&hash_stats.rejected_nonfinite, 1u);
        return HASH_REJECTED;
    }
    if cell.status == HASH_STATUS_OUT_OF_RANGE {
        atomicAdd(&hash_stats.rejected_out_of_range, 1u);
        return HASH_REJECTED;
    }
    return hash_find_or_insert(cell.bucket, cell.checksum);
}

// find of the cell of `pos`: a slot, HASH_NOT_FOUND or HASH_REJECTED (not counted).
fn hash_find_position(pos: vec3<f32>) -> u32 {
    let cell = hash_cell(hash_params, pos);
    if cell.status != HASH_STATUS_OK {
        return HASH_REJECTED;
    }
    return hash_find(cell.bucket, cell.checksum);
}

// Adds one item to `slot`'s counter and returns the item's index in the slot (Algorithm 2).
fn hash_slot_append(slot: u32) -> u32 {
    return atomicAdd(&hash_counters[slot], 1u);
}

fn hash_slot_count(slot: u32) -> u32 {
    return atomicLoad(&hash_counters[slot]);
}
