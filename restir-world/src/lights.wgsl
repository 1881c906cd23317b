// Light sampling over every light of the scene in one power-proportional alias table (Vose):
// emissive triangles (uniform area sampling), the environment (a pixel by luminance x solid
// angle, then a direction uniformly in its solid angle) and punctual lights (point, spot,
// directional). A sample's pdf_area is in its own measure: area, solid angle (environment) or a
// discrete probability (punctual). Emitters are two-sided. Needs sampling.wgsl, the light kind
// constants (restir_world::lights::constants_wgsl) and the bindings of
// restir_world::lights::bindings (lights_triangles, lights_alias, lights_env, lights_info).
// Twin: restir_world::lights::Lights.

// One light of the table. A triangle (kind LIGHTS_KIND_TRIANGLE): p0 and the edges
// e1 = p1 - p0, e2 = p2 - p0 (the geometric normal is normalize(cross(e1, e2))), `triangle` =
// its index in the scene's triangle list (not the BVH order). Other kinds have area 1 and
// triangle 0xffffffff; a point/spot light has its position in p0, its spot axis in e1 and
// e2 = (cos outer, 1 / (cos inner - cos outer) or 0 for a point light, range or 0); a
// directional light the unit direction towards it in p0. `prob` = probability that
// lights_pick returns it (power / total).
struct LightTriangle {
    p0: vec3<f32>,
    area: f32,
    e1: vec3<f32>,
    prob: f32,
    e2: vec3<f32>,
    triangle: u32,
    emission: vec3<f32>,
    kind: u32,
}

// One environment pixel: radiance, the solid-angle density of directions in it once the
// environment is the chosen light, and its column of the pixels' alias table.
struct EnvPixel {
    radiance: vec3<f32>,
    pdf: f32,
    alias_prob: f32,
    alias_index: u32,
    _pad0: u32,
    _pad1: u32,
}

// One column of the alias table: keep the column with probability `prob`, else take `alias`.
struct AliasEntry {
    prob: f32,
    alias_index: u32,
}

// count = number of lights in the table (0: nothing to sample; the buffers then hold one dummy
// entry each). total_power = sum of the weights (informative). env_width x env_height: the
// environment map (0 x 0: none).
struct LightsInfo {
    count: u32,
    env_width: u32,
    total_power: f32,
    env_height: u32,
    // The environment's index in the table (LIGHTS_NONE without one).
    env_light: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// A sample of a light: a point on it, or the unit direction towards it (`position`) for the
// kinds at infinity (environment, directional). pdf_area = density of having sampled it in its
// measure (0 when there are no lights: treat as no contribution). normal = the triangle's unit
// geometric normal (either side emits), the spot axis, or the direction. emission = radiance,
// intensity or illuminance. (light, coords) determine the rest (lights_sample_at): coords are a
// triangle point's barycentrics (b1, b2), or an environment direction in octahedral
// coordinates (sampling_oct_encode); punctual lights do not use them.
struct LightSample {
    position: vec3<f32>,
    pdf_area: f32,
    normal: vec3<f32>,
    light: u32,
    emission: vec3<f32>,
    triangle: u32,
    coords: vec2<f32>,
    kind: u32,
}

fn lights_at_infinity(kind: u32) -> bool {
    return kind == LIGHTS_KIND_ENV || kind == LIGHTS_KIND_DIRECTIONAL;
}

// cos theta at the top and bottom edges of environment row y.
fn lights_env_row_cosines(y: u32) -> vec2<f32> {
    let step = 3.14159265358979 / f32(lights_info.env_height);
    return vec2<f32>(cos(f32(y) * step), cos(f32(y + 1u) * step));
}

// The environment pixel a unit direction falls in (twin: scene::environment::pixel_of).
fn lights_env_pixel(dir: vec3<f32>) -> u32 {
    let tau = 6.28318530717959;
    var phi = atan2(dir.x, -dir.z);
    if phi < 0.0 {
        phi += tau;
    }
    let theta = acos(clamp(dir.y, -1.0, 1.0));
    let w = lights_info.env_width;
    let h = lights_info.env_height;
    let x = min(u32(phi / tau * f32(w)), w - 1u);
    let y = min(u32(theta / 3.14159265358979 * f32(h)), h - 1u);
    return y * w + x;
}

// Radiance of the environment from unit direction dir (0 without one).
fn lights_env_radiance(dir: vec3<f32>) -> vec3<f32> {
    if lights_info.env_width == 0u {
        return vec3<f32>(0.0);
    }
    return lights_env[lights_env_pixel(dir)].radiance;
}

// Spot cone and range attenuation of point light `light` towards a receiver in unit direction
// wo (from the light) at squared distance d2 (KHR_lights_punctual's recommendation).
fn lights_point_falloff(light: u32, wo: vec3<f32>, d2: f32) -> f32 {
    let t = lights_triangles[light];
    var a = 1.0;
    if t.e2.y > 0.0 {
        let s = clamp((dot(t.e1, wo) - t.e2.x) * t.e2.y, 0.0, 1.0);
        a = s * s;
    }
    if t.e2.z > 0.0 {
        let q = d2 / (t.e2.z * t.e2.z);
        a *= clamp(1.0 - q * q, 0.0, 1.0);
    }
    return a;
}

// Index into lights_triangles drawn proportionally to power, from two uniforms in [0, 1).
// Requires lights_info.count > 0.
fn lights_pick(u0: f32, u1: f32) -> u32 {
    let n = lights_info.count;
    let column = min(u32(u0 * f32(n)), n - 1u);
    let entry = lights_alias[column];
    if u1 < entry.prob {
        return column;
    }
    return entry.alias_index;
}

// Area density of points of light `light` under lights_sample.
fn lights_pdf_area(light: u32) -> f32 {
    let t = lights_triangles[light];
    return t.prob / t.area;
}

// A power-proportional light, then a sample of it, from four uniforms in [0, 1): u.x, u.y pick
// the light, u.z, u.w the point on a triangle (or the environment's pixel); an environment
// sample draws two more uniforms from rng for the direction in its pixel.
fn lights_sample(u: vec4<f32>, rng: ptr<function, u32>) -> LightSample {
    if lights_info.count == 0u {
        var s: LightSample;
        s.pdf_area = 0.0;
        s.light = 0xffffffffu;
        s.triangle = 0xffffffffu;
        return s;
    }
    let i = lights_pick(u.x, u.y);
    let t = lights_triangles[i];
    if t.kind != LIGHTS_KIND_ENV {
        // A triangle's point from u.zw; punctual lights have no coordinates to draw.
        return lights_sample_at(i, sampling_triangle_uniform(u.zw));
    }
    let w = lights_info.env_width;
    let n = w * lights_info.env_height;
    let column = min(u32(u.z * f32(n)), n - 1u);
    let c = lights_env[column];
    var k = c.alias_index;
    if u.w < c.alias_prob {
        k = column;
    }
    let a = rng_next_f32(rng);
    let b = rng_next_f32(rng);
    let phi = (f32(k % w) + a) * (6.28318530717959 / f32(w));
    let rows = lights_env_row_cosines(k / w);
    let cos_theta = rows.x + b * (rows.y - rows.x);
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    let px = lights_env[k];
    var s = lights_sample_common(i, t);
    s.position = vec3<f32>(sin_theta * sin(phi), cos_theta, -sin_theta * cos(phi));
    s.normal = s.position;
    s.coords = sampling_oct_encode(s.position);
    s.pdf_area = t.prob * px.pdf;
    s.emission = px.radiance;
    return s;
}

// The fields of a sample of light i (its table entry t) that do not depend on where on the
// light it is: a punctual light's whole sample.
fn lights_sample_common(i: u32, t: LightTriangle) -> LightSample {
    var s: LightSample;
    s.light = i;
    s.emission = t.emission;
    s.triangle = t.triangle;
    s.kind = t.kind;
    s.position = t.p0;
    s.pdf_area = t.prob;
    s.normal = select(t.e1, t.p0, t.kind == LIGHTS_KIND_DIRECTIONAL);
    return s;
}

// The sample of light `light` (a lights_triangles index) at `coords` (see LightSample): the
// inverse of a sample's (light, coords), for storing a sample compactly. pdf_area is the
// sample's density, except for the environment, where it is left 0 (the pixel's density is
// not needed by the reuse passes that decode samples).
fn lights_sample_at(light: u32, coords: vec2<f32>) -> LightSample {
    let t = lights_triangles[light];
    var s = lights_sample_common(light, t);
    s.coords = coords;
    if t.kind == LIGHTS_KIND_TRIANGLE {
        s.position = t.p0 + coords.x * t.e1 + coords.y * t.e2;
        s.pdf_area = t.prob / t.area;
        s.normal = normalize(cross(t.e1, t.e2));
    } else if t.kind == LIGHTS_KIND_ENV {
        s.position = sampling_oct_decode(coords);
        s.normal = s.position;
        s.pdf_area = 0.0;
        s.emission = lights_env_radiance(s.position);
    }
    return s;
}

// Solid-angle density at the receiver of a light point sampled with area density pdf_area,
// where to_light = light point - receiver and light_normal is the light's unit normal:
// pdf_area * d^2 / |cos theta_light|. Returns 0 when the light is seen edge-on (or the points
// coincide): its contribution is 0 then, so skip it rather than divide.
fn lights_pdf_solid_angle(pdf_area: f32, to_light: vec3<f32>, light_normal: vec3<f32>) -> f32 {
    let d2 = dot(to_light, to_light);
    let cos_l = abs(dot(light_normal, to_light)) * inverseSqrt(max(d2, 1e-30));
    if cos_l <= 0.0 || d2 <= 0.0 {
        return 0.0;
    }
    return pdf_area * d2 / cos_l;
}

// Solid-angle density with which lights_sample picks the point q (geometric normal nq) of scene
// triangle `triangle`, seen from p: 0 when the triangle does not emit. For multiple importance
// sampling of a ray that hit an emitter.
fn lights_pdf_hit(triangle: u32, p: vec3<f32>, q: vec3<f32>, nq: vec3<f32>) -> f32 {
    let light = lights_of_triangle[triangle];
    if light == LIGHTS_NONE {
        return 0.0;
    }
    return lights_pdf_solid_angle(lights_pdf_area(light), q - p, nq);
}

// Solid-angle density with which lights_sample picks the environment direction dir (0 without
// an environment).
fn lights_pdf_env(dir: vec3<f32>) -> f32 {
    if lights_info.env_light == LIGHTS_NONE {
        return 0.0;
    }
    return lights_triangles[lights_info.env_light].prob * lights_env[lights_env_pixel(dir)].pdf;
}
