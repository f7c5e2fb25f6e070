//! Pixel filters and sample accumulation.
//!
//! Filters are applied by *filter importance sampling*: each camera sample's position
//! inside its pixel is drawn from the (separable) filter profile, and the pixel value is the
//! plain mean of its samples. For the positive filters here this is unbiased for the
//! filtered image, keeps every sample inside one pixel (tiles need no shared borders), and
//! costs nothing per sample beyond a table lookup.

use crate::distribution::Distribution1D;
use glam::{DVec3, Vec2, Vec3};
use lamina_core::PixelFilter;

/// Bins of the tabulated 1D filter profile.
const FILTER_BINS: usize = 256;

/// A filter's 1D profile: weight at an offset in pixels.
type Profile = Box<dyn Fn(f32) -> f32>;

/// Draws sample offsets from a pixel filter.
#[derive(Clone, Debug)]
pub struct FilterSampler {
    radius: f32,
    /// The tabulated profile; `None` for the box filter, whose samples are the uniform
    /// numbers themselves (two table searches per camera sample were a measured few per
    /// cent of a render).
    dist: Option<Distribution1D>,
}

impl FilterSampler {
    /// A sampler for `filter`. Non-positive or non-finite radii fall back to the box filter.
    pub fn new(filter: PixelFilter) -> Self {
        let (radius, profile): (f32, Option<Profile>) = match filter {
            PixelFilter::Tent { radius } if radius.is_finite() && radius > 0.0 => (
                radius,
                Some(Box::new(move |x: f32| (1.0 - x.abs() / radius).max(0.0))),
            ),
            PixelFilter::Gaussian { radius, sigma }
                if radius.is_finite() && radius > 0.0 && sigma.is_finite() && sigma > 0.0 =>
            {
                let g = move |x: f32| (-x * x / (2.0 * sigma * sigma)).exp();
                let edge = g(radius);
                (radius, Some(Box::new(move |x: f32| (g(x) - edge).max(0.0))))
            }
            _ => (0.5, None),
        };
        let dist = profile.map(|profile| {
            let func: Vec<f32> = (0..FILTER_BINS)
                .map(|i| profile(((i as f32 + 0.5) / FILTER_BINS as f32 * 2.0 - 1.0) * radius))
                .collect();
            Distribution1D::new(&func)
        });
        FilterSampler { radius, dist }
    }

    /// Offset (pixels) from the pixel centre for `u ∈ [0, 1)²`. Always inlined: the
    /// wavefront's lane loop calls it per camera sample, and out of line (as the compiler
    /// left it) the call was 1.5-2 % of a camera-rays-only frame.
    #[inline(always)]
    pub fn sample(&self, u: Vec2) -> Vec2 {
        let p = match &self.dist {
            Some(d) => Self::tabulated(d, u),
            None => u,
        };
        (p * 2.0 - Vec2::ONE) * self.radius
    }

    /// A tabulated filter's two lookups (inlined here, side by side), out of line: the box filter's path (the common
    /// one) stays a few instructions that inline into every camera sample.
    #[inline(never)]
    fn tabulated(d: &Distribution1D, u: Vec2) -> Vec2 {
        Vec2::new(d.sample_x(u.x), d.sample_x(u.y))
    }
}

/// Per-pixel radiance sums in double precision (so thousands of samples add exactly
/// enough), `channels` per pixel: 3 for RGB, one per band for a band render.
#[derive(Clone, Debug)]
pub struct Accumulator {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Values per pixel.
    pub channels: usize,
    /// Row-major, `channels` per pixel.
    sums: Vec<f64>,
}

impl Accumulator {
    /// All-zero sums for a `width x height` image of `channels` values per pixel.
    pub fn new(width: u32, height: u32, channels: usize) -> Self {
        Accumulator {
            width,
            height,
            channels,
            sums: vec![0.0; width as usize * height as usize * channels],
        }
    }

    /// Adds a tile's sums (row-major within the tile, `channels` per pixel) at `(x0, y0)`.
    pub fn add_tile(&mut self, x0: u32, y0: u32, w: u32, sums: &[f64]) {
        let c = self.channels;
        for (i, s) in sums.chunks_exact(c).enumerate() {
            let (x, y) = (x0 + i as u32 % w, y0 + i as u32 / w);
            let at = (y * self.width + x) as usize * c;
            for (d, v) in self.sums[at..at + c].iter_mut().zip(s) {
                *d += *v;
            }
        }
    }

    /// The per-pixel sums of an RGB image, row-major.
    pub fn into_rgb_sums(self) -> Vec<DVec3> {
        debug_assert_eq!(self.channels, 3);
        self.sums
            .chunks_exact(3)
            .map(|s| DVec3::new(s[0], s[1], s[2]))
            .collect()
    }

    /// The per-pixel sums, one row-major plane per channel.
    pub fn into_planes(self) -> Vec<Vec<f64>> {
        (0..self.channels)
            .map(|k| {
                self.sums
                    .iter()
                    .skip(k)
                    .step_by(self.channels)
                    .copied()
                    .collect()
            })
            .collect()
    }

    /// The mean of `spp` samples per pixel of an RGB image (zero when `spp == 0`): each
    /// sum times the f64 reciprocal of `spp`, rounded to f32. `lamina_farm::part::mean_f32`
    /// repeats this formula so that merged parts give the same bits.
    pub fn mean_rgb(&self, spp: u32) -> Vec<Vec3> {
        debug_assert_eq!(self.channels, 3);
        let inv = inverse(spp);
        self.sums
            .chunks_exact(3)
            .map(|s| (DVec3::new(s[0], s[1], s[2]) * inv).as_vec3())
            .collect()
    }

    /// The mean of `spp` samples per pixel, one row-major plane per channel, by the same
    /// formula as [`Self::mean_rgb`].
    pub fn mean_planes(&self, spp: u32) -> Vec<Vec<f32>> {
        let inv = inverse(spp);
        (0..self.channels)
            .map(|k| {
                self.sums
                    .iter()
                    .skip(k)
                    .step_by(self.channels)
                    .map(|s| (s * inv) as f32)
                    .collect()
            })
            .collect()
    }
}

/// `1 / spp` in f64, 0 for no samples.
fn inverse(spp: u32) -> f64 {
    if spp == 0 { 0.0 } else { 1.0 / spp as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filters_stay_within_radius_and_centre() {
        for f in [
            PixelFilter::Box,
            PixelFilter::Tent { radius: 1.5 },
            PixelFilter::Gaussian {
                radius: 2.0,
                sigma: 0.5,
            },
        ] {
            let s = FilterSampler::new(f);
            let mut mean = Vec2::ZERO;
            let n = 1000;
            for i in 0..n {
                let u = Vec2::new(
                    (i as f32 + 0.5) / n as f32,
                    ((i * 7919) % n) as f32 / n as f32,
                );
                let o = s.sample(u);
                assert!(o.abs().max_element() <= 2.0 + 1e-4);
                mean += o / n as f32;
            }
            assert!(mean.length() < 0.01, "{f:?} {mean}");
        }
        let b = FilterSampler::new(PixelFilter::Box);
        assert!((b.sample(Vec2::new(0.0, 0.999_99)) - Vec2::new(-0.5, 0.5)).length() < 1e-3);
    }
}
