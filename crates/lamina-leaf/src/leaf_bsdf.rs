//! The leaf BSDF at one texel: subsurface light (single scattering plus diffusion, or the
//! paper's Eq. (1), or the fully diffusing limit) scaled so the maps keep their meaning,
//! plus the specular surface lobe, with a bump-mapped shading normal.
//!
//! # Sides and the shading normal
//! Reflection versus transmission, and adaxial versus abaxial, are decided by the
//! *geometric* normal (`+z`): both directions on `+z` is adaxial reflection (front map,
//! waxy sharp highlight), both on `-z` abaxial reflection (back map, rough highlight),
//! opposite sides transmission (translucency map, the same lobe from both sides). The bump
//! map's shading normal `n_s` (always on the `+z` side, `n_s.z >= 0.2`) enters in two places:
//! the specular lobe lives in the shading frame (flipped to `-n_s` on the abaxial side), and
//! the subsurface lobes use the shading cosine `max(0, wi . ±n_s)` in place of `|wi.z|`.
//! Within [`crate::LeafParams::blend_width_deg`] of the leaf plane both blend smoothly
//! (smoothstep in `|z|`) back to the geometric cosine, which vanishes at the plane, and the
//! specular lobe fades to zero there: a light crossing the plane changes the value
//! continuously however the bump map tilts the shading normal.
//!
//! # Sampling
//! One of three lobes is chosen with probabilities proportional to their albedo estimates
//! (specular: the epidermis Fresnel reflectance at `wo` times `specular`; diffuse
//! reflection and transmission: luminance of the texel's albedos). Specular: GGX visible
//! normals; diffuse lobes: cosine-weighted on the respective side. [`Bsdf::pdf`] returns the
//! mixture density, so `sample`'s weight is exactly `eval / pdf`.

use crate::analytic::{
    same_slab_geometry, single_scatter, single_scatter_and_surface,
    single_scatter_and_surface_sets, single_scatter_mirrored, single_scatter_summed_each,
};
use crate::bsdf::{Bsdf, BsdfSample};
use crate::diffusion::Diffusion;
use crate::frame::Frame;
use crate::layers::{LayerStack, fresnel_dielectric, fresnel_transmission, refracted_cos};
use crate::march::{Pcg32, single_scatter_marched};
use crate::params::LeafMode;
use crate::sampling::{cosine_hemisphere, luminance};
use crate::specular;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// The leaf's BSDF at one texel, in the local frame (`+z` = geometric normal on the adaxial
/// side). `Copy`, no allocation; built by [`crate::LeafMaterial::bsdf`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafBsdf {
    pub(crate) mode: LeafMode,
    /// Layers at this texel, adaxial first.
    pub(crate) stack: LayerStack,
    /// Kubelka-Munk diffusion of this texel's stack.
    pub(crate) diffusion: Diffusion,
    /// Hemispherical Fresnel reflectance of the adaxial / abaxial surface from outside.
    pub(crate) r_out: [f32; 2],
    /// `1 / (1 - r_out)` per side: the diffusion lobes' normalisation.
    pub(crate) inv_t_out: [f32; 2],
    /// Multipliers of the physical subsurface BSDF: adaxial R, abaxial R, T.
    pub(crate) scale: [Vec3; 3],
    /// Diffuse albedos at this texel (adaxial R, abaxial R, T), linear RGB.
    pub(crate) albedo: [Vec3; 3],
    /// Shading frame (bump-mapped normal, `+z` side).
    pub(crate) shading: Frame,
    /// GGX roughness, adaxial / abaxial.
    pub(crate) alpha: [f32; 2],
    /// Weight of the specular lobe.
    pub(crate) specular: f32,
    /// One over the sine of the blend width next to the plane.
    pub(crate) inv_blend: f32,
}

/// `smoothstep(0, 1, x)`.
#[inline]
fn smooth(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl LeafBsdf {
    /// A texel BSDF with the physical subsurface model unscaled (maps ignored), no
    /// specular lobe and a flat normal: the raw layer model. Used to normalise the maps and
    /// by tests and plots.
    pub fn physical(
        mode: LeafMode,
        stack: LayerStack,
        diffusion: Diffusion,
        r_out: [f32; 2],
    ) -> Self {
        LeafBsdf {
            mode,
            stack,
            diffusion,
            r_out,
            inv_t_out: r_out.map(|r| 1.0 / (1.0 - r)),
            scale: [Vec3::ONE; 3],
            albedo: [Vec3::ZERO; 3],
            shading: Frame::from_normal_tangent(Vec3::Z, Vec3::X),
            alpha: [0.2, 0.5],
            specular: 0.0,
            inv_blend: 10.0,
        }
    }

    /// Hemispherical diffuse reflectance seen from the adaxial side and diffuse
    /// transmittance at this texel (linear RGB): the white-sky albedos of the subsurface
    /// lobes [`Bsdf::eval`] returns here, specular excluded and bump map excluded (flat
    /// frame), see [`crate::material`]. Used by the paper integrator's ambient term and the
    /// GPU bake.
    pub fn diffuse_albedo(&self) -> (Vec3, Vec3) {
        (self.albedo[0], self.albedo[2])
    }

    /// Hemispherical diffuse reflectance seen from the abaxial side.
    pub fn diffuse_albedo_abaxial(&self) -> Vec3 {
        self.albedo[1]
    }

    /// The layers at this texel, adaxial first.
    pub fn stack(&self) -> &LayerStack {
        &self.stack
    }

    /// The bump-mapped shading normal (local frame, `z > 0`).
    pub fn shading_normal(&self) -> Vec3 {
        self.shading.n
    }

    /// Normalised Fresnel transmission of the outer surface on the side of `w`:
    /// `(1 - F) / (1 - r_out)`, cosine-weighted mean 1 over the hemisphere.
    #[inline]
    fn surface_t(&self, w: Vec3) -> f32 {
        let (side, n) = if w.z > 0.0 {
            (0, self.stack.layers[0].ior)
        } else {
            (1, self.stack.layers[2].ior)
        };
        fresnel_transmission(w.z.abs(), n) * self.inv_t_out[side]
    }

    /// Optical depth of the whole blade along the direction `w` refracted into it.
    #[inline]
    fn optical_depth(&self, w: Vec3) -> Vec3 {
        let c = w.z.abs();
        self.stack.layers.iter().fold(Vec3::ZERO, |acc, l| {
            acc + l.sigma_t() * (l.d / refracted_cos(c, l.ior))
        })
    }

    /// The diffuse albedo of the lobe `wo`, `wi` belong to (adaxial or abaxial reflection,
    /// or transmission).
    #[inline]
    fn diffuse_lobe(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z < 0.0 {
            self.diffusion.t
        } else if wo.z > 0.0 {
            self.diffusion.r_top
        } else {
            self.diffusion.r_bottom
        }
    }

    /// The diffusion part of the physical model (1/sr, no cosine).
    #[inline]
    fn diffusion_term(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.diffuse_lobe(wo, wi) * (self.surface_t(wo) * self.surface_t(wi) * FRAC_1_PI)
    }

    /// The layered model's subsurface BSDF (single scattering plus diffusion), the outer
    /// surfaces' Fresnel transmissions taken from the single-scattering computation.
    #[inline]
    fn layered(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (ss, [t_wo, t_wi]) = single_scatter_and_surface(&self.stack, wo, wi);
        let side = |w: Vec3| if w.z > 0.0 { 0 } else { 1 };
        let norm = self.inv_t_out[side(wo)] * self.inv_t_out[side(wi)];
        ss + self.diffuse_lobe(wo, wi) * (t_wo * t_wi * norm * FRAC_1_PI)
    }

    /// The physical subsurface BSDF of the texel's layers (1/sr, no cosine, maps not
    /// applied), with the single-scattering part supplied by `single`.
    #[inline]
    fn subsurface_with(&self, wo: Vec3, wi: Vec3, single: impl FnOnce() -> Vec3) -> Vec3 {
        if wo.z == 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        match self.mode {
            LeafMode::Layered => single() + self.diffusion_term(wo, wi),
            LeafMode::Eq1 => {
                let ss = (-(self.optical_depth(wo) + self.optical_depth(wi))).exp();
                (Vec3::ONE + ss) * FRAC_1_PI
            }
            LeafMode::Diffuse => self.diffuse_lobe(wo, wi) * FRAC_1_PI,
        }
    }

    /// The physical subsurface BSDF (1/sr, no cosine, maps not applied) with the
    /// closed-form single scattering.
    pub fn subsurface(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.mode == LeafMode::Layered && wo.z != 0.0 && wi.z != 0.0 {
            return self.layered(wo, wi);
        }
        self.subsurface_with(wo, wi, || self.single(wo, wi))
    }

    /// [`Self::subsurface`] with transmission from the closed form for the light's side only
    /// (no mirror average): half the cost, and the same white-sky albedo, since single
    /// scattering is reciprocal.
    pub(crate) fn subsurface_one_way(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.subsurface_with(wo, wi, || single_scatter(&self.stack, wo, wi))
    }

    /// Whether [`Self::subsurface_summed_each`] shares the geometry of `b`: layered texels whose
    /// layers have the same indices, `g` and outer-surface normalisation (one leaf's
    /// texel in several channel sets, or at several thickness and extinction values).
    pub(crate) fn share_subsurface_geometry(b: &[LeafBsdf]) -> bool {
        b.iter().all(|x| {
            x.mode == LeafMode::Layered
                && same_slab_geometry(&b[0].stack, &x.stack)
                && x.inv_t_out == b[0].inv_t_out
        })
    }

    /// Azimuthal quadratures of [`Self::subsurface`] for several texels: `out(k, sum_j c_j
    /// f_k(wo_j, wi_j))` over `pairs` `(wo_j, wi_j, c_j)`, which share `wo.z` and `wi.z` and differ
    /// in azimuth, `f_k` the subsurface BSDF of `b[k]` (with `one_way`,
    /// [`Self::subsurface_one_way`]'s). Where `share` ([`Self::share_subsurface_geometry`]
    /// of `b`) holds, the whole sum costs one evaluation per texel
    /// ([`single_scatter_summed_each`]: only the phase function sees the azimuth, and the
    /// diffusion lobe does not), equal to the separate evaluations' sum up to rounding.
    pub(crate) fn subsurface_summed_each(
        b: &[LeafBsdf],
        share: bool,
        pairs: &[(Vec3, Vec3, f32)],
        one_way: bool,
        mut out: impl FnMut(usize, Vec3),
    ) {
        let (wo, wi, _) = pairs[0];
        if !share || wo.z == 0.0 || wi.z == 0.0 {
            for (k, x) in b.iter().enumerate() {
                let mut sum = Vec3::ZERO;
                for &(wo, wi, c) in pairs {
                    let v = if one_way {
                        x.subsurface_one_way(wo, wi)
                    } else {
                        x.subsurface(wo, wi)
                    };
                    sum += v * c;
                }
                out(k, sum);
            }
            return;
        }
        let c: f32 = pairs.iter().map(|p| p.2).sum();
        let stack = |k: usize| &b[k].stack;
        let lobe = |k: usize| b[k].diffuse_lobe(wo, wi);
        if one_way {
            let s = b[0].surface_t(wo) * b[0].surface_t(wi) * FRAC_1_PI * c;
            single_scatter_summed_each(b.len(), stack, pairs, true, |k, ss, _| {
                out(k, ss + lobe(k) * s)
            });
        } else {
            let side = |w: Vec3| if w.z > 0.0 { 0 } else { 1 };
            let norm = b[0].inv_t_out[side(wo)] * b[0].inv_t_out[side(wi)];
            single_scatter_summed_each(b.len(), stack, pairs, false, |k, ss, [t_wo, t_wi]| {
                out(k, ss + lobe(k) * (t_wo * t_wi * norm * FRAC_1_PI * c))
            });
        }
    }

    /// Closed-form single scattering; transmission is averaged over the slab and its
    /// mirror image, so that through-light is the same from both sides (the paper's
    /// observation, Sec. 4) even when the two epidermis layers differ. Stays reciprocal.
    #[inline]
    fn single(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z < 0.0 {
            single_scatter_mirrored(&self.stack, wo, wi)
        } else {
            single_scatter(&self.stack, wo, wi)
        }
    }

    /// The cosine the subsurface lobes use for `wi`: the bump-mapped shading cosine away
    /// from the plane, blended to the geometric `|wi.z|` near it.
    #[inline]
    fn cos_eff(&self, wi: Vec3) -> f32 {
        let cg = wi.z.abs();
        let n = if wi.z > 0.0 {
            self.shading.n
        } else {
            -self.shading.n
        };
        let cs = wi.dot(n).max(0.0);
        cg + smooth(cg * self.inv_blend) * (cs - cg)
    }

    /// `wo`, `wi` in the shading frame of `wo`'s side (`+z` = `±n_s`), and the side index.
    #[inline]
    fn shading_dirs(&self, wo: Vec3, wi: Vec3) -> (Vec3, Vec3, usize) {
        let mut lo = self.shading.to_local(wo);
        let mut li = self.shading.to_local(wi);
        if wo.z > 0.0 {
            (lo, li, 0)
        } else {
            lo.z = -lo.z;
            li.z = -li.z;
            (lo, li, 1)
        }
    }

    #[inline]
    fn shading_to_local(&self, w: Vec3, side: usize) -> Vec3 {
        let w = if side == 0 {
            w
        } else {
            Vec3::new(w.x, w.y, -w.z)
        };
        self.shading.to_world(w)
    }

    #[inline]
    fn eta(&self, side: usize) -> f32 {
        self.stack.layers[if side == 0 { 0 } else { 2 }].ior
    }

    /// The specular term `f_spec cos` (light on the viewer's side only).
    #[inline]
    fn specular_term(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.specular <= 0.0 || wo.z * wi.z <= 0.0 {
            return 0.0;
        }
        let (lo, li, side) = self.shading_dirs(wo, wi);
        let fade = smooth(wo.z.abs() * self.inv_blend) * smooth(wi.z.abs() * self.inv_blend);
        self.specular * fade * specular::eval(lo, li, self.alpha[side], self.eta(side))
    }

    #[inline]
    fn lobe_scale(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z * wi.z < 0.0 {
            self.scale[2]
        } else if wo.z > 0.0 {
            self.scale[0]
        } else {
            self.scale[1]
        }
    }

    /// `eval` with the physical subsurface BSDF supplied by `subsurface` (called only when
    /// neither direction lies in the plane).
    #[inline]
    fn eval_with(&self, wo: Vec3, wi: Vec3, subsurface: impl FnOnce() -> Vec3) -> Vec3 {
        if wo.z == 0.0 || wi.z == 0.0 {
            return Vec3::ZERO;
        }
        let sub = subsurface() * self.lobe_scale(wo, wi) * self.cos_eff(wi);
        sub + Vec3::splat(self.specular_term(wo, wi))
    }

    /// [`Bsdf::eval`] with the single scattering estimated by the paper's ray march
    /// ([`crate::march`]) with `samples` steps per layer instead of the closed form.
    pub fn eval_marched(&self, wo: Vec3, wi: Vec3, samples: u32, rng: &mut Pcg32) -> Vec3 {
        self.eval_with(wo, wi, || {
            self.subsurface_with(wo, wi, || {
                if wo.z * wi.z < 0.0 {
                    let m = Vec3::new(1.0, 1.0, -1.0);
                    let half = samples.div_ceil(2);
                    0.5 * (single_scatter_marched(&self.stack, wo, wi, half, rng)
                        + single_scatter_marched(&self.stack, wo * m, wi * m, half, rng))
                } else {
                    single_scatter_marched(&self.stack, wo, wi, samples, rng)
                }
            })
        })
    }

    /// Lobe selection probabilities (specular, diffuse reflection, diffuse transmission).
    #[inline]
    fn lobe_probabilities(&self, wo: Vec3) -> [f32; 3] {
        let side = if wo.z > 0.0 { 0 } else { 1 };
        let lo_z = self.shading.n.dot(wo) * if side == 0 { 1.0 } else { -1.0 };
        let ps = if self.specular > 0.0 && lo_z > 0.0 {
            self.specular * fresnel_dielectric(lo_z, self.eta(side)).max(0.02)
        } else {
            0.0
        };
        let pr = luminance(self.albedo[side]).max(0.0);
        let pt = luminance(self.albedo[2]).max(0.0);
        let sum = ps + pr + pt;
        if sum > 0.0 {
            [ps / sum, pr / sum, pt / sum]
        } else {
            [0.0; 3]
        }
    }

    /// The direction [`Bsdf::sample`] draws (a lobe picked by `u.x`, then a direction in
    /// it from `u.y`, `u.z`), and the lobe probabilities it picked with.
    #[inline]
    fn sample_lobe(&self, wo: Vec3, u: Vec3) -> Option<(Vec3, [f32; 3])> {
        if wo.z == 0.0 {
            return None;
        }
        let probs = self.lobe_probabilities(wo);
        let [ps, pr, _] = probs;
        let wi = if u.x < ps {
            let (lo, _, side) = self.shading_dirs(wo, wo);
            let li = specular::sample(lo, self.alpha[side], Vec2::new(u.y, u.z))?;
            self.shading_to_local(li, side)
        } else {
            let mut wi = cosine_hemisphere(Vec2::new(u.y, u.z));
            let reflect = u.x < ps + pr;
            if (wo.z < 0.0) == reflect {
                wi.z = -wi.z;
            }
            wi
        };
        (wi.z != 0.0).then_some((wi, probs))
    }
}

impl Bsdf for LeafBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.eval_with(wo, wi, || self.subsurface(wo, wi))
    }

    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
        let (wi, probs) = self.sample_lobe(wo, u)?;
        // (`pdf` with the lobe probabilities already at hand.)
        let pdf = self.pdf_with(wo, wi, probs);
        (pdf > 0.0).then(|| BsdfSample {
            wi,
            f: self.eval(wo, wi),
            pdf,
        })
    }

    fn sample_direction(&self, wo: Vec3, u: Vec3) -> Option<Vec3> {
        self.sample_lobe(wo, u).map(|(wi, _)| wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z == 0.0 || wi.z == 0.0 {
            return 0.0;
        }
        self.pdf_with(wo, wi, self.lobe_probabilities(wo))
    }
}

impl LeafBsdf {
    /// Whether `other` is this texel in other channels: everything but the coefficients,
    /// the colours and what follows from them is the same (mode, thicknesses, indices,
    /// phase asymmetry, shading normal, specular lobe, blend band), so that directions,
    /// Fresnel terms and the specular lobe can be shared ([`LeafBsdf::eval_sets`]).
    fn same_geometry(&self, other: &LeafBsdf) -> bool {
        let layers = |b: &LeafBsdf| b.stack.layers.map(|l| (l.d, l.ior));
        self.mode == other.mode
            && layers(self) == layers(other)
            && self.stack.g == other.stack.g
            && self.shading == other.shading
            && self.alpha == other.alpha
            && self.specular == other.specular
            && self.inv_blend == other.inv_blend
            && self.inv_t_out == other.inv_t_out
    }

    /// [`Bsdf::eval`] of several texel BSDFs of one leaf in other channels (wavelength
    /// bins or bands of a spectral render) for the same directions: bit for bit each one's
    /// `eval`, with what they share (refraction, Fresnel, the phase function's geometry, the
    /// specular lobe, the shading cosine) computed once where their geometry agrees.
    pub fn eval_sets<const G: usize>(b: [&LeafBsdf; G], wo: Vec3, wi: Vec3) -> [Vec3; G] {
        let shared =
            G > 1 && b[0].mode == LeafMode::Layered && b[1..].iter().all(|x| b[0].same_geometry(x));
        if !shared {
            return std::array::from_fn(|k| b[k].eval(wo, wi));
        }
        if wo.z == 0.0 || wi.z == 0.0 {
            return [Vec3::ZERO; G];
        }
        let stacks: [&LayerStack; G] = std::array::from_fn(|k| &b[k].stack);
        let (ss, [t_wo, t_wi]) = single_scatter_and_surface_sets(stacks, wo, wi);
        let side = |w: Vec3| if w.z > 0.0 { 0 } else { 1 };
        let norm = b[0].inv_t_out[side(wo)] * b[0].inv_t_out[side(wi)];
        let cos = b[0].cos_eff(wi);
        let spec = Vec3::splat(b[0].specular_term(wo, wi));
        std::array::from_fn(|k| {
            let layered = ss[k] + b[k].diffuse_lobe(wo, wi) * (t_wo * t_wi * norm * FRAC_1_PI);
            layered * b[k].lobe_scale(wo, wi) * cos + spec
        })
    }

    /// The mean of [`Bsdf::pdf`] over several texel BSDFs of one leaf in other channels
    /// (the one-sample MIS density of a spectral path), the specular lobe's density computed
    /// once where their geometry agrees; equal to the mean of each one's `pdf` up to the
    /// order of the additions.
    pub fn pdf_mean<const G: usize>(b: [&LeafBsdf; G], wo: Vec3, wi: Vec3) -> f32 {
        let shared = G > 1 && b[1..].iter().all(|x| b[0].same_geometry(x));
        if !shared || wo.z == 0.0 || wi.z == 0.0 {
            return b.iter().map(|x| x.pdf(wo, wi)).sum::<f32>() / G as f32;
        }
        let (lo, li, side) = b[0].shading_dirs(wo, wi);
        let spec = if b[0].specular > 0.0 {
            specular::pdf(lo, li, b[0].alpha[side])
        } else {
            0.0
        };
        let cos = wi.z.abs() * FRAC_1_PI;
        let mut sum = 0.0;
        for x in &b {
            let [ps, pr, pt] = x.lobe_probabilities(wo);
            let mut p = if wo.z * wi.z > 0.0 { pr } else { pt } * cos;
            if ps > 0.0 {
                p += ps * spec;
            }
            sum += p;
        }
        sum / G as f32
    }

    /// [`Bsdf::pdf`] for `wo.z != 0`, `wi.z != 0`, given `lobe_probabilities(wo)`.
    #[inline]
    fn pdf_with(&self, wo: Vec3, wi: Vec3, [ps, pr, pt]: [f32; 3]) -> f32 {
        let mut p = if wo.z * wi.z > 0.0 { pr } else { pt } * wi.z.abs() * FRAC_1_PI;
        if ps > 0.0 {
            let (lo, li, side) = self.shading_dirs(wo, wi);
            p += ps * specular::pdf(lo, li, self.alpha[side]);
        }
        p
    }
}
