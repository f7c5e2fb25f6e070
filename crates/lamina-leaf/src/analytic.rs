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
