//! Image output: EXR (linear float RGB, the ground truth) and PNG (8-bit sRGB for display).
//!
//! The writer and the tone maps live in lamina-image (shared with the GPU renderer, see
//! [`lamina_image::output`] for the exact curves); this module keeps them under their
//! lamina-render names and reports failures as [`RenderError`] with the same messages.

use crate::error::RenderError;
use crate::render::Image;
use lamina_core::Film;
use std::path::Path;

pub use lamina_image::output::{to_srgb8, tonemap};

/// Writes `image` to `path`: `.exr` (linear float) or `.png` (sRGB, exposure and tone map
/// of `film`), by extension, case-insensitive, atomically ([`lamina_image::write_image`]).
/// Errors name the file and the step that failed.
pub fn write_image(path: &Path, image: &Image, film: &Film) -> Result<(), RenderError> {
    Ok(lamina_image::write_image(path, image, film)?)
}
