//! Image output: EXR (linear float RGB, the ground truth) and PNG (8-bit sRGB for display).
//!
//! * **EXR**: the linear Rec.709 radiance exactly as rendered, 32-bit float RGB, no exposure,
//!   no tone map.
//! * **PNG**: per channel, `x = radiance · 2^exposure`, then the film's tone map:
//!   - `Clamp`: `min(max(x, 0), 1)`;
//!   - `Aces`: Narkowicz's (2015) fit of the ACES filmic curve
//!     `x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14)`, clamped to `[0, 1]`;
//!   - `Reinhard`: `x / (1 + x)`;
//!
//!   then the sRGB transfer curve (IEC 61966-2-1) and rounding to 8 bits. NaNs become 0.
//!
//! Both carry lamina's mark (PNG `tEXt Software`, EXR `software`; see `lamina_io::owned`),
//! are encoded in memory and then written atomically by [`lamina_io::write_bytes`]
//! (a temporary file in the target's folder, synced, renamed over the target): on any
//! failure no output file appears and an existing one is untouched.

use crate::Image;
use crate::error::ImageWriteError;
use lamina_core::{Film, ToneMap};
use lamina_leaf::texture::linear_to_srgb;
use std::path::Path;

/// Tone-maps one linear channel value already multiplied by the exposure, to `[0, 1]`
/// (before the sRGB curve).
#[inline]
pub fn tonemap(x: f32, op: ToneMap) -> f32 {
    if !x.is_finite() {
        return if x == f32::INFINITY { 1.0 } else { 0.0 };
    }
    let x = x.max(0.0);
    match op {
        ToneMap::Clamp => x.min(1.0),
        ToneMap::Aces => ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0),
        ToneMap::Reinhard => x / (1.0 + x),
    }
}

/// The 8-bit sRGB PNG bytes (RGB, row-major) of `image` under `film`'s exposure and tone map.
pub fn to_srgb8(image: &Image, film: &Film) -> Vec<u8> {
    let scale = if film.exposure.is_finite() {
        2f32.powf(film.exposure)
    } else {
        1.0
    };
    image
        .pixels
        .iter()
        .flat_map(|p| p.to_array())
        .map(|c| {
            (linear_to_srgb(tonemap(c * scale, film.tonemap)) * 255.0 + 0.5).clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// Writes `image` to `path`: `.exr` (linear float) or `.png` (sRGB, exposure and tone map
/// of `film`), by extension, case-insensitive. Atomic (see the module docs). Errors name
/// the file and the step that failed.
pub fn write_image(path: &Path, image: &Image, film: &Film) -> Result<(), ImageWriteError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let format = match ext.as_str() {
        "exr" => image::ImageFormat::OpenExr,
        "png" => image::ImageFormat::Png,
        _ => {
            return Err(ImageWriteError::UnsupportedFormat {
                path: path.to_owned(),
            });
        }
    };
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 || image.pixels.len() != w as usize * h as usize {
        return Err(ImageWriteError::BadImage {
            path: path.to_owned(),
            len: image.pixels.len(),
            width: w,
            height: h,
        });
    }
    // Encode in memory first (with lamina's mark, so a later render may replace the file):
    // a failed encode must leave no file behind.
    let (pixels, color) = match format {
        image::ImageFormat::OpenExr => (
            image
                .pixels
                .iter()
                .flat_map(|p| p.to_array())
                .flat_map(f32::to_ne_bytes)
                .collect(),
            image::ExtendedColorType::Rgb32F,
        ),
        _ => (to_srgb8(image, film), image::ExtendedColorType::Rgb8),
    };
    let bytes = lamina_io::image_out::encode(path, &pixels, w, h, color).map_err(|e| match e {
        lamina_io::ImageOutError::Encode { source, .. } => ImageWriteError::Encode {
            path: path.to_owned(),
            source,
        },
        _ => ImageWriteError::UnsupportedFormat {
            path: path.to_owned(),
        },
    })?;
    lamina_io::write_bytes(path, &bytes).map_err(|e| ImageWriteError::Io {
        path: path.to_owned(),
        what: e.what,
        source: e.source,
    })
}
