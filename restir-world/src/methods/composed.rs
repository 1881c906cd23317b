//! [`Composed`]: a method made of the renderer and the stages that replace its shading, in the
//! one order every method shares.

use super::plan::{FramePlan, Step};
use super::{FrameImages, FrameMethod, MethodError, MethodSettings};
use crate::cache::{CacheStats, RadianceCache};
use crate::denoise::Denoiser;
use crate::gpu::{FrameEncoder, GpuContext};
use crate::light_tiles::LightTiles;
use crate::render::{DebugView, RenderOptions, Renderer};
use crate::restir_di::{RestirDi, RestirDiConfig};
use crate::restir_gi::RestirGi;
use crate::scene::{Camera, Scene};
use crate::world_restir::{WorldRestir, WorldRestirConfig};

/// The renderer (primary and GI passes, the baselines' shading, accumulation) and the stages
/// a method adds, run in the order of the method's [`FramePlan`]
/// ([`MethodSettings::plan`]): each step enters the renderer or one stage once.
#[derive(Debug)]
pub struct Composed {
    renderer: Renderer,
    plan: FramePlan,
    tiles: Option<LightTiles>,
    world: Option<WorldRestir>,
    gi: Option<RestirGi>,
    di: Option<RestirDi>,
    cache: Option<RadianceCache>,
    /// The plan's last step, when the settings ask for it.
    denoiser: Option<Denoiser>,
}

impl Composed {
    /// Builds `settings` for `scene` seen by `camera`, seeded by `seed` (the default paths).
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        settings: &MethodSettings,
        seed: u32,
    ) -> Result<Self, MethodError> {
        Self::with_options(ctx, scene, camera, settings, &RenderOptions::seeded(seed))
    }

    /// Builds `settings` for `scene` seen by `camera`, rendering with `options`.
    pub fn with_options(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        settings: &MethodSettings,
        options: &RenderOptions,
    ) -> Result<Self, MethodError> {
        settings.validate()?;
        settings.check_paths(&options.paths)?;
        let plan = settings.plan(&options.paths)?;
        // world-restir-gi's sub-path reuse reads the path split, restir-gi's reconnection at a
        // glossy x2 the glossy record it holds there (only a scene with glossy materials has one).
        let x2_roughness = match (settings.gi, settings.wgi) {
            (Some(g), _) => Some(g.x2_min_roughness),
            (None, Some(w)) => Some(w.x2_min_roughness),
            (None, None) => None,
        };
        // Half the packed roughness' step below the knob (as min-roughness): a material at the
        // knob's value is taken whichever way its roughness rounded when packed.
        let glossy_x2 = x2_roughness
            .filter(|_| scene.glossy_materials() > 0)
            .map(|r| (r.clamp(0.0, 1.0) * 65535.0 - 0.5).ceil().max(0.0) as u16);
        let options = &RenderOptions {
            path_split: options.path_split
                || glossy_x2.is_some()
                || settings.wgi.is_some_and(|w| w.subpath_k > 0),
            glossy_x2,
            ..*options
        };
        let renderer = Renderer::with_options(ctx, scene, camera, settings.estimator, options)?;
        let tiles = match settings.di {
            Some(d) => Some(LightTiles::new(
                ctx,
                &renderer.shared,
                d.tiles,
                d.tile_size,
            )?),
            None => None,
        };
        let gi_tiles = tiles
            .as_ref()
            .filter(|_| settings.di.is_some_and(|d| d.gi_tiles));
        let world = match settings.world {
            Some(w) => Some(WorldRestir::new(ctx, &renderer, w, gi_tiles)?),
            None => None,
        };
        let gi = match (settings.gi, settings.wgi) {
            (Some(g), _) => Some(RestirGi::new(ctx, &renderer, g)?),
            (None, Some(g)) => Some(RestirGi::world(ctx, &renderer, g)?),
            (None, None) => None,
        };
        let di = match (settings.di, &tiles) {
            (Some(d), Some(t)) => Some(RestirDi::new(ctx, &renderer, d, t)?),
            _ => None,
        };
        let cache = match settings.cache {
            Some(c) => Some(RadianceCache::new(ctx, &renderer, c)?),
            None => None,
        };
        let denoiser = match &settings.denoise {
            Some(d) => Some(Denoiser::new(ctx, &renderer, d)?),
            None => None,
        };
        Ok(Self {
            renderer,
            plan,
            tiles,
            world,
            gi,
            di,
            cache,
            denoiser,
        })
    }

    /// `world-restir` with `config`.
    pub fn world_restir(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        config: WorldRestirConfig,
        seed: u32,
    ) -> Result<Self, MethodError> {
        let settings = MethodSettings {
            world: Some(config),
            ..super::parse_spec("world-restir")?
        };
        Self::new(ctx, scene, camera, &settings, seed)
    }

    /// `restir-di` with `config`.
    pub fn restir_di(
        ctx: &GpuContext,
        scene: &Scene,
        camera: &Camera,
        config: RestirDiConfig,
        seed: u32,
    ) -> Result<Self, MethodError> {
        let settings = MethodSettings {
            di: Some(config),
            ..super::parse_spec("restir-di")?
        };
        Self::new(ctx, scene, camera, &settings, seed)
    }

    /// The world-restir stage, when the method has one.
    pub fn world(&self) -> Option<&WorldRestir> {
        self.world.as_ref()
    }

    /// The ReSTIR GI stage (screen or world space), when the method has one.
    pub fn gi(&self) -> Option<&RestirGi> {
        self.gi.as_ref()
    }

    /// The ReSTIR GI stage, mutable (tests plant defects in it).
    pub fn gi_mut(&mut self) -> Option<&mut RestirGi> {
        self.gi.as_mut()
    }

    /// The ReSTIR DI stage, when the method has one.
    pub fn di(&self) -> Option<&RestirDi> {
        self.di.as_ref()
    }

    /// The radiance cache, when the method has one.
    pub fn cache(&self) -> Option<&RadianceCache> {
        self.cache.as_ref()
    }

    /// The radiance cache, mutable (tests plant defects in it).
    pub fn cache_mut(&mut self) -> Option<&mut RadianceCache> {
        self.cache.as_mut()
    }

    /// The frame's steps.
    pub fn plan(&self) -> &FramePlan {
        &self.plan
    }

    /// The denoiser, when the method has one.
    pub fn denoiser(&self) -> Option<&Denoiser> {
        self.denoiser.as_ref()
    }

    /// The light tiles, when a stage draws from them.
    pub fn tiles(&self) -> Option<&LightTiles> {
        self.tiles.as_ref()
    }
}

impl FrameMethod for Composed {
    fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    fn encode_frame(&mut self, f: &mut FrameEncoder) -> Result<(), MethodError> {
        let r = &mut self.renderer;
        for &step in self.plan.steps() {
            let missing = || MethodError::Variant {
                method: "composed".into(),
                msg: format!("the plan's step {} has no stage", step.name()),
            };
            match step {
                Step::PrimaryAndGi => r.encode_primary_and_gi(f),
                Step::LightTiles => self.tiles.as_ref().ok_or_else(missing)?.encode(f),
                Step::CacheUpdate => self
                    .cache
                    .as_mut()
                    .ok_or_else(missing)?
                    .encode_update(f, r)?,
                Step::WorldRestir { .. } => {
                    self.world.as_mut().ok_or_else(missing)?.encode(f, r)?
                }
                Step::ShadeIndirect => r.encode_shade_indirect(f),
                Step::Path { cache: true, .. } => {
                    self.cache.as_ref().ok_or_else(missing)?.encode_path(f)
                }
                Step::Path { world: true, .. } => {
                    self.world.as_ref().ok_or_else(missing)?.encode_path(f, r)
                }
                Step::Path { .. } => r.encode_path(f),
                Step::RestirGi { .. } => self.gi.as_mut().ok_or_else(missing)?.encode(f, r)?,
                Step::RestirDi => self.di.as_mut().ok_or_else(missing)?.encode(f, r),
                Step::ShadeDirect => r.encode_shade_direct(f),
                Step::Accumulate => r.encode_accumulate(f),
                Step::Denoise => self.denoiser.as_mut().ok_or_else(missing)?.encode(f, r),
            }
        }
        Ok(())
    }

    fn set_camera(&mut self, camera: &Camera) -> Result<(), MethodError> {
        Ok(self.renderer.set_camera(camera)?)
    }

    fn restart_accumulation(&mut self, f: &mut FrameEncoder) {
        self.renderer.restart_accumulation(f);
    }

    fn grid_overflows(&self, ctx: &GpuContext) -> Result<Option<u32>, MethodError> {
        // Items left out of a grid: world-restir's and world-restir-gi's, added up.
        let world = match &self.world {
            Some(w) => Some(w.grid_stats(ctx)?.overflows),
            None => None,
        };
        let gi = match &self.gi {
            Some(g) => g.grid_stats(ctx)?.map(|s| s.overflows),
            None => None,
        };
        Ok(match (world, gi) {
            (None, None) => None,
            (a, b) => Some(a.unwrap_or(0) + b.unwrap_or(0)),
        })
    }

    fn frame_bytes(&self) -> u64 {
        self.renderer.bytes()
            + self.tiles.as_ref().map_or(0, LightTiles::bytes)
            + self.world.as_ref().map_or(0, WorldRestir::bytes)
            + self.gi.as_ref().map_or(0, RestirGi::bytes)
            + self.di.as_ref().map_or(0, RestirDi::bytes)
            + self.cache.as_ref().map_or(0, RadianceCache::bytes)
            + self.denoiser.as_ref().map_or(0, Denoiser::bytes)
    }

    fn reuse_bytes(&self) -> Option<u64> {
        self.gi.as_ref().map(RestirGi::bytes)
    }

    fn cache_stats(&self, ctx: &GpuContext) -> Result<Option<CacheStats>, MethodError> {
        match &self.cache {
            Some(c) => Ok(Some(c.stats(ctx)?)),
            None => Ok(None),
        }
    }

    fn read_denoised(&self, ctx: &GpuContext) -> Result<Option<FrameImages>, MethodError> {
        match &self.denoiser {
            Some(d) => Ok(Some(d.read(ctx, &self.renderer.gpu_camera())?)),
            None => Ok(None),
        }
    }

    fn denoise_iterations(
        &self,
        ctx: &GpuContext,
    ) -> Result<Option<Vec<Vec<[f32; 3]>>>, MethodError> {
        match &self.denoiser {
            Some(d) => Ok(Some(d.iteration_images(ctx, &self.renderer)?)),
            None => Ok(None),
        }
    }

    fn debug_image(
        &self,
        ctx: &GpuContext,
        view: DebugView,
    ) -> Result<Option<Vec<[f32; 3]>>, MethodError> {
        if let Some(d) = &self.denoiser {
            if let Some(image) = d.debug_image(ctx, view)? {
                return Ok(Some(image));
            }
        }
        if let Some(c) = &self.cache {
            if let Some(image) = c.debug_image(ctx, view)? {
                return Ok(Some(image));
            }
        }
        if let Some(gi) = &self.gi {
            if let Some(image) = gi.debug_image(ctx, view)? {
                return Ok(Some(image));
            }
        }
        match &self.world {
            Some(w) if matches!(view, DebugView::Cells | DebugView::M | DebugView::Overflow) => {
                Ok(Some(w.debug_image(ctx, view)?))
            }
            _ => Ok(None),
        }
    }
}
