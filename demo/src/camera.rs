//! The one camera-motion vocabulary of the CLI: `render --animation` and `compare --camera`.

use restir_world::scene::CameraPath;
use serde::Serialize;

/// How the camera moves over a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Motion {
    /// The scene's camera, every frame.
    Static,
    /// Orbits the target about the up axis.
    Orbit,
    /// Moves towards the target.
    Dolly,
}

/// The largest fraction of the eye-target distance `compare`'s dolly covers in one run, so that
/// long runs never reach the target.
pub const MAX_DOLLY_FRACTION: f32 = 0.5;

impl Motion {
    /// The path over `frames` frames (then it repeats): an orbit of `degrees`, or a dolly over
    /// `fraction` of the eye-target distance.
    pub fn path(self, frames: u32, degrees: f32, fraction: f32) -> CameraPath {
        match self {
            Motion::Static => CameraPath::Static,
            Motion::Orbit => CameraPath::Orbit { frames, degrees },
            Motion::Dolly => CameraPath::Dolly { frames, fraction },
        }
    }

    /// `compare`'s pace over a run of `frames`: 1 degree, or 1% of the distance (at most
    /// [`MAX_DOLLY_FRACTION`] in all), per frame.
    pub fn per_frame(self, frames: u32) -> CameraPath {
        let frames = frames.max(1);
        let fraction = (0.01 * frames as f32).min(MAX_DOLLY_FRACTION);
        self.path(frames, frames as f32, fraction)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use restir_world::scene::Camera;

    /// A dolly over 150 frames used to reach the target at frame 100 ("eye and target
    /// coincide"); every frame's camera of a long run is now valid.
    #[test]
    fn long_dolly_never_reaches_the_target() {
        let base = Camera {
            eye: glam::Vec3::new(0.0, 1.0, 5.0),
            target: glam::Vec3::new(0.0, 1.0, 0.0),
            up: glam::Vec3::Y,
            vfov_deg: 40.0,
            width: 8,
            height: 8,
        };
        for frames in [1, 100, 150, 10_000] {
            for f in [0, frames / 2, frames - 1] {
                let c = Motion::Dolly.per_frame(frames).camera(&base, f);
                c.validate()
                    .unwrap_or_else(|e| panic!("{frames} frames, frame {f}: {e}"));
                assert!((c.eye - c.target).length() >= 0.5 * 5.0 - 1e-4);
            }
        }
    }
}
