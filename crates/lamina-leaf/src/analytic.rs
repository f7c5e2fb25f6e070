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

use crate::layers::{LayerStack, border_t, henyey_greenstein, refracted_cos};
use glam::{Vec3, Vec4};

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
        let border = |mu: &[f32; 3], c: f32, b: usize| {
            let (near, far) = stack.border_iors(b);
            let c_near = if b == 0 { c } else { mu[b - 1] };
            let c_far = if b == 3 { c } else { mu[b] };
            border_t(near, c_near, far, c_far)
        };
        let ti = [0, 1, 2, 3].map(|b| border(&mu_i, ci, b));
        let to = [0, 1, 2, 3].map(|b| border(&mu_o, co, b));
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
/// cosine) of the slab, for directions in the frame of `stack` (layer 0 on `+z`), in its
/// readable form: [`SlabPaths`] and the depth integrals as the module docs write them.
/// [`single_scatter`] computes the same (to about `1e-6` relative; tested) several times
/// faster; this one is what it is checked against, and what [`crate::march`] shares.
pub fn single_scatter_reference(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Vec3 {
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

/// The single-scattering BSDF `f^{(1)}(wo, wi)` (1/sr, per linear-RGB channel, without the
/// cosine) of the slab, for directions in the frame of `stack` (layer 0 on `+z`): the
/// module docs' formula, evaluated as [`Paths`] describes.
pub fn single_scatter(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z == 0.0 || wi.z == 0.0 {
        return Vec3::ZERO;
    }
    let (stack, wo, wi) = oriented(stack, wo, wi);
    Paths::new(&stack, wo, wi).term()
}

/// Transmission single scattering averaged over the slab and its mirror image,
/// `0.5 (f(stack; wo, wi) + f(stack; m wo, m wi))` with `m` the mirror in the leaf plane,
/// for `wo` and `wi` on opposite sides: what [`crate::LeafBsdf`] evaluates for
/// transmission, bit for bit [`single_scatter`] twice (tested), but sharing what the two
/// terms have in common. Both terms are the same pair of directions (light on `+z`)
/// through the slab and through the slab flipped, so every per-layer quantity of
/// [`Paths`] is computed once and listed in reverse for the flipped slab; only the products
/// of Fresnel transmissions and attenuations along the two layer orders differ.
pub fn single_scatter_mirrored(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z == 0.0 || wi.z == 0.0 {
        return Vec3::ZERO;
    }
    debug_assert!(wo.z * wi.z < 0.0, "transmission only");
    mirrored_paths(stack, wo, wi).mirror_average()
}

/// The paths through the unflipped `stack` for transmission, both directions mirrored in
/// the leaf plane when the light is on the abaxial side, so that it enters layer 0: the
/// mirror average is the same either way round, and so are the outer surfaces'
/// transmissions.
#[inline(always)]
fn mirrored_paths(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Paths {
    let m = Vec3::new(1.0, 1.0, -1.0);
    if wi.z > 0.0 {
        Paths::new(stack, wo, wi)
    } else {
        Paths::new(stack, wo * m, wi * m)
    }
}

/// What [`crate::LeafBsdf`] needs of the slab for one pair of directions (`wo.z`, `wi.z`
/// nonzero): the single scattering (mirror-averaged for transmission, as
/// [`single_scatter_mirrored`]) and the Fresnel transmissions `1 - F` of the outer surface
/// on `wo`'s side and on `wi`'s side, which the diffusion lobe's angular shape uses: computed
/// here anyway, so not again.
#[inline]
pub(crate) fn single_scatter_and_surface(
    stack: &LayerStack,
    wo: Vec3,
    wi: Vec3,
) -> (Vec3, [f32; 2]) {
    let transmit = wo.z * wi.z < 0.0;
    if transmit {
        let p = mirrored_paths(stack, wo, wi);
        (p.mirror_average(), [p.to[3], p.ti[0]])
    } else {
        let (stack, wo, wi) = oriented(stack, wo, wi);
        let p = Paths::new(&stack, wo, wi);
        (p.term(), [p.to[0], p.ti[0]])
    }
}

/// [`single_scatter_and_surface`] for slabs that differ only in their coefficients (the
/// same thicknesses, indices and `g`: one texel in several spectral channels), their
/// shared geometry computed once. Bit for bit the single-slab values.
#[inline]
pub(crate) fn single_scatter_and_surface_sets<const G: usize>(
    stacks: [&LayerStack; G],
    wo: Vec3,
    wi: Vec3,
) -> ([Vec3; G], [f32; 2]) {
    let mut ss = [Vec3::ZERO; G];
    let t = single_scatter_and_surface_each(G, |k| stacks[k], wo, wi, |k, v, _| ss[k] = v);
    (ss, t)
}

/// Whether slabs `a` and `b` share what [`Geometry`] takes from a slab (indices and phase
/// asymmetry), so that one geometry serves both.
#[inline]
pub(crate) fn same_slab_geometry(a: &LayerStack, b: &LayerStack) -> bool {
    a.g == b.g && a.layers.map(|l| l.ior) == b.layers.map(|l| l.ior)
}

/// [`single_scatter_and_surface`] of `n` slabs `stack(0..n)` that share their indices and
/// `g` ([`same_slab_geometry`]; their thicknesses and coefficients may differ), for one pair
/// of directions (`wo.z`, `wi.z` nonzero): each slab's single scattering goes to
/// `out(k, value, t)` with the outer surfaces' transmissions `t`, which they share, and
/// which are also returned. The geometry is computed once; bit for bit each slab's own
/// value. What the albedo quadratures of several channel sets of one leaf use.
#[inline]
pub(crate) fn single_scatter_and_surface_each<'a>(
    n: usize,
    stack: impl Fn(usize) -> &'a LayerStack,
    wo: Vec3,
    wi: Vec3,
    out: impl FnMut(usize, Vec3, [f32; 2]),
) -> [f32; 2] {
    let geometry = |s: &LayerStack, mirror: bool| {
        let m = Vec3::new(1.0, 1.0, -1.0);
        if mirror {
            Geometry::new(s, wo * m, wi * m)
        } else {
            Geometry::new(s, wo, wi)
        }
    };
    scatter_each(n, stack, (wo.z, wi.z), false, geometry, out)
}

/// Azimuthal quadratures of [`single_scatter_and_surface_each`] (`one_way` false) or
/// [`single_scatter`] (`one_way` true), for `n` slabs as there: `out(k, sum_j c_j f_k(wo_j, wi_j), t)` over
/// `pairs` `(wo_j, wi_j, c_j)`, which share `wo.z` and `wi.z` (both nonzero) and differ in
/// azimuth. Only the phase function depends on the azimuth, and the single scattering is
/// linear in it, so the sum costs one evaluation ([`Geometry::summed`]); equal to the sum
/// of the separate values up to rounding (tested). The surface transmissions `t` depend on
/// the cosines alone.
pub(crate) fn single_scatter_summed_each<'a>(
    n: usize,
    stack: impl Fn(usize) -> &'a LayerStack,
    pairs: &[(Vec3, Vec3, f32)],
    one_way: bool,
    out: impl FnMut(usize, Vec3, [f32; 2]),
) -> [f32; 2] {
    let (wo, wi, _) = pairs[0];
    debug_assert!(wo.z != 0.0 && wi.z != 0.0);
    let geometry = |s: &LayerStack, mirror: bool| Geometry::summed(s, pairs, mirror);
    scatter_each(n, stack, (wo.z, wi.z), one_way, geometry, out)
}

/// The orientation logic shared by the functions above: the slabs and directions turned
/// as [`single_scatter_and_surface`] (`one_way` false: transmission mirror-averaged) or
/// [`single_scatter`] (`one_way` true) turn them, `geometry(slab, mirror)` the geometry of
/// the directions (mirrored in the leaf plane where `mirror`) through the turned first
/// slab, then each slab's paths.
#[inline(always)]
fn scatter_each<'a>(
    n: usize,
    stack: impl Fn(usize) -> &'a LayerStack,
    (wo_z, wi_z): (f32, f32),
    one_way: bool,
    geometry: impl Fn(&LayerStack, bool) -> Geometry,
    mut out: impl FnMut(usize, Vec3, [f32; 2]),
) -> [f32; 2] {
    debug_assert!((1..n).all(|k| same_slab_geometry(stack(0), stack(k))));
    if wo_z * wi_z < 0.0 && !one_way {
        // `mirrored_paths`: the directions mirrored when the light is abaxial, the slab not.
        let g = geometry(stack(0), wi_z <= 0.0);
        let t = [g.to[3], g.ti[0]];
        for k in 0..n {
            out(k, g.paths(stack(k)).mirror_average(), t);
        }
        t
    } else {
        // `oriented`: slab and directions flipped when the light is abaxial.
        let flip = wi_z <= 0.0;
        let orient = |s: &LayerStack| if flip { s.flipped() } else { *s };
        let g = geometry(&orient(stack(0)), flip);
        let t = [g.to[0], g.ti[0]];
        for k in 0..n {
            out(k, g.paths(&orient(stack(k))).term(), t);
        }
        t
    }
}

/// The slab and the directions turned so the light enters through layer 0 (`wi.z > 0`).
#[inline]
fn oriented(stack: &LayerStack, wo: Vec3, wi: Vec3) -> (LayerStack, Vec3, Vec3) {
    if wi.z > 0.0 {
        (*stack, wo, wi)
    } else {
        let f = Vec3::new(1.0, 1.0, -1.0);
        (stack.flipped(), wo * f, wi * f)
    }
}

/// Below this, `(1 - e^{-x}) / x` comes from its series: above it, `1 - e^{-x}` from the
/// attenuations loses at most about `1e-6` relative to cancellation.
const SERIES_BELOW: f32 = 0.5;

/// `(1 - e^{-x}) / x` for `0 <= x < SERIES_BELOW` (Taylor to `x^8 / 9!`: error below
/// `1e-8`).
#[inline(always)]
fn one_minus_exp_over_series(x: f32) -> f32 {
    const C: [f32; 9] = [
        1.0,
        1.0 / 2.0,
        1.0 / 6.0,
        1.0 / 24.0,
        1.0 / 120.0,
        1.0 / 720.0,
        1.0 / 5040.0,
        1.0 / 40_320.0,
        1.0 / 362_880.0,
    ];
    C[0] - x
        * (C[1]
            - x * (C[2]
                - x * (C[3] - x * (C[4] - x * (C[5] - x * (C[6] - x * (C[7] - x * C[8])))))))
}

/// `1 / n` per layer, computed once per distinct index.
#[inline(always)]
fn inverse3(n: [f32; 3]) -> [f32; 3] {
    let r0 = 1.0 / n[0];
    let r1 = if n[1] == n[0] { r0 } else { 1.0 / n[1] };
    let r2 = if n[2] == n[1] { r1 } else { 1.0 / n[2] };
    [r0, r1, r2]
}

/// The refracted cosines `mu` and their inverses `1 / mu` of a direction with cosine `c`
/// outside, in the three layers of indices `n` (`inv_n = 1 / n`), computed once per distinct
/// index: `mu = sqrt((n - 1)(n + 1) + c^2) / n`, as [`refracted_cos`].
#[inline(always)]
fn refracted3(c: f32, n: [f32; 3], inv_n: [f32; 3]) -> ([f32; 3], [f32; 3]) {
    let one = |k: usize| {
        let s = ((n[k] - 1.0) * (n[k] + 1.0) + c * c).sqrt();
        (s * inv_n[k], n[k] / s)
    };
    let m0 = one(0);
    let m1 = if n[1] == n[0] { m0 } else { one(1) };
    let m2 = if n[2] == n[1] { m1 } else { one(2) };
    ([m0.0, m1.0, m2.0], [m0.1, m1.1, m2.1])
}

/// The single-scattering paths of one pair of directions through a slab whose layer 0
/// faces the light (`wi.z > 0`), reduced to what the sum over layers needs: per border the
/// Fresnel transmissions, per layer the attenuations through it and everything else of the
/// layer's term (`sigma_s p / (n^2 mu_i mu_o) I_k`). The same formula as [`SlabPaths`] and
/// [`single_scatter_reference`], computed faster: the 18 attenuations `e^{-sigma_t d / mu}`
/// with one vectorised exponential ([`crate::fastexp`]), the depth integrals from those
/// attenuations (`1 - e^{-(a+b)d}` is `1 - A_i A_o`; `e^{-bd} - e^{-ad}` is `A_o - A_i`) with
/// no further exponential (a series where that would cancel), the Fresnel factors from the
/// refracted cosines without square roots, and refracted cosines and phase functions once
/// per distinct index. Every per-layer value depends on that layer alone, so the flipped
/// slab's values are these in reverse order, bit for bit ([`Paths::reversed`]).
#[derive(Clone, Copy, Debug)]
struct Paths {
    transmit: bool,
    /// Fresnel transmission of borders 0..=3 (0: the outer surface the light enters by, 3:
    /// the far outer surface) along the light path and along the view path.
    ti: [f32; 4],
    to: [f32; 4],
    /// Attenuation through the whole of each layer along the refracted light and view
    /// paths (RGB in `x, y, z`; `w` unused, 1).
    att_i: [Vec4; 3],
    att_o: [Vec4; 3],
    /// Per layer: `sigma_s p / (n^2 mu_i mu_o) I_k` (1/sr; `w` unused).
    local: [Vec4; 3],
}

/// What [`Paths`] takes from the directions and the layers' thicknesses, indices and phase
/// asymmetry alone, not from their coefficients: shared by slabs that differ only in their
/// coefficients (one leaf's texel in other spectral channels), whose [`Paths`] are then
/// [`Geometry::paths`] of each.
#[derive(Clone, Copy, Debug)]
struct Geometry {
    transmit: bool,
    ti: [f32; 4],
    to: [f32; 4],
    /// `1 / mu` per layer along the light and view paths.
    ri: [f32; 3],
    ro: [f32; 3],
    /// The phase function over `n^2 mu_i mu_o` per layer.
    w: [f32; 3],
}

/// What [`Geometry`]'s phase-function weights take besides the azimuths of the two
/// directions: the same for every pair of directions with the same `wo.z` and `wi.z`.
#[derive(Clone, Copy, Debug)]
struct PhaseParts {
    transmit: bool,
    g: f32,
    /// `(1 - g^2) / (4 pi)`.
    hg: f32,
    n: [f32; 3],
    inv_n: [f32; 3],
    mu_i: [f32; 3],
    mu_o: [f32; 3],
    ri: [f32; 3],
    ro: [f32; 3],
    /// `c_o^2 - c_i^2`.
    c2: f32,
}

impl PhaseParts {
    /// Per layer the Henyey-Greenstein phase function between the refracted directions
    /// `u` (the light's propagation direction) and `v` (toward the viewer) of `wo`, `wi`,
    /// over `n^2 mu_i mu_o`. Its denominator `1 + g^2 - 2 g cos` is written
    /// `(1 - g)^2 + g |u - v|^2` for `g >= 0` and `(1 + g)^2 - g |u + v|^2` for `g < 0`:
    /// sums of positive terms, which keep their precision where a strongly peaked lobe
    /// looks along its peak. The `z` difference `mu_o - mu_i` is
    /// `(c_o^2 - c_i^2) / (n^2 (mu_i + mu_o))` for the same reason.
    #[inline(always)]
    fn weights(&self, wo: Vec3, wi: Vec3) -> [f32; 3] {
        let (n, inv_n, g) = (&self.n, &self.inv_n, self.g);
        let (sx, sy) = (wi.x + wo.x, wi.y + wo.y);
        let (dx, dy) = (wo.x - wi.x, wo.y - wi.y);
        let (sxy, dxy) = (sx * sx + sy * sy, dx * dx + dy * dy);
        let weight = |k: usize| {
            let inv_n2 = inv_n[k] * inv_n[k];
            let zsum = self.mu_i[k] + self.mu_o[k];
            let zdiff = self.c2 * inv_n2 / zsum;
            // |u - v|^2 and |u + v|^2.
            let (minus, plus) = if self.transmit {
                (sxy * inv_n2 + zdiff * zdiff, dxy * inv_n2 + zsum * zsum)
            } else {
                (sxy * inv_n2 + zsum * zsum, dxy * inv_n2 + zdiff * zdiff)
            };
            let denom = if g >= 0.0 {
                (1.0 - g) * (1.0 - g) + g * minus
            } else {
                (1.0 + g) * (1.0 + g) - g * plus
            };
            self.hg * inv_n2 * self.ri[k] * self.ro[k] / (denom * denom.sqrt())
        };
        let w0 = weight(0);
        let w1 = if n[1] == n[0] { w0 } else { weight(1) };
        let w2 = if n[2] == n[1] { w1 } else { weight(2) };
        [w0, w1, w2]
    }
}

impl Geometry {
    #[inline(always)]
    fn new(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Geometry {
        let (mut geometry, phase) = Geometry::without_phase(stack, wo, wi);
        geometry.w = phase.weights(wo, wi);
        geometry
    }

    /// The geometry of the pairs of directions `pairs` (`wo`, `wi`, weight `c`), which
    /// share `wo.z` and `wi.z` and differ in azimuth, summed: the phase-function weights
    /// are `sum c w`, everything else depends on the cosines alone. Since [`Paths`] is
    /// linear in those weights, `summed.paths(s).term()` is `sum c paths(s).term()` up to
    /// rounding: an azimuthal quadrature for the price of one pair. With `mirror`, every
    /// direction mirrored in the leaf plane first.
    fn summed(stack: &LayerStack, pairs: &[(Vec3, Vec3, f32)], mirror: bool) -> Geometry {
        let m = if mirror {
            Vec3::new(1.0, 1.0, -1.0)
        } else {
            Vec3::ONE
        };
        let (wo, wi, _) = pairs[0];
        let (mut geometry, phase) = Geometry::without_phase(stack, wo * m, wi * m);
        let mut w = [0.0f32; 3];
        for &(wo, wi, c) in pairs {
            debug_assert!(wo.z == pairs[0].0.z && wi.z == pairs[0].1.z);
            let x = phase.weights(wo * m, wi * m);
            for k in 0..3 {
                w[k] += c * x[k];
            }
        }
        geometry.w = w;
        geometry
    }

    /// Everything but the phase-function weights (zero), and what they need.
    #[inline(always)]
    fn without_phase(stack: &LayerStack, wo: Vec3, wi: Vec3) -> (Geometry, PhaseParts) {
        let l = &stack.layers;
        let transmit = wo.z < 0.0;
        let (ci, co) = (wi.z, wo.z.abs());
        let n = [l[0].ior, l[1].ior, l[2].ior];
        let inv_n = inverse3(n);
        let (mu_i, ri) = refracted3(ci, n, inv_n);
        let (mu_o, ro) = refracted3(co, n, inv_n);
        let borders = |c: f32, mu: &[f32; 3]| {
            [
                border_t(1.0, c, n[0], mu[0]),
                border_t(n[0], mu[0], n[1], mu[1]),
                border_t(n[1], mu[1], n[2], mu[2]),
                border_t(n[2], mu[2], 1.0, c),
            ]
        };
        let (ti, to) = (borders(ci, &mu_i), borders(co, &mu_o));
        let g = stack.g;
        (
            Geometry {
                transmit,
                ti,
                to,
                ri,
                ro,
                w: [0.0; 3],
            },
            PhaseParts {
                transmit,
                g,
                hg: (1.0 - g * g) * (0.25 * std::f32::consts::FRAC_1_PI),
                n,
                inv_n,
                mu_i,
                mu_o,
                ri,
                ro,
                c2: (co - ci) * (co + ci),
            },
        )
    }

    /// The paths through `stack`, whose thicknesses, indices and `g` are those this
    /// geometry was made with.
    #[inline(always)]
    fn paths(&self, stack: &LayerStack) -> Paths {
        let l = &stack.layers;
        let (ri, ro) = (&self.ri, &self.ro);
        // Per layer four lanes (RGB and a spare, whose optical thickness is 0): the
        // optical thickness, the path-length factors 1/mu, the thickness.
        let mut tau = [0.0f32; 12];
        let mut inv_i = [0.0f32; 12];
        let mut inv_o = [0.0f32; 12];
        let mut d = [0.0f32; 12];
        for k in 0..3 {
            let st = l[k].sigma_t() * l[k].d;
            for c in 0..4 {
                tau[4 * k + c] = if c < 3 { st[c] } else { 0.0 };
                inv_i[4 * k + c] = ri[k];
                inv_o[4 * k + c] = ro[k];
                d[4 * k + c] = l[k].d;
            }
        }
        // The 18 attenuations (and 6 spare lanes), light path then view path.
        let mut e = [0.0f32; 24];
        for j in 0..12 {
            e[j] = -tau[j] * inv_i[j];
            e[12 + j] = -tau[j] * inv_o[j];
        }
        crate::fastexp::exp_neg_in_place(&mut e);
        // Depth integrals I_k (mm) from the attenuations: `d (1 - A_i A_o) / x` with
        // `x = (a + b) d` (reflection), `d (A_hi - A_lo) / y` with `y = |a - b| d`
        // (transmission), by the series `d A_hi (1 - e^{-y}) / y` where the difference
        // would cancel.
        let mut integral = [0.0f32; 12];
        if self.transmit {
            for j in 0..12 {
                let (ei, eo) = (e[j], e[12 + j]);
                let y = tau[j] * (inv_i[j] - inv_o[j]).abs();
                let (hi, lo) = (ei.max(eo), ei.min(eo));
                integral[j] = if y < SERIES_BELOW {
                    d[j] * hi * one_minus_exp_over_series(y)
                } else {
                    d[j] * (hi - lo) / y
                };
            }
        } else {
            for j in 0..12 {
                let (ei, eo) = (e[j], e[12 + j]);
                let x = tau[j] * (inv_i[j] + inv_o[j]);
                integral[j] = if x < SERIES_BELOW {
                    d[j] * one_minus_exp_over_series(x)
                } else {
                    d[j] * (1.0 - ei * eo) / x
                };
            }
        }
        let v4 = |a: &[f32], k: usize| Vec4::from_slice(&a[4 * k..4 * k + 4]);
        let local = |k: usize| l[k].sigma_s.extend(0.0) * (self.w[k] * v4(&integral, k));
        Paths {
            transmit: self.transmit,
            ti: self.ti,
            to: self.to,
            att_i: [v4(&e, 0), v4(&e, 1), v4(&e, 2)],
            att_o: [v4(&e, 3), v4(&e, 4), v4(&e, 5)],
            local: [local(0), local(1), local(2)],
        }
    }
}

impl Paths {
    #[inline(always)]
    fn new(stack: &LayerStack, wo: Vec3, wi: Vec3) -> Paths {
        Geometry::new(stack, wo, wi).paths(stack)
    }

    /// The same paths through the slab flipped (layer order reversed).
    #[inline(always)]
    fn reversed(&self) -> Paths {
        let r3 = |a: [Vec4; 3]| [a[2], a[1], a[0]];
        let r4 = |a: [f32; 4]| [a[3], a[2], a[1], a[0]];
        Paths {
            transmit: self.transmit,
            ti: r4(self.ti),
            to: r4(self.to),
            att_i: r3(self.att_i),
            att_o: r3(self.att_o),
            local: r3(self.local),
        }
    }

    /// `0.5 (f(slab) + f(slab flipped))`: the transmission through the slab and its
    /// mirror image.
    #[inline(always)]
    fn mirror_average(&self) -> Vec3 {
        0.5 * (self.term() + self.reversed().term())
    }

    /// The sum over layers: each layer's term times the Fresnel transmissions and
    /// attenuations of the borders and layers crossed on the way in and on the way out.
    #[inline(always)]
    fn term(&self) -> Vec3 {
        let (ti, to, ai, ao) = (&self.ti, &self.to, &self.att_i, &self.att_o);
        // Out of layer k: up through the layers above (reflection) or down through the
        // layers below and the far surface (transmission).
        let (t_out, a_out) = if self.transmit {
            let t2 = to[3];
            let t1 = t2 * to[2];
            let a1 = ao[2];
            ([t1 * to[1], t1, t2], [a1 * ao[1], a1, Vec4::ONE])
        } else {
            let t1 = to[0] * to[1];
            ([to[0], t1, t1 * to[2]], [Vec4::ONE, ao[0], ao[0] * ao[1]])
        };
        let t_in = [ti[0], ti[0] * ti[1], ti[0] * ti[1] * ti[2]];
        let a_in = [Vec4::ONE, ai[0], ai[0] * ai[1]];
        let mut f = Vec4::ZERO;
        for k in 0..3 {
            f += self.local[k] * (t_in[k] * t_out[k]) * (a_in[k] * a_out[k]);
        }
        f.truncate()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::march::Pcg32;
    use crate::sampling::uniform_sphere;
    use glam::Vec2;

    /// A random slab: indices equal or not, thin and thick layers (optical depths from
    /// about 1e-5 to 100), channels without extinction, any phase asymmetry.
    fn random_stack(rng: &mut Pcg32) -> LayerStack {
        let mut stack = LayerStack::at_texel(&crate::LeafParams::default(), 0.5, 0.5);
        let same_ior = rng.next_f32() < 0.3;
        let n0 = 1.0 + rng.next_f32();
        for l in &mut stack.layers {
            l.ior = if same_ior { n0 } else { 1.0 + rng.next_f32() };
            l.d = 10f32.powf(-3.0 + 3.0 * rng.next_f32());
            for c in 0..3 {
                let scale = 10f32.powf(-2.0 + 4.0 * rng.next_f32());
                l.sigma_a[c] = if rng.next_f32() < 0.1 {
                    0.0
                } else {
                    scale * rng.next_f32()
                };
                l.sigma_s[c] = scale * rng.next_f32();
            }
        }
        stack.g = rng.next_f32() * 1.9 - 0.95;
        stack
    }

    /// The module docs' formula in f64, written from them directly (no code shared with
    /// the evaluators): the oracle the two f32 evaluators are held to. Also returns the
    /// largest `3 |g| / (1 + g^2 - 2 g cos)` over the layers: how much the phase function
    /// amplifies a relative error in `cos` (f32 directions are unit only to about 1e-7).
    fn single_scatter_f64(stack: &LayerStack, wo: Vec3, wi: Vec3, ch: usize) -> (f64, f64) {
        let (mut layers, mut wo, mut wi) = (stack.layers, wo.as_dvec3(), wi.as_dvec3());
        if wi.z < 0.0 {
            layers.reverse();
            (wo.z, wi.z) = (-wo.z, -wi.z);
        }
        let transmit = wo.z < 0.0;
        let (ci, co) = (wi.z, wo.z.abs());
        let n = layers.map(|l| l.ior as f64);
        let refr = |c: f64, n: f64| (1.0 - (1.0 - c * c) / (n * n)).sqrt();
        let fresnel = |ci: f64, eta: f64| {
            let ct = (1.0 - (1.0 - ci * ci) / (eta * eta)).sqrt();
            let rs = (ci - eta * ct) / (ci + eta * ct);
            let rp = (eta * ci - ct) / (eta * ci + ct);
            0.5 * (rs * rs + rp * rp)
        };
        let mu_i = n.map(|n| refr(ci, n));
        let mu_o = n.map(|n| refr(co, n));
        let border = |mu: &[f64; 3], c: f64, b: usize| {
            let near = if b == 0 { 1.0 } else { n[b - 1] };
            let far = if b == 3 { 1.0 } else { n[b] };
            1.0 - fresnel(if b == 0 { c } else { mu[b - 1] }, far / near)
        };
        let ti = [0, 1, 2, 3].map(|b| border(&mu_i, ci, b));
        let to = [0, 1, 2, 3].map(|b| border(&mu_o, co, b));
        let st = layers.map(|l| (l.sigma_a[ch] + l.sigma_s[ch]) as f64);
        let d = layers.map(|l| l.d as f64);
        let ai = [0, 1, 2].map(|k| (-st[k] * d[k] / mu_i[k]).exp());
        let ao = [0, 1, 2].map(|k| (-st[k] * d[k] / mu_o[k]).exp());
        let g = stack.g as f64;
        let (mut f, mut peak) = (0.0, 0.0f64);
        for k in 0..3 {
            let t_in: f64 = ti[..=k].iter().product::<f64>() * ai[..k].iter().product::<f64>();
            let t_out: f64 = if transmit {
                to[k + 1..].iter().product::<f64>() * ao[k + 1..].iter().product::<f64>()
            } else {
                to[..=k].iter().product::<f64>() * ao[..k].iter().product::<f64>()
            };
            let inv = glam::DVec3::new(-wi.x / n[k], -wi.y / n[k], -mu_i[k]);
            let out = glam::DVec3::new(
                wo.x / n[k],
                wo.y / n[k],
                if transmit { -mu_o[k] } else { mu_o[k] },
            );
            let den = 1.0 + g * g - 2.0 * g * inv.dot(out);
            peak = peak.max(3.0 * g.abs() / den);
            let p = (1.0 - g * g) / (4.0 * std::f64::consts::PI * den * den.sqrt());
            let (a, b) = (st[k] / mu_i[k], st[k] / mu_o[k]);
            let i = if transmit {
                if (a - b).abs() * d[k] < 1e-9 {
                    d[k] * (-a * d[k]).exp()
                } else {
                    ((-b * d[k]).exp() - (-a * d[k]).exp()) / (a - b)
                }
            } else if (a + b) * d[k] < 1e-9 {
                d[k]
            } else {
                -(-(a + b) * d[k]).exp_m1() / (a + b)
            };
            f += layers[k].sigma_s[ch] as f64 * p * t_in * t_out * i
                / (n[k] * n[k] * mu_i[k] * mu_o[k]);
        }
        (f, peak)
    }

    #[test]
    fn closed_forms_equal_the_formula_in_double_precision() {
        let mut rng = Pcg32::new(7);
        let mut worst = [0.0f64; 2];
        for n in 0..200_000 {
            let stack = random_stack(&mut rng);
            let mut wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let wi = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            if n % 50 == 0 {
                // Grazing.
                wo.z = wo.z.signum() * 1e-4;
                wo = wo.normalize();
            }
            let fast = single_scatter(&stack, wo, wi);
            let readable = single_scatter_reference(&stack, wo, wi);
            for c in 0..3 {
                let (want, peak) = single_scatter_f64(&stack, wo, wi, c);
                // Values below 1e-30 are zero for any image.
                if want < 1e-30 {
                    continue;
                }
                for (w, got) in worst.iter_mut().zip([fast[c], readable[c]]) {
                    let err = (got as f64 - want).abs() / want;
                    *w = w.max(err);
                }
                // An f32 exponent `-x` carries a relative error of about `x` ulp into
                // `e^{-x}`: the bound grows with the optical depth along both paths, and
                // with the phase function's peak.
                let depth: f32 = stack
                    .layers
                    .iter()
                    .map(|l| {
                        let (mi, mo) = (
                            refracted_cos(wi.z.abs(), l.ior),
                            refracted_cos(wo.z.abs(), l.ior),
                        );
                        l.sigma_t()[c] * l.d * (1.0 / mi + 1.0 / mo)
                    })
                    .sum();
                let tol = 1e-5 + 2e-7 * depth as f64 + 3e-7 * peak;
                let rel = |x: f32| (x as f64 - want).abs() / want;
                assert!(
                    rel(readable[c]) < 10.0 * tol,
                    "readable: {stack:?} wo {wo} wi {wi} channel {c}: {} against {want}",
                    readable[c]
                );
                assert!(
                    rel(fast[c]) < tol,
                    "{stack:?} wo {wo} wi {wi} channel {c}: {} (readable {}) against {want}",
                    fast[c],
                    readable[c]
                );
            }
        }
        eprintln!(
            "worst relative error against f64: fast {:.1e}, readable {:.1e}",
            worst[0], worst[1]
        );
    }

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
