//! The layered slab at one texel: three homogeneous layers with their thicknesses, indices
//! of refraction and coefficients, plus the optics of their borders (Snell, Fresnel) and the
//! Henyey-Greenstein phase function.

use crate::params::LeafParams;
use glam::Vec3;
use std::f32::consts::PI;

/// One homogeneous layer at a texel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layer {
    /// Thickness in millimetres.
    pub d: f32,
    /// Index of refraction.
    pub ior: f32,
    /// Absorption coefficient per linear-RGB channel, 1/mm.
    pub sigma_a: Vec3,
    /// Scattering coefficient per linear-RGB channel, 1/mm.
    pub sigma_s: Vec3,
}

impl Layer {
    /// Extinction coefficient `sigma_a + sigma_s`, 1/mm.
    #[inline]
    pub fn sigma_t(&self) -> Vec3 {
        self.sigma_a + self.sigma_s
    }
}

/// The three layers at a texel, listed from the side the light is treated as entering
/// (index 0) to the far side. [`LayerStack::at_texel`] lists them adaxial first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerStack {
    /// Layers, first = the `+z` side of the frame the stack is used in.
    pub layers: [Layer; 3],
    /// Henyey-Greenstein asymmetry of single scattering, shared by the layers.
    pub g: f32,
}

impl LayerStack {
    /// The stack at a texel whose thickness map reads `t` and extinction map reads `e`
    /// (both in `[0, 1]`, 0.5 = nominal), upper epidermis first.
    pub fn at_texel(p: &LeafParams, t: f32, e: f32) -> Self {
        let t = t.clamp(0.0, 1.0);
        let e = e.clamp(0.0, 1.0);
        let thickness = p.thickness_mm * (1.0 + p.thickness_variation * (2.0 * t - 1.0));
        let absorb = 1.0 + p.extinction_strength * (2.0 * e - 1.0);
        let layers = p.layers().map(|l| Layer {
            d: thickness * l.fraction,
            ior: l.ior,
            sigma_a: l.absorption * absorb,
            sigma_s: l.scattering,
        });
        LayerStack {
            layers,
            g: p.phase_g,
        }
    }

    /// The same slab seen from the other side (layer order reversed).
    #[inline]
    pub fn flipped(&self) -> Self {
        let [a, b, c] = self.layers;
        LayerStack {
            layers: [c, b, a],
            g: self.g,
        }
    }

    /// Index of refraction of the medium on the far side of border `b` (border 0 is the
    /// outer surface on the entry side, border 3 the outer surface on the far side), and on
    /// its near side. Outside the leaf is air (1.0).
    #[inline]
    pub fn border_iors(&self, b: usize) -> (f32, f32) {
        let near = if b == 0 { 1.0 } else { self.layers[b - 1].ior };
        let far = if b == 3 { 1.0 } else { self.layers[b].ior };
        (near, far)
    }
}

/// Cosine of the refracted angle inside a medium of index `n` (relative to air) for a
/// direction whose cosine outside is `cos_out`. Never total internal reflection: `n >= 1`.
#[inline]
pub fn refracted_cos(cos_out: f32, n: f32) -> f32 {
    // `1 - (1 - c^2) / n^2` written as `((n - 1)(n + 1) + c^2) / n^2`, which does not cancel
    // for indices near 1 at grazing angles.
    (((n - 1.0) * (n + 1.0) + cos_out * cos_out).max(0.0)).sqrt() / n
}

/// Unpolarised Fresnel reflectance of a smooth dielectric border, for light arriving at
/// cosine `cos_i` (`>= 0`) in a medium of index `n_i` onto a medium of index `n_t`;
/// `eta = n_t / n_i`. Returns 1 under total internal reflection.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Fresnel transmission `1 - F` (unpolarised: the mean of `1 - r_s^2` and `1 - r_p^2`) of
/// the smooth border between a medium of index `n_a`, where the ray's cosine to the normal
/// is `c_a`, and one of index `n_b` with cosine `c_b` (Snell's
/// law already applied, so no square root here). Written symmetric in the two sides, so the
/// border gives the same bits seen from either (the mirror average relies on it); `1`
/// exactly between equal indices.
#[inline(always)]
pub fn border_t(n_a: f32, c_a: f32, n_b: f32, c_b: f32) -> f32 {
    if n_a == n_b {
        return 1.0;
    }
    // `1 - r^2 = (1 - r)(1 + r)` for `r = (a - b) / (a + b)`, which does not cancel at
    // grazing angles where `F` approaches 1.
    let (a, b) = (n_a * c_a, n_b * c_b);
    let (p, q) = (n_b * c_a, n_a * c_b);
    let (s, t) = (a + b, p + q);
    let (s2, t2) = (s * s, t * t);
    2.0 * (a * b * t2 + p * q * s2) / (s2 * t2)
}

/// Fresnel transmission `1 - F` of a smooth dielectric border for light arriving at cosine
/// `cos_i` (`>= 0`) in a medium of index `n_i` onto one of index `n_t` (`eta = n_t / n_i`):
/// [`fresnel_dielectric`]'s complement, computed by [`border_t`] so that it keeps its
/// precision at grazing angles, where `F` approaches 1; 0 under total internal reflection.
#[inline]
pub fn fresnel_transmission(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 0.0;
    }
    border_t(1.0, cos_i, eta, (1.0 - sin2_t).sqrt())
}

/// Hemispherical average `∫ F(μ) 2μ dμ` of the Fresnel reflectance for diffuse light
/// arriving from the medium of index `n_i` onto `n_t` (numerical, 256 midpoints).
pub fn fresnel_diffuse(n_i: f32, n_t: f32) -> f32 {
    const N: usize = 256;
    let eta = n_t / n_i;
    (0..N)
        .map(|k| {
            let mu = (k as f32 + 0.5) / N as f32;
            fresnel_dielectric(mu, eta) * 2.0 * mu / N as f32
        })
        .sum()
}

/// Henyey-Greenstein phase function (1/sr) for the cosine between the propagation
/// directions before and after scattering; integrates to 1 over the sphere.
#[inline]
pub fn henyey_greenstein(cos: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * denom * denom.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_limits() {
        let f0 = ((1.5f32 - 1.0) / 2.5).powi(2);
        assert!((fresnel_dielectric(1.0, 1.5) - f0).abs() < 1e-6);
        assert!(fresnel_dielectric(0.0, 1.5) > 0.999);
        assert_eq!(fresnel_dielectric(0.1, 1.0 / 1.5), 1.0);
        // Diffuse reflectance from inside: 1 - (1 - r_out) / n^2.
        let r_out = fresnel_diffuse(1.0, 1.5);
        let r_in = fresnel_diffuse(1.5, 1.0);
        assert!(
            (r_in - (1.0 - (1.0 - r_out) / 2.25)).abs() < 2e-3,
            "{r_in} {r_out}"
        );
    }

    #[test]
    fn transmission_is_the_complement_and_keeps_precision_at_grazing() {
        for eta in [1.0 / 1.5, 1.0, 1.33, 1.5, 2.0] {
            for k in 0..=100 {
                let c = k as f32 / 100.0;
                let sum = fresnel_transmission(c, eta) + fresnel_dielectric(c, eta);
                assert!((sum - 1.0).abs() < 1e-6, "eta {eta} cos {c}: R + T = {sum}");
            }
        }
        // Near grazing `1 - F` is proportional to the cosine: f32 `1 - F` has lost most of
        // its digits there, the transmission has not.
        let (t1, t2) = (
            fresnel_transmission(1e-4, 1.5),
            fresnel_transmission(2e-4, 1.5),
        );
        assert!(t1 > 0.0 && (t2 / t1 - 2.0).abs() < 1e-3, "{t1} {t2}");
    }

    #[test]
    fn hg_normalised() {
        for g in [-0.5, 0.0, 0.3, 0.8] {
            let n = 20000;
            let s: f32 = (0..n)
                .map(|k| {
                    let c = -1.0 + 2.0 * (k as f32 + 0.5) / n as f32;
                    henyey_greenstein(c, g) * 2.0 * PI * 2.0 / n as f32
                })
                .sum();
            assert!((s - 1.0).abs() < 1e-3, "g {g}: {s}");
        }
    }
}
