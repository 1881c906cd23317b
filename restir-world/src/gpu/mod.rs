//! GPU plumbing, and the one way every pass in this workspace is written:
//!
//! - [`BindingSet`] declares a bind group's buffers once (name, WGSL type, access): its WGSL
//!   header, its layout, and a bind call checked by name ([`BindGroupLayout::bind`]).
//! - [`WgslModule`] + [`compose`]: modules name what they need; the order is computed.
//!   Constants come from Rust headers (`WORKGROUP_SIZE` from [`workgroup_size_wgsl`]).
//! - [`Kernel`] compiles a composed module on its layouts; [`Kernel::pass`] makes a [`Pass`]
//!   (pipeline + bind groups + grid), so recording a pass is one line.
//! - [`FrameEncoder`] is what a frame records into: `span` (a named timestamp span),
//!   `dispatch`, `upload` (in-encoder staging, so frames record back to back) and `raw` for
//!   primitives that record themselves.
//!
//! Also: [`GpuContext`] (adapter + device), [`GpuTimer`] (timestamp spans) and buffer
//! upload/readback ([`buffers`]).

mod binding;
pub mod buffers;
mod context;
mod frame;
mod kernel;
mod timing;
mod wgsl;

pub use binding::{Access, BindGroupLayout, BindingSet, Resource, count_storage_buffers};
pub use context::{GpuContext, GpuError, IMAGE_TOO_LARGE, OptionalFeatures, Tracer};
pub use frame::FrameEncoder;
pub use kernel::{
    Constants, Kernel, KernelCache, Pass, WORKGROUP_SIZE, dispatch_2d, workgroup_size_wgsl,
};
pub use timing::{GpuTimer, PassTimes, SPANS_PER_SET, SpanTimes};
pub use wgsl::{WgslModule, compose};
