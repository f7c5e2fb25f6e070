//! Warps from the unit square to directions, with their densities.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Concentric map of the unit square to the unit disk (Shirley & Chiu 1997).
///
/// Written without a branch on which of `|x|`, `|y|` is larger: the two cases share one
/// division and pick their operands by selects, since with random `u` that branch is
/// mispredicted half the time (it was a tenth of a diffuse BSDF sample's cost).
#[inline]
pub fn square_to_disk(u: Vec2) -> Vec2 {
    let (r, dir) = concentric(u);
    r * dir
}

/// [`square_to_disk`] as `(r, dir)`, the point `r · dir` with `dir` the unit direction of
/// its angle (unit within rounding) and `|r|` its distance from the centre.
#[inline]
fn concentric(u: Vec2) -> (f32, Vec2) {
    let p = 2.0 * u - Vec2::ONE;
    if p.x == 0.0 && p.y == 0.0 {
        return (0.0, Vec2::ZERO);
    }
    let x_major = p.x.abs() > p.y.abs();
    let (r, other) = if x_major { (p.x, p.y) } else { (p.y, p.x) };
    // The angle is `a` (x major) or `π/2 - a` (y major), `|a| <= π/4`: its cosine and
    // sine are `a`'s, in one order or the other, from short series on that range.
    let a = std::f32::consts::FRAC_PI_4 * (other / r);
    let (c, s) = cos_sin_quarter(a);
    let (x, y) = if x_major { (c, s) } else { (s, c) };
    (r, Vec2::new(x, y))
}

/// `(cos a, sin a)` for `|a| <= π/4`, within 2 units in the last place of the libm
/// values: Taylor series to degree 10 and 11 (their next terms are below 3e-9 on the
/// range), without the general functions' range reduction and call, each evaluated in
/// pairs of terms (Estrin's scheme) so that its chain of dependent operations is short.
/// Public for code that runs the concentric map in vector lanes (lamina-render's wavefront
/// path tracer), so that its lanes compute these very values.
#[inline]
pub fn cos_sin_quarter(a: f32) -> (f32, f32) {
    let x = a * a;
    let (x2, x4) = (x * x, (x * x) * (x * x));
    let c01 = 1.0 - 0.5 * x;
    let c23 = 1.0 / 24.0 - (1.0 / 720.0) * x;
    let c45 = 1.0 / 40_320.0 - (1.0 / 3_628_800.0) * x;
    let c = (c01 + x2 * c23) + x4 * c45;
    let s01 = 1.0 - (1.0 / 6.0) * x;
    let s23 = 1.0 / 120.0 - (1.0 / 5_040.0) * x;
    let s45 = 1.0 / 362_880.0 - (1.0 / 39_916_800.0) * x;
    let s = a * ((s01 + x2 * s23) + x4 * s45);
    (c, s)
}

/// Cosine-weighted direction on the `+z` hemisphere; density [`cosine_hemisphere_pdf`].
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let (r, dir) = concentric(u);
    // The disk point lies `|r|` from the centre: the height is computed from `r` alone,
    // beside the angle's arithmetic rather than after it. Unit within 1e-6.
    let z = (1.0 - r * r).max(0.0).sqrt();
    Vec3::new(r * dir.x, r * dir.y, z)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::march::Pcg32;

    /// Shirley & Chiu's map as first written, with a branch per case.
    fn square_to_disk_branched(u: Vec2) -> Vec2 {
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

    /// [`cos_sin_quarter`] against libm's over the whole range, ends included: within 2
    /// ulp (of the larger of the value and 2⁻²⁴, near zero), `cos² + sin²` within 4e-7 of 1.
    #[test]
    fn cos_sin_quarter_is_libm_within_two_ulp() {
        let q = std::f32::consts::FRAC_PI_4;
        let n = 1_000_000;
        let mut worst = 0.0f32;
        for i in 0..=n {
            let a = -q + 2.0 * q * (i as f32 / n as f32);
            for a in [a, a.clamp(-q, q), -a] {
                let (c, s) = cos_sin_quarter(a);
                let (want_s, want_c) = a.sin_cos();
                for (got, want) in [(c, want_c), (s, want_s)] {
                    let ulp = (want.abs().max(1.0 / 16_777_216.0)) * f32::EPSILON;
                    let e = (got - want).abs() / ulp;
                    worst = worst.max(e);
                    assert!(e <= 2.0, "a = {a}: {got} vs {want} ({e} ulp)");
                }
                assert!((c * c + s * s - 1.0).abs() < 4e-7, "a = {a}");
            }
        }
        assert!(worst > 0.0, "compared something");
    }

    /// Cosine-weighted directions are unit within 1e-6 and on the `+z` side, over the
    /// square (its centre, edges and corners included), and their mean `z` is 2/3.
    #[test]
    fn cosine_hemisphere_is_unit_and_cosine_weighted() {
        let mut rng = Pcg32::new(5);
        let mut sum = 0.0f64;
        let n = 400_000;
        let edges = [0.0, 0.5, 1.0 - f32::EPSILON / 2.0];
        let fixed = edges
            .iter()
            .flat_map(|&a| edges.iter().map(move |&b| Vec2::new(a, b)));
        for u in fixed.chain((0..n).map(|_| Vec2::new(rng.next_f32(), rng.next_f32()))) {
            let w = cosine_hemisphere(u);
            assert!((w.length_squared() - 1.0).abs() <= 1e-6, "{u}: {w}");
            assert!(w.z >= 0.0, "{u}: {w}");
            sum += f64::from(w.z);
        }
        let mean = sum / (n + 9) as f64;
        assert!((mean - 2.0 / 3.0).abs() < 2e-3, "mean z {mean}");
    }

    #[test]
    fn square_to_disk_is_the_branched_map() {
        let mut rng = Pcg32::new(17);
        let mut points: Vec<Vec2> = (0..200_000)
            .map(|_| Vec2::new(rng.next_f32(), rng.next_f32()))
            .collect();
        // The centre, the diagonals (|x| = |y|), the axes and the corners.
        for &a in &[0.0, 0.25, 0.5, 0.75, 1.0 - f32::EPSILON / 2.0] {
            for &b in &[0.0, 0.25, 0.5, 0.75, 1.0 - f32::EPSILON / 2.0, a, 1.0 - a] {
                points.push(Vec2::new(a, b));
            }
        }
        for u in points {
            let (got, want) = (square_to_disk(u), square_to_disk_branched(u));
            // The same point but for the last bits of the cosine and sine (above).
            assert!(
                (got - want).abs().max_element() <= 3.0 * f32::EPSILON,
                "{u}: {got} vs {want}"
            );
            assert!(got.length() <= 1.0 + 1e-6, "{u}: {got}");
        }
    }
}
