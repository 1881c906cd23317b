//! The plumbing every screen-space reuse stage shares (restir-di, restir-gi): its reservoir
//! buffers (two per frame, last frame's, last frame's G-buffer) and its chain of reuse passes,
//! temporal then spatial, after an initial pass that writes reservoirs 0. The stage writes its
//! kernels (initial, reuse, shade); this binds and records the chain between them.

use crate::gpu::{FrameEncoder, GpuContext, GpuError, Pass, buffers};
use crate::render::GVertex;

/// A stage's reservoir buffers: this frame's pair (the passes write one from the other), last
/// frame's final reservoirs and last frame's G-buffer (the temporal pass's history).
#[derive(Debug)]
pub struct ReuseBuffers {
    pub reservoirs: [wgpu::Buffer; 2],
    pub prev_reservoirs: wgpu::Buffer,
    pub prev_gbuffer: wgpu::Buffer,
}

impl ReuseBuffers {
    /// Buffers for `pixels` reservoirs of `reservoir_size` bytes, labelled `stage`; the
    /// reservoirs must fit one storage binding of the device.
    pub fn new(
        ctx: &GpuContext,
        stage: &str,
        pixels: u32,
        reservoir_size: usize,
    ) -> Result<Self, GpuError> {
        let px = u64::from(pixels);
        let bytes = px * reservoir_size as u64;
        ctx.check_binding_size(&format!("the {stage} reservoirs"), bytes)?;
        let zeroed = |label: String, size| buffers::storage_zeroed(&ctx.device, &label, size);
        Ok(Self {
            reservoirs: [0, 1].map(|p| zeroed(format!("{stage} reservoirs {p}"), bytes)),
            prev_reservoirs: zeroed(format!("{stage} prev reservoirs"), bytes),
            prev_gbuffer: zeroed(
                format!("{stage} prev gbuffer"),
                px * size_of::<GVertex>() as u64,
            ),
        })
    }
}

/// The span names of a stage's chain: temporal, spatial, persist (`di-temporal`, ...).
pub type ChainSpans = [&'static str; 3];

/// A stage's reuse passes. Reservoir chain: initial -> R0; temporal R0 (+ last frame's) ->
/// R1; spatial R(cur) -> R(1-cur); the shade pass reads [`ReuseChain::final_index`].
#[derive(Debug)]
pub struct ReuseChain {
    temporal: Option<Pass>,
    spatial: Option<Pass>,
    final_index: usize,
    spans: ChainSpans,
}

impl ReuseChain {
    /// Binds the passes the stage has: `pass(temporal, [src, own, out])` binds one reuse pass
    /// merging `src`'s reservoirs into the receivers' own (`own`), writing `out`.
    pub fn new<'a>(
        b: &'a ReuseBuffers,
        temporal: bool,
        spatial: bool,
        spans: ChainSpans,
        mut pass: impl FnMut(bool, [&'a wgpu::Buffer; 3]) -> Result<Pass, GpuError>,
    ) -> Result<Self, GpuError> {
        let r = &b.reservoirs;
        let mut cur = 0;
        let temporal = match temporal {
            true => {
                cur = 1;
                Some(pass(true, [&b.prev_reservoirs, &r[0], &r[1]])?)
            }
            false => None,
        };
        let spatial = match spatial {
            true => {
                let p = pass(false, [&r[cur], &r[cur], &r[1 - cur]])?;
                cur = 1 - cur;
                Some(p)
            }
            false => None,
        };
        Ok(Self {
            temporal,
            spatial,
            final_index: cur,
            spans,
        })
    }

    /// Which of the pair holds the final reservoirs.
    pub fn final_index(&self) -> usize {
        self.final_index
    }

    /// Records the temporal and spatial passes the stage has.
    pub fn encode(&self, f: &mut FrameEncoder) {
        if let Some(t) = &self.temporal {
            f.span(self.spans[0], |f| f.dispatch(t));
        }
        if let Some(s) = &self.spatial {
            f.span(self.spans[1], |f| f.dispatch(s));
        }
    }

    /// Keeps this frame's final reservoirs and `gbuffer` for the next frame's temporal pass
    /// (after the shade pass), when the stage has one.
    pub fn persist(&self, f: &mut FrameEncoder, b: &ReuseBuffers, gbuffer: &wgpu::Buffer) {
        if self.temporal.is_some() {
            f.span(self.spans[2], |f| {
                f.copy(&b.reservoirs[self.final_index], &b.prev_reservoirs);
                f.copy(gbuffer, &b.prev_gbuffer);
            });
        }
    }
}
