//! Image files written whole or not at all.
//!
//! The encoder is chosen from the file name's extension (case-insensitive) *before* any file
//! is created, the image is encoded in memory, and only a successful encoding is written,
//! atomically ([`crate::atomic`]). So an unsupported type (`.bmp`, `.gif`), a pixel layout
//! the chosen encoder cannot store (16-bit JPEG) or a failed encode is an error naming the
//! file, with no file left behind and an existing file untouched.
//!
//! The types lamina writes: `.png`, `.jpg`/`.jpeg` and `.exr`, each with lamina's mark
//! ([`crate::owned`]), so a later run knows it may replace the file.

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
/// encoder of `path`'s type, with lamina's mark ([`crate::owned`]): PNG and JPEG through
/// the `image` encoders, OpenEXR (32-bit float RGB or RGBA) through `exr` so that the
/// header can carry its `software` attribute.
pub fn encode(
    path: &Path,
    pixels: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<Vec<u8>, ImageOutError> {
    let format = format_for(path)?;
    let encode_error = |source| ImageOutError::Encode {
        path: path.to_owned(),
        source,
    };
    if format == ImageFormat::OpenExr {
        return encode_exr(pixels, width, height, color).map_err(encode_error);
    }
    let mut bytes = Cursor::new(Vec::new());
    image::write_buffer_with_format(&mut bytes, pixels, width, height, color, format)
        .map_err(encode_error)?;
    Ok(crate::owned::mark_encoded(bytes.into_inner()))
}

/// OpenEXR bytes of float RGB(A) pixels, lossless (RLE in 64x64 tiles, written in
/// increasing order so the bytes depend on the pixels only), with `software` = [`crate::owned::GENERATOR`].
fn encode_exr(
    pixels: &[u8],
    width: u32,
    height: u32,
    color: ExtendedColorType,
) -> Result<Vec<u8>, image::ImageError> {
    use exr::prelude::{
        Encoding, Image, Layer, LayerAttributes, LineOrder, SpecificChannels, Vec2, WritableImage,
    };
    // Blocks in increasing order: the encoder compresses them in parallel, and with an
    // unspecified order it writes them as they finish, so the same image would give
    // different bytes from run to run.
    let encoding = Encoding {
        line_order: LineOrder::Increasing,
        ..Encoding::FAST_LOSSLESS
    };
    let channels = match color {
        ExtendedColorType::Rgb32F => 3,
        ExtendedColorType::Rgba32F => 4,
        other => {
            return Err(image::ImageError::Unsupported(
                image::error::UnsupportedError::from_format_and_kind(
                    ImageFormat::OpenExr.into(),
                    image::error::UnsupportedErrorKind::Color(other),
                ),
            ));
        }
    };
    let (w, h) = (width as usize, height as usize);
    if pixels.len() != w * h * channels * 4 {
        return Err(image::ImageError::Parameter(
            image::error::ParameterError::from_kind(
                image::error::ParameterErrorKind::DimensionMismatch,
            ),
        ));
    }
    let sample = |Vec2(x, y): Vec2<usize>, c: usize| {
        let at = ((y * w + x) * channels + c) * 4;
        f32::from_ne_bytes(pixels[at..at + 4].try_into().expect("4 bytes"))
    };
    let attributes = LayerAttributes {
        software_name: Some(crate::owned::GENERATOR.into()),
        ..LayerAttributes::default()
    };
    let to_image_error = |e: exr::error::Error| {
        image::ImageError::Encoding(image::error::EncodingError::new(
            ImageFormat::OpenExr.into(),
            e,
        ))
    };
    let mut bytes = Cursor::new(Vec::new());
    if channels == 3 {
        let rgb =
            SpecificChannels::rgb(|p: Vec2<usize>| (sample(p, 0), sample(p, 1), sample(p, 2)));
        Image::from_layer(Layer::new((w, h), attributes, encoding, rgb))
            .write()
            .to_buffered(&mut bytes)
            .map_err(to_image_error)?;
    } else {
        let rgba = SpecificChannels::rgba(|p: Vec2<usize>| {
            (sample(p, 0), sample(p, 1), sample(p, 2), sample(p, 3))
        });
        Image::from_layer(Layer::new(
            (w, h),
            attributes,
            Encoding::FAST_LOSSLESS,
            rgba,
        ))
        .write()
        .to_buffered(&mut bytes)
        .map_err(to_image_error)?;
    }
    Ok(bytes.into_inner())
}

/// Where a named-channel EXR's pixels sit and what its header carries besides lamina's mark
/// (the default: the whole image at the origin, no other attribute).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExrLayout {
    /// The data window's top-left corner in the display window (a crop's position).
    pub position: (i32, i32),
    /// The display window's size (the whole image a crop belongs to); `None`: the data
    /// window's size.
    pub display: Option<(u32, u32)>,
    /// Text attributes of the header, `(name, value)`; values are Latin-1 text.
    pub attributes: Vec<(String, String)>,
}

/// OpenEXR bytes of float channels with names (spectral bands, render parts): channel `k` is
/// `channels[k].1`, `width * height` samples, rows top first, placed and annotated by
/// `layout`. Lossless, deterministic bytes, lamina's mark in `software`. Errors: a channel
/// or attribute name or value an EXR header cannot hold, or the encoder's error.
pub fn encode_named_channels(
    width: u32,
    height: u32,
    channels: &[(String, Vec<f32>)],
    layout: &ExrLayout,
) -> Result<Vec<u8>, String> {
    use exr::prelude::{
        AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Image, IntegerBounds,
        Layer, LayerAttributes, LineOrder, Text, Vec2, WritableImage,
    };
    let n = width as usize * height as usize;
    if channels.is_empty() || channels.iter().any(|c| c.1.len() != n) {
        return Err(format!(
            "every channel must have {width} x {height} samples, and there must be one"
        ));
    }
    let text = |s: &str| {
        Text::new_or_none(s)
            .ok_or_else(|| format!("'{s}' has characters an EXR header cannot hold"))
    };
    let list = channels
        .iter()
        .map(|(name, v)| Ok(AnyChannel::new(text(name)?, FlatSamples::F32(v.clone()))))
        .collect::<Result<Vec<AnyChannel<FlatSamples>>, String>>()?;
    let encoding = Encoding {
        line_order: LineOrder::Increasing,
        ..Encoding::FAST_LOSSLESS
    };
    let mut attributes = LayerAttributes {
        software_name: Some(crate::owned::GENERATOR.into()),
        ..LayerAttributes::default()
    };
    attributes.layer_position = Vec2(layout.position.0, layout.position.1);
    for (name, value) in &layout.attributes {
        attributes
            .other
            .insert(text(name)?, AttributeValue::Text(text(value)?));
    }
    let layer = Layer::new(
        (width as usize, height as usize),
        attributes,
        encoding,
        AnyChannels::sort(list.into()),
    );
    let mut image = Image::from_layer(layer);
    if let Some((w, h)) = layout.display {
        image.attributes.display_window =
            IntegerBounds::new(Vec2(0, 0), Vec2(w as usize, h as usize));
    }
    let mut bytes = Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| e.to_string())?;
    Ok(bytes.into_inner())
}

/// Saves float channels with names (e.g. spectral bands) as one OpenEXR image
/// ([`encode_named_channels`] with the default layout), written atomically.
pub fn save_named_channels(
    path: &Path,
    width: u32,
    height: u32,
    channels: &[(String, Vec<f32>)],
) -> Result<(), ImageOutError> {
    let bytes =
        encode_named_channels(width, height, channels, &ExrLayout::default()).map_err(|why| {
            ImageOutError::Encode {
                path: path.to_owned(),
                source: image::ImageError::Encoding(image::error::EncodingError::new(
                    ImageFormat::OpenExr.into(),
                    why,
                )),
            }
        })?;
    Ok(write_bytes(path, &bytes)?)
}

/// Saves raw pixels to `path` (type from the extension), atomically, with lamina's mark;
/// see the module docs.
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
/// `Rgb32FImage`) to `path`, atomically, with lamina's mark; see the module docs.
pub fn save_image<P>(
    path: &Path,
    image: &image::ImageBuffer<P, Vec<P::Subpixel>>,
) -> Result<(), ImageOutError>
where
    P: image::PixelWithColorType,
    [P::Subpixel]: image::EncodableLayout,
{
    use image::EncodableLayout;
    save_pixels(
        path,
        image.as_raw().as_bytes(),
        image.width(),
        image.height(),
        P::COLOR_TYPE,
    )
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
    fn the_same_image_gives_the_same_bytes() {
        // Large enough for many tiles compressed in parallel.
        let f = image::Rgb32FImage::from_fn(700, 500, |x, y| {
            image::Rgb([(x * y % 97) as f32 * 0.01, (x % 13) as f32, y as f32 * 1e-3])
        });
        let bytes = |_| {
            encode(
                Path::new("a.exr"),
                bytemuck_bytes(&f),
                700,
                500,
                ExtendedColorType::Rgb32F,
            )
            .unwrap()
        };
        let first = bytes(0);
        for i in 1..4 {
            assert!(bytes(i) == first, "run {i} gave other bytes");
        }
    }

    fn bytemuck_bytes(f: &image::Rgb32FImage) -> &[u8] {
        use image::EncodableLayout;
        f.as_raw().as_bytes()
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
        let fa = image::Rgba32FImage::from_fn(3, 2, |x, y| {
            image::Rgba([x as f32 * 0.25, y as f32 + 0.5, 3.0, 0.5])
        });
        save_image(&d.join("d.exr"), &fa).unwrap();
        assert_eq!(image::open(d.join("d.exr")).unwrap().to_rgba32f(), fa);
        // Every one carries the mark; the EXR's is the header's `software` attribute, as
        // another EXR reader sees it.
        for name in ["a.PNG", "b.png", "c.exr", "d.exr"] {
            assert_eq!(
                crate::owned::file_state(&d.join(name)).unwrap(),
                crate::owned::FileState::Ours,
                "{name}"
            );
        }
        let meta = exr::meta::MetaData::read_from_file(d.join("c.exr"), false).unwrap();
        assert_eq!(
            meta.headers[0].own_attributes.software_name,
            Some(crate::owned::GENERATOR.into())
        );
        let jpg = d.join("e.jpg");
        save_image(&jpg, &rgb).unwrap();
        assert_eq!(image::open(&jpg).unwrap().to_rgb8().dimensions(), (3, 2));
        assert_eq!(
            crate::owned::file_state(&jpg).unwrap(),
            crate::owned::FileState::Ours
        );
    }
}
