//! Closed-form single scattering through the three refracting layers (Hanrahan & Krueger
//! 1993, Sec. 4, chained over layers).
//!
//! Light arriving from `wi` refracts into the slab (Snell at every border, Fresnel
//! transmission `1 - F` at every border), is attenuated by `exp(-sigma_t z / mu_i)` down to
//! a depth `z` inside layer `k`, scatters once with the Henyey-Greenstein phase function
//! `p`, and leaves along the refracted `wo`, attenuated and Fresnel-transmitted again. With
//! `mu_i`, `mu_o` the cosines of the refracted directions in layer `k` and `n_k` its index,
//!
//! `f_k(wo, wi) = sigma_s p T_in T_out A_in A_out / (n_k^2 mu_i mu_o) * I_k`,
//!
//! where `A_in`, `A_out` are the attenuations through the layers crossed before reaching
//! layer `k` on the way in and after leaving it on the way out, `1 / n_k^2` is the
//! radiance's escape-cone compression and `I_k = ∫_0^{d_k} e^{-sigma_t z_in / mu_i}
//! e^{-sigma_t z_view / mu_o} dz` (`z_in` measured from the border facing the light,
//! `z_view` from the border facing the viewer) is analytic:
//!
//! * reflection (`z_in = z_view`): `I = (1 - e^{-(a+b) d}) / (a + b)`,
//! * transmission (`z_view = d - z_in`): `I = (e^{-b d} - e^{-a d}) / (a - b)`,
//!
//! with `a = sigma_t / mu_i`, `b = sigma_t / mu_o`. The sum over the three layers is the
//! single-scattering BSDF `f^{(1)}`; it is reciprocal. [`crate::march`] estimates the same
//! integral by the paper's ray march.

use crate::layers::{LayerStack, fresnel_dielectric, henyey_greenstein, refracted_cos};
use glam::Vec3;

/// The geometry of the single-scattering paths for one pair of directions, oriented so that
/// the light enters from the `+z` side of `stack` (layer 0).
#[derive(Clone, Copy, Debug)]
pub struct SlabPaths {
    /// The slab, layer 0 facing the light.
    pub stack: LayerStack,
    /// `true` when the viewer is on the far side (transmission).
    pub transmit: bool,
    /// Cosine of the refracted light direction in each layer.
    pub mu_i: [f32; 3],
    /// Cosine of the refracted view direction in each layer.
    pub mu_o: [f32; 3],
    /// Per layer: `sigma_s p T_in T_out A_in A_out / (n^2 mu_i mu_o)` (1/(mm sr)).
    pub coef: [Vec3; 3],
}

impl SlabPaths {
    /// Paths for `wo`, `wi` in the frame of `stack` (layer 0 on `+z`). `None` when either
    /// direction lies in the plane.
    pub fn new(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Option<Self> {
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let (stack, wi, wo) = if wi.z > 0.0 {
            (*stack, wi, wo)
        } else {
            let f = Vec3::new(1.0, 1.0, -1.0);
            (stack.flipped(), wi * f, wo * f)
        };
        let transmit = wo.z < 0.0;
        let (ci, co) = (wi.z.abs(), wo.z.abs());
        let l = &stack.layers;
        let mu_i = [0, 1, 2].map(|k| refracted_cos(ci, l[k].ior));
        let mu_o = [0, 1, 2].map(|k| refracted_cos(co, l[k].ior));
        // Fresnel transmission of the four borders for the light path and the view path
        // (cosine taken in the medium above border b; by reciprocity of a smooth border the
        // same value holds for the way up).
        let border_t = |mu: &[f32; 3], c: f32, b: usize| {
            let (near, far) = stack.border_iors(b);
            let cos = if b == 0 { c } else { mu[b - 1] };
            1.0 - fresnel_dielectric(cos, far / near)
        };
        let ti = [0, 1, 2, 3].map(|b| border_t(&mu_i, ci, b));
        let to = [0, 1, 2, 3].map(|b| border_t(&mu_o, co, b));
        let att = |k: usize, mu: &[f32; 3]| (-l[k].sigma_t() * (l[k].d / mu[k])).exp();
        let att_i = [0, 1, 2].map(|k| att(k, &mu_i));
        let att_o = [0, 1, 2].map(|k| att(k, &mu_o));
        // Suffix products for the way down to the far side (transmission).
        let mut t_below = [1.0f32; 3];
        let mut a_below = [Vec3::ONE; 3];
        if transmit {
            let (mut t, mut a) = (to[3], Vec3::ONE);
            for k in (0..3).rev() {
                t_below[k] = t;
                a_below[k] = a;
                t *= to[k];
                a *= att_o[k];
            }
        }
        let mut coef = [Vec3::ZERO; 3];
        let (mut t_in, mut a_in) = (1.0, Vec3::ONE);
        let (mut t_up, mut a_up) = (1.0, Vec3::ONE);
        for k in 0..3 {
            t_in *= ti[k];
            t_up *= to[k];
            let (t_out, a_out) = if transmit {
                (t_below[k], a_below[k])
            } else {
                (t_up, a_up)
            };
            let n = l[k].ior;
            let inv = Vec3::new(-wi.x / n, -wi.y / n, -mu_i[k]);
            let out = Vec3::new(
                wo.x / n,
                wo.y / n,
                if transmit { -mu_o[k] } else { mu_o[k] },
            );
            let p = henyey_greenstein(inv.dot(out), stack.g);
            coef[k] =
                l[k].sigma_s * (p * t_in * t_out / (n * n * mu_i[k] * mu_o[k])) * a_in * a_out;
            a_in *= att_i[k];
            a_up *= att_o[k];
        }
        Some(SlabPaths {
            stack,
            transmit,
            mu_i,
            mu_o,
            coef,
        })
    }
}

/// `(1 - e^{-x}) / x` for `x >= 0`, accurate near 0.
#[inline]
fn one_minus_exp_over(x: f32) -> f32 {
    if x < 1e-4 {
        1.0 - 0.5 * x
    } else {
        -(-x).exp_m1() / x
    }
}

/// The depth integral `I_k` of the module docs for one channel.
#[inline]
fn depth_integral(sigma_t: f32, mu_i: f32, mu_o: f32, d: f32, transmit: bool) -> f32 {
    let a = sigma_t / mu_i;
    let b = sigma_t / mu_o;
    if transmit {
        // e^{-b d} (1 - e^{-(a-b) d}) / (a - b), written symmetric in a, b.
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        d * (-lo * d).exp() * one_minus_exp_over((hi - lo) * d)
    } else {
        d * one_minus_exp_over((a + b) * d)
    }
}

/// The single-scattering BSDF `f^{(1)}(wo, wi)` (1/sr, per linear-RGB channel, without the
/// cosine) of the slab, for directions in the frame of `stack` (layer 0 on `+z`).
pub fn single_scatter(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Vec3 {
    let Some(p) = SlabPaths::new(stack, wo, wi) else {
        return Vec3::ZERO;
    };
    let mut f = Vec3::ZERO;
    for k in 0..3 {
        let l = &p.stack.layers[k];
        let st = l.sigma_t();
        let i = Vec3::new(
            depth_integral(st.x, p.mu_i[k], p.mu_o[k], l.d, p.transmit),
            depth_integral(st.y, p.mu_i[k], p.mu_o[k], l.d, p.transmit),
            depth_integral(st.z, p.mu_i[k], p.mu_o[k], l.d, p.transmit),
        );
        f += p.coef[k] * i;
    }
    f
}

/// Transmission single scattering averaged over the slab and its mirror image,
/// `0.5 (f(stack; wo, wi) + f(stack; m wo, m wi))` with `m` the mirror in the leaf plane,
/// for `wo` and `wi` on opposite sides: what [`crate::LeafBsdf`] evaluates for
/// transmission, bit for bit [`single_scatter`] twice, but sharing what the two terms have
/// in common. Both terms are the same pair of directions (light on `+z`) through the
/// slab and through the slab flipped, so the refracted cosines, the attenuation through
/// each layer, the phase function and the depth integral of each layer are computed
/// once, in the same operations; only the Fresnel transmissions and their products
/// along the two layer orders differ.
pub fn single_scatter_mirrored(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z == 0.0 || wi.z == 0.0 {
        return Vec3::ZERO;
    }
    debug_assert!(wo.z * wi.z < 0.0, "transmission only");
    let f = Vec3::new(1.0, 1.0, -1.0);
    let (wi, wo) = if wi.z > 0.0 {
        (wi, wo)
    } else {
        (wi * f, wo * f)
    };
    let (ci, co) = (wi.z.abs(), wo.z.abs());
    let l = &stack.layers;
    let mu_i = [0, 1, 2].map(|k| refracted_cos(ci, l[k].ior));
    let mu_o = [0, 1, 2].map(|k| refracted_cos(co, l[k].ior));
    let att = |k: usize, mu: &[f32; 3]| (-l[k].sigma_t() * (l[k].d / mu[k])).exp();
    let att_i = [0, 1, 2].map(|k| att(k, &mu_i));
    let att_o = [0, 1, 2].map(|k| att(k, &mu_o));
    let phase = [0, 1, 2].map(|k| {
        let n = l[k].ior;
        let inv = Vec3::new(-wi.x / n, -wi.y / n, -mu_i[k]);
        let out = Vec3::new(wo.x / n, wo.y / n, -mu_o[k]);
        henyey_greenstein(inv.dot(out), stack.g)
    });
    let integral = [0, 1, 2].map(|k| {
        let st = l[k].sigma_t();
        let di = |s: f32| depth_integral(s, mu_i[k], mu_o[k], l[k].d, true);
        Vec3::new(di(st.x), di(st.y), di(st.z))
    });
    /// Per-layer values of the flipped slab.
    fn rev<T: Copy>(a: [T; 3]) -> [T; 3] {
        [a[2], a[1], a[0]]
    }
    // One term: `SlabPaths::new` and `single_scatter` for transmission through `s`, with
    // the per-layer values listed in `s`'s order.
    let term = |s: &LayerStack,
                mu_i: [f32; 3],
                mu_o: [f32; 3],
                att_i: [Vec3; 3],
                att_o: [Vec3; 3],
                phase: [f32; 3],
                integral: [Vec3; 3]| {
        let l = &s.layers;
        let border_t = |mu: &[f32; 3], c: f32, b: usize| {
            let (near, far) = s.border_iors(b);
            let cos = if b == 0 { c } else { mu[b - 1] };
            1.0 - fresnel_dielectric(cos, far / near)
        };
        let ti = [0, 1, 2, 3].map(|b| border_t(&mu_i, ci, b));
        let to = [0, 1, 2, 3].map(|b| border_t(&mu_o, co, b));
        let mut t_below = [1.0f32; 3];
        let mut a_below = [Vec3::ONE; 3];
        let (mut t, mut a) = (to[3], Vec3::ONE);
        for k in (0..3).rev() {
            t_below[k] = t;
            a_below[k] = a;
            t *= to[k];
            a *= att_o[k];
        }
        let mut sum = Vec3::ZERO;
        let (mut t_in, mut a_in) = (1.0, Vec3::ONE);
        for k in 0..3 {
            t_in *= ti[k];
            let n = l[k].ior;
            let coef = l[k].sigma_s
                * (phase[k] * t_in * t_below[k] / (n * n * mu_i[k] * mu_o[k]))
                * a_in
                * a_below[k];
            sum += coef * integral[k];
            a_in *= att_i[k];
        }
        sum
    };
    let straight = term(stack, mu_i, mu_o, att_i, att_o, phase, integral);
    let flipped = term(
        &stack.flipped(),
        rev(mu_i),
        rev(mu_o),
        rev(att_i),
        rev(att_o),
        rev(phase),
        rev(integral),
    );
    0.5 * (straight + flipped)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::march::Pcg32;
    use crate::sampling::uniform_sphere;
    use glam::Vec2;

    #[test]
    fn mirrored_transmission_is_bit_identical_to_two_single_scatters() {
        let mut rng = Pcg32::new(21);
        let p = crate::LeafParams::default();
        let mut n = 0;
        while n < 50_000 {
            let mut stack = LayerStack::at_texel(&p, rng.next_f32(), rng.next_f32());
            // Epidermis layers that differ, as the mirror average is there for.
            stack.layers[0].ior = 1.3 + 0.3 * rng.next_f32();
            stack.layers[2].d *= 0.5 + rng.next_f32();
            stack.g = rng.next_f32() * 1.6 - 0.8;
            let wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let wi = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            if wo.z * wi.z >= 0.0 {
                continue;
            }
            n += 1;
            let m = Vec3::new(1.0, 1.0, -1.0);
            let old =
                0.5 * (single_scatter(&stack, wo, wi) + single_scatter(&stack, wo * m, wi * m));
            let new = single_scatter_mirrored(&stack, wo, wi);
            assert_eq!(
                new.to_array().map(f32::to_bits),
                old.to_array().map(f32::to_bits)
            );
        }
    }
}
