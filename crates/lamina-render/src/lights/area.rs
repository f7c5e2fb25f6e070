//! Area lights: emitting parallelograms and spheres. Both are geometry too: camera and
//! BSDF rays hit them (see [`crate::accel`]), and they end paths (they do not reflect).

use super::{LightSample, sample_cone};
use glam::{Vec2, Vec3};
use lamina_leaf::frame::Frame;
use lamina_leaf::sampling::uniform_sphere;
use std::f32::consts::PI;

/// An emitting parallelogram `corner + s·edge_u + t·edge_v`, sampled uniformly by area.
#[derive(Clone, Copy, Debug)]
pub struct QuadLight {
    corner: Vec3,
    edge_u: Vec3,
    edge_v: Vec3,
    /// Unit normal `edge_u × edge_v`: the emitting side (both when two-sided).
    normal: Vec3,
    area: f32,
    radiance: Vec3,
    two_sided: bool,
}

impl QuadLight {
    /// `None` for non-finite values or zero area.
    pub fn new(
        corner: Vec3,
        edge_u: Vec3,
        edge_v: Vec3,
        radiance: Vec3,
        two_sided: bool,
    ) -> Option<Self> {
        let c = edge_u.cross(edge_v);
        let area = c.length();
        if !(area > 0.0 && area.is_finite() && corner.is_finite() && radiance.is_finite()) {
            return None;
        }
        Some(QuadLight {
            corner,
            edge_u,
            edge_v,
            normal: c / area,
            area,
            radiance,
            two_sided,
        })
    }

    /// Emitted radiance (W m⁻² sr⁻¹).
    #[inline]
    pub fn radiance(&self) -> Vec3 {
        self.radiance
    }

    /// Emitted flux (W): `π A L`, twice that when two-sided.
    pub fn power(&self) -> Vec3 {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        self.radiance * (PI * self.area * sides)
    }

    /// A point on the quad seen from `p`.
    #[inline]
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let q = self.corner + self.edge_u * u.x + self.edge_v * u.y;
        let d = q - p;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = d / dist;
        let cos_l = -wi.dot(self.normal);
        if !self.two_sided && cos_l <= 0.0 || cos_l.abs() < 1e-7 {
            return None;
        }
        Some(LightSample {
            wi,
            li: self.radiance,
            pdf: d2 / (cos_l.abs() * self.area),
            dist,
            delta: false,
            texel: super::NO_TEXEL,
        })
    }

    /// Radiance seen by a ray of unit direction `dir` that hits the quad at distance `t`, and
    /// the solid-angle density with which [`QuadLight::sample`] picks that point.
    #[inline]
    pub fn hit(&self, dir: Vec3, t: f32) -> (Vec3, f32) {
        let cos_l = -dir.dot(self.normal);
        if (!self.two_sided && cos_l <= 0.0) || cos_l == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        (self.radiance, t * t / (cos_l.abs() * self.area))
    }
}

/// An emitting sphere. From outside it is sampled uniformly within the cone it subtends
/// (pbrt's method); from inside, uniformly by area.
#[derive(Clone, Copy, Debug)]
pub struct SphereLight {
    /// Centre (m).
    pub center: Vec3,
    /// Radius (m).
    pub radius: f32,
    /// Emitted radiance (W m⁻² sr⁻¹).
    pub radiance: Vec3,
}

impl SphereLight {
    /// `(1 - cos θmax, distance to the centre)` from `p`, or `None` when `p` is inside.
    #[inline]
    fn cone(&self, p: Vec3) -> Option<(f32, f32)> {
        let dc2 = (self.center - p).length_squared();
        let r2 = self.radius * self.radius;
        if dc2 <= r2 * 1.0001 {
            return None;
        }
        let sin2 = r2 / dc2;
        let cos = (1.0 - sin2).max(0.0).sqrt();
        Some((sin2 / (1.0 + cos), dc2.sqrt()))
    }

    /// A direction toward the sphere from `p`.
    #[inline]
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        if let Some((h, dc)) = self.cone(p) {
            let axis = (self.center - p) / dc;
            let local = sample_cone(u, h);
            let wi = Frame::from_normal(axis).to_world(local).normalize();
            let cos_t = local.z;
            let sin2_t = (1.0 - cos_t * cos_t).max(0.0);
            let disc = (self.radius * self.radius - dc * dc * sin2_t).max(0.0);
            let dist = dc * cos_t - disc.sqrt();
            return Some(LightSample {
                wi,
                li: self.radiance,
                pdf: 1.0 / (2.0 * PI * h),
                dist,
                delta: false,
                texel: super::NO_TEXEL,
            });
        }
        let n = uniform_sphere(u);
        let q = self.center + n * self.radius;
        let d = q - p;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = d / dist;
        let cos = wi.dot(n).abs();
        if cos < 1e-7 {
            return None;
        }
        Some(LightSample {
            wi,
            li: self.radiance,
            pdf: d2 / (cos * 4.0 * PI * self.radius * self.radius),
            dist,
            delta: false,
            texel: super::NO_TEXEL,
        })
    }

    /// Radiance seen by a ray from `origin` along unit `dir` that hits the sphere at distance
    /// `t`, and the density with which [`SphereLight::sample`] from `origin` picks it.
    #[inline]
    pub fn hit(&self, origin: Vec3, dir: Vec3, t: f32) -> (Vec3, f32) {
        if let Some((h, _)) = self.cone(origin) {
            return (self.radiance, 1.0 / (2.0 * PI * h));
        }
        let q = origin + dir * t;
        let n = (q - self.center).normalize_or_zero();
        let cos = dir.dot(n).abs().max(1e-7);
        (
            self.radiance,
            t * t / (cos * 4.0 * PI * self.radius * self.radius),
        )
    }
}
