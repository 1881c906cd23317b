//! The one image set every renderer returns: the direct and indirect images of a run, linear
//! HDR RGB, row-major, and their sum (`combined`).

use crate::image_io::Image;
use crate::reference::Rendered;

/// Images read back from a method, linear HDR RGB, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameImages {
    pub width: u32,
    pub height: u32,
    /// Frames averaged.
    pub frames: u32,
    pub direct: Vec<[f32; 3]>,
    pub indirect: Vec<[f32; 3]>,
}

impl FrameImages {
    /// direct + indirect.
    pub fn combined(&self) -> Vec<[f32; 3]> {
        self.direct
            .iter()
            .zip(&self.indirect)
            .map(|(a, b)| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            .collect()
    }

    /// As the three images the CPU reference returns.
    pub fn into_rendered(self) -> Result<Rendered, crate::image_io::ImageIoError> {
        let (w, h) = (self.width, self.height);
        let combined = self.combined();
        Ok(Rendered {
            direct: Image::from_pixels(w, h, self.direct)?,
            indirect: Image::from_pixels(w, h, self.indirect)?,
            combined: Image::from_pixels(w, h, combined)?,
        })
    }
}

/// Which images a method's `read` returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Readback {
    /// The mean of the frames accumulated since creation or the last restart.
    Accumulated,
    /// The last frame alone.
    LastFrame,
}
