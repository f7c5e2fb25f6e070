//! The image lamina's renderers produce, and its writer.
//!
//! [`Image`] holds linear Rec.709 RGB radiance (W m⁻² sr⁻¹) before exposure and tone
//! mapping; the offline ray tracer (lamina-render) and the real-time rasteriser
//! (lamina-gpu) both return one. [`write_image`] stores it as EXR (linear float, the
//! ground truth) or PNG (8-bit sRGB after the film's exposure and tone map), atomically and
//! with lamina's mark.
//!
//! It lives in its own crate so that the two renderers share it without depending on each
//! other.
//!
//! * [`output`]: tone maps, sRGB encoding and the EXR / PNG writer.
//! * [`error`](mod@error): why a write failed.
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod error;
pub mod output;

pub use error::ImageWriteError;
pub use output::{to_srgb8, tonemap, write_image};

use glam::Vec3;

/// An image of linear Rec.709 RGB radiance (W m⁻² sr⁻¹), before exposure and tone mapping.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixels, top row first, `width * height` of them.
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// Mean linear RGB radiance over all pixels (zero for an empty image).
    pub fn mean(&self) -> Vec3 {
        if self.pixels.is_empty() {
            return Vec3::ZERO;
        }
        self.pixels.iter().copied().sum::<Vec3>() / self.pixels.len() as f32
    }

    /// The pixel at column `x`, row `y` (0 = top).
    pub fn at(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }
}
