// Renderer library: the G-buffer vertex, surface reconstruction at a hit, and next-event
// estimation (one light sample, or RIS over K light candidates) with one shadow ray.
// Functions and structs only. Needs: trace.wgsl (+ its header), sampling.wgsl, lights.wgsl
// (+ its header), reservoir's rng.wgsl, the constants header `render::constants_wgsl` and the
// bindings header `render::bindings_wgsl` (render_params, render_materials, ...).
// CPU reference with the same estimators: restir_world::reference.

// Material, as restir_world::scene::Material. The textures are 1 + a texture ref index (0:
// none); the texture multiplies the factor (the normal texture: render_normal_mapped). model:
// 0 diffuse, 1 glTF metallic-roughness.
struct Material {
    albedo: vec3<f32>,
    base_color_texture: u32,
    emission: vec3<f32>,
    emissive_texture: u32,
    model: u32,
    metallic: f32,
    roughness: f32,
    metallic_roughness_texture: u32,
    normal_texture: u32,
    normal_scale: f32,
    _pad: vec2<u32>,
}

// A material's use of a texture (Rust: render::TextureGpu): (s, t) = (row0, row1) . (u, v, 1);
// texels at render_texels[offset ..], wrap = s | t << 8 (0 repeat, 1 mirrored, 2 clamp), |
// RENDER_TEXTURE_LINEAR for linear data (value / 255) rather than sRGB-encoded colour.
struct TextureGpu {
    row0: vec4<f32>,
    row1: vec4<f32>,
    offset: u32,
    width: u32,
    height: u32,
    wrap: u32,
}

// A surface vertex: `prim` is the BVH-order triangle (BVH_NO_HIT: the ray escaped), `normal`
// the unit geometric normal turned towards the incoming ray (ray offsets, light sidedness),
// `shading` the unit shading normal (interpolated vertex normals turned to the side of
// `normal`; `normal` itself for a triangle without them), `albedo` the base colour and
// `material` the rest of the surface's BRDF (render_pack_material: 0 is diffuse). `wo` is the
// unit direction towards whoever sees the vertex (the ray's origin), which a glossy BRDF
// depends on; buffers do not store it: render_surface sets it, and a pass that unpacks a
// vertex sets it from the vertex before (render_primary_vertex, render_secondary_vertex;
// render_unpack_vertex leaves the shading normal, which a diffuse surface never reads).
struct GVertex {
    position: vec3<f32>,
    prim: u32,
    normal: vec3<f32>,
    albedo: vec3<f32>,
    emission: vec3<f32>,
    shading: vec3<f32>,
    material: u32,
    wo: vec3<f32>,
}

// A GVertex as buffers store it (the G-buffer, the secondary vertices, the histories; Rust:
// render::GVertex): 64 bytes without padding, so that a 1920x1080 frame's vertices fit one
// 128 MiB storage binding (a vec3's 16-byte alignment made it 80). The shading normal is kept
// as its octahedral coordinates (sampling_oct_encode, f32: exact to about 1e-7), or with
// RENDER_SHADING_FLAT (outside [-1, 1]) first where it is the geometric normal (then exactly
// that).
struct PackedVertex {
    position: array<f32, 3>,
    prim: u32,
    normal: array<f32, 3>,
    albedo: array<f32, 3>,
    emission: array<f32, 3>,
    shading: array<f32, 2>,
    material: u32,
}

fn render_vec3(a: array<f32, 3>) -> vec3<f32> {
    return vec3<f32>(a[0], a[1], a[2]);
}

fn render_array3(v: vec3<f32>) -> array<f32, 3> {
    return array<f32, 3>(v.x, v.y, v.z);
}

fn render_unpack_vertex(p: PackedVertex) -> GVertex {
    let normal = render_vec3(p.normal);
    var shading = normal;
    if p.shading[0] != RENDER_SHADING_FLAT {
        shading = sampling_oct_decode(vec2<f32>(p.shading[0], p.shading[1]));
    }
    return GVertex(render_vec3(p.position), p.prim, normal, render_vec3(p.albedo),
                   render_vec3(p.emission), shading, p.material, shading);
}

// Whether the world-space and path reuse stages take vertex v (its light sample at a shared
// cell, its path sample, its cell): a diffuse vertex, whose reflected radiance is the same in
// every direction (restir-di's screen-space light reuse takes glossy ones too: di_reuses). A glossy one is left
// to the renderer's own estimators (render_direct_pixel, render_indirect_pixel, the path's light
// sample), which a stage calls for it where it replaces them; a sample reconnected at a glossy
// vertex is none (its radiance would be another direction's). Decided here, once; always true
// without glossy materials (RENDER_GLOSSY false).
fn render_reuses(v: GVertex) -> bool {
    // Planted defect REUSE_TAKES_GLOSSY (restir_world::plant): no hand-off.
    return !RENDER_GLOSSY || v.material == 0u || render_planted(PLANTED_REUSE_TAKES_GLOSSY);
}

// Vertex v as the reuse evaluates it (its targets, its light samples' shading): diffuse, as
// every vertex it takes is (render_reuses). The constant material word lets the compiler drop
// the BRDF's glossy branches from the reuse's loops (on lavapipe, world-restir's path kernel
// compiled for minutes with them).
fn render_reused_vertex(v: GVertex) -> GVertex {
    var d = v;
    d.material = 0u;
    return d;
}

// Pixel i's primary vertex (the G-buffer's), seen from this frame's camera.
fn render_primary_vertex(i: u32) -> GVertex {
    var g = render_unpack_vertex(render_gbuffer[i]);
    g.wo = normalize(render_params.camera.eye - g.position);
    return g;
}

// Pixel i's secondary vertex, seen from its primary vertex g (from the origin of g's GI ray).
fn render_secondary_vertex(i: u32, g: GVertex) -> GVertex {
    var s = render_unpack_vertex(render_secondary[i]);
    s.wo = normalize(render_offset(g.position, g.normal) - s.position);
    return s;
}

fn render_pack_vertex(v: GVertex) -> PackedVertex {
    var shading = array<f32, 2>(RENDER_SHADING_FLAT, 0.0);
    if any(v.shading != v.normal) {
        let e = sampling_oct_encode(v.shading);
        shading = array<f32, 2>(e.x, e.y);
    }
    return PackedVertex(render_array3(v.position), v.prim, render_array3(v.normal),
                        render_array3(v.albedo), render_array3(v.emission), shading,
                        v.material);
}

// A GVertex's material word: perceptual roughness as unorm16 (bits 0-15), metallic as unorm8
// (16-23), the model above (0 diffuse, 1 metallic-roughness); 0 for a diffuse surface (whose
// roughness and metallic are not read). Rust twin: render::pack_material.
fn render_pack_material(model: u32, metallic: f32, roughness: f32) -> u32 {
    if model == 0u {
        return 0u;
    }
    let r = u32(round(clamp(roughness, 0.0, 1.0) * 65535.0));
    let m = u32(round(clamp(metallic, 0.0, 1.0) * 255.0));
    return r | (m << 16u) | (model << 24u);
}

// The BRDF of vertex v (brdf.wgsl): its base colour and material word unpacked.
fn render_vertex_brdf(v: GVertex) -> BrdfSurface {
    var s: BrdfSurface;
    s.base = v.albedo;
    s.diffuse = (v.material >> 24u) == 0u;
    s.metallic = f32((v.material >> 16u) & 255u) / 255.0;
    s.roughness = f32(v.material & 65535u) / 65535.0;
    return s;
}

// Per scene triangle: vertex normals (flags & 1), texture coordinates (flags & 2) and
// tangents (flags & RENDER_ATTR_TANGENTS: octahedral snorm16 pairs, handedness -1 where
// RENDER_ATTR_TANGENT_FLIP << corner) (Rust: render::TriangleAttributes).
struct TriangleAttributes {
    n0: vec3<f32>,
    flags: u32,
    n1: vec3<f32>,
    emissive_texture: u32,
    n2: vec3<f32>,
    tangent0: u32,
    uv0: vec2<f32>,
    uv1: vec2<f32>,
    uv2: vec2<f32>,
    tangent12: vec2<u32>,
}

// Per-render constants. method: RENDER_METHOD_NEE or RENDER_METHOD_RIS.
struct RenderParams {
    camera: CameraGpu,
    pixel_count: u32,
    seed: u32,
    method: u32,
    candidates: u32,
    ray_offset_floor: f32,
    attributes: u32,
    // render::RenderOptions: bounces of indirect light, Russian roulette from this bounce on
    // (0: never).
    bounces: u32,
    roulette_from: u32,
    // 1: light samples and the emission rays hit are weighted by multiple importance sampling.
    mis: u32,
    // restir_world::plant: the build's planted defect (PLANTED_* ids; 0: none) and the scales of
    // the accumulated direct and indirect frames (1 but in tests' power checks).
    planted: u32,
    planted_direct_scale: f32,
    planted_indirect_scale: f32,
    // 1: the path pass records each pixel's path split (render_path_split, RenderPathSplit).
    path_split: u32,
    // restir_world::plant: a tunable defect's size (1 but in tests' negative controls).
    planted_amount: f32,
    // The smallest packed roughness (unorm16) of a glossy x2 whose record the passes keep
    // (render_records_glossy; restir-gi's x2-min-roughness); 0xffffffff: none.
    glossy_x2: u32,
    _pad2: u32,
}

// A pixel's path sample (what ReSTIR GI resamples): its reconnection vertex x2 (the secondary
// vertex, render_secondary, with its normal) and the radiance leaving x2 towards the primary
// vertex x1 along the pixel's path (render_path_radiance: the light estimate at x2 plus every
// bounce beyond). The indirect image is x1's albedo times that radiance (the GI ray's cosine
// pdf cancels x1's cosine and 1/pi), summed in the same passes with its own throughput so that
// neither depends on who reads the other. The path's random numbers are pixel i's streams of
// the frame (render_rng(i, STREAM_INDIRECT), render_rng_salted(i, STREAM_PATH, SALT_PATH_BOUNCE + bounce)).
struct PathLight {
    // x1's reflected light (the indirect image's share).
    reflected: vec3<f32>,
    // The radiance leaving x2 towards x1 (the path sample's).
    leaving: vec3<f32>,
}

// Pixel i's PathLight, as the pass that lights its secondary vertex writes it (the path pass
// adds to it), and e, the estimate x2's light sample was MIS-weighted with
// (render_light_mis_at; 0: the light table's density), kept in render_path_radiance[i].w so
// that the path's first ray from x2 weighs the emission it finds with the same.
fn render_store_path_light(i: u32, light: PathLight, e: f32) {
    render_indirect_frame[i] = vec4<f32>(light.reflected, 1.0);
    render_path_radiance[i] = vec4<f32>(light.leaving, e);
}

// Pixel i's path split, recorded by the path pass when render_params.path_split is 1 (for
// sub-path reuse at x2, world-restir-gi's subpath-k): the radiance leaving x2 towards x1 cut at
// x2's own light (`direct`: x2's light sample and the emission its path's ray from x2 finds,
// MIS-weighted as they are) and the rest (`beyond`: the radiance leaving the tertiary vertex x3
// towards x2, Le(x3) left out, divided by the roulette at x2, so that the path sample's radiance
// is direct + albedo(x2) x beyond); the radiance leaving x2 towards x1 one vertex short
// (`one_short`: the light estimate of the path's last vertex and the emission its ray finds left
// out), the depth a path sample has when another path reconnects to it from its secondary
// vertex; and x3 (`x3_hit` 0: the path ended at x2; `x3_glossy`: x3 is a vertex the reuse does
// not take, render_reuses). Four vec4 per pixel in render_path_split.
struct RenderPathSplit {
    direct: vec3<f32>,
    beyond: vec3<f32>,
    one_short: vec3<f32>,
    x3: vec3<f32>,
    x3_normal: vec3<f32>,
    x3_hit: bool,
    x3_glossy: bool,
}

fn render_store_path_split(i: u32, s: RenderPathSplit) {
    render_path_split[4u * i] = vec4<f32>(s.direct, s.x3_normal.x);
    render_path_split[4u * i + 1u] = vec4<f32>(s.beyond, s.x3_normal.y);
    render_path_split[4u * i + 2u] = vec4<f32>(s.one_short, s.x3_normal.z);
    // The last word: 0 no x3, 1 x3, 2 a glossy x3.
    render_path_split[4u * i + 3u] = vec4<f32>(s.x3, select(0.0, 1.0, s.x3_hit) + select(0.0, 1.0, s.x3_glossy));
}

// At a glossy x2 that restir-gi reconnects to (render_records_glossy), the same four vec4 hold
// x2's glossy record instead (the sub-path reuse reads only diffuse x2's split): the radiance
// leaving x2 towards any x1 is f(x2; wo, wl) a_l + f(x2; wo, wi) a_i, from x2's light sample
// (direction wl, a_l its light x cos / pdf with its MIS weight) and the continuation its path
// step drew (direction wi, a_i = cos / pdf x the radiance arriving along wi: the MIS-weighted
// emission and the light beyond, over the roulette at x2). Such an x2 is sampled as a white
// diffuse surface would be (render_sampled_as_diffuse), so that the record's distribution
// is the same whichever x1 drew it: a neighbour's record is then an estimate of the radiance
// towards the receiver from the same distribution as the receiver's own would be (what
// reconnecting to a diffuse x2 relies on; a record drawn by the BRDF's sampler towards one x1's
// wo biased cornell-glossy's indirect light by +2 to +4%). The light pass writes it
// (render_store_glossy_light, the continuation zero), the path pass the continuation
// (render_store_glossy_continuation).
struct RenderGlossyX2 {
    a_l: vec3<f32>,
    wl: vec3<f32>,
    a_i: vec3<f32>,
    wi: vec3<f32>,
}

fn render_store_glossy_light(i: u32, wl: vec3<f32>, a_l: vec3<f32>) {
    render_path_split[4u * i] = vec4<f32>(a_l, 0.0);
    render_path_split[4u * i + 1u] = vec4<f32>(wl, 0.0);
    render_path_split[4u * i + 2u] = vec4<f32>(0.0);
    render_path_split[4u * i + 3u] = vec4<f32>(0.0);
}

fn render_store_glossy_continuation(i: u32, wi: vec3<f32>, a_i: vec3<f32>) {
    render_path_split[4u * i + 2u] = vec4<f32>(a_i, 0.0);
    render_path_split[4u * i + 3u] = vec4<f32>(wi, 0.0);
}

fn render_load_glossy_x2(i: u32) -> RenderGlossyX2 {
    return RenderGlossyX2(render_path_split[4u * i].xyz, render_path_split[4u * i + 1u].xyz,
                          render_path_split[4u * i + 2u].xyz, render_path_split[4u * i + 3u].xyz);
}

// Whether secondary vertex v is a glossy x2 whose record the passes keep (RenderGlossyX2):
// glossy, at render_params.glossy_x2's packed roughness or rougher (restir-gi's
// x2-min-roughness; 0xffffffff: none), and the path split on.
fn render_records_glossy(v: GVertex) -> bool {
    return RENDER_GLOSSY && v.material != 0u && (v.material & 65535u) >= render_params.glossy_x2
        && render_params.path_split != 0u;
}

// A recorded glossy x2 as its light sample and path step see it: a white diffuse surface
// (cosine-distributed ray, a light target without the BRDF), whatever x1 saw it from.
fn render_sampled_as_diffuse(v: GVertex) -> GVertex {
    var d = v;
    d.material = 0u;
    d.albedo = vec3<f32>(1.0);
    return d;
}

fn render_load_path_split(i: u32) -> RenderPathSplit {
    let a = render_path_split[4u * i];
    let b = render_path_split[4u * i + 1u];
    let c = render_path_split[4u * i + 2u];
    let d = render_path_split[4u * i + 3u];
    return RenderPathSplit(a.xyz, b.xyz, c.xyz, d.xyz, vec3<f32>(a.w, b.w, c.w), d.w > 0.0, d.w > 1.5);
}

// GPU-side frame counter: advanced by render_accumulate, read by every pass for its seeds.
struct RenderState {
    frame: u32,
    _pad: array<u32, 3>,
}

fn render_luminance(c: vec3<f32>) -> f32 {
    return dot(c, RENDER_LUMINANCE);
}

// Random state of invocation i (a pixel, a grid item, a tile entry) of the pass drawing from
// `stream` (a STREAM_* id) in the current frame.
fn render_rng(i: u32, stream: u32) -> u32 {
    return rng_seed(i, render_state.frame, render_params.seed * STREAM_COUNT + stream);
}

// render_rng of sub-stream `salt` of `stream` (e.g. the n-th of a pass's repeats).
fn render_rng_salted(i: u32, stream: u32, salt: u32) -> u32 {
    return rng_seed(i, render_state.frame, (render_params.seed * STREAM_COUNT + stream) ^ (salt << 20u));
}

fn render_rand4(rng: ptr<function, u32>) -> vec4<f32> {
    let a = rng_next_f32(rng);
    let b = rng_next_f32(rng);
    let c = rng_next_f32(rng);
    let d = rng_next_f32(rng);
    return vec4<f32>(a, b, c, d);
}

// The surface the ray (origin + t dir) hit.
fn render_surface(dir: vec3<f32>, hit: Hit) -> GVertex {
    var v: GVertex;
    v.prim = hit.prim;
    v.wo = -dir;
    if hit.prim == BVH_NO_HIT {
        // The ray escaped: it sees the environment. The direction is kept in `shading` (for
        // multiple importance sampling of what it sees).
        v.emission = lights_env_radiance(dir);
        v.shading = dir;
        return v;
    }
    let tri = bvh_triangles[hit.prim];
    let e1 = tri.v1 - tri.v0;
    let e2 = tri.v2 - tri.v0;
    v.position = tri.v0 + hit.b1 * e1 + hit.b2 * e2;
    var n = normalize(cross(e1, e2));
    if dot(n, dir) > 0.0 {
        n = -n;
    }
    v.normal = n;
    v.shading = n;
    let m = render_materials[tri.material];
    v.albedo = m.albedo;
    v.emission = m.emission;
    var metallic = m.metallic;
    var roughness = m.roughness;
    if render_params.attributes != 0u {
        let a = render_attributes[tri.index];
        if (a.flags & 1u) != 0u {
            v.shading = render_shading_normal(a, hit, n);
        }
        if (a.flags & 2u) != 0u {
            let uv = render_uv(a, hit.b1, hit.b2);
            if RENDER_NORMAL_MAPS && (a.flags & RENDER_ATTR_TANGENTS) != 0u {
                v.shading = render_normal_mapped(a, hit, n, m, uv);
            }
            if m.base_color_texture != 0u {
                v.albedo *= render_texture(m.base_color_texture, uv);
            }
            if m.emissive_texture != 0u {
                v.emission *= render_texture(m.emissive_texture, uv);
            }
            if RENDER_GLOSSY && m.metallic_roughness_texture != 0u {
                // glTF: blue is metallic, green roughness.
                let t = render_texture(m.metallic_roughness_texture, uv);
                metallic *= t.z;
                roughness *= t.y;
            }
        }
    }
    if RENDER_GLOSSY {
        v.material = render_pack_material(m.model, metallic, roughness);
    }
    return v;
}

// Texture coordinates at barycentrics (b1, b2) (of vertices 1 and 2).
fn render_uv(a: TriangleAttributes, b1: f32, b2: f32) -> vec2<f32> {
    return (1.0 - b1 - b2) * a.uv0 + b1 * a.uv1 + b2 * a.uv2;
}

// An integer texel coordinate wrapped into 0..n (twin: scene::texture::wrap).
fn render_wrap(i: i32, n: i32, mode: u32) -> i32 {
    if mode == 0u {
        return ((i % n) + n) % n;
    }
    if mode == 2u {
        return clamp(i, 0, n - 1);
    }
    let m = 2 * n;
    let p = ((i % m) + m) % m;
    return select(p, m - 1 - p, p >= n);
}

fn render_srgb_to_linear(c: u32) -> f32 {
    let x = f32(c) / 255.0;
    if x <= 0.04045 {
        return x / 12.92;
    }
    return pow((x + 0.055) / 1.055, 2.4);
}

fn render_texel(t: TextureGpu, i: i32, j: i32) -> vec3<f32> {
    let x = u32(render_wrap(i, i32(t.width), t.wrap & 255u));
    let y = u32(render_wrap(j, i32(t.height), (t.wrap >> 8u) & 255u));
    let p = render_texels[t.offset + y * t.width + x];
    if (t.wrap & RENDER_TEXTURE_LINEAR) != 0u {
        return vec3<f32>(f32(p & 255u), f32((p >> 8u) & 255u), f32((p >> 16u) & 255u)) / 255.0;
    }
    return vec3<f32>(render_srgb_to_linear(p & 255u), render_srgb_to_linear((p >> 8u) & 255u),
                     render_srgb_to_linear((p >> 16u) & 255u));
}

// Bilinear linear-RGB sample of texture ref `index - 1` at vertex coordinates uv (twin:
// scene::TextureRef::sample).
fn render_texture(index: u32, uv: vec2<f32>) -> vec3<f32> {
    let t = render_textures[index - 1u];
    let st = clamp(vec2<f32>(t.row0.x * uv.x + t.row0.y * uv.y + t.row0.z,
                             t.row1.x * uv.x + t.row1.y * uv.y + t.row1.z),
                   vec2<f32>(-1e6), vec2<f32>(1e6));
    let x = st.x * f32(t.width) - 0.5;
    let y = st.y * f32(t.height) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let i = i32(x0);
    let j = i32(y0);
    let a = render_texel(t, i, j);
    let b = render_texel(t, i + 1, j);
    let c = render_texel(t, i, j + 1);
    let d = render_texel(t, i + 1, j + 1);
    let top = a + (b - a) * fx;
    let bottom = c + (d - c) * fx;
    return top + (bottom - top) * fy;
}

// The light sample s with the emission of a textured emissive triangle at its point.
fn render_textured_emission(sample: LightSample) -> LightSample {
    var s = sample;
    if render_params.attributes != 0u && s.kind == LIGHTS_KIND_TRIANGLE && s.pdf_area > 0.0 {
        let a = render_attributes[s.triangle];
        if a.emissive_texture != 0u && (a.flags & 2u) != 0u {
            s.emission *= render_texture(a.emissive_texture, render_uv(a, s.coords.x, s.coords.y));
        }
    }
    return s;
}

// lights_sample with the emission of a textured emissive triangle at the sampled point.
fn render_light_sample(u: vec4<f32>, rng: ptr<function, u32>) -> LightSample {
    var s = render_textured_emission(lights_sample(u, rng));
    if render_planted(PLANTED_LIGHT_PDF_OVERSTATED) {
        s.pdf_area *= 1.1;
    }
    return s;
}

// The confidence a reuse pass merges a neighbour's reservoir with: its (capped) M, but at most
// 1 under the planted defect MERGE_WITHOUT_M (restir_world::plant).
fn render_planted_m(m: u32) -> u32 {
    return select(m, min(m, 1u), render_planted(PLANTED_MERGE_WITHOUT_M));
}

// The probability that a path survives Russian roulette at vertex v: the share of the light
// its next step carries on average, v's albedo's largest channel where diffuse (the step's
// weight render_throughput), the BRDF's directional albedo's (brdf_albedo) where glossy; at
// most 1. Positive wherever a step can carry light, so that every path keeps a chance.
fn render_roulette_survival(v: GVertex) -> f32 {
    var a = v.albedo;
    if RENDER_GLOSSY && v.material != 0u {
        a = brdf_albedo(render_vertex_brdf(v), v.shading, v.wo);
    }
    return min(max(a.x, max(a.y, a.z)), 1.0);
}

// Whether the planted defect `id` (restir_world::plant) is compiled in and chosen: never in
// the kernels the library builds for users, where the override RENDER_PLANTED is false and
// the driver folds every planted branch away; the test harness's negative controls build
// theirs with it true and choose the defect in render_params.planted.
fn render_planted(id: u32) -> bool {
    return RENDER_PLANTED && render_params.planted == id;
}

// The survival probability a path's throughput is divided by after Russian roulette: q, but 1
// under the planted defect ROULETTE_WITHOUT_DIVISION (restir_world::plant).
fn render_roulette_divisor(q: f32) -> f32 {
    return select(q, 1.0, render_planted(PLANTED_ROULETTE_WITHOUT_DIVISION));
}

// lights_sample_at with the emission of a textured emissive triangle at the point.
fn render_light_sample_at(light: u32, coords: vec2<f32>) -> LightSample {
    return render_textured_emission(lights_sample_at(light, coords));
}

// Per reuse pass (Rust twin: render::ReusePass): temporal = 1 for the pass that reads last
// frame's reservoirs, pass_index mixes into its random stream.
struct ReusePass {
    temporal: u32,
    pass_index: u32,
    _pad0: u32,
    _pad1: u32,
}

// A reservoir as the reuse methods (world-restir, restir-di) store it between passes, 16 bytes
// (Rust twin: render::StoredReservoir). Its light sample is the light and where on it, one
// representation for every light kind: light_kind = the sample's LIGHTS_KIND_* in the low 2
// bits and its light table index above; coords = LightSample.coords packed: a triangle point's
// barycentrics as two unorm16, an environment direction's octahedral coordinates as two
// snorm16, 0 for punctual lights. render_stored_sample decodes it (position, normal, textured
// emission) from the light table. (ucw, m) is reservoir's PackedReservoir; m = 0: none.
struct StoredReservoir {
    light_kind: u32,
    coords: u32,
    ucw: f32,
    m: u32,
}

// Light sample s with a reservoir's packed (W, M), as stored.
fn render_store_reservoir(s: LightSample, packed: PackedReservoir) -> StoredReservoir {
    var coords = 0u;
    if s.kind == LIGHTS_KIND_TRIANGLE {
        coords = pack2x16unorm(s.coords);
    } else if s.kind == LIGHTS_KIND_ENV {
        coords = pack2x16snorm(s.coords);
    }
    return StoredReservoir(s.kind | (s.light << 2u), coords, packed.ucw, packed.m);
}

// The light sample of a stored reservoir, decoded. pdf_area is 1 (the reuse passes do not use
// it).
fn render_stored_sample(r: StoredReservoir) -> LightSample {
    let kind = r.light_kind & 3u;
    var coords = unpack2x16unorm(r.coords);
    if kind == LIGHTS_KIND_ENV {
        coords = unpack2x16snorm(r.coords);
    } else if coords.x + coords.y > 1.0 {
        // Rounding can leave the triangle by half a step: back onto its edge.
        coords /= coords.x + coords.y;
    }
    var s = render_light_sample_at(r.light_kind >> 2u, coords);
    s.pdf_area = 1.0;
    return s;
}

// Multiple importance sampling (render_params.mis) of light reached two ways: a light sample
// (next-event estimation) and a cosine-sampled ray that hits an emitter or escapes to the
// environment. Each strategy's estimate is weighted by the power heuristic of the two densities
// (solid angle at the receiver: the light table's density of the point or direction, and the
// cosine density); both sides compute the direction from the same positions, so the weights
// sum to 1 everywhere. Delta lights (point, spot, directional) cannot be hit: weight 1.

// As 1 / (1 + (b/a)^2): a^2 overflows above 1.8e19 (a small lamp's density seen at a grazing
// angle), and inf / inf is NaN.
fn render_power_heuristic(a: f32, b: f32) -> f32 {
    let r = b / a;
    return select(0.0, 1.0 / (1.0 + r * r), a > 0.0);
}

// MIS from the resampled density (world-restir's vertices). A light sample resampled from M
// candidates of the light table (density p_table) towards the target p_hat (the unshadowed
// reflected luminance) has about the density M p_hat(y) / (w(y) + (M - 1) I), w = p_hat /
// p_table, I = the target's integral: p_hat / I (the resampled density) where one candidate's
// weight is small beside the others' sum, M p_table where it dominates them. Over solid angle
// at a vertex of albedo a, p_hat / I = p_ray lum(Le(y)) / e, p_ray = cos / pi the cosine
// density, e = I / lum(a) (the vertex's cosine-weighted mean incident luminance, unshadowed),
// so the light side's density is M / (1 / p_table + (M - 1) e / (p_ray lum(Le(y)))), with M =
// RENDER_MIS_CANDIDATES (world-restir's default candidates; its reuse only sharpens the real
// density). Both strategies compute it from the same y and the same e (an estimate independent
// of the frame's light sample and ray) and weigh themselves by the power heuristic, so the two
// weights sum to one for every y; e <= 0 (no estimate): the light table's density. At a glossy
// vertex p_hat / I = lum(f(wi) Le(y)) cos / e with e = I itself (render_light_estimate): the
// lobe's shape, which the BRDF sample's density p_ray also follows.
const RENDER_MIS_CANDIDATES: f32 = 16.0;

fn render_light_density(v: GVertex, wi: vec3<f32>, p_table: f32, p_ray: f32, le: vec3<f32>,
                        e: f32) -> f32 {
    if e <= 0.0 {
        return p_table;
    }
    var p_res = p_ray * render_luminance(le) / e;
    if RENDER_GLOSSY && v.material != 0u {
        p_res = render_luminance(render_brdf(v, wi) * le) * max(dot(v.shading, wi), 0.0) / e;
    }
    if !(p_table > 0.0) || !(p_res > 0.0) {
        // No ray reaches y (p_ray = 0), or the table cannot draw it: the table's alone.
        return p_table;
    }
    let m = RENDER_MIS_CANDIDATES;
    return m / (1.0 / p_table + (m - 1.0) / p_res);
}


// An estimate e of vertex v's unshadowed cosine-weighted mean incident luminance (the target's
// integral over lum(albedo), render_light_density; at a glossy vertex the target's integral
// itself) from k light samples of the light table that no reservoir sees; 0 with k = 0 (MIS
// with the light table's density) and without MIS (nothing reads it).
fn render_light_estimate(v: GVertex, k: u32, rng: ptr<function, u32>) -> f32 {
    let glossy = RENDER_GLOSSY && v.material != 0u;
    let a = select(render_luminance(v.albedo), 1.0, glossy);
    if k == 0u || render_params.mis == 0u || !(a > 0.0) {
        return 0.0;
    }
    var sum = 0.0;
    for (var c = 0u; c < k; c++) {
        let s = render_light_sample(render_rand4(rng), rng);
        if s.pdf_area > 0.0 {
            sum += render_luminance(render_vertex_light(v, s)) / s.pdf_area;
        }
    }
    return sum / (f32(k) * a);
}

// render_light_mis with the resampled density where the vertex has an estimate e > 0.
fn render_light_mis_at(v: GVertex, s: LightSample, e: f32) -> f32 {
    if render_params.mis == 0u || s.kind == LIGHTS_KIND_POINT || s.kind == LIGHTS_KIND_DIRECTIONAL {
        return 1.0;
    }
    var wi = s.position;
    var p_table = 0.0;
    if s.kind == LIGHTS_KIND_ENV {
        p_table = lights_pdf_env(wi);
    } else {
        let to = s.position - v.position;
        wi = normalize(to);
        p_table = lights_pdf_solid_angle(lights_pdf_area(s.light), to, s.normal);
    }
    let p_ray = render_brdf_pdf(v, wi);
    var p_light = render_light_density(v, wi, p_table, p_ray, s.emission, e);
    if e > 0.0 && render_planted(PLANTED_LIGHT_MIS_DOUBLED) {
        // Planted defect: the light side's density doubled, the ray side's not.
        p_light *= 2.0;
    }
    let w = render_power_heuristic(p_light, p_ray);
    // Planted defect LIGHT_MIS_SCALED: the light side's weight off by a tunable factor.
    return select(w, w * render_params.planted_amount, render_planted(PLANTED_LIGHT_MIS_SCALED));
}

// The emission a ray from v drawn by its path step (render_path_step) found at w (a hit, or an
// escaped ray whose emission is the environment's radiance in direction w.shading), weighted
// by the ray strategy's MIS weight against the light table's density; 0 without MIS
// (next-event estimation then counts all of it).
fn render_hit_emission(v: GVertex, w: GVertex) -> vec3<f32> {
    return render_hit_emission_at(v, w, 0.0);
}

// render_hit_emission against the resampled density where v has an estimate e > 0
// (render_light_density).
fn render_hit_emission_at(v: GVertex, w: GVertex, e: f32) -> vec3<f32> {
    if render_params.mis == 0u || all(w.emission == vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    var dir = w.shading;
    var p_table = 0.0;
    if w.prim == BVH_NO_HIT {
        p_table = lights_pdf_env(dir);
    } else {
        dir = normalize(w.position - v.position);
        p_table = lights_pdf_hit(bvh_triangles[w.prim].index, v.position, w.position, w.normal);
    }
    let p_ray = render_brdf_pdf(v, dir);
    return w.emission * render_power_heuristic(p_ray, render_light_density(v, dir, p_table, p_ray, w.emission, e));
}

// f(y) of a stored reservoir's light sample y at vertex v (MIS-weighted with MIS on, against
// the resampled density where v has an estimate e > 0, render_light_mis_at), with one shadow
// ray: 0 when the reservoir is empty or y is occluded. Every reuse method shades its final
// reservoirs with it, as weight x f(y) x W (render_shade_stored).
fn render_stored_light(v: GVertex, res: StoredReservoir, e: f32) -> vec3<f32> {
    if res.m == 0u || !(res.ucw > 0.0) {
        return vec3<f32>(0.0);
    }
    let y = render_stored_sample(res);
    var f = render_vertex_light(v, y);
    if !any(f > vec3<f32>(0.0)) || !render_visible_sample(v.position, v.normal, y) {
        return vec3<f32>(0.0);
    }
    if render_params.mis != 0u {
        f *= render_light_mis_at(v, y, e);
    }
    return f;
}

// f(y) W of a stored reservoir's light sample y at vertex v, times `weight` (applied first):
// render_stored_light's f(y) for a light f already traced.
fn render_shade_stored(f: vec3<f32>, res: StoredReservoir, weight: vec3<f32>) -> vec3<f32> {
    return weight * f * res.ucw;
}

// Reuse of stored light reservoirs (restir-di, world-restir): merges neighbour n's reservoir
// `src` (confidence m, capped), generated at vertex `source`, into the combination c at vertex
// `receiver`, whose own sample is own_sample; both as the stage evaluates them (each with its own
// view direction where it is glossy: restir-di; render_reused_vertex: world-restir). Light
// samples need no shift: every Jacobian is 1. Returns true when src's sample is now selected.
fn render_reuse_light(c: ptr<function, Reuse>, n: u32, src: StoredReservoir, m: u32,
                      v: GVertex, q: GVertex, own_sample: LightSample, u: f32) -> bool {
    let y = render_stored_sample(src);
    var p_n_y = 0.0;
    var p_n_own = 0.0;
    if (*c).mode == REUSE_PAIRWISE {
        p_n_y = render_light_target(q, y);
        p_n_own = render_light_target(q, own_sample);
    }
    let packed = PackedReservoir(src.ucw, render_planted_m(m));
    return reuse_neighbour(c, n, packed, render_light_target(v, y), p_n_y, p_n_own, u);
}

// Ends a reuse of stored light reservoirs: `own` when the receiver's sample won, else `chosen`
// (the neighbour last selected), with the combination's W and M.
fn render_reuse_store(c: ptr<function, Reuse>, own: StoredReservoir,
                      chosen: StoredReservoir) -> StoredReservoir {
    let stored = reuse_finish(c);
    var out = chosen;
    if reuse_selected(*c) == REUSE_CANONICAL {
        out = own;
    }
    out.ucw = stored.ucw;
    out.m = stored.m;
    return out;
}

// The weight f cos / pdf of the step from vertex v to vertex w (a hit, or an escaped ray whose
// direction is w.shading) that v's path step (render_path_step) drew: v's albedo for a diffuse
// surface (the cosine density cancels the cosine and 1 / pi), the BRDF's ratio otherwise.
fn render_throughput(v: GVertex, w: GVertex) -> vec3<f32> {
    if !RENDER_GLOSSY || v.material == 0u {
        return v.albedo;
    }
    let dir = render_step_direction(v, w);
    let pdf = render_brdf_pdf(v, dir);
    if !(pdf > 0.0) {
        return vec3<f32>(0.0);
    }
    return render_brdf(v, dir) * (max(dot(v.shading, dir), 0.0) / pdf);
}

// The direction of the step from v to w (a hit, or an escaped ray's w.shading) at a glossy v:
// from the ray's origin, not from v: a narrow lobe's weight at a direction off by offset /
// distance (near where two surfaces meet) lost 2% of a smooth metal's light.
fn render_step_direction(v: GVertex, w: GVertex) -> vec3<f32> {
    if w.prim == BVH_NO_HIT {
        return w.shading;
    }
    return normalize(w.position - render_offset(v.position, v.normal));
}

// Pixel i's direct light, as the renderer estimates it (render_shade_direct; a stage that
// replaces that pass calls it for a primary vertex it does not take, render_reuses): the
// emission seen (a camera ray that missed sees the environment, the vertex's emission) + NEE,
// + with MIS the emission the GI ray found.
fn render_direct_pixel(i: u32) -> vec3<f32> {
    let g = render_primary_vertex(i);
    var c = g.emission;
    if g.prim != BVH_NO_HIT {
        var rng = render_rng(i, STREAM_DIRECT);
        c = g.emission + render_nee(g, &rng);
        if render_params.mis != 0u {
            let s = render_secondary_vertex(i, g);
            c += render_throughput(g, s) * render_hit_emission(g, s);
        }
    }
    return c;
}

// Pixel i's one-bounce indirect light, as the renderer estimates it (render_shade_indirect; a
// stage that replaces that pass calls it for a secondary vertex it does not take): NEE at the
// secondary vertex is the radiance leaving it towards the primary, which reflects it with the
// GI ray's weight (render_throughput).
// At a recorded glossy x2 (render_records_glossy) its light sample is drawn as a white diffuse
// surface's and kept (render_store_glossy_light).
fn render_indirect_pixel(i: u32) -> PathLight {
    let g = render_primary_vertex(i);
    let s = render_secondary_vertex(i, g);
    var light = PathLight(vec3<f32>(0.0), vec3<f32>(0.0));
    if g.prim != BVH_NO_HIT && s.prim != BVH_NO_HIT {
        var rng = render_rng(i, STREAM_INDIRECT);
        if render_records_glossy(s) {
            let nee = render_nee_sampled(render_sampled_as_diffuse(s), &rng, 0.0);
            // The white surface's BRDF 1 / pi divided out.
            let a_l = nee.light * SAMPLING_PI;
            render_store_glossy_light(i, nee.wi, a_l);
            var leaving = vec3<f32>(0.0);
            if any(a_l > vec3<f32>(0.0)) {
                leaving = render_brdf(s, nee.wi) * a_l;
            }
            return PathLight(render_throughput(g, s) * leaving, leaving);
        }
        let nee = render_nee(s, &rng);
        light = PathLight(render_throughput(g, s) * nee, nee);
    }
    return light;
}

// Direct light at primary vertex g from a stored reservoir: the emission seen + f(y) W with one
// shadow ray (restir-di's and the unified cache's shading), + with MIS the emission its GI ray
// found at `secondary`, both weighted with g's estimate e (render_light_mis_at).
fn render_direct_from_stored(g: GVertex, res: StoredReservoir, secondary: GVertex, e: f32) -> vec3<f32> {
    var c = g.emission;
    if g.prim != BVH_NO_HIT {
        c += render_shade_stored(render_stored_light(g, res, e), res, vec3<f32>(1.0));
        if render_params.mis != 0u {
            c += render_throughput(g, secondary) * render_hit_emission_at(g, secondary, e);
        }
    }
    return c;
}

// Screen-space reuse (restir-di, restir-gi): the pixel that sees a point, the similarity of two
// pixels' vertices, and a neighbour drawn in a disc.

// The continuous image coordinates ((0, 0) the top-left corner, pixel centres at + 0.5) at which
// camera `cam` sees the point p, or (-1, -1) when p is behind it.
fn render_project_xy(cam: CameraGpu, p: vec3<f32>) -> vec2<f32> {
    let d = p - cam.eye;
    let z = dot(d, cam.forward);
    if !(z > 1e-6) {
        return vec2<f32>(-1.0);
    }
    let sx = dot(d, cam.right) / (z * dot(cam.right, cam.right));
    let sy = dot(d, cam.up) / (z * dot(cam.up, cam.up));
    return vec2<f32>((sx + 1.0) * 0.5 * f32(cam.width), (1.0 - sy) * 0.5 * f32(cam.height));
}

// The pixel whose camera ray through `cam` sees the point p, or RENDER_NO_PIXEL when p is
// behind the camera or outside the image.
fn render_project(cam: CameraGpu, p: vec3<f32>) -> u32 {
    let xy = render_project_xy(cam, p);
    let x = xy.x;
    let y = xy.y;
    // Also rejects NaN.
    if !(x >= 0.0 && x < f32(cam.width) && y >= 0.0 && y < f32(cam.height)) {
        return RENDER_NO_PIXEL;
    }
    return min(u32(y), cam.height - 1u) * cam.width + min(u32(x), cam.width - 1u);
}

// Geometric similarity of a reused pixel's vertex q to the receiver g, both seen from eye: both
// hit, depths within depth_threshold (relative), shading normals within normal_threshold
// (cosine).
fn render_similar(g: GVertex, q: GVertex, eye: vec3<f32>, depth_threshold: f32,
                  normal_threshold: f32) -> bool {
    if q.prim == BVH_NO_HIT {
        return false;
    }
    let dg = distance(g.position, eye);
    let dq = distance(q.position, eye);
    return abs(dq - dg) <= depth_threshold * dg && dot(g.shading, q.shading) >= normal_threshold;
}

// A pixel drawn uniformly in the disc of `radius` pixels around pixel i of this frame's image,
// or RENDER_NO_PIXEL when it falls outside the image.
fn render_disc_neighbour(i: u32, radius: f32, rng: ptr<function, u32>) -> u32 {
    let cam = render_params.camera;
    let x = f32(i % cam.width);
    let y = f32(i / cam.width);
    let r = radius * sqrt(rng_next_f32(rng));
    let phi = 6.28318530717959 * rng_next_f32(rng);
    let nx = floor(x + 0.5 + r * cos(phi));
    let ny = floor(y + 0.5 + r * sin(phi));
    if !(nx >= 0.0 && nx < f32(cam.width) && ny >= 0.0 && ny < f32(cam.height)) {
        return RENDER_NO_PIXEL;
    }
    return u32(ny) * cam.width + u32(nx);
}

// Interpolated vertex normals at the hit, normalized and turned to the side of the geometric
// normal n (n when they cancel out). Twin: reference::shading_normal.
fn render_shading_normal(a: TriangleAttributes, hit: Hit, n: vec3<f32>) -> vec3<f32> {
    let raw = (1.0 - hit.b1 - hit.b2) * a.n0 + hit.b1 * a.n1 + hit.b2 * a.n2;
    let l2 = dot(raw, raw);
    if !(l2 > 1e-30) {
        return n;
    }
    let ns = raw * inverseSqrt(l2);
    return select(ns, -ns, dot(ns, n) < 0.0);
}

// The shading normal of a normal-mapped triangle at the hit (texture coordinates uv): the
// interpolated normal N and tangent T (made orthogonal to N), B = w cross(N, T) (w the sign of
// the interpolated handedness), the normal texture's n = normalize((2 texel - 1) * (scale,
// scale, 1)), and normalize(T n.x + B n.y + N n.z) turned to the side of the geometric normal
// n as render_shading_normal turns the interpolated one; that one where the frame degenerates.
// Twin: reference::normal_mapped.
fn render_normal_mapped(a: TriangleAttributes, hit: Hit, n: vec3<f32>, m: Material,
                        uv: vec2<f32>) -> vec3<f32> {
    let b = vec3<f32>(1.0 - hit.b1 - hit.b2, hit.b1, hit.b2);
    let raw = b.x * a.n0 + b.y * a.n1 + b.z * a.n2;
    let l2 = dot(raw, raw);
    if !(l2 > 1e-30) {
        return n;
    }
    let nn = raw * inverseSqrt(l2);
    let ns = select(nn, -nn, dot(nn, n) < 0.0);
    let t = b.x * sampling_oct_decode(unpack2x16snorm(a.tangent0))
        + b.y * sampling_oct_decode(unpack2x16snorm(a.tangent12.x))
        + b.z * sampling_oct_decode(unpack2x16snorm(a.tangent12.y));
    let tp = t - nn * dot(nn, t);
    let tl2 = dot(tp, tp);
    let ts = (render_texture(m.normal_texture, uv) * 2.0 - 1.0)
        * vec3<f32>(m.normal_scale, m.normal_scale, 1.0);
    let sl2 = dot(ts, ts);
    if !(tl2 > 1e-8 && sl2 > 1e-30) {
        return ns;
    }
    let flip_bits = vec3<u32>(1u, 2u, 4u) * RENDER_ATTR_TANGENT_FLIP;
    let flip = (vec3<u32>(a.flags) & flip_bits) != vec3<u32>(0u);
    let w = dot(b, select(vec3<f32>(1.0), vec3<f32>(-1.0), flip));
    let tu = tp * inverseSqrt(tl2);
    let bu = select(1.0, -1.0, w < 0.0) * cross(nn, tu);
    let p = normalize(tu * ts.x + bu * ts.y + nn * ts.z);
    return select(p, -p, dot(p, n) < 0.0);
}

// Origin offset off a surface along its normal, scaled with the coordinates' magnitude.
fn render_offset(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let scale = render_offset_scale(p);
    return p + n * (RENDER_RAY_EPS * scale);
}

// The BRDF of vertex v towards the viewer (v.wo) from direction wi (unit, towards the light),
// without the cosine: albedo / pi for a diffuse surface (the same product as before glossy
// materials, so diffuse images are unchanged), brdf_eval otherwise.
fn render_brdf(v: GVertex, wi: vec3<f32>) -> vec3<f32> {
    if !RENDER_GLOSSY || v.material == 0u {
        return v.albedo * SAMPLING_INV_PI;
    }
    let f = brdf_eval(render_vertex_brdf(v), v.shading, v.wo, wi);
    // Planted defect GLOSSY_ENERGY_LOSS (restir_world::plant).
    return f * select(1.0, 0.99, render_planted(PLANTED_GLOSSY_ENERGY_LOSS));
}

// The density (solid angle) with which vertex v's path step (render_path_step) draws the
// direction wi: the cosine's for a diffuse surface, brdf_pdf otherwise.
fn render_brdf_pdf(v: GVertex, wi: vec3<f32>) -> f32 {
    if !RENDER_GLOSSY || v.material == 0u {
        return max(dot(v.shading, wi), 0.0) * SAMPLING_INV_PI;
    }
    return brdf_pdf(render_vertex_brdf(v), v.shading, v.wo, wi);
}

// Unshadowed reflected radiance integrand of light sample s at vertex v, in the sample's
// measure (no pdf): BRDF * Le * G for a triangle point (area), BRDF * I * falloff * cos / d^2
// for a point or spot light (discrete), BRDF * L (or E) * cos for a direction at infinity
// (solid angle, or discrete for a directional light). The light must be on the side of v's
// geometric normal; the cosine is the shading normal's. Twin: lights::Lights::contribution.
fn render_vertex_light(v: GVertex, s: LightSample) -> vec3<f32> {
    if s.kind != LIGHTS_KIND_TRIANGLE {
        return render_other_light_contribution(v, s);
    }
    let to_light = s.position - v.position;
    let d2 = dot(to_light, to_light);
    if d2 <= 0.0 {
        return vec3<f32>(0.0);
    }
    let wi = to_light * inverseSqrt(d2);
    let cos_x = dot(v.shading, wi);
    let cos_l = abs(dot(s.normal, wi));
    if cos_x <= 0.0 || dot(v.normal, wi) <= 0.0 {
        return vec3<f32>(0.0);
    }
    return render_brdf(v, wi) * s.emission * (cos_x * cos_l / d2);
}

// The target p_hat of every light-sample resampling (ris, world-restir, restir-di): luminance
// of the unshadowed reflected radiance of s at v.
fn render_light_target(v: GVertex, s: LightSample) -> f32 {
    return render_luminance(render_vertex_light(v, s));
}

fn render_other_light_contribution(v: GVertex, s: LightSample) -> vec3<f32> {
    if lights_at_infinity(s.kind) {
        let cos_x = dot(v.shading, s.position);
        if cos_x <= 0.0 || dot(v.normal, s.position) <= 0.0 {
            return vec3<f32>(0.0);
        }
        return render_brdf(v, s.position) * s.emission * cos_x;
    }
    let to_light = s.position - v.position;
    let d2 = dot(to_light, to_light);
    if d2 <= 0.0 {
        return vec3<f32>(0.0);
    }
    let d = sqrt(d2);
    let cos_x = dot(v.shading, to_light) / d;
    if cos_x <= 0.0 || dot(v.normal, to_light) <= 0.0 {
        return vec3<f32>(0.0);
    }
    let falloff = lights_point_falloff(s.light, -to_light / d, d2);
    return render_brdf(v, to_light / d) * s.emission * (cos_x * falloff / d2);
}

// What ray offsets at p are relative to: the point's largest coordinate (float precision
// there), at least the scene's extent capped at 1 (render_params.ray_offset_floor), so that a
// scene in small units keeps the same relative offsets as one in metres.
fn render_offset_scale(p: vec3<f32>) -> f32 {
    return max(render_params.ray_offset_floor, max(abs(p.x), max(abs(p.y), abs(p.z))));
}

// Whether the segment from the surface point p (normal n) to the light point q is unoccluded.
fn render_visible(p: vec3<f32>, n: vec3<f32>, q: vec3<f32>) -> bool {
    let o = render_offset(p, n);
    let to = q - o;
    let d = length(to);
    if d <= 0.0 {
        return false;
    }
    var ray: Ray;
    ray.origin = o;
    ray.tmin = 0.0;
    ray.dir = to / d;
    ray.tmax = d - RENDER_RAY_EPS * render_offset_scale(q);
    return !trace_any(ray);
}

// Whether light sample s is unoccluded from the surface point p (normal n): the segment to its
// point, or a ray to infinity along its direction.
fn render_visible_sample(p: vec3<f32>, n: vec3<f32>, s: LightSample) -> bool {
    if !lights_at_infinity(s.kind) {
        return render_visible(p, n, s.position);
    }
    var ray: Ray;
    ray.origin = render_offset(p, n);
    ray.tmin = 0.0;
    ray.dir = s.position;
    ray.tmax = RENDER_T_MAX;
    return !trace_any(ray);
}

// Resampled importance sampling over `candidates` light samples at vertex v, target =
// luminance of the unshadowed reflected radiance (render_light_target). The reservoir crate does the resampling; the
// chosen light sample is the caller's payload. Shared by the `ris` baseline and world-space
// ReSTIR's initial reservoirs.
struct RisLightSample {
    reservoir: Reservoir,
    light: LightSample,
    p_hat: f32,
}

fn render_ris_lights(v: GVertex, candidates: u32, rng: ptr<function, u32>) -> RisLightSample {
    // A whole local reservoir (not a pointer into a struct field): naga's SPIR-V backend
    // rejects the latter as a function argument.
    var r = reservoir_empty();
    var out: RisLightSample;
    out.p_hat = 0.0;
    for (var k = 0u; k < candidates; k++) {
        let s = render_light_sample(render_rand4(rng), rng);
        render_ris_candidate(&r, &out, v, s, rng_next_f32(rng));
    }
    reservoir_finalize(&r, out.p_hat);
    out.reservoir = r;
    return out;
}

// One RIS candidate: light sample s, drawn with density s.pdf_area, into r with uniform u, at
// vertex v; out keeps the selected sample and its target.
fn render_ris_candidate(r: ptr<function, Reservoir>, out: ptr<function, RisLightSample>,
                        v: GVertex, s: LightSample, u: f32) {
    var w = 0.0;
    var p_hat = 0.0;
    if s.pdf_area > 0.0 {
        p_hat = render_light_target(v, s);
        w = p_hat / s.pdf_area;
    }
    if reservoir_update(r, w, u) {
        (*out).light = s;
        (*out).p_hat = p_hat;
    }
}

// Reflected direct light at a surface vertex with the render's method, MIS-weighted with the
// light table's density.
fn render_nee(v: GVertex, rng: ptr<function, u32>) -> vec3<f32> {
    return render_nee_at(v, rng, 0.0);
}

// render_nee with the MIS density of estimate e (render_light_density; 0: the table's): one
// light sample of the table (nee), or the one RIS selects among render_params.candidates (ris),
// shaded with one shadow ray, f / pdf or f W. One shading block for both methods, so that a
// kernel carries one copy of the BRDF's evaluation and density here, not two.
fn render_nee_at(v: GVertex, rng: ptr<function, u32>, e: f32) -> vec3<f32> {
    return render_nee_sampled(v, rng, e).light;
}

// render_nee_at's light and the direction its light sample arrives from (0 where none).
struct RenderNee {
    light: vec3<f32>,
    wi: vec3<f32>,
}

fn render_nee_sampled(v: GVertex, rng: ptr<function, u32>, e: f32) -> RenderNee {
    var none = RenderNee(vec3<f32>(0.0), vec3<f32>(0.0));
    if lights_info.count == 0u {
        return none;
    }
    let ris_method = render_params.method == RENDER_METHOD_RIS;
    var s: LightSample;
    var ucw = 0.0;
    if ris_method {
        let ris = render_ris_lights(v, render_params.candidates, rng);
        s = ris.light;
        ucw = ris.reservoir.ucw;
        if ucw <= 0.0 {
            return none;
        }
    } else {
        s = render_light_sample(render_rand4(rng), rng);
        if s.pdf_area <= 0.0 {
            return none;
        }
    }
    var f = render_vertex_light(v, s);
    if all(f == vec3<f32>(0.0)) || !render_visible_sample(v.position, v.normal, s) {
        return none;
    }
    if render_params.mis != 0u {
        f *= render_light_mis_at(v, s, e);
    }
    var wi = s.position;
    if !lights_at_infinity(s.kind) {
        wi = normalize(s.position - v.position);
    }
    if ris_method {
        return RenderNee(f * ucw, wi);
    }
    return RenderNee(f / s.pdf_area, wi);
}

// The debug views' heat map of t in [0, 1]: blue .. cyan .. yellow .. red (twin: render::heat).
fn render_heat(t: f32) -> vec3<f32> {
    let x = clamp(t, 0.0, 1.0);
    return clamp(vec3<f32>(1.5) - abs(vec3<f32>(4.0 * x) - vec3<f32>(3.0, 2.0, 1.0)), vec3<f32>(0.0), vec3<f32>(1.0));
}
