//! Both GPU tracers against obvhs's CPU traversal with the same watertight triangle test, on
//! 10^5 random rays per scene: our CWBVH traversal (`trace.wgsl`) on every adapter, and the
//! ray-query backend (`trace_rq.wgsl`) where the adapter has ray queries (skipped with a printed
//! reason otherwise). Same hit/miss, same triangle, t within 1e-4 relative (to the larger of t
//! and the ray origin's coordinates; hardware t carries the origin's rounding). Rays that graze an
//! edge (a barycentric within 1e-4 of 0) may resolve to the neighbouring triangle or miss on one
//! side only; those are counted and must stay below 0.1%.

use glam::Vec3;
use rand::{Rng, SeedableRng, rngs::StdRng};
use restir_world::GpuContext;
use restir_world::gpu::Tracer;
use restir_world::scene::{Material, Scene, Triangle};
use restir_world::trace::{self, Bvh, BvhTriangle, Hit, Ray, TraceKernel};
use tests::{buffers, gpu};

const RAYS: usize = 100_000;
const T_REL: f32 = 1e-4;
const EDGE: f32 = 1e-4;
const MAX_GRAZING: f64 = 1e-3;
/// Most rays whose closest hit the tracers resolve to different coplanar triangles at the same
/// t (many-lights has lamps lying on its surfaces).
const MAX_TIES: f64 = 5e-3;

fn material_scene(triangles: Vec<Triangle>) -> Scene {
    Scene {
        triangles,
        materials: vec![Material::new([0.5; 3], [0.0; 3])],
        ..Default::default()
    }
}

fn random_unit(rng: &mut StdRng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        let l = v.length_squared();
        if l > 1e-4 && l <= 1.0 {
            return v / l.sqrt();
        }
    }
}

fn soup(n: usize, seed: u64) -> Scene {
    let mut rng = StdRng::seed_from_u64(seed);
    let tris = (0..n)
        .map(|_| {
            let c = Vec3::new(rng.random(), rng.random(), rng.random());
            let s: f32 = rng.random_range(0.01..0.2);
            let v = [0, 1, 2].map(|_| c + random_unit(&mut rng) * s);
            Triangle {
                v,
                n: None,
                uv: None,
                t: None,
                material: 0,
            }
        })
        .filter(|t| t.area() > 1e-7)
        .collect();
    material_scene(tris)
}

/// A grid of axis-aligned boxes (12 triangles each, sharing edges) with varied sizes.
fn boxes(per_axis: usize, seed: u64) -> Scene {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut tris = Vec::new();
    for i in 0..per_axis {
        for j in 0..per_axis {
            for k in 0..per_axis {
                let lo = Vec3::new(i as f32, j as f32, k as f32) / per_axis as f32;
                let size = rng.random_range(0.3..0.9) / per_axis as f32;
                push_box(&mut tris, lo, lo + Vec3::splat(size));
            }
        }
    }
    material_scene(tris)
}

fn push_box(tris: &mut Vec<Triangle>, lo: Vec3, hi: Vec3) {
    let c = |x: bool, y: bool, z: bool| {
        Vec3::new(
            if x { hi.x } else { lo.x },
            if y { hi.y } else { lo.y },
            if z { hi.z } else { lo.z },
        )
    };
    let faces = [
        [
            c(false, false, false),
            c(false, true, false),
            c(true, true, false),
            c(true, false, false),
        ],
        [
            c(false, false, true),
            c(true, false, true),
            c(true, true, true),
            c(false, true, true),
        ],
        [
            c(false, false, false),
            c(true, false, false),
            c(true, false, true),
            c(false, false, true),
        ],
        [
            c(false, true, false),
            c(false, true, true),
            c(true, true, true),
            c(true, true, false),
        ],
        [
            c(false, false, false),
            c(false, false, true),
            c(false, true, true),
            c(false, true, false),
        ],
        [
            c(true, false, false),
            c(true, true, false),
            c(true, true, true),
            c(true, false, true),
        ],
    ];
    for q in faces {
        for v in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            tris.push(Triangle {
                v,
                n: None,
                uv: None,
                t: None,
                material: 0,
            });
        }
    }
}

/// Random rays from a box around the scene: mostly random directions, some axis-aligned (zero
/// direction components exercise the safe inverse), finite `tmax` on half of them.
fn random_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = StdRng::seed_from_u64(seed);
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for t in &scene.triangles {
        for v in t.v {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let ext = hi - lo;
    let (olo, ohi) = (lo - ext * 0.25, hi + ext * 0.25);
    (0..n)
        .map(|i| {
            let o = Vec3::new(
                rng.random_range(olo.x..ohi.x),
                rng.random_range(olo.y..ohi.y),
                rng.random_range(olo.z..ohi.z),
            );
            let d = if i % 16 == 0 {
                let mut d = Vec3::ZERO;
                d[rng.random_range(0..3)] = if rng.random() { 1.0 } else { -1.0 };
                d
            } else {
                random_unit(&mut rng)
            };
            let tmax = if i % 2 == 0 {
                f32::MAX
            } else {
                rng.random_range(0.0..ext.length())
            };
            Ray::new(o, d, 0.0, tmax)
        })
        .collect()
}

/// The contexts to test: the software BVH always, ray queries when the adapter has them.
fn tracers() -> Vec<GpuContext> {
    let mut bvh = gpu::context().clone();
    bvh.set_tracer(Some(Tracer::Bvh)).expect("bvh");
    let mut out = vec![bvh];
    match gpu::with_tracer(Tracer::RayQuery) {
        Some(rq) => out.push(rq),
        None => tests::skip("trace: the ray-query tracer (this adapter has no ray queries)"),
    }
    out
}

fn gpu_trace(ctx: &GpuContext, bvh: &Bvh, rays: &[Ray], any_hit: bool) -> Vec<Hit> {
    let gpu_bvh = bvh.upload(ctx).expect("upload");
    let kernel = TraceKernel::new(&ctx.device, ctx.tracer);
    let rays_buf = buffers::storage_from(&ctx.device, "rays", rays);
    let hits_buf =
        buffers::storage_zeroed(&ctx.device, "hits", (rays.len() * size_of::<Hit>()) as u64);
    gpu::run(ctx, |enc| {
        kernel
            .encode(
                &ctx.device,
                enc,
                &gpu_bvh,
                &rays_buf,
                &hits_buf,
                rays.len() as u32,
                any_hit,
            )
            .expect("trace")
    });
    let mut hits: Vec<Hit> = buffers::read(ctx, &hits_buf).expect("readback");
    hits.truncate(rays.len());
    hits
}

/// Whether `tri` contains the point at `t` on `ray` (within 1e-4 of its plane, relative to t,
/// and of its edges in barycentric terms).
fn contains(ray: &Ray, tri: &BvhTriangle, t: f32) -> bool {
    let (v0, v1, v2) = (Vec3::from(tri.v0), Vec3::from(tri.v1), Vec3::from(tri.v2));
    let p = Vec3::from(ray.origin) + Vec3::from(ray.dir) * t;
    let (e1, e2) = (v1 - v0, v2 - v0);
    let n = e1.cross(e2);
    if n.length_squared() == 0.0 || (p - v0).dot(n.normalize()).abs() > T_REL * t.max(1.0) {
        return false;
    }
    // Barycentrics of p by areas.
    let area = n.length();
    let b1 = (p - v0).cross(e2).length() / area;
    let b2 = e1.cross(p - v0).length() / area;
    b1 <= 1.0 + EDGE && b2 <= 1.0 + EDGE && b1 + b2 <= 1.0 + EDGE
}

fn grazing(h: &Hit) -> bool {
    h.is_hit() && (h.b1 < EDGE || h.b2 < EDGE || 1.0 - h.b1 - h.b2 < EDGE)
}

#[derive(Debug, Default)]
struct Report {
    hits: usize,
    grazing: usize,
    /// Both hit at the same t, on different triangles that both contain the hit point
    /// (coplanar overlapping triangles: which one wins is the tracer's choice).
    ties: usize,
    /// The GPU hit a triangle nearer than obvhs's node clamp, which obvhs cannot report.
    near: usize,
    wrong: usize,
    examples: Vec<String>,
}

/// obvhs's CPU traversal enters node boxes at t >= 1e-4 (absolute); our GPU traversal enters
/// them from the ray's tmin, so that scenes in small units keep their near hits.
const OBVHS_NODE_TMIN: f32 = 1e-4;
/// Most rays whose GPU hit lies nearer than [`OBVHS_NODE_TMIN`] while obvhs reports another.
const MAX_NEAR: f64 = 1e-3;

/// Compares closest hits. A disagreement is tolerated (counted as grazing) only when one side
/// grazes an edge and the t values agree or one side missed; or (counted as near) when the GPU
/// hit is nearer than obvhs's node clamp, where obvhs cannot see it.
fn compare_closest(tris: &[BvhTriangle], rays: &[Ray], cpu: &[Hit], gpu: &[Hit]) -> Report {
    let mut r = Report::default();
    for (i, (c, g)) in cpu.iter().zip(gpu).enumerate() {
        r.hits += usize::from(c.is_hit());
        // Hit points are only as precise as the coordinates: t relative to the larger of t and
        // the ray origin's magnitude.
        let scale =
            c.t.abs()
                .max(Vec3::from(rays[i].origin).abs().max_element());
        let t_ok = (c.t - g.t).abs() <= T_REL * scale.max(1e-3);
        let same = c.is_hit() == g.is_hit() && (!c.is_hit() || (c.prim == g.prim && t_ok));
        if same {
            continue;
        }
        if g.is_hit() && g.t < OBVHS_NODE_TMIN && (!c.is_hit() || c.t > g.t) {
            r.near += 1;
            continue;
        }
        if c.is_hit() && g.is_hit() && t_ok && contains(&rays[i], &tris[g.prim as usize], c.t) {
            r.ties += 1;
            continue;
        }
        let edge = grazing(c) || grazing(g);
        let both_hit_same_t = c.is_hit() && g.is_hit() && t_ok;
        if edge && (both_hit_same_t || c.is_hit() != g.is_hit()) {
            r.grazing += 1;
        } else {
            r.wrong += 1;
            if r.examples.len() < 5 {
                let name = |h: &Hit| {
                    if h.is_hit() {
                        format!("tri {} t {}", tris[h.prim as usize].index, h.t)
                    } else {
                        "miss".into()
                    }
                };
                r.examples
                    .push(format!("ray {i}: cpu {} / gpu {}", name(c), name(g)));
            }
        }
    }
    r
}

fn check_scene(name: &str, scene: &Scene, seed: u64) {
    for ctx in tracers() {
        let label = format!("{name} ({})", ctx.tracer.name());
        check_scene_on(&ctx, &label, scene, seed);
    }
}

fn check_scene_on(ctx: &GpuContext, name: &str, scene: &Scene, seed: u64) {
    let bvh = Bvh::build(scene).expect("build");
    let rays = random_rays(scene, RAYS, seed);
    let cpu: Vec<Hit> = rays.iter().map(|r| bvh.closest_hit(r)).collect();
    let gpu_hits = gpu_trace(ctx, &bvh, &rays, false);
    let report = compare_closest(&bvh.triangles, &rays, &cpu, &gpu_hits);
    eprintln!(
        "{name}: {} triangles, {} nodes, {} of {} rays hit, {} grazing, {} ties, {} near, {} \
         wrong",
        scene.triangles.len(),
        bvh.cwbvh.nodes.len(),
        report.hits,
        rays.len(),
        report.grazing,
        report.ties,
        report.near,
        report.wrong
    );
    assert!(
        (report.ties as f64) < MAX_TIES * rays.len() as f64,
        "{name}: {} coplanar ties",
        report.ties
    );
    assert!(
        (report.near as f64) < MAX_NEAR * rays.len() as f64,
        "{name}: {} hits nearer than obvhs's node clamp",
        report.near
    );
    assert!(
        report.hits > rays.len() / 10,
        "{name}: too few hits to test anything"
    );
    assert_eq!(report.wrong, 0, "{name}: {:?}", report.examples);
    assert!(
        (report.grazing as f64) < MAX_GRAZING * rays.len() as f64,
        "{name}: {} grazing disagreements",
        report.grazing
    );

    // Any hit (shadow rays): same occlusion answer, except where the closest hit grazes an edge
    // or lies nearer than obvhs's node clamp.
    let any_gpu = gpu_trace(ctx, &bvh, &rays, true);
    let mut any_wrong = Vec::new();
    for (i, ((ray, c), g)) in rays.iter().zip(&cpu).zip(&any_gpu).enumerate() {
        let cpu_any = bvh.any_hit(ray);
        assert_eq!(
            cpu_any,
            c.is_hit(),
            "{name}: CPU any-hit disagrees with CPU closest hit"
        );
        let near = gpu_hits[i].is_hit() && gpu_hits[i].t < OBVHS_NODE_TMIN;
        if cpu_any != g.is_hit() && !grazing(c) && !grazing(g) && !near {
            any_wrong.push(i);
        }
        if g.is_hit() {
            assert!(
                g.t >= ray.tmin && g.t <= ray.tmax,
                "{name}: any-hit t outside the ray"
            );
        }
    }
    assert!(
        any_wrong.is_empty(),
        "{name}: any-hit disagrees on {} rays, first {:?}",
        any_wrong.len(),
        &any_wrong[..any_wrong.len().min(5)]
    );
}

#[test]
fn random_triangle_soup_matches_obvhs() {
    check_scene("soup", &soup(5_000, 1), 11);
}

#[test]
fn boxes_with_shared_edges_match_obvhs() {
    check_scene("boxes", &boxes(6, 2), 12);
}

#[test]
fn comparison_catches_a_planted_geometry_error() {
    // Negative control: trace on the GPU against triangles nudged by 1e-3 (well above the
    // tolerance); the comparison must flag it.
    let scene = soup(2_000, 3);
    let bvh = Bvh::build(&scene).expect("build");
    let rays = random_rays(&scene, 20_000, 13);
    let cpu: Vec<Hit> = rays.iter().map(|r| bvh.closest_hit(r)).collect();
    let mut nudged = bvh.clone();
    for t in &mut nudged.triangles {
        for v in [&mut t.v0, &mut t.v1, &mut t.v2] {
            v[0] += 1e-3;
            v[1] += 1e-3;
        }
    }
    for ctx in tracers() {
        let gpu_hits = gpu_trace(&ctx, &nudged, &rays, false);
        let report = compare_closest(&bvh.triangles, &rays, &cpu, &gpu_hits);
        assert!(
            report.wrong > 100,
            "{}: planted error went unnoticed: {report:?}",
            ctx.tracer.name()
        );
    }
}

#[test]
fn empty_scene_is_an_error() {
    assert!(matches!(
        Bvh::build(&material_scene(Vec::new())),
        Err(trace::TraceError::Empty)
    ));
}

#[test]
fn gpu_structs_match_wgsl_layout() {
    let src = trace::kernel_source(Tracer::Bvh);
    tests::assert_wgsl_layout!(
        trace::BvhNode,
        src,
        "BvhNode",
        [
            p,
            e_imask,
            child_base_idx,
            primitive_base_idx,
            child_meta,
            child_min_x,
            child_max_x,
            child_min_y,
            child_max_y,
            child_min_z,
            child_max_z
        ]
    );
    tests::assert_wgsl_layout!(
        BvhTriangle,
        src,
        "BvhTriangle",
        [v0, material, v1, index, v2, flags]
    );
    tests::assert_wgsl_layout!(Ray, src, "Ray", [origin, tmin, dir, tmax]);
    tests::assert_wgsl_layout!(Hit, src, "Hit", [t, prim, b1, b2]);
}

/// The GPU traversal's nodes and triangles per ray (`TraceKernel::counting`) against obvhs's
/// CPU traversal of the same BVH and rays (`Bvh::traverse`), closest and any hit, on a
/// triangle soup and many-lights: the same walk, so the same counts up to the rays whose
/// floating-point box tests differ. Guards the traversal's work (an extra node a ray, a lost
/// front-to-back order) where the hit tests above see only its answers.
#[test]
fn gpu_traversal_visits_what_obvhs_visits() {
    use restir_world::scene::{BuiltinOptions, builtin};
    use restir_world::trace::Visits;
    let mut ctx = gpu::context().clone();
    ctx.set_tracer(Some(Tracer::Bvh)).expect("bvh");
    let many = builtin("many-lights", &BuiltinOptions::default()).expect("many-lights");
    for (name, scene, seed) in [("soup", soup(5_000, 3), 31), ("many-lights", many, 32)] {
        let bvh = Bvh::build(&scene).expect("build");
        let rays = random_rays(&scene, RAYS, seed);
        let gpu_bvh = bvh.upload(&ctx).expect("upload");
        let kernel = TraceKernel::counting(&ctx.device);
        let rays_buf = buffers::storage_from(&ctx.device, "rays", &rays);
        let n = rays.len() as u64;
        let hits_buf = buffers::storage_zeroed(&ctx.device, "hits", n * size_of::<Hit>() as u64);
        let counts_buf =
            buffers::storage_zeroed(&ctx.device, "visits", n * size_of::<Visits>() as u64);
        for any_hit in [false, true] {
            let binding = kernel
                .bind_counted(
                    &ctx.device,
                    &gpu_bvh,
                    &rays_buf,
                    &hits_buf,
                    &counts_buf,
                    rays.len() as u32,
                    any_hit,
                )
                .expect("bind");
            gpu::run(&ctx, |enc| kernel.encode_with(enc, &binding));
            let gpu: Vec<Visits> = buffers::read(&ctx, &counts_buf).expect("readback");
            let cpu: Vec<Visits> = rays.iter().map(|r| bvh.traverse(r, any_hit).1).collect();
            let total = |v: &[Visits]| {
                v.iter().take(rays.len()).fold((0u64, 0u64), |(a, b), x| {
                    (a + u64::from(x.nodes), b + u64::from(x.triangles))
                })
            };
            let (g, c) = (total(&gpu), total(&cpu));
            let same = gpu.iter().zip(&cpu).filter(|(a, b)| a == b).count();
            eprintln!(
                "{name} (any hit: {any_hit}): nodes a ray GPU {:.3} CPU {:.3}, triangles GPU \
                 {:.3} CPU {:.3}, the same counts on {same} of {} rays",
                g.0 as f64 / n as f64,
                c.0 as f64 / n as f64,
                g.1 as f64 / n as f64,
                c.1 as f64 / n as f64,
                rays.len()
            );
            // 1%: rays whose box tests round differently (FMA on the GPU, SSE on the CPU, and
            // obvhs's 1e-4 clamp of the node tmin) walk a few nodes more or fewer.
            for (what, gv, cv) in [("nodes", g.0, c.0), ("triangles", g.1, c.1)] {
                let ratio = gv as f64 / cv.max(1) as f64;
                assert!(
                    (0.99..=1.01).contains(&ratio),
                    "{name}: the GPU visits {ratio:.4}x obvhs's {what}"
                );
            }
            assert!(
                same as f64 >= 0.95 * rays.len() as f64,
                "{name}: the same counts on only {same} of {} rays",
                rays.len()
            );
        }
    }
}

#[test]
fn builtin_scenes_match_obvhs() {
    use restir_world::scene::{BUILTIN_NAMES, BuiltinOptions, builtin};
    let opts = BuiltinOptions::default();
    for (i, name) in BUILTIN_NAMES.iter().enumerate() {
        let scene = builtin(name, &opts).expect("built-in scene");
        check_scene(name, &scene, 100 + i as u64);
    }
}

/// Sponza (262k triangles, the public scenes' largest): both tracers against obvhs.
#[test]
fn sponza_matches_obvhs() {
    let Some(dir) = tests::scenes_dir() else {
        return;
    };
    let loaded =
        restir_world::scene::load(&dir.join("sponza-capsaicin/Sponza.gltf")).expect("Sponza loads");
    check_scene("sponza", &loaded.scene, 200);
}
