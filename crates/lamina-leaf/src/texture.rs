//! Image maps: loading (PNG, JPEG, 16-bit PNG, EXR, HDR) and bilinear lookup.
//!
//! A [`Texture`] stores linear RGBA `f32` texels. Colour maps are decoded from sRGB to
//! linear on load ([`Encoding::Srgb`]); data maps (alpha, thickness, extinction, bump) are
//! taken as stored ([`Encoding::Linear`]). Float formats (EXR, HDR) are always linear.
//! Texture coordinates: `u` to the right, `v` *up*, origin at the bottom-left of the image
//! (the OpenGL / glTF-with-flip convention used by OBJ): `v = 1` is the top row of the file.

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

    /// A 1x1 texture of one value.
    pub fn constant(value: Vec4) -> Self {
        Self::from_texels(1, 1, vec![value], Wrap::Repeat)
    }

    /// Loads an image file. 8/16-bit channels are normalised to `[0, 1]` and, for
    /// [`Encoding::Srgb`], decoded to linear; float images are taken as linear. Grey images
    /// are expanded to RGB; a missing alpha channel reads as 1.
    pub fn load(path: &Path, encoding: Encoding) -> Result<Self, TextureError> {
        let img = image::ImageReader::open(path)
            .map_err(|e| TextureError::Read {
                path: path.to_owned(),
                source: image::ImageError::IoError(e),
            })?
            .with_guessed_format()
            .map_err(|e| TextureError::Read {
                path: path.to_owned(),
                source: image::ImageError::IoError(e),
            })?
            .decode()
            .map_err(|source| TextureError::Read {
                path: path.to_owned(),
                source,
            })?;
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
        if self.texels.len() == 1 {
            return self.texels[0];
        }
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return self.texels[0];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // Address the two columns and two rows once, then read the four texels directly.
        let (x0, x1) = self.neighbours(x0 as i64, self.width);
        let (y0, y1) = self.neighbours(y0 as i64, self.height);
        let w = self.width as usize;
        let t = &self.texels;
        let a = t[y0 * w + x0].lerp(t[y0 * w + x1], fx);
        let b = t[y1 * w + x0].lerp(t[y1 * w + x1], fx);
        a.lerp(b, fy)
    }

    /// Indices `i` and `i + 1` on an axis of `n` texels, addressed by [`Self::wrap`].
    #[inline]
    fn neighbours(&self, i: i64, n: u32) -> (usize, usize) {
        let n = n as i64;
        if i >= 0 && i + 1 < n {
            return (i as usize, i as usize + 1);
        }
        let at = |i: i64| match self.wrap {
            Wrap::Repeat => i.rem_euclid(n) as usize,
            Wrap::Clamp => i.clamp(0, n - 1) as usize,
        };
        (at(i), at(i + 1))
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
        if self.texels.len() == 1 {
            return Vec2::ZERO;
        }
        let du = 1.0 / self.width as f32;
        let dv = 1.0 / self.height as f32;
        let gu = self.scalar(uv + Vec2::new(du, 0.0)) - self.scalar(uv - Vec2::new(du, 0.0));
        let gv = self.scalar(uv + Vec2::new(0.0, dv)) - self.scalar(uv - Vec2::new(0.0, dv));
        Vec2::new(gu / (2.0 * du), gv / (2.0 * dv))
    }

    /// All texels, row-major, top row first.
    pub fn texels(&self) -> &[Vec4] {
        &self.texels
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for i in 0..=100 {
            let c = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5);
        }
        assert!((srgb_to_linear(0.5) - 0.214).abs() < 1e-3);
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
