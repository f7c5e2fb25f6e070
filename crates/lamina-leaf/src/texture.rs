//! Image maps: loading (PNG, JPEG, 16-bit PNG, EXR, HDR) and bilinear lookup.
//!
//! A [`Texture`] stores linear RGBA `f32` texels. Colour maps are decoded from sRGB to
//! linear on load ([`Encoding::Srgb`]); data maps (alpha, thickness, extinction, bump) are
//! taken as stored ([`Encoding::Linear`]). Float formats (EXR, HDR) are always linear.
//! Texture coordinates: `u` to the right, `v` *up*, origin at the bottom-left of the image
//! (the OpenGL / glTF-with-flip convention used by OBJ): `v = 1` is the top row of the file.
//!
//! **Limits**: an image file is checked before it is decoded (from its header): at most
//! [`MAX_IMAGE_SIDE`] pixels a side and [`MAX_IMAGE_PIXELS`] pixels in all, so that neither
//! the decoder (at most [`MAX_IMAGE_DECODED_BYTES`] for the stored pixels × channels × bytes
//! per channel) nor the texture (16 bytes a texel) allocates without bound on a crafted
//! header; a panic inside a decoder becomes [`TextureError::Panicked`].

use glam::{Vec2, Vec3, Vec4};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How the stored values of an 8- or 16-bit image map to linear values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// sRGB transfer curve (colour photographs): decoded to linear on load. Alpha stays linear.
    Srgb,
    /// Values are already linear (data maps).
    Linear,
}

/// What happens to texture coordinates outside `[0, 1]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Wrap {
    /// Tile the image (`u` taken modulo 1).
    #[default]
    Repeat,
    /// Hold the edge texel.
    Clamp,
}

/// Largest width or height (pixels) of an image that [`Texture::load`] and
/// [`open_image`] accept.
pub const MAX_IMAGE_SIDE: u32 = 32768;

/// Largest number of pixels (width × height) of an image that [`Texture::load`] and
/// [`open_image`] accept: 2^26 (8192 x 8192), 1 GiB as a [`Texture`]'s linear RGBA `f32`
/// texels.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 26;

/// Largest size (bytes) of an image's stored pixels (width × height × channels × bytes per
/// channel) that the decoder may allocate: 1 GiB (2^26 pixels of 32-bit float RGBA).
pub const MAX_IMAGE_DECODED_BYTES: u64 = 1 << 30;

/// Checks an image's size against [`MAX_IMAGE_SIDE`], [`MAX_IMAGE_PIXELS`] and
/// [`MAX_IMAGE_DECODED_BYTES`] (`bytes_per_pixel` of the stored format); `Err` says what is
/// too large and the limit.
pub fn check_image_size(width: u32, height: u32, bytes_per_pixel: u64) -> Result<(), String> {
    let pixels = width as u64 * height as u64;
    if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
        return Err(format!(
            "{width}x{height} pixels: a side is longer than the {MAX_IMAGE_SIDE} supported"
        ));
    }
    if pixels > MAX_IMAGE_PIXELS {
        return Err(format!(
            "{width}x{height} = {pixels} pixels: more than the {MAX_IMAGE_PIXELS} (8192 x 8192) supported"
        ));
    }
    let bytes = pixels.saturating_mul(bytes_per_pixel);
    if bytes > MAX_IMAGE_DECODED_BYTES {
        return Err(format!(
            "{width}x{height} pixels of {bytes_per_pixel} bytes = {bytes} bytes decoded: more than the {MAX_IMAGE_DECODED_BYTES} supported"
        ));
    }
    Ok(())
}

/// Why a map could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// The file could not be opened or decoded.
    #[error("cannot read image '{path}': {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        #[source]
        source: image::ImageError,
    },
    /// The image has no pixels.
    #[error("image '{path}' is empty ({width}x{height})")]
    Empty {
        /// The file.
        path: PathBuf,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// The image's header announces more pixels than are supported (checked before
    /// decoding, see [`MAX_IMAGE_PIXELS`]).
    #[error("image '{path}' is too large ({channels} channels): {reason}")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Channels of the stored format.
        channels: u8,
        /// What is too large, and the limit.
        reason: String,
    },
    /// The decoder panicked on the file (a bug in it; the file is rejected).
    #[error("image '{path}' cannot be decoded: {message}")]
    Panicked {
        /// The file.
        path: PathBuf,
        /// The decoder's panic message, in words.
        message: String,
    },
}

/// Opens an image file and decodes it, after checking its size from the header (see
/// [`check_image_size`]). The decoder runs under [`crate::guard::catch_panic`]. Errors name
/// the file.
pub fn open_image(path: &Path) -> Result<image::DynamicImage, TextureError> {
    let path_buf = path.to_owned();
    crate::guard::catch_panic(|| {
        crate::guard::fault_point("open_image");
        let reader = image::ImageReader::open(path).map_err(|e| TextureError::Read {
            path: path.to_owned(),
            source: image::ImageError::IoError(e),
        })?;
        decode_checked(reader, path)
    })
    .unwrap_or_else(|message| {
        Err(TextureError::Panicked {
            path: path_buf,
            message: crate::guard::panic_error_message(&message),
        })
    })
}

/// Decodes an image held in memory (the format guessed from its content), with the checks
/// of [`open_image`]; `name` names it in errors.
pub fn decode_image(bytes: &[u8], name: &Path) -> Result<image::DynamicImage, TextureError> {
    crate::guard::catch_panic(|| {
        decode_checked(image::ImageReader::new(std::io::Cursor::new(bytes)), name)
    })
    .unwrap_or_else(|message| {
        Err(TextureError::Panicked {
            path: name.to_owned(),
            message: crate::guard::panic_error_message(&message),
        })
    })
}

/// Guesses the format, reads the header, checks the size, then decodes.
fn decode_checked<R: std::io::BufRead + std::io::Seek>(
    reader: image::ImageReader<R>,
    path: &Path,
) -> Result<image::DynamicImage, TextureError> {
    use image::ImageDecoder;
    let read_err = |source| TextureError::Read {
        path: path.to_owned(),
        source,
    };
    let mut reader = reader
        .with_guessed_format()
        .map_err(|e| read_err(image::ImageError::IoError(e)))?;
    // The size is checked from the header below; this bounds what a decoder may allocate
    // while it reads the header and the pixels.
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_IMAGE_DECODED_BYTES);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(read_err)?;
    let (width, height) = decoder.dimensions();
    let color = decoder.color_type();
    if width == 0 || height == 0 {
        return Err(TextureError::Empty {
            path: path.to_owned(),
            width,
            height,
        });
    }
    check_image_size(width, height, color.bytes_per_pixel() as u64).map_err(|reason| {
        TextureError::TooLarge {
            path: path.to_owned(),
            channels: color.channel_count(),
            reason,
        }
    })?;
    image::DynamicImage::from_decoder(decoder).map_err(read_err)
}

/// A bilinearly filtered RGBA image of linear values, cheap to clone (shared storage).
#[derive(Clone, Debug)]
pub struct Texture {
    width: u32,
    height: u32,
    /// Row-major, top row first, linear RGBA.
    texels: Arc<[Vec4]>,
    /// Addressing outside `[0, 1]`.
    pub wrap: Wrap,
}

/// sRGB electro-optical transfer function (IEC 61966-2-1), one channel.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Inverse of [`srgb_to_linear`].
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// The texels a bilinear lookup reads and their weights: the addressing of
/// [`Texture::sample`], shared with the packed texel grid of [`crate::LeafMaterial`] so that
/// both filter with exactly the same arithmetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Footprint {
    /// Row-major texel indices: (x0, y0), (x1, y0), (x0, y1), (x1, y1).
    idx: [usize; 4],
    /// Weights of the second column and the second row.
    fx: f32,
    fy: f32,
    /// Read `idx[0]` unfiltered (a 1x1 image, or a non-finite coordinate).
    single: bool,
}

/// `x.floor()` for finite `x`, without a libm call (the baseline x86-64 target has no
/// rounding instruction): exact, since `|x| < 2^23` converts to `i32` exactly and larger
/// floats are integers.
#[inline]
pub(crate) fn floor_finite(x: f32) -> f32 {
    if x.abs() < 8_388_608.0 {
        let t = x as i32 as f32;
        // (An integral `x` is returned as it is, which keeps the sign of `-0.0`.)
        if t > x {
            t - 1.0
        } else if t < x {
            t
        } else {
            x
        }
    } else {
        x
    }
}

impl Footprint {
    /// The footprint of texture coordinates `uv` (`v` up) on a `width x height` image
    /// addressed by `wrap`.
    #[inline]
    pub(crate) fn new(width: u32, height: u32, wrap: Wrap, uv: Vec2) -> Self {
        let single = Footprint {
            idx: [0; 4],
            fx: 0.0,
            fy: 0.0,
            single: true,
        };
        if width == 1 && height == 1 {
            return single;
        }
        let x = uv.x * width as f32 - 0.5;
        let y = (1.0 - uv.y) * height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return single;
        }
        let (x0, y0) = (floor_finite(x), floor_finite(y));
        let (fx, fy) = (x - x0, y - y0);
        // Address the two columns and two rows once.
        let (x0, x1) = neighbours(wrap, x0 as i64, width);
        let (y0, y1) = neighbours(wrap, y0 as i64, height);
        let w = width as usize;
        Footprint {
            idx: [y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1],
            fx,
            fy,
            single: false,
        }
    }

    /// The bilinear filter of the values `at` returns for texel indices.
    #[inline]
    pub(crate) fn filter<T: Lerp>(&self, at: impl Fn(usize) -> T) -> T {
        if self.single {
            return at(self.idx[0]);
        }
        let a = at(self.idx[0]).lerp(at(self.idx[1]), self.fx);
        let b = at(self.idx[2]).lerp(at(self.idx[3]), self.fx);
        a.lerp(b, self.fy)
    }
}

/// [`Texture::gradient`] of the scalar image `at` (texel index to value) of
/// `width x height` texels addressed by `wrap`.
#[inline]
pub(crate) fn gradient(
    width: u32,
    height: u32,
    wrap: Wrap,
    uv: Vec2,
    at: impl Fn(usize) -> f32 + Copy,
) -> Vec2 {
    if width == 1 && height == 1 {
        return Vec2::ZERO;
    }
    let du = 1.0 / width as f32;
    let dv = 1.0 / height as f32;
    let s = |uv: Vec2| Footprint::new(width, height, wrap, uv).filter(at);
    let gu = s(uv + Vec2::new(du, 0.0)) - s(uv - Vec2::new(du, 0.0));
    let gv = s(uv + Vec2::new(0.0, dv)) - s(uv - Vec2::new(0.0, dv));
    Vec2::new(gu / (2.0 * du), gv / (2.0 * dv))
}

/// Linear interpolation `a (1 - s) + b s` (glam's formula), per channel.
pub(crate) trait Lerp: Copy {
    fn lerp(self, b: Self, s: f32) -> Self;
}

impl Lerp for Vec4 {
    #[inline]
    fn lerp(self, b: Self, s: f32) -> Self {
        Vec4::lerp(self, b, s)
    }
}

impl Lerp for f32 {
    #[inline]
    fn lerp(self, b: Self, s: f32) -> Self {
        self * (1.0 - s) + b * s
    }
}

/// Indices `i` and `i + 1` on an axis of `n` texels, addressed by `wrap`.
#[inline]
fn neighbours(wrap: Wrap, i: i64, n: u32) -> (usize, usize) {
    let n = n as i64;
    // (`i < n - 1`, not `i + 1 < n`: a huge texture coordinate saturates `i` to
    // `i64::MAX`, where `i + 1` would wrap around.)
    if i >= 0 && i < n - 1 {
        return (i as usize, i as usize + 1);
    }
    let at = |i: i64| match wrap {
        Wrap::Repeat => i.rem_euclid(n) as usize,
        Wrap::Clamp => i.clamp(0, n - 1) as usize,
    };
    (at(i), at(i.saturating_add(1)))
}

impl Texture {
    /// A texture from linear RGBA texels, row-major with the top row first.
    ///
    /// # Panics
    /// If `texels.len() != width * height` or either size is zero (a programming error,
    /// not bad input: file input goes through [`Texture::load`]).
    pub fn from_texels(width: u32, height: u32, texels: Vec<Vec4>, wrap: Wrap) -> Self {
        assert!(width > 0 && height > 0, "texture must have pixels");
        assert_eq!(texels.len(), (width * height) as usize, "texel count");
        Texture {
            width,
            height,
            texels: texels.into(),
            wrap,
        }
    }

    /// A texture whose texel `(x, y)` (column, row from the top) is `f(x, y)`.
    ///
    /// # Panics
    /// If either size is zero (as [`Texture::from_texels`]).
    pub fn from_fn(
        width: u32,
        height: u32,
        wrap: Wrap,
        mut f: impl FnMut(u32, u32) -> Vec4,
    ) -> Self {
        let texels = (0..width * height)
            .map(|i| f(i % width, i / width))
            .collect();
        Self::from_texels(width, height, texels, wrap)
    }

    /// A 1x1 texture of one value.
    pub fn constant(value: Vec4) -> Self {
        Self::from_texels(1, 1, vec![value], Wrap::Repeat)
    }

    /// Loads an image file. 8/16-bit channels are normalised to `[0, 1]` and, for
    /// [`Encoding::Srgb`], decoded to linear; float images are taken as linear. Grey images
    /// are expanded to RGB; a missing alpha channel reads as 1.
    ///
    /// The size is checked before decoding (see [`check_image_size`]); a panic inside the
    /// decoder is an error. Errors name the file.
    pub fn load(path: &Path, encoding: Encoding) -> Result<Self, TextureError> {
        Self::from_image(open_image(path)?, encoding, path)
    }

    /// [`Texture::load`] for an image file held in memory (PNG, JPEG, EXR, HDR, the format
    /// guessed from the content); `name` names it in errors.
    pub fn decode(bytes: &[u8], encoding: Encoding, name: &Path) -> Result<Self, TextureError> {
        Self::from_image(decode_image(bytes, name)?, encoding, name)
    }

    /// A decoded image as a texture (see [`Texture::load`]).
    fn from_image(
        img: image::DynamicImage,
        encoding: Encoding,
        path: &Path,
    ) -> Result<Self, TextureError> {
        let (width, height) = (img.width(), img.height());
        if width == 0 || height == 0 {
            return Err(TextureError::Empty {
                path: path.to_owned(),
                width,
                height,
            });
        }
        let is_float = matches!(
            img.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        );
        let rgba = img.into_rgba32f();
        let decode = encoding == Encoding::Srgb && !is_float;
        let texels = rgba
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0;
                if decode {
                    Vec4::new(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), a)
                } else {
                    Vec4::new(r, g, b, a)
                }
            })
            .collect::<Vec<_>>();
        Ok(Self::from_texels(width, height, texels, Wrap::Repeat))
    }

    /// Width in texels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The texel at integer coordinates (`y = 0` is the top row), addressed by [`Self::wrap`].
    #[inline]
    pub fn texel(&self, x: i64, y: i64) -> Vec4 {
        let (w, h) = (self.width as i64, self.height as i64);
        let (x, y) = match self.wrap {
            Wrap::Repeat => (x.rem_euclid(w), y.rem_euclid(h)),
            Wrap::Clamp => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
        };
        self.texels[(y * w + x) as usize]
    }

    /// Bilinearly filtered RGBA at texture coordinates `uv` (`v` up, see the module docs).
    #[inline]
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        Footprint::new(self.width, self.height, self.wrap, uv).filter(|i| self.texels[i])
    }

    /// Filtered RGB at `uv`.
    #[inline]
    pub fn rgb(&self, uv: Vec2) -> Vec3 {
        self.sample(uv).truncate()
    }

    /// Filtered first channel at `uv` (the value of a grey data map).
    #[inline]
    pub fn scalar(&self, uv: Vec2) -> f32 {
        self.sample(uv).x
    }

    /// Filtered alpha channel at `uv`.
    #[inline]
    pub fn alpha(&self, uv: Vec2) -> f32 {
        self.sample(uv).w
    }

    /// Gradient `(d/du, d/dv)` of the first channel at `uv` (`v` up), per unit of texture
    /// coordinate, by central differences one texel apart. Zero for a 1x1 texture.
    #[inline]
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        gradient(self.width, self.height, self.wrap, uv, |i| self.texels[i].x)
    }

    /// All texels, row-major, top row first.
    pub fn texels(&self) -> &[Vec4] {
        &self.texels
    }

    /// Whether `other` is this very image (the same shared texels, size and wrap mode): a
    /// clone of it, not merely equal values.
    pub fn is_same_image(&self, other: &Texture) -> bool {
        Arc::ptr_eq(&self.texels, &other.texels)
            && (self.width, self.height, self.wrap) == (other.width, other.height, other.wrap)
    }

    /// Channel `c` (0 red, 1 green, 2 blue, 3 alpha) on its own, with this texture's size
    /// and current wrap mode.
    ///
    /// # Panics
    /// When `c > 3`.
    pub fn channel(&self, c: usize) -> TextureChannel {
        assert!(c < 4, "a texture has channels 0 to 3, not {c}");
        TextureChannel {
            width: self.width,
            height: self.height,
            wrap: self.wrap,
            texels: self.texels.iter().map(|t| t[c]).collect(),
        }
    }
}

/// One channel of a [`Texture`] on its own (its linear values, as the texture holds them):
/// a quarter of the memory, for lookups that read one channel at scattered places (the
/// alpha test of a matte's leaves), filtered with the texture's footprint and arithmetic,
/// so that [`TextureChannel::sample`] is that channel of [`Texture::sample`] bit for bit.
#[derive(Clone, Debug)]
pub struct TextureChannel {
    width: u32,
    height: u32,
    wrap: Wrap,
    texels: Arc<[f32]>,
}

impl TextureChannel {
    /// The channel bilinearly filtered at texture coordinates `uv` (`v` up, see the module
    /// docs): the same value as the channel of [`Texture::sample`] at `uv`.
    #[inline]
    pub fn sample(&self, uv: Vec2) -> f32 {
        Footprint::new(self.width, self.height, self.wrap, uv).filter(|i| self.texels[i])
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A channel on its own filters to that channel of the whole texture, bit for bit:
    /// inside, outside and on the edges of `[0, 1]`, at texel centres, for non-finite
    /// coordinates and 1x1 images, in both wrap modes.
    #[test]
    fn a_channel_samples_as_the_texture_does() {
        for (w, h) in [(1u32, 1u32), (1, 5), (7, 5), (64, 33)] {
            let texels: Vec<Vec4> = (0..w * h)
                .map(|i| {
                    let f = |k: u32| ((i * k + 13) % 97) as f32 / 96.0;
                    Vec4::new(f(37), f(11), f(53), f(29))
                })
                .collect();
            for wrap in [Wrap::Repeat, Wrap::Clamp] {
                let t = Texture::from_texels(w, h, texels.clone(), wrap);
                let chans: Vec<TextureChannel> = (0..4).map(|c| t.channel(c)).collect();
                let mut uvs: Vec<Vec2> = (0..3000)
                    .map(|i| {
                        Vec2::new(
                            i as f32 / 3000.0 * 2.4 - 0.7,
                            ((i * 7919) % 3000) as f32 / 3000.0 * 2.4 - 0.7,
                        )
                    })
                    .collect();
                uvs.extend((0..w).map(|x| Vec2::new((x as f32 + 0.5) / w as f32, 0.5)));
                uvs.extend([
                    Vec2::ZERO,
                    Vec2::ONE,
                    Vec2::new(f32::NAN, 0.5),
                    Vec2::new(0.5, f32::INFINITY),
                    Vec2::new(-1e30, 1e30),
                ]);
                for uv in uvs {
                    let all = t.sample(uv);
                    for (c, ch) in chans.iter().enumerate() {
                        assert_eq!(
                            ch.sample(uv).to_bits(),
                            all[c].to_bits(),
                            "{w}x{h} {wrap:?} channel {c} at {uv}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=100 {
            let c = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5);
        }
        assert!((srgb_to_linear(0.5) - 0.214).abs() < 1e-3);
    }

    #[test]
    fn huge_image_headers_are_rejected_before_decoding() {
        let dir = std::env::temp_dir().join(format!("lamina-texture-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // 16384 x 16384 grey: 256 MiB as stored (within the image crate's own default
        // limit), 4 GiB as a texture.
        let p = dir.join("huge.png");
        std::fs::write(&p, crate::testing::png_header_only(16384, 16384)).unwrap();
        let e = Texture::load(&p, Encoding::Linear).unwrap_err();
        assert!(matches!(e, TextureError::TooLarge { .. }), "{e}");
        let e = e.to_string();
        assert!(e.contains("huge.png") && e.contains("67108864"), "{e}");
        // One side too long.
        let p = dir.join("long.png");
        std::fs::write(&p, crate::testing::png_header_only(40000, 1)).unwrap();
        let e = Texture::load(&p, Encoding::Srgb).unwrap_err().to_string();
        assert!(e.contains("long.png") && e.contains("32768"), "{e}");
        // The same from memory.
        let e = Texture::decode(
            &crate::testing::png_header_only(16384, 8192),
            Encoding::Linear,
            Path::new("m.png"),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("m.png") && e.contains("too large"), "{e}");
    }

    #[test]
    fn a_decoder_panic_is_an_error_naming_the_file() {
        let dir = std::env::temp_dir().join(format!("lamina-texture-p-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("fine.png");
        image::GrayImage::from_pixel(2, 2, image::Luma([128]))
            .save(&p)
            .unwrap();
        assert!(Texture::load(&p, Encoding::Linear).is_ok());
        let e = crate::guard::with_fault("open_image", || Texture::load(&p, Encoding::Linear));
        let e = e.unwrap_err();
        assert!(matches!(e, TextureError::Panicked { .. }), "{e}");
        let e = e.to_string();
        assert!(
            e.contains("fine.png") && e.contains("injected fault"),
            "{e}"
        );
    }

    #[test]
    fn huge_texture_coordinates_do_not_index_out_of_bounds() {
        // A finite but absurd coordinate (an OBJ `vt 1e30 0`) saturates the texel index.
        for wrap in [Wrap::Repeat, Wrap::Clamp] {
            let t = Texture::from_texels(2, 2, vec![Vec4::ONE; 4], wrap);
            for uv in [
                Vec2::new(1e30, 0.5),
                Vec2::new(-1e30, 0.5),
                Vec2::new(0.5, 1e30),
                Vec2::new(f32::MAX, f32::MIN),
            ] {
                assert_eq!(t.sample(uv), Vec4::ONE, "{uv:?} {wrap:?}");
                assert!(t.gradient(uv).is_finite());
            }
        }
    }

    #[test]
    fn bilinear_and_wrap() {
        let t = Texture::from_texels(2, 1, vec![Vec4::splat(0.0), Vec4::splat(1.0)], Wrap::Clamp);
        // Texel centres sit at u = 0.25 and 0.75.
        assert!((t.scalar(Vec2::new(0.25, 0.5)) - 0.0).abs() < 1e-6);
        assert!((t.scalar(Vec2::new(0.75, 0.5)) - 1.0).abs() < 1e-6);
        assert!((t.scalar(Vec2::new(0.5, 0.5)) - 0.5).abs() < 1e-6);
        assert!((t.scalar(Vec2::new(2.0, 0.5)) - 1.0).abs() < 1e-6);
        let mut r = t.clone();
        r.wrap = Wrap::Repeat;
        // Halfway between the last texel and the wrapped first one.
        assert!((r.scalar(Vec2::new(1.0, 0.5)) - 0.5).abs() < 1e-6);
    }
}
