//! Warps from the unit square to directions, with their densities.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Concentric map of the unit square to the unit disk (Shirley & Chiu 1997).
#[inline]
pub fn square_to_disk(u: Vec2) -> Vec2 {
    let p = 2.0 * u - Vec2::ONE;
    if p.x == 0.0 && p.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if p.x.abs() > p.y.abs() {
        (p.x, std::f32::consts::FRAC_PI_4 * (p.y / p.x))
    } else {
        (
            p.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (p.x / p.y),
        )
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the `+z` hemisphere; density [`cosine_hemisphere_pdf`].
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`cosine_hemisphere`] at `cos θ` (zero below the horizon).
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 0.25 * FRAC_1_PI;

/// Rec.709 luminance of a linear RGB colour.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// A 32-bit integer hash with good avalanche (C. Wellons' `lowbias32` finaliser), shared by
/// the renderer's sampler and the procedural noise of the leaf maps.
#[inline]
pub const fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}
