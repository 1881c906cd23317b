//! Scene loaders (glTF 2.0, OBJ+MTL) on small fixture files written by the tests into a temp
//! dir: what they read, and every bad-input case (malformed, truncated, missing, out-of-range,
//! NaN/degenerate geometry, empty, unsupported).

use std::path::{Path, PathBuf};

use glam::Vec3;
use restir_world::lights::Lights;
use restir_world::scene::{self, SceneError};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("restir-scene-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, contents).unwrap();
    p
}

/// Writes `contents` as `name` into `dir` and loads it.
fn load_written(dir: &Path, name: &str, contents: &str) -> scene::Loaded {
    scene::load(&write(dir, name, contents)).unwrap()
}

/// Asserts the error names the file and contains `needle`.
fn assert_err_names(e: &SceneError, path: &Path, needle: &str) {
    let msg = e.to_string();
    assert!(
        msg.contains(&path.display().to_string()),
        "error does not name {}: {msg}",
        path.display()
    );
    assert!(msg.contains(needle), "error lacks {needle:?}: {msg}");
}

const MTL: &str = "newmtl wall\nKd 0.5 0.25 0.125\nnewmtl lamp\nKd 0.1 0.1 0.1\nKe 4 5 6\n";

#[test]
fn obj_reads_geometry_materials_and_emission() {
    let d = temp_dir("obj-ok");
    write(&d, "box.mtl", MTL);
    let l = load_written(
        &d,
        "box.obj",
        "mtllib box.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\n\
         usemtl wall\nf 1 2 3 4\nusemtl lamp\nf 1 2 5\no other\nf 2 6 5\n",
    );
    assert!(l.report.is_clean(), "{}", l.report);
    assert_eq!(
        l.scene.triangles.len(),
        4,
        "quad triangulated + 2 triangles"
    );
    let mats: Vec<_> = l
        .scene
        .triangles
        .iter()
        .map(|t| l.scene.materials[t.material as usize])
        .collect();
    assert_eq!(mats[0].albedo, [0.5, 0.25, 0.125]);
    assert_eq!(mats[2].emission, [4.0, 5.0, 6.0]);
    assert_eq!(Lights::build(&l.scene).len(), 2);
    assert!(l.scene.camera.is_none());
}

#[test]
fn obj_bad_geometry_is_dropped_and_counted() {
    let d = temp_dir("obj-nan");
    let l = load_written(
        &d,
        "nan.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nv inf 1 1\nv 2 0 0\n\
         f 1 2 3\nf 1 4 2\nf 5 2 3\nf 1 2 6\nf 1 1 3\n",
    );
    assert_eq!(l.scene.triangles.len(), 1);
    assert_eq!(l.report.non_finite, 2, "{}", l.report);
    assert_eq!(l.report.degenerate, 2, "{}", l.report);
    assert!(l.report.to_string().contains("dropped 4 triangles"));
}

#[test]
fn obj_errors_name_the_file() {
    let d = temp_dir("obj-bad");
    let oob = write(&d, "oob.obj", "v 0 0 0\nv 1 0 0\nf 1 2 9\n");
    assert_err_names(&scene::load(&oob).unwrap_err(), &oob, "out of bounds");
    let garbage = write(&d, "garbage.obj", "v 0 zero 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_err_names(&scene::load(&garbage).unwrap_err(), &garbage, "OBJ");
    let missing = d.join("missing.obj");
    let e = scene::load(&missing).unwrap_err();
    assert!(matches!(e, SceneError::Io { .. }), "{e}");
    assert_err_names(&e, &missing, "");
    let empty = write(&d, "empty.obj", "# nothing\n");
    let e = scene::load(&empty).unwrap_err();
    assert!(matches!(e, SceneError::Empty { .. }), "{e}");
    assert_err_names(&e, &empty, "no valid triangles");
    let all_bad = write(&d, "allbad.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    assert_err_names(&scene::load(&all_bad).unwrap_err(), &all_bad, "NaN/Inf");
    let txt = write(&d, "scene.txt", "hello");
    assert!(matches!(
        scene::load(&txt),
        Err(SceneError::UnsupportedFormat { .. })
    ));
}

#[test]
fn obj_missing_material_library_warns_and_uses_grey() {
    let d = temp_dir("obj-nomtl");
    let l = load_written(
        &d,
        "a.obj",
        "mtllib nowhere.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n",
    );
    assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
    assert!(l.warnings[0].contains("a.obj"));
    let m = l.scene.materials[l.scene.triangles[0].material as usize];
    assert_eq!(m.albedo, scene::DEFAULT_ALBEDO);
    // No emitters at all: allowed, nothing to sample.
    assert!(Lights::build(&l.scene).is_empty());
}

/// One triangle (0,0,0) (1,0,0) (0,1,0) with u16 indices: the binary buffer (36 + 6 bytes,
/// padded to 44).
fn triangle_bin(index_2: u16) -> Vec<u8> {
    let mut b: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    for i in [0u16, 1, index_2] {
        b.extend(i.to_le_bytes());
    }
    b.extend([0, 0]);
    b
}

/// The glTF JSON around a buffer `uri` (None: the GLB chunk) of `len` bytes.
fn gltf_json(uri: Option<&str>, len: usize, textured: bool) -> String {
    let uri = uri
        .map(|u| format!(r#""uri": "{u}", "#))
        .unwrap_or_default();
    let texture = if textured {
        r#", "baseColorTexture": {"index": 0}"#
    } else {
        ""
    };
    let textures = if textured {
        r#""images": [{"uri": "t.png"}], "textures": [{"source": 0}],"#
    } else {
        ""
    };
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_materials_emissive_strength"],
  "scene": 0,
  "scenes": [{{"nodes": [0, 2]}}],
  "nodes": [
    {{"translation": [0, 0, 5], "children": [1]}},
    {{"mesh": 0, "scale": [2, 2, 2]}},
    {{"camera": 0, "translation": [0, 0, 10]}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.5, "znear": 0.1, "aspectRatio": 2.0}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{{
    "pbrMetallicRoughness": {{"baseColorFactor": [0.2, 0.4, 0.6, 1.0]{texture}}},
    "emissiveFactor": [1.0, 0.5, 0.25],
    "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 8.0}}}}
  }}],
  {textures}
  "buffers": [{{{uri}"byteLength": {len}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 36, "byteLength": 6}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}}
  ]
}}"#
    )
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

fn check_triangle_scene(l: &scene::Loaded) {
    let s = &l.scene;
    assert_eq!(s.triangles.len(), 1);
    // Node transforms compose: parent translation (0,0,5) x child scale 2.
    assert_eq!(
        s.triangles[0].v,
        [
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::new(2.0, 0.0, 5.0),
            Vec3::new(0.0, 2.0, 5.0)
        ]
    );
    let m = s.materials[s.triangles[0].material as usize];
    assert_eq!(m.albedo, [0.2, 0.4, 0.6]);
    assert_eq!(m.emission, [8.0, 4.0, 2.0], "emissiveFactor x strength");
    let cam = s.camera.expect("camera from the file");
    assert_eq!(cam.eye, Vec3::new(0.0, 0.0, 10.0));
    assert!((cam.target - cam.eye - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
    assert!((cam.vfov_deg - 0.5f32.to_degrees()).abs() < 1e-4);
    assert_eq!((cam.width, cam.height), (512, 256));
}

#[test]
fn gltf_with_data_uri_reads_transforms_materials_and_camera() {
    let d = temp_dir("gltf-ok");
    let bin = triangle_bin(2);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        tests::scenes::base64(&bin)
    );
    let p = write(&d, "t.gltf", gltf_json(Some(&uri), 42, false));
    let l = scene::load(&p).unwrap();
    check_triangle_scene(&l);
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    // External .bin next to the file.
    write(&d, "t.bin", &bin);
    write(&d, "t.png", b"");
    let p = write(&d, "ext.gltf", gltf_json(Some("t.bin"), 42, true));
    let l = scene::load(&p).unwrap();
    check_triangle_scene(&l);
    // The empty t.png cannot be decoded: one warning, the factor is kept.
    assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
    assert!(
        l.warnings[0].contains("cannot be decoded"),
        "{:?}",
        l.warnings
    );
}

#[test]
fn glb_reads_and_truncated_glb_is_an_error() {
    let d = temp_dir("glb");
    let bytes = glb(&gltf_json(None, 42, false), &triangle_bin(2));
    let p = write(&d, "t.glb", &bytes);
    check_triangle_scene(&scene::load(&p).unwrap());
    for cut in [bytes.len() - 10, bytes.len() / 2, 30, 5, 0] {
        let p = write(&d, &format!("cut{cut}.glb"), &bytes[..cut]);
        let e = scene::load(&p).unwrap_err();
        assert_err_names(&e, &p, "");
    }
}

#[test]
fn gltf_errors_name_the_file() {
    let d = temp_dir("gltf-bad");
    let bin = triangle_bin(2);
    // Malformed JSON.
    let p = write(&d, "broken.gltf", &gltf_json(None, 42, false)[..200]);
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "glTF");
    // Buffer shorter than declared.
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        tests::scenes::base64(&bin[..20])
    );
    let p = write(&d, "short.gltf", gltf_json(Some(&uri), 42, false));
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "truncated");
    // Missing external buffer.
    let p = write(&d, "nobin.gltf", gltf_json(Some("gone.bin"), 42, false));
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "gone.bin");
    // Index out of range.
    let bad = triangle_bin(7);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        tests::scenes::base64(&bad)
    );
    let p = write(&d, "oob.gltf", gltf_json(Some(&uri), 42, false));
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "out of range");
    // Invalid base64.
    let p = write(
        &d,
        "b64.gltf",
        gltf_json(Some("data:application/octet-stream;base64,@@@@"), 42, false),
    );
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "base64");
    // Missing file.
    let p = d.join("absent.glb");
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "");
}

/// `gltf_json` (data-URI buffer) with `extensionsRequired` set to `required`.
fn gltf_requiring(required: &[&str], textured: bool) -> String {
    let bin = triangle_bin(2);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        tests::scenes::base64(&bin)
    );
    let list: Vec<String> = required.iter().map(|e| format!("{e:?}")).collect();
    gltf_json(Some(&uri), 42, textured).replacen(
        r#""asset": {"version": "2.0"},"#,
        &format!(
            r#""asset": {{"version": "2.0"}}, "extensionsRequired": [{}],"#,
            list.join(", ")
        ),
        1,
    )
}

#[test]
fn gltf_required_extensions_are_used_ignored_or_refused() {
    let d = temp_dir("gltf-ext");
    // Supported: no warning.
    let p = write(
        &d,
        "ok.gltf",
        gltf_requiring(
            &[
                "KHR_materials_emissive_strength",
                "KHR_texture_transform",
                "KHR_lights_punctual",
            ],
            false,
        ),
    );
    let l = scene::load(&p).unwrap();
    check_triangle_scene(&l);
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    // Appearance only: one warning each (a duplicate listing warns once), the scene loads.
    let p = write(
        &d,
        "looks.gltf",
        gltf_requiring(
            &[
                "AMD_split_roughnessMetallic",
                "KHR_materials_clearcoat",
                "KHR_texture_basisu",
                "AMD_split_roughnessMetallic",
                "VENDOR_something_new",
            ],
            false,
        ),
    );
    let l = scene::load(&p).unwrap();
    check_triangle_scene(&l);
    assert_eq!(l.warnings.len(), 4, "{:?}", l.warnings);
    for (w, ext) in l.warnings.iter().zip([
        "AMD_split_roughnessMetallic",
        "KHR_materials_clearcoat",
        "KHR_texture_basisu",
        "VENDOR_something_new",
    ]) {
        assert!(w.contains(ext) && w.contains("ignored"), "{w}");
        assert!(w.contains(&p.display().to_string()), "{w}");
    }
    assert!(l.warnings[3].contains("unknown"), "{}", l.warnings[3]);
    // Geometry: refused, naming the extension and the file.
    for ext in [
        "KHR_draco_mesh_compression",
        "EXT_meshopt_compression",
        "KHR_mesh_quantization",
    ] {
        let p = write(
            &d,
            &format!("{ext}.gltf"),
            gltf_requiring(&["KHR_texture_transform", ext], false),
        );
        assert_err_names(&scene::load(&p).unwrap_err(), &p, ext);
    }
    // Quantized positions without the extension listed: refused too, not read as floats.
    let p = write(
        &d,
        "quantized.gltf",
        gltf_requiring(&[], false).replacen(
            r#""componentType": 5126"#,
            r#""componentType": 5122"#,
            1,
        ),
    );
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "not 32-bit float");
}

#[test]
fn gltf_cameras_in_file_order_named_with_unit_up() {
    let d = temp_dir("gltf-cams");
    let json = gltf_requiring(&[], false)
        .replace(r#""nodes": [0, 2]"#, r#""nodes": [2, 0, 3]"#)
        .replace(
            r#"{"camera": 0, "translation": [0, 0, 10]}"#,
            r#"{"camera": 0, "translation": [0, 0, 10], "name": "Front"},
    {"camera": 1, "translation": [0, 0, 20], "scale": [0.5, 0.5, 0.5]}"#,
        )
        .replace(
            r#""cameras": ["#,
            r#""cameras": [{"type": "perspective", "name": "Far", "perspective": {"yfov": 0.7, "znear": 0.1}}, "#,
        )
        .replace(r#""camera": 0, "translation": [0, 0, 10]"#, r#""camera": 1, "translation": [0, 0, 10]"#)
        .replace(r#""camera": 1, "translation": [0, 0, 20]"#, r#""camera": 0, "translation": [0, 0, 20]"#);
    let p = write(&d, "cams.gltf", json);
    let l = scene::load(&p).unwrap();
    let names: Vec<&str> = l.scene.cameras.iter().map(|c| c.name.as_str()).collect();
    // Node 2 ("Front", camera 1) comes first in the scene's node list, then node 3 (camera 0,
    // unnamed node: the camera's name).
    assert_eq!(names, ["Front", "Far"]);
    assert_eq!(
        l.scene.camera,
        Some(l.scene.cameras[0].camera),
        "the first is the default"
    );
    for c in &l.scene.cameras {
        assert!((c.camera.up.length() - 1.0).abs() < 1e-6, "{}", c.camera.up);
        assert!(((c.camera.target - c.camera.eye).length() - 1.0).abs() < 1e-6);
    }
    let mut s = l.scene.clone();
    s.select_camera("Far").unwrap();
    assert_eq!(s.camera.unwrap().eye, Vec3::new(0.0, 0.0, 20.0));
    let e = s.select_camera("5").unwrap_err().to_string();
    assert!(e.contains(r#"0 "Front", 1 "Far""#), "{e}");
}

#[test]
fn gltf_punctual_lights_are_parsed_validated_and_said_unrendered() {
    let d = temp_dir("gltf-lights");
    let json = gltf_requiring(&["KHR_lights_punctual"], false)
        .replace(r#""nodes": [0, 2]"#, r#""nodes": [0, 2, 3, 4, 5, 6]"#)
        .replace(
            r#"{"camera": 0, "translation": [0, 0, 10]}"#,
            r#"{"camera": 0, "translation": [0, 0, 10]},
    {"name": "Bulb", "translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
    {"rotation": [-0.7071068, 0, 0, 0.7071068], "translation": [0, 5, 0], "scale": [3, 3, 3],
     "extensions": {"KHR_lights_punctual": {"light": 1}}},
    {"extensions": {"KHR_lights_punctual": {"light": 2}}},
    {"extensions": {"KHR_lights_punctual": {"light": 3}}}"#,
        )
        .replace(
            r#""asset": {"version": "2.0"},"#,
            r#""asset": {"version": "2.0"},
  "extensions": {"KHR_lights_punctual": {"lights": [
    {"type": "point", "color": [1, 0.5, 0.25], "intensity": 40, "range": 10},
    {"type": "spot", "name": "Spot", "intensity": 100, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
    {"type": "directional", "name": "Sun", "intensity": 6830},
    {"type": "spot", "name": "Bad", "spot": {"innerConeAngle": 0.6, "outerConeAngle": 0.5}}
  ]}},"#,
        );
    let p = write(&d, "lights.gltf", json);
    let l = scene::load(&p).unwrap();
    check_triangle_scene(&l);
    let lights = &l.scene.lights;
    let names: Vec<&str> = lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Bulb", "Spot", "Sun"]);
    assert_eq!(lights[0].kind, scene::PunctualKind::Point);
    assert_eq!(lights[0].position, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(
        (lights[0].color, lights[0].intensity, lights[0].range),
        ([1.0, 0.5, 0.25], 40.0, Some(10.0))
    );
    // Rotated -90 degrees about x (and scaled): the spot points down, unit length.
    assert!(
        (lights[1].direction - Vec3::NEG_Y).length() < 1e-5,
        "{}",
        lights[1].direction
    );
    assert_eq!(lights[1].position, Vec3::new(0.0, 5.0, 0.0));
    assert_eq!(
        lights[1].kind,
        scene::PunctualKind::Spot {
            inner_cone: 0.2,
            outer_cone: 0.5
        }
    );
    assert_eq!(lights[2].kind, scene::PunctualKind::Directional);
    assert_eq!(lights[2].color, [1.0; 3], "default colour");
    // The lights are rendered (no "not rendered" warning); only the invalid one is reported.
    assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
    assert!(l.warnings[0].contains("\"Bad\" skipped") && l.warnings[0].contains("cone"));
}

#[test]
fn gltf_texture_with_only_a_dds_source_and_missing_images_load() {
    let d = temp_dir("gltf-dds");
    let json = gltf_requiring(&["MSFT_texture_dds"], true).replace(
        r#""images": [{"uri": "t.png"}], "textures": [{"source": 0}],"#,
        r#""images": [{"uri": "t.dds"}], "textures": [{"extensions": {"MSFT_texture_dds": {"source": 0}}}],"#,
    );
    assert!(json.contains("t.dds"));
    let p = write(&d, "dds.gltf", json);
    let l = scene::load(&p).unwrap();
    check_triangle_scene(&l);
    let joined = l.warnings.join("\n");
    assert_eq!(l.warnings.len(), 2, "{joined}");
    assert!(joined.contains("MSFT_texture_dds"), "{joined}");
    assert!(joined.contains("1 image files are missing"), "{joined}");
    assert!(l.scene.textures.is_empty());
}

#[test]
fn gltf_undecodable_texture_keeps_the_factor_with_a_warning() {
    let d = temp_dir("gltf-bad-png");
    let p = write(&d, "bad.gltf", gltf_requiring(&[], true));
    std::fs::write(d.join("t.png"), b"not a png at all").unwrap();
    let l = scene::load(&p).unwrap();
    let joined = l.warnings.join("\n");
    assert!(joined.contains("cannot be decoded"), "{joined}");
    assert!(joined.contains("bad.gltf"), "{joined}");
    assert!(l.scene.textures.is_empty());
    assert!(
        l.scene
            .materials
            .iter()
            .all(|m| m.base_color_texture == 0 && m.emissive_texture == 0)
    );
    // A decodable one is read, its material refers to it.
    image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 128, 0, 255]))
        .save(d.join("t.png"))
        .unwrap();
    let l = scene::load(&p).unwrap();
    assert_eq!(l.scene.textures.len(), 1, "{:?}", l.warnings);
    assert_eq!(l.scene.textures[0].texels[0], [255, 128, 0, 255]);
}

#[test]
fn gltf_degenerate_and_nan_geometry_is_dropped() {
    let d = temp_dir("gltf-nan");
    let mut bin = triangle_bin(2);
    // A NaN in the third vertex.
    bin[24..28].copy_from_slice(&f32::NAN.to_le_bytes());
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        tests::scenes::base64(&bin)
    );
    let p = write(&d, "nan.gltf", gltf_json(Some(&uri), 42, false));
    let e = scene::load(&p).unwrap_err();
    assert!(matches!(e, SceneError::Empty { .. }), "{e}");
    assert_err_names(&e, &p, "1 with NaN/Inf");
    // Degenerate: all three indices the same vertex would fail validation elsewhere; use
    // index 1 twice.
    let bin = triangle_bin(1);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        tests::scenes::base64(&bin)
    );
    let p = write(&d, "degen.gltf", gltf_json(Some(&uri), 42, false));
    assert_err_names(&scene::load(&p).unwrap_err(), &p, "1 degenerate");
}

#[test]
fn builtin_scene_names_and_options() {
    let opts = scene::BuiltinOptions::default();
    for name in scene::BUILTIN_NAMES {
        let s = scene::builtin(name, &opts).unwrap();
        let c = s.camera.unwrap();
        assert_eq!((c.width, c.height), (256, 256));
    }
    let e = scene::builtin("kitchen", &opts).unwrap_err();
    assert!(e.to_string().contains("cornell"), "{e}");
    let zero = scene::BuiltinOptions { width: 0, ..opts };
    assert!(scene::builtin("cornell", &zero).is_err());
}

/// Guards glTF's metallic-roughness materials as the loader reads them: the factors into the
/// material (the file's default metallic and roughness are glTF's 1), its model glossy;
/// factors outside [0, 1] (or NaN, which JSON cannot carry but a hand-built scene can) warn
/// naming the material and are clamped by sanitize; `--materials diffuse` keeps the base
/// colour and drops the rest.
#[test]
fn gltf_metallic_roughness_is_read_clamped_and_can_be_dropped() {
    let d = temp_dir("gltf-pbr");
    let bin = triangle_bin(2);
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        tests::scenes::base64(&bin)
    );
    let json = gltf_json(Some(&uri), 42, false).replace(
        r#""baseColorFactor": [0.2, 0.4, 0.6, 1.0]"#,
        r#""baseColorFactor": [0.2, 0.4, 0.6, 1.0], "metallicFactor": 0.25, "roughnessFactor": 1.5"#,
    );
    let p = write(&d, "pbr.gltf", json);
    let l = scene::load(&p).unwrap();
    let m = l.scene.materials[l.scene.triangles[0].material as usize];
    assert_eq!(m.model(), scene::MaterialModel::MetalRoughness);
    assert_eq!(
        (m.metallic, m.roughness),
        (0.25, 1.0),
        "roughness clamped to 1"
    );
    assert_eq!(l.report.clamped_materials, 1, "{}", l.report);
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains("material 0") && w.contains("roughnessFactor 1.5")),
        "{:?}",
        l.warnings
    );
    // Without the fields: glTF's defaults, a rough metal.
    let p = write(&d, "default.gltf", gltf_json(Some(&uri), 42, false));
    let l = scene::load(&p).unwrap();
    let m = l.scene.materials[0];
    assert_eq!(
        (m.model(), m.metallic, m.roughness),
        (scene::MaterialModel::MetalRoughness, 1.0, 1.0)
    );
    let matte = l.scene.with_diffuse_materials();
    assert_eq!(matte.materials[0].model(), scene::MaterialModel::Diffuse);
    assert_eq!(matte.materials[0].albedo, [0.2, 0.4, 0.6]);
    assert_eq!(matte.materials[0].emission, [8.0, 4.0, 2.0]);
    // A hand-built NaN factor is clamped to 1 and counted.
    let mut s = matte;
    s.materials[0] = scene::Material::metal_roughness([0.5; 3], f32::NAN, -2.0);
    let r = s.sanitize("hand-built").unwrap();
    assert_eq!(r.clamped_materials, 1);
    assert_eq!(
        (s.materials[0].metallic, s.materials[0].roughness),
        (1.0, 0.0)
    );
}

/// Guards the MTL PBR extension's mapping (the same model as glTF's): `Pm`/`Pr` make a
/// material metallic-roughness with Kd as its base colour; `Ns` stands in for a missing `Pr`
/// (GGX alpha = sqrt(2 / (Ns + 2)), roughness = sqrt(alpha)); a material without `Pm` and `Pr`
/// stays diffuse whatever its `Ns`; a bad `Pm` is an error naming the line.
#[test]
fn mtl_pbr_extension_maps_to_metallic_roughness() {
    let d = temp_dir("obj-pbr");
    write(
        &d,
        "pbr.mtl",
        "newmtl metal\nKd 0.9 0.8 0.7\nPm 1\nPr 0.3\n\
         newmtl phong\nKd 0.5 0.5 0.5\nPm 0.5\nNs 98\n\
         newmtl matte\nKd 0.4 0.4 0.4\nNs 10\n",
    );
    let l = load_written(
        &d,
        "pbr.obj",
        "mtllib pbr.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl metal\nf 1 2 3\nusemtl phong\nf 1 2 3\n\
         usemtl matte\nf 1 2 3\n",
    );
    let m = |k: usize| l.scene.materials[l.scene.triangles[k].material as usize];
    assert_eq!(m(0).model(), scene::MaterialModel::MetalRoughness);
    assert_eq!(
        (m(0).albedo, m(0).metallic, m(0).roughness),
        ([0.9, 0.8, 0.7], 1.0, 0.3)
    );
    // Ns 98: alpha = sqrt(2 / 100) = 0.1414, roughness = 0.376.
    assert_eq!(m(1).metallic, 0.5);
    assert!(
        (m(1).roughness - 0.02f32.sqrt().sqrt()).abs() < 1e-6,
        "{}",
        m(1).roughness
    );
    assert_eq!(m(2).model(), scene::MaterialModel::Diffuse);
    write(&d, "bad.mtl", "newmtl x\nKd 1 1 1\nPm metal\n");
    let p = write(
        &d,
        "bad.obj",
        "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl x\nf 1 2 3\n",
    );
    let e = scene::load(&p).unwrap_err();
    assert!(
        e.to_string().contains("MTL line 3: Pm expects one number"),
        "{e}"
    );
}
