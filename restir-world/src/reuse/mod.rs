//! The one merge loop every reuse method calls (`merge.wgsl`, module `reuse-merge`): a
//! receiver's neighbours merged into its reservoir on the `reservoir` crate's protocol, with
//! the stage's target, shift and neighbour choice as hooks of the kernel that includes it.

use crate::gpu::WgslModule;

/// The loop's WGSL (see its header for the hooks a kernel supplies).
pub const MERGE_WGSL: &str = include_str!("merge.wgsl");

/// The module's name, for a kernel's dependencies.
pub const MERGE: &str = "reuse-merge";

/// The module (after the render library and the reservoir crate's).
pub fn merge_module() -> WgslModule {
    WgslModule::new(MERGE, &["render", "reservoir"], MERGE_WGSL)
}
