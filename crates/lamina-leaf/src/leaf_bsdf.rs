//! The leaf BSDF at one texel (placeholder body; the layered model follows).

use crate::bsdf::{Bsdf, BsdfSample};
use crate::lambert::DiffuseTransmission;
use glam::Vec3;

/// The leaf's BSDF at one texel, in the local frame (`+z` = adaxial side). `Copy`, no
/// allocation; built by [`crate::LeafMaterial::bsdf`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafBsdf {
    r_front: Vec3,
    r_back: Vec3,
    t: Vec3,
}

impl LeafBsdf {
    /// Hemispherical diffuse reflectance seen from the adaxial side and diffuse
    /// transmittance, linear RGB.
    pub fn diffuse_albedo(&self) -> (Vec3, Vec3) {
        (self.r_front, self.t)
    }

    pub(crate) fn placeholder(r_front: Vec3, r_back: Vec3, t: Vec3) -> Self {
        LeafBsdf { r_front, r_back, t }
    }

    fn side(&self, wo: Vec3) -> DiffuseTransmission {
        DiffuseTransmission {
            reflectance: if wo.z >= 0.0 {
                self.r_front
            } else {
                self.r_back
            },
            transmittance: self.t,
        }
    }
}

impl Bsdf for LeafBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.side(wo).eval(wo, wi)
    }
    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
        self.side(wo).sample(wo, u)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.side(wo).pdf(wo, wi)
    }
}
