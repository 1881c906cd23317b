//! The CPU reference renderer as the tests call it.

use restir_world::reference::{ReferenceOptions, ReferenceRenderer, Rendered};
use restir_world::render::Paths;
use restir_world::sampling::Estimator;
use restir_world::scene::{Camera, Scene};

/// The CPU reference's images of `s` seen from `cam`: `spp` samples per pixel of `method`
/// with `seed`, on every core.
pub fn reference(s: &Scene, cam: &Camera, method: Estimator, spp: u32, seed: u32) -> Rendered {
    reference_at(s, cam, method, spp, seed, Paths::default())
}

/// [`reference`] with paths of `paths`.
pub fn reference_at(
    s: &Scene,
    cam: &Camera,
    method: Estimator,
    spp: u32,
    seed: u32,
    paths: Paths,
) -> Rendered {
    let o = ReferenceOptions {
        method,
        spp,
        seed,
        threads: 0,
        paths,
    };
    ReferenceRenderer::new(s)
        .expect("reference")
        .render(cam, &o, None)
        .expect("cpu reference")
}
