// The indirect path beyond the secondary vertex, shared by the renderer's `render_path` pass and
// the radiance cache's `cache_path` pass. Needs the render library and a module "path-cache"
// that defines
//     fn path_cache_radiance(w: GVertex, bounce: u32, footprint: f32) -> vec4<f32>
// the radiance reflected at the path's vertex w, reached by bounce `bounce` with the path's
// footprint there (render_path_spread), towards the vertex before it (.w = 1), or .w = 0 when
// the path goes on (no cache, no sample in w's cell, or a footprint smaller than the cell);
// and a module "path-light" that defines
//     fn path_light_estimate(i: u32, w: GVertex, bounce: u32) -> f32
// the estimate e that pixel i's light sample at the path's vertex w (reached by bounce
// `bounce`) and the ray leaving w weigh their MIS with (render_light_density; 0: the light
// table's density), drawn from numbers of its own, and
//     fn path_light_nee(i: u32, w: GVertex, bounce: u32, e: f32, rng: ptr<function, u32>) -> vec3<f32>
// the light reflected at w by its light sample (render_nee_at without a stage's own).

// The spread a segment from v (direction dir, drawn by v's path step) to w adds to a path's
// footprint (Mueller et al. 2021, neural radiance caching: the square root of the area term
// |v - w|^2 / (p(dir) |cos at w|), p the step's density, cos at v / pi for a diffuse surface):
// a length, at least the segment's for a diffuse surface (a glossy lobe's is narrower).
fn render_path_spread(v: GVertex, w: GVertex, dir: vec3<f32>) -> f32 {
    let cos_w = max(abs(dot(w.normal, dir)), 0.01);
    if RENDER_GLOSSY && v.material != 0u {
        let p = max(render_brdf_pdf(v, dir), 0.01 * SAMPLING_INV_PI);
        return length(w.position - v.position) * sqrt(1.0 / (p * cos_w));
    }
    let cos_v = max(dot(v.shading, dir), 0.01);
    return length(w.position - v.position) * sqrt(SAMPLING_PI / (cos_v * cos_w));
}

// Bounces 2..=render_params.bounces of pixel i: the path goes on from the secondary vertex by
// its vertices' path steps (render_path_step: cosine sampling on a diffuse surface, the BRDF's
// sampler on a glossy one), with the render's light estimate (render_nee) at every vertex,
// weighted by the throughput (products of render_throughput: albedos where diffuse, the cosine
// pdf cancelling the BRDF's cos / pi); Russian roulette from bounce roulette_from on
// (render_roulette_survival). Adds what it finds to both parts of the pixel's
// PathLight, the radiance leaving the secondary vertex (render_path_radiance, throughput from 1)
// and the primary's reflected light (render_indirect_frame, throughput from the primary's
// albedo), which the secondary vertex's pass wrote. Emission the path hits is not added (NEE at
// the vertex before counts it), nor the environment an escaping ray sees, except with MIS
// (render_params.mis), which weighs both ways to the light and traces one more ray for the last
// bounce's hits. A vertex whose cached radiance path_cache_radiance gives ends the path: that
// radiance stands for its light estimate and every bounce beyond it. With
// render_params.path_split on, also records the pixel's path split (RenderPathSplit), or at a
// glossy x2 its record's continuation (RenderGlossyX2).
fn render_path_pixel(i: u32) {
    let g = render_primary_vertex(i);
    var v = render_secondary_vertex(i, g);
    if g.prim == BVH_NO_HIT || v.prim == BVH_NO_HIT {
        return;
    }
    // The two throughputs: leaving the secondary vertex, and reflected at the primary.
    var leaving = vec3<f32>(1.0);
    var reflected = render_throughput(g, v);
    var light = PathLight(vec3<f32>(0.0), vec3<f32>(0.0));
    var footprint = render_path_spread(g, v, normalize(v.position - g.position));
    // The MIS estimate of v's light sample (x2's, as its pass stored it: render_store_path_light).
    var e_v = render_path_radiance[i].w;
    // One bounce fewer under the planted defect MISSING_BOUNCE (restir_world::plant).
    let bounces = render_params.bounces - select(0u, 1u, render_planted(PLANTED_MISSING_BOUNCE));
    // With MIS one more ray: the emission the last vertex's ray finds is part of the last bounce.
    let last = bounces + render_params.mis;
    // The path split (render_params.path_split): x2's light so far is its light sample's.
    var split = RenderPathSplit(render_path_radiance[i].xyz, vec3<f32>(0.0), vec3<f32>(0.0),
                                vec3<f32>(0.0), vec3<f32>(0.0), false, false);
    split.one_short = select(vec3<f32>(0.0), split.direct, bounces >= 2u);
    // The throughput of what x3 sends towards x2.
    var beyond = vec3<f32>(1.0);
    // A recorded glossy x2's continuation (RenderGlossyX2): its ray's direction, cos / pdf
    // (pi: cosine-distributed) and the emission it found over the roulette at x2.
    let x2 = v;
    var x2_wi = vec3<f32>(0.0);
    var x2_ratio = 0.0;
    var x2_found = vec3<f32>(0.0);
    for (var bounce = 2u; bounce <= last; bounce++) {
        var rng = render_rng_salted(i, STREAM_PATH, SALT_PATH_BOUNCE + bounce);
        // A recorded glossy x2 is sampled as a white diffuse surface (RenderGlossyX2), its
        // roulette too: its step's weight is f cos / (cos / pi).
        let x2_recorded = bounce == 2u && render_records_glossy(v);
        var sv = v;
        if x2_recorded {
            sv = render_sampled_as_diffuse(v);
        }
        if render_params.roulette_from != 0u && bounce >= render_params.roulette_from {
            let q = render_roulette_survival(sv);
            if !(rng_next_f32(&rng) < q) {
                break;
            }
            leaving /= render_roulette_divisor(q);
            reflected /= render_roulette_divisor(q);
            beyond /= render_roulette_divisor(q);
        }
        let w = render_path_step(sv, &rng);
        var t = render_throughput(v, w);
        if x2_recorded {
            t = render_brdf(v, render_step_direction(v, w)) * SAMPLING_PI;
        }
        leaving *= t;
        reflected *= t;
        if bounce > 2u {
            beyond *= t;
        }
        // The ray from v weighs what it finds as v's light sample was.
        let found = render_hit_emission_at(sv, w, e_v);
        render_path_add(&light, leaving, reflected, found);
        // Split: the emission x2's ray finds is x2's own light; the one vertex k's ray finds is
        // vertex k's light (k = bounce), in the short radiance where k is at most `bounces`.
        if bounce == 2u {
            x2_wi = render_step_direction(v, w);
            x2_ratio = select(0.0, SAMPLING_PI, w.prim != BVH_NO_HIT || any(w.shading != vec3<f32>(0.0)));
            x2_found = beyond * found;
            split.direct += leaving * found;
            split.x3 = w.position;
            split.x3_normal = w.normal;
            split.x3_hit = w.prim != BVH_NO_HIT;
            split.x3_glossy = split.x3_hit && !render_reuses(w);
        } else {
            split.beyond += beyond * found;
        }
        split.one_short += select(vec3<f32>(0.0), leaving * found, bounce <= bounces);
        if w.prim == BVH_NO_HIT || bounce > bounces {
            break;
        }
        footprint += render_path_spread(sv, w, normalize(w.position - v.position));
        let cached = path_cache_radiance(w, bounce, footprint);
        // Vertex w is vertex bounce + 1: its light (or the cache's radiance) is in the short
        // radiance where that is at most `bounces`.
        let in_short = bounce + 1u <= bounces;
        if cached.w > 0.0 {
            render_path_add(&light, leaving, reflected, cached.xyz);
            split.beyond += beyond * cached.xyz;
            split.one_short += select(vec3<f32>(0.0), leaving * cached.xyz, in_short);
            break;
        }
        let e_w = path_light_estimate(i, w, bounce);
        let nee = path_light_nee(i, w, bounce, e_w, &rng);
        render_path_add(&light, leaving, reflected, nee);
        split.beyond += beyond * nee;
        split.one_short += select(vec3<f32>(0.0), leaving * nee, in_short);
        v = w;
        e_v = e_w;
    }
    render_path_radiance[i] += vec4<f32>(light.leaving, 0.0);
    render_indirect_frame[i] += vec4<f32>(light.reflected, 0.0);
    if render_records_glossy(x2) {
        if x2_ratio > 0.0 {
            render_store_glossy_continuation(i, x2_wi, x2_ratio * (x2_found + split.beyond));
        }
    } else if render_params.path_split != 0u {
        render_store_path_split(i, split);
    }
}

// Adds radiance l, found along the path with the two throughputs, to both parts of `light`.
fn render_path_add(light: ptr<function, PathLight>, leaving: vec3<f32>, reflected: vec3<f32>,
                   l: vec3<f32>) {
    (*light).leaving += leaving * l;
    (*light).reflected += reflected * l;
}

// One bounce from v: the vertex a ray drawn by v's BRDF finds, cosine-sampled about v's shading
// normal on a diffuse surface (two random numbers), by brdf_sample on a glossy one (three); its
// density is render_brdf_pdf, its weight render_throughput. prim = BVH_NO_HIT where the ray
// escapes or points below the geometric surface (then emission is 0 and the path ends).
fn render_path_step(v: GVertex, rng: ptr<function, u32>) -> GVertex {
    let u = vec2<f32>(rng_next_f32(rng), rng_next_f32(rng));
    var ray: Ray;
    ray.origin = render_offset(v.position, v.normal);
    ray.tmin = 0.0;
    ray.dir = sampling_cosine_hemisphere(v.shading, u);
    ray.tmax = RENDER_T_MAX;
    if RENDER_GLOSSY && v.material != 0u {
        let u3 = vec3<f32>(u, rng_next_f32(rng));
        let s = brdf_sample(render_vertex_brdf(v), v.shading, v.wo, u3);
        ray.dir = s.wi;
        if !(s.pdf > 0.0) || dot(ray.dir, v.normal) <= 0.0 {
            var none: GVertex;
            none.prim = BVH_NO_HIT;
            return none;
        }
    }
    if render_params.attributes != 0u && dot(ray.dir, v.normal) <= 0.0 {
        var none: GVertex;
        none.prim = BVH_NO_HIT;
        return none;
    }
    return render_surface(ray.dir, trace_closest(ray));
}
