//! GPU plumbing: device acquisition, timestamp spans, buffer upload and readback.

pub mod buffers;
mod context;
mod timing;

pub use context::{GpuContext, GpuError, OptionalFeatures};
pub use timing::{GpuTimer, SpanTimes};
