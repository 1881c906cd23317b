// gpu-scan workgroup scan without subgroups: raking over the SCAN_WG thread totals in workgroup
// memory (SCAN_WG / SCAN_RAKE threads each scan SCAN_RAKE totals, one thread scans the chunk
// sums). Needs the constants SCAN_WG and SCAN_RAKE; the entry point sets `scan_t` (the
// thread's index in the workgroup) before the first `wg_scan`. Composed after scan.wgsl, with
// wg_shared_main.wgsl; the reduce-then-scan floor of the benchmarks uses it as well.

var<private> scan_t: u32;
var<workgroup> scan_wg_sums: array<u32, SCAN_WG>;
var<workgroup> scan_wg_spine: array<u32, SCAN_WG>;
var<workgroup> scan_wg_total: u32;

// (exclusive prefix of this thread's x among threads 0..scan_t, sum over the workgroup)
fn wg_scan(x: u32) -> vec2<u32> {
    workgroupBarrier(); // the previous call's results have been read
    scan_wg_sums[scan_t] = x;
    workgroupBarrier();
    let chunks = SCAN_WG / SCAN_RAKE;
    if scan_t < chunks {
        var s = 0u;
        for (var r = 0u; r < SCAN_RAKE; r++) {
            let k = scan_t * SCAN_RAKE + r;
            s += scan_wg_sums[k];
            scan_wg_sums[k] = s;
        }
        scan_wg_spine[scan_t] = s;
    }
    workgroupBarrier();
    if scan_t == 0u {
        var s = 0u;
        for (var c = 0u; c < chunks; c++) {
            let v = scan_wg_spine[c];
            scan_wg_spine[c] = s;
            s += v;
        }
        scan_wg_total = s;
    }
    workgroupBarrier();
    let excl = scan_wg_spine[scan_t / SCAN_RAKE] + scan_wg_sums[scan_t] - x;
    return vec2<u32>(excl, scan_wg_total);
}
