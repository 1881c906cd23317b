// gpu-scan indirect pre-pass: reads n from a GPU buffer, clamps it to the scan's capacity, stores
// it in the per-encode parameters and writes the scan's own indirect dispatch arguments.
// Composed as: constants header + common.wgsl + this file.

@group(0) @binding(0) var<storage, read> scan_len: array<u32>;
@group(0) @binding(1) var<storage, read_write> scan_params_rw: ScanParams;
@group(0) @binding(2) var<storage, read_write> scan_dispatch: array<u32, 3>;

@compute @workgroup_size(1)
fn scan_prepare() {
    let n = min(scan_len[scan_params_rw.len_index], SCAN_MAX_LEN);
    scan_params_rw.n = n;
    let tiles = scan_num_tiles(n);
    let x = min(tiles, SCAN_MAX_GROUPS_X);
    scan_dispatch[0] = x;
    scan_dispatch[1] = (tiles + x - 1u) / x;
    scan_dispatch[2] = 1u;
}
