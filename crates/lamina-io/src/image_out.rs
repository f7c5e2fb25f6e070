//! Image files written whole or not at all.
//!
//! The encoder is chosen from the file name's extension (case-insensitive) *before* any file
//! is created, the image is encoded in memory, and only a successful encoding is written,
//! atomically ([`crate::atomic`]). So an unsupported type (`.bmp`, `.gif`), a pixel layout
//! the chosen encoder cannot store (16-bit JPEG) or a failed encode is an error naming the
//! file, with no file left behind and an existing file untouched.
//!
//! The types lamina writes: `.png`, `.jpg`/`.jpeg` and `.exr`.

use crate::atomic::{WriteError, write_bytes};
use image::{ExtendedColorType, ImageFormat};
use std::io::Cursor;
use std::path::{Path, PathBuf};

/// An image could not be saved; nothing was written.
#[derive(Debug, thiserror::Error)]
pub enum ImageOutError {
    /// The extension names no type lamina writes.
    #[error("'{path}': cannot write images of this type (use .png, .jpg or .exr)")]
    UnsupportedType {
        /// The file asked for.
        path: PathBuf,
    },
    /// The encoder rejected the image (size, pixel layout).
    #[error("cannot encode '{path}': {source}")]
    Encode {
        /// The file asked for.
        path: PathBuf,
        /// The encoder's error.
        #[source]
        source: image::ImageError,
    },
    /// The encoded bytes could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// The encoder for `path`, from its extension: PNG, JPEG or OpenEXR, or
/// [`ImageOutError::UnsupportedType`]. Call it before any long work to fail early.
pub fn format_for(path: &Path) -> Result<ImageFormat, ImageOutError> {
    let unsupported = || ImageOutError::UnsupportedType {
        path: path.to_owned(),
    };
    let format = path
        .extension()
        .and_then(ImageFormat::from_extension)
        .ok_or_else(unsupported)?;
    match format {
        ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::OpenExr if format.writing_enabled() => {
            Ok(format)
        }
        _ => Err(unsupported()),
    }
}

/// Encodes raw pixels (`color` says their layout, rows top first) in memory with the
/// encoder of `path`'s type.
pub fn encode(
    path: &Path,
    pixels: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<Vec<u8>, ImageOutError> {
    let format = format_for(path)?;
    let mut bytes = Cursor::new(Vec::new());
    image::write_buffer_with_format(&mut bytes, pixels, width, height, color, format).map_err(
        |source| ImageOutError::Encode {
            path: path.to_owned(),
            source,
        },
    )?;
    Ok(bytes.into_inner())
}

/// Saves raw pixels to `path` (type from the extension), atomically; see the module docs.
pub fn save_pixels(
    path: &Path,
    pixels: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<(), ImageOutError> {
    let bytes = encode(path, pixels, width, height, color)?;
    Ok(write_bytes(path, &bytes)?)
}

/// Saves an image buffer (e.g. `RgbImage`, `GrayImage`, a 16-bit grey buffer,
/// `Rgb32FImage`) to `path`, atomically; see the module docs.
pub fn save_image<P>(
    path: &Path,
    image: &image::ImageBuffer<P, Vec<P::Subpixel>>,
) -> Result<(), ImageOutError>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    let format = format_for(path)?;
    let mut bytes = Cursor::new(Vec::new());
    image
        .write_to(&mut bytes, format)
        .map_err(|source| ImageOutError::Encode {
            path: path.to_owned(),
            source,
        })?;
    Ok(write_bytes(path, &bytes.into_inner())?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lamina-io-image-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn unsupported_types_leave_no_file() {
        let d = scratch("types");
        let img = image::RgbImage::new(4, 4);
        for name in ["sheet.bmp", "sheet.tga", "sheet.gif", "sheet", "sheet.tiff"] {
            let p = d.join(name);
            let e = save_image(&p, &img).unwrap_err();
            assert!(
                matches!(e, ImageOutError::UnsupportedType { .. }),
                "{name}: {e}"
            );
            assert!(e.to_string().contains(name), "{e}");
            assert!(!p.exists(), "{name} was created");
        }
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
    }

    #[test]
    fn an_encoder_that_cannot_store_the_layout_leaves_the_old_file() {
        let d = scratch("layout");
        let p = d.join("x.jpg");
        std::fs::write(&p, b"old").unwrap();
        // JPEG has no 16-bit grey.
        let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(4, 4);
        let e = save_image(&p, &img).unwrap_err();
        assert!(matches!(e, ImageOutError::Encode { .. }), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 1);
    }

    #[test]
    fn round_trips_8_16_bit_and_float() {
        let d = scratch("roundtrip");
        let rgb =
            image::RgbImage::from_fn(3, 2, |x, y| image::Rgb([x as u8 * 80, y as u8 * 90, 7]));
        save_image(&d.join("a.PNG"), &rgb).unwrap();
        assert_eq!(image::open(d.join("a.PNG")).unwrap().to_rgb8(), rgb);
        let g16 = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(3, 2, |x, y| {
            image::Luma([(x * 20000 + y * 7) as u16])
        });
        save_image(&d.join("b.png"), &g16).unwrap();
        assert_eq!(image::open(d.join("b.png")).unwrap().to_luma16(), g16);
        let f = image::Rgb32FImage::from_fn(3, 2, |x, y| {
            image::Rgb([x as f32 * 0.25, y as f32 + 0.5, 3.0])
        });
        save_image(&d.join("c.exr"), &f).unwrap();
        assert_eq!(image::open(d.join("c.exr")).unwrap().to_rgb32f(), f);
    }
}
