// gpu-scan workgroup scan with subgroup operations, for any subgroup size that divides SCAN_WG
// (threads are ranked by (subgroup_id, subgroup_invocation_id), so no layout of subgroups over
// local_invocation_index is assumed). Defines the entry point `scan_main`. Composed after
// scan.wgsl; needs Features::SUBGROUP.

var<private> scan_t: u32;
var<private> scan_lane: u32;
var<private> scan_sg_size: u32;
var<private> scan_sg_id: u32;
var<private> scan_num_sg: u32;
var<workgroup> scan_wg_sums: array<u32, SCAN_WG>;
var<workgroup> scan_wg_total: u32;

// (exclusive prefix of this thread's x among threads 0..scan_t, sum over the workgroup)
fn wg_scan(x: u32) -> vec2<u32> {
    let incl = subgroupInclusiveAdd(x);
    let sub_total = subgroupAdd(x);
    workgroupBarrier(); // the previous call's results have been read
    if scan_lane == 0u {
        scan_wg_sums[scan_sg_id] = sub_total;
    }
    workgroupBarrier();
    if scan_sg_id == 0u {
        // Exclusive scan of the subgroup totals by the first subgroup, scan_sg_size at a time.
        var carry = 0u;
        for (var b = 0u; b < scan_num_sg; b += scan_sg_size) {
            let k = b + scan_lane;
            var v = 0u;
            if k < scan_num_sg {
                v = scan_wg_sums[k];
            }
            let e = subgroupExclusiveAdd(v);
            if k < scan_num_sg {
                scan_wg_sums[k] = carry + e;
            }
            carry += subgroupAdd(v);
        }
        if scan_lane == 0u {
            scan_wg_total = carry;
        }
    }
    workgroupBarrier();
    return vec2<u32>(scan_wg_sums[scan_sg_id] + incl - x, scan_wg_total);
}

@compute @workgroup_size(SCAN_WG)
fn scan_main(
    @builtin(local_invocation_index) li: u32,
    @builtin(subgroup_invocation_id) lane: u32,
    @builtin(subgroup_size) sg_size: u32,
    @builtin(subgroup_id) sg_id: u32,
    @builtin(num_subgroups) num_sg: u32,
) {
    scan_lane = lane;
    scan_sg_size = sg_size;
    scan_sg_id = sg_id;
    scan_num_sg = num_sg;
    scan_t = sg_id * sg_size + lane;
    scan_tile(li);
}
