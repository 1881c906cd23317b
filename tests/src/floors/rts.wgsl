// Reduce-then-scan prefix sum in three dispatches: the classic baseline a single-pass scan must
// beat. Reads the input twice, writes the output once, plus the tile partials.
// Composed as: constants header (RTS_WG, RTS_ITEMS, SCAN_WG, SCAN_RAKE from rts.rs) +
// gpu-scan's workgroup scan without subgroups (wg_shared.wgsl: `wg_scan`, `scan_t`) + this file.
//   rts_reduce:    partials[tile] = sum of the tile
//   rts_spine:     one workgroup: exclusive scan of the partials in place
//   rts_downsweep: out = partials[tile] + exclusive scan of the tile

struct RtsParams {
    n: u32,
    num_tiles: u32,
}

@group(0) @binding(0) var<storage, read> rts_in: array<u32>;
@group(0) @binding(1) var<storage, read_write> rts_out: array<u32>;
@group(0) @binding(2) var<storage, read_write> rts_partials: array<u32>;
@group(0) @binding(3) var<uniform> rts_params: RtsParams;

const RTS_TILE: u32 = RTS_WG * RTS_ITEMS;

var<workgroup> rts_tile_buf: array<u32, RTS_TILE + RTS_TILE / 32u>;

fn rts_pad(i: u32) -> u32 {
    return i + (i >> 5u);
}

// Where a tile's workgroup is: its thread and its place in the (2D) grid of tiles.
struct TileInvocation {
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
}

fn rts_tile(id: TileInvocation) -> u32 {
    return id.wid.x + id.wid.y * id.groups.x;
}

@compute @workgroup_size(RTS_WG)
fn rts_reduce(id: TileInvocation) {
    let tile = rts_tile(id);
    if tile >= rts_params.num_tiles { return; }
    let li = id.li;
    scan_t = li;
    let base = tile * RTS_TILE;
    var x = 0u;
    for (var k = 0u; k < RTS_ITEMS; k++) {
        let g = base + k * RTS_WG + li;
        if g < rts_params.n {
            x += rts_in[g];
        }
    }
    let r = wg_scan(x);
    if li == 0u {
        rts_partials[tile] = r.y;
    }
}

@compute @workgroup_size(RTS_WG)
fn rts_spine_scan(@builtin(local_invocation_index) li: u32) {
    scan_t = li;
    var carry = 0u;
    let m = rts_params.num_tiles;
    for (var base = 0u; base < m; base += RTS_TILE) {
        var items: array<u32, RTS_ITEMS>;
        var x = 0u;
        for (var j = 0u; j < RTS_ITEMS; j++) {
            let g = base + li * RTS_ITEMS + j;
            if g < m {
                items[j] = rts_partials[g];
            } else {
                items[j] = 0u;
            }
            x += items[j];
        }
        let r = wg_scan(x);
        var s = carry + r.x;
        for (var j = 0u; j < RTS_ITEMS; j++) {
            let g = base + li * RTS_ITEMS + j;
            if g < m {
                rts_partials[g] = s;
            }
            s += items[j];
        }
        carry += r.y;
    }
}

@compute @workgroup_size(RTS_WG)
fn rts_downsweep(id: TileInvocation) {
    let tile = rts_tile(id);
    if tile >= rts_params.num_tiles { return; }
    let li = id.li;
    scan_t = li;
    let base = tile * RTS_TILE;
    let n = rts_params.n;
    for (var k = 0u; k < RTS_ITEMS; k++) {
        let i = k * RTS_WG + li;
        var v = 0u;
        if base + i < n {
            v = rts_in[base + i];
        }
        rts_tile_buf[rts_pad(i)] = v;
    }
    workgroupBarrier();
    var items: array<u32, RTS_ITEMS>;
    var x = 0u;
    for (var j = 0u; j < RTS_ITEMS; j++) {
        items[j] = x; // exclusive within the thread
        x += rts_tile_buf[rts_pad(li * RTS_ITEMS + j)];
    }
    let r = wg_scan(x);
    let offset = rts_partials[tile] + r.x;
    for (var j = 0u; j < RTS_ITEMS; j++) {
        rts_tile_buf[rts_pad(li * RTS_ITEMS + j)] = offset + items[j];
    }
    workgroupBarrier();
    for (var k = 0u; k < RTS_ITEMS; k++) {
        let i = k * RTS_WG + li;
        if base + i < n {
            rts_out[base + i] = rts_tile_buf[rts_pad(i)];
        }
    }
}
