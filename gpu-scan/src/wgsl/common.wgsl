// gpu-scan: what the scan kernel and its indirect pre-pass share. The constants (SCAN_*) come
// from the header Rust generates (`gpu_scan::shaders::constants_header`).

// Per-binding parameters: one small buffer per ScanBinding, so that many scans in one submit
// never share (and overwrite) one parameter block.
struct ScanParams {
    // Number of elements. The indirect pre-pass overwrites it with the length it reads on the GPU.
    n: u32,
    // 1: inclusive scan; 0: exclusive scan.
    inclusive: u32,
    // 1: write the total (sum of all n inputs, modulo 2^32) to `scan_total[0]`.
    write_total: u32,
    // Indirect only: word index of n in the length buffer.
    len_index: u32,
}

// Number of tiles for n elements: at least one, so that n = 0 still writes a total of 0.
fn scan_num_tiles(n: u32) -> u32 {
    return max(1u, n / SCAN_TILE + select(0u, 1u, n % SCAN_TILE != 0u));
}
