//! A leaf material: the seven maps plus the parameters, queried per texel.
//!
//! # How the maps and the layer physics combine
//! The colour maps are photographs taken under diffuse, specular-free light (the paper
//! photographs leaves under water with an area light), so they are read as **white-sky
//! albedos**: `front` is the adaxial diffuse reflectance, `back` the abaxial one,
//! `translucency` the diffuse transmittance, for diffuse illumination, specular excluded.
//! The layer model supplies everything else: the **angular shape** of each lobe (single
//! scattering, Fresnel, the phase function) and the **variation with thickness and
//! extinction** relative to the nominal texel (thickness and extinction maps at 0.5). So,
//! per lobe `X` (adaxial R, abaxial R, T):
//!
//! `f_X(wo, wi; texel) = C_X(texel) * lambda(texel) * f_phys,X(wo, wi; texel) / A_X`
//!
//! with `A_X` the white-sky albedo of the physical lobe at the nominal texel (computed once
//! here by numerical integration). A nominal texel under diffuse light therefore shows
//! exactly the photo's colour. A missing colour map is replaced by the physical albedo (see
//! [`crate::maps`]), so a leaf without maps is the pure layer model.
//!
//! **Texel albedos**: [`LeafBsdf::diffuse_albedo`] and [`LeafBsdf::diffuse_albedo_abaxial`]
//! (what the paper integrator's ambient term and the GPU bake use) are the white-sky
//! albedos of the subsurface lobes `eval` returns at the texel, `C_X lambda A_X(t, e) / A_X`
//! with `A_X(t, e)` the white-sky albedo of the whole physical lobe (single scattering plus
//! diffusion) at the texel's thickness and extinction map values, `min(1)` per channel:
//! specular lobe excluded, bump map excluded (geometric cosines, flat frame). In diffuse mode
//! `A_X(t, e) / A_X` is the exact Kubelka-Munk ratio per texel; otherwise it is tabulated
//! here over up to 9 x 9 map values spanning the ranges the maps contain (9 per axis over
//! the whole `[0, 1]`, proportionally fewer over a narrower range; denser toward low values;
//! 0.5 is a node where it is inside, so nominal texels and a leaf without thickness or
//! extinction maps are exact), by a 16 x 16 x 6 quadrature, and interpolated bilinearly in
//! its logarithm (within about 2 % of a fine integration of `eval`).
//!
//! **Cost**: each azimuthal ring of these quadratures costs one evaluation of the slab, not
//! one per azimuth: only the single-scattering phase function depends on the azimuth, and
//! the BSDF is linear in it, so its weights are summed over the ring first
//! ([`LeafBsdf::subsurface_summed_each`]). A leaf in several channel sets (a spectral
//! render's wavelength bins or bands) runs the quadratures of all of them together
//! ([`LeafMaterial::new_like_each`], [`LeafMaterial::variant_each`]), the slab geometry
//! computed once per pair of cosines, and the corners of the energy table and the nodes of
//! the ratio table each run as one quadrature over all their BSDFs. A pigment leaf's sixteen
//! visible sets with thickness and extinction maps take about 80 ms on one core (150 ms
//! before the corners and nodes were merged and the tables sized to the ranges; `cargo
//! bench -p lamina-leaf --bench bsdf -- pigment_materials`).
//!
//! **Energy**: `lambda` (per texel and channel, `<= 1`) scales the colours down where the
//! maps ask for more than light can give: for every incidence angle on either side,
//! `specular albedo + C_R rho_R / A_R + C_T rho_T / A_T <= 0.99` (`rho` = directional
//! albedo of the physical lobe), with `rho / A` tabulated here at 24 incidence angles and
//! taken at its maximum over the extreme thickness and extinction values the maps contain.
//! White maps thus give `R + T < 1` at every angle, not `R + T = 2`. (A bump map's shading
//! cosine can add a few percent on tilted texels; it is not part of the bound.)

use crate::diffusion::{BorderReflectances, Diffusion, diffusion};
use crate::error::LeafError;
use crate::frame::Frame;
use crate::layers::LayerStack;
use crate::leaf_bsdf::LeafBsdf;
use crate::maps::{LeafDescription, LeafMaps};
use crate::packed::{MapValues, PackedMaps};
use crate::params::{LeafMode, LeafParams};
use crate::sampling::luminance;
use crate::specular;
use crate::texture::Texture;
use glam::{Mat3, Vec2, Vec3, Vec4};
use std::path::Path;

/// Incidence cosines of the albedo integration (midpoints); the energy table has these
/// plus normal incidence.
const TABLE_N: usize = 48;
/// Safety margin of the energy bound (numerical integration error).
const ENERGY_MARGIN: f32 = 0.99;
/// Nodes per axis of the thickness x extinction table of white-sky albedo ratios over a
/// map that spans the whole `[0, 1]` (one node for a missing or constant map; a narrower
/// range gets proportionally fewer, see [`ratio_nodes`]).
const RATIO_N: usize = 9;
/// Incidence (and exitance) cosines of the white-sky integration behind that table.
const RATIO_MU: usize = 16;
/// Azimuths (over `[0, pi]`, doubled) of that integration.
const RATIO_PHI: usize = 6;

/// White-sky albedos (adaxial R, abaxial R, T) of the physical subsurface lobes of `b`:
/// `(1/pi) ∫∫ f_phys |cos_i| |cos_o| dwi dwo` over the geometric hemispheres. Exact
/// Kubelka-Munk values in diffuse mode; otherwise a product quadrature (`mu = x^2` midpoints,
/// dense near grazing; azimuth midpoints). T is integrated for light from above only: the
/// subsurface lobes are reciprocal, so the white-sky transmittance is the same from below
/// (and single scattering needs no mirror average).
fn white_sky_albedos(b: &LeafBsdf) -> [Vec3; 3] {
    white_sky_albedos_each(std::slice::from_ref(b))[0]
}

/// [`white_sky_albedos`] of every texel BSDF of `b`, bit for bit, their shared slab
/// geometry computed once per pair of cosines ([`LeafBsdf::subsurface_summed_each`]).
fn white_sky_albedos_each(b: &[LeafBsdf]) -> Vec<[Vec3; 3]> {
    if b.iter().any(|x| x.mode == LeafMode::Diffuse) {
        return b
            .iter()
            .map(|x| {
                if x.mode == LeafMode::Diffuse {
                    let d = &x.diffusion;
                    [d.r_top, d.r_bottom, d.t]
                } else {
                    white_sky_albedos(x)
                }
            })
            .collect();
    }
    let share = LeafBsdf::share_subsurface_geometry(b);
    let node = |i: usize| {
        let x = (i as f32 + 0.5) / RATIO_MU as f32;
        (x * x, 2.0 * x / RATIO_MU as f32)
    };
    let mut acc = vec![[Vec3::ZERO; 3]; b.len()];
    for io in 0..RATIO_MU {
        let (mo, wmo) = node(io);
        let so = (1.0 - mo * mo).max(0.0).sqrt();
        let o_up = Vec3::new(so, 0.0, mo);
        let o_dn = Vec3::new(so, 0.0, -mo);
        for ii in 0..RATIO_MU {
            let (mi, wmi) = node(ii);
            let si = (1.0 - mi * mi).max(0.0).sqrt();
            // (1/pi) * 2 pi (outgoing azimuth) * 2 pi / RATIO_PHI (incoming, doubled).
            let w = 4.0 * std::f32::consts::PI / RATIO_PHI as f32 * wmo * mo * wmi * mi;
            // The azimuths of the incoming direction, summed in one evaluation per lobe
            // (`subsurface_summed_each`).
            let dirs: [(Vec3, Vec3); RATIO_PHI] = std::array::from_fn(|k| {
                let phi = std::f32::consts::PI * (k as f32 + 0.5) / RATIO_PHI as f32;
                let (sp, cp) = phi.sin_cos();
                (
                    Vec3::new(si * cp, si * sp, mi),
                    Vec3::new(si * cp, si * sp, -mi),
                )
            });
            let pairs = |o: Vec3, up: bool| dirs.map(|(u, d)| (o, if up { u } else { d }, w));
            LeafBsdf::subsurface_summed_each(b, share, &pairs(o_up, true), false, |j, v| {
                acc[j][0] += v
            });
            LeafBsdf::subsurface_summed_each(b, share, &pairs(o_dn, false), false, |j, v| {
                acc[j][1] += v
            });
            LeafBsdf::subsurface_summed_each(b, share, &pairs(o_dn, true), true, |j, v| {
                acc[j][2] += v
            });
        }
    }
    acc
}

/// `A_X(t, e) / A_X(0.5, 0.5)` per lobe (adaxial R, abaxial R, T) and channel, tabulated
/// over the thickness x extinction map values of the material, stored as logarithms and
/// interpolated bilinearly (the albedos vary roughly exponentially with both).
#[derive(Clone, Debug)]
struct AlbedoRatios {
    /// Thickness-map nodes, increasing (0.5 is one of them where it lies in the range).
    t: Vec<f32>,
    /// Extinction-map nodes, likewise.
    e: Vec<f32>,
    /// `ln(A_X(t_i, e_j) / A_X(0.5, 0.5))` at index `i * e.len() + j`.
    ln: Vec<[Vec3; 3]>,
}

/// Nodes spanning `range` (one where it is a point), denser toward its low end, with the
/// node nearest to the nominal 0.5 moved onto it where 0.5 lies inside, so that nominal
/// texels are exact. [`RATIO_N`] of them over `[0, 1]`, and over a narrower range as many
/// as keep its intervals no wider than the full table's (`1 + ⌈(RATIO_N - 1) · width⌉`, at
/// least 2): a leaf whose maps span 0.4-0.8 (the procedural species) takes 5 x 5 nodes,
/// not 9 x 9, and its spectral channel sets are that much cheaper to make.
fn ratio_nodes(range: (f32, f32)) -> Vec<f32> {
    let (lo, hi) = range;
    if hi <= lo {
        return vec![lo];
    }
    let n = (1 + ((RATIO_N - 1) as f32 * (hi - lo)).ceil() as usize).clamp(2, RATIO_N);
    let mut v: Vec<f32> = (0..n)
        // Denser toward low values: thin and weakly absorbing texels curve the most.
        .map(|k| lo + (hi - lo) * (k as f32 / (n - 1) as f32).powf(1.6))
        .collect();
    if lo <= 0.5 && 0.5 <= hi {
        let k = (0..n)
            .min_by(|&a, &b| (v[a] - 0.5).abs().total_cmp(&(v[b] - 0.5).abs()))
            .unwrap_or(0);
        v[k] = 0.5;
    }
    v
}

/// Cell index and fraction of `x` on the increasing `nodes` (clamped to their range).
#[inline]
fn locate(nodes: &[f32], x: f32) -> (usize, f32) {
    let n = nodes.len();
    // Also catches NaN.
    if n == 1 || x.is_nan() || x <= nodes[0] {
        return (0, 0.0);
    }
    let mut i = 0;
    while i + 2 < n && x >= nodes[i + 1] {
        i += 1;
    }
    let f = ((x - nodes[i]) / (nodes[i + 1] - nodes[i])).clamp(0.0, 1.0);
    (i, f)
}

impl AlbedoRatios {
    fn new(
        nominal: [Vec3; 3],
        t_range: (f32, f32),
        e_range: (f32, f32),
        albedos: impl Fn(f32, f32) -> [Vec3; 3],
    ) -> Self {
        let t = ratio_nodes(t_range);
        let e = ratio_nodes(e_range);
        let ln_of = |a: Vec3, a0: Vec3| {
            let safe = |v: Vec3| v.max(Vec3::splat(1e-30));
            Vec3::from_array([0, 1, 2].map(|c| (safe(a)[c] / safe(a0)[c]).ln()))
        };
        let mut ln = Vec::with_capacity(t.len() * e.len());
        for &ti in &t {
            for &ej in &e {
                let a = if (ti, ej) == (0.5, 0.5) {
                    nominal
                } else {
                    albedos(ti, ej)
                };
                ln.push([0, 1, 2].map(|x| ln_of(a[x], nominal[x])));
            }
        }
        AlbedoRatios { t, e, ln }
    }

    /// The ratios at map values `(t, e)`.
    #[inline]
    fn at(&self, t: f32, e: f32) -> [Vec3; 3] {
        let (i, ft) = locate(&self.t, t);
        let (j, fe) = locate(&self.e, e);
        let ne = self.e.len();
        let i1 = (i + 1).min(self.t.len() - 1);
        let j1 = (j + 1).min(ne - 1);
        let (a, b) = (&self.ln[i * ne + j], &self.ln[i * ne + j1]);
        let (c, d) = (&self.ln[i1 * ne + j], &self.ln[i1 * ne + j1]);
        [0, 1, 2].map(|x| {
            let lo = a[x].lerp(b[x], fe);
            let hi = c[x].lerp(d[x], fe);
            lo.lerp(hi, ft).exp()
        })
    }
}

/// One incidence angle of the energy table: specular albedo and the largest
/// `rho / A` of the reflection and transmission lobes.
#[derive(Clone, Copy, Debug, Default)]
struct EnergyRow {
    spec: f32,
    refl: Vec3,
    trans: Vec3,
}

/// Whether the alpha matte is read from its alpha channel: it has one (some texel below 1).
fn alpha_in_channel(maps: &LeafMaps) -> bool {
    maps.alpha
        .as_ref()
        .is_some_and(|t| t.texels().iter().any(|v| v.w < 1.0))
}

/// Everything that depends on the parameters and the maps' value ranges, not on the texel.
#[derive(Clone, Debug)]
struct Precomputed {
    borders: BorderReflectances,
    r_out: [f32; 2],
    /// White-sky albedos of the physical lobes at the nominal texel in the chosen mode
    /// (adaxial R, abaxial R, T).
    a_mode: [Vec3; 3],
    /// The same for the layered model (default colours without maps).
    a_layered: [Vec3; 3],
    /// Light from the adaxial side, then from the abaxial side (the whole table: what the
    /// tests check `binding` against).
    #[cfg_attr(not(test), allow(dead_code))]
    table: [[EnergyRow; TABLE_N + 1]; 2],
    /// The rows of `table` that can set `lambda` (see [`binding_rows`]), per side.
    binding: [Vec<BindingRow>; 2],
    /// Bound on the total albedo: [`ENERGY_MARGIN`], or exactly 1 where the table is exact
    /// (diffuse mode without specular lobe, so the diffuse limit holds up to `R + T = 1`).
    #[cfg_attr(not(test), allow(dead_code))]
    margin: f32,
    /// White-sky albedo of each physical lobe at the texel's thickness and extinction
    /// relative to the nominal texel (not used in diffuse mode, where it is exact per texel).
    ratios: AlbedoRatios,
    /// Kubelka-Munk diffusion of the nominal texel (thickness and extinction maps at 0.5).
    nominal_diffusion: Diffusion,
    /// One over the sine of [`LeafParams::blend_width_deg`] ([`LeafBsdf`]'s blend band).
    inv_blend: f32,
}

/// A leaf's maps and validated parameters. `Send + Sync`; per-texel queries are cheap and
/// do not allocate.
#[derive(Clone, Debug)]
pub struct LeafMaterial {
    maps: LeafMaps,
    params: LeafParams,
    /// Read the alpha matte from the alpha channel (it has one) rather than the grey value.
    alpha_from_channel: bool,
    pre: Box<Precomputed>,
    /// The per-hit maps interleaved (see [`crate::packed`]); `None` where they differ in
    /// size or are too large, and [`LeafMaterial::bsdf`] reads them one by one.
    packed: Option<PackedMaps>,
    /// The pigment leaf this RGB material was made from, if any (band renders rebuild the
    /// leaf per wavelength from it).
    pigment: Option<Box<crate::PigmentLeaf>>,
    /// Value ranges of the thickness and extinction maps (`(0.5, 0.5)` without one).
    ranges: [(f32, f32); 2],
    /// For a material in other channels than its maps' ([`LeafMaterial::variant`]): the
    /// linear map from the maps' RGB colours to this material's channels, and the RGB
    /// physical albedos of the material the maps belong to (what the colours of missing
    /// maps are derived with, in RGB, before the map).
    channels: Option<(Mat3, [Vec3; 3])>,
}

/// Cosines of the incidence angles of the energy table and of the albedo integration
/// (midpoints in `mu`).
fn mu_grid(k: usize) -> f32 {
    if k == TABLE_N {
        1.0
    } else {
        (k as f32 + 0.5) / TABLE_N as f32
    }
}

/// The specular lobe's albedo at each incidence of the energy table ([`mu_grid`]), light
/// from the adaxial side and from the abaxial side.
type SpecTable = std::sync::Arc<[[f32; TABLE_N + 1]; 2]>;

/// [`SpecTable`] of `p`'s specular lobe (weight, roughness and epidermis index per side),
/// computed once per distinct lobe in the process and kept (a few hundred bytes each):
/// the 98 integrations cost about 2 ms, and a pigment leaf makes materials with the same
/// lobe for each of its wavelength triples.
fn specular_table(p: &LeafParams) -> SpecTable {
    use std::sync::{Mutex, OnceLock};
    type Key = [u32; 5];
    static MEMO: OnceLock<Mutex<Vec<(Key, SpecTable)>>> = OnceLock::new();
    let key = [
        p.specular,
        p.roughness_adaxial,
        p.upper.ior,
        p.roughness_abaxial,
        p.lower.ior,
    ]
    .map(f32::to_bits);
    let memo = MEMO.get_or_init(|| Mutex::new(Vec::new()));
    let found = |m: &Vec<(Key, SpecTable)>| m.iter().find(|(k, _)| *k == key).map(|e| e.1.clone());
    if let Some(t) = found(&memo.lock().unwrap_or_else(|e| e.into_inner())) {
        return t;
    }
    let mut spec = [[0.0f32; TABLE_N + 1]; 2];
    for k in 0..=TABLE_N {
        let mu = mu_grid(k);
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        let wo = Vec3::new(s, 0.0, mu);
        for (side, spec) in spec.iter_mut().enumerate() {
            let (alpha, eta) = if side == 0 {
                (p.roughness_adaxial, p.upper.ior)
            } else {
                (p.roughness_abaxial, p.lower.ior)
            };
            spec[k] = if p.specular > 0.0 {
                p.specular * specular::albedo(wo, alpha, eta, 24)
            } else {
                0.0
            };
        }
    }
    let table: SpecTable = std::sync::Arc::new(spec);
    let mut m = memo.lock().unwrap_or_else(|e| e.into_inner());
    // Another thread may have made it meanwhile: the same values either way.
    if let Some(t) = found(&m) {
        return t;
    }
    // A bound on the memo's size (each distinct lobe of a scene, usually a handful).
    if m.len() >= 4096 {
        m.clear();
    }
    m.push((key, table.clone()));
    table
}

/// Directional albedos (adaxial R, abaxial R, T from above, T from below) of the physical
/// model `b` for incidence cosine `mu`, integrated over the outgoing hemisphere.
#[cfg(test)]
fn directional_albedos(b: &LeafBsdf, mu: f32) -> [Vec3; 4] {
    directional_albedos_each(std::slice::from_ref(b), mu)[0]
}

/// [`directional_albedos`] of every texel BSDF of `b`, bit for bit, their shared slab
/// geometry computed once per pair of cosines ([`LeafBsdf::subsurface_summed_each`]).
fn directional_albedos_each(b: &[LeafBsdf], mu: f32) -> Vec<[Vec3; 4]> {
    // Diffuse mode: Lambertian lobes, whose albedos are the Kubelka-Munk values, exactly.
    let diffuse = |x: &LeafBsdf| {
        let d = &x.diffusion;
        [d.r_top, d.r_bottom, d.t, d.t]
    };
    if b.iter().any(|x| x.mode == LeafMode::Diffuse) {
        return b
            .iter()
            .map(|x| {
                if x.mode == LeafMode::Diffuse {
                    diffuse(x)
                } else {
                    directional_albedos_each(std::slice::from_ref(x), mu)[0]
                }
            })
            .collect();
    }
    let share = LeafBsdf::share_subsurface_geometry(b);
    // Midpoints; the integrand is smooth and periodic in phi, so few phi points suffice.
    const NM: usize = 24;
    const NP: usize = 12;
    let s = (1.0 - mu * mu).max(0.0).sqrt();
    let up = Vec3::new(s, 0.0, mu);
    let down = Vec3::new(s, 0.0, -mu);
    let mut acc = vec![[Vec3::ZERO; 4]; b.len()];
    for i in 0..NM {
        // Denser near grazing: mu_o = x^2 with x midpoints (dmu = 2x dx).
        let x = (i as f32 + 0.5) / NM as f32;
        let mo = x * x;
        let w_mu = 2.0 * x / NM as f32;
        let so = (1.0 - mo * mo).max(0.0).sqrt();
        // phi in [0, pi], doubled (the physical lobes are symmetric in phi); the azimuths
        // summed in one evaluation per lobe (`subsurface_summed_each`).
        let w = 2.0 * std::f32::consts::PI / NP as f32 * w_mu * mo;
        let outs: [(Vec3, Vec3); NP] = std::array::from_fn(|j| {
            let phi = std::f32::consts::PI * (j as f32 + 0.5) / NP as f32;
            let (sp, cp) = phi.sin_cos();
            (
                Vec3::new(so * cp, so * sp, mo),
                Vec3::new(so * cp, so * sp, -mo),
            )
        });
        for (lobe, (o_is_up, i)) in [(true, up), (false, down), (false, up), (true, down)]
            .into_iter()
            .enumerate()
        {
            let pairs = outs.map(|(u, d)| (if o_is_up { u } else { d }, i, w));
            LeafBsdf::subsurface_summed_each(b, share, &pairs, false, |k, v| acc[k][lobe] += v);
        }
    }
    acc
}

impl Precomputed {
    fn new(params: &LeafParams, t_range: (f32, f32), e_range: (f32, f32)) -> Self {
        let mut v = Self::new_each(std::slice::from_ref(params), t_range, e_range);
        v.pop().expect("one precomputation per parameter set")
    }

    /// [`Self::new`] for each of `params` (one leaf in several channel sets: the same
    /// layers, indices and map ranges, other coefficients), bit for bit, with the
    /// quadratures of all of them run together so that each pair of directions'
    /// slab geometry is computed once ([`LeafBsdf::subsurface_summed_each`]).
    fn new_each(params: &[LeafParams], t_range: (f32, f32), e_range: (f32, f32)) -> Vec<Self> {
        let n = params.len();
        if n > 1 && params.iter().any(|p| p.mode != params[0].mode) {
            return params
                .iter()
                .map(|p| Self::new(p, t_range, e_range))
                .collect();
        }
        let Some(mode) = params.first().map(|p| p.mode) else {
            return Vec::new();
        };
        let nominal: Vec<LayerStack> = params
            .iter()
            .map(|p| LayerStack::at_texel(p, 0.5, 0.5))
            .collect();
        let borders: Vec<BorderReflectances> =
            nominal.iter().map(BorderReflectances::new).collect();
        let r_out: Vec<[f32; 2]> = borders
            .iter()
            .map(|b| [b.from_above[0], b.from_below[3]])
            .collect();
        let physical = |j: usize, mode: LeafMode, stack: LayerStack| {
            LeafBsdf::physical(mode, stack, diffusion(&stack, &borders[j]), r_out[j])
        };
        // Each leaf's physical BSDF at the map values (t, e) (the nominal texel at 0.5).
        let at = |mode: LeafMode, t: f32, e: f32| -> Vec<LeafBsdf> {
            (0..n)
                .map(|j| physical(j, mode, LayerStack::at_texel(&params[j], t, e)))
                .collect()
        };
        // White-sky albedos from the directional table, and the table.
        let white_sky = |mode: LeafMode| -> (Vec<[Vec3; 3]>, Vec<[[Vec3; 4]; TABLE_N + 1]>) {
            let b: Vec<LeafBsdf> = (0..n).map(|j| physical(j, mode, nominal[j])).collect();
            let mut a = vec![[Vec3::ZERO; 3]; n];
            let mut rows = vec![[[Vec3::ZERO; 4]; TABLE_N + 1]; n];
            // `k` is the incidence of the table: its cosine and a row of every leaf's table.
            #[allow(clippy::needless_range_loop)]
            for k in 0..=TABLE_N {
                let mu = mu_grid(k);
                for (j, row) in directional_albedos_each(&b, mu).into_iter().enumerate() {
                    rows[j][k] = row;
                    if k < TABLE_N {
                        let w = 2.0 * mu / TABLE_N as f32;
                        a[j][0] += row[0] * w;
                        a[j][1] += row[1] * w;
                        a[j][2] += (row[2] + row[3]) * (0.5 * w);
                    }
                }
            }
            if mode == LeafMode::Diffuse {
                for (a, rows) in a.iter_mut().zip(&rows) {
                    *a = [rows[0][0], rows[0][1], rows[0][2]];
                }
            }
            (a, rows)
        };
        let (a_mode, nominal_rows) = white_sky(mode);
        let a_layered = if mode == LeafMode::Layered {
            a_mode.clone()
        } else {
            white_sky(LeafMode::Layered).0
        };
        let safe = |v: Vec3| v.max(Vec3::splat(1e-30));
        let a_mode: Vec<[Vec3; 3]> = a_mode.into_iter().map(|a| a.map(safe)).collect();
        let a_layered: Vec<[Vec3; 3]> = a_layered.into_iter().map(|a| a.map(safe)).collect();

        // Corners of the map ranges (deduplicated; the nominal texel is always included).
        let mut corners: Vec<(f32, f32)> = Vec::with_capacity(4);
        for t in [t_range.0, t_range.1] {
            for e in [e_range.0, e_range.1] {
                if !corners.contains(&(t, e)) && (t, e) != (0.5, 0.5) {
                    corners.push((t, e));
                }
            }
        }
        // Every corner's BSDFs in one list, corner-major: their slabs differ only in
        // thickness and coefficients, so one call per incidence shares the geometry of the
        // quadrature's directions among all of them.
        let corner_bsdfs: Vec<LeafBsdf> =
            corners.iter().flat_map(|&(t, e)| at(mode, t, e)).collect();
        let mut table = vec![[[EnergyRow::default(); TABLE_N + 1]; 2]; n];
        // The specular albedo per incidence and side depends on parameters that one leaf's
        // channel sets share (and that every wavelength triple of a pigment leaf shares, in
        // its calibration and in each render's sets): computed once per distinct set of them
        // in the process ([`specular_table`]).
        let spec: Vec<SpecTable> = params.iter().map(specular_table).collect();
        for k in 0..=TABLE_N {
            let mu = mu_grid(k);
            let ratio = |j: usize, row: &[Vec3; 4]| {
                [
                    row[0] / a_mode[j][0],
                    row[1] / a_mode[j][1],
                    row[2] / a_mode[j][2],
                    row[3] / a_mode[j][2],
                ]
            };
            let mut best: Vec<[Vec3; 4]> = (0..n).map(|j| ratio(j, &nominal_rows[j][k])).collect();
            if !corner_bsdfs.is_empty() {
                for rows in directional_albedos_each(&corner_bsdfs, mu).chunks_exact(n) {
                    for (j, row) in rows.iter().enumerate() {
                        let r = ratio(j, row);
                        for i in 0..4 {
                            best[j][i] = best[j][i].max(r[i]);
                        }
                    }
                }
            }
            for j in 0..n {
                let spec = &*spec[j];
                for side in 0..2 {
                    table[j][side][k] = EnergyRow {
                        spec: spec[side][k],
                        refl: best[j][side],
                        trans: best[j][2 + side],
                    };
                }
            }
        }
        let ratios: Vec<AlbedoRatios> = if mode == LeafMode::Diffuse {
            (0..n)
                .map(|_| {
                    AlbedoRatios::new([Vec3::ONE; 3], (0.5, 0.5), (0.5, 0.5), |_, _| {
                        [Vec3::ONE; 3]
                    })
                })
                .collect()
        } else {
            // The white-sky albedos at the table's nodes and at the nominal texel, all
            // leaves together.
            let mut points: Vec<(f32, f32)> = vec![(0.5, 0.5)];
            for &t in &ratio_nodes(t_range) {
                for &e in &ratio_nodes(e_range) {
                    if !points.contains(&(t, e)) {
                        points.push((t, e));
                    }
                }
            }
            // All of them in one quadrature (point-major), the directions' geometry shared.
            let all: Vec<LeafBsdf> = points.iter().flat_map(|&(t, e)| at(mode, t, e)).collect();
            let ws = white_sky_albedos_each(&all);
            let lookup = |j: usize, t: f32, e: f32| {
                let i = points
                    .iter()
                    .position(|&q| q == (t, e))
                    .expect("a node of the table");
                ws[i * n + j]
            };
            (0..n)
                .map(|j| {
                    AlbedoRatios::new(lookup(j, 0.5, 0.5), t_range, e_range, |t, e| {
                        lookup(j, t, e)
                    })
                })
                .collect()
        };
        (0..n)
            .map(|j| {
                let p = &params[j];
                let margin = if p.mode == LeafMode::Diffuse && p.specular == 0.0 {
                    1.0
                } else {
                    ENERGY_MARGIN
                };
                Precomputed {
                    borders: borders[j],
                    r_out: r_out[j],
                    a_mode: a_mode[j],
                    a_layered: a_layered[j],
                    binding: [0, 1].map(|side| binding_rows(&table[j][side], margin)),
                    table: table[j],
                    margin,
                    ratios: ratios[j].clone(),
                    nominal_diffusion: diffusion(&nominal[j], &borders[j]),
                    inv_blend: 1.0 / p.blend_width_deg.to_radians().sin(),
                }
            })
            .collect()
    }

    /// Largest `lambda <= 1` per channel keeping every tabulated incidence within the bound.
    #[inline]
    fn energy_scale(&self, c_front: Vec3, c_back: Vec3, c_t: Vec3) -> Vec3 {
        // Four lanes at once (the fourth unused): the same operations per channel as on
        // `Vec3`, so the same values, with one division instruction per row.
        let c_t = c_t.extend(0.0);
        let mut lambda = Vec4::ONE;
        for (side, c_r) in [(0, c_front), (1, c_back)] {
            let c_r = c_r.extend(0.0);
            for row in &self.binding[side] {
                let demand = c_r * row.refl + c_t * row.trans;
                lambda = lambda.min(row.room / demand.max(Vec4::splat(1e-12)));
            }
        }
        lambda.truncate().min(Vec3::ONE)
    }
}

/// A row of the energy table as [`Precomputed::energy_scale`] uses it: the room
/// `max(margin - spec, 0)` left by the specular lobe (in every lane), and the lobes'
/// `rho / A` (linear RGB, fourth lane zero).
#[derive(Clone, Copy, Debug, PartialEq)]
struct BindingRow {
    room: Vec4,
    refl: Vec4,
    trans: Vec4,
}

/// Smallest room a row may have to be dropped by [`binding_rows`]: where its demand is
/// clamped to `1e-12`, its quotient is then at least `1e6`, above the final `min(1)`.
const MIN_DROPPED_ROOM: f32 = 1e-6;

/// The rows of one side's energy table that can set `lambda` in `energy_scale`, the
/// minimum over the rows of `q = room / max(c_r refl + c_t trans, 1e-12)` (and 1), for some
/// colours `c_r, c_t >= 0`; the others are dropped, which leaves the result bit for bit the
/// same.
///
/// Per channel, with `P = (refl, trans) / room`, row `j` is dropped where `room_j >= 1e-6`
/// and `P_j <= (1 - 1e-5) (s P_a + (1 - s) P_b)` componentwise for some `s` in `[0, 1]`
/// and rows `a`, `b` still kept (`a = b` allowed). Then for any colours
/// `c . P_j <= (1 - 1e-5) max(c . P_a, c . P_b)`: where `j`'s demand is clamped, its `q`
/// is at least `1e6` and does not reach the minimum with 1; otherwise the margin `1e-5`
/// (about 40 times the relative rounding of two products and a sum, on both rows) keeps
/// `j`'s computed `room / demand` above the larger-demand row's, before and, rounding being
/// monotone, after the division. A row is dropped where that holds in all three channels.
/// Each dropped row thus has a chain of rows with smaller or equal `q` ending in a kept
/// row. A row with no room at all (`q = 0` whatever the colours) is kept alone.
fn binding_rows(table: &[EnergyRow], margin: f32) -> Vec<BindingRow> {
    let rooms: Vec<f32> = table.iter().map(|r| (margin - r.spec).max(0.0)).collect();
    let row = |k: usize| BindingRow {
        room: Vec4::splat(rooms[k]),
        refl: table[k].refl.extend(0.0),
        trans: table[k].trans.extend(0.0),
    };
    if let Some(k) = rooms.iter().position(|&r| r == 0.0) {
        return vec![row(k)];
    }
    let finite = table
        .iter()
        .zip(&rooms)
        .all(|(r, room)| room.is_finite() && r.refl.is_finite() && r.trans.is_finite());
    if !finite {
        return (0..table.len()).map(row).collect();
    }
    const SLACK: f64 = 1.0 - 1e-5;
    let point = |k: usize, c: usize| {
        let room = rooms[k] as f64;
        (
            table[k].refl[c] as f64 / room,
            table[k].trans[c] as f64 / room,
        )
    };
    // Whether `(x, y)` lies below the segment from `a` to `b`: some `s` in `[0, 1]` with
    // `s a + (1 - s) b >= (x, y)` componentwise.
    let below = |(x, y): (f64, f64), a: (f64, f64), b: (f64, f64)| {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for (v, va, vb) in [(x, a.0, b.0), (y, a.1, b.1)] {
            let slope = va - vb;
            if slope > 0.0 {
                lo = lo.max((v - vb) / slope);
            } else if slope < 0.0 {
                hi = hi.min((v - vb) / slope);
            } else if vb < v {
                return false;
            }
        }
        lo <= hi
    };
    let n = table.len();
    let mut kept = vec![true; n];
    for j in 0..n {
        if rooms[j] < MIN_DROPPED_ROOM {
            continue;
        }
        let dropped = (0..3).all(|c| {
            let (x, y) = point(j, c);
            let p = (x / SLACK, y / SLACK);
            (0..n).filter(|&a| a != j && kept[a]).any(|a| {
                (a..n)
                    .filter(|&b| b != j && kept[b])
                    .any(|b| below(p, point(a, c), point(b, c)))
            })
        });
        if dropped {
            kept[j] = false;
        }
    }
    (0..n).filter(|&k| kept[k]).map(row).collect()
}

fn map_range(t: &Option<Texture>) -> (f32, f32) {
    match t {
        None => (0.5, 0.5),
        Some(t) => t.texels().iter().fold((1.0f32, 0.0f32), |(lo, hi), v| {
            let x = v.x.clamp(0.0, 1.0);
            (lo.min(x), hi.max(x))
        }),
    }
}

/// The default abaxial colour derived from an adaxial photo: 30 % desaturated toward its
/// luminance and 20 % brighter (the lower side is paler), clamped to 1.
#[inline]
pub fn derive_back(front: Vec3) -> Vec3 {
    (front.lerp(Vec3::splat(luminance(front)), 0.3) * 1.2).min(Vec3::ONE)
}

/// One texel of a leaf material, its maps read: its BSDF is made by [`TexelBsdf::make`],
/// or written over one the caller keeps by [`TexelBsdf::write`]
/// ([`LeafMaterial::bsdf_sets_each`]).
#[derive(Clone, Copy, Debug)]
pub struct TexelBsdf<'a> {
    material: &'a LeafMaterial,
    values: MapValues,
}

impl TexelBsdf<'_> {
    /// The texel's BSDF ([`LeafMaterial::bsdf`] at its texture coordinates).
    #[inline]
    pub fn make(&self) -> LeafBsdf {
        self.material.bsdf_from(&self.values)
    }

    /// [`Self::make`] into `b`, in place.
    #[inline]
    pub fn write(&self, b: &mut LeafBsdf) {
        *b = self.material.bsdf_from(&self.values);
    }
}

impl LeafMaterial {
    /// A material from maps already in memory; validates `params` and precomputes the
    /// normalisation of the maps (a few tens of milliseconds). The maps [`Self::bsdf`] reads
    /// per hit (colours, thickness, extinction, bump) are also copied into one interleaved
    /// texel grid, 48 bytes a texel, where all of them that are larger than 1 x 1 share one
    /// size and wrap mode of at most 2048 x 2048 texels (192 MiB); otherwise `bsdf` reads
    /// them one by one, with the same results.
    pub fn new(maps: LeafMaps, params: LeafParams) -> Result<Self, LeafError> {
        let mut m = Self::new_each(vec![(maps, params)])?;
        Ok(m.pop().expect("one material per item"))
    }

    /// [`Self::new`] for each of `items` (one leaf's maps and parameters in several channel
    /// sets): each bit for bit `new`'s, their precomputations run together where their map
    /// ranges agree (see [`Self::new_like_each`]).
    pub fn new_each(items: Vec<(LeafMaps, LeafParams)>) -> Result<Vec<Self>, LeafError> {
        let mut parts = Vec::with_capacity(items.len());
        for (maps, params) in items {
            params.validate()?;
            let alpha_from_channel = alpha_in_channel(&maps);
            let ranges = [map_range(&maps.thickness), map_range(&maps.extinction)];
            let packed = PackedMaps::new(&maps);
            parts.push((maps, params, alpha_from_channel, ranges, packed));
        }
        Ok(Self::assemble_each(parts))
    }

    /// [`Self::new`] for maps that share their data maps (alpha, thickness, extinction,
    /// bump: clones of the same images) with `like`'s, as a pigment leaf's per-wavelength
    /// materials do: the interleaved grid and the map ranges are `like`'s, not copied or
    /// scanned again. Results are those of [`Self::new`], bit for bit.
    pub fn new_like(
        maps: LeafMaps,
        params: LeafParams,
        like: &LeafMaterial,
    ) -> Result<Self, LeafError> {
        let mut m = Self::new_like_each(vec![(maps, params)], like)?;
        Ok(m.pop().expect("one material per item"))
    }

    /// [`Self::new_like`] for each of `items` (maps and parameters of one leaf in several
    /// channel sets, as a pigment leaf's wavelength triples of a spectral render): each
    /// material bit for bit `new_like`'s, their precomputations run together where their
    /// map ranges agree, so that the slab geometry of every pair of directions of the
    /// albedo quadratures is computed once for all of them (several times faster than
    /// one by one for a visible render's sixteen sets).
    pub fn new_like_each(
        items: Vec<(LeafMaps, LeafParams)>,
        like: &LeafMaterial,
    ) -> Result<Vec<Self>, LeafError> {
        let mut parts = Vec::with_capacity(items.len());
        for (maps, params) in items {
            params.validate()?;
            let (alpha_from_channel, ranges, packed) = like.parts_for(&maps);
            parts.push((maps, params, alpha_from_channel, ranges, packed));
        }
        Ok(Self::assemble_each(parts))
    }

    /// The materials from their parts, with the precomputations their parameters and map
    /// ranges need, run together where their map ranges agree.
    #[allow(clippy::type_complexity)]
    fn assemble_each(
        parts: Vec<(
            LeafMaps,
            LeafParams,
            bool,
            [(f32, f32); 2],
            Option<PackedMaps>,
        )>,
    ) -> Vec<Self> {
        let params: Vec<LeafParams> = parts.iter().map(|p| p.1).collect();
        let pre: Vec<Precomputed> = match parts.first() {
            Some(first) if parts.iter().all(|p| p.3 == first.3) => {
                Precomputed::new_each(&params, first.3[0], first.3[1])
            }
            _ => parts
                .iter()
                .map(|p| Precomputed::new(&p.1, p.3[0], p.3[1]))
                .collect(),
        };
        parts
            .into_iter()
            .zip(pre)
            .map(
                |((maps, params, alpha_from_channel, ranges, packed), pre)| LeafMaterial {
                    maps,
                    params,
                    alpha_from_channel,
                    pre: Box::new(pre),
                    packed,
                    pigment: None,
                    ranges,
                    channels: None,
                },
            )
            .collect()
    }

    /// What [`Self::new_like`] takes from `self` for `maps` that may share data maps with
    /// this material's: whether the matte is in the alpha channel, the map ranges and the
    /// interleaved texel grid.
    fn parts_for(&self, maps: &LeafMaps) -> (bool, [(f32, f32); 2], Option<PackedMaps>) {
        let same = |a: &Option<Texture>, b: &Option<Texture>| match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => a.is_same_image(b),
            _ => false,
        };
        let ranges = [
            if same(&maps.thickness, &self.maps.thickness) {
                self.ranges[0]
            } else {
                map_range(&maps.thickness)
            },
            if same(&maps.extinction, &self.maps.extinction) {
                self.ranges[1]
            } else {
                map_range(&maps.extinction)
            },
        ];
        let alpha_from_channel = if same(&maps.alpha, &self.maps.alpha) {
            self.alpha_from_channel
        } else {
            alpha_in_channel(maps)
        };
        let packed = match &self.packed {
            Some(p) => PackedMaps::new_like(maps, p, &self.maps),
            None => PackedMaps::new(maps),
        };
        (alpha_from_channel, ranges, packed)
    }

    /// This leaf in other channels (three spectral bands, say): the same maps, shared, not
    /// copied; `params` in the new channels (for an RGB leaf in bands, its layer
    /// coefficients through the band basis); and the colour maps' RGB taken through
    /// `matrix` (row `i`: the weights of R, G, B in channel `i`) after the colours of
    /// missing maps are derived in RGB as for this material (a leaf without colour maps:
    /// this material's physical albedos through `matrix`). `matrix` must map `[0, 1]³`
    /// into itself (non-negative rows summing to at most 1), as
    /// [`crate::spectrum::bands::BandBasis::reflectance_matrix`] does. The normalisation
    /// (white-sky albedos, energy bound) is computed for the new channels.
    pub fn variant(&self, params: LeafParams, matrix: Mat3) -> Result<Self, LeafError> {
        let mut v = self.variant_each(vec![(params, matrix)])?;
        Ok(v.pop().expect("one variant per item"))
    }

    /// [`Self::variant`] for each of `items` (this leaf in several channel sets): each bit
    /// for bit `variant`'s, their precomputations run together (see
    /// [`Self::new_like_each`]).
    pub fn variant_each(&self, items: Vec<(LeafParams, Mat3)>) -> Result<Vec<Self>, LeafError> {
        for (params, _) in &items {
            params.validate()?;
        }
        let params: Vec<LeafParams> = items.iter().map(|i| i.0).collect();
        let pre = Precomputed::new_each(&params, self.ranges[0], self.ranges[1]);
        Ok(items
            .into_iter()
            .zip(pre)
            .map(|((params, matrix), pre)| {
                let channels = match self.channels {
                    Some((m, rgb)) => (matrix * m, rgb),
                    None => (matrix, self.pre.a_layered),
                };
                LeafMaterial {
                    maps: self.maps.clone(),
                    params,
                    alpha_from_channel: self.alpha_from_channel,
                    pre: Box::new(pre),
                    packed: self.packed.clone(),
                    pigment: None,
                    ranges: self.ranges,
                    channels: Some(channels),
                }
            })
            .collect())
    }

    /// A material from maps, parameters and optional PROSPECT pigments: without pigments
    /// [`Self::new`]; with them the RGB material of a [`crate::PigmentLeaf`] (colours from
    /// PROSPECT, 10 nm integration; `maps` may not hold colour maps).
    pub fn from_parts(
        maps: LeafMaps,
        params: LeafParams,
        pigments: Option<crate::Pigments>,
    ) -> Result<Self, LeafError> {
        match pigments {
            None => Self::new(maps, params),
            Some(p) => {
                let leaf = crate::PigmentLeaf::new(p, params, maps)?;
                let mut m = leaf.rgb_material(10.0)?;
                m.pigment = Some(Box::new(leaf));
                Ok(m)
            }
        }
    }

    /// Loads the maps of `desc` (paths relative to `base_dir`) and validates its parameters.
    /// The error names the map and the file, or the parameter.
    ///
    /// Each map's size is checked before it is decoded (see
    /// [`crate::texture::check_image_size`]); a panic while loading is an error naming
    /// `base_dir`.
    pub fn load(desc: &LeafDescription, base_dir: &Path) -> Result<Self, LeafError> {
        crate::guard::catch_panic(|| {
            crate::guard::fault_point("leaf_material");
            desc.params.validate()?;
            let maps = LeafMaps::load(&desc.maps, base_dir)?;
            Self::from_parts(maps, desc.params, desc.pigments)
        })
        .unwrap_or_else(|message| {
            Err(LeafError::Panicked {
                path: base_dir.to_owned(),
                message: crate::guard::panic_error_message(&message),
            })
        })
    }

    /// Alpha test at texture coordinates `uv`: `true` where the leaf is (matte `>= 0.5`;
    /// the alpha channel if the map has one, else its grey value).
    pub fn opaque(&self, uv: Vec2) -> bool {
        match &self.maps.alpha {
            None => true,
            Some(t) if self.alpha_from_channel => t.alpha(uv) >= 0.5,
            Some(t) => t.scalar(uv) >= 0.5,
        }
    }

    /// The colours (adaxial R, abaxial R, T) the maps ask for at `uv`, linear RGB in `[0, 1]`,
    /// before the energy bound.
    pub fn map_colours(&self, uv: Vec2) -> [Vec3; 3] {
        self.colours(&MapValues::read(&self.maps, uv, false))
    }

    /// [`Self::map_colours`] from the filtered map values.
    #[inline]
    fn colours(&self, v: &MapValues) -> [Vec3; 3] {
        let a = &self.pre.a_layered;
        let clamp = |v: Vec3| v.clamp(Vec3::ZERO, Vec3::ONE);
        let front = v.front.map(clamp);
        if let Some((m, rgb)) = &self.channels {
            // The colours the RGB material has (its maps, or its model's albedos where it
            // has none), then into these channels.
            let back = match (v.back, front) {
                (Some(c), _) => clamp(c),
                (None, Some(f)) => derive_back(f),
                (None, None) => rgb[1],
            };
            let trans = match (v.translucency, front) {
                (Some(c), _) => clamp(c),
                (None, Some(f)) => clamp(f * rgb[2] / rgb[0]),
                (None, None) => rgb[2],
            };
            let into = |c: Vec3| (*m * c).clamp(Vec3::ZERO, Vec3::ONE);
            return [into(front.unwrap_or(rgb[0])), into(back), into(trans)];
        }
        let back = match (v.back, front) {
            (Some(c), _) => clamp(c),
            (None, Some(f)) => derive_back(f),
            (None, None) => a[1],
        };
        let trans = match (v.translucency, front) {
            (Some(c), _) => clamp(c),
            (None, Some(f)) => clamp(f * a[2] / a[0]),
            (None, None) => a[2],
        };
        [front.unwrap_or(a[0]), back, trans]
    }

    /// The BSDF at texture coordinates `uv`.
    pub fn bsdf(&self, uv: Vec2) -> LeafBsdf {
        self.bsdf_from(&self.values(uv))
    }

    /// The filtered map values at `uv` that [`Self::bsdf`] reads.
    #[inline]
    fn values(&self, uv: Vec2) -> MapValues {
        let with_bump = self.params.bump_scale > 0.0;
        match &self.packed {
            Some(p) => p.read(uv, with_bump),
            None => MapValues::read(&self.maps, uv, with_bump),
        }
    }

    /// [`Self::bsdf`] of several materials of one leaf in other channels (variants sharing
    /// its maps) at the same `uv`: the shared maps are read once. Bit for bit each one's
    /// `bsdf`.
    pub fn bsdf_sets<const G: usize>(m: [&LeafMaterial; G], uv: Vec2) -> [LeafBsdf; G] {
        let mut out = [const { None }; G];
        Self::bsdf_sets_each(m, uv, |k, t| out[k] = Some(t.make()));
        out.map(|b| b.expect("one BSDF per set"))
    }

    /// [`Self::bsdf_sets`], set `k`'s texel handed to `put(k, texel)` to be made where the
    /// caller keeps it ([`TexelBsdf::write`] over a BSDF already there, in place: an array
    /// of a caller's enum of BSDFs built through an array of these, or through `from_fn`,
    /// was copied whole, a measured few per cent of a spectral render).
    #[inline]
    pub fn bsdf_sets_each<const G: usize>(
        m: [&LeafMaterial; G],
        uv: Vec2,
        mut put: impl FnMut(usize, TexelBsdf<'_>),
    ) {
        let with_bump = m[0].params.bump_scale > 0.0;
        let shared = G > 1
            && m.iter().all(|x| {
                (x.params.bump_scale > 0.0) == with_bump
                    && match (&x.packed, &m[0].packed) {
                        (Some(a), Some(b)) => a.shares_grid(b),
                        _ => false,
                    }
            });
        match (&m[0].packed, shared) {
            (Some(p), true) => {
                let l = p.lookup(uv, with_bump);
                for (k, x) in m.iter().enumerate() {
                    let values = match &x.packed {
                        Some(q) => q.values(&l),
                        None => MapValues::read(&x.maps, uv, with_bump),
                    };
                    put(
                        k,
                        TexelBsdf {
                            material: x,
                            values,
                        },
                    );
                }
            }
            _ => {
                for (k, x) in m.iter().enumerate() {
                    put(
                        k,
                        TexelBsdf {
                            material: x,
                            values: x.values(uv),
                        },
                    );
                }
            }
        }
    }

    /// The BSDF of a texel whose filtered map values are `v`.
    #[inline]
    fn bsdf_from(&self, v: &MapValues) -> LeafBsdf {
        let p = &self.params;
        let t = v.thickness.unwrap_or(0.5);
        let e = v.extinction.unwrap_or(0.5);
        let stack = LayerStack::at_texel(p, t, e);
        let diff = diffusion(&stack, &self.pre.borders);
        let [cf, cb, ct] = self.colours(v);
        let lambda = self.pre.energy_scale(cf, cb, ct);
        let a = &self.pre.a_mode;
        let scale = [cf * lambda / a[0], cb * lambda / a[1], ct * lambda / a[2]];
        // White-sky albedos of the lobes `eval` returns at this texel: the colours times the
        // physical lobes' albedo at this texel relative to the nominal one (exactly the
        // colours at the nominal texel). Diffuse mode: the Kubelka-Munk values, exact;
        // otherwise interpolated in the table built with the material.
        let ratio = if p.mode == LeafMode::Diffuse {
            let nominal = &self.pre.nominal_diffusion;
            let var = |x: Vec3, x0: Vec3| {
                Vec3::from_array([0, 1, 2].map(|c| if x0[c] > 0.0 { x[c] / x0[c] } else { 1.0 }))
            };
            [
                var(diff.r_top, nominal.r_top),
                var(diff.r_bottom, nominal.r_bottom),
                var(diff.t, nominal.t),
            ]
        } else {
            self.pre.ratios.at(t, e)
        };
        let albedo = [
            (cf * lambda * ratio[0]).min(Vec3::ONE),
            (cb * lambda * ratio[1]).min(Vec3::ONE),
            (ct * lambda * ratio[2]).min(Vec3::ONE),
        ];
        let normal = match v.bump_gradient {
            Some(g) => {
                let g = g * p.bump_scale;
                let mut n = Vec3::new(-g.x, -g.y, 1.0).normalize();
                if !n.is_finite() {
                    n = Vec3::Z;
                }
                // Keep the shading normal well inside the adaxial hemisphere.
                const MIN_Z: f32 = 0.2;
                if n.z < MIN_Z {
                    let xy = Vec2::new(n.x, n.y).normalize_or_zero() * (1.0 - MIN_Z * MIN_Z).sqrt();
                    n = Vec3::new(xy.x, xy.y, MIN_Z);
                }
                n
            }
            None => Vec3::Z,
        };
        let mut b = LeafBsdf::physical(p.mode, stack, diff, self.pre.r_out);
        b.scale = scale;
        b.albedo = albedo;
        b.shading = Frame::from_normal_tangent(normal, Vec3::X);
        b.alpha = [p.roughness_adaxial, p.roughness_abaxial];
        b.specular = p.specular;
        b.inv_blend = self.pre.inv_blend;
        b
    }

    /// Directional-hemispherical `(R, T)` per channel of the physical subsurface lobes of
    /// each of `m` at its nominal texel (thickness and extinction maps at 0.5) for light on
    /// the adaxial side at incidence cosine `mu`: the layer model alone, before the texel's
    /// colours and energy scale, by the energy table's quadrature with the directions'
    /// geometry shared among all of them. What a pigment leaf's calibration divides by
    /// ([`crate::PigmentLeaf`]): the rendered lobes are these times `colour / A` and the
    /// material's own energy scale, which is 1 wherever the calibrated colours leave room.
    pub(crate) fn nominal_directional_albedos_each(
        m: &[LeafMaterial],
        mu: f32,
    ) -> Vec<(Vec3, Vec3)> {
        // No map values: the nominal texel.
        let b: Vec<LeafBsdf> = m
            .iter()
            .map(|x| x.bsdf_from(&MapValues::default()))
            .collect();
        directional_albedos_each(&b, mu)
            .into_iter()
            .map(|rows| (rows[0], rows[2]))
            .collect()
    }

    /// White-sky albedos (adaxial R, abaxial R, T) of the pure layered model at the nominal
    /// texel: the colours a leaf without maps has.
    pub fn physical_albedos(&self) -> [Vec3; 3] {
        self.pre.a_layered
    }

    /// The pigment leaf this material was made from ([`Self::from_parts`] with pigments).
    pub fn pigment_leaf(&self) -> Option<&crate::PigmentLeaf> {
        self.pigment.as_deref()
    }

    /// The validated parameters.
    pub fn params(&self) -> &LeafParams {
        &self.params
    }

    /// The maps.
    pub fn maps(&self) -> &LeafMaps {
        &self.maps
    }

    /// The alpha matte [`LeafMaterial::opaque`] thresholds at 0.5, and whether it reads the
    /// matte's alpha channel (else its first channel); `None` without an alpha map.
    pub fn matte(&self) -> Option<(&Texture, bool)> {
        self.maps
            .alpha
            .as_ref()
            .map(|t| (t, self.alpha_from_channel))
    }
}

#[cfg(test)]
mod tests {
    //! The fast per-hit path against the computation it replaced, kept here verbatim as the
    //! reference: per-map lookups (libm `floor`), the whole energy table, the nominal
    //! diffusion and the blend sine recomputed per query. The texel BSDFs must be equal
    //! bit for bit.

    use super::*;
    use crate::march::Pcg32;
    use crate::texture::Wrap;

    /// [`Texture::sample`] as it was.
    fn old_sample(t: &Texture, uv: Vec2) -> Vec4 {
        let texels = t.texels();
        if texels.len() == 1 {
            return texels[0];
        }
        let (width, height) = (t.width(), t.height());
        let x = uv.x * width as f32 - 0.5;
        let y = (1.0 - uv.y) * height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return texels[0];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let neighbours = |i: i64, n: u32| {
            let n = n as i64;
            if i >= 0 && i < n - 1 {
                return (i as usize, i as usize + 1);
            }
            let at = |i: i64| match t.wrap {
                Wrap::Repeat => i.rem_euclid(n) as usize,
                Wrap::Clamp => i.clamp(0, n - 1) as usize,
            };
            (at(i), at(i.saturating_add(1)))
        };
        let (x0, x1) = neighbours(x0 as i64, width);
        let (y0, y1) = neighbours(y0 as i64, height);
        let w = width as usize;
        let a = texels[y0 * w + x0].lerp(texels[y0 * w + x1], fx);
        let b = texels[y1 * w + x0].lerp(texels[y1 * w + x1], fx);
        a.lerp(b, fy)
    }

    fn old_scalar(t: &Texture, uv: Vec2) -> f32 {
        old_sample(t, uv).x
    }

    /// [`Texture::gradient`] as it was.
    fn old_gradient(t: &Texture, uv: Vec2) -> Vec2 {
        if t.texels().len() == 1 {
            return Vec2::ZERO;
        }
        let du = 1.0 / t.width() as f32;
        let dv = 1.0 / t.height() as f32;
        let gu = old_scalar(t, uv + Vec2::new(du, 0.0)) - old_scalar(t, uv - Vec2::new(du, 0.0));
        let gv = old_scalar(t, uv + Vec2::new(0.0, dv)) - old_scalar(t, uv - Vec2::new(0.0, dv));
        Vec2::new(gu / (2.0 * du), gv / (2.0 * dv))
    }

    /// `energy_scale` over the whole table, as it was.
    fn old_energy_scale(pre: &Precomputed, c_front: Vec3, c_back: Vec3, c_t: Vec3) -> Vec3 {
        let mut lambda = Vec3::ONE;
        for (side, c_r) in [(0, c_front), (1, c_back)] {
            for row in &pre.table[side] {
                let demand = c_r * row.refl + c_t * row.trans;
                let room = (pre.margin - row.spec).max(0.0);
                lambda = lambda.min(Vec3::splat(room) / demand.max(Vec3::splat(1e-12)));
            }
        }
        lambda.min(Vec3::ONE)
    }

    fn old_map_colours(m: &LeafMaterial, uv: Vec2) -> [Vec3; 3] {
        let a = &m.pre.a_layered;
        let clamp = |v: Vec3| v.clamp(Vec3::ZERO, Vec3::ONE);
        let front = m
            .maps
            .front
            .as_ref()
            .map(|t| clamp(old_sample(t, uv).truncate()));
        let back = match (&m.maps.back, front) {
            (Some(t), _) => clamp(old_sample(t, uv).truncate()),
            (None, Some(f)) => derive_back(f),
            (None, None) => a[1],
        };
        let trans = match (&m.maps.translucency, front) {
            (Some(t), _) => clamp(old_sample(t, uv).truncate()),
            (None, Some(f)) => clamp(f * a[2] / a[0]),
            (None, None) => a[2],
        };
        [front.unwrap_or(a[0]), back, trans]
    }

    /// `LeafMaterial::bsdf` as it was, with Kubelka-Munk diffusion by [`diffusion`] or, with
    /// `libm_km`, as it was (libm `tanh` and `cosh`, three-lane adding).
    fn old_bsdf_with(m: &LeafMaterial, uv: Vec2, libm_km: bool) -> LeafBsdf {
        let diffusion = |stack: &LayerStack, borders: &BorderReflectances| {
            crate::diffusion::tests::old_diffusion_with(stack, borders, libm_km)
        };
        let p = &m.params;
        let t = m.maps.thickness.as_ref().map_or(0.5, |t| old_scalar(t, uv));
        let e = m
            .maps
            .extinction
            .as_ref()
            .map_or(0.5, |t| old_scalar(t, uv));
        let stack = LayerStack::at_texel(p, t, e);
        let diff = diffusion(&stack, &m.pre.borders);
        let [cf, cb, ct] = old_map_colours(m, uv);
        let lambda = old_energy_scale(&m.pre, cf, cb, ct);
        let a = &m.pre.a_mode;
        let scale = [cf * lambda / a[0], cb * lambda / a[1], ct * lambda / a[2]];
        let ratio = if p.mode == LeafMode::Diffuse {
            let nominal = diffusion(&LayerStack::at_texel(p, 0.5, 0.5), &m.pre.borders);
            let var = |x: Vec3, x0: Vec3| {
                Vec3::from_array([0, 1, 2].map(|c| if x0[c] > 0.0 { x[c] / x0[c] } else { 1.0 }))
            };
            [
                var(diff.r_top, nominal.r_top),
                var(diff.r_bottom, nominal.r_bottom),
                var(diff.t, nominal.t),
            ]
        } else {
            m.pre.ratios.at(t, e)
        };
        let albedo = [
            (cf * lambda * ratio[0]).min(Vec3::ONE),
            (cb * lambda * ratio[1]).min(Vec3::ONE),
            (ct * lambda * ratio[2]).min(Vec3::ONE),
        ];
        let normal = match &m.maps.bump {
            Some(t) if p.bump_scale > 0.0 => {
                let g = old_gradient(t, uv) * p.bump_scale;
                let mut n = Vec3::new(-g.x, -g.y, 1.0).normalize();
                if !n.is_finite() {
                    n = Vec3::Z;
                }
                const MIN_Z: f32 = 0.2;
                if n.z < MIN_Z {
                    let xy = Vec2::new(n.x, n.y).normalize_or_zero() * (1.0 - MIN_Z * MIN_Z).sqrt();
                    n = Vec3::new(xy.x, xy.y, MIN_Z);
                }
                n
            }
            _ => Vec3::Z,
        };
        let mut b = LeafBsdf::physical(p.mode, stack, diff, m.pre.r_out);
        b.scale = scale;
        b.albedo = albedo;
        b.shading = Frame::from_normal_tangent(normal, Vec3::X);
        b.alpha = [p.roughness_adaxial, p.roughness_abaxial];
        b.specular = p.specular;
        b.inv_blend = 1.0 / p.blend_width_deg.to_radians().sin();
        b
    }

    /// `LeafMaterial::bsdf` as it was, with today's Kubelka-Munk slab.
    fn old_bsdf(m: &LeafMaterial, uv: Vec2) -> LeafBsdf {
        old_bsdf_with(m, uv, false)
    }

    /// A `w x h` map of `f(u, v)` at the texel centres.
    fn map(w: u32, h: u32, wrap: Wrap, f: impl Fn(f32, f32) -> Vec4) -> Option<Texture> {
        let texels = (0..w * h)
            .map(|i| f((i % w) as f32 / w as f32, (i / w) as f32 / h as f32))
            .collect();
        Some(Texture::from_texels(w, h, texels, wrap))
    }

    /// Seven maps with colours partly outside `[0, 1]` (as EXR maps can be), thickness and
    /// extinction spanning `[0, 1]` and a steep bump map; `sizes` gives each map's size.
    fn maps(sizes: [(u32, u32); 7], wrap: Wrap) -> LeafMaps {
        let [f, b, tr, al, th, ex, bu] = sizes;
        LeafMaps {
            front: map(f.0, f.1, wrap, |u, v| {
                Vec4::new(0.05 + 0.2 * u, 0.2 + v, 0.03 + 0.05 * v, 1.0)
            }),
            back: map(b.0, b.1, wrap, |u, _| {
                Vec4::new(0.1, 0.25 + 0.1 * u, 0.08, 1.0)
            }),
            translucency: map(tr.0, tr.1, wrap, |u, v| {
                Vec4::new(0.1 * u, 0.3, -0.02 + 0.1 * v, 1.0)
            }),
            alpha: map(al.0, al.1, wrap, |u, _| {
                Vec4::splat(if u < 0.9 { 1.0 } else { 0.0 })
            }),
            thickness: map(th.0, th.1, wrap, |u, v| {
                Vec4::splat((0.5 + 0.6 * (20.0 * u).sin() * v).clamp(0.0, 1.0))
            }),
            extinction: map(ex.0, ex.1, wrap, |u, v| {
                Vec4::splat((0.5 + 0.6 * (17.0 * v).sin() * u).clamp(0.0, 1.0))
            }),
            bump: map(bu.0, bu.1, wrap, |u, v| {
                Vec4::splat(0.02 * (30.0 * u).sin() * (25.0 * v).cos())
            }),
        }
    }

    fn materials() -> Vec<(&'static str, LeafMaterial)> {
        let same = [(48, 40); 7];
        let mixed = [
            (48, 40),
            (32, 32),
            (1, 1),
            (16, 16),
            (20, 24),
            (48, 40),
            (64, 8),
        ];
        let consts = [(1, 1), (1, 1), (1, 1), (1, 1), (11, 11), (11, 11), (1, 1)];
        let mut v = Vec::new();
        for (mode, mname) in [
            (LeafMode::Layered, "layered"),
            (LeafMode::Eq1, "eq1"),
            (LeafMode::Diffuse, "diffuse"),
        ] {
            let params = LeafParams {
                mode,
                bump_scale: 0.02,
                ..Default::default()
            };
            for (name, sizes, wrap) in [
                ("same size, repeat", same, Wrap::Repeat),
                ("same size, clamp", same, Wrap::Clamp),
                ("mixed sizes", mixed, Wrap::Repeat),
                ("constants and ramps", consts, Wrap::Clamp),
            ] {
                let m = LeafMaterial::new(maps(sizes, wrap), params).unwrap();
                assert_eq!(m.packed.is_some(), name != "mixed sizes", "{name}");
                let _ = mname;
                v.push((name, m));
            }
        }
        // Some maps only, no bump lookups, and no maps at all.
        let mut some = maps([(48, 40); 7], Wrap::Repeat);
        some.back = None;
        some.translucency = None;
        some.extinction = None;
        v.push((
            "front and thickness",
            LeafMaterial::new(some, LeafParams::default()).unwrap(),
        ));
        let flat = LeafParams {
            bump_scale: 0.0,
            ..Default::default()
        };
        v.push((
            "bump scale 0",
            LeafMaterial::new(maps([(48, 40); 7], Wrap::Repeat), flat).unwrap(),
        ));
        v.push((
            "no maps",
            LeafMaterial::new(LeafMaps::default(), LeafParams::default()).unwrap(),
        ));
        v
    }

    /// Texture coordinates: random ones inside and outside `[0, 1]`, texel centres and
    /// borders, and absurd ones.
    fn uvs() -> Vec<Vec2> {
        let mut rng = Pcg32::new(11);
        let mut v: Vec<Vec2> = (0..3000)
            .map(|_| Vec2::new(rng.next_f32(), rng.next_f32()) * 2.0 - Vec2::splat(0.5))
            .collect();
        for i in 0..=48 {
            v.push(Vec2::new(i as f32 / 48.0, 1.0 - i as f32 / 40.0));
            v.push(Vec2::new((i as f32 + 0.5) / 48.0, (i as f32 + 0.5) / 40.0));
        }
        v.extend([
            Vec2::ZERO,
            Vec2::ONE,
            Vec2::new(-0.0, -0.0),
            Vec2::new(1e30, 0.5),
            Vec2::new(0.5, -1e30),
            Vec2::new(f32::MAX, f32::MIN),
            Vec2::new(f32::NAN, 0.5),
            Vec2::new(0.5, f32::INFINITY),
        ]);
        v
    }

    #[test]
    fn texel_bsdf_is_bit_identical_to_the_per_map_computation() {
        let uvs = uvs();
        for (name, m) in materials() {
            for &uv in &uvs {
                let (new, old) = (m.bsdf(uv), old_bsdf(&m, uv));
                assert_eq!(new, old, "{name}, mode {:?}, uv {uv:?}", m.params.mode);
                assert_eq!(m.map_colours(uv), old_map_colours(&m, uv), "{name} {uv:?}");
            }
        }
    }

    /// Largest relative difference of the float fields of two texel BSDFs (floor `1e-30`);
    /// the others must be equal.
    fn bsdf_difference(a: &LeafBsdf, b: &LeafBsdf) -> f32 {
        assert_eq!(
            (
                a.mode,
                a.stack,
                a.r_out,
                a.shading,
                a.alpha,
                a.specular,
                a.inv_blend
            ),
            (
                b.mode,
                b.stack,
                b.r_out,
                b.shading,
                b.alpha,
                b.specular,
                b.inv_blend
            )
        );
        let rel = |x: Vec3, y: Vec3| {
            ((x - y).abs() / x.abs().max(y.abs()).max(Vec3::splat(1e-30))).max_element()
        };
        let (da, db) = (&a.diffusion, &b.diffusion);
        [
            rel(da.r_top, db.r_top),
            rel(da.r_bottom, db.r_bottom),
            rel(da.t, db.t),
        ]
        .into_iter()
        .chain((0..3).map(|k| rel(a.scale[k], b.scale[k])))
        .chain((0..3).map(|k| rel(a.albedo[k], b.albedo[k])))
        .fold(0.0, f32::max)
    }

    /// End to end against the old computation including its libm Kubelka-Munk: equal up
    /// to float rounding (relative `5e-6`; the one-exponential `tanh`/`sech` differ from
    /// libm's by a few units in the last place).
    #[test]
    fn texel_bsdf_matches_the_old_computation_with_libm_kubelka_munk() {
        let uvs = uvs();
        let mut worst = 0.0f32;
        for (name, m) in materials() {
            for &uv in &uvs {
                let d = bsdf_difference(&m.bsdf(uv), &old_bsdf_with(&m, uv, true));
                assert!(d < 5e-6, "{name}, mode {:?}, uv {uv:?}: {d}", m.params.mode);
                worst = worst.max(d);
            }
        }
        eprintln!("texel BSDF: largest relative difference {worst}");
    }

    #[test]
    fn floor_without_libm_is_floor() {
        let mut rng = Pcg32::new(5);
        for _ in 0..100_000 {
            let x = (rng.next_f32() - 0.5) * 2f32.powi((rng.next_u32() % 40) as i32 - 8);
            assert_eq!(
                crate::texture::floor_finite(x).to_bits(),
                x.floor().to_bits(),
                "{x}"
            );
        }
        for x in [
            0.0,
            -0.0,
            1.0,
            -1.0,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            1e30,
            -1e30,
        ] {
            assert_eq!(
                crate::texture::floor_finite(x).to_bits(),
                x.floor().to_bits(),
                "{x}"
            );
        }
    }

    #[test]
    fn pruned_energy_rows_give_the_same_bound() {
        let mut rng = Pcg32::new(9);
        for (name, m) in materials() {
            let kept = m.pre.binding.iter().map(Vec::len).sum::<usize>();
            assert!(kept <= 2 * (TABLE_N + 1), "{name}");
            eprintln!(
                "{name} {:?}: {kept} energy rows of {}",
                m.params.mode,
                2 * (TABLE_N + 1)
            );
            for k in 0..20_000 {
                let mut c = || {
                    // Some zeros, tiny and large values among them.
                    let r = rng.next_f32();
                    let x = rng.next_f32();
                    match k % 4 {
                        0 => x,
                        1 if r < 0.3 => 0.0,
                        1 => x * 1e-6,
                        2 => x * x * x,
                        _ => 1.0 - x * 1e-3,
                    }
                };
                let mut v = || Vec3::new(c(), c(), c());
                let (f, b, t) = (v(), v(), v());
                let new = m.pre.energy_scale(f, b, t);
                let old = old_energy_scale(&m.pre, f, b, t);
                assert_eq!(new, old, "{name}: {f} {b} {t}");
            }
        }
    }

    /// A variant with the identity map and the same parameters is the material itself, bit
    /// for bit, whatever maps are missing: the colours of missing maps are derived as the
    /// RGB material does.
    #[test]
    fn identity_variant_is_the_material() {
        for (name, m) in materials() {
            let v = m.variant(m.params, Mat3::IDENTITY).unwrap();
            for uv in uvs() {
                assert_eq!(v.bsdf(uv), m.bsdf(uv), "{name} at {uv}");
                assert_eq!(v.map_colours(uv), m.map_colours(uv), "{name} at {uv}");
            }
        }
    }

    /// A variant in other channels equals the material built from maps converted texel by
    /// texel (what band renders did before variants), where every colour map is present; it
    /// shares the maps instead of copying them; variants of variants compose their maps.
    #[test]
    fn variant_equals_converted_maps() {
        let m3 = Mat3::from_cols(
            Vec3::new(0.6, 0.1, 0.0),
            Vec3::new(0.3, 0.7, 0.2),
            Vec3::new(0.1, 0.2, 0.8),
        );
        let convert = |t: &Texture, m: Mat3| {
            let texels = t
                .texels()
                .iter()
                .map(|v| (m * v.truncate().clamp(Vec3::ZERO, Vec3::ONE)).extend(v.w))
                .collect();
            Texture::from_texels(t.width(), t.height(), texels, t.wrap)
        };
        for (name, m) in materials() {
            if m.maps.front.is_none() || m.maps.back.is_none() || m.maps.translucency.is_none() {
                continue;
            }
            // Colours inside [0, 1] (where clamping the filtered value and filtering clamped
            // texels agree).
            let mut inside = m.maps.clone();
            for t in [
                &mut inside.front,
                &mut inside.back,
                &mut inside.translucency,
            ]
            .into_iter()
            .flatten()
            {
                *t = convert(t, Mat3::IDENTITY);
            }
            let m = LeafMaterial::new(inside, m.params).unwrap();
            let mut params = m.params;
            for l in [&mut params.upper, &mut params.mesophyll, &mut params.lower] {
                l.absorption = m3 * l.absorption;
            }
            let v = m.variant(params, m3).unwrap();
            let mut maps = m.maps.clone();
            for t in [&mut maps.front, &mut maps.back, &mut maps.translucency]
                .into_iter()
                .flatten()
            {
                *t = convert(t, m3);
            }
            let reference = LeafMaterial::new(maps, params).unwrap();
            assert!(
                v.maps
                    .front
                    .as_ref()
                    .unwrap()
                    .is_same_image(m.maps.front.as_ref().unwrap()),
                "{name}: shared"
            );
            for uv in uvs()
                .into_iter()
                .filter(|uv| uv.is_finite() && uv.abs().max_element() < 4.0)
            {
                let (a, b) = (v.map_colours(uv), reference.map_colours(uv));
                for k in 0..3 {
                    assert!(
                        (a[k] - b[k]).abs().max_element() < 1e-5,
                        "{name} {uv}: {a:?} {b:?}"
                    );
                }
                let d = bsdf_difference(&v.bsdf(uv), &reference.bsdf(uv));
                assert!(d < 1e-4, "{name} {uv}: {d}");
            }
            // A variant of the variant: the maps through both matrices.
            let vv = v.variant(params, m3).unwrap();
            let uv = Vec2::new(0.3, 0.6);
            let want = (m3
                * (m3
                    * m.maps
                        .front
                        .as_ref()
                        .unwrap()
                        .rgb(uv)
                        .clamp(Vec3::ZERO, Vec3::ONE)))
            .clamp(Vec3::ZERO, Vec3::ONE);
            assert!(
                (vv.map_colours(uv)[0] - want).abs().max_element() < 1e-5,
                "{name}"
            );
        }
    }

    /// A material made `new_like` another whose data maps it shares is the material `new`
    /// makes, bit for bit, and holds the other's grid instead of its own.
    #[test]
    fn new_like_shares_the_grid_and_changes_nothing() {
        for (name, m) in materials() {
            let mut maps = m.maps.clone();
            maps.front = Some(Texture::constant(Vec4::new(0.1, 0.4, 0.05, 1.0)));
            maps.back = Some(Texture::constant(Vec4::new(0.2, 0.3, 0.1, 1.0)));
            maps.translucency = None;
            let params = LeafParams {
                specular: 0.3,
                ..m.params
            };
            let like = LeafMaterial::new_like(maps.clone(), params, &m).unwrap();
            let fresh = LeafMaterial::new(maps, params).unwrap();
            if let (Some(a), Some(b)) = (&like.packed, &m.packed) {
                assert!(
                    std::sync::Arc::ptr_eq(&a.texels_arc(), &b.texels_arc()),
                    "{name}"
                );
            }
            assert_eq!(like.packed.is_some(), fresh.packed.is_some(), "{name}");
            for uv in uvs() {
                assert_eq!(like.bsdf(uv), fresh.bsdf(uv), "{name} at {uv}");
            }
            assert_eq!(like.alpha_from_channel, fresh.alpha_from_channel);
            assert_eq!(like.ranges, fresh.ranges);
        }
    }

    /// Several channel variants of a leaf at once (RGB variants sharing the colour maps,
    /// pigment-like variants with their own constant colours): `bsdf_sets` and
    /// `LeafBsdf::eval_sets` equal each variant's own `bsdf` and `eval` bit for bit, and
    /// `LeafBsdf::pdf_mean` the mean of their `pdf`s.
    /// [`white_sky_albedos`] as it was written before the azimuths were summed in one
    /// evaluation: one BSDF evaluation per pair of directions.
    fn per_direction_white_sky(b: &LeafBsdf) -> [Vec3; 3] {
        let node = |i: usize| {
            let x = (i as f32 + 0.5) / RATIO_MU as f32;
            (x * x, 2.0 * x / RATIO_MU as f32)
        };
        let mut acc = [Vec3::ZERO; 3];
        for io in 0..RATIO_MU {
            let (mo, wmo) = node(io);
            let so = (1.0 - mo * mo).max(0.0).sqrt();
            for ii in 0..RATIO_MU {
                let (mi, wmi) = node(ii);
                let si = (1.0 - mi * mi).max(0.0).sqrt();
                let w = 4.0 * std::f32::consts::PI / RATIO_PHI as f32 * wmo * mo * wmi * mi;
                for k in 0..RATIO_PHI {
                    let phi = std::f32::consts::PI * (k as f32 + 0.5) / RATIO_PHI as f32;
                    let (sp, cp) = phi.sin_cos();
                    let i_up = Vec3::new(si * cp, si * sp, mi);
                    let i_dn = Vec3::new(si * cp, si * sp, -mi);
                    acc[0] += b.subsurface(Vec3::new(so, 0.0, mo), i_up) * w;
                    acc[1] += b.subsurface(Vec3::new(so, 0.0, -mo), i_dn) * w;
                    acc[2] += b.subsurface_one_way(Vec3::new(so, 0.0, -mo), i_up) * w;
                }
            }
        }
        acc
    }

    /// [`directional_albedos`] one BSDF evaluation per pair of directions.
    fn per_direction_directional(b: &LeafBsdf, mu: f32) -> [Vec3; 4] {
        let (nm, np) = (24, 12);
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        let (up, down) = (Vec3::new(s, 0.0, mu), Vec3::new(s, 0.0, -mu));
        let mut acc = [Vec3::ZERO; 4];
        for i in 0..nm {
            let x = (i as f32 + 0.5) / nm as f32;
            let mo = x * x;
            let so = (1.0 - mo * mo).max(0.0).sqrt();
            for j in 0..np {
                let phi = std::f32::consts::PI * (j as f32 + 0.5) / np as f32;
                let w = 2.0 * std::f32::consts::PI / np as f32 * (2.0 * x / nm as f32) * mo;
                let (sp, cp) = phi.sin_cos();
                let o_up = Vec3::new(so * cp, so * sp, mo);
                let o_dn = Vec3::new(so * cp, so * sp, -mo);
                acc[0] += b.subsurface(o_up, up) * w;
                acc[1] += b.subsurface(o_dn, down) * w;
                acc[2] += b.subsurface(o_dn, up) * w;
                acc[3] += b.subsurface(o_up, down) * w;
            }
        }
        acc
    }

    #[test]
    fn summed_azimuths_equal_the_per_direction_quadratures() {
        let close =
            |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 2e-6 * b.abs().max_element() + 1e-9;
        let mut params = vec![LeafParams::default()];
        for g in [-0.6, 0.0, 0.95] {
            let mut p = LeafParams {
                phase_g: g,
                ..Default::default()
            };
            p.mesophyll.absorption *= 7.0;
            params.push(p);
        }
        params.push(LeafParams {
            mode: LeafMode::Eq1,
            ..Default::default()
        });
        for p in params {
            for (t, e) in [(0.5, 0.5), (0.05, 0.95), (1.0, 0.0)] {
                let s = LayerStack::at_texel(&p, t, e);
                let borders = BorderReflectances::new(&s);
                let r_out = [borders.from_above[0], borders.from_below[3]];
                let b = LeafBsdf::physical(p.mode, s, diffusion(&s, &borders), r_out);
                let (got, want) = (white_sky_albedos(&b), per_direction_white_sky(&b));
                for x in 0..3 {
                    assert!(
                        close(got[x], want[x]),
                        "{:?} g {} ({t}, {e}) lobe {x}: {} vs {}",
                        p.mode,
                        p.phase_g,
                        got[x],
                        want[x]
                    );
                }
                for mu in [0.01, 0.3, 0.99, 1.0] {
                    let (got, want) = (
                        directional_albedos(&b, mu),
                        per_direction_directional(&b, mu),
                    );
                    for x in 0..4 {
                        assert!(
                            close(got[x], want[x]),
                            "{:?} mu {mu} lobe {x}: {} vs {}",
                            p.mode,
                            got[x],
                            want[x]
                        );
                    }
                }
            }
        }
    }

    /// Parameters of one leaf in other channels: the same layers and indices, other
    /// absorption and scattering (as a pigment leaf at other wavelengths, or an RGB leaf
    /// through a band basis).
    fn channel_params(p: LeafParams) -> Vec<LeafParams> {
        [
            (Vec3::ONE, Vec3::ONE),
            (Vec3::new(0.5, 2.0, 3.0), Vec3::ONE),
            (Vec3::new(40.0, 0.01, 1.0), Vec3::new(0.5, 1.5, 1.0)),
            (Vec3::ZERO, Vec3::new(2.0, 0.1, 1.0)),
        ]
        .into_iter()
        .map(|(a, sc)| {
            let mut q = p;
            for l in [&mut q.upper, &mut q.mesophyll, &mut q.lower] {
                l.absorption = l.absorption * a + Vec3::new(0.0, 0.3, 0.0) * a;
                l.scattering *= sc;
            }
            q
        })
        .collect()
    }

    /// The white-sky albedo ratio table between its nodes: over the full `[0, 1]` (9 x 9
    /// nodes) and over a species' narrower maps (0.4-0.8 and 0.35-0.75: 5 x 5 nodes), the
    /// interpolated ratios at the cells' centres against the albedos integrated there. The
    /// narrow table, with fewer nodes, is no less accurate than the full one.
    #[test]
    fn albedo_ratio_table_between_its_nodes() {
        let params = LeafParams {
            thickness_variation: 0.8,
            extinction_strength: 0.8,
            ..Default::default()
        };
        let physical = |t: f32, e: f32| {
            let s = LayerStack::at_texel(&params, t, e);
            let borders = BorderReflectances::new(&s);
            let r_out = [borders.from_above[0], borders.from_below[3]];
            LeafBsdf::physical(params.mode, s, diffusion(&s, &borders), r_out)
        };
        let worst = |t_range: (f32, f32), e_range: (f32, f32)| {
            let pre = Precomputed::new(&params, t_range, e_range);
            let (tn, en) = (ratio_nodes(t_range), ratio_nodes(e_range));
            let a0 = white_sky_albedos(&physical(0.5, 0.5));
            let mut worst = 0.0f32;
            for ti in tn.windows(2) {
                for ei in en.windows(2) {
                    let (t, e) = (0.5 * (ti[0] + ti[1]), 0.5 * (ei[0] + ei[1]));
                    let exact = white_sky_albedos(&physical(t, e));
                    let got = pre.ratios.at(t, e);
                    for lobe in 0..3 {
                        let rel = (got[lobe] * a0[lobe] / exact[lobe] - Vec3::ONE).abs();
                        worst = worst.max(rel.max_element());
                    }
                }
            }
            (tn.len(), en.len(), worst)
        };
        let full = worst((0.0, 1.0), (0.0, 1.0));
        let narrow = worst((0.4, 0.8), (0.35, 0.75));
        println!("full {full:?}, narrow {narrow:?}");
        assert_eq!((full.0, full.1), (RATIO_N, RATIO_N));
        assert_eq!((narrow.0, narrow.1), (5, 5));
        // Measured: 6.6 % over the full range (its thinnest, least absorbing corner), 0.97 %
        // over the narrow one (0.23 % with 9 x 9 nodes there).
        assert!(full.2 < 0.08, "full range: {}", full.2);
        assert!(narrow.2 < 0.012, "narrow range: {}", narrow.2);
        assert!(narrow.2 <= full.2, "narrow {} vs full {}", narrow.2, full.2);
    }

    #[test]
    fn precomputations_together_equal_one_by_one() {
        for (name, m) in materials() {
            let ps = channel_params(m.params);
            let each = Precomputed::new_each(&ps, m.ranges[0], m.ranges[1]);
            assert_eq!(each.len(), ps.len());
            for (p, got) in ps.iter().zip(&each) {
                let one = Precomputed::new(p, m.ranges[0], m.ranges[1]);
                assert_eq!(format!("{got:?}"), format!("{one:?}"), "{name}");
            }
            // The layered ones share their geometry (what makes them faster together).
            let b: Vec<LeafBsdf> = ps
                .iter()
                .map(|p| {
                    let s = LayerStack::at_texel(p, 0.3, 0.7);
                    let borders = BorderReflectances::new(&s);
                    let r_out = [borders.from_above[0], borders.from_below[3]];
                    LeafBsdf::physical(p.mode, s, diffusion(&s, &borders), r_out)
                })
                .collect();
            assert_eq!(
                LeafBsdf::share_subsurface_geometry(&b),
                m.params.mode == LeafMode::Layered,
                "{name}"
            );
        }
        // Mixed modes fall back to one by one.
        let mut ps = channel_params(LeafParams::default());
        ps[1].mode = LeafMode::Eq1;
        let each = Precomputed::new_each(&ps, (0.2, 0.9), (0.1, 0.6));
        for (p, got) in ps.iter().zip(&each) {
            let one = Precomputed::new(p, (0.2, 0.9), (0.1, 0.6));
            assert_eq!(format!("{got:?}"), format!("{one:?}"));
        }
        assert!(Precomputed::new_each(&[], (0.5, 0.5), (0.5, 0.5)).is_empty());
    }

    #[test]
    fn variants_and_materials_together_equal_one_by_one() {
        let m =
            LeafMaterial::new(maps([(48, 40); 7], Wrap::Repeat), LeafParams::default()).unwrap();
        let items: Vec<(LeafParams, Mat3)> = channel_params(m.params)
            .into_iter()
            .enumerate()
            .map(|(k, p)| (p, Mat3::from_diagonal(Vec3::splat(1.0 - 0.1 * k as f32))))
            .collect();
        let together = m.variant_each(items.clone()).unwrap();
        let with_maps: Vec<(LeafMaps, LeafParams)> =
            items.iter().map(|&(p, _)| (m.maps.clone(), p)).collect();
        let like = LeafMaterial::new_like_each(with_maps.clone(), &m).unwrap();
        let fresh = LeafMaterial::new_each(with_maps.clone()).unwrap();
        for ((maps, p), got) in with_maps.into_iter().zip(&fresh) {
            let one = LeafMaterial::new(maps, p).unwrap();
            assert_eq!(format!("{:?}", got.pre), format!("{:?}", one.pre));
            assert_eq!(got.bsdf(Vec2::new(0.3, 0.6)), one.bsdf(Vec2::new(0.3, 0.6)));
        }
        for (k, (p, mat)) in items.into_iter().enumerate() {
            let one = m.variant(p, mat).unwrap();
            let one_like = LeafMaterial::new_like(m.maps.clone(), p, &m).unwrap();
            for uv in uvs() {
                assert_eq!(together[k].bsdf(uv), one.bsdf(uv), "variant {k} at {uv}");
                assert_eq!(like[k].bsdf(uv), one_like.bsdf(uv), "new_like {k} at {uv}");
            }
            assert_eq!(format!("{:?}", together[k].pre), format!("{:?}", one.pre));
            assert_eq!(format!("{:?}", like[k].pre), format!("{:?}", one_like.pre));
        }
        // A bad parameter set is named, as one by one.
        let mut bad = m.params;
        bad.thickness_mm = -1.0;
        assert!(
            m.variant_each(vec![(m.params, Mat3::IDENTITY), (bad, Mat3::IDENTITY)])
                .is_err()
        );
    }

    #[test]
    fn channel_sets_equal_each_variant() {
        use crate::bsdf::Bsdf;
        let m3 = |a: f32| {
            Mat3::from_cols(
                Vec3::new(0.6, 0.1 * a, 0.0),
                Vec3::new(0.3, 0.7, 0.2 * a),
                Vec3::new(0.1, 0.2 * a, 0.8),
            )
        };
        let mut rng = Pcg32::new(5);
        for (name, m) in materials() {
            let mut pa = m.params;
            pa.mesophyll.absorption *= Vec3::new(0.5, 2.0, 3.0);
            let a = m.variant(m.params, m3(1.0)).unwrap();
            let b = m.variant(pa, m3(0.5)).unwrap();
            let mut cmaps = m.maps.clone();
            cmaps.front = Some(Texture::constant(Vec4::new(0.2, 0.5, 0.1, 1.0)));
            let c = LeafMaterial::new_like(cmaps, pa, &m).unwrap();
            for uv in uvs() {
                let sets = LeafMaterial::bsdf_sets([&a, &b, &c], uv);
                assert_eq!(sets, [a.bsdf(uv), b.bsdf(uv), c.bsdf(uv)], "{name} at {uv}");
                for _ in 0..8 {
                    let wo =
                        crate::sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                    let wi =
                        crate::sampling::uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
                    let refs = [&sets[0], &sets[1], &sets[2]];
                    let each = refs.map(|s| s.eval(wo, wi));
                    assert_eq!(LeafBsdf::eval_sets(refs, wo, wi), each, "{name}");
                    let mean = refs.iter().map(|s| s.pdf(wo, wi)).sum::<f32>() / 3.0;
                    let got = LeafBsdf::pdf_mean(refs, wo, wi);
                    assert!(
                        (got - mean).abs() <= 1e-5 * mean.abs() + 1e-12,
                        "{name}: {got} {mean}"
                    );
                }
            }
        }
    }
}
