//! The converged images a compare run measures against: rendered on the GPU (or read from the
//! cache) for each evaluated frame, or one external EXR for a static camera.

use anyhow::{Context, Result, bail};
use indicatif::ProgressBar;
use restir_world::GpuContext;
use restir_world::gpu_reference::{self, GpuReference, ReferenceSettings};
use restir_world::scene::{Camera, Scene};

use super::report::{ImageKind, PerImage, ReferenceInfo};
use super::{CameraMode, CompareOptions, Rgb};

/// One reference's images: combined always, direct and indirect when the reference has an
/// indirect image (direct = combined - indirect).
pub struct Reference {
    pub width: u32,
    pub height: u32,
    pub combined: Rgb,
    pub indirect: Option<Rgb>,
    pub direct: Option<Rgb>,
}

impl Reference {
    fn new(r: GpuReference) -> Self {
        Self {
            width: r.width,
            height: r.height,
            direct: r.direct(),
            indirect: r.indirect,
            combined: r.combined,
        }
    }

    /// The reference image of `kind`, if this reference has it.
    pub fn image(&self, kind: ImageKind) -> Option<&Rgb> {
        match kind {
            ImageKind::Direct => self.direct.as_ref(),
            ImageKind::Indirect => self.indirect.as_ref(),
            ImageKind::Combined => Some(&self.combined),
        }
    }
}

/// The references of a scene by frame.
pub struct Refs {
    /// Frame index -> reference (static: one reference for every frame, key 0).
    pub by_frame: Vec<(u32, Reference)>,
    pub static_camera: bool,
}

impl Refs {
    pub fn get(&self, frame: u32) -> Option<&Reference> {
        if self.static_camera {
            self.by_frame.first().map(|(_, r)| r)
        } else {
            self.by_frame
                .iter()
                .find(|(f, _)| *f == frame)
                .map(|(_, r)| r)
        }
    }

    pub fn last(&self) -> Option<&Reference> {
        self.by_frame.last().map(|(_, r)| r)
    }
}

/// The references of `scene` for `opts`: `--reference` (static camera), else one GPU reference
/// per evaluated frame, from the cache when it has them.
pub fn make_references(
    ctx: &GpuContext,
    scene: &Scene,
    base: &Camera,
    opts: &CompareOptions,
    bar: &ProgressBar,
) -> Result<(Refs, ReferenceInfo)> {
    if let Some(path) = &opts.reference {
        if opts.camera != CameraMode::Static {
            bail!("--reference needs --animation static (one image for every frame)");
        }
        let r = gpu_reference::external(path, opts.reference_indirect.as_deref(), base)?;
        let info = ReferenceInfo {
            source: "external".into(),
            estimator: format!("external file {}", path.display()),
            samples: 0,
            self_rel_mse: PerImage::default(),
            key: String::new(),
            count: 1,
        };
        let refs = Refs {
            by_frame: vec![(0, Reference::new(r))],
            static_camera: true,
        };
        return Ok((refs, info));
    }
    let settings = ReferenceSettings {
        spp: opts.reference_spp,
        paths: opts.paths,
        ..Default::default()
    };
    let mut rendered = Vec::new();
    for f in evaluated_frames(opts) {
        let cam = opts.camera.per_frame(opts.frames).camera(base, f);
        let start = std::time::Instant::now();
        super::log_line(bar, || {
            format!(
                "reference of frame {f}: {} spp at {}x{}, {} bounces (loaded from --cache when \
                 there; rendering it takes minutes on a CPU adapter)",
                settings.spp, cam.width, cam.height, settings.paths.bounces
            )
        });
        let r = gpu_reference::load_or_render(
            ctx,
            scene,
            &cam,
            &settings,
            opts.cache.as_deref(),
            |n| bar.inc(u64::from(n)),
        )
        .with_context(|| {
            let motion = format!("{:?}", opts.camera).to_lowercase();
            format!("the reference of frame {f} of the {motion} camera")
        })?;
        if let Some(note) = &r.cache_note {
            bar.suspend(|| eprintln!("warning: {note}"));
        }
        super::log_line(bar, || {
            format!(
                "reference of frame {f}: done in {:.1} s",
                start.elapsed().as_secs_f64()
            )
        });
        rendered.push((f, r));
    }
    let info = rendered_info(&rendered, &settings);
    let refs = Refs {
        by_frame: rendered
            .into_iter()
            .map(|(f, r)| (f, Reference::new(r)))
            .collect(),
        static_camera: opts.camera == CameraMode::Static,
    };
    Ok((refs, info))
}

/// The frames measured against a reference: frame 0 for a static camera (its reference serves
/// every frame), else every `--eval-every`-th frame and the last, and with `--denoise` the
/// frame before each of those (the denoised image's frame-to-frame change is measured against
/// the reference's own).
fn evaluated_frames(opts: &CompareOptions) -> Vec<u32> {
    match opts.camera {
        CameraMode::Static => vec![0],
        CameraMode::Orbit | CameraMode::Dolly => {
            let every = opts.eval_every.max(1);
            let mut v: Vec<u32> = (0..opts.frames).filter(|f| (f + 1) % every == 0).collect();
            if v.last() != Some(&(opts.frames - 1)) {
                v.push(opts.frames - 1);
            }
            if opts.denoise.is_some() {
                let before: Vec<u32> = v.iter().filter_map(|f| f.checked_sub(1)).collect();
                v.extend(before);
                v.sort_unstable();
                v.dedup();
            }
            v
        }
    }
}

/// What the report says about GPU references: their own error is the mean over them.
fn rendered_info(rendered: &[(u32, GpuReference)], settings: &ReferenceSettings) -> ReferenceInfo {
    let first = &rendered[0].1;
    let mean = |pick: fn(&GpuReference) -> Option<f64>| -> Option<f64> {
        let v: Vec<f64> = rendered.iter().filter_map(|(_, r)| pick(r)).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let from_cache = rendered.iter().all(|(_, r)| r.from_cache);
    ReferenceInfo {
        source: if from_cache { "cache" } else { "gpu" }.into(),
        estimator: format!("{:?}", settings.method),
        samples: first.samples,
        self_rel_mse: PerImage {
            direct: None,
            indirect: mean(|r| r.self_rel_mse.map(|x| x.1)),
            combined: mean(|r| r.self_rel_mse.map(|x| x.0)),
        },
        key: first.key.clone(),
        count: rendered.len() as u32,
    }
}
