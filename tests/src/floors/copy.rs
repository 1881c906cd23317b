pub(crate) const SOURCE: &str = include_str!("copy.wgsl");

/// `dst[i] = src[i]` over `vec4<u32>`s: the bandwidth floor of a scan.
#[derive(Debug)]
pub struct CopyKernel {
    pipeline: wgpu::ComputePipeline,
}

impl CopyKernel {
    pub fn new(device: &wgpu::Device) -> Self {
        let [pipeline] = super::item_pipelines(device, "floors/copy", SOURCE, ["copy_vec4"]);
        Self { pipeline }
    }

    /// Records a copy of the first `n_vec4` vec4s of `src` into `dst`.
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        src: &wgpu::Buffer,
        dst: &wgpu::Buffer,
        n_vec4: u32,
    ) {
        let params = super::params(device, "floors/copy params", [n_vec4, 0, 0, 0]);
        let buffers = [(0, src), (1, dst), (2, &params)];
        let pass = ("floors/copy", &self.pipeline);
        super::dispatch_items(device, encoder, pass, &buffers, n_vec4);
    }
}
