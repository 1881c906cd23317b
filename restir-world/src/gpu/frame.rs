//! [`FrameEncoder`]: what a frame is recorded into: the caller's encoder, optional timestamp
//! spans, and the passes.

use super::{GpuTimer, Pass};

/// The caller's command encoder and optional timer, as one frame records into them.
///
/// `span` names a stage (a timestamp span when a timer is given), `dispatch` records a
/// [`Pass`], `upload` stages small data inside the encoder (so frames with different cameras
/// can be recorded back to back), and [`FrameEncoder::raw`] hands the encoder to primitives
/// that record themselves (scan, clears, copies).
#[derive(Debug)]
pub struct FrameEncoder<'a> {
    encoder: &'a mut wgpu::CommandEncoder,
    timer: Option<&'a mut GpuTimer>,
    device: &'a wgpu::Device,
    /// Compute dispatches recorded through it (a frame's fixed cost on a GPU).
    dispatches: u32,
}

impl<'a> FrameEncoder<'a> {
    pub fn new(
        device: &'a wgpu::Device,
        encoder: &'a mut wgpu::CommandEncoder,
        timer: Option<&'a mut GpuTimer>,
    ) -> Self {
        Self {
            encoder,
            timer,
            device,
            dispatches: 0,
        }
    }

    /// The compute dispatches recorded through this encoder so far.
    pub fn dispatches(&self) -> u32 {
        self.dispatches
    }

    /// Records `body` as the stage `name`.
    pub fn span<R>(&mut self, name: &str, body: impl FnOnce(&mut Self) -> R) -> R {
        let open = self
            .timer
            .as_deref_mut()
            .map(|t| t.begin(self.encoder, name));
        let out = body(self);
        if let (Some(t), Some(index)) = (self.timer.as_deref_mut(), open) {
            t.end(self.encoder, index);
        }
        out
    }

    /// Records `pass`.
    pub fn dispatch(&mut self, pass: &Pass) {
        pass.record(self.encoder);
        self.dispatches += 1;
    }

    /// Records a bound gpu-scan.
    pub fn scan(
        &mut self,
        scan: &gpu_scan::Scan,
        binding: &gpu_scan::ScanBinding,
    ) -> Result<(), gpu_scan::ScanError> {
        scan.encode(self.encoder, binding)?;
        self.dispatches += binding.dispatches();
        Ok(())
    }

    /// The encoder, for clears and copies (dispatches go through [`FrameEncoder::dispatch`]
    /// and [`FrameEncoder::scan`], which count them).
    pub fn raw(&mut self) -> &mut wgpu::CommandEncoder {
        self.encoder
    }

    /// Copies the whole of `src` into `dst`.
    pub fn copy(&mut self, src: &wgpu::Buffer, dst: &wgpu::Buffer) {
        self.encoder.copy_buffer_to_buffer(src, 0, dst, 0, None);
    }

    /// Copies the whole of `src` into `dst` from byte `offset` on.
    pub fn copy_to(&mut self, src: &wgpu::Buffer, dst: &wgpu::Buffer, offset: u64) {
        self.encoder
            .copy_buffer_to_buffer(src, 0, dst, offset, None);
    }

    /// Writes `data` into `dst` at `offset` from inside the encoder (through a small staging
    /// buffer), so that it takes effect in recording order, not at the next submission.
    pub fn upload<T: bytemuck::Pod>(&mut self, dst: &wgpu::Buffer, offset: u64, data: &T) {
        self.upload_slice(dst, offset, std::slice::from_ref(data));
    }

    /// [`FrameEncoder::upload`] of a slice.
    pub fn upload_slice<T: bytemuck::Pod>(&mut self, dst: &wgpu::Buffer, offset: u64, data: &[T]) {
        let staging = super::buffers::with_usage(
            self.device,
            "frame upload",
            data,
            wgpu::BufferUsages::COPY_SRC,
        );
        let size = size_of_val(data) as u64;
        self.encoder
            .copy_buffer_to_buffer(&staging, 0, dst, offset, size);
    }
}
