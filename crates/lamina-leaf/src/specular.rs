//! The surface (specular) lobe: a GGX microfacet dielectric reflection (Walter et al. 2007)
//! with the height-correlated Smith masking-shadowing and the unpolarised Fresnel
//! reflectance of the epidermis, sampled through the distribution of visible normals
//! (Heitz 2018). Directions are in a frame whose `+z` is the (shading) normal of the side
//! the viewer is on.

use crate::layers::fresnel_dielectric;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// GGX normal distribution `D(wm)` (1/sr) for roughness `alpha`.
#[inline]
pub fn ggx_d(wm: Vec3, alpha: f32) -> f32 {
    if wm.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let c2 = wm.z * wm.z;
    let t = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

/// Smith `Lambda(w)` for GGX.
#[inline]
pub fn ggx_lambda(w: Vec3, alpha: f32) -> f32 {
    let c2 = w.z * w.z;
    if c2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan2 = (1.0 - c2).max(0.0) / c2;
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// Smith masking `G1(w)`.
#[inline]
pub fn ggx_g1(w: Vec3, alpha: f32) -> f32 {
    1.0 / (1.0 + ggx_lambda(w, alpha))
}

/// The microfacet normal reflecting `wo` into `wi`, when both lie above the surface (`+z`)
/// and are not opposite.
#[inline]
fn half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return None;
    }
    let h = wo + wi;
    let len2 = h.length_squared();
    (len2 > 1e-12).then(|| h / len2.sqrt())
}

/// `f_spec(wo, wi) cos θi` of the dielectric GGX reflection lobe (both directions on `+z`,
/// else 0); `eta` is the index of the epidermis relative to air.
#[inline]
pub fn eval(wo: Vec3, wi: Vec3, alpha: f32, eta: f32) -> f32 {
    // `F D G2 / (4 cos_o)` with the factors written over one division. With `h = wo + wi`
    // (unnormalised, `|h|^2 = L`), `D = a^2 L^2 / (pi t^2)` where `t = h_z^2 (a^2 - 1) + L`,
    // and `1 + Lambda_o + Lambda_i = (c_i s_o + c_o s_i) / (2 c_o c_i)` where
    // `s = sqrt(c^2 + a^2 (1 - c^2))`; so the value is
    // `F a^2 L^2 c_i / (2 pi t^2 (c_i s_o + c_o s_i))`.
    let (co, ci) = (wo.z, wi.z);
    if co <= 0.0 || ci <= 0.0 {
        return 0.0;
    }
    let h = wo + wi;
    let len2 = h.length_squared();
    if len2 <= 1e-12 {
        return 0.0;
    }
    let f = fresnel_dielectric(wo.dot(h) / len2.sqrt(), eta);
    let a2 = alpha * alpha;
    let t = h.z * h.z * (a2 - 1.0) + len2;
    let s = |c: f32| (c * c + a2 * (1.0 - c * c).max(0.0)).sqrt();
    f * a2 * len2 * len2 * ci / (2.0 * PI * t * t * (ci * s(co) + co * s(ci)))
}

/// Density (1/sr) of [`sample`] returning `wi` for `wo`: `G1(wo) D(wm) / (4 wo.z)`, zero
/// where `wi` is below the surface (those samples are rejected).
#[inline]
pub fn pdf(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let Some(wm) = half_vector(wo, wi) else {
        return 0.0;
    };
    ggx_g1(wo, alpha) * ggx_d(wm, alpha) / (4.0 * wo.z)
}

/// Samples a visible microfacet normal (Heitz 2018, "Sampling the GGX distribution of
/// visible normals") and reflects `wo` about it. `None` when the reflection points below the
/// surface.
#[inline]
pub fn sample(wo: Vec3, alpha: f32, u: Vec2) -> Option<Vec3> {
    if wo.z <= 0.0 {
        return None;
    }
    // Stretch to the hemisphere configuration.
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * phi.sin());
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let wm = Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(1e-7)).normalize();
    let wi = 2.0 * wo.dot(wm) * wm - wo;
    (wi.z > 0.0).then_some(wi)
}

/// Directional albedo of the lobe for `wo` (fraction of light reflected specularly),
/// estimated with `n * n` stratified visible-normal samples.
pub fn albedo(wo: Vec3, alpha: f32, eta: f32, n: u32) -> f32 {
    let mut s = 0.0;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            if let Some(wi) = sample(wo, alpha, u) {
                let p = pdf(wo, wi, alpha);
                if p > 0.0 {
                    s += eval(wo, wi, alpha, eta) / p;
                }
            }
        }
    }
    s / (n * n) as f32
}
