//! The plan of a composed frame: its steps in frame order, each declaring the frame buffers it
//! reads, writes, adds to and rewrites; checked when a method is built, so that a step never
//! reads what no earlier step wrote and a buffer has one writer unless a later step says that
//! it rewrites it.

use std::fmt;

/// What the steps of a frame pass on to each other (per pixel unless noted).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameBuffer {
    /// The G-buffer: each pixel's primary vertex.
    Primary,
    /// Each pixel's secondary vertex (where its GI ray lands).
    Secondary,
    /// The light tiles ReSTIR DI (and world-restir with `gi-tiles`) draw candidates from.
    LightTiles,
    /// The radiance cache's cells (they live across frames; updated each frame).
    Cache,
    /// The radiance leaving each secondary vertex towards its primary: with the secondary
    /// vertex, each pixel's path sample.
    PathRadiance,
    /// The frame's indirect image.
    Indirect,
    /// The frame's direct image.
    Direct,
    /// The running sums of the frames.
    Accumulation,
    /// The denoised frame (and the denoiser's history, across frames).
    Denoised,
}

impl FrameBuffer {
    pub fn name(self) -> &'static str {
        match self {
            FrameBuffer::Primary => "primary",
            FrameBuffer::Secondary => "secondary",
            FrameBuffer::LightTiles => "light-tiles",
            FrameBuffer::Cache => "cache",
            FrameBuffer::PathRadiance => "path-radiance",
            FrameBuffer::Indirect => "indirect",
            FrameBuffer::Direct => "direct",
            FrameBuffer::Accumulation => "accumulation",
            FrameBuffer::Denoised => "denoised",
        }
    }
}

/// What one step does with the frame's buffers.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Access {
    pub reads: Vec<FrameBuffer>,
    /// First written this frame by this step.
    pub writes: Vec<FrameBuffer>,
    /// Added to (an earlier step wrote it).
    pub adds: Vec<FrameBuffer>,
    /// Replaced (an earlier step wrote it; later steps read this step's).
    pub rewrites: Vec<FrameBuffer>,
}

/// One step of a composed frame. Each enters its owner (the renderer or a stage) once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// The renderer's camera and GI rays.
    PrimaryAndGi,
    /// The light tiles.
    LightTiles,
    /// The radiance cache's update and resolve.
    CacheUpdate,
    /// World-space ReSTIR: the light at each secondary vertex (`tiles`: its candidates from the
    /// light tiles), and with `direct` (the unified cache) at each primary vertex too.
    WorldRestir { tiles: bool, direct: bool },
    /// The renderer's light estimate at each secondary vertex.
    ShadeIndirect,
    /// The path beyond the secondary vertex: the renderer's, or (`cache`) ending in the cache,
    /// or (`world`) world-restir's, whose vertices weigh their MIS with its grid's estimates.
    Path { cache: bool, world: bool },
    /// ReSTIR GI: resamples the path samples, rewrites the indirect image; between pixels
    /// (screen space) or (`world`) through a world-space grid of the primary vertices; with
    /// `subpath` (world-space only) it first rewrites the radiance leaving each secondary
    /// vertex (sub-path reuse at x2).
    RestirGi { world: bool, subpath: bool },
    /// Screen-space ReSTIR DI: the direct light.
    RestirDi,
    /// The renderer's direct light.
    ShadeDirect,
    /// The renderer's running sums.
    Accumulate,
    /// The denoiser (SVGF) on the frame's images, after they are accumulated.
    Denoise,
}

impl Step {
    /// Who runs it and which of its passes.
    pub fn name(self) -> &'static str {
        match self {
            Step::PrimaryAndGi => "renderer primary+gi",
            Step::LightTiles => "light-tiles",
            Step::CacheUpdate => "cache update+resolve",
            Step::WorldRestir { .. } => "world-restir",
            Step::ShadeIndirect => "renderer shade_indirect",
            Step::Path { cache: true, .. } => "cache path",
            Step::Path { world: true, .. } => "world-restir path",
            Step::Path { .. } => "renderer path",
            Step::RestirGi { world: false, .. } => "restir-gi",
            Step::RestirGi { world: true, .. } => "world-restir-gi",
            Step::RestirDi => "restir-di",
            Step::ShadeDirect => "renderer shade_direct",
            Step::Accumulate => "renderer accumulate",
            Step::Denoise => "denoiser",
        }
    }

    /// What it reads and writes.
    pub fn access(self) -> Access {
        use FrameBuffer::*;
        let vertices = [Primary, Secondary];
        let when = |on: bool, b: FrameBuffer| on.then_some(b).into_iter();
        // (reads, writes, adds, rewrites); every step but the first reads the vertices.
        let (reads, writes, adds, rewrites): (Vec<_>, Vec<_>, Vec<_>, Vec<_>) = match self {
            Step::PrimaryAndGi => (vec![], vertices.into(), vec![], vec![]),
            Step::LightTiles => (vec![], vec![LightTiles], vec![], vec![]),
            Step::CacheUpdate => (vertices.into(), vec![Cache], vec![], vec![]),
            Step::WorldRestir { tiles, direct } => (
                vertices
                    .into_iter()
                    .chain(when(tiles, LightTiles))
                    .collect(),
                [PathRadiance, Indirect]
                    .into_iter()
                    .chain(when(direct, Direct))
                    .collect(),
                vec![],
                vec![],
            ),
            Step::ShadeIndirect => (
                vertices.into(),
                vec![PathRadiance, Indirect],
                vec![],
                vec![],
            ),
            Step::Path { cache, .. } => (
                vertices.into_iter().chain(when(cache, Cache)).collect(),
                vec![],
                vec![PathRadiance, Indirect],
                vec![],
            ),
            Step::RestirGi { subpath, .. } => (
                vec![Primary, Secondary, PathRadiance],
                vec![],
                vec![],
                when(subpath, PathRadiance).chain([Indirect]).collect(),
            ),
            Step::RestirDi => (
                vec![Primary, Secondary, LightTiles],
                vec![Direct],
                vec![],
                vec![],
            ),
            Step::ShadeDirect => (vertices.into(), vec![Direct], vec![], vec![]),
            Step::Accumulate => (vec![Direct, Indirect], vec![Accumulation], vec![], vec![]),
            Step::Denoise => (
                vec![Primary, Direct, Indirect],
                vec![Denoised],
                vec![],
                vec![],
            ),
        };
        Access {
            reads,
            writes,
            adds,
            rewrites,
        }
    }
}

/// A frame's steps in order, checked: every buffer a step reads, adds to or rewrites was
/// written by an earlier step; a buffer is written once (a later step that replaces it says
/// so: it rewrites); the frame ends with both images written and accumulated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FramePlan {
    steps: Vec<Step>,
}

impl FramePlan {
    pub fn new(steps: Vec<Step>) -> Result<Self, String> {
        let mut written: Vec<FrameBuffer> = Vec::new();
        for step in &steps {
            let a = step.access();
            let before = a.reads.iter().chain(&a.adds).chain(&a.rewrites);
            if let Some(b) = before.copied().find(|b| !written.contains(b)) {
                return Err(format!(
                    "{} needs {} before any step writes it",
                    step.name(),
                    b.name()
                ));
            }
            if let Some(b) = a.writes.iter().find(|b| written.contains(b)) {
                return Err(format!(
                    "{} writes {}, which an earlier step wrote (a step that replaces it \
                     rewrites it)",
                    step.name(),
                    b.name()
                ));
            }
            written.extend(&a.writes);
        }
        let needed = [
            FrameBuffer::Direct,
            FrameBuffer::Indirect,
            FrameBuffer::Accumulation,
        ];
        if let Some(b) = needed.iter().find(|b| !written.contains(b)) {
            return Err(format!("no step writes {}", b.name()));
        }
        Ok(Self { steps })
    }

    pub fn steps(&self) -> &[Step] {
        &self.steps
    }
}

/// One line per step: `name: reads a, b -> writes c; adds d; rewrites e`.
impl fmt::Display for FramePlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let list = |v: &[FrameBuffer]| v.iter().map(|b| b.name()).collect::<Vec<_>>().join(", ");
        for (i, step) in self.steps.iter().enumerate() {
            let a = step.access();
            write!(f, "{}. {}:", i + 1, step.name())?;
            for (what, v) in [
                ("reads", &a.reads),
                ("writes", &a.writes),
                ("adds to", &a.adds),
                ("rewrites", &a.rewrites),
            ] {
                if !v.is_empty() {
                    write!(f, " {what} {};", list(v))?;
                }
            }
            writeln!(f)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_that_reads_before_its_writer_is_refused() {
        let e = FramePlan::new(vec![
            Step::PrimaryAndGi,
            Step::RestirGi {
                world: false,
                subpath: false,
            },
            Step::ShadeIndirect,
            Step::ShadeDirect,
            Step::Accumulate,
        ])
        .unwrap_err();
        assert!(e.contains("restir-gi needs path-radiance"), "{e}");
    }

    #[test]
    fn a_second_writer_must_say_it_rewrites() {
        let e = FramePlan::new(vec![
            Step::PrimaryAndGi,
            Step::ShadeIndirect,
            Step::WorldRestir {
                tiles: false,
                direct: false,
            },
            Step::ShadeDirect,
            Step::Accumulate,
        ])
        .unwrap_err();
        assert!(e.contains("world-restir writes path-radiance"), "{e}");
        let e = FramePlan::new(vec![
            Step::PrimaryAndGi,
            Step::ShadeIndirect,
            Step::Accumulate,
        ])
        .unwrap_err();
        assert!(e.contains("needs direct"), "{e}");
    }
}
