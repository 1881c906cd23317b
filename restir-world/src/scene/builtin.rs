//! Built-in procedural scenes: `cornell` (and `cornell-glossy`), `many-lights`, `colonnade`,
//! `glossy`, `furnace` and `furnace-sphere`.

use glam::Vec3;
use reservoir::rng::Rng;

use super::{Camera, Material, Scene, SceneError, luminance};

/// Names accepted by [`builtin`].
pub const BUILTIN_NAMES: [&str; 7] = [
    "cornell",
    "cornell-glossy",
    "many-lights",
    "colonnade",
    "glossy",
    "furnace",
    "furnace-sphere",
];

/// Parameters of the built-in scenes (each scene reads the ones it needs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuiltinOptions {
    /// `many-lights`: number of small emissive quads (default 10,000; tested up to 100,000).
    pub lights: u32,
    /// `many-lights`: seed of the light placement, colours and powers.
    pub seed: u32,
    /// `furnace`: albedo of every surface (grey).
    pub rho: f32,
    /// `furnace`: emitted radiance of every surface (grey).
    pub le: f32,
    /// Image size of the default camera.
    pub width: u32,
    pub height: u32,
}

impl Default for BuiltinOptions {
    fn default() -> Self {
        Self {
            lights: 10_000,
            seed: 1,
            rho: 0.5,
            le: 1.0,
            width: 256,
            height: 256,
        }
    }
}

/// A built-in scene by name (see [`BUILTIN_NAMES`]), with its default camera.
pub fn builtin(name: &str, opts: &BuiltinOptions) -> Result<Scene, SceneError> {
    if opts.width == 0 || opts.height == 0 {
        return Err(SceneError::BadOption(
            "image size must be at least 1x1".into(),
        ));
    }
    match name {
        "cornell" => Ok(cornell(opts.width, opts.height)),
        "cornell-glossy" => Ok(cornell_glossy(opts.width, opts.height)),
        "glossy" => Ok(glossy(opts.seed, opts.width, opts.height)),
        "many-lights" => many_lights(opts.lights, opts.seed, opts.width, opts.height),
        "colonnade" => Ok(colonnade(opts.seed, opts.width, opts.height)),
        "furnace" => furnace(opts.rho, opts.le, opts.width, opts.height),
        "furnace-sphere" => furnace_sphere(opts.rho, opts.le, opts.width, opts.height),
        _ => Err(SceneError::UnknownBuiltin { name: name.into() }),
    }
}

/// The Cornell box from the Cornell University Program of Computer Graphics' published
/// measurements ("Cornell Box Data", graphics.cornell.edu/online/box/data.html): the measured
/// geometry in millimetres scaled to metres (x 0.001): floor 552.8 x 559.2 (slightly
/// non-rectangular, as measured), ceiling at y = 548.8 with the light 343-213 (x) by 227-332 (z),
/// the short and the tall block. The ceiling is cut around the light so the two do not overlap.
///
/// Reflectances are the usual RGB approximations of the measured spectra: white 0.73,
/// red (0.63, 0.065, 0.05), green (0.14, 0.45, 0.091). The light's radiance (17, 12, 4) is the
/// RGB approximation used by the common pbrt/Mitsuba conversions of this scene. The camera is
/// the published one: eye (278, 273, -800) mm looking along +z, 35 mm focal length on a
/// 25 mm film, i.e. a vertical field of view of 2 atan(12.5 / 35) = 39.3 degrees.
pub fn cornell(width: u32, height: u32) -> Scene {
    let mut s = Scene::default();
    let white = s.add_material(Material::new([0.73; 3], [0.0; 3]));
    let red = s.add_material(Material::new([0.63, 0.065, 0.05], [0.0; 3]));
    let green = s.add_material(Material::new([0.14, 0.45, 0.091], [0.0; 3]));
    let light = s.add_material(Material::new([0.78; 3], [17.0, 12.0, 4.0]));
    let mm = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * 0.001;
    let quad = |s: &mut Scene, q: [[f32; 3]; 4], m: u32| {
        s.push_quad(q.map(|p| mm(p[0], p[1], p[2])), m);
    };
    // Floor.
    quad(
        &mut s,
        [
            [552.8, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 559.2],
            [549.6, 0.0, 559.2],
        ],
        white,
    );
    // Ceiling (556 x 559.2 at y = 548.8) in four pieces around the light's hole.
    let y = 548.8;
    for (x0, x1, z0, z1) in [
        (0.0, 556.0, 0.0, 227.0),
        (0.0, 556.0, 332.0, 559.2),
        (0.0, 213.0, 227.0, 332.0),
        (343.0, 556.0, 227.0, 332.0),
    ] {
        quad(
            &mut s,
            [[x1, y, z0], [x1, y, z1], [x0, y, z1], [x0, y, z0]],
            white,
        );
    }
    // Light.
    quad(
        &mut s,
        [
            [343.0, y, 227.0],
            [343.0, y, 332.0],
            [213.0, y, 332.0],
            [213.0, y, 227.0],
        ],
        light,
    );
    // Back wall.
    quad(
        &mut s,
        [
            [549.6, 0.0, 559.2],
            [0.0, 0.0, 559.2],
            [0.0, 548.8, 559.2],
            [556.0, 548.8, 559.2],
        ],
        white,
    );
    // Right wall (green, x = 0).
    quad(
        &mut s,
        [
            [0.0, 0.0, 559.2],
            [0.0, 0.0, 0.0],
            [0.0, 548.8, 0.0],
            [0.0, 548.8, 559.2],
        ],
        green,
    );
    // Left wall (red, x ~ 550).
    quad(
        &mut s,
        [
            [552.8, 0.0, 0.0],
            [549.6, 0.0, 559.2],
            [556.0, 548.8, 559.2],
            [556.0, 548.8, 0.0],
        ],
        red,
    );
    // Short block: top, then four sides.
    let short: [[[f32; 3]; 4]; 5] = [
        [
            [130.0, 165.0, 65.0],
            [82.0, 165.0, 225.0],
            [240.0, 165.0, 272.0],
            [290.0, 165.0, 114.0],
        ],
        [
            [290.0, 0.0, 114.0],
            [290.0, 165.0, 114.0],
            [240.0, 165.0, 272.0],
            [240.0, 0.0, 272.0],
        ],
        [
            [130.0, 0.0, 65.0],
            [130.0, 165.0, 65.0],
            [290.0, 165.0, 114.0],
            [290.0, 0.0, 114.0],
        ],
        [
            [82.0, 0.0, 225.0],
            [82.0, 165.0, 225.0],
            [130.0, 165.0, 65.0],
            [130.0, 0.0, 65.0],
        ],
        [
            [240.0, 0.0, 272.0],
            [240.0, 165.0, 272.0],
            [82.0, 165.0, 225.0],
            [82.0, 0.0, 225.0],
        ],
    ];
    // Tall block: top, then four sides.
    let tall: [[[f32; 3]; 4]; 5] = [
        [
            [423.0, 330.0, 247.0],
            [265.0, 330.0, 296.0],
            [314.0, 330.0, 456.0],
            [472.0, 330.0, 406.0],
        ],
        [
            [423.0, 0.0, 247.0],
            [423.0, 330.0, 247.0],
            [472.0, 330.0, 406.0],
            [472.0, 0.0, 406.0],
        ],
        [
            [472.0, 0.0, 406.0],
            [472.0, 330.0, 406.0],
            [314.0, 330.0, 456.0],
            [314.0, 0.0, 456.0],
        ],
        [
            [314.0, 0.0, 456.0],
            [314.0, 330.0, 456.0],
            [265.0, 330.0, 296.0],
            [265.0, 0.0, 296.0],
        ],
        [
            [265.0, 0.0, 296.0],
            [265.0, 330.0, 296.0],
            [423.0, 330.0, 247.0],
            [423.0, 0.0, 247.0],
        ],
    ];
    for q in short.into_iter().chain(tall) {
        quad(&mut s, q, white);
    }
    s.camera = Some(Camera {
        eye: mm(278.0, 273.0, -800.0),
        target: mm(278.0, 273.0, 0.0),
        up: Vec3::Y,
        vfov_deg: 2.0 * (12.5f32 / 35.0).atan().to_degrees(),
        width,
        height,
    });
    s
}

/// The Cornell box with glossy materials (glTF metallic-roughness): the floor a polished
/// dielectric (its white, roughness 0.2), the tall block a smooth metal (base 0.9, roughness
/// 0.1), the short block a rough gold (base (1.0, 0.78, 0.34), roughness 0.45); the walls,
/// ceiling and light as in [`cornell`]. Triangle order and camera are [`cornell`]'s.
pub fn cornell_glossy(width: u32, height: u32) -> Scene {
    let mut s = cornell(width, height);
    let floor = s.add_material(Material::metal_roughness([0.73; 3], 0.0, 0.2));
    let mirror_metal = s.add_material(Material::metal_roughness([0.9; 3], 1.0, 0.1));
    let gold = s.add_material(Material::metal_roughness([1.0, 0.78, 0.34], 1.0, 0.45));
    // cornell's order: floor (2 triangles), ceiling (8), light (2), back, right and left walls
    // (2 each), the short block (10), the tall block (10).
    s.triangles[0].material = floor;
    s.triangles[1].material = floor;
    let blocks = 2 + 8 + 2 + 6;
    for t in &mut s.triangles[blocks..blocks + 10] {
        t.material = gold;
    }
    for t in &mut s.triangles[blocks + 10..blocks + 20] {
        t.material = mirror_metal;
    }
    s
}

/// Size of the `glossy` hall (x, y, z), metres.
pub const GLOSSY_SIZE: Vec3 = Vec3::new(16.0, 6.0, 12.0);

/// Number of small lamps in the `glossy` hall (besides its one large panel).
pub const GLOSSY_LAMPS: usize = 240;

/// Where resampling is hard: a closed hall (16 x 6 x 12 m) with a polished dielectric floor
/// (roughness 0.1), rough dielectric walls (roughness 0.7), a diffuse ceiling, six columns
/// alternately smooth metal (silver, roughness 0.08) and rough metal (copper, roughness 0.4),
/// a mirror (base 0.95, roughness 0: the smallest the BRDF keeps) on the far wall, and a low
/// polished plinth (roughness 0.3). Lit by one large panel under the ceiling (1 x 3 m) and
/// 240 small lamps (0.12 m quads, varied hue, power log-uniform over a decade) along the side
/// walls at 2.5 and 4 m; the panel emits as much as all the lamps together. Deterministic in
/// `seed` (the lamps' colours and powers). The camera looks along the hall at the mirror
/// from a corner, the floor's reflections in view.
pub fn glossy(seed: u32, width: u32, height: u32) -> Scene {
    let size = GLOSSY_SIZE;
    let mut s = Scene::default();
    let wall = s.add_material(Material::metal_roughness([0.7, 0.68, 0.64], 0.0, 0.7));
    let floor = s.add_material(Material::metal_roughness([0.3, 0.28, 0.26], 0.0, 0.1));
    let ceiling = s.add_material(Material::new([0.7; 3], [0.0; 3]));
    let silver = s.add_material(Material::metal_roughness([0.95, 0.93, 0.88], 1.0, 0.08));
    let copper = s.add_material(Material::metal_roughness([0.95, 0.64, 0.54], 1.0, 0.4));
    let mirror = s.add_material(Material::metal_roughness([0.95; 3], 1.0, 0.0));
    let plinth = s.add_material(Material::metal_roughness([0.2, 0.3, 0.5], 0.0, 0.3));
    s.push_box(Vec3::ZERO, size, wall);
    // push_box's faces: bottom, top, then the sides.
    for (t, m) in s.triangles[..4]
        .iter_mut()
        .zip([floor, floor, ceiling, ceiling])
    {
        t.material = m;
    }
    for i in 0..6 {
        let c = Vec3::new(
            3.0 + 2.0 * (i / 2) as f32 * 2.5,
            0.0,
            3.5 + 5.0 * (i % 2) as f32,
        );
        let m = if (i / 2 + i % 2) % 2 == 0 {
            silver
        } else {
            copper
        };
        s.push_box(
            c - Vec3::new(0.3, 0.0, 0.3),
            c + Vec3::new(0.3, size.y, 0.3),
            m,
        );
    }
    // The mirror, 4 x 3 m, 2 cm off the far wall (x = size.x).
    let (x, y0, y1, z0, z1) = (size.x - 0.02, 1.0, 4.0, 4.0, 8.0);
    s.push_quad(
        [
            Vec3::new(x, y0, z0),
            Vec3::new(x, y0, z1),
            Vec3::new(x, y1, z1),
            Vec3::new(x, y1, z0),
        ],
        mirror,
    );
    s.push_box(Vec3::new(6.5, 0.0, 5.0), Vec3::new(9.5, 0.4, 7.0), plinth);
    glossy_lights(&mut s, seed);
    s.camera = Some(Camera {
        eye: Vec3::new(0.8, 1.7, 1.2),
        target: Vec3::new(size.x, 1.6, 0.6 * size.z),
        up: Vec3::Y,
        vfov_deg: 60.0,
        width,
        height,
    });
    s
}

/// The `glossy` hall's lamps on its side walls and its ceiling panel, the total emitted power
/// normalised as in [`many_lights`].
fn glossy_lights(s: &mut Scene, seed: u32) {
    let size = GLOSSY_SIZE;
    let mut rng = Rng::seed(0x9105, seed, 5);
    let side = 0.12;
    let mut lamps = Vec::with_capacity(GLOSSY_LAMPS);
    for k in 0..GLOSSY_LAMPS / 4 {
        let x = 0.4 + (size.x - 0.8) * (k as f32 + 0.5) / (GLOSSY_LAMPS / 4) as f32;
        for y in [2.5f32, 4.0] {
            lamps.push((Vec3::new(x, y, 0.06), Vec3::Z));
            lamps.push((Vec3::new(x, y, size.z - 0.06), Vec3::NEG_Z));
        }
    }
    let drawn: Vec<(Vec3, f32)> = lamps
        .iter()
        .map(|_| {
            let color = hue_rgb(rng.next_f32() * 6.0, 0.2 + 0.6 * rng.next_f32());
            (color, 10f32.powf(rng.next_f32()))
        })
        .collect();
    let power_sum: f64 = drawn.iter().map(|d| f64::from(d.1)).sum();
    let surface = 2.0 * (size.x * size.y + size.y * size.z + size.x * size.z);
    // Half of many-lights' sum A_i L_i to the lamps, half to the panel.
    let target = f64::from(surface) * 0.0625;
    for ((c, n), (color, power)) in lamps.into_iter().zip(drawn) {
        let (a, b) = n.any_orthonormal_pair();
        let (a, b) = (a * (0.5 * side), b * (0.5 * side));
        let lum = (target * f64::from(power) / power_sum) as f32 / (side * side);
        let m = s.add_material(Material::new([0.8; 3], (color * lum).to_array()));
        s.push_quad([c - a - b, c + a - b, c + a + b, c - a + b], m);
    }
    let (y, x0, x1, z0, z1) = (size.y - 0.05, 7.5, 8.5, 4.5, 7.5);
    let lum = (target / f64::from((x1 - x0) * (z1 - z0))) as f32;
    let panel = s.add_material(Material::new([0.8; 3], [lum, lum * 0.95, lum * 0.85]));
    s.push_quad(
        [
            Vec3::new(x0, y, z0),
            Vec3::new(x1, y, z0),
            Vec3::new(x1, y, z1),
            Vec3::new(x0, y, z1),
        ],
        panel,
    );
}

/// Side length (x, z) and height (y) of the `many-lights` hall, metres.
pub const HALL_SIZE: f32 = 24.0;
pub const HALL_HEIGHT: f32 = 6.0;

/// An enclosed hall (24 x 6 x 24 m, white-ish walls, floor and ceiling) lit only by `lights`
/// small two-sided emissive quads (0.1-0.3 m, random orientation) scattered in its upper half,
/// of varied colour (random hue) and power (log-uniform over two decades), plus occluders:
/// a 4 x 4 grid of pillars and 40 random crates. The total emitted power is fixed
/// independently of `lights`, so images stay comparably exposed. Deterministic in `seed`.
pub fn many_lights(lights: u32, seed: u32, width: u32, height: u32) -> Result<Scene, SceneError> {
    if lights == 0 || lights > 4_000_000 {
        return Err(SceneError::BadOption(format!(
            "many-lights: light count {lights} must be in 1..=4000000"
        )));
    }
    let mut s = Scene::default();
    let (w, h) = (HALL_SIZE, HALL_HEIGHT);
    let floor = s.add_material(Material::new([0.6, 0.58, 0.55], [0.0; 3]));
    let wall = s.add_material(Material::new([0.7; 3], [0.0; 3]));
    let pillar = s.add_material(Material::new([0.5, 0.45, 0.4], [0.0; 3]));
    let crate_m = s.add_material(Material::new([0.35, 0.5, 0.65], [0.0; 3]));
    // Hall: floor, ceiling and four walls (an inward-facing box, two-sided anyway).
    s.push_box(Vec3::ZERO, Vec3::new(w, h, w), wall);
    s.triangles[0].material = floor;
    s.triangles[1].material = floor;
    // Pillars.
    for i in 0..4 {
        for j in 0..4 {
            let c = Vec3::new(w * (i as f32 + 0.5) / 4.0, 0.0, w * (j as f32 + 0.5) / 4.0);
            s.push_box(
                c - Vec3::new(0.4, 0.0, 0.4),
                c + Vec3::new(0.4, h, 0.4),
                pillar,
            );
        }
    }
    let mut rng = Rng::seed(0x5ce9e, seed, 1);
    // Crates.
    for _ in 0..40 {
        let x = 1.0 + rng.next_f32() * (w - 2.0);
        let z = 1.0 + rng.next_f32() * (w - 2.0);
        let size = Vec3::new(
            0.5 + rng.next_f32(),
            0.4 + 1.6 * rng.next_f32(),
            0.5 + rng.next_f32(),
        );
        let lo = Vec3::new(x, 0.0, z);
        s.push_box(lo, lo + size, crate_m);
    }
    // Lights: draw everything first, then normalize the powers.
    struct Q {
        corners: [Vec3; 4],
        color: Vec3,
        power: f32,
    }
    let mut quads = Vec::with_capacity(lights as usize);
    let mut power_sum = 0.0f64;
    for _ in 0..lights {
        let c = Vec3::new(
            0.3 + rng.next_f32() * (w - 0.6),
            0.5 * h + rng.next_f32() * (0.5 * h - 0.3),
            0.3 + rng.next_f32() * (w - 0.6),
        );
        // Random orientation: a uniform direction for the normal, a random size.
        let z = 1.0 - 2.0 * rng.next_f32();
        let phi = std::f32::consts::TAU * rng.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let n = Vec3::new(r * phi.cos(), z, r * phi.sin());
        let (t, b) = n.any_orthonormal_pair();
        let half = 0.5 * (0.1 + 0.2 * rng.next_f32());
        let (t, b) = (t * half, b * half);
        let corners = [c - t - b, c + t - b, c + t + b, c - t + b];
        let hue = rng.next_f32() * 6.0;
        let color = hue_rgb(hue, 0.25 + 0.75 * rng.next_f32());
        let power = 10f32.powf(2.0 * rng.next_f32()); // 1..100, relative
        power_sum += f64::from(power);
        quads.push(Q {
            corners,
            color,
            power,
        });
    }
    // Total two-sided power P = sum 2 pi A_i L_i; aim for an average irradiance of about
    // pi / 4 on the hall's surfaces (white surfaces then look about 0.25 before tone mapping,
    // leaving room for the interreflections and the lights seen directly).
    let surface = 2.0 * w * w + 4.0 * w * h;
    let target = f64::from(surface) * 0.125; // sum A_i L_i (luminance)
    s.materials.reserve(quads.len());
    s.triangles.reserve(2 * quads.len());
    for q in quads {
        let area = (q.corners[1] - q.corners[0])
            .cross(q.corners[3] - q.corners[0])
            .length();
        let lum = (target * f64::from(q.power) / power_sum) as f32 / area;
        let e = q.color * lum;
        let m = s.add_material(Material::new([0.8; 3], e.to_array()));
        s.push_quad(q.corners, m);
    }
    s.camera = Some(Camera {
        // Down the corridor between the pillar rows at z = w/4 * 1.5 and w/4 * 2.5.
        eye: Vec3::new(0.8, 1.6, 0.5 * w),
        target: Vec3::new(w, 3.0, 0.5 * w + 0.5),
        up: Vec3::Y,
        vfov_deg: 60.0,
        width,
        height,
    });
    Ok(s)
}

/// Size of the `colonnade` hall (x, y, z), metres.
pub const COLONNADE_SIZE: Vec3 = Vec3::new(48.0, 9.0, 16.0);

/// Number of lamps (emissive quads) in the `colonnade`.
pub const COLONNADE_LAMPS: usize = 1064;

/// The paper's regime: a large hall (48 x 9 x 16 m, closed) lit only by 1064 small lamps
/// (0.12-0.2 m emissive quads) close to the surfaces they light: seven on each face of 26
/// columns (two rows of 13), sconces along the four walls at two heights, lamps hanging under
/// the two architraves that the columns carry, and lamps on 48 pedestals down the central
/// aisle; 24 benches add occluders. Lamps are warm white of varied tint, their power
/// log-uniform over a decade, the total fixed as in `many-lights`. Deterministic in `seed`
/// (colours and powers; the layout is fixed). The camera looks down the central aisle.
pub fn colonnade(seed: u32, width: u32, height: u32) -> Scene {
    let size = COLONNADE_SIZE;
    let mut s = Scene::default();
    let wall = s.add_material(Material::new([0.7, 0.68, 0.64], [0.0; 3]));
    let floor = s.add_material(Material::new([0.45, 0.4, 0.35], [0.0; 3]));
    let stone = s.add_material(Material::new([0.6, 0.58, 0.52], [0.0; 3]));
    let wood = s.add_material(Material::new([0.4, 0.25, 0.15], [0.0; 3]));
    s.push_box(Vec3::ZERO, size, wall);
    s.triangles[0].material = floor;
    s.triangles[1].material = floor;
    // (centre, normal, side) of every lamp.
    let mut lamps: Vec<(Vec3, Vec3, f32)> = Vec::with_capacity(COLONNADE_LAMPS);
    // Columns and their lamps.
    let half = 0.35;
    for row_z in [4.5f32, 11.5] {
        for i in 0..13 {
            let c = Vec3::new(3.0 + 3.5 * i as f32, 0.0, row_z);
            s.push_box(
                c - Vec3::new(half, 0.0, half),
                c + Vec3::new(half, size.y, half),
                stone,
            );
            for n in [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z] {
                for k in 0..7 {
                    let y = 0.8 + 0.9 * k as f32;
                    lamps.push((c + Vec3::Y * y + n * (half + 0.06), n, 0.12));
                }
            }
        }
        // The architrave the row carries, with lamps hanging under it every metre.
        s.push_box(
            Vec3::new(0.0, 7.0, row_z - half),
            Vec3::new(size.x, 7.6, row_z + half),
            stone,
        );
        for i in 0..48 {
            let x = 0.5 + i as f32;
            if (x - 3.0).rem_euclid(3.5) < 0.6 || (x - 3.0).rem_euclid(3.5) > 2.9 {
                continue; // a column is there
            }
            lamps.push((Vec3::new(x, 6.8, row_z), Vec3::NEG_Y, 0.2));
        }
    }
    // Sconces on the walls at 2.2 and 4.5 m: every metre on the long walls, every 1.5 m on
    // the short ones.
    for k in 0..48 {
        for y in [2.2f32, 4.5] {
            let x = 0.5 + k as f32;
            lamps.push((Vec3::new(x, y, 0.08), Vec3::Z, 0.15));
            lamps.push((Vec3::new(x, y, size.z - 0.08), Vec3::NEG_Z, 0.15));
        }
    }
    for k in 0..10 {
        for y in [2.2f32, 4.5] {
            let z = 1.25 + 1.5 * k as f32;
            lamps.push((Vec3::new(0.08, y, z), Vec3::X, 0.15));
            lamps.push((Vec3::new(size.x - 0.08, y, z), Vec3::NEG_X, 0.15));
        }
    }
    // Pedestals with a lamp on top down the aisle, benches along the walls.
    for i in 0..24 {
        let x = 1.0 + 2.0 * i as f32;
        for z in [6.6f32, 9.4] {
            let c = Vec3::new(x, 0.0, z);
            s.push_box(
                c - Vec3::new(0.15, 0.0, 0.15),
                c + Vec3::new(0.15, 0.9, 0.15),
                stone,
            );
            lamps.push((c + Vec3::Y * 0.95, Vec3::Y, 0.16));
        }
    }
    for i in 0..12 {
        let x = 2.0 + 4.0 * i as f32;
        for z in [1.2f32, 14.3] {
            s.push_box(Vec3::new(x, 0.0, z), Vec3::new(x + 1.6, 0.5, z + 0.5), wood);
        }
    }
    debug_assert_eq!(lamps.len(), COLONNADE_LAMPS);
    // Colours and powers, then normalise the total as `many_lights` does.
    let mut rng = Rng::seed(0xc010, seed, 3);
    let drawn: Vec<(Vec3, f32)> = lamps
        .iter()
        .map(|_| {
            let hue = 0.3 + 0.6 * rng.next_f32(); // orange to yellow
            let color = hue_rgb(hue, 0.15 + 0.35 * rng.next_f32());
            (color, 10f32.powf(rng.next_f32()))
        })
        .collect();
    let power_sum: f64 = drawn.iter().map(|d| f64::from(d.1)).sum();
    let surface = 2.0 * (size.x * size.y + size.y * size.z + size.x * size.z);
    let target = f64::from(surface) * 0.125;
    for ((c, n, side), (color, power)) in lamps.into_iter().zip(drawn) {
        let (a, b) = n.any_orthonormal_pair();
        let (a, b) = (a * (0.5 * side), b * (0.5 * side));
        let lum = (target * f64::from(power) / power_sum) as f32 / (side * side);
        let m = s.add_material(Material::new([0.8; 3], (color * lum).to_array()));
        s.push_quad([c - a - b, c + a - b, c + a + b, c - a + b], m);
    }
    s.camera = Some(Camera {
        eye: Vec3::new(1.2, 1.7, 0.5 * size.z),
        target: Vec3::new(size.x, 3.5, 0.5 * size.z),
        up: Vec3::Y,
        vfov_deg: 60.0,
        width,
        height,
    });
    s
}

/// A fully saturated hue (0..6) blended towards white by `1 - saturation`, scaled to unit
/// luminance (Rec. 709 weights).
fn hue_rgb(hue: f32, saturation: f32) -> Vec3 {
    let x = 1.0 - (hue % 2.0 - 1.0).abs();
    let c = match hue as u32 {
        0 => Vec3::new(1.0, x, 0.0),
        1 => Vec3::new(x, 1.0, 0.0),
        2 => Vec3::new(0.0, 1.0, x),
        3 => Vec3::new(0.0, x, 1.0),
        4 => Vec3::new(x, 0.0, 1.0),
        _ => Vec3::new(1.0, 0.0, x),
    };
    let c = Vec3::ONE.lerp(c, saturation);
    c / luminance(c.to_array())
}

/// Side length of the `furnace` box, metres.
pub const FURNACE_SIZE: f32 = 2.0;

/// The white furnace: a closed 2 m cube in which every surface has grey albedo `rho` and
/// emits grey radiance `le`, seen from its centre (60 degree field of view). Analytic values
/// at every visible point: emitted `le`, direct lighting reflected `rho le`, one-bounce indirect
/// `rho^2 le`, converged radiance `le / (1 - rho)`.
pub fn furnace(rho: f32, le: f32, width: u32, height: u32) -> Result<Scene, SceneError> {
    if !(0.0..=1.0).contains(&rho) {
        return Err(SceneError::BadOption(format!(
            "furnace: rho {rho} must be in [0, 1]"
        )));
    }
    if !(0.0..=super::MAX_EMISSION).contains(&le) {
        return Err(SceneError::BadOption(format!(
            "furnace: Le {le:e} must be in [0, {:e}] (larger emission overflows the image \
             accumulation)",
            super::MAX_EMISSION
        )));
    }
    let mut s = Scene::default();
    let m = s.add_material(Material::new([rho; 3], [le; 3]));
    let half = 0.5 * FURNACE_SIZE;
    s.push_box(Vec3::splat(-half), Vec3::splat(half), m);
    s.camera = Some(Camera {
        eye: Vec3::ZERO,
        target: Vec3::Z,
        up: Vec3::Y,
        vfov_deg: 60.0,
        width,
        height,
    });
    Ok(s)
}

/// Radius of the `furnace-sphere`, metres.
pub const FURNACE_SPHERE_RADIUS: f32 = 1.0;

/// The unit icosahedron: 12 vertices on the unit sphere and its 20 faces (outward winding),
/// the start of every icosphere here and in the tests.
pub fn icosahedron() -> ([Vec3; 12], [[usize; 3]; 20]) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let v = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .map(|p| Vec3::from(p).normalize());
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    (v, faces)
}

/// The white furnace as a closed icosphere (icosahedron subdivided 3 times: 1280 triangles,
/// watertight) of radius 1 m, seen from its centre. Same analytic values as [`furnace`] (any
/// closed enclosure gives irradiance pi Le everywhere), but a far better-behaved estimator:
/// on a sphere cos_x cos_y / d^2 = 1 / (4 R^2) for any two points, so area light sampling has
/// almost no variance, whereas in the box that term is unbounded near the edges (the NEE
/// estimator's variance diverges there and fixed-seed means scatter by a few percent).
/// Use this one for tight furnace tests.
pub fn furnace_sphere(rho: f32, le: f32, width: u32, height: u32) -> Result<Scene, SceneError> {
    let mut s = furnace(rho, le, width, height)?;
    s.triangles.clear();
    let (v, faces) = icosahedron();
    let mut tris: Vec<[Vec3; 3]> = faces.iter().map(|f| f.map(|i| v[i])).collect();
    // Midpoints are computed symmetrically ((a + b) * 0.5 is commutative), so neighbours share
    // bit-identical vertices and the mesh stays watertight.
    let mid = |a: Vec3, b: Vec3| ((a + b) * 0.5).normalize();
    for _ in 0..3 {
        tris = tris
            .into_iter()
            .flat_map(|[a, b, c]| {
                let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    for t in tris {
        s.triangles.push(super::Triangle::new(
            t.map(|p| p * FURNACE_SPHERE_RADIUS),
            0,
        ));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_are_clean_and_have_cameras() {
        for name in BUILTIN_NAMES {
            let mut s = builtin(
                name,
                &BuiltinOptions {
                    lights: 100,
                    ..Default::default()
                },
            )
            .unwrap();
            let r = s.sanitize(name).unwrap();
            assert!(r.is_clean(), "{name}: {r}");
            s.camera.unwrap().validate().unwrap();
            assert!(s.emissive_triangles() > 0, "{name}");
        }
        assert!(matches!(
            builtin("nope", &BuiltinOptions::default()),
            Err(SceneError::UnknownBuiltin { .. })
        ));
    }

    #[test]
    fn cornell_matches_the_published_measurements() {
        let s = cornell(8, 8);
        assert_eq!(s.triangles.len(), 2 * (1 + 4 + 1 + 3 + 10));
        let (lo, hi) = s.bounds().unwrap();
        assert!((lo - Vec3::ZERO).abs().max_element() < 1e-6);
        assert!((hi - Vec3::new(0.556, 0.5488, 0.5592)).abs().max_element() < 1e-6);
        let light_area: f32 = s
            .triangles
            .iter()
            .filter(|t| s.materials[t.material as usize].is_emissive())
            .map(|t| t.area())
            .sum();
        assert!((light_area - 0.130 * 0.105).abs() < 1e-6);
        let fov = s.camera.unwrap().vfov_deg;
        assert!((fov - 39.3).abs() < 0.05, "{fov}");
    }

    #[test]
    fn many_lights_scales_and_is_deterministic() {
        let a = many_lights(1000, 3, 4, 4).unwrap();
        let b = many_lights(1000, 3, 4, 4).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.emissive_triangles(), 2000);
        let c = many_lights(1000, 4, 4, 4).unwrap();
        assert_ne!(a, c);
        let big = many_lights(100_000, 1, 4, 4).unwrap();
        assert_eq!(big.emissive_triangles(), 200_000);
        assert!(many_lights(0, 1, 4, 4).is_err());
    }

    #[test]
    fn colonnade_is_lit_by_its_lamps_and_deterministic() {
        let a = colonnade(1, 8, 8);
        assert_eq!(a, colonnade(1, 8, 8));
        assert_ne!(a, colonnade(2, 8, 8), "the seed changes colours and powers");
        assert_eq!(a.emissive_triangles(), 2 * COLONNADE_LAMPS);
        let (lo, hi) = a.bounds().unwrap();
        assert_eq!((lo, hi), (Vec3::ZERO, COLONNADE_SIZE));
        // Every lamp is small and within 0.25 m of a surface it lights (a wall, a column, an
        // architrave or a pedestal): nearby lights, the paper's regime.
        let mut probe = a.clone();
        probe
            .triangles
            .retain(|t| !a.materials[t.material as usize].is_emissive());
        let bvh = crate::trace::Bvh::build(&probe).unwrap();
        for t in a
            .triangles
            .iter()
            .filter(|t| a.materials[t.material as usize].is_emissive())
        {
            assert!(t.area() <= 0.5 * 0.2 * 0.2 + 1e-6);
            let c = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
            let n = t.cross().normalize();
            // (Slightly off the axis: the traversal wants no zero direction component.)
            let dir = (-n + Vec3::new(0.011, 0.013, 0.017)).normalize();
            let behind = bvh.closest_hit(&crate::trace::Ray::new(c, dir, 0.0, 0.25));
            assert!(
                behind.is_hit(),
                "lamp at {c} facing {n} has no surface behind it"
            );
        }
    }

    #[test]
    fn furnace_is_closed_and_uniform() {
        let s = furnace(0.5, 2.0, 4, 4).unwrap();
        assert_eq!(s.triangles.len(), 12);
        assert_eq!(s.materials, vec![Material::new([0.5; 3], [2.0; 3])]);
        assert!(furnace(1.5, 1.0, 4, 4).is_err());
        assert!(furnace(0.5, f32::NAN, 4, 4).is_err());
        let e = furnace(0.5, 1e38, 4, 4).unwrap_err();
        assert!(
            e.to_string().contains("Le 1e38 must be in [0, 1e10]"),
            "{e}"
        );
        let sphere = furnace_sphere(0.5, 2.0, 4, 4).unwrap();
        assert_eq!(sphere.triangles.len(), 1280);
        // Watertight: every edge is shared by exactly two triangles.
        let mut edges = std::collections::HashMap::new();
        for t in &sphere.triangles {
            for k in 0..3 {
                let (a, b) = (t.v[k].to_array(), t.v[(k + 1) % 3].to_array());
                let key = if a.map(f32::to_bits) < b.map(f32::to_bits) {
                    (a.map(f32::to_bits), b.map(f32::to_bits))
                } else {
                    (b.map(f32::to_bits), a.map(f32::to_bits))
                };
                *edges.entry(key).or_insert(0) += 1;
            }
        }
        assert!(edges.values().all(|&n| n == 2));
    }
}
