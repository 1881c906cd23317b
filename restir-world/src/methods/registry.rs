//! The registry: every method as one [`MethodEntry`] (its name, its stages, the stage its
//! variant configures and that stage's named variants), and [`MethodSettings`], the
//! composition a spec parses to and prints back as ([`MethodSettings::spec`]).

use std::fmt;

use super::plan::{FramePlan, Step};
use super::{Composed, FrameMethod, MethodError};
use crate::cache::{self, CacheConfig};
use crate::denoise::DenoiseConfig;
use crate::gpu::GpuContext;
use crate::knobs::{Knob, Knobs, Variant, parse_config};
use crate::render::{self, RenderOptions};
use crate::restir_di::{self, RestirDiConfig};
use crate::restir_gi::{self, RestirGiConfig, WorldRestirGiConfig};
use crate::sampling::Estimator;
use crate::scene::{Camera, Scene};
use crate::world_restir::{self, WorldRestirConfig};

/// Which part of a method its variant text configures.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariantOf {
    /// None: the method has no variants.
    Nothing,
    /// The `ris` baseline's candidate count (`ris:K`).
    RisCandidates,
    /// world-restir's knobs.
    WorldRestir,
    /// ReSTIR DI's knobs.
    RestirDi,
    /// ReSTIR GI's knobs.
    RestirGi,
    /// World-space ReSTIR GI's knobs.
    WorldRestirGi,
    /// The radiance cache's knobs.
    Cache,
}

/// One registered method.
#[derive(Clone, Copy)]
pub struct MethodEntry {
    /// Name on the command line.
    pub name: &'static str,
    /// One line for `--help` and reports.
    pub about: &'static str,
    /// Its stages: world-restir for the light at the secondary vertex, ReSTIR GI resampling
    /// the paths, ReSTIR DI for the direct light (the renderer's RIS lights what no stage
    /// does).
    pub world_restir: bool,
    pub restir_gi: bool,
    /// World-space ReSTIR GI resampling the paths (instead of ReSTIR GI).
    pub world_restir_gi: bool,
    pub restir_di: bool,
    /// Paths end in a radiance cache.
    pub cache: bool,
    /// The renderer's light estimate is one light sample (`nee`) instead of RIS.
    pub nee: bool,
    /// What its variant text configures.
    pub variant_of: VariantOf,
    /// Whether this is the method that equal-time comparisons are measured against when the
    /// run includes it (world-space ReSTIR).
    pub equal_time_target: bool,
}

impl fmt::Debug for MethodEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MethodEntry")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

impl MethodEntry {
    /// The named variants of the stage its variant configures.
    pub fn variants(&self) -> Vec<Variant> {
        match self.variant_of {
            VariantOf::WorldRestir => world_restir::variants(),
            VariantOf::RestirDi => restir_di::variants(),
            VariantOf::RestirGi => restir_gi::variants(),
            VariantOf::WorldRestirGi => restir_gi::world::variants(),
            VariantOf::Cache => cache::variants(),
            VariantOf::Nothing | VariantOf::RisCandidates => Vec::new(),
        }
    }

    /// What `name:` accepts, for `--help`: the named variants, or the knobs.
    pub fn variants_help(&self) -> String {
        match self.variant_of {
            VariantOf::Nothing => "none".into(),
            VariantOf::RisCandidates => "K (candidate count)".into(),
            VariantOf::WorldRestir => self.knobs_help(WorldRestirConfig::KNOBS),
            VariantOf::RestirDi => self.knobs_help(RestirDiConfig::KNOBS),
            VariantOf::RestirGi => self.knobs_help(RestirGiConfig::KNOBS),
            VariantOf::WorldRestirGi => self.knobs_help(WorldRestirGiConfig::KNOBS),
            VariantOf::Cache => self.knobs_help(CacheConfig::KNOBS),
        }
    }

    /// The help of a stage's variant: its named variants, or its knobs `all`.
    fn knobs_help(&self, all: &[Knob]) -> String {
        let names: Vec<&str> = self.variants().iter().map(|v| v.name).collect();
        let knobs: Vec<&str> = all.iter().map(|k| k.name).collect();
        format!(
            "{}, or knobs key=value ({}), joined by +",
            names.join(", "),
            knobs.join(", ")
        )
    }

    fn bad(&self, msg: impl Into<String>) -> MethodError {
        MethodError::Variant {
            method: self.name.into(),
            msg: msg.into(),
        }
    }

    /// The settings of this method with `variant` (`None`: the default).
    pub fn settings(&'static self, variant: Option<&str>) -> Result<MethodSettings, MethodError> {
        let mut s = MethodSettings {
            entry: self,
            estimator: render::ris(),
            world: self.world_restir.then(WorldRestirConfig::default),
            gi: self.restir_gi.then(RestirGiConfig::default),
            wgi: self.world_restir_gi.then(WorldRestirGiConfig::default),
            di: self.restir_di.then(RestirDiConfig::default),
            cache: self.cache.then(CacheConfig::default),
            denoise: None,
        };
        match (self.variant_of, variant) {
            (VariantOf::Nothing, None) => {}
            (VariantOf::Nothing, Some(v)) => {
                return Err(self.bad(format!("has no variants (got {v:?})")));
            }
            (VariantOf::RisCandidates, v) => {
                let candidates = match v {
                    None => render::DEFAULT_CANDIDATES,
                    Some(v) => v.parse().map_err(|_| {
                        self.bad(format!("ris:<candidates> wants a number, got {v:?}"))
                    })?,
                };
                render::check_candidates(candidates).map_err(|e| self.bad(e))?;
                s.estimator = Estimator::Ris { candidates };
            }
            (VariantOf::WorldRestir, v) => {
                s.world =
                    Some(parse_config(&world_restir::variants(), v).map_err(|e| self.bad(e))?);
            }
            (VariantOf::RestirDi, v) => {
                s.di = Some(parse_config(&restir_di::variants(), v).map_err(|e| self.bad(e))?);
            }
            (VariantOf::RestirGi, v) => {
                s.gi = Some(parse_config(&restir_gi::variants(), v).map_err(|e| self.bad(e))?);
            }
            (VariantOf::WorldRestirGi, v) => {
                let variants = restir_gi::world::variants();
                s.wgi = Some(parse_config(&variants, v).map_err(|e| self.bad(e))?);
            }
            (VariantOf::Cache, v) => {
                s.cache = Some(parse_config(&cache::variants(), v).map_err(|e| self.bad(e))?);
            }
        }
        if self.nee {
            s.estimator = Estimator::Nee;
        }
        s.validate()?;
        Ok(s)
    }
}

/// What a method spec parses to: the registry entry, the renderer's light estimator (for the
/// images no stage lights) and the configuration of each of its stages.
#[derive(Debug, Clone, Copy)]
pub struct MethodSettings {
    pub entry: &'static MethodEntry,
    pub estimator: Estimator,
    pub world: Option<WorldRestirConfig>,
    pub gi: Option<RestirGiConfig>,
    pub wgi: Option<WorldRestirGiConfig>,
    pub di: Option<RestirDiConfig>,
    pub cache: Option<CacheConfig>,
    /// The denoiser after the method's frames (not part of its spec: the tools' `--denoise`).
    pub denoise: Option<DenoiseConfig>,
}

impl PartialEq for MethodSettings {
    fn eq(&self, other: &Self) -> bool {
        self.entry.name == other.entry.name
            && (self.estimator, self.world, self.gi, self.di, self.cache)
                == (
                    other.estimator,
                    other.world,
                    other.gi,
                    other.di,
                    other.cache,
                )
            && self.wgi == other.wgi
            && self.denoise == other.denoise
    }
}

impl MethodSettings {
    /// The debug views a method of these settings draws ([`FrameMethod::debug_image`]):
    /// world-restir's grid, the reservoirs' M (world-restir, restir-gi, world-restir-gi),
    /// the rejected reconnections and why (restir-gi, world-restir-gi), the temporal
    /// neighbours' origin and age (world-restir-gi), the cache's and the denoiser's.
    pub fn debug_views(&self) -> Vec<render::DebugView> {
        use render::DebugView as V;
        let paths = self.gi.is_some() || self.wgi.is_some();
        V::ALL
            .into_iter()
            .filter(|v| match v {
                V::Cells | V::Overflow => self.world.is_some(),
                V::M => self.world.is_some() || paths,
                V::Rejected | V::Refused => paths,
                V::History | V::HistoryAge => self.wgi.is_some(),
                V::CacheRadiance | V::CacheAge | V::CacheSamples => self.cache.is_some(),
                V::DenoiseHistory | V::DenoiseVariance => self.denoise.is_some(),
            })
            .collect()
    }

    /// What `scene` does to a method of these settings that its image would not say (the
    /// radiance cache's range, light that does not converge, a scene the GPU renders in
    /// other units); empty when nothing.
    pub fn scene_warnings(&self, scene: &Scene) -> Vec<String> {
        let mut warnings = match &self.cache {
            Some(_) => cache::scene_warnings(scene),
            None => Vec::new(),
        };
        let units = scene.gpu_units();
        if units != 1.0 {
            warnings.push(format!(
                "the scene's extent is below {}: the GPU renders it {units:e} times larger \
                 (a power of two: the image is the same), and knobs in world units \
                 (min-cell-size) are in those units",
                crate::scene::SMALLEST_GPU_EXTENT
            ));
        }
        warnings
    }

    /// Checks each stage's knobs and how they compose.
    pub fn validate(&self) -> Result<(), MethodError> {
        let bad = |msg: &str| Err(self.entry.bad(msg));
        if let Some(w) = &self.world {
            w.validate()?;
        }
        if let Some(g) = &self.gi {
            g.validate().map_err(|e| self.entry.bad(e.to_string()))?;
        }
        if let Some(g) = &self.wgi {
            g.validate().map_err(|e| self.entry.bad(e.to_string()))?;
            if self.gi.is_some() {
                return bad("restir-gi and world-restir-gi both resample the paths: use one");
            }
        }
        if let Some(c) = &self.cache {
            c.validate().map_err(|e| self.entry.bad(e.to_string()))?;
        }
        if let Some(d) = &self.di {
            d.validate().map_err(|e| self.entry.bad(e.to_string()))?;
            if d.gi_tiles && self.world.is_none() {
                return bad(
                    "gi-tiles feeds world-restir's generate pass: use world-restir+restir-di",
                );
            }
        }
        if self.world.is_some_and(|w| w.unified) && self.di.is_some() {
            return bad("unified and restir-di both light the direct image: use one");
        }
        Ok(())
    }

    /// Checks without a GPU what the method needs of the camera (before any GPU work):
    /// world-restir sizes its hash grid's cells from the image size and the field of view, and
    /// a tiny image (1x1, 4x4) cannot be sized.
    pub fn check_camera(&self, camera: &Camera) -> Result<(), MethodError> {
        let pixels = camera.width.saturating_mul(camera.height);
        if let Some(w) = &self.world {
            let table = w.table(camera.width, camera.height);
            self.check_cells("world-restir", &table, &w.sizing(camera), camera)?;
        }
        if let Some(g) = &self.wgi {
            let table = g.table(pixels);
            self.check_cells("world-restir-gi", &table, &g.sizing(camera), camera)?;
        }
        if let Some(c) = &self.cache {
            let table = c.table(pixels);
            self.check_cells("the cache", &table, &c.sizing(camera), camera)?;
        }
        Ok(())
    }

    /// Checks that `stage`'s cell sizing gives cells for `camera`; the error names the knobs
    /// that set it (the image's size only enters through the angle `projected-size` spans).
    fn check_cells(
        &self,
        stage: &str,
        table: &gpu_hash::TableConfig,
        sizing: &gpu_hash::CellSizing,
        camera: &Camera,
    ) -> Result<(), MethodError> {
        gpu_hash::HashGridParams::new(table, sizing, camera.eye).map_err(|e| {
            self.entry.bad(format!(
                "{stage}'s cells: min-cell-size={} and projected-size={} at {}x{}: {e}; \
                 change these knobs (a larger image also narrows the angle of projected-size \
                 pixels)",
                sizing.min_cell_size, sizing.projected_size, camera.width, camera.height
            ))
        })?;
        Ok(())
    }

    /// Checks without a GPU what the method needs of the paths: its light estimator's loops at
    /// every bounce within the drivers' cap (`Paths::check`); a radiance cache holds the light
    /// of every bounce, so a `+cache` method renders unbounded paths only
    /// ([`render::MAX_BOUNCES`] bounces, Russian roulette on), or its image would hold more
    /// light than the depth asked for.
    pub fn check_paths(&self, paths: &render::Paths) -> Result<(), MethodError> {
        // The renderer checks the same when it is built; here it is refused before any work.
        let candidates = match self.estimator {
            Estimator::Nee => 1,
            Estimator::Ris { candidates } => candidates,
        };
        paths
            .check(candidates)
            .map_err(|e| self.entry.bad(format!("bad render setting: {e}")))?;
        if self.cache.is_some()
            && (paths.bounces != render::MAX_BOUNCES || paths.roulette_from == 0)
        {
            return Err(self.entry.bad(format!(
                "the radiance cache holds the light of every bounce: render it with unbounded \
                 paths (--bounces {} and Russian roulette on), not {} bounces{}",
                render::MAX_BOUNCES,
                paths.bounces,
                if paths.roulette_from == 0 {
                    " without roulette"
                } else {
                    ""
                }
            )));
        }
        Ok(())
    }

    /// The frame's steps for paths `paths`, in the one order every method shares, checked
    /// ([`FramePlan::new`]): the renderer's camera and GI rays; the light tiles and the
    /// radiance cache's update when a stage needs them; the path samples and the indirect image
    /// (world-restir or the renderer's light estimate at the secondary vertex, then the path
    /// beyond it unless there is none: one bounce without MIS); ReSTIR GI rewriting the
    /// indirect image from the path samples; the direct image (world-restir's unified cache,
    /// ReSTIR DI or the renderer's); accumulation.
    pub fn plan(&self, paths: &render::Paths) -> Result<FramePlan, MethodError> {
        let mut steps = vec![Step::PrimaryAndGi];
        steps.extend(self.di.map(|_| Step::LightTiles));
        steps.extend(self.cache.map(|_| Step::CacheUpdate));
        let unified = self.world.is_some_and(|w| w.unified);
        steps.push(match self.world {
            Some(_) => Step::WorldRestir {
                tiles: self.di.is_some_and(|d| d.gi_tiles),
                direct: unified,
            },
            None => Step::ShadeIndirect,
        });
        if self.cache.is_some() || paths.beyond_secondary() {
            // The cache's path ends in its cells and keeps the light table's MIS beyond x2.
            steps.push(Step::Path {
                cache: self.cache.is_some(),
                world: self.world.is_some() && self.cache.is_none(),
            });
        }
        steps.extend(self.gi.map(|_| Step::RestirGi {
            world: false,
            subpath: false,
        }));
        steps.extend(self.wgi.map(|w| Step::RestirGi {
            world: true,
            subpath: w.subpath_k > 0,
        }));
        match self.di {
            _ if unified => {}
            Some(_) => steps.push(Step::RestirDi),
            None => steps.push(Step::ShadeDirect),
        }
        steps.push(Step::Accumulate);
        steps.extend(self.denoise.as_ref().map(|_| Step::Denoise));
        FramePlan::new(steps).map_err(|e| self.entry.bad(e))
    }

    /// The spec that rebuilds these settings (`name` or `name:knobs`).
    pub fn spec(&self) -> String {
        let knobs = match self.entry.variant_of {
            VariantOf::Nothing => String::new(),
            VariantOf::RisCandidates => match self.estimator {
                Estimator::Ris { candidates } if candidates != render::DEFAULT_CANDIDATES => {
                    candidates.to_string()
                }
                _ => String::new(),
            },
            VariantOf::WorldRestir => self.world.map(|c| c.knobs_spec()).unwrap_or_default(),
            VariantOf::RestirDi => self.di.map(|c| c.knobs_spec()).unwrap_or_default(),
            VariantOf::RestirGi => self.gi.map(|c| c.knobs_spec()).unwrap_or_default(),
            VariantOf::WorldRestirGi => self.wgi.map(|c| c.knobs_spec()).unwrap_or_default(),
            VariantOf::Cache => self.cache.map(|c| c.knobs_spec()).unwrap_or_default(),
        };
        match knobs.is_empty() {
            true => self.entry.name.to_owned(),
            false => format!("{}:{knobs}", self.entry.name),
        }
    }

    /// The knobs the variant configures, with their current values (empty for methods
    /// without knobs): what a knob panel shows.
    pub fn knobs(&self) -> Vec<(Knob, String)> {
        fn values<C: Knobs>(c: &C) -> Vec<(Knob, String)> {
            C::KNOBS
                .iter()
                .map(|k| (*k, c.get(k.name).unwrap_or_default()))
                .collect()
        }
        match self.entry.variant_of {
            VariantOf::WorldRestir => self.world.as_ref().map(values),
            VariantOf::RestirDi => self.di.as_ref().map(values),
            VariantOf::RestirGi => self.gi.as_ref().map(values),
            VariantOf::WorldRestirGi => self.wgi.as_ref().map(values),
            VariantOf::Cache => self.cache.as_ref().map(values),
            VariantOf::Nothing | VariantOf::RisCandidates => None,
        }
        .unwrap_or_default()
    }

    /// These settings with one knob of the variant changed, checked.
    pub fn with_knob(&self, key: &str, value: &str) -> Result<MethodSettings, MethodError> {
        let mut next = *self;
        let set = match self.entry.variant_of {
            VariantOf::WorldRestir => next.world.as_mut().map(|w| w.set(key, value)),
            VariantOf::RestirDi => next.di.as_mut().map(|d| d.set(key, value)),
            VariantOf::RestirGi => next.gi.as_mut().map(|g| g.set(key, value)),
            VariantOf::WorldRestirGi => next.wgi.as_mut().map(|g| g.set(key, value)),
            VariantOf::Cache => next.cache.as_mut().map(|c| c.set(key, value)),
            VariantOf::Nothing | VariantOf::RisCandidates => None,
        }
        .unwrap_or_else(|| Err(format!("{} has no knobs", self.entry.name)));
        set.map_err(|e| self.entry.bad(e))?;
        next.validate()?;
        Ok(next)
    }

    /// Builds the method, seeded by `seed` (the default paths).
    pub fn build(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        seed: u32,
    ) -> Result<Box<dyn FrameMethod>, MethodError> {
        self.build_with(ctx, scene, camera, &RenderOptions::seeded(seed))
    }

    /// Builds the method, rendering with `options` (seed, path depth).
    pub fn build_with(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        options: &RenderOptions,
    ) -> Result<Box<dyn FrameMethod>, MethodError> {
        Ok(Box::new(Composed::with_options(
            ctx, scene, camera, self, options,
        )?))
    }
}

/// Every registered method, in display order.
pub fn registry() -> &'static [MethodEntry] {
    const fn entry(name: &'static str, about: &'static str, variant_of: VariantOf) -> MethodEntry {
        MethodEntry {
            name,
            about,
            world_restir: false,
            restir_gi: false,
            world_restir_gi: false,
            restir_di: false,
            cache: false,
            nee: false,
            variant_of,
            equal_time_target: false,
        }
    }
    const REGISTRY: &[MethodEntry] = &[
        MethodEntry {
            nee: true,
            ..entry(
                "nee",
                "one light sample + one shadow ray at each vertex",
                VariantOf::Nothing,
            )
        },
        entry(
            "ris",
            "RIS over 16 light candidates (ris:K for K), one shadow ray, no reuse",
            VariantOf::RisCandidates,
        ),
        MethodEntry {
            world_restir: true,
            equal_time_target: true,
            ..entry(
                "world-restir",
                "world-space ReSTIR GI: RIS + hash-grid temporal and spatial reuse",
                VariantOf::WorldRestir,
            )
        },
        MethodEntry {
            restir_di: true,
            ..entry(
                "restir-di",
                "ris with screen-space ReSTIR DI (light tiles, temporal + spatial reuse) for \
                 the direct light",
                VariantOf::RestirDi,
            )
        },
        MethodEntry {
            world_restir: true,
            restir_di: true,
            ..entry(
                "world-restir+restir-di",
                "world-space ReSTIR GI for the indirect light (its defaults), ReSTIR DI for the \
                 direct light (its variants)",
                VariantOf::RestirDi,
            )
        },
        MethodEntry {
            restir_gi: true,
            ..entry(
                "restir-gi",
                "screen-space ReSTIR GI: each pixel's path resampled with its temporal and \
                 spatial neighbours' by reconnection (ris lights every vertex)",
                VariantOf::RestirGi,
            )
        },
        MethodEntry {
            world_restir: true,
            restir_gi: true,
            ..entry(
                "restir-gi+world-restir",
                "ReSTIR GI (its variants) over paths whose secondary vertex world-restir \
                 lights (its defaults)",
                VariantOf::RestirGi,
            )
        },
        MethodEntry {
            world_restir: true,
            restir_gi: true,
            restir_di: true,
            ..entry(
                "restir-di+restir-gi+world-restir",
                "the full stack: ReSTIR DI for the direct light, ReSTIR GI over world-restir's \
                 secondary vertices (their defaults; the variant is ReSTIR GI's)",
                VariantOf::RestirGi,
            )
        },
        MethodEntry {
            world_restir_gi: true,
            ..entry(
                "world-restir-gi",
                "world-space ReSTIR GI: each pixel's path resampled with the path samples other \
                 pixels left in its cell of a world-space grid, this frame and last (ris lights \
                 every vertex)",
                VariantOf::WorldRestirGi,
            )
        },
        MethodEntry {
            world_restir: true,
            world_restir_gi: true,
            ..entry(
                "world-restir-gi+world-restir",
                "world-restir-gi (its variants) over paths whose secondary vertex world-restir \
                 lights (its defaults)",
                VariantOf::WorldRestirGi,
            )
        },
        MethodEntry {
            world_restir: true,
            world_restir_gi: true,
            restir_di: true,
            ..entry(
                "restir-di+world-restir-gi+world-restir",
                "ReSTIR DI for the direct light, world-restir-gi over world-restir's secondary \
                 vertices (their defaults; the variant is world-restir-gi's)",
                VariantOf::WorldRestirGi,
            )
        },
        MethodEntry {
            nee: true,
            cache: true,
            ..entry(
                "nee+cache",
                "nee with paths that end in the radiance cache (the variant is the cache's)",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            cache: true,
            ..entry(
                "ris+cache",
                "ris with paths that end in the radiance cache (the variant is the cache's)",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            world_restir: true,
            cache: true,
            ..entry(
                "world-restir+cache",
                "world-restir (its defaults) with paths that end in the radiance cache",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            restir_di: true,
            cache: true,
            ..entry(
                "restir-di+cache",
                "restir-di (its defaults) with paths that end in the radiance cache",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            world_restir: true,
            restir_di: true,
            cache: true,
            ..entry(
                "world-restir+restir-di+cache",
                "world-restir+restir-di (their defaults) with paths that end in the radiance \
                 cache",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            restir_gi: true,
            cache: true,
            ..entry(
                "restir-gi+cache",
                "restir-gi (its defaults) over paths that end in the radiance cache",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            world_restir: true,
            restir_gi: true,
            cache: true,
            ..entry(
                "restir-gi+world-restir+cache",
                "restir-gi+world-restir (their defaults) over paths that end in the radiance \
                 cache",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            world_restir_gi: true,
            cache: true,
            ..entry(
                "world-restir-gi+cache",
                "world-restir-gi (its defaults) over paths that end in the radiance cache",
                VariantOf::Cache,
            )
        },
        MethodEntry {
            world_restir: true,
            restir_gi: true,
            restir_di: true,
            cache: true,
            ..entry(
                "restir-di+restir-gi+world-restir+cache",
                "the full stack (its defaults) over paths that end in the radiance cache",
                VariantOf::Cache,
            )
        },
    ];
    REGISTRY
}

/// The registry entry of `spec` (`name` or `name:variant`).
pub fn entry(spec: &str) -> Result<&'static MethodEntry, MethodError> {
    let name = spec.split_once(':').map_or(spec, |(n, _)| n);
    registry().iter().find(|e| e.name == name).ok_or_else(|| {
        let names: Vec<&str> = registry().iter().map(|e| e.name).collect();
        MethodError::Unknown {
            name: name.into(),
            known: names.join(", "),
        }
    })
}

/// Parses a method spec (`name` or `name:variant`) without a GPU: the name is registered and
/// its variant parses. Tools call it before any expensive work.
pub fn parse_spec(spec: &str) -> Result<MethodSettings, MethodError> {
    entry(spec)?.settings(spec.split_once(':').map(|(_, v)| v))
}

/// [`parse_spec`], for its errors only.
pub fn check_spec(spec: &str) -> Result<(), MethodError> {
    parse_spec(spec).map(drop)
}

/// [`MethodSettings::check_camera`] of `spec`.
pub fn check_camera(spec: &str, camera: &Camera) -> Result<(), MethodError> {
    parse_spec(spec)?.check_camera(camera)
}

/// [`MethodSettings::check_paths`] of `spec`.
pub fn check_paths(spec: &str, paths: &render::Paths) -> Result<(), MethodError> {
    parse_spec(spec)?.check_paths(paths)
}

/// Builds the method named by `spec` (`name` or `name:variant`).
pub fn build_method(
    spec: &str,
    ctx: &GpuContext,
    scene: &Scene,
    camera: &Camera,
    seed: u32,
) -> Result<Box<dyn FrameMethod>, MethodError> {
    parse_spec(spec)?.build(ctx, scene, camera, seed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use reservoir::reuse::Combination;

    #[test]
    fn names_are_unique_and_found() {
        let r = registry();
        for (i, a) in r.iter().enumerate() {
            assert!(r[i + 1..].iter().all(|b| b.name != a.name));
            assert_eq!(entry(a.name).unwrap().name, a.name);
        }
        assert_eq!(entry("ris:4").unwrap().name, "ris");
        assert!(entry("nope").is_err());
        for good in [
            "nee",
            "ris",
            "ris:4",
            "ris:65535",
            "world-restir:biased+spatial-passes=2",
            "world-restir:unified",
            "restir-di",
            "restir-di:no-reuse",
            "restir-di:biased+spatial-k=2",
            "restir-di:combine=one-over-z",
            "world-restir+restir-di:spatial-k=4",
            "world-restir+restir-di:gi-tiles",
            "restir-gi",
            "restir-gi:biased+spatial-k=8",
            "restir-gi+world-restir:no-reuse",
            "restir-di+restir-gi+world-restir:max-jacobian=4",
            "world-restir-gi",
            "world-restir-gi:no-reuse",
            "world-restir-gi:temporal-k=2+projected-size=16",
            "world-restir-gi+world-restir:biased",
            "restir-di+world-restir-gi+world-restir",
            "world-restir-gi+cache:history=64",
            "ris+cache",
            "ris+cache:after=3+update-fraction=0.1",
            "world-restir+cache:frequent",
            "restir-di+restir-gi+world-restir+cache:history=64",
        ] {
            check_spec(good).unwrap_or_else(|e| panic!("{good}: {e}"));
        }
        for bad in [
            "nee:1",
            "ris:0",
            "ris:65536",
            "ris:x",
            "world-restir:bogus",
            "restir-di:bogus",
            "restir-di:spatial-k=99",
            "restir-di:tiles=0",
            "restir-di:gi-tiles",
            "world-restir+restir-di:combine=x",
            "restir-gi:max-jacobian=0",
            "restir-gi:spatial-k=17",
            "ris+cache:after=1",
            "ris+cache:update-fraction=0",
            "nope",
        ] {
            assert!(check_spec(bad).is_err(), "{bad}");
        }
    }

    /// Every named variant of every entry parses, and its spec rebuilds the same settings.
    #[test]
    fn every_variant_round_trips_through_its_spec() {
        for e in registry() {
            let mut specs = vec![e.name.to_owned()];
            specs.extend(
                e.variants()
                    .iter()
                    .map(|v| format!("{}:{}", e.name, v.name)),
            );
            if e.variant_of == VariantOf::RisCandidates {
                specs.push("ris:4".into());
            }
            for spec in specs {
                let Ok(s) = parse_spec(&spec) else {
                    // gi-tiles is world-restir+restir-di's only.
                    assert!(spec == "restir-di:gi-tiles", "{spec}");
                    continue;
                };
                let again = parse_spec(&s.spec()).unwrap_or_else(|e| panic!("{spec}: {e}"));
                assert_eq!(again, s, "{spec} -> {}", s.spec());
            }
        }
        let b = parse_spec("world-restir:biased+spatial-passes=3").unwrap();
        assert_eq!(b.spec(), "world-restir:spatial-passes=3+combine=biased");
        assert_eq!(parse_spec("ris:16").unwrap().spec(), "ris");
    }

    #[test]
    fn every_method_has_a_checked_frame_plan() {
        let unbounded = render::Paths {
            bounces: render::MAX_BOUNCES,
            ..render::Paths::default()
        };
        for e in registry() {
            let s = e.settings(None).unwrap();
            let paths = if e.cache {
                unbounded
            } else {
                render::Paths::default()
            };
            s.plan(&paths)
                .unwrap_or_else(|err| panic!("{}: {err}", e.name));
        }
    }

    #[test]
    fn restir_gi_over_world_restir_enters_each_stage_once() {
        let s = parse_spec("restir-gi+world-restir").unwrap();
        let plan = s.plan(&render::Paths::default()).unwrap();
        assert_eq!(
            plan.to_string(),
            "1. renderer primary+gi: writes primary, secondary;\n\
             2. world-restir: reads primary, secondary; writes path-radiance, indirect;\n\
             3. world-restir path: reads primary, secondary; adds to path-radiance, indirect;\n\
             4. restir-gi: reads primary, secondary, path-radiance; rewrites indirect;\n\
             5. renderer shade_direct: reads primary, secondary; writes direct;\n\
             6. renderer accumulate: reads direct, indirect; writes accumulation;\n"
        );
        let one_bounce = render::Paths {
            bounces: 1,
            mis: false,
            ..render::Paths::default()
        };
        let steps = parse_spec("ris").unwrap().plan(&one_bounce).unwrap();
        assert!(!steps.steps().iter().any(|s| matches!(s, Step::Path { .. })));
    }

    #[test]
    fn knobs_change_the_variant_stage_only() {
        let s = parse_spec("world-restir+restir-di").unwrap();
        assert_eq!(s.knobs().len(), RestirDiConfig::KNOBS.len());
        let next = s.with_knob("spatial-k", "2").unwrap();
        assert_eq!(next.spec(), "world-restir+restir-di:spatial-k=2");
        assert_eq!(next.world, s.world);
        let err = s.with_knob("spatial-k", "99").unwrap_err().to_string();
        assert!(err.contains("spatial-k"), "{err}");
        assert!(parse_spec("ris").unwrap().knobs().is_empty());
        let k = parse_spec("restir-di:biased+spatial-k=2")
            .unwrap()
            .di
            .unwrap();
        assert_eq!((k.combine, k.spatial_k), (Combination::OneOverM, 2));
        let w = parse_spec("world-restir:biased+spatial-passes=2+max_count=8").unwrap();
        let w = w.world.unwrap();
        assert_eq!(
            (w.combine, w.spatial_passes, w.max_count),
            (Combination::OneOverM, 2, 8)
        );
        for (bad, knob) in [
            ("restir-di:spatial-k=x", "spatial-k"),
            ("restir-di:tiles=0", "tiles"),
            ("restir-di:bogus", "bogus"),
            ("world-restir:nosuch=1", "nosuch"),
        ] {
            let e = check_spec(bad).unwrap_err().to_string();
            assert!(e.contains(knob), "{bad}: {e}");
        }
        let unified = parse_spec("world-restir:unified").unwrap();
        let both = MethodSettings {
            di: Some(RestirDiConfig::default()),
            ..unified
        };
        assert!(both.validate().is_err());
    }
}
