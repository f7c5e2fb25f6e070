//! The sun: a distant disc of given irradiance and angular diameter.

use super::{LightSample, sample_cone};
use glam::{Vec2, Vec3};
use lamina_leaf::frame::Frame;
use std::f32::consts::PI;

/// A distant light. With a zero angular diameter it is a delta light (hard shadows, next-
/// event estimation only); otherwise a uniform disc of radiance `E / (π sin²θmax)` over the
/// cone of half-angle `θmax`, so a surface facing it receives irradiance `E`. The disc is
/// sampled uniformly in solid angle and is visible to rays that escape the scene.
#[derive(Clone, Copy, Debug)]
pub struct SunLight {
    frame: Frame,
    irradiance: Vec3,
    radiance: Vec3,
    /// `1 - cos θmax`; 0 for a delta light.
    h: f32,
    /// `sin² θmax`.
    sin2_max: f32,
}

impl SunLight {
    /// A sun toward `direction` (any length > 0), `irradiance` in W m⁻², diameter in
    /// degrees (clamped to `[0, 179]`). `None` for a zero or non-finite direction.
    pub fn new(direction: Vec3, irradiance: Vec3, diameter_deg: f32) -> Option<Self> {
        let d = direction.normalize_or_zero();
        if d == Vec3::ZERO || !d.is_finite() || !irradiance.is_finite() {
            return None;
        }
        let diam = if diameter_deg.is_finite() {
            diameter_deg.clamp(0.0, 179.0)
        } else {
            0.0
        };
        let half = (diam * 0.5).to_radians();
        let s = (half * 0.5).sin();
        let h = 2.0 * s * s;
        let sin2_max = half.sin().powi(2);
        let radiance = if h > 0.0 {
            irradiance / (PI * sin2_max)
        } else {
            Vec3::ZERO
        };
        Some(SunLight {
            frame: Frame::from_normal(d),
            irradiance,
            radiance,
            h,
            sin2_max,
        })
    }

    /// Unit direction toward the sun's centre.
    pub fn direction(&self) -> Vec3 {
        self.frame.n
    }

    /// Whether the sun is a delta light (zero diameter).
    pub fn is_delta(&self) -> bool {
        self.h <= 0.0
    }

    /// Irradiance (W m⁻²) on a surface facing the sun.
    #[inline]
    pub fn irradiance(&self) -> Vec3 {
        self.irradiance
    }

    /// What [`Self::sample`] returns as `li`: the irradiance of a delta sun, the disc's
    /// radiance otherwise.
    #[inline]
    pub fn li(&self) -> Vec3 {
        if self.is_delta() {
            self.irradiance
        } else {
            self.radiance
        }
    }

    /// A direction toward the sun.
    #[inline]
    pub fn sample(&self, u: Vec2) -> LightSample {
        if self.is_delta() {
            return LightSample {
                wi: self.frame.n,
                li: self.irradiance,
                pdf: 1.0,
                dist: f32::INFINITY,
                delta: true,
                texel: super::NO_TEXEL,
            };
        }
        LightSample {
            wi: self.frame.to_world(sample_cone(u, self.h)).normalize(),
            li: self.radiance,
            pdf: 1.0 / (2.0 * PI * self.h),
            dist: f32::INFINITY,
            delta: false,
            texel: super::NO_TEXEL,
        }
    }

    /// Radiance and sampling density along an escaping ray's direction `dir` (unit).
    #[inline]
    pub fn escaped(&self, dir: Vec3) -> (Vec3, f32) {
        if self.is_delta() || dir.dot(self.frame.n) <= 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        if dir.cross(self.frame.n).length_squared() <= self.sin2_max {
            (self.radiance, 1.0 / (2.0 * PI * self.h))
        } else {
            (Vec3::ZERO, 0.0)
        }
    }
}
