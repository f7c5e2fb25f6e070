//! The sky: constant, or an equirectangular image importance-sampled with a 2D
//! piecewise-constant distribution.
//!
//! Image orientation (as [`lamina_core::Sky::Image`]): column coordinate `u ∈ [0, 1)` runs
//! with azimuth `φ = atan2(d.x, -d.z)` from `u = 0` at `φ = -π` (looking along `+z`) through
//! `u = 0.5` at `φ = 0` (looking along `-z`); row coordinate `v ∈ [0, 1]` runs with the polar
//! angle `θ = acos(d.y)` from the zenith (`+y`, top row) to the nadir (bottom row).
//! `rotation_deg` turns the map about `+y` counter-clockwise seen from above:
//! `d_world = R_y(rotation) d_map`.
//!
//! The radiance of a direction is the value of the texel it falls in (nearest, no
//! filtering), so the sampling density is exactly proportional to
//! `mean(rgb) · sin θ_row` per texel and the estimator has no mismatch between what is
//! sampled and what is evaluated.

use super::{LightSample, NO_TEXEL};
use crate::distribution::Distribution2D;
use crate::error::RenderError;
use glam::{Vec2, Vec3};
use lamina_core::Sky;
use lamina_leaf::sampling::{UNIFORM_SPHERE_PDF, uniform_sphere};
use std::f32::consts::PI;

/// One texel of an [`EnvMap`]: its radiance and the sampling density of its cell, side by
/// side so that a lookup reads one 16-byte record (a 512 x 256 map's texels, its rows' and
/// its marginal's densities are megabytes apart, and a ray leaving the scene lands
/// anywhere in them).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct Texel {
    /// Radiance, W m⁻² sr⁻¹.
    le: Vec3,
    /// The density of [`EnvMap::sample`]'s `(u, v)` in this cell, per unit `u`·`v` (the
    /// distribution's `pdf_cell`); 0 for an unsampled map.
    pdf_uv: f32,
}

/// An equirectangular radiance map prepared for lookup and sampling.
#[derive(Clone, Debug)]
pub struct EnvMap {
    width: usize,
    height: usize,
    /// Radiance (W m⁻² sr⁻¹, scale applied) and sampling density per texel, row-major, top
    /// row (zenith) first: what a direction's lookup reads, in one place.
    texels: Vec<Texel>,
    /// The sampling distribution; `None` for a map that is only looked up
    /// ([`EnvMap::new_unsampled`]).
    dist: Option<Distribution2D>,
    /// `cos` and `sin` of the rotation about `+y`.
    rot: Vec2,
}

impl EnvMap {
    /// A map of `width x height` radiance texels (top row = zenith), rotated by
    /// `rotation_deg` about `+y`. `None` when sizes do not match the texel count.
    pub fn new(width: usize, height: usize, texels: Vec<Vec3>, rotation_deg: f32) -> Option<Self> {
        Self::build(width, height, texels, rotation_deg, true)
    }

    /// [`EnvMap::new`] without the sampling distribution: a map that is looked up, never
    /// sampled ([`EnvMap::sample`] gives `None`, [`EnvMap::pdf`] zero), as a spectral
    /// render's channel sets' skies are (their directions come from the scene's own sky).
    pub fn new_unsampled(
        width: usize,
        height: usize,
        texels: Vec<Vec3>,
        rotation_deg: f32,
    ) -> Option<Self> {
        Self::build(width, height, texels, rotation_deg, false)
    }

    fn build(
        width: usize,
        height: usize,
        texels: Vec<Vec3>,
        rotation_deg: f32,
        sampled: bool,
    ) -> Option<Self> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return None;
        }
        let texels: Vec<Vec3> = texels
            .into_iter()
            .map(|t| {
                if t.is_finite() {
                    t.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        let dist = sampled.then(|| {
            let mut func = Vec::with_capacity(width * height);
            for y in 0..height {
                let sin_t = (PI * (y as f32 + 0.5) / height as f32).sin();
                for x in 0..width {
                    let t = texels[y * width + x];
                    func.push((t.x + t.y + t.z) / 3.0 * sin_t);
                }
            }
            Distribution2D::new(&func, width, height)
        });
        let r = if rotation_deg.is_finite() {
            rotation_deg.to_radians()
        } else {
            0.0
        };
        let texels = texels
            .iter()
            .enumerate()
            .map(|(i, &le)| Texel {
                le,
                pdf_uv: dist
                    .as_ref()
                    .map_or(0.0, |d| d.pdf_cell(i % width, i / width)),
            })
            .collect();
        Some(EnvMap {
            width,
            height,
            dist,
            texels,
            rot: Vec2::new(r.cos(), r.sin()),
        })
    }

    /// World direction to map coordinates `(u, v)`.
    #[inline]
    pub fn dir_to_uv(&self, d: Vec3) -> Vec2 {
        self.dir_to_uv_sin(d).0
    }

    /// [`EnvMap::dir_to_uv`] of unit `d`, and `sin θ` (`θ = π v`, the polar angle): the
    /// length of `d`'s horizontal part, which the conversion computes anyway.
    #[inline]
    fn dir_to_uv_sin(&self, d: Vec3) -> (Vec2, f32) {
        // d_map = R_y(-rot) d_world.
        let (c, s) = (self.rot.x, self.rot.y);
        let m = Vec3::new(d.x * c - d.z * s, d.y, d.x * s + d.z * c);
        let phi = m.x.atan2(-m.z);
        let u = (phi + PI) * (0.5 / PI);
        // atan2 rather than acos: precise near the poles.
        let sin_t = (m.x * m.x + m.z * m.z).sqrt();
        let v = sin_t.atan2(m.y) / PI;
        (Vec2::new(u, v), sin_t)
    }

    /// Map coordinates `(u, v)` to the world direction.
    #[inline]
    pub fn uv_to_dir(&self, uv: Vec2) -> Vec3 {
        let (st, ct) = (PI * uv.y).sin_cos();
        self.dir_at(st, ct, uv.x)
    }

    /// The world direction at column coordinate `u` whose polar angle has sine `st` and
    /// cosine `ct`.
    #[inline]
    fn dir_at(&self, st: f32, ct: f32, u: f32) -> Vec3 {
        let (sp, cp) = (2.0 * PI * u - PI).sin_cos();
        let m = Vec3::new(st * sp, ct, -st * cp);
        let (c, s) = (self.rot.x, self.rot.y);
        Vec3::new(m.x * c + m.z * s, m.y, -m.x * s + m.z * c)
    }

    #[inline]
    fn cell(&self, uv: Vec2) -> (usize, usize) {
        let x = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        (x, y)
    }

    /// Radiance toward the viewer from direction `d` (unit, pointing at the sky).
    #[inline]
    pub fn le(&self, d: Vec3) -> Vec3 {
        let (x, y) = self.cell(self.dir_to_uv(d));
        self.texels[y * self.width + x].le
    }

    /// Solid-angle density of [`EnvMap::sample`] at direction `d` (unit).
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.le_pdf(d).1
    }

    /// The solid-angle density of a texel's `(u, v)` density `pdf_uv` where `sin θ` is
    /// `sin_t` (`dω = 2π² sin θ du dv`); 0 at the poles.
    #[inline]
    fn solid_angle_pdf(pdf_uv: f32, sin_t: f32) -> f32 {
        if sin_t > 0.0 {
            pdf_uv / (2.0 * PI * PI * sin_t)
        } else {
            0.0
        }
    }

    /// [`EnvMap::le`] and [`EnvMap::pdf`] of unit `d` together, and the index of its texel
    /// (for [`EnvMap::le_at`] of maps of the same size), the direction converted once and
    /// one texel record read.
    #[inline]
    pub fn le_pdf(&self, d: Vec3) -> (Vec3, f32, usize) {
        let (uv, sin_t) = self.dir_to_uv_sin(d);
        let (x, y) = self.cell(uv);
        let i = y * self.width + x;
        let t = self.texels[i];
        (t.le, Self::solid_angle_pdf(t.pdf_uv, sin_t), i)
    }

    /// The radiance of texel `i` (row-major), as [`EnvMap::le`] of a direction in it.
    #[inline]
    pub fn le_at(&self, i: usize) -> Vec3 {
        self.texels[i].le
    }

    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// A direction drawn proportionally to radiance (times `sin θ` per row).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<LightSample> {
        let (uv, (x, y)) = self.dist.as_ref()?.sample_cell(u);
        let i = y * self.width + x;
        let t = self.texels[i];
        // `uv_to_dir`'s polar angle, its sine shared with the density.
        let (sin_t, cos_t) = (PI * uv.y).sin_cos();
        if !(t.pdf_uv > 0.0 && sin_t > 0.0) {
            return None;
        }
        Some(LightSample {
            wi: self.dir_at(sin_t, cos_t, uv.x),
            li: t.le,
            pdf: Self::solid_angle_pdf(t.pdf_uv, sin_t),
            dist: f32::INFINITY,
            delta: false,
            texel: i as u32,
        })
    }

    /// Mean radiance over the sphere of directions.
    pub fn mean(&self) -> Vec3 {
        let mut sum = glam::DVec3::ZERO;
        for y in 0..self.height {
            let t0 = PI as f64 * y as f64 / self.height as f64;
            let t1 = PI as f64 * (y + 1) as f64 / self.height as f64;
            let omega = 2.0 * std::f64::consts::PI / self.width as f64 * (t0.cos() - t1.cos());
            for x in 0..self.width {
                sum += self.texels[y * self.width + x].le.as_dvec3() * omega;
            }
        }
        (sum / (4.0 * std::f64::consts::PI)).as_vec3()
    }
}

/// The sky light.
#[derive(Clone, Debug)]
pub enum SkyLight {
    /// The same radiance from every direction; sampled uniformly over the sphere.
    Constant(Vec3),
    /// An importance-sampled radiance map.
    Image(Box<EnvMap>),
}

impl SkyLight {
    /// Prepares the scene's sky.
    pub fn new(sky: &Sky) -> Result<Self, RenderError> {
        Self::with_sampling(sky, true)
    }

    /// [`SkyLight::new`]; a map sky without its sampling distribution unless `sampled`
    /// ([`EnvMap::new_unsampled`]).
    pub fn with_sampling(sky: &Sky, sampled: bool) -> Result<Self, RenderError> {
        match sky {
            Sky::Constant(c) => {
                if !c.is_finite() {
                    return Err(RenderError::InvalidScene(
                        "sky radiance must be finite".into(),
                    ));
                }
                Ok(SkyLight::Constant(*c))
            }
            Sky::Image {
                map,
                scale,
                rotation_deg,
                ..
            } => {
                let scale = if scale.is_finite() { *scale } else { 0.0 };
                let texels = map.texels().iter().map(|t| t.truncate() * scale).collect();
                let make = if sampled {
                    EnvMap::new
                } else {
                    EnvMap::new_unsampled
                };
                make(
                    map.width() as usize,
                    map.height() as usize,
                    texels,
                    *rotation_deg,
                )
                .map(|m| SkyLight::Image(Box::new(m)))
                .ok_or_else(|| RenderError::InvalidScene("sky image has no pixels".into()))
            }
        }
    }

    /// Radiance arriving from direction `d`.
    #[inline]
    pub fn le(&self, d: Vec3) -> Vec3 {
        match self {
            SkyLight::Constant(c) => *c,
            SkyLight::Image(m) => m.le(d),
        }
    }

    /// Radiance from `d`, the density of [`SkyLight::sample`] there, and `d`'s texel
    /// ([`NO_TEXEL`] for a constant sky), the direction converted once.
    #[inline]
    pub fn le_pdf(&self, d: Vec3) -> (Vec3, f32, u32) {
        match self {
            SkyLight::Constant(c) => (*c, UNIFORM_SPHERE_PDF, NO_TEXEL),
            SkyLight::Image(m) => {
                let (le, pdf, i) = m.le_pdf(d);
                (le, pdf, i as u32)
            }
        }
    }

    /// Radiance from `d`, whose texel in a map of this one's size is `texel` (or
    /// [`NO_TEXEL`]: then from `d` itself).
    #[inline]
    pub fn le_texel(&self, d: Vec3, texel: u32) -> Vec3 {
        match self {
            SkyLight::Constant(c) => *c,
            SkyLight::Image(m) if texel != NO_TEXEL => m.le_at(texel as usize),
            SkyLight::Image(m) => m.le(d),
        }
    }

    /// The map's size in texels (`None` for a constant sky).
    pub fn size(&self) -> Option<(usize, usize)> {
        match self {
            SkyLight::Constant(_) => None,
            SkyLight::Image(m) => Some(m.size()),
        }
    }

    /// Solid-angle density of [`SkyLight::sample`] at `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        match self {
            SkyLight::Constant(_) => UNIFORM_SPHERE_PDF,
            SkyLight::Image(m) => m.pdf(d),
        }
    }

    /// A direction toward the sky.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<LightSample> {
        match self {
            SkyLight::Constant(c) => Some(LightSample {
                wi: uniform_sphere(u),
                li: *c,
                pdf: UNIFORM_SPHERE_PDF,
                dist: f32::INFINITY,
                delta: false,
                texel: NO_TEXEL,
            }),
            SkyLight::Image(m) => m.sample(u),
        }
    }

    /// Mean radiance over all directions.
    pub fn mean(&self) -> Vec3 {
        match self {
            SkyLight::Constant(c) => *c,
            SkyLight::Image(m) => m.mean(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::sobol_2d;

    fn test_map() -> EnvMap {
        let (w, h) = (16, 8);
        let texels = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let v = 0.1
                    + ((x * 7 + y * 13) % 11) as f32
                    + if (x, y) == (3, 2) { 50.0 } else { 0.0 };
                Vec3::new(v, 0.5 * v, 0.25 * v)
            })
            .collect();
        EnvMap::new(w, h, texels, 30.0).unwrap()
    }

    /// The documented orientation: `u = 0.5` looks along `-z`, `u = 0.75` along `+x`, rows
    /// from the zenith down; the rotation is right-handed about `+y`.
    #[test]
    fn orientation_matches_the_scene_convention() {
        let m = EnvMap::new(4, 2, vec![Vec3::ONE; 8], 0.0).unwrap();
        let s = std::f32::consts::FRAC_1_SQRT_2;
        assert!((m.uv_to_dir(Vec2::new(0.5, 0.25)) - Vec3::new(0.0, s, -s)).length() < 1e-5);
        assert!((m.uv_to_dir(Vec2::new(0.75, 0.5)) - Vec3::X).length() < 1e-5);
        assert!((m.uv_to_dir(Vec2::new(0.25, 0.5)) + Vec3::X).length() < 1e-5);
        assert!((m.uv_to_dir(Vec2::new(0.0, 0.5)) - Vec3::Z).length() < 1e-5);
        assert!((m.uv_to_dir(Vec2::new(0.3, 1.0)) + Vec3::Y).length() < 1e-5);
        let r = EnvMap::new(4, 2, vec![Vec3::ONE; 8], 90.0).unwrap();
        // R_y(90°) takes the map's -z to world -x.
        assert!((r.uv_to_dir(Vec2::new(0.5, 0.5)) + Vec3::X).length() < 1e-5);
        assert!((r.dir_to_uv(-Vec3::X) - Vec2::new(0.5, 0.5)).length() < 1e-5);
    }

    #[test]
    fn directions_round_trip() {
        let m = test_map();
        for uv in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.7, 0.9),
            Vec2::new(0.5, 0.5),
        ] {
            let d = m.uv_to_dir(uv);
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!((m.dir_to_uv(d) - uv).length() < 1e-4);
        }
        // Top row is the zenith.
        assert!((m.uv_to_dir(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-5);
    }

    #[test]
    fn sky_pdf_integrates_to_one_and_matches_histogram() {
        let m = test_map();
        // ∫ pdf dω over the sphere by a fine midpoint rule in (φ, cos θ).
        let n = 512;
        let mut integral = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                let phi = 2.0 * PI * (j as f32 + 0.5) / n as f32;
                let r = (1.0 - z * z).sqrt();
                let d = Vec3::new(r * phi.cos(), z, r * phi.sin());
                integral += m.pdf(d) as f64 * (4.0 * PI as f64 / (n * n) as f64);
            }
        }
        assert!((integral - 1.0).abs() < 0.01, "∫pdf = {integral}");
        // Histogram of sampled texels against the probability mass of each texel.
        let samples = 200_000u32;
        let mut hist = vec![0u32; 16 * 8];
        for i in 0..samples {
            let s = m.sample(sobol_2d(i, 42)).unwrap();
            assert!(
                (s.pdf - m.pdf(s.wi)).abs() <= 1e-4 * s.pdf,
                "{} vs {}",
                s.pdf,
                m.pdf(s.wi)
            );
            assert_eq!(s.li, m.le(s.wi));
            let uv = m.dir_to_uv(s.wi);
            let (x, y) = m.cell(uv);
            hist[y * 16 + x] += 1;
        }
        for y in 0..8 {
            for x in 0..16 {
                let mass = m.dist.as_ref().expect("sampled").pdf_cell(x, y) / (16.0 * 8.0);
                let expect = mass * samples as f32;
                let got = hist[y * 16 + x] as f32;
                // 4 sigma of a binomial count, plus one for rounding.
                assert!(
                    (got - expect).abs() <= 4.0 * expect.sqrt() + 1.0,
                    "cell {x},{y}: {got} vs {expect}"
                );
            }
        }
    }

    /// A map without its distribution looks up the same texels and is never sampled.
    #[test]
    fn unsampled_map_is_looked_up_only() {
        let m = test_map();
        let texels = (0..16 * 8).map(|i| m.le_at(i)).collect();
        let u = EnvMap::new_unsampled(16, 8, texels, 30.0).unwrap();
        for k in 0..64u32 {
            let d = uniform_sphere(sobol_2d(k, 5));
            assert_eq!(u.le(d), m.le(d));
            assert_eq!(u.le_pdf(d).0, m.le_pdf(d).0);
            assert_eq!(u.le_pdf(d).2, m.le_pdf(d).2);
            assert_eq!(u.pdf(d), 0.0);
            assert!(m.pdf(d) > 0.0);
            assert!(u.sample(sobol_2d(k, 9)).is_none());
        }
    }
}
