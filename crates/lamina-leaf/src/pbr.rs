//! The glTF 2.0 metallic-roughness surface (with `KHR_materials_diffuse_transmission`):
//! the material of pots, stems, bark and ground that come from glTF, OBJ + MTL or a scene
//! file's `type = "pbr"`. PLACEHOLDER: Lambertian stand-in until the real model lands.

use crate::bsdf::{Bsdf, BsdfSample};
use crate::lambert::DiffuseTransmission;
use glam::Vec3;

/// One point of a glTF metallic-roughness surface, two-sided (it reflects on the side of
/// `wo`; diffuse transmission goes to the other side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PbrBsdf {
    /// glTF `baseColor`, linear RGB in `[0, 1]`: diffuse albedo of the dielectric part,
    /// normal-incidence reflectance (F0) of the metallic part.
    pub base_color: Vec3,
    /// glTF `metallic` in `[0, 1]`: 0 dielectric, 1 conductor, linear mix between.
    pub metallic: f32,
    /// glTF perceptual `roughness` in `[0, 1]`; the GGX `alpha` is `roughness²`.
    pub roughness: f32,
    /// Index of refraction of the dielectric part (glTF default 1.5, i.e. F0 = 0.04).
    pub ior: f32,
    /// `KHR_materials_diffuse_transmission` `diffuseTransmissionFactor` in `[0, 1]`: the
    /// fraction of the dielectric's diffuse part that is transmitted instead of reflected.
    pub transmission: f32,
    /// `diffuseTransmissionColor`, linear RGB in `[0, 1]`.
    pub transmission_color: Vec3,
}

impl Default for PbrBsdf {
    fn default() -> Self {
        PbrBsdf {
            base_color: Vec3::splat(0.8),
            metallic: 0.0,
            roughness: 0.5,
            ior: 1.5,
            transmission: 0.0,
            transmission_color: Vec3::ONE,
        }
    }
}

impl PbrBsdf {
    fn lambert(&self) -> DiffuseTransmission {
        let d = self.base_color * (1.0 - self.metallic);
        DiffuseTransmission {
            reflectance: d * (1.0 - self.transmission),
            transmittance: self.transmission_color * self.transmission * (1.0 - self.metallic),
        }
    }

    /// Diffuse hemispherical (reflectance, transmittance), linear RGB: the Lambertian
    /// parts only (what the paper integrator's ambient term and the GPU bake use).
    pub fn diffuse_albedo(&self) -> (Vec3, Vec3) {
        let l = self.lambert();
        (l.reflectance, l.transmittance)
    }
}

impl Bsdf for PbrBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.lambert().eval(wo, wi)
    }
    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
        self.lambert().sample(wo, u)
    }
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.lambert().pdf(wo, wi)
    }
}
