// gpu-scan: single-pass prefix sum of u32 (modulo 2^32) by chained scan with decoupled look-back
// (Merrill & Garland 2016) and a forward-progress fallback (Smith, Levien & Owens, SPAA 2025).
//
// Composed as: constants header + common.wgsl + this file + ONE workgroup-scan variant
// (wg_shared.wgsl or wg_subgroup.wgsl), which defines `scan_t`, `wg_scan` and the entry point.
//
// Each workgroup takes a tile rank from an atomic ticket (never from workgroup_id, so a tile only
// waits on tiles whose workgroups already started), scans its SCAN_TILE elements (each invocation
// a run of SCAN_ITEMS consecutive ones, see scan_tile), publishes its aggregate, looks back over
// its predecessors' published states for its exclusive prefix, publishes its inclusive prefix
// and writes the output.
//
// Tile state: two atomic words per tile, each `flag | 16-bit half of the value`, flags in the
// high bits (0: nothing yet, SCAN_FLAG_AGGREGATE: the tile's sum, SCAN_FLAG_PREFIX: the sum of
// all tiles up to and including it). Every publisher of a given flag publishes the same value
// (sums are unique modulo 2^32) and publishes with atomicMax, so a word never moves backwards.
// A reader trusts a state only when both words carry the same flag.
//
// When a predecessor's state stays empty for more than SCAN_SPIN_LIMIT polls, the workgroup
// reduces that tile's input itself (the fallback), publishes the aggregate with atomicMax and
// looks further back. A stalled workgroup can therefore never block its successors.

@group(0) @binding(0) var<storage, read> scan_in: array<u32>;
@group(0) @binding(1) var<storage, read_write> scan_out: array<u32>;
// [0]: ticket counter; [1 + 2 t], [2 + 2 t]: low and high state words of tile t.
// The host clears it in the same encoder before every scan.
@group(0) @binding(2) var<storage, read_write> scan_scratch: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> scan_total: array<u32>;
@group(0) @binding(4) var<storage, read> scan_params: ScanParams;
// Debug counters (only touched when SCAN_COUNTERS): tiles, look-back steps, failed polls, fallbacks.
@group(0) @binding(5) var<storage, read_write> scan_counters: array<atomic<u32>, 4>;
// The same input and output buffers viewed as vec4s (their first floor(n / 4) * 16 bytes):
// full tiles move their data with one vec4 access per 4 elements, straight between registers
// and memory; only the last, partial tile goes through scalar accesses.
@group(0) @binding(6) var<storage, read> scan_in4: array<vec4<u32>>;
@group(0) @binding(7) var<storage, read_write> scan_out4: array<vec4<u32>>;

// The look-back found the whole prefix (no tile to fall back on).
const SCAN_NO_TILE: u32 = 0xFFFFFFFFu;

// Broadcast slot for values thread 0 finds (ticket, the tile to fall back on, the prefix).
var<workgroup> scan_bcast: vec2<u32>;

fn scan_publish(tile: u32, flag: u32, value: u32) {
    atomicMax(&scan_scratch[1u + 2u * tile], flag | (value & 0xFFFFu));
    atomicMax(&scan_scratch[2u + 2u * tile], flag | (value >> 16u));
}

// Sum of the full tile `tile`, by the whole workgroup (the fallback).
fn scan_reduce_tile(li: u32, tile: u32, vec4_ok: bool) -> u32 {
    var x = 0u;
    if vec4_ok {
        let base4 = tile * (SCAN_TILE / 4u) + li;
        for (var k = 0u; k < SCAN_ITEMS / 4u; k++) {
            let v = scan_in4[base4 + k * SCAN_WG];
            x += v.x + v.y + v.z + v.w;
        }
    } else {
        let base = tile * SCAN_TILE + li;
        for (var k = 0u; k < SCAN_ITEMS; k++) {
            x += scan_in[base + k * SCAN_WG];
        }
    }
    return wg_scan(x).y;
}

// Exclusive prefix of tile `tile` (> 0) from its predecessors' states. Called by the whole
// workgroup. Thread 0 walks back alone, with no barrier per step (as the decoupled-fallback
// paper's single-thread look-back does), until it holds the prefix or a predecessor stayed
// empty for SCAN_SPIN_LIMIT polls; only then does the workgroup meet, to reduce that tile
// (the fallback) or to take the prefix. Every branch after a meeting depends only on
// workgroup-uniform values.
fn scan_lookback(li: u32, tile: u32, vec4_ok: bool) -> u32 {
    var prefix = 0u; // thread 0's running sum
    var j = tile - 1u;
    // Testing knob: with SCAN_SPIN_LIMIT = 0 every tile takes the fallback for its predecessor
    // without polling, then falls back at once on any predecessor that is not ready.
    var force = SCAN_SPIN_LIMIT == 0u;
    var steps = 0u;
    var failed = 0u;
    var fallbacks = 0u;
    loop {
        if li == 0u {
            // The tile the workgroup must reduce, or SCAN_NO_TILE once the prefix is whole.
            var stuck = SCAN_NO_TILE;
            var polls = 0u;
            loop {
                if force {
                    stuck = j;
                    break;
                }
                let lo = atomicLoad(&scan_scratch[1u + 2u * j]);
                let hi = atomicLoad(&scan_scratch[2u + 2u * j]);
                let flag = lo & SCAN_FLAG_MASK;
                // Halves of a publish in progress (flags differ) are not usable yet.
                if flag != 0u && (hi & SCAN_FLAG_MASK) == flag {
                    prefix += (lo & 0xFFFFu) | (hi << 16u);
                    steps += 1u;
                    polls = 0u;
                    if flag == SCAN_FLAG_PREFIX || j == 0u {
                        break;
                    }
                    j -= 1u;
                    continue;
                }
                polls += 1u;
                failed += 1u;
                if polls > SCAN_SPIN_LIMIT {
                    stuck = j;
                    break;
                }
            }
            scan_bcast.x = stuck;
        }
        let stuck = workgroupUniformLoad(&scan_bcast).x;
        if stuck == SCAN_NO_TILE {
            break;
        }
        force = false;
        let agg = scan_reduce_tile(li, stuck, vec4_ok);
        if li == 0u {
            // The sum of tile 0 is its inclusive prefix.
            scan_publish(stuck, select(SCAN_FLAG_AGGREGATE, SCAN_FLAG_PREFIX, stuck == 0u), agg);
            prefix += agg;
            fallbacks += 1u;
        }
        if stuck == 0u {
            break;
        }
        j = stuck - 1u;
    }
    if SCAN_COUNTERS && li == 0u {
        atomicAdd(&scan_counters[1], steps);
        atomicAdd(&scan_counters[2], failed);
        atomicAdd(&scan_counters[3], fallbacks);
    }
    // Thread 0 holds the prefix: one meeting gives it to the workgroup.
    if li == 0u {
        scan_bcast.y = prefix;
    }
    return workgroupUniformLoad(&scan_bcast).y;
}

// One invocation's run of SCAN_ITEMS consecutive elements starting at `run` (a multiple of 4)
// lies inside n and inside the vec4 views: it moves with SCAN_ITEMS / 4 vec4 accesses.
fn scan_run_is_vec4(run: u32, n: u32, len4: u32) -> bool {
    return run + SCAN_ITEMS <= n && run / 4u + SCAN_ITEMS / 4u <= len4;
}

// Thread-coarsened tile: each invocation owns a run of SCAN_ITEMS consecutive elements. Pass 1
// sums its run in registers (no workgroup memory); one workgroup scan of the run sums and the
// look-back give the run's exclusive prefix; pass 2 writes the run's scan from the vec4s it
// kept (SCAN_KEEP_RUN: runs of at most 16 elements, the GPU shapes) or re-reads them (a tile
// is SCAN_TILE * 4 bytes, in cache) (scan_run_sum, scan_run_write). Runs that reach past n (the
// last tile only) or past the vec4 views (indirect scans) take scalar accesses.
fn scan_tile(li: u32) {
    if li == 0u {
        scan_bcast.x = atomicAdd(&scan_scratch[0], 1u);
    }
    let tile = workgroupUniformLoad(&scan_bcast).x;
    let n = min(scan_params.n, min(arrayLength(&scan_in), arrayLength(&scan_out)));
    let num_tiles = scan_num_tiles(n);
    if tile >= num_tiles {
        return; // surplus workgroup of a 2D or indirect dispatch
    }
    // Every full tile lies inside the vec4 views (all tiles before the last are full); the
    // views may be shorter only in the indirect variant, where they are checked.
    let len4 = min(arrayLength(&scan_in4), arrayLength(&scan_out4));
    let vec4_ok = tile * (SCAN_TILE / 4u) + SCAN_TILE / 4u <= len4;

    let run = tile * SCAN_TILE + scan_t * SCAN_ITEMS;
    let fast = scan_run_is_vec4(run, n, len4);
    let local = wg_scan(scan_run_sum(run, n, fast));
    let aggregate = local.y;

    var prefix = 0u;
    if tile == 0u {
        if li == 0u {
            scan_publish(0u, SCAN_FLAG_PREFIX, aggregate);
        }
    } else {
        if li == 0u {
            scan_publish(tile, SCAN_FLAG_AGGREGATE, aggregate);
        }
        prefix = scan_lookback(li, tile, vec4_ok);
        if li == 0u {
            scan_publish(tile, SCAN_FLAG_PREFIX, prefix + aggregate);
        }
    }
    if li == 0u {
        if tile == num_tiles - 1u && scan_params.write_total != 0u {
            scan_total[0] = prefix + aggregate;
        }
        if SCAN_COUNTERS {
            atomicAdd(&scan_counters[0], 1u);
        }
    }

    // Pass 2: the run again, now with its exclusive prefix.
    scan_run_write(run, n, fast, prefix + local.x);
}

// A fast run's vec4s between its sum and its write, where SCAN_KEEP_RUN (GPU shapes).
var<private> scan_kept: array<vec4<u32>, SCAN_KEPT_VEC4S>;

// Pass 1 of a run: the sum of its elements inside n (SCAN_ITEMS / 4 vec4 loads when `fast`,
// kept in registers for pass 2 where SCAN_KEEP_RUN).
fn scan_run_sum(run: u32, n: u32, fast: bool) -> u32 {
    var x = 0u;
    if fast {
        for (var q = 0u; q < SCAN_ITEMS / 4u; q++) {
            let v = scan_in4[run / 4u + q];
            if SCAN_KEEP_RUN {
                scan_kept[q] = v;
            }
            x += (v.x + v.y) + (v.z + v.w);
        }
    } else {
        for (var j = 0u; j < SCAN_ITEMS; j++) {
            if run + j < n {
                x += scan_in[run + j];
            }
        }
    }
    return x;
}

// Pass 2 of a run: its scan from the exclusive prefix `s` (inclusive or exclusive as asked).
fn scan_run_write(run: u32, n: u32, fast: bool, prefix: u32) {
    var s = prefix;
    let inclusive = scan_params.inclusive != 0u;
    if fast {
        let at = run / 4u;
        for (var q = 0u; q < SCAN_ITEMS / 4u; q++) {
            var v: vec4<u32>;
            if SCAN_KEEP_RUN {
                v = scan_kept[q];
            } else {
                v = scan_in4[at + q];
            }
            let a = s + v.x;
            let b = a + v.y;
            let c = b + v.z;
            let d = c + v.w;
            scan_out4[at + q] = select(vec4<u32>(s, a, b, c), vec4<u32>(a, b, c, d), inclusive);
            s = d;
        }
        return;
    }
    for (var j = 0u; j < SCAN_ITEMS; j++) {
        let i = run + j;
        if i < n {
            let next = s + scan_in[i];
            scan_out[i] = select(s, next, inclusive);
            s = next;
        }
    }
}
