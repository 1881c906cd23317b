//! Scene flags and loading, shared by `info`, `render` and `compare`.

use std::path::Path;

use anyhow::{Context, Result};
use restir_world::scene::{self, Scene};

#[derive(clap::Args, Debug, Clone)]
pub struct SceneArgs {
    /// many-lights: number of emissive quads.
    #[arg(long, default_value_t = 10_000)]
    pub lights: u32,
    /// furnace: albedo of every surface.
    #[arg(long, default_value_t = 0.5)]
    pub rho: f32,
    /// furnace: emitted radiance of every surface.
    #[arg(long, default_value_t = 1.0)]
    pub le: f32,
    /// Seed of the generated scene (many-lights) and of --add-lights' placement.
    #[arg(long, default_value_t = 1)]
    pub scene_seed: u32,
    /// The scene file's camera to use, by name or index (`info --scene FILE` lists them).
    /// Default: the file's first camera; a file without one gets a default framing.
    #[arg(long = "camera")]
    pub camera: Option<String>,
    /// Place N small emissive quads on the scene's own surfaces (picked by area, half a quad
    /// above the surface, facing away from it; deterministic in --scene-seed): any scene
    /// becomes a many-light scene.
    #[arg(long, default_value_t = 0,
          value_parser = clap::value_parser!(u32).range(0..=i64::from(scene::MAX_ADDED_LIGHTS)))]
    pub add_lights: u32,
    /// --add-lights: power of each light in watts, both sides (default: together the lights
    /// emit pi/4 per unit of the scene's surface area).
    #[arg(long, value_parser = positive_f32)]
    pub add_light_power: Option<f32>,
    /// --add-lights: side length of each quad in scene units (default: 0.5% of the scene's
    /// bounding-box diagonal).
    #[arg(long, value_parser = positive_f32)]
    pub add_light_size: Option<f32>,
}

fn positive_f32(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("expected a finite number above 0, got {s:?}")),
    }
}

/// A built-in scene by name or a scene file, sanitized; warnings go to stderr.
pub fn load(name: &str, opts: &SceneArgs, size: Option<(u32, u32)>) -> Result<Scene> {
    if scene::BUILTIN_NAMES.contains(&name) {
        let (width, height) = size.unwrap_or((256, 256));
        let mut s = scene::builtin(
            name,
            &scene::BuiltinOptions {
                lights: opts.lights,
                seed: opts.scene_seed,
                rho: opts.rho,
                le: opts.le,
                width,
                height,
            },
        )?;
        s.sanitize(name)?;
        prepare(&mut s, opts)?;
        warn_if_dark(name, &s);
        return Ok(s);
    }
    let path = Path::new(name);
    if path.extension().is_none() && !path.exists() {
        anyhow::bail!(
            "{name:?} is neither a built-in scene ({}) nor a scene file",
            scene::BUILTIN_NAMES.join(", ")
        );
    }
    let loaded = scene::load(path)?;
    if !loaded.report.is_clean() {
        eprintln!("warning: {}: {}", path.display(), loaded.report);
    }
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    let mut s = loaded.scene;
    prepare(&mut s, opts)?;
    warn_if_dark(name, &s);
    Ok(s)
}

/// Applies `--camera` and `--add-lights`.
fn prepare(s: &mut Scene, opts: &SceneArgs) -> Result<()> {
    if let Some(c) = &opts.camera {
        s.select_camera(c)
            .with_context(|| format!("--camera {c}"))?;
    }
    if opts.add_lights > 0 {
        let r = scene::add_lights(
            s,
            &scene::AddLights {
                count: opts.add_lights,
                power: opts.add_light_power,
                size: opts.add_light_size,
                seed: opts.scene_seed,
            },
        )
        .context("--add-lights")?;
        eprintln!(
            "added {} lights: {:.3e} x {:.3e} quads of {:.3e} W each",
            opts.add_lights, r.size, r.size, r.power
        );
    } else if opts.add_light_power.is_some() || opts.add_light_size.is_some() {
        anyhow::bail!("--add-light-power and --add-light-size need --add-lights N (N > 0)");
    }
    Ok(())
}

/// A scene without emitters renders black: say so.
pub fn warn_if_dark(name: &str, s: &Scene) {
    if s.emissive_triangles() == 0 {
        eprintln!("warning: {name}: the scene has no lights (no material emits): it renders black");
    }
}
