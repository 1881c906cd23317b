//! The debug views a stage draws of its last frame.

use crate::gpu::{GpuContext, GpuError, buffers};

/// Debug views of a stage's last frame (each stage draws those it has).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DebugView {
    /// A colour per grid slot (cell) of each vertex; black: not in the grid.
    Cells = 0,
    /// Heat map of log2(M) of the final reservoir (blue M = 1 .. red M >= 2^16).
    M = 1,
    /// Red where the vertex found its bucket full and kept its own reservoir.
    Overflow = 2,
    /// The share of a pixel's reconnections rejected (restir-gi: Jacobian out of range, x2
    /// facing away, or occluded): green none .. red all; black: no neighbour merged.
    Rejected = 3,
    /// The radiance cache's cell at each primary vertex: its radiance (demodulated,
    /// x / (1 + x)); black: no cell with samples.
    CacheRadiance = 4,
    /// The cell's frames since its last sample (heat map up to `evict-after`).
    CacheAge = 5,
    /// The cell's sample count (heat map of log2 up to `history`).
    CacheSamples = 6,
    /// The denoiser's history length per pixel (heat map up to 1 / `alpha` frames).
    DenoiseHistory = 7,
    /// The denoiser's luminance variance per pixel (heat map of log10, 1e-4 .. 1e2).
    DenoiseVariance = 8,
    /// Where world-restir-gi's temporal neighbour came from: blue last frame's reprojected
    /// pixel, green another pixel of last frame's cell (the reprojection failed), red a record
    /// the pool kept (the cell was out of view last frame); black: none merged.
    History = 9,
    /// How old world-restir-gi's temporal neighbour's sample is, in frames since a pixel
    /// resampled it: heat map from 1 (blue, last frame's pixel) to `history-frames` + 2 (red,
    /// the oldest pooled record); black: none merged.
    HistoryAge = 10,
    /// Why path reuse refused a pixel's reconnections (restir-gi, world-restir-gi): grey its
    /// primary vertex is too smooth to take part (`min-roughness`); otherwise colours added,
    /// blue its own secondary vertex too smooth to reconnect to (`x2-min-roughness`), red a
    /// neighbour's shift refused (Jacobian out of range or x2 facing away), green the selected
    /// sample occluded; black: nothing refused.
    Refused = 11,
}

impl DebugView {
    /// Every view.
    pub const ALL: [DebugView; 12] = [
        Self::Cells,
        Self::M,
        Self::Overflow,
        Self::Rejected,
        Self::CacheRadiance,
        Self::CacheAge,
        Self::CacheSamples,
        Self::DenoiseHistory,
        Self::DenoiseVariance,
        Self::History,
        Self::HistoryAge,
        Self::Refused,
    ];

    /// Whether the denoiser draws this view.
    pub fn is_denoise_view(self) -> bool {
        matches!(self, Self::DenoiseHistory | Self::DenoiseVariance)
    }

    /// Whether the radiance cache draws this view.
    pub fn is_cache_view(self) -> bool {
        matches!(
            self,
            Self::CacheRadiance | Self::CacheAge | Self::CacheSamples
        )
    }
}

/// The debug views' heat map of t in [0, 1]: blue .. cyan .. yellow .. red (the twin of
/// WGSL `render_heat`).
pub fn heat(t: f32) -> [f32; 3] {
    let x = t.clamp(0.0, 1.0);
    [3.0, 2.0, 1.0].map(|c| (1.5 - (4.0 * x - c).abs()).clamp(0.0, 1.0))
}

/// Reads the first `pixels` entries of a per-pixel `vec4` buffer back as RGB scaled by
/// `scale`.
pub fn read_rgb(
    ctx: &GpuContext,
    image: &wgpu::Buffer,
    pixels: u32,
    scale: f32,
) -> Result<Vec<[f32; 3]>, GpuError> {
    let v: Vec<[f32; 4]> = buffers::read(ctx, image)?;
    let rgb = |p: &[f32; 4]| [p[0] * scale, p[1] * scale, p[2] * scale];
    Ok(v.iter().take(pixels as usize).map(rgb).collect())
}
