//! The glTF 2.0 metallic-roughness surface (with `KHR_materials_diffuse_transmission`):
//! the material of pots, stems, bark and ground that come from glTF, OBJ + MTL or a scene
//! file's `type = "pbr"`.
//!
//! # Model
//! The glTF 2.0 specification, Appendix B ("BRDF Implementation"), defines the material as
//!
//! ```text
//! material   = mix(dielectric, metal, metallic)
//! metal      = conductor_fresnel(base_color, specular_brdf(α))
//! dielectric = fresnel_mix(ior, diffuse_part, specular_brdf(α))
//! ```
//!
//! with `α = roughness²`, and `KHR_materials_diffuse_transmission` replaces the dielectric's
//! Lambertian base by `diffuse_part = mix(diffuse_brdf(base_color),
//! diffuse_btdf(transmission_color), transmission)`. Here:
//!
//! * `specular_brdf` is GGX (Walter et al. 2007) with the height-correlated Smith `G2`, as
//!   in [`crate::specular`]; `α` is clamped to [`ALPHA_MIN`] so that roughness 0 stays
//!   finite (a very sharp but still continuous lobe).
//! * The metal's Fresnel is the spec's Schlick conductor term
//!   `F = base + (1 − base)(1 − |v·h|)⁵`.
//! * The dielectric's specular Fresnel is the *exact* unpolarised dielectric reflectance
//!   ([`crate::layers::fresnel_dielectric`]) for the relative index `max(ior, 1/ior)`
//!   (the spec allows Schlick with `F0 = ((ior − 1)/(ior + 1))²`; the exact term has the
//!   same `F0` but vanishes for `ior = 1`, so that an index-matched surface is exactly
//!   Lambertian).
//! * `fresnel_mix`: the spec's reference weights the base layer by `1 − F(v·h)` per
//!   direction pair, which neither conserves energy exactly nor is meant to (it says so).
//!   We use instead the energy-conserving coupling of Kelemen & Szirmay-Kalos (2001)
//!   (also used by Kulla & Conty 2017 and the Enterprise PBR / OpenPBR reference
//!   implementations): the diffuse lobes are weighted by
//!   `(1 − E(μo)) (1 − E(μi)) / (1 − E_avg)`, where `E(μ)` is the directional albedo of
//!   the dielectric specular lobe and `E_avg = 2∫E(μ)μ dμ` its cosine-weighted average.
//!   This is symmetric in `wo`, `wi` (reciprocal) and integrates over `wi` to exactly
//!   `1 − E(μo)` times the diffuse colour, so the dielectric's directional albedo is
//!   `E(μo) + (1 − E(μo))·((1 − t)·base + t·transmission_color) ≤ 1`. The transmitted
//!   light crosses the (identical) interface on the other side too, hence the same factor
//!   `1 − E(μi)` there.
//! * `E(μ)` depends on `μ = cos θ`, roughness and `ior`; it is tabulated once (the first time
//!   any `PbrBsdf` is used, in a `OnceLock`) on a `40 (√μ) × 48 (roughness) × 17 (√F0)` grid
//!   by stratified visible-normal quadrature and interpolated (trilinear), with `E_avg`
//!   integrated exactly from the interpolated table so the energy identity above holds for
//!   the interpolated `E` too. The table also holds the moments needed for the metal's
//!   albedo (`∫ D G2/4μo` and `∫(1 − v·h)⁵ D G2/4μo`, which make Schlick's albedo exact
//!   per channel), used by [`PbrBsdf::albedo`] and for lobe selection.
//! * No multiple-scattering compensation: rough conductors lose the energy of
//!   inter-reflections between microfacets, as in the spec.
//!
//! Two-sided: the surface reflects on the side of `wo` (for `wo.z < 0` both directions are
//! mirrored to `+z` before evaluation); diffuse transmission goes to the opposite side, and
//! directions on opposite sides see only the diffuse transmission lobe.
//!
//! Sampling chooses a lobe with `u.x` (specular, diffuse reflection, diffuse transmission,
//! with probabilities proportional to the luminance of each lobe's directional albedo for
//! `wo`), then draws the direction with `u.yz`: GGX visible normals (Heitz 2018) for the
//! specular lobe, cosine-weighted hemispheres for the diffuse ones. [`Bsdf::pdf`] is the full
//! mixture density.

use crate::bsdf::{Bsdf, BsdfSample};
use crate::layers::fresnel_dielectric;
use crate::sampling::{cosine_hemisphere, luminance};
use crate::specular;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::OnceLock;

/// Smallest GGX `α` used: roughness below `√ALPHA_MIN` behaves as this (near-mirror) value,
/// which keeps the microfacet distribution finite.
pub const ALPHA_MIN: f32 = 1e-3;

/// One point of a glTF metallic-roughness surface, two-sided (it reflects on the side of
/// `wo`; diffuse transmission goes to the other side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PbrBsdf {
    /// glTF `baseColor`, linear RGB in `[0, 1]`: diffuse albedo of the dielectric part,
    /// normal-incidence reflectance (F0) of the metallic part.
    pub base_color: Vec3,
    /// glTF `metallic` in `[0, 1]`: 0 dielectric, 1 conductor, linear mix between.
    pub metallic: f32,
    /// glTF perceptual `roughness` in `[0, 1]`; the GGX `alpha` is `roughness²`.
    pub roughness: f32,
    /// Index of refraction of the dielectric part (glTF default 1.5, i.e. F0 = 0.04).
    pub ior: f32,
    /// `KHR_materials_diffuse_transmission` `diffuseTransmissionFactor` in `[0, 1]`: the
    /// fraction of the dielectric's diffuse part that is transmitted instead of reflected.
    pub transmission: f32,
    /// `diffuseTransmissionColor`, linear RGB in `[0, 1]`.
    pub transmission_color: Vec3,
}

impl Default for PbrBsdf {
    fn default() -> Self {
        PbrBsdf {
            base_color: Vec3::splat(0.8),
            metallic: 0.0,
            roughness: 0.5,
            ior: 1.5,
            transmission: 0.0,
            transmission_color: Vec3::ONE,
        }
    }
}

// ------------------------------------------------------------------ albedo tables

/// Table points in `√μ = √cos θo` (uniform on `[0, 1]`, dense near grazing where the
/// Fresnel reflectance changes fast).
const NMU: usize = 40;
/// Table points in perceptual roughness (uniform on `[√ALPHA_MIN, 1]`).
const NR: usize = 48;
/// Table points in `√F0` (uniform on `[0, 1]`); slice `NS − 1` is `F ≡ 1`.
const NS: usize = 17;
/// Index of the extra slice holding the Schlick moment `∫(1 − v·h)⁵ D G2 / 4μo`.
const SLICE_SCHLICK: usize = NS;
/// `μ` at which the grazing table point is evaluated (`μ = 0` itself carries no light).
const MU_MIN: f32 = 1e-5;
/// Quadrature nodes in `u.x` when building the table (half as many in `φ`).
const TABLE_STRATA: u32 = 32;

/// Directional albedos of the GGX lobe (see the module docs), flattened
/// `[slice][roughness][μ]`, plus their cosine-weighted averages `[slice][roughness]`.
struct Tables {
    e: Vec<f32>,
    avg: Vec<f32>,
}

/// Relative index of refraction with normal-incidence reflectance `s²`.
#[inline]
fn eta_from_sqrt_f0(s: f32) -> f32 {
    (1.0 + s) / (1.0 - s)
}

/// Dielectric Fresnel reflectance for `cos = v·h` and `s = √F0` (`s >= 1`: total).
#[inline]
fn fresnel_s(cos: f32, s: f32) -> f32 {
    if s <= 0.0 {
        0.0
    } else if s >= 1.0 {
        1.0
    } else {
        fresnel_dielectric(cos, eta_from_sqrt_f0(s))
    }
}

/// Schlick's `(1 − c)⁵`.
#[inline]
fn schlick_weight(c: f32) -> f32 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Smallest perceptual roughness with its own `α` (`√ALPHA_MIN`).
#[inline]
fn roughness_min() -> f32 {
    ALPHA_MIN.sqrt()
}

/// Table coordinate in `[0, 1]` of a perceptual roughness.
#[inline]
fn roughness_axis(r: f32) -> f32 {
    let r0 = roughness_min();
    (r.max(r0) - r0) / (1.0 - r0)
}

/// Perceptual roughness of table node `j`.
fn roughness_of_node(j: usize) -> f32 {
    let r0 = roughness_min();
    r0 + (1.0 - r0) * j as f32 / (NR - 1) as f32
}

/// GGX `α` of a perceptual roughness.
#[inline]
fn alpha_of(roughness: f32) -> f32 {
    (roughness * roughness).max(ALPHA_MIN)
}

/// Quadrature nodes on the unit square for visible-normal sampling, with weights summing to
/// one: midpoints in `φ` (`u.y`), and in `u.x` midpoints of `v` with `u.x = 1 − (1 − v)²`,
/// which crowds nodes toward the rim of the projected disk where the masking and the
/// rejection (samples reflected below the horizon) live.
fn for_each_vndf_node(nx: u32, nphi: u32, mut f: impl FnMut(Vec2, f64)) {
    for a in 0..nx {
        let v = (a as f64 + 0.5) / nx as f64;
        let ux = 1.0 - (1.0 - v) * (1.0 - v);
        let jac = 2.0 * (1.0 - v) / (nx * nphi) as f64;
        for b in 0..nphi {
            let uy = (b as f64 + 0.5) / nphi as f64;
            f(Vec2::new(ux as f32, uy as f32), jac);
        }
    }
}

fn build_tables() -> Tables {
    let mut e = vec![0.0f32; (NS + 1) * NR * NMU];
    let mut acc = [0.0f64; NS + 1];
    for j in 0..NR {
        let alpha = alpha_of(roughness_of_node(j));
        for i in 0..NMU {
            let x = i as f32 / (NMU - 1) as f32;
            let mu = (x * x).max(MU_MIN);
            let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            acc.fill(0.0);
            for_each_vndf_node(TABLE_STRATA, TABLE_STRATA / 2, |u, weight| {
                let Some(wi) = specular::sample(wo, alpha, u) else {
                    return;
                };
                let p = specular::pdf(wo, wi, alpha);
                let g = ggx_reflect(wo, wi, alpha);
                if p <= 0.0 || g.value <= 0.0 {
                    return;
                }
                let w = weight * (g.value / p) as f64;
                for (k, slot) in acc.iter_mut().enumerate().take(NS) {
                    let s = k as f32 / (NS - 1) as f32;
                    *slot += w * fresnel_s(g.cos_vh, s) as f64;
                }
                acc[SLICE_SCHLICK] += w * schlick_weight(g.cos_vh) as f64;
            });
            for (k, v) in acc.iter().enumerate() {
                e[(k * NR + j) * NMU + i] = v.clamp(0.0, 1.0) as f32;
            }
        }
    }
    // Cosine-weighted averages 2∫E(μ)μ dμ = ∫4x³E dx (μ = x²) of the interpolant, which is
    // linear in x on each segment: 3-point Gauss-Legendre is exact there (degree 4).
    let mut avg = vec![0.0f32; (NS + 1) * NR];
    let h = 1.0 / (NMU - 1) as f64;
    let gl = [
        (-(0.6f64.sqrt()), 5.0 / 9.0),
        (0.0, 8.0 / 9.0),
        (0.6f64.sqrt(), 5.0 / 9.0),
    ];
    for (row, out) in avg.iter_mut().enumerate() {
        let v = &e[row * NMU..(row + 1) * NMU];
        let mut sum = 0.0f64;
        for i in 0..NMU - 1 {
            let (e0, e1) = (v[i] as f64, v[i + 1] as f64);
            for &(t, w) in &gl {
                let f = 0.5 * (1.0 + t);
                let x = (i as f64 + f) * h;
                sum += 0.5 * h * w * 4.0 * x * x * x * (e0 + f * (e1 - e0));
            }
        }
        *out = sum.clamp(0.0, 1.0) as f32;
    }
    Tables { e, avg }
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(build_tables)
}

/// Bilinear weights of four `(slice, roughness)` rows of the table.
#[derive(Clone, Copy, Debug)]
struct Rows {
    row: [usize; 4],
    w: [f32; 4],
}

/// Index and fraction of `x ∈ [0, 1]` on a uniform grid of `n` points.
#[inline]
fn grid(x: f32, n: usize) -> (usize, f32) {
    let t = unit(x) * (n - 1) as f32;
    let i = (t as usize).min(n - 2);
    (i, (t - i as f32).clamp(0.0, 1.0))
}

impl Rows {
    /// Rows for roughness `r` and `√F0 = s` (dielectric slices).
    #[inline]
    fn dielectric(r: f32, s: f32) -> Rows {
        let (j, fr) = grid(roughness_axis(r), NR);
        let (k, fs) = grid(s, NS);
        Rows {
            row: [
                k * NR + j,
                k * NR + j + 1,
                (k + 1) * NR + j,
                (k + 1) * NR + j + 1,
            ],
            w: [
                (1.0 - fs) * (1.0 - fr),
                (1.0 - fs) * fr,
                fs * (1.0 - fr),
                fs * fr,
            ],
        }
    }

    /// Rows of one fixed slice for roughness `r`.
    #[inline]
    fn slice(r: f32, k: usize) -> Rows {
        let (j, fr) = grid(roughness_axis(r), NR);
        Rows {
            row: [k * NR + j, k * NR + j + 1, k * NR + j, k * NR + j + 1],
            w: [1.0 - fr, fr, 0.0, 0.0],
        }
    }

    /// Interpolated directional albedo at `μ`.
    #[inline]
    fn e(&self, t: &Tables, mu: f32) -> f32 {
        let (i, f) = grid(mu.max(0.0).sqrt(), NMU);
        let mut s = 0.0;
        for (&row, &w) in self.row.iter().zip(&self.w) {
            let base = row * NMU + i;
            s += w * (t.e[base] + f * (t.e[base + 1] - t.e[base]));
        }
        s
    }

    /// Interpolated cosine-weighted average albedo.
    #[inline]
    fn avg(&self, t: &Tables) -> f32 {
        self.row
            .iter()
            .zip(&self.w)
            .map(|(&row, &w)| w * t.avg[row])
            .sum()
    }
}

/// The GGX reflection of `wo` into `wi` without Fresnel: `D G2 / (4 μo)` (which is
/// `f cos θi`), and `v·h`.
#[derive(Clone, Copy, Debug)]
struct Ggx {
    value: f32,
    cos_vh: f32,
}

/// [`Ggx`] for `wo`, `wi` both on `+z` (zero otherwise).
#[inline]
fn ggx_reflect(wo: Vec3, wi: Vec3, alpha: f32) -> Ggx {
    let zero = Ggx {
        value: 0.0,
        cos_vh: 1.0,
    };
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return zero;
    }
    let h = wo + wi;
    let len2 = h.length_squared();
    if len2 <= 1e-12 {
        return zero;
    }
    let h = h / len2.sqrt();
    let g2 = 1.0 / (1.0 + specular::ggx_lambda(wo, alpha) + specular::ggx_lambda(wi, alpha));
    let value = specular::ggx_d(h, alpha) * g2 / (4.0 * wo.z);
    Ggx {
        value: if value.is_finite() { value } else { 0.0 },
        cos_vh: wo.dot(h).clamp(0.0, 1.0),
    }
}

// ------------------------------------------------------------------ per-call setup

/// Everything about one `PbrBsdf` and one `wo` (on `+z`) that eval, sample and pdf share.
struct Setup {
    t: &'static Tables,
    alpha: f32,
    /// `√F0` of the dielectric.
    s: f32,
    metallic: f32,
    base: Vec3,
    /// `(1 − metallic)(1 − transmission) base`.
    diffuse_r: Vec3,
    /// `(1 − metallic) transmission transmission_color`.
    diffuse_t: Vec3,
    rows: Rows,
    /// `1 − E(μo)` of the dielectric specular lobe.
    one_minus_e_o: f32,
    /// `1 / (1 − E_avg)`.
    inv_one_minus_avg: f32,
    /// Lobe probabilities: specular, diffuse reflection, diffuse transmission.
    p: [f32; 3],
    /// Metal directional albedo at `μo`, per channel.
    metal_albedo: Vec3,
    /// Dielectric specular albedo `E(μo)`.
    e_o: f32,
}

/// `x` clamped to `[0, 1]`, NaN to 0 (so that no input can poison the table indices).
#[inline]
fn unit(x: f32) -> f32 {
    if x >= 0.0 { x.min(1.0) } else { 0.0 }
}

#[inline]
fn unit3(c: Vec3) -> Vec3 {
    c.max(Vec3::ZERO).min(Vec3::ONE)
}

impl PbrBsdf {
    /// `√F0` of the dielectric part, `|ior − 1| / (ior + 1)` in `[0, 1]` (the same for `ior`
    /// and `1/ior`).
    #[inline]
    fn sqrt_f0(&self) -> f32 {
        unit(((self.ior - 1.0) / (self.ior + 1.0)).abs())
    }

    fn setup(&self, mu_o: f32) -> Setup {
        let t = tables();
        let r = unit(self.roughness);
        let s = self.sqrt_f0();
        let metallic = unit(self.metallic);
        let tr = unit(self.transmission);
        let base = unit3(self.base_color);
        let diffuse_r = base * ((1.0 - metallic) * (1.0 - tr));
        let diffuse_t = unit3(self.transmission_color) * ((1.0 - metallic) * tr);
        let rows = Rows::dielectric(r, s);
        let e_o = rows.e(t, mu_o);
        let avg = rows.avg(t);
        let e1 = Rows::slice(r, NS - 1).e(t, mu_o);
        let e5 = Rows::slice(r, SLICE_SCHLICK).e(t, mu_o);
        let metal_albedo = base * e1 + (Vec3::ONE - base) * e5;
        let one_minus_e_o = unit(1.0 - e_o);
        let w = [
            (1.0 - metallic) * e_o + metallic * luminance(metal_albedo),
            one_minus_e_o * luminance(diffuse_r),
            one_minus_e_o * luminance(diffuse_t),
        ];
        let total = w[0] + w[1] + w[2];
        let p = if total > 0.0 && total.is_finite() {
            [w[0] / total, w[1] / total, w[2] / total]
        } else {
            [0.0, 1.0, 0.0]
        };
        Setup {
            t,
            alpha: alpha_of(r),
            s,
            metallic,
            base,
            diffuse_r,
            diffuse_t,
            rows,
            one_minus_e_o,
            inv_one_minus_avg: 1.0 / (1.0 - avg).max(1e-6),
            p,
            metal_albedo,
            e_o,
        }
    }

    /// Diffuse hemispherical (reflectance, transmittance), linear RGB: the Lambertian-like
    /// lobes only (what the paper integrator's ambient term and the GPU bake use), averaged
    /// over `wo` with cosine weight, i.e. the fraction of uniform diffuse illumination that
    /// leaves diffusely on the lit side and on the far side. With the energy-conserving
    /// coupling this is `(1 − metallic)(1 − E_avg)` times `(1 − transmission) base_color`
    /// and `transmission · transmission_color` respectively, `E_avg` being the dielectric
    /// specular lobe's cosine-averaged albedo (about 0.09 for `ior` 1.5): the light the
    /// specular coat reflects does not reach the diffuse base.
    pub fn diffuse_albedo(&self) -> (Vec3, Vec3) {
        let r = unit(self.roughness);
        let avg = Rows::dielectric(r, self.sqrt_f0()).avg(tables());
        let metallic = unit(self.metallic);
        let tr = unit(self.transmission);
        let k = (1.0 - metallic) * (1.0 - avg);
        (
            unit3(self.base_color) * (k * (1.0 - tr)),
            unit3(self.transmission_color) * (k * tr),
        )
    }

    /// Directional albedo for light leaving toward `wo`, split into (reflection on the side
    /// of `wo`, diffuse transmission from the far side), linear RGB: the fraction of light
    /// arriving from all directions (uniform radiance) that is scattered toward `wo`, which
    /// by reciprocity is also the fraction of a beam from `wo` that is scattered at all.
    /// From the precomputed tables (interpolation error about 1e-3); zero for `wo` in the
    /// plane.
    pub fn directional_albedo(&self, wo: Vec3) -> (Vec3, Vec3) {
        let mu = wo.z.abs();
        if mu.is_nan() || mu <= 0.0 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let st = self.setup(mu.min(1.0));
        let m = st.metallic;
        let refl =
            st.metal_albedo * m + Vec3::splat((1.0 - m) * st.e_o) + st.diffuse_r * st.one_minus_e_o;
        (refl, st.diffuse_t * st.one_minus_e_o)
    }

    /// Total directional albedo (reflection plus transmission) for `wo`, linear RGB; see
    /// [`PbrBsdf::directional_albedo`]. At most 1 per channel (up to table error).
    pub fn albedo(&self, wo: Vec3) -> Vec3 {
        let (r, t) = self.directional_albedo(wo);
        r + t
    }
}

impl Setup {
    /// The diffuse coupling `(1 − E(μo))(1 − E(μi)) / (1 − E_avg)`.
    #[inline]
    fn coupling(&self, mu_i: f32) -> f32 {
        let one_minus_e_i = unit(1.0 - self.rows.e(self.t, mu_i));
        self.one_minus_e_o * one_minus_e_i * self.inv_one_minus_avg
    }

    /// `f cos θi` for `wo.z > 0`.
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wi.z > 0.0 {
            let g = ggx_reflect(wo, wi, self.alpha);
            let mut f = Vec3::ZERO;
            if g.value > 0.0 {
                let m = self.metallic;
                let fd = fresnel_s(g.cos_vh, self.s);
                let fm = self.base + (Vec3::ONE - self.base) * schlick_weight(g.cos_vh);
                f = (fm * m + Vec3::splat((1.0 - m) * fd)) * g.value;
            }
            if self.diffuse_r != Vec3::ZERO {
                f += self.diffuse_r * (self.coupling(wi.z.min(1.0)) * FRAC_1_PI * wi.z);
            }
            f
        } else if wi.z < 0.0 && self.diffuse_t != Vec3::ZERO {
            let mu_i = (-wi.z).min(1.0);
            self.diffuse_t * (self.coupling(mu_i) * FRAC_1_PI * mu_i)
        } else {
            Vec3::ZERO
        }
    }

    /// Mixture density for `wo.z > 0`.
    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wi.z > 0.0 {
            let spec = if self.p[0] > 0.0 {
                self.p[0] * specular::pdf(wo, wi, self.alpha)
            } else {
                0.0
            };
            spec + self.p[1] * wi.z.min(1.0) * FRAC_1_PI
        } else if wi.z < 0.0 {
            self.p[2] * (-wi.z).min(1.0) * FRAC_1_PI
        } else {
            0.0
        }
    }
}

/// `wo` mirrored to `+z` (with whether it was), `None` in the plane or for NaN.
#[inline]
fn to_upper(wo: Vec3) -> Option<(Vec3, bool)> {
    if wo.z > 0.0 {
        Some((wo, false))
    } else if wo.z < 0.0 {
        Some((Vec3::new(wo.x, wo.y, -wo.z), true))
    } else {
        None
    }
}

#[inline]
fn mirror(w: Vec3, flip: bool) -> Vec3 {
    if flip { Vec3::new(w.x, w.y, -w.z) } else { w }
}

impl Bsdf for PbrBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some((wo, flip)) = to_upper(wo) else {
            return Vec3::ZERO;
        };
        let wi = mirror(wi, flip);
        let st = self.setup(wo.z.min(1.0));
        st.eval(wo, wi)
    }

    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
        let (wo, flip) = to_upper(wo)?;
        let st = self.setup(wo.z.min(1.0));
        let uv = Vec2::new(u.y, u.z);
        let wi = if u.x < st.p[0] {
            specular::sample(wo, st.alpha, uv)?
        } else if u.x < st.p[0] + st.p[1] || st.p[2] <= 0.0 {
            cosine_hemisphere(uv)
        } else {
            let w = cosine_hemisphere(uv);
            Vec3::new(w.x, w.y, -w.z)
        };
        let pdf = st.pdf(wo, wi);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi: mirror(wi, flip),
            f: st.eval(wo, wi),
            pdf,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some((wo, flip)) = to_upper(wo) else {
            return 0.0;
        };
        let wi = mirror(wi, flip);
        let st = self.setup(wo.z.min(1.0));
        st.pdf(wo, wi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct (untabulated) directional albedo of the GGX lobe with Fresnel `fres`.
    fn direct(mu: f32, r: f32, fres: impl Fn(f32) -> f32) -> f32 {
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let alpha = alpha_of(r);
        let mut acc = 0.0f64;
        for_each_vndf_node(512, 64, |u, w| {
            if let Some(wi) = specular::sample(wo, alpha, u) {
                let p = specular::pdf(wo, wi, alpha);
                let g = ggx_reflect(wo, wi, alpha);
                if p > 0.0 {
                    acc += w * (g.value / p * fres(g.cos_vh)) as f64;
                }
            }
        });
        acc as f32
    }

    /// Plain stratified estimate, as an independent check of the warped nodes.
    #[test]
    fn warped_nodes_agree_with_plain_strata() {
        let wo = Vec3::new(0.5, 0.0, 0.75f32.sqrt());
        let alpha = 0.3;
        let mut plain = 0.0f64;
        let n = 1024;
        for a in 0..n {
            for b in 0..n / 8 {
                let u = Vec2::new(
                    (a as f32 + 0.5) / n as f32,
                    (b as f32 + 0.5) / (n / 8) as f32,
                );
                if let Some(wi) = specular::sample(wo, alpha, u) {
                    let g = ggx_reflect(wo, wi, alpha);
                    plain += (g.value / specular::pdf(wo, wi, alpha)) as f64;
                }
            }
        }
        plain /= (n * n / 8) as f64;
        let warped = direct(wo.z, alpha.sqrt(), |_| 1.0) as f64;
        assert!((plain - warped).abs() < 1e-3, "{plain} vs {warped}");
    }

    /// The interpolated table against a fine direct quadrature at points between the grid
    /// nodes.
    #[test]
    fn table_matches_direct_integration() {
        let t = tables();
        let (mut worst, mut grazing) = (0.0f32, 0.0f32);
        for &mu in &[0.004f32, 0.05, 0.137, 0.3, 0.55, 0.81, 0.99] {
            for &r in &[0.0f32, 0.05, 0.23, 0.5, 0.77, 0.98] {
                let mut err = 0.0f32;
                for &ior in &[1.33f32, 1.5, 2.4] {
                    let s = ((ior - 1.0) / (ior + 1.0)).abs();
                    let e = Rows::dielectric(r, s).e(t, mu);
                    err = err.max((e - direct(mu, r, |c| fresnel_s(c, s))).abs());
                }
                let e1 = Rows::slice(r, NS - 1).e(t, mu);
                err = err.max((e1 - direct(mu, r, |_| 1.0)).abs());
                let e5 = Rows::slice(r, SLICE_SCHLICK).e(t, mu);
                err = err.max((e5 - direct(mu, r, schlick_weight)).abs());
                if mu < 0.02 {
                    grazing = grazing.max(err);
                } else {
                    worst = worst.max(err);
                }
            }
        }
        eprintln!("max table error {worst}, at 89.8° {grazing}");
        assert!(worst < 4e-3, "table error {worst}");
        assert!(grazing < 0.015, "table error at grazing {grazing}");
    }

    /// Index-matched surfaces have no specular lobe; a mirror has E = 1.
    #[test]
    fn table_limits() {
        let t = tables();
        for &mu in &[0.0, 0.3, 1.0] {
            assert_eq!(Rows::dielectric(0.5, 0.0).e(t, mu), 0.0);
            let e1 = Rows::slice(0.0, NS - 1).e(t, mu.max(0.05));
            assert!(e1 > 0.98, "mirror albedo {e1} at {mu}");
        }
        assert_eq!(Rows::dielectric(0.5, 0.0).avg(t), 0.0);
        let avg = Rows::dielectric(0.0, 0.2).avg(t);
        // Hemispherical Fresnel average of ior 1.5 is about 0.092.
        assert!((avg - 0.092).abs() < 0.01, "E_avg {avg}");
    }
}
