//! Isotropic point lights.

use super::LightSample;
use glam::Vec3;

/// A point light of radiant intensity `intensity` (W sr⁻¹): a delta light.
#[derive(Clone, Copy, Debug)]
pub struct PointLight {
    /// Position (m).
    pub position: Vec3,
    /// Radiant intensity (W sr⁻¹).
    pub intensity: Vec3,
}

impl PointLight {
    /// The direction toward the light from `p` with `li = I / d²`.
    #[inline]
    pub fn sample(&self, p: Vec3) -> Option<LightSample> {
        let d = self.position - p;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        Some(LightSample {
            wi: d / dist,
            li: self.intensity / d2,
            pdf: 1.0,
            dist,
            delta: true,
            texel: super::NO_TEXEL,
        })
    }
}
