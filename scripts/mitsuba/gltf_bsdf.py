#!/usr/bin/env python3
"""glTF 2.0 metal-roughness BRDF with Kulla-Conty energy compensation, as a Mitsuba 3 plugin.

The model is the workspace's (`restir-world/src/brdf/mod.rs`), written again from its
definition, with its compensation tables computed here by an independent quadrature (nothing
is read from the renderer). In the local frame of the shading normal n, wo the direction
towards the viewer and wi the one towards the light (f = 0 unless both are above the surface):

- D: GGX (Trowbridge-Reitz), alpha = roughness^2, roughness clamped to [0.02, 1];
- V = G2 / (4 cos_o cos_i), G2 the height-correlated Smith masking-shadowing:
  V = 0.5 / (cos_i sqrt(cos_o^2 (1 - a^2) + a^2) + cos_o sqrt(cos_i^2 (1 - a^2) + a^2));
- F: Schlick, F0 + (1 - F0) (1 - |wo.h|)^5;
- E(mu): the directional albedo of D V cos (F = 1); E_avg = 2 int E(mu) mu dmu;
- f_ms(F0) = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)) * F_ms(F0), with
  F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)), F_avg = F0 + (1 - F0) / 21 (Kulla-Conty);
- metal = F(base) D V + f_ms(base);
- E_s(mu): the directional albedo of the dielectric's specular part, F(0.04) D V + f_ms(0.04);
- dielectric = F(0.04) D V + f_ms(0.04) + base / pi (1 - E_s(mu_o)) (1 - E_s(mu_i)) / (1 - E_s,avg);
- f = mix(dielectric, metal, metallic).

Both faces shade alike: where the viewer is below the surface (si.wi.z < 0) both directions
are mirrored through the tangent plane first (the renderer turns the normal towards the
incoming ray).

Sampling (any unbiased choice will do; this one is Mitsuba's): with probability `p_spec` GGX's
visible normals (`mi.MicrofacetDistribution`, sample_visible) reflected about, otherwise the
cosine lobe; the pdf is the mixture's.

Controls for the tests (`variant`): "full" (the model above), "no-compensation" (glTF
Appendix B's single scattering: dielectric = F(0.04) D V + base / pi (1 - F(0.04)), metal =
F(base) D V), "no-fresnel" (compensated, but F = F0 everywhere: Schlick's term dropped),
"uncorrelated" (compensated, separable Smith G1(wo) G1(wi) in V, its own tables).

Run this file to check the plugin (furnace: a white metal's and a white dielectric's albedo
is 1 at every angle; the sampler's weights against a uniform-hemisphere estimate; the pdf's
integral; reciprocity; both faces):

    python3 scripts/mitsuba/gltf_bsdf.py
"""

import math

import numpy as np

MIN_ROUGHNESS = 0.02
DIELECTRIC_F0 = 0.04
VARIANTS = ("full", "no-compensation", "no-fresnel", "uncorrelated")

# The tables' mu axis: mu = t^3 at TABLE_NODES nodes uniform in t (dense near grazing, where
# E(mu) dips at mu ~ alpha); lookups are linear in t.
TABLE_NODES = 384
# Quadrature per table node (HalfVectorQuadrature): Gauss-Legendre nodes in ln tan^2 theta_h,
# midpoints in azimuth over the half circle.
QUAD_U = 1024
QUAD_PHI = 192


def clamp_roughness(r):
    return min(max(float(r), MIN_ROUGHNESS), 1.0)


def smith_lambda_term(cos, a2):
    """sqrt(cos^2 (1 - a^2) + a^2) = cos (1 + 2 Lambda(cos))."""
    return np.sqrt(cos * cos * (1.0 - a2) + a2)


def visibility_np(cos_o, cos_i, a2, correlated=True):
    """V = G2 / (4 cos_o cos_i); height-correlated or separable Smith."""
    so = smith_lambda_term(cos_o, a2)
    si = smith_lambda_term(cos_i, a2)
    if correlated:
        return 0.5 / (cos_i * so + cos_o * si)
    # G1(c) = 2 c / (c + s(c)); V = G1(o) G1(i) / (4 cos_o cos_i) = 1 / ((c_o + s_o)(c_i + s_i))
    return 1.0 / ((cos_o + so) * (cos_i + si))


class HalfVectorQuadrature:
    """The directional albedos (E, E04) of D V cos with F = 1 and with Schlick's F at F0 = 0.04.

    Integrates over the half vector h, weighted by the GGX distribution of normals D(h) (n.h)
    dw_h, whose CDF in T = tan^2 theta_h is u = T / (a^2 + T): then
    int f cos dw_i = int du dphi / (2 pi) [4 (wo.h) V F cos_i / (n.h)] over wo.h > 0 and
    cos_i > 0. The nodes are Gauss-Legendre in ln T over [a^2 1e-8, a^2 1e8] (du = T a^2 /
    (a^2 + T)^2 d ln T; the mass outside is 1e-8) and midpoints in phi over the half circle
    (the integrand is even in phi with wo in the xz plane). Uniform in ln T, the nodes resolve
    GGX's long tail, whose directions past the horizon are what a smooth surface loses (1 - E
    = a^2 / (1 + a^2) at normal incidence, 1e-4 at roughness 0.1), as well as its peak."""

    def __init__(self, alpha, correlated=True, nu=QUAD_U, nphi=QUAD_PHI):
        self.a2 = alpha * alpha
        self.correlated = correlated
        x, w = np.polynomial.legendre.leggauss(nu)
        lo, hi = math.log(self.a2 * 1e-8), math.log(self.a2 * 1e8)
        t = np.exp(lo + (hi - lo) * 0.5 * (x + 1.0))
        du = 0.5 * (hi - lo) * w * t * self.a2 / (self.a2 + t) ** 2
        phi = (np.arange(nphi) + 0.5) * (math.pi / nphi)
        cos_h = 1.0 / np.sqrt(1.0 + t)
        sin_h = np.sqrt(t) * cos_h
        self.hx = (sin_h[:, None] * np.cos(phi)[None, :]).ravel()
        self.hz = np.repeat(cos_h, nphi)
        self.w = np.repeat(du / nphi, nphi)

    def albedos(self, mu):
        so = math.sqrt(max(0.0, 1.0 - mu * mu))
        vh = so * self.hx + mu * self.hz
        cos_i = 2.0 * vh * self.hz - mu
        ok = (vh > 0.0) & (cos_i > 0.0)
        vh, hz, ci, w = vh[ok], self.hz[ok], cos_i[ok], self.w[ok]
        g = w * 4.0 * vh * visibility_np(mu, ci, self.a2, self.correlated) * ci / hz
        x = np.clip(1.0 - vh, 0.0, 1.0)
        x2 = x * x
        f04 = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * (x2 * x2 * x)
        return float(np.sum(g)), float(np.sum(g * f04))


def ms_fresnel(f0, loss_avg):
    """Kulla-Conty's F_ms from F0 (scalar or array) and 1 - E_avg."""
    f0 = np.asarray(f0, dtype=np.float64)
    f_avg = f0 + (1.0 - f0) / 21.0
    return f_avg * f_avg * (1.0 - loss_avg) / (1.0 - f_avg * loss_avg)


class Tables:
    """1 - E(mu) and 1 - E_s(mu) at TABLE_NODES nodes (mu = t^3) for one roughness, and their
    averages 2 int (1 - E) mu dmu of the linear interpolants."""

    def __init__(self, roughness, correlated=True, fresnel=True):
        alpha = clamp_roughness(roughness) ** 2
        t = np.linspace(0.0, 1.0, TABLE_NODES)
        mu = t**3
        quad = HalfVectorQuadrature(alpha, correlated)
        e = np.empty(TABLE_NODES)
        e04 = np.empty(TABLE_NODES)
        for k, m in enumerate(mu):
            e[k], e04[k] = quad.albedos(m)
        if not fresnel:
            e04 = DIELECTRIC_F0 * e
        self.t = t
        self.loss = np.maximum(1.0 - e, 0.0)
        self.loss_avg = self._average(self.loss)
        f_ms04 = float(ms_fresnel(DIELECTRIC_F0, self.loss_avg))
        self.spec_loss = np.maximum(1.0 - (e04 + self.loss * f_ms04), 0.0)
        self.spec_loss_avg = self._average(self.spec_loss)

    def _average(self, table):
        """2 int_0^1 L(mu) mu dmu of the interpolant (linear in t, mu = t^3): 8-point
        Gauss-Legendre on each interval."""
        x, w = np.polynomial.legendre.leggauss(8)
        a, b = self.t[:-1, None], self.t[1:, None]
        s = 0.5 * (x[None, :] + 1.0)
        tt = a + (b - a) * s
        lo, hi = table[:-1, None], table[1:, None]
        val = lo + (hi - lo) * s
        # dmu = 3 t^2 dt, mu = t^3.
        return float(2.0 * np.sum(0.5 * w[None, :] * (b - a) * val * tt**3 * 3.0 * tt**2))

    def lookup(self, mu, table):
        """numpy twin of the plugin's lookup."""
        return np.interp(np.cbrt(np.clip(mu, 0.0, 1.0)), self.t, table)


_TABLES = {}


def tables(roughness, correlated=True, fresnel=True):
    key = (clamp_roughness(roughness), correlated, fresnel)
    if key not in _TABLES:
        _TABLES[key] = Tables(*key)
    return _TABLES[key]


def register(mi, dr):
    """Registers the plugin as `gltf_metal_roughness` with the active (JIT) Mitsuba variant.
    Parameters: base_r, base_g, base_b (base colour), metallic, roughness, variant (see
    VARIANTS), p_spec (the probability of drawing the visible-normal lobe; default by
    metallic)."""

    inv_pi = 1.0 / math.pi

    class GltfMetalRoughness(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            base = [min(max(float(props.get(f"base_{c}", 1.0)), 0.0), 1.0) for c in "rgb"]
            self.base_np = np.array(base)
            self.metallic = min(max(float(props.get("metallic", 0.0)), 0.0), 1.0)
            self.roughness = clamp_roughness(props.get("roughness", 1.0))
            self.alpha = self.roughness**2
            self.variant = str(props.get("variant", "full"))
            if self.variant not in VARIANTS:
                raise ValueError(f"gltf_metal_roughness: unknown variant {self.variant!r}")
            self.compensation = self.variant != "no-compensation"
            self.fresnel = self.variant != "no-fresnel"
            self.correlated = self.variant != "uncorrelated"
            self.p_spec = float(props.get("p_spec", 0.25 + 0.65 * self.metallic))
            tab = tables(self.roughness, self.correlated, self.fresnel)
            self.tab = tab
            self.loss = mi.Float(tab.loss.astype(np.float32))
            self.spec_loss = mi.Float(tab.spec_loss.astype(np.float32))
            dr.eval(self.loss, self.spec_loss)
            self.loss_avg = tab.loss_avg
            self.spec_loss_avg = tab.spec_loss_avg
            self.fms_metal = [float(x) for x in ms_fresnel(self.base_np, tab.loss_avg)]
            self.fms_04 = float(ms_fresnel(DIELECTRIC_F0, tab.loss_avg))
            self.distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)
            flags = (
                mi.BSDFFlags.GlossyReflection
                | mi.BSDFFlags.FrontSide
                | mi.BSDFFlags.BackSide
            )
            self.m_components = [flags]
            self.m_flags = flags

        # --- the model, in the local frame with wo (viewer) above the surface -------------

        def _lookup(self, table, mu):
            last = TABLE_NODES - 1
            x = dr.cbrt(dr.clip(mu, 0.0, 1.0)) * last
            i = dr.minimum(mi.UInt32(dr.floor(x)), last - 1)
            s = x - mi.Float(i)
            v0 = dr.gather(mi.Float, table, i)
            v1 = dr.gather(mi.Float, table, i + 1)
            return v0 + (v1 - v0) * s

        def _f(self, wo, wi):
            """f (without the cosine) for wo.z > 0, wi.z > 0."""
            a2 = self.alpha * self.alpha
            co, ci = wo.z, wi.z
            hs = wo + wi
            hl2 = dr.squared_norm(hs)
            # 1 - (n.h)^2 from the tangential part of hs: precise for narrow lobes in f32.
            sin2 = (hs.x * hs.x + hs.y * hs.y) / hl2
            cos2 = hs.z * hs.z / hl2
            den = a2 * cos2 + sin2
            d = a2 * inv_pi / (den * den)
            so = dr.sqrt(co * co * (1.0 - a2) + a2)
            si = dr.sqrt(ci * ci * (1.0 - a2) + a2)
            if self.correlated:
                v = 0.5 / (ci * so + co * si)
            else:
                v = 1.0 / ((co + so) * (ci + si))
            dv = d * v
            vh = dr.clip(0.5 * dr.sqrt(hl2), 0.0, 1.0)
            w = (1.0 - vh) ** 5 if self.fresnel else mi.Float(0.0)
            f04 = DIELECTRIC_F0 + (1.0 - DIELECTRIC_F0) * w
            base = mi.Color3f(*[float(b) for b in self.base_np])
            f_metal = base + (1.0 - base) * w
            m = self.metallic
            if not self.compensation:
                dielectric = base * (inv_pi * (1.0 - f04)) + f04 * dv
                metal = f_metal * dv
                return dielectric * (1.0 - m) + metal * m
            ms = (
                inv_pi
                * self._lookup(self.loss, co)
                * self._lookup(self.loss, ci)
                / self.loss_avg
            )
            metal = f_metal * dv + mi.Color3f(*self.fms_metal) * ms
            spec = f04 * dv + self.fms_04 * ms
            diffuse = (
                inv_pi
                * self._lookup(self.spec_loss, co)
                * self._lookup(self.spec_loss, ci)
                / self.spec_loss_avg
            )
            dielectric = base * diffuse + spec
            return dielectric * (1.0 - m) + metal * m

        def _pdf(self, wo, wi):
            """The mixture's density of wi (solid angle), wo.z > 0."""
            hs = wo + wi
            h = dr.normalize(hs)
            vh = dr.dot(wi, h)
            spec = self.distr.pdf(wo, mi.Normal3f(h)) / (4.0 * dr.abs(vh))
            spec = dr.select((vh > 0.0) & dr.isfinite(spec), spec, 0.0)
            return self.p_spec * spec + (1.0 - self.p_spec) * wi.z * inv_pi

        # --- the Mitsuba interface ------------------------------------------------------

        @staticmethod
        def _faced(si_wi, v):
            """v mirrored through the tangent plane where the viewer is below it."""
            flip = si_wi.z < 0.0
            return mi.Vector3f(v.x, v.y, dr.select(flip, -v.z, v.z))

        def eval_pdf(self, ctx, si, wo, active=True):
            view = self._faced(si.wi, si.wi)
            light = self._faced(si.wi, wo)
            ok = active & (view.z > 0.0) & (light.z > 0.0)
            f = self._f(view, light) * light.z
            pdf = self._pdf(view, light)
            return (
                dr.select(ok, f, mi.Color3f(0.0)),
                dr.select(ok, pdf, 0.0),
            )

        def eval(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[1]

        def sample(self, ctx, si, sample1, sample2, active=True):
            view = self._faced(si.wi, si.wi)
            m, _ = self.distr.sample(view, sample2)
            spec_dir = mi.reflect(view, m)
            cos_dir = mi.warp.square_to_cosine_hemisphere(sample2)
            light = dr.select(sample1 < self.p_spec, spec_dir, cos_dir)
            ok = active & (view.z > 0.0) & (light.z > 0.0)
            f = self._f(view, light) * light.z
            pdf = self._pdf(view, light)
            ok &= pdf > 0.0
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = self._faced(si.wi, light)
            bs.pdf = dr.select(ok, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            weight = dr.select(ok, f / pdf, mi.Color3f(0.0))
            return bs, weight

        def eval_pdf_sample(self, ctx, si, wo, sample1, sample2, active=True):
            f, pdf = self.eval_pdf(ctx, si, wo, active)
            bs, weight = self.sample(ctx, si, sample1, sample2, active)
            return f, pdf, bs, weight

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return (
                f"GltfMetalRoughness[base={self.base_np.tolist()}, metallic={self.metallic}, "
                f"roughness={self.roughness}, variant={self.variant}]"
            )

    mi.register_bsdf("gltf_metal_roughness", lambda props: GltfMetalRoughness(props))
    return GltfMetalRoughness


def _selftest():
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(1)
    register(mi, dr)
    rng = np.random.default_rng(5)
    worst = {"furnace": 0.0, "sampler": 0.0, "pdf": 0.0, "reciprocity": 0.0, "faces": 0.0}

    def interaction(mu, n):
        si = dr.zeros(mi.SurfaceInteraction3f, n)
        s = math.sqrt(1.0 - mu * mu)
        si.wi = mi.Vector3f(s, 0.0, mu)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        return si

    ctx = mi.BSDFContext()
    n = 1 << 20
    cases = [
        ([1.0, 1.0, 1.0], 1.0, 0.1),
        ([1.0, 1.0, 1.0], 1.0, 0.45),
        ([1.0, 1.0, 1.0], 1.0, 1.0),
        ([1.0, 1.0, 1.0], 0.0, 0.2),
        ([1.0, 1.0, 1.0], 0.0, 0.7),
        ([0.73, 0.73, 0.73], 0.0, 0.2),
        ([1.0, 0.78, 0.34], 1.0, 0.45),
        ([0.95, 0.95, 0.95], 1.0, 0.0),
    ]
    for base, metallic, rough in cases:
        bsdf = mi.load_dict(
            {
                "type": "gltf_metal_roughness",
                "base_r": base[0],
                "base_g": base[1],
                "base_b": base[2],
                "metallic": metallic,
                "roughness": rough,
            }
        )
        white = base == [1.0, 1.0, 1.0]
        for mu in (0.05, 0.3, 0.7, 1.0):
            si = interaction(mu, n)
            u1 = mi.Float(rng.random(n).astype(np.float32))
            u2 = mi.Point2f(*(rng.random((2, n)).astype(np.float32)))
            bs, w = bsdf.sample(ctx, si, u1, u2)
            by_sampling = np.array(w).reshape(3, -1).mean(1)
            # The sampler's pdf is the density of its draws: E[(cos / pi) / pdf] over the
            # draws above the surface is the cosine density's integral, 1.
            pdf_s = np.array(bs.pdf)
            cos_s = np.abs(np.array(bs.wo.z))
            valid = pdf_s > 0.0
            cos_check = float(np.sum(cos_s[valid] / math.pi / pdf_s[valid]) / n)
            worst["pdf"] = max(worst["pdf"], abs(cos_check - 1.0))
            # Uniform-hemisphere estimates of int f cos and of int pdf (the share of the draws
            # above the surface); they resolve only wide lobes.
            d = mi.warp.square_to_uniform_hemisphere(
                mi.Point2f(*(rng.random((2, n)).astype(np.float32)))
            )
            f, pdf = bsdf.eval_pdf(ctx, si, d)
            uniform = np.array(f).reshape(3, -1).mean(1) * 2.0 * math.pi
            pdf_int = float(np.array(pdf).mean() * 2.0 * math.pi)
            if rough >= 0.45:
                worst["sampler"] = max(
                    worst["sampler"], float(np.max(np.abs(by_sampling / uniform - 1.0)))
                )
                worst["pdf"] = max(worst["pdf"], abs(pdf_int - float(np.mean(valid))))
            if white:
                worst["furnace"] = max(worst["furnace"], float(np.max(np.abs(by_sampling - 1.0))))
            print(
                f"base {base} metallic {metallic} roughness {rough} mu {mu}: albedo sampled "
                f"{np.round(by_sampling, 4).tolist()} uniform {np.round(uniform, 4).tolist()}; "
                f"int pdf {pdf_int:.4f}, draws above {np.mean(valid):.4f}, cos check "
                f"{cos_check:.4f}"
            )
        # Reciprocity and the back face: f(a, b) cos_b / cos_b = f(b, a); mirrored = same.
        m = 4096
        a = rng.normal(size=(m, 3))
        b = rng.normal(size=(m, 3))
        a[:, 2] = np.abs(a[:, 2])
        b[:, 2] = np.abs(b[:, 2])
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        si = dr.zeros(mi.SurfaceInteraction3f, m)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(*a.T.astype(np.float32))
        fab = np.array(bsdf.eval(ctx, si, mi.Vector3f(*b.T.astype(np.float32)))) / b[:, 2]
        si.wi = mi.Vector3f(*b.T.astype(np.float32))
        fba = np.array(bsdf.eval(ctx, si, mi.Vector3f(*a.T.astype(np.float32)))) / a[:, 2]
        si.wi = mi.Vector3f(a[:, 0], a[:, 1], -a[:, 2])
        fback = np.array(bsdf.eval(ctx, si, mi.Vector3f(b[:, 0], b[:, 1], -b[:, 2]))) / b[:, 2]
        big = np.maximum(np.abs(fab), 1e-3)
        worst["reciprocity"] = max(worst["reciprocity"], float(np.max(np.abs(fab - fba) / big)))
        worst["faces"] = max(worst["faces"], float(np.max(np.abs(fab - fback) / big)))
    print("worst:", {k: round(v, 5) for k, v in worst.items()})
    bounds = {"furnace": 0.005, "sampler": 0.01, "pdf": 0.01, "reciprocity": 1e-4, "faces": 1e-6}
    bad = [k for k in bounds if worst[k] > bounds[k]]
    if bad:
        raise SystemExit(f"self-test failed: {bad}")
    print("self-test passed")


if __name__ == "__main__":
    _selftest()
