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
    #[arg(long = "camera", allow_hyphen_values = true)]
    pub camera: Option<String>,
    /// Place N small emissive quads on the scene's own surfaces (picked by area, half a quad
    /// above the surface, facing away from it; deterministic in --scene-seed): any scene
    /// becomes a many-light scene.
    #[arg(long, default_value_t = 0,
          value_parser = clap::value_parser!(u32).range(0..=i64::from(scene::MAX_ADDED_LIGHTS)))]
    pub add_lights: u32,
    /// --add-lights: power of each light in watts, both sides (default: together the lights
    /// emit pi/4 per unit of the scene's surface area).
    #[arg(long, value_parser = positive_f32, allow_hyphen_values = true)]
    pub add_light_power: Option<f32>,
    /// --add-lights: side length of each quad in scene units (default: 0.5% of the scene's
    /// bounding-box diagonal).
    #[arg(long, value_parser = positive_f32, allow_hyphen_values = true)]
    pub add_light_size: Option<f32>,
    /// A constant sky of linear radiance R,G,B (or one value for grey) lighting the scene from
    /// every direction rays escape in.
    #[arg(
        long,
        value_name = "R,G,B",
        conflicts_with = "env",
        allow_hyphen_values = true
    )]
    pub sky: Option<String>,
    /// An equirectangular environment map (.hdr or .exr, linear radiance; the map's top row
    /// is straight up, its left edge looks along -z) lighting the scene.
    #[arg(long, value_name = "FILE.hdr|FILE.exr")]
    pub env: Option<std::path::PathBuf>,
    /// Scale of --env's (or --sky's) radiance.
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub env_intensity: Option<f32>,
    /// Scale of the scene file's punctual lights (KHR_lights_punctual intensities are candela
    /// and lux, rendered 1:1 as radiometric units: a 6830 lux sun outshines a surface of
    /// radiance 20 by far); 0 turns them off.
    #[arg(long, value_name = "K", default_value_t = 1.0, value_parser = non_negative_f32,
          allow_hyphen_values = true)]
    pub punctual_intensity: f32,
    /// The surfaces' materials: `scene` as the scene has them (glTF metallic-roughness where a
    /// file gives it); for comparison, `diffuse` every surface matte with its base colour, or
    /// `dielectric:R` / `metal:R` every surface that glTF material at perceptual roughness R in
    /// [0, 1] with its base colour (a method measured against the lobe's width).
    #[arg(long, value_parser = parse_materials, default_value = "scene")]
    pub materials: Materials,
}

/// `--materials`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Materials {
    Scene,
    Diffuse,
    /// Every surface glTF metallic-roughness with `metallic` (0 or 1) at `roughness`.
    Uniform {
        metallic: f32,
        roughness: f32,
    },
}

fn parse_materials(s: &str) -> Result<Materials, String> {
    let expected = "expected scene, diffuse, dielectric:R or metal:R (R a roughness in [0, 1])";
    match s.trim() {
        "scene" => return Ok(Materials::Scene),
        "diffuse" => return Ok(Materials::Diffuse),
        _ => {}
    }
    let (kind, r) = s
        .trim()
        .split_once(':')
        .ok_or_else(|| format!("{s:?}: {expected}"))?;
    let metallic = match kind {
        "dielectric" => 0.0,
        "metal" => 1.0,
        _ => return Err(format!("{s:?}: {expected}")),
    };
    match r.trim().parse::<f32>() {
        Ok(roughness) if (0.0..=1.0).contains(&roughness) => Ok(Materials::Uniform {
            metallic,
            roughness,
        }),
        _ => Err(format!("{s:?}: {expected}")),
    }
}

fn non_negative_f32(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!("expected a finite number >= 0, got {s:?}")),
    }
}

/// Parses `--sky`: `R,G,B` or one value, each finite and >= 0.
pub fn parse_sky(s: &str) -> Result<[f32; 3]> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--sky {s:?}: expected R,G,B or one number"))?;
    let rgb = match v[..] {
        [g] => [g; 3],
        [r, g, b] => [r, g, b],
        _ => anyhow::bail!("--sky {s:?}: expected R,G,B or one number"),
    };
    scene::Environment::constant(rgb).with_context(|| format!("--sky {s}"))?;
    Ok(rgb)
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

/// Applies `--materials`, `--camera`, `--add-lights`, `--sky` and `--env`.
fn prepare(s: &mut Scene, opts: &SceneArgs) -> Result<()> {
    match opts.materials {
        Materials::Scene => {}
        Materials::Diffuse => *s = std::mem::take(s).with_diffuse_materials(),
        Materials::Uniform {
            metallic,
            roughness,
        } => *s = std::mem::take(s).with_uniform_gloss(metallic, roughness),
    }
    if opts.punctual_intensity == 0.0 {
        s.lights.clear();
    }
    // Checked after scaling: a product above the cap (or infinite) is refused, not dropped.
    let k = opts.punctual_intensity;
    for l in &mut s.lights {
        let scaled = l.intensity * k;
        l.intensity = scaled;
        l.validate().map_err(|e| {
            anyhow::anyhow!(
                "--punctual-intensity {k:e}: light {:?}: {} x {k:e} = {scaled:e}: {e}",
                l.name,
                scaled / k
            )
        })?;
    }
    let k = opts.env_intensity;
    if let Some(k) = k {
        scene::environment::check_intensity("--env-intensity", k)?;
    }
    if let Some(sky) = &opts.sky {
        let rgb = parse_sky(sky)?.map(|c| c * k.unwrap_or(1.0));
        s.environment =
            Some(scene::Environment::constant(rgb).with_context(|| format!("--sky {sky}"))?);
    } else if let Some(path) = &opts.env {
        let mut env = scene::Environment::load(path, k.unwrap_or(1.0))
            .with_context(|| format!("--env {}", path.display()))?;
        // Messages about the map (the GPU's binding limit) name the flag and the file.
        env.source = format!("--env {}", path.display());
        s.environment = Some(env);
    } else if k.is_some() {
        anyhow::bail!("--env-intensity scales --env or --sky: give one of them");
    }
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
        .with_context(|| {
            let mut flags = format!("--add-lights {}", opts.add_lights);
            if let Some(p) = opts.add_light_power {
                flags.push_str(&format!(" --add-light-power {p:e}"));
            }
            if let Some(z) = opts.add_light_size {
                flags.push_str(&format!(" --add-light-size {z:e}"));
            }
            flags
        })?;
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
    // A black sky (`--sky 0`, `--env-intensity 0`, a map of zeros) lights nothing either.
    let sky = s
        .environment
        .as_ref()
        .is_some_and(|e| e.pixels.iter().flatten().any(|&c| c > 0.0));
    if restir_world::lights::Lights::build(s).is_empty() && !sky {
        eprintln!(
            "warning: {name}: the scene has no lights (no material emits, no punctual light, \
             no --sky or --env that is not black): it renders black"
        );
    }
}
