//! Multiple scattering ("diffusion", the `1 +` of the paper's Eq. (1)) from the layer
//! parameters: Kubelka-Munk per layer, combined with the adding equations.
//!
//! Each layer is a Kubelka-Munk two-flux slab with absorption `K = 2 sigma_a` and
//! scattering `S = sigma_s (1 - g)` per mm: the factor 2 is the mean path-length increase of
//! diffuse light, `sigma_s (1 - g)` the similarity-reduced scattering coefficient, so that
//! forward scattering (`g > 0`) scatters back less. The borders between media (air and the
//! epidermis, epidermis and mesophyll ...) are diffuse Fresnel interfaces with the
//! hemispherical Fresnel reflectance from the denser side obeying `1 - r_in = (1 - r_out)
//! / n^2`. Layers and interfaces are stacked with the adding equations (Stokes 1862;
//! e.g. Yamada & Fujimura 1991 for leaves), giving the slab's diffuse reflectance from
//! either side and its transmittance.
//!
//! The result is used as hemispherical albedos of Lambertian-like lobes whose angular shape
//! is the Fresnel transmission of the outer surface, normalised:
//! `f_ms(wo, wi) = R_ms t(wi) t(wo) / pi` with `t(w) = (1 - F(w)) / (1 - r_out)`. The
//! outer surface's own reflection is excluded from `R_ms` (it is the specular lobe).
//! Single scattering ([`crate::analytic`]) is added on top, as in Jensen et al. 2001 whose
//! model the paper adapts; the first scattering order is thereby partly counted twice,
//! which the texture normalisation in [`crate::material`] absorbs.

use crate::layers::{Layer, LayerStack};
use glam::{Vec3, Vec4};

/// Diffuse (hemispherical) reflectances and transmittances of a slab, per linear-RGB
/// channel. "Top" is layer 0's side (`+z` for an unflipped stack).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slab {
    /// Reflectance for diffuse light arriving at the top.
    pub r_top: Vec3,
    /// Transmittance from top to bottom.
    pub t_down: Vec3,
    /// Reflectance for diffuse light arriving at the bottom.
    pub r_bottom: Vec3,
    /// Transmittance from bottom to top.
    pub t_up: Vec3,
}

impl Slab {
    /// An interface between a medium above with hemispherical Fresnel reflectance `r_above`
    /// (diffuse light arriving from above) and `r_below` (from below).
    pub fn interface(r_above: f32, r_below: f32) -> Self {
        Slab {
            r_top: Vec3::splat(r_above),
            t_down: Vec3::splat(1.0 - r_above),
            r_bottom: Vec3::splat(r_below),
            t_up: Vec3::splat(1.0 - r_below),
        }
    }

    /// A Kubelka-Munk layer (symmetric).
    pub fn kubelka_munk(layer: &Layer, g: f32) -> Self {
        let k = 2.0 * layer.sigma_a;
        let s = layer.sigma_s * (1.0 - g);
        let rt = [0, 1, 2].map(|c| km(k[c], s[c], layer.d));
        let r = Vec3::new(rt[0].0, rt[1].0, rt[2].0);
        let t = Vec3::new(rt[0].1, rt[1].1, rt[2].1);
        Slab {
            r_top: r,
            t_down: t,
            r_bottom: r,
            t_up: t,
        }
    }

    /// `self` on top of `below` (adding equations with all inter-reflections).
    pub fn over(&self, below: &Slab) -> Slab {
        let denom = Vec3::ONE / (Vec3::ONE - self.r_bottom * below.r_top).max(Vec3::splat(1e-6));
        Slab {
            r_top: self.r_top + self.t_down * self.t_up * below.r_top * denom,
            t_down: self.t_down * below.t_down * denom,
            r_bottom: below.r_bottom + below.t_up * below.t_down * self.r_bottom * denom,
            t_up: below.t_up * self.t_up * denom,
        }
    }
}

/// `tanh x` and `sech x = 1 / cosh x` for `x >= 0` from one exponential (libm's `tanh`
/// and `cosh` take one each): `e^{-2x} - 1` by `exp_m1` below 0.5, where `1 - e^{-2x}`
/// would cancel, with `sech = sqrt((1 - th)(1 + th))`; `q = e^{-x}` above, with
/// `tanh = (1 - q^2) / (1 + q^2)`, `sech = 2q / (1 + q^2)`. Within a few units in the last
/// place of the libm values (see the tests); `sech` keeps its tail `2 e^{-x}` for large `x`.
#[inline]
fn tanh_sech(x: f32) -> (f32, f32) {
    if x < 0.5 {
        let m = (-2.0 * x).exp_m1();
        let th = -m / (2.0 + m);
        (th, ((1.0 - th) * (1.0 + th)).sqrt())
    } else {
        let q = (-x).exp();
        let e = q * q;
        ((1.0 - e) / (1.0 + e), 2.0 * q / (1.0 + e))
    }
}

/// Kubelka-Munk reflectance and transmittance of one slab (`k`, `s` per mm, `d` in mm).
fn km(k: f32, s: f32, d: f32) -> (f32, f32) {
    if s * d < 1e-7 {
        return (0.0, (-k * d).exp());
    }
    let a = (s + k) / s;
    let b = (a * a - 1.0).max(0.0).sqrt();
    let x = b * s * d;
    if x < 1e-6 {
        // Non-absorbing limit: R = S d / (1 + S d).
        let sd = s * d;
        return (sd / (1.0 + sd), 1.0 / (1.0 + sd));
    }
    // Divide numerator and denominator by cosh(x) to avoid overflow.
    let (th, sech) = tanh_sech(x);
    let den = a * th + b;
    (th / den, b * sech / den)
}

/// Hemispherical Fresnel reflectances of the four borders of a stack (air, layer 0, 1, 2,
/// air), for diffuse light arriving from above and from below each border.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BorderReflectances {
    /// Border `b` from above (medium `b-1` onto medium `b`).
    pub from_above: [f32; 4],
    /// Border `b` from below.
    pub from_below: [f32; 4],
}

impl BorderReflectances {
    /// Computes the four borders' diffuse Fresnel reflectances of `stack`.
    pub fn new(stack: &LayerStack) -> Self {
        let mut from_above = [0.0; 4];
        let mut from_below = [0.0; 4];
        for b in 0..4 {
            let (near, far) = stack.border_iors(b);
            from_above[b] = crate::layers::fresnel_diffuse(near, far);
            from_below[b] = crate::layers::fresnel_diffuse(far, near);
        }
        BorderReflectances {
            from_above,
            from_below,
        }
    }

    /// The same borders seen from the other side.
    pub fn flipped(&self) -> Self {
        let mut a = self.from_below;
        let mut b = self.from_above;
        a.reverse();
        b.reverse();
        BorderReflectances {
            from_above: a,
            from_below: b,
        }
    }
}

/// The diffusion term of a stack: diffuse reflectance seen from the top (layer 0 side) and
/// from the bottom, without the outer surfaces' own reflection, and the transmittance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diffusion {
    /// Diffuse reflectance from the layer-0 side, surface reflection excluded.
    pub r_top: Vec3,
    /// Diffuse reflectance from the layer-2 side, surface reflection excluded.
    pub r_bottom: Vec3,
    /// Diffuse transmittance (the same both ways: the adding equations are reciprocal).
    pub t: Vec3,
}

/// [`Slab`] in four lanes (linear RGB and an unused fourth, zero), for [`diffusion`]: the
/// same operations per channel as [`Slab::over`], so the same values, with one division
/// instruction per step instead of three.
#[derive(Clone, Copy, Debug)]
struct Slab4 {
    r_top: Vec4,
    t_down: Vec4,
    r_bottom: Vec4,
    t_up: Vec4,
}

impl Slab4 {
    #[inline]
    fn interface(r_above: f32, r_below: f32) -> Self {
        Slab4 {
            r_top: Vec4::splat(r_above),
            t_down: Vec4::splat(1.0 - r_above),
            r_bottom: Vec4::splat(r_below),
            t_up: Vec4::splat(1.0 - r_below),
        }
    }

    #[inline]
    fn kubelka_munk(layer: &Layer, g: f32) -> Self {
        let s = Slab::kubelka_munk(layer, g);
        Slab4 {
            r_top: s.r_top.extend(0.0),
            t_down: s.t_down.extend(0.0),
            r_bottom: s.r_bottom.extend(0.0),
            t_up: s.t_up.extend(0.0),
        }
    }

    /// [`Slab::over`].
    #[inline]
    fn over(&self, below: &Slab4) -> Slab4 {
        let denom = Vec4::ONE / (Vec4::ONE - self.r_bottom * below.r_top).max(Vec4::splat(1e-6));
        Slab4 {
            r_top: self.r_top + self.t_down * self.t_up * below.r_top * denom,
            t_down: self.t_down * below.t_down * denom,
            r_bottom: below.r_bottom + below.t_up * below.t_down * self.r_bottom * denom,
            t_up: below.t_up * self.t_up * denom,
        }
    }
}

/// Kubelka-Munk plus adding for the whole stack, outer borders included.
pub fn diffusion(stack: &LayerStack, borders: &BorderReflectances) -> Diffusion {
    let iface = |b: usize| Slab4::interface(borders.from_above[b], borders.from_below[b]);
    let mut s = iface(0);
    for k in 0..3 {
        s = s
            .over(&Slab4::kubelka_munk(&stack.layers[k], stack.g))
            .over(&iface(k + 1));
    }
    Diffusion {
        r_top: (s.r_top.truncate() - Vec3::splat(borders.from_above[0])).max(Vec3::ZERO),
        r_bottom: (s.r_bottom.truncate() - Vec3::splat(borders.from_below[3])).max(Vec3::ZERO),
        t: 0.5 * (s.t_down.truncate() + s.t_up.truncate()),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    #[test]
    fn km_limits_and_energy() {
        // Thick non-absorbing slab reflects almost everything.
        let (r, t) = km(0.0, 10.0, 100.0);
        assert!(r > 0.99 && t < 0.01);
        // Semi-infinite absorbing slab: R_inf = a - b.
        let (k, s) = (1.0f32, 3.0f32);
        let a = (s + k) / s;
        let (r, _) = km(k, s, 1e3);
        assert!((r - (a - (a * a - 1.0).sqrt())).abs() < 1e-5);
        for (k, s, d) in [(0.5, 2.0, 0.3), (10.0, 40.0, 0.2), (0.0, 1.0, 1.0)] {
            let (r, t) = km(k, s, d);
            assert!(r >= 0.0 && t >= 0.0 && r + t <= 1.0 + 1e-6, "{r} {t}");
        }
    }

    /// `km` as it was (libm `tanh` and `cosh`).
    pub(crate) fn old_km(k: f32, s: f32, d: f32) -> (f32, f32) {
        if s * d < 1e-7 {
            return (0.0, (-k * d).exp());
        }
        let a = (s + k) / s;
        let b = (a * a - 1.0).max(0.0).sqrt();
        let x = b * s * d;
        if x < 1e-6 {
            let sd = s * d;
            return (sd / (1.0 + sd), 1.0 / (1.0 + sd));
        }
        let th = x.tanh();
        let sech = if x > 40.0 {
            2.0 * (-x).exp()
        } else {
            1.0 / x.cosh()
        };
        let den = a * th + b;
        (th / den, b * sech / den)
    }

    /// Relative difference, against an absolute floor of `1e-30`.
    fn rel(a: f32, b: f32) -> f32 {
        (a - b).abs() / a.abs().max(b.abs()).max(1e-30)
    }

    #[test]
    fn one_exponential_tanh_and_sech_match_libm() {
        let mut worst = (0.0f32, 0.0f32);
        for i in 0..200_000 {
            let x = 1e-6 * 1.0001f32.powi(i);
            if x > 80.0 {
                break;
            }
            let (th, sech) = tanh_sech(x);
            worst.0 = worst.0.max(rel(th, x.tanh()));
            let sech_libm = if x > 40.0 {
                2.0 * (-x).exp()
            } else {
                1.0 / x.cosh()
            };
            worst.1 = worst.1.max(rel(sech, sech_libm));
        }
        // A few units in the last place (2^-23 = 1.2e-7).
        eprintln!("tanh, sech: largest relative difference {worst:?}");
        assert!(worst.0 < 5e-7 && worst.1 < 5e-7, "{worst:?}");
    }

    #[test]
    fn kubelka_munk_matches_the_libm_version() {
        let mut rng = crate::march::Pcg32::new(8);
        let mut worst = 0.0f32;
        for _ in 0..200_000 {
            // Coefficients over many decades (1/mm) and thicknesses 1 um to 10 mm.
            let k = 10f32.powf(rng.next_f32() * 8.0 - 4.0);
            let s = 10f32.powf(rng.next_f32() * 8.0 - 4.0);
            let d = 10f32.powf(rng.next_f32() * 4.0 - 3.0);
            let (r, t) = km(k, s, d);
            let (r0, t0) = old_km(k, s, d);
            // Transmittances below 1e-30 are nothing; compare the rest relatively.
            worst = worst
                .max(rel(r, r0))
                .max(if t0 > 1e-30 { rel(t, t0) } else { 0.0 });
        }
        eprintln!("km: largest relative difference {worst}");
        assert!(worst < 1e-6, "{worst}");
    }

    /// [`diffusion`] as it was, on [`Slab`] (with the libm `km` when `libm_km`).
    pub(crate) fn old_diffusion_with(
        stack: &LayerStack,
        borders: &BorderReflectances,
        libm_km: bool,
    ) -> Diffusion {
        let km_layer = |l: &Layer| {
            if !libm_km {
                return Slab::kubelka_munk(l, stack.g);
            }
            let k = 2.0 * l.sigma_a;
            let s = l.sigma_s * (1.0 - stack.g);
            let rt = [0, 1, 2].map(|c| old_km(k[c], s[c], l.d));
            let r = Vec3::new(rt[0].0, rt[1].0, rt[2].0);
            let t = Vec3::new(rt[0].1, rt[1].1, rt[2].1);
            Slab {
                r_top: r,
                t_down: t,
                r_bottom: r,
                t_up: t,
            }
        };
        let iface = |b: usize| Slab::interface(borders.from_above[b], borders.from_below[b]);
        let mut s = iface(0);
        for k in 0..3 {
            s = s.over(&km_layer(&stack.layers[k])).over(&iface(k + 1));
        }
        Diffusion {
            r_top: (s.r_top - Vec3::splat(borders.from_above[0])).max(Vec3::ZERO),
            r_bottom: (s.r_bottom - Vec3::splat(borders.from_below[3])).max(Vec3::ZERO),
            t: 0.5 * (s.t_down + s.t_up),
        }
    }

    fn old_diffusion(stack: &LayerStack, borders: &BorderReflectances) -> Diffusion {
        let iface = |b: usize| Slab::interface(borders.from_above[b], borders.from_below[b]);
        let mut s = iface(0);
        for k in 0..3 {
            s = s
                .over(&Slab::kubelka_munk(&stack.layers[k], stack.g))
                .over(&iface(k + 1));
        }
        Diffusion {
            r_top: (s.r_top - Vec3::splat(borders.from_above[0])).max(Vec3::ZERO),
            r_bottom: (s.r_bottom - Vec3::splat(borders.from_below[3])).max(Vec3::ZERO),
            t: 0.5 * (s.t_down + s.t_up),
        }
    }

    #[test]
    fn four_lane_diffusion_is_bit_identical_to_slab_adding() {
        let p = crate::LeafParams::default();
        let borders = BorderReflectances::new(&LayerStack::at_texel(&p, 0.5, 0.5));
        let mut rng = crate::march::Pcg32::new(3);
        for i in 0..20_000 {
            let (t, e) = (rng.next_f32(), rng.next_f32());
            let mut stack = LayerStack::at_texel(&p, t, e);
            if i % 3 == 0 {
                // Extreme coefficients: no scattering, no absorption, very thick.
                for l in &mut stack.layers {
                    l.sigma_s *= [0.0, 1e-6, 1e3][i / 3 % 3];
                    l.sigma_a *= [0.0, 1.0, 1e3][i / 9 % 3];
                }
            }
            assert_eq!(
                diffusion(&stack, &borders),
                old_diffusion(&stack, &borders),
                "{stack:?}"
            );
        }
    }

    #[test]
    fn adding_conserves_energy_without_absorption() {
        let l = Layer {
            d: 0.2,
            ior: 1.4,
            sigma_a: Vec3::ZERO,
            sigma_s: Vec3::splat(30.0),
        };
        let stack = LayerStack {
            layers: [l; 3],
            g: 0.0,
        };
        let b = BorderReflectances::new(&stack);
        let iface = |i: usize| Slab::interface(b.from_above[i], b.from_below[i]);
        let mut s = iface(0);
        for k in 0..3 {
            s = s
                .over(&Slab::kubelka_munk(&stack.layers[k], 0.0))
                .over(&iface(k + 1));
        }
        assert!((s.r_top + s.t_down - Vec3::ONE).abs().max_element() < 1e-4);
        assert!((s.t_down - s.t_up).abs().max_element() < 1e-5);
    }
}
