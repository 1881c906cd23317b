//! Writes a built-in scene as JSON for external renderers (the Mitsuba 3 references in
//! `tests/data/mitsuba`, made by `scripts/mitsuba/render_reference.py`).
//!
//! ```text
//! cargo run -p tests --example dump_scene -- cornell 64 64 tests/data/mitsuba/cornell-64x64.json
//! ```
//!
//! The JSON holds what those renderers need and nothing more: `triangles` (`[v0, v1, v2]`,
//! each `[x, y, z]`), `material` (one material index per triangle), `materials` (`albedo` and
//! `emission`, linear RGB; two-sided, emitting from both faces; Lambertian unless the material
//! also has `"model": "metal-roughness"` with its `metallic` and `roughness` factors, glTF 2.0's
//! metal-roughness model with `albedo` its base colour, see `restir_world::brdf`; a diffuse
//! material is written as before the model existed, so a diffuse scene's JSON is unchanged and
//! a reader that knows no `model` reads it alike) and `camera` (`eye`, `target`, `up`,
//! `vfov_deg` (vertical, degrees), `width`, `height`; pixel (0, 0) is the top-left one,
//! `forward x up` points right in the image). Scenes with anything else (vertex normals,
//! textures, punctual lights, an environment) are refused rather than half-written.

use std::process::ExitCode;

use restir_world::scene::{BuiltinOptions, Material, MaterialModel, Scene, builtin};
use serde_json::json;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("dump_scene: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [name, width, height, out] = args.as_slice() else {
        return Err("usage: dump_scene <builtin-name> <width> <height> <out.json>".into());
    };
    let parse = |s: &str| {
        s.parse::<u32>()
            .map_err(|e| format!("bad image size {s:?}: {e}"))
    };
    let (width, height) = (parse(width)?, parse(height)?);
    let scene = builtin(
        name,
        &BuiltinOptions {
            width,
            height,
            ..Default::default()
        },
    )
    .map_err(|e| e.to_string())?;

    check_supported(name, &scene)?;

    let cam = scene.camera_or_default(width, height);
    // f32 values as their shortest decimal (0.278, not 0.27800002694129944): read back as f32
    // they are the same numbers.
    let f = |x: f32| -> f64 { x.to_string().parse().unwrap() };
    let v = |p: glam::Vec3| p.to_array().map(f);
    let line = |value: serde_json::Value| value.to_string();
    let camera = json!({
        "eye": v(cam.eye),
        "target": v(cam.target),
        "up": v(cam.up),
        "vfov_deg": f(cam.vfov_deg),
        "width": cam.width,
        "height": cam.height,
    });
    let material_json = |m: &Material| {
        let mut j = json!({ "albedo": m.albedo.map(f), "emission": m.emission.map(f) });
        if m.model() == MaterialModel::MetalRoughness {
            j["model"] = json!("metal-roughness");
            j["metallic"] = json!(f(m.metallic));
            j["roughness"] = json!(f(m.roughness));
        }
        line(j)
    };
    let materials: Vec<String> = scene.materials.iter().map(material_json).collect();
    let material: Vec<u32> = scene.triangles.iter().map(|t| t.material).collect();
    let triangles: Vec<String> = scene
        .triangles
        .iter()
        .map(|t| line(json!(t.v.map(v))))
        .collect();
    // One material and one triangle per line: small, and diffs read well.
    let text = format!(
        "{{\n  \"scene\": {},\n  \"camera\": {},\n  \"materials\": [\n    {}\n  ],\n  \
         \"material\": {},\n  \"triangles\": [\n    {}\n  ]\n}}\n",
        line(json!(name)),
        line(camera),
        materials.join(",\n    "),
        line(json!(material)),
        triangles.join(",\n    "),
    );
    serde_json::from_str::<serde_json::Value>(&text).map_err(|e| format!("bad JSON: {e}"))?;
    std::fs::write(out, text).map_err(|e| format!("{out}: {e}"))?;
    eprintln!(
        "dump_scene: {name} {width}x{height}: {} triangles, {} materials -> {out}",
        scene.triangles.len(),
        scene.materials.len()
    );
    Ok(())
}

/// Refuses what the JSON cannot hold.
fn check_supported(name: &str, scene: &Scene) -> Result<(), String> {
    let unsupported = [
        (
            scene.triangles.iter().any(|t| t.n.is_some()),
            "vertex normals",
        ),
        (
            scene.triangles.iter().any(|t| t.uv.is_some()) || !scene.textures.is_empty(),
            "textures",
        ),
        (!scene.lights.is_empty(), "punctual lights"),
        (scene.environment.is_some(), "an environment"),
    ];
    if let Some((_, what)) = unsupported.iter().find(|(has, _)| *has) {
        return Err(format!(
            "scene {name:?} has {what}, which the JSON cannot hold"
        ));
    }
    Ok(())
}
