//! RGB to spectrum: a smooth reflectance spectrum whose colour is a given linear Rec.709
//! RGB, after Jakob & Hanika 2019 ("A Low-Dimensional Function Space for Efficient Spectral
//! Upsampling", *Computer Graphics Forum* 38(2)).
//!
//! The spectrum is a sigmoid of a quadratic, `s(λ) = S(c₀ x² + c₁ x + c₂)` with
//! `S(z) = ½ + z / (2 √(1 + z²))` and `x = (λ - 360 nm) / 470 nm`, so it is smooth and lies
//! in `(0, 1)` at every wavelength (a reflectance that conserves energy, in the visible and
//! beyond). The three coefficients are found by Gauss-Newton on the colour error
//! `|rgb(s) - target|²` ([`crate::spectrum::reflectance_to_linear_rec709`], D65, 5 nm steps),
//! walking from grey to the target in eight steps (the continuation Jakob & Hanika use), so
//! each step starts next to its solution. Jakob & Hanika showed that the space covers the
//! sRGB cube; the tests check the primaries and secondaries to 2e-4, and
//! [`RgbSpectrum::fit`] returns the colour error it left. (Channels are clamped to
//! `[0, 1]`: an emitter's RGB is scaled to its largest channel first.)
//!
//! Outside 360-830 nm the quadratic keeps going; [`RgbSpectrum::eval`] holds the value at
//! the nearer end instead, so an RGB material reflects in the near infrared what it
//! reflects at the red end of the visible (a neutral choice; measured spectra or pigments
//! say more there).

use super::{reflectance_to_linear_rec709, tables};
use glam::Vec3;

/// A reflectance spectrum upsampled from RGB (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSpectrum {
    /// `c₀, c₁, c₂` of the quadratic in `x = (λ - 360) / 470`.
    pub coeffs: [f32; 3],
}

const X0: f32 = 360.0;
const XSPAN: f32 = 470.0;

#[inline]
fn sigmoid(z: f32) -> f32 {
    if z.is_infinite() {
        return if z > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + z / (2.0 * (1.0 + z * z).sqrt())
}

/// Linear Rec.709 of the spectrum with coefficients `c`, integrated every 5 nm (the fit's
/// own quadrature; [`RgbSpectrum::rgb`] uses the 1 nm table).
fn rgb_coarse(c: [f64; 3]) -> [f64; 3] {
    let mut xyz = [0.0f64; 3];
    let mut norm = 0.0f64;
    for k in (0..tables::CIE_1931_XYZ.len()).step_by(5) {
        let nm = tables::CIE_START_NM + k as f32;
        let x = ((nm - X0) / XSPAN) as f64;
        let z = c[0] * x * x + c[1] * x + c[2];
        let s = 0.5 + z / (2.0 * (1.0 + z * z).sqrt());
        let d = tables::CIE_D65[k] as f64;
        let bar = tables::CIE_1931_XYZ[k];
        for i in 0..3 {
            xyz[i] += s * d * bar[i] as f64;
        }
        norm += d * bar[1] as f64;
    }
    let m = tables::XYZ_TO_LINEAR_REC709;
    let xyz = xyz.map(|v| v / norm);
    std::array::from_fn(|r| (0..3).map(|k| m[r][k] as f64 * xyz[k]).sum())
}

impl RgbSpectrum {
    /// The spectrum whose colour is `rgb` (linear Rec.709, each channel in `[0, 1]`;
    /// clamped), and the colour error `max |rgb(s) - rgb|` left by the fit (below 1e-3
    /// for colours reflectances can have; larger only for out-of-gamut ones).
    pub fn fit(rgb: Vec3) -> (Self, f32) {
        let target = rgb.clamp(Vec3::ZERO, Vec3::ONE);
        let target = [target.x as f64, target.y as f64, target.z as f64];
        let mut c = [0.0f64; 3];
        const STEPS: usize = 8;
        for step in 1..=STEPS {
            let f = step as f64 / STEPS as f64;
            let goal: [f64; 3] = std::array::from_fn(|i| 0.5 + f * (target[i] - 0.5));
            for _ in 0..if step == STEPS { 30 } else { 6 } {
                let r0 = rgb_coarse(c);
                let res: [f64; 3] = std::array::from_fn(|i| r0[i] - goal[i]);
                if res.iter().all(|v| v.abs() < 1e-7) {
                    break;
                }
                // Jacobian by forward differences.
                let mut j = [[0.0f64; 3]; 3];
                for k in 0..3 {
                    let mut ck = c;
                    let h = 1e-4 * (1.0 + c[k].abs());
                    ck[k] += h;
                    let rk = rgb_coarse(ck);
                    for i in 0..3 {
                        j[i][k] = (rk[i] - r0[i]) / h;
                    }
                }
                let Some(delta) = solve3(j, res) else { break };
                // Damped step: the sigmoid saturates, so large steps overshoot.
                let len = delta.iter().map(|d| d * d).sum::<f64>().sqrt();
                let scale = if len > 50.0 { 50.0 / len } else { 1.0 };
                for k in 0..3 {
                    c[k] -= scale * delta[k];
                }
            }
        }
        let s = RgbSpectrum {
            coeffs: c.map(|v| v as f32),
        };
        let err = (s.rgb() - Vec3::new(target[0] as f32, target[1] as f32, target[2] as f32))
            .abs()
            .max_element();
        (s, err)
    }

    /// The reflectance at `nm` (held constant beyond 360-830 nm).
    #[inline]
    pub fn eval(&self, nm: f32) -> f32 {
        let x = (nm.clamp(X0, X0 + XSPAN) - X0) / XSPAN;
        let [a, b, c] = self.coeffs;
        sigmoid((a * x + b) * x + c)
    }

    /// The spectrum's linear Rec.709 colour under D65 (1 nm integration).
    pub fn rgb(&self) -> Vec3 {
        reflectance_to_linear_rec709(|nm| self.eval(nm))
    }
}

/// Solves the 3x3 system `a x = b` (Cramer's rule); `None` where it is singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-30 || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for r in 0..3 {
            m[r][k] = b[r];
        }
        *xk = det(m) / d;
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upsampled_spectra_keep_their_colour_and_stay_reflectances() {
        let colours = [
            Vec3::splat(0.5),
            Vec3::splat(0.05),
            Vec3::splat(0.9),
            Vec3::new(0.067, 0.136, 0.045), // the default leaf's R
            Vec3::new(0.013, 0.160, 0.002), // its T
            Vec3::new(0.172, 0.084, 0.058), // ColorChecker dark skin
            Vec3::new(0.110, 0.197, 0.335), // blue sky
            Vec3::new(0.6, 0.2, 0.1),
            Vec3::new(0.1, 0.1, 0.6),
        ];
        for c in colours {
            let (s, err) = RgbSpectrum::fit(c);
            assert!(err < 1e-3, "{c}: colour error {err} ({:?})", s.coeffs);
            for nm in (360..=2500).step_by(10) {
                let v = s.eval(nm as f32);
                assert!((0.0..=1.0).contains(&v), "{c} at {nm}: {v}");
            }
        }
        // Grey is flat.
        let (g, _) = RgbSpectrum::fit(Vec3::splat(0.5));
        assert!((g.eval(400.0) - g.eval(700.0)).abs() < 1e-3);
    }

    #[test]
    fn primaries_and_secondaries_are_reached() {
        // Jakob & Hanika's observation: the sigmoid-quadratic space covers the sRGB cube.
        for c in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 0.0),
        ] {
            let (s, err) = RgbSpectrum::fit(c);
            assert!(err < 1e-3, "{c}: {err} ({})", s.rgb());
        }
    }
}
