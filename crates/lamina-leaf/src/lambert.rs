//! Reference materials: opaque Lambertian reflection, and Lambertian reflection plus
//! Lambertian transmission (pbrt-v4 `diffusetransmission`, glTF
//! `KHR_materials_diffuse_transmission`).
//!
//! Both are two-sided: reflection happens on whichever side `wo` lies. They are the
//! diffuse limit the leaf model must reduce to, and the materials other renderers render
//! identically, so comparisons between renderers use them.

use crate::bsdf::{Bsdf, BsdfSample};
use crate::sampling::{cosine_hemisphere, cosine_hemisphere_pdf, luminance};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Opaque Lambertian reflector: `f = R / π` on the side of `wo`, nothing transmitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambertian {
    /// Hemispherical reflectance (albedo), linear RGB, each channel in `[0, 1]`.
    pub reflectance: Vec3,
}

impl Bsdf for Lambertian {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        self.reflectance * (FRAC_1_PI * wi.z.abs())
    }

    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let mut wi = cosine_hemisphere(Vec2::new(u.y, u.z));
        if wo.z < 0.0 {
            wi.z = -wi.z;
        }
        let pdf = cosine_hemisphere_pdf(wi.z.abs());
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 {
            0.0
        } else {
            cosine_hemisphere_pdf(wi.z.abs())
        }
    }
}

/// Lambertian reflection `R / π` on the side of `wo` plus Lambertian transmission `T / π`
/// to the other side. Symmetric: the same from both faces. Energy is conserved when
/// `R + T <= 1` per channel (checked by the constructor of scene materials, not here).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffuseTransmission {
    /// Hemispherical reflectance, linear RGB.
    pub reflectance: Vec3,
    /// Hemispherical (diffuse) transmittance, linear RGB.
    pub transmittance: Vec3,
}

impl DiffuseTransmission {
    /// Probability of sampling the reflection lobe, proportional to its luminance (Rec.709
    /// luminance of the reflectance against that of reflectance plus transmittance; one
    /// half when both are black).
    #[inline]
    pub fn reflect_probability(&self) -> f32 {
        let r = luminance(self.reflectance).max(0.0);
        let t = luminance(self.transmittance).max(0.0);
        if r + t <= 0.0 { 0.5 } else { r / (r + t) }
    }
}

impl Bsdf for DiffuseTransmission {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let c = wo.z * wi.z;
        if c > 0.0 {
            self.reflectance * (FRAC_1_PI * wi.z.abs())
        } else if c < 0.0 {
            self.transmittance * (FRAC_1_PI * wi.z.abs())
        } else {
            Vec3::ZERO
        }
    }

    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let pr = self.reflect_probability();
        let mut wi = cosine_hemisphere(Vec2::new(u.y, u.z));
        let reflect = u.x < pr;
        // Reflection stays on the side of wo, transmission crosses to the other: a sign
        // flip and the lobe's numbers picked by selects, not branches (the choice is a
        // coin toss, so a branch would be mispredicted often). Where `wi.z = 0` the density
        // is 0 and no sample is returned, as `pdf` and `eval` would say.
        let flip = (wo.z < 0.0) == reflect;
        wi.z = f32::from_bits(wi.z.to_bits() ^ (u32::from(flip) << 31));
        let (lobe, albedo) = if reflect {
            (pr, self.reflectance)
        } else {
            (1.0 - pr, self.transmittance)
        };
        let cos = wi.z.abs();
        let pdf = lobe * cosine_hemisphere_pdf(cos);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f: albedo * (FRAC_1_PI * cos),
            pdf,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let c = wo.z * wi.z;
        let pr = self.reflect_probability();
        let lobe = if c > 0.0 {
            pr
        } else if c < 0.0 {
            1.0 - pr
        } else {
            0.0
        };
        lobe * cosine_hemisphere_pdf(wi.z.abs())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::march::Pcg32;
    use crate::sampling::uniform_sphere;

    /// `sample` gives, bit for bit, the weight and density that `eval` and `pdf` give for
    /// its direction: its selects stand for the same lobe choice as theirs.
    #[test]
    fn samples_carry_the_eval_and_pdf_of_their_direction() {
        let dt = DiffuseTransmission {
            reflectance: Vec3::new(0.3, 0.5, 0.2),
            transmittance: Vec3::new(0.2, 0.3, 0.1),
        };
        let black = DiffuseTransmission {
            reflectance: Vec3::ZERO,
            transmittance: Vec3::ZERO,
        };
        let lambert = Lambertian {
            reflectance: Vec3::new(0.5, 0.4, 0.3),
        };
        let bsdfs: [&dyn Bsdf; 3] = [&dt, &black, &lambert];
        let mut rng = Pcg32::new(5);
        let (mut reflected, mut transmitted) = (0, 0);
        for b in bsdfs {
            for k in 0..50_000 {
                let mut wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                if k % 97 == 0 {
                    wo.z = -0.0; // grazing: no sample
                }
                let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let Some(s) = b.sample(wo, u) else {
                    assert!(
                        wo.z == 0.0 || b.pdf(wo, cosine_hemisphere(Vec2::new(u.y, u.z))) == 0.0
                    );
                    continue;
                };
                if s.wi.z * wo.z > 0.0 {
                    reflected += 1;
                } else {
                    transmitted += 1;
                }
                assert_eq!(s.pdf.to_bits(), b.pdf(wo, s.wi).to_bits(), "{wo} {u}");
                assert_eq!(
                    s.f.to_array().map(f32::to_bits),
                    b.eval(wo, s.wi).to_array().map(f32::to_bits),
                    "{wo} {u}"
                );
            }
        }
        assert!(
            reflected > 50_000 && transmitted > 20_000,
            "{reflected} {transmitted}"
        );
    }
}
