//! Planted defects: the one test hook in shipped code, compiled out of it.
//!
//! A statistical test's negative control runs an estimator with a known defect and checks that
//! the test's own check fails on it. The defect is chosen per method build
//! ([`RenderOptions::planted`](crate::render::RenderOptions), which exists only with the
//! crate's feature `planted-defects`: the workspace's test harness enables it, nothing a user
//! types reaches it) and reaches that build's kernels twice: its kernels are specialized with
//! the override `RENDER_PLANTED` (WGSL; false in every kernel built without a defect, so the
//! driver folds every planted branch and scale away and shipped kernels carry none of them),
//! and the render parameters' uniform names the defect (`render_params.planted`, the defect's
//! id, and the two power-check scales), which the kernels compare with the `PLANTED_*` ids
//! ([`Planted::wgsl`]) through `render_planted`. A control's kernels are compiled apart, once
//! per process for each kernel set (the kernel cache's key holds the override; Mesa's shader
//! cache keeps them between runs); all controls share them.
//!
//! Two kinds:
//! - defects of an estimator ([`Planted::is_defect`]): a wrong Jacobian, a merge that drops
//!   the neighbours' M, Russian roulette without its division, an overstated light pdf, a path
//!   one bounce short, cache updates without their tail, sub-path reuse one bounce too deep or without its
//!   escaped candidates, the reuse's forward ray untested, a glossy BRDF losing energy, the
//!   reuse taking glossy vertices as diffuse ones, and one of tunable size (light samples' MIS
//!   weights scaled by a few percent: a control near a check's bound).
//!   These are the controls of the bias tests: each must fail the check its test makes.
//! - power checks ([`Planted::Scale`]): the finished frames scaled as they are accumulated.
//!   They show only that a bound can see a shift of that size, never that a check catches a
//!   defect, and are named so where used.

/// A defect planted in every kernel of one method build (tests' negative controls only).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Planted {
    /// No defect: the shipped estimator.
    #[default]
    None,
    /// Power check, not a defect of an estimator: the direct and indirect frames scaled to
    /// these percentages as they are accumulated.
    Scale { direct: u32, indirect: u32 },
    /// ReSTIR GI's reconnection Jacobian without its distance ratio |x1_q - x2|^2 /
    /// |x1_r - x2|^2 (the cosine ratio kept).
    JacobianWithoutDistance,
    /// Every reuse pass (world-restir, ReSTIR DI, ReSTIR GI) merges each neighbour's reservoir
    /// without its M (as if it held one sample) while the total confidence still counts it:
    /// pairwise MIS shares no longer sum to one. (1/M and 1/Z renormalise by what they merged,
    /// so for them it is a reweighting, not a defect.)
    MergeWithoutM,
    /// Russian roulette keeps a surviving path's throughput without dividing it by the
    /// survival probability.
    RouletteWithoutDivision,
    /// Every light sample's pdf overstated by 10% (the light table's density, as NEE, RIS
    /// candidates and the light tiles read it); MIS weights still use the true density, so
    /// they no longer sum to one.
    LightPdfOverstated,
    /// The path loop (bounces 2..) stops one bounce short of `--bounces`, MIS's last
    /// emission-hit ray included; at one bounce without MIS there is no loop to shorten.
    MissingBounce,
    /// The light side's density in the MIS from the resampled density (world-restir's
    /// vertices, WGSL `render_light_mis_at`) doubled, the ray side's not: the two weights no
    /// longer sum to one.
    LightMisDoubled,
    /// The radiance cache's update paths lose their tail (the radiance beyond their last
    /// vertex taken as 0): the cells learn only the light of `update-depth` vertices.
    CacheUpdateWithoutTail,
    /// The denoiser's temporal blend keeps only 90% of the history's weight (the weights of
    /// history and new frame no longer sum to one).
    DenoiseHistoryWeight,
    /// The denoiser takes last frame's pixels as history whatever surface they saw (no
    /// disocclusion test).
    DenoiseNoDisocclusion,
    /// The denoiser's a-trous filter without its luminance edge-stopping weight.
    DenoiseNoLuminanceStop,
    /// world-restir-gi's sub-path reuse takes the other paths' samples at their full depth
    /// (the radiance leaving their x2 along all of their bounces) instead of one vertex short:
    /// a reconnected path is one bounce deeper than `--bounces`.
    SubpathFullDepth,
    /// world-restir-gi's sub-path reuse leaves out the candidates whose GI ray escaped (they
    /// hold no sample) while it weighs the others as if every candidate had been drawn: the
    /// kept ones' weights are too large by the share that escaped.
    SubpathSkipsEscaped,
    /// ReSTIR GI's forward ray (the receiver's x1 to a neighbour's x2) is never traced: with
    /// `visibility=on` the neighbours' samples enter the receiver's target untested, with
    /// `selected` (the default) the sample a merge selects is left untested; either way an
    /// occluded neighbour's sample lights the receiver.
    ForwardUntested,
    /// Every glossy surface's BRDF (render_brdf, so its light samples and its path steps'
    /// weights alike) loses 1% of its energy: an energy compensation 99% accurate, the bound
    /// the BRDF's own furnace test allows.
    GlossyEnergyLoss,
    /// The reuse stages take glossy vertices as diffuse ones (render_reuses true everywhere):
    /// no hand-off to the path, so their targets, shifts and shading read a glossy vertex as
    /// albedo / pi and its radiance as the same in every direction.
    ReuseTakesGlossy,
    /// Tunable: the MIS weight of every light sample of an area or environment light
    /// (render_light_mis_at: NEE, RIS and every reused reservoir's shading) scaled to `percent`,
    /// the emission hits' weights kept: the two no longer sum to one, and the light the light
    /// side carries is off by `percent` - 100.
    LightMisScaled { percent: u32 },
}

impl Planted {
    /// The WGSL id of the defect (`render_params.planted`; 0: none, and the power checks).
    pub fn id(self) -> u32 {
        match self {
            Self::None | Self::Scale { .. } => 0,
            Self::JacobianWithoutDistance => 1,
            Self::MergeWithoutM => 2,
            Self::RouletteWithoutDivision => 3,
            Self::LightPdfOverstated => 4,
            Self::MissingBounce => 5,
            Self::CacheUpdateWithoutTail => 6,
            Self::LightMisDoubled => 7,
            Self::DenoiseHistoryWeight => 8,
            Self::DenoiseNoDisocclusion => 9,
            Self::DenoiseNoLuminanceStop => 10,
            Self::SubpathFullDepth => 11,
            Self::SubpathSkipsEscaped => 12,
            Self::ForwardUntested => 13,
            Self::GlossyEnergyLoss => 14,
            Self::ReuseTakesGlossy => 15,
            Self::LightMisScaled { .. } => 16,
        }
    }

    /// Whether it is a defect of an estimator (not a power check, not none).
    pub fn is_defect(self) -> bool {
        self.id() != 0
    }

    /// The scales of the (direct, indirect) frames as they are accumulated.
    pub fn scales(self) -> (f32, f32) {
        match self {
            Self::Scale { direct, indirect } => (direct as f32 / 100.0, indirect as f32 / 100.0),
            _ => (1.0, 1.0),
        }
    }

    /// The size of a tunable defect (`render_params.planted_amount`): the factor of
    /// [`Planted::LightMisScaled`], 1 otherwise.
    pub fn amount(self) -> f32 {
        match self {
            Self::LightMisScaled { percent } => percent as f32 / 100.0,
            _ => 1.0,
        }
    }

    /// No defect, in the kernels the controls use (the planted hooks compiled in, frames
    /// scaled by 100%): the shipped estimator's arithmetic, as no planted branch is taken, so
    /// that a check and its controls share one compile (minutes per kernel set on lavapipe).
    pub fn none_compiled_in() -> Self {
        Self::Scale {
            direct: 100,
            indirect: 100,
        }
    }

    /// Power check: the direct frames scaled to `percent`.
    pub fn direct_scaled(percent: u32) -> Self {
        Self::Scale {
            direct: percent,
            indirect: 100,
        }
    }

    /// Power check: the indirect frames scaled to `percent`.
    pub fn indirect_scaled(percent: u32) -> Self {
        Self::Scale {
            direct: 100,
            indirect: percent,
        }
    }

    /// The WGSL constants every kernel composes: the `PLANTED_*` ids the kernels compare
    /// `render_params.planted` with.
    pub fn wgsl() -> String {
        let ids = [
            ("JACOBIAN_WITHOUT_DISTANCE", Self::JacobianWithoutDistance),
            ("MERGE_WITHOUT_M", Self::MergeWithoutM),
            ("ROULETTE_WITHOUT_DIVISION", Self::RouletteWithoutDivision),
            ("LIGHT_PDF_OVERSTATED", Self::LightPdfOverstated),
            ("MISSING_BOUNCE", Self::MissingBounce),
            ("CACHE_UPDATE_WITHOUT_TAIL", Self::CacheUpdateWithoutTail),
            ("LIGHT_MIS_DOUBLED", Self::LightMisDoubled),
            ("DENOISE_HISTORY_WEIGHT", Self::DenoiseHistoryWeight),
            ("DENOISE_NO_DISOCCLUSION", Self::DenoiseNoDisocclusion),
            ("DENOISE_NO_LUMINANCE_STOP", Self::DenoiseNoLuminanceStop),
            ("SUBPATH_FULL_DEPTH", Self::SubpathFullDepth),
            ("SUBPATH_SKIPS_ESCAPED", Self::SubpathSkipsEscaped),
            ("FORWARD_UNTESTED", Self::ForwardUntested),
            ("GLOSSY_ENERGY_LOSS", Self::GlossyEnergyLoss),
            ("REUSE_TAKES_GLOSSY", Self::ReuseTakesGlossy),
            ("LIGHT_MIS_SCALED", Self::LightMisScaled { percent: 100 }),
        ];
        let mut s = String::from(
            "// Planted defects (restir_world::plant), compared with render_params.planted.\n",
        );
        for (name, p) in ids {
            s += &format!("const PLANTED_{name}: u32 = {}u;\n", p.id());
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::Planted;

    #[test]
    fn ids_are_distinct_and_none_is_zero() {
        let all = [
            Planted::JacobianWithoutDistance,
            Planted::MergeWithoutM,
            Planted::RouletteWithoutDivision,
            Planted::LightPdfOverstated,
            Planted::MissingBounce,
            Planted::CacheUpdateWithoutTail,
            Planted::LightMisDoubled,
            Planted::DenoiseHistoryWeight,
            Planted::DenoiseNoDisocclusion,
            Planted::DenoiseNoLuminanceStop,
            Planted::SubpathFullDepth,
            Planted::SubpathSkipsEscaped,
            Planted::ForwardUntested,
            Planted::GlossyEnergyLoss,
            Planted::ReuseTakesGlossy,
            Planted::LightMisScaled { percent: 104 },
        ];
        let mut ids: Vec<u32> = all.iter().map(|p| p.id()).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), all.len());
        assert!(all.iter().all(|p| p.is_defect()));
        assert!(!Planted::None.is_defect() && !Planted::indirect_scaled(96).is_defect());
        assert_eq!(Planted::None.scales(), (1.0, 1.0));
        assert_eq!(Planted::indirect_scaled(96).scales(), (1.0, 0.96));
        assert_eq!(Planted::LightMisScaled { percent: 104 }.amount(), 1.04);
        assert_eq!(Planted::MergeWithoutM.amount(), 1.0);
        assert!(Planted::wgsl().contains("const PLANTED_MERGE_WITHOUT_M: u32 = 2u;"));
    }
}
