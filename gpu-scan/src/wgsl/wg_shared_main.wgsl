// The entry point of the scan kernel without subgroups (with wg_shared.wgsl).

@compute @workgroup_size(SCAN_WG)
fn scan_main(@builtin(local_invocation_index) li: u32) {
    scan_t = li;
    scan_tile(li);
}
