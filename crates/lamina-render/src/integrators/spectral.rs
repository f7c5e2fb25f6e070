//! The path tracer of [`super::path`] carrying `G` channel sets along one path: the
//! wavelengths of a `spectral = "visible"` render or the bands of a band render, three per
//! set.
//!
//! Geometry is shared: one camera ray, one traversal per bounce, one shadow ray per light
//! sample serve every set. What differs per set are the values: each set has the scene's
//! materials and lights in its own channels ([`ChannelSet`]), and at every vertex each set's
//! BSDF is evaluated for the same directions.
//!
//! * **Light samples** are drawn from the scene's own lights ([`SceneContext::lights`],
//!   the same geometry in every set; the sky by the RGB map's importance) and weighted per
//!   set by that set's radiance along them ([`crate::lights::AnyLight::li_along`]).
//! * **BSDF samples** come from one set, the *hero*, chosen uniformly per bounce (its index
//!   from the same random number that picks the lobe, so the dimensions used are those of
//!   the RGB integrator); every set weighs the direction by the one-sample MIS density
//!   `p(ω) = (1/G) Σ_k p_k(ω)` (Veach's balance heuristic over the sets' sampling
//!   strategies, as in hero-wavelength sampling, Wilkie et al. 2014): `β_k ·= f_k / p`,
//!   unbiased for every set wherever some set's density covers its BSDF. The same `p` is
//!   the BSDF density of the power heuristic against light sampling.
//! * **Russian roulette** survives with the largest throughput of any channel of any set.
//!
//! Everything else (depth, emitters ending paths, shading normals and the geometric side
//! rule) is [`super::path`]'s.

use super::SceneContext;
use crate::accel::{FLAG_EMITTER, HitKind, ID_MASK, PrimRef, Ray, spawn_origin};
use crate::lights::{LightSet, power_heuristic};
use crate::materials::SurfaceBsdf;
use crate::sampler::PixelSampler;
use crate::shading::{ShadingFrame, shading_normal};
use glam::Vec3;
use lamina_core::Material;
use lamina_leaf::Bsdf;
use std::array::from_fn;

/// The scene's values in three channels (wavelength bins or bands): its materials, and its
/// lights and sky in [`SceneContext::lights`]' order and geometry.
#[derive(Debug)]
pub struct ChannelSet {
    /// The scene's materials, in scene order.
    pub materials: Vec<Material>,
    /// The scene's lights and sky.
    pub lights: LightSet,
}

/// The radiance (W m⁻² sr⁻¹ per channel: per nm for spectral channels) arriving along the
/// camera ray `ray` in each of the `G` sets. Adds the rays it traces to `rays`.
pub fn radiance_sets<const G: usize>(
    ctx: &SceneContext,
    sets: [&ChannelSet; G],
    mut ray: Ray,
    sampler: &mut PixelSampler,
    max_depth: u32,
    rr_depth: u32,
    rays: &mut u64,
) -> [Vec3; G] {
    let mut l = [Vec3::ZERO; G];
    let mut beta = [Vec3::ONE; G];
    let mut prev_pdf = 0.0f32;
    let mut camera_ray = true;
    let mut skip = PrimRef::NONE;
    let mut bounces = 0u32;
    let lights = &ctx.lights.lights;
    let weight = |camera_ray: bool, prev: f32, pdf: f32| {
        if camera_ray {
            1.0
        } else {
            power_heuristic(prev, pdf)
        }
    };
    loop {
        *rays += 1;
        let Some(hit) = ctx.accel.intersect_skip(&ray, skip) else {
            for (i, light) in lights.iter().enumerate() {
                if !light.is_infinite() {
                    continue;
                }
                let (_, pdf, texel) = light.escaped_texel(ray.dir);
                let w = weight(camera_ray, prev_pdf, pdf);
                for k in 0..G {
                    let le = sets[k].lights.lights[i].escaped_radiance(ray.dir, texel);
                    l[k] += beta[k] * le * w;
                }
            }
            break;
        };
        if let Some(light) = ctx.emitter_light(hit.kind) {
            if let Some(base) = lights.get(light) {
                let (_, pdf) = base.hit(ray.origin, ray.dir, hit.t);
                let w = weight(camera_ray, prev_pdf, pdf);
                for k in 0..G {
                    let le = sets[k].lights.lights[light]
                        .hit(ray.origin, ray.dir, hit.t)
                        .0;
                    l[k] += beta[k] * le * w;
                }
            }
            break;
        }
        let HitKind::Triangle { prim, bary } = hit.kind else {
            break;
        };
        if bounces >= max_depth {
            break;
        }
        let (p, info) = ctx.accel.surface(prim, bary);
        debug_assert!(info.flags & FLAG_EMITTER == 0);
        let m = (info.flags & ID_MASK) as usize;
        let normal_map = ctx.scene.materials[m].normal_map();
        let ns = shading_normal(&ctx.accel, prim, bary, &info, normal_map);
        let frame = ShadingFrame::new(&info, ns, -ray.dir);
        let uv = info.uv_at(bary);
        let bsdfs: [SurfaceBsdf; G] = from_fn(|k| SurfaceBsdf::at(&sets[k].materials[m], uv));
        let wo = frame.to_local(-ray.dir);
        let mixture_pdf = |wi: Vec3| bsdfs.iter().map(|b| b.pdf(wo, wi)).sum::<f32>() / G as f32;

        for (i, light) in lights.iter().enumerate() {
            let u = sampler.next_2d();
            let Some(ls) = light.sample(p, u) else {
                continue;
            };
            if !(ls.pdf > 0.0) || !frame.consistent(ls.wi) {
                continue;
            }
            let li: [Vec3; G] = from_fn(|k| sets[k].lights.lights[i].li_along(&ls));
            if li.iter().all(|v| *v == Vec3::ZERO) {
                continue;
            }
            let wi = frame.to_local(ls.wi);
            let f: [Vec3; G] = from_fn(|k| {
                if li[k] == Vec3::ZERO {
                    Vec3::ZERO
                } else {
                    bsdfs[k].eval(wo, wi)
                }
            });
            if f.iter().all(|v| *v == Vec3::ZERO) {
                continue;
            }
            if !ctx.unoccluded(p, info.n, prim, &ls, rays) {
                continue;
            }
            let w = if ls.delta {
                1.0
            } else {
                power_heuristic(ls.pdf, mixture_pdf(wi))
            };
            for k in 0..G {
                l[k] += beta[k] * f[k] * li[k] * (w / ls.pdf);
            }
        }

        let u1 = sampler.next_1d();
        let u2 = sampler.next_2d();
        // The hero set and the lobe from one number: `u1 G` split into its integer and
        // fractional parts (the fraction is again uniform in [0, 1)).
        let (hero, u1) = if G == 1 {
            (0, u1)
        } else {
            let x = u1 * G as f32;
            let h = (x as usize).min(G - 1);
            (h, (x - h as f32).clamp(0.0, 1.0 - f32::EPSILON))
        };
        let Some(bs) = bsdfs[hero].sample(wo, Vec3::new(u1, u2.x, u2.y)) else {
            break;
        };
        if !(bs.pdf > 0.0) {
            break;
        }
        let dir = frame.to_world(bs.wi).normalize();
        if !frame.consistent(dir) {
            break; // its geometric side disagrees with the BSDF's: no light goes there
        }
        let mut pdf_sum = bs.pdf;
        let f: [Vec3; G] = from_fn(|k| {
            if k == hero {
                bs.f
            } else {
                pdf_sum += bsdfs[k].pdf(wo, bs.wi);
                bsdfs[k].eval(wo, bs.wi)
            }
        });
        let pdf = pdf_sum / G as f32;
        let mut largest = 0.0f32;
        let mut finite = true;
        for k in 0..G {
            beta[k] *= f[k] / pdf;
            largest = largest.max(beta[k].max_element());
            finite &= beta[k].is_finite();
        }
        if !(largest > 0.0) || !finite {
            break;
        }
        ray = Ray {
            origin: spawn_origin(p, info.n, dir),
            dir,
            tmax: f32::INFINITY,
        };
        skip = prim;
        prev_pdf = pdf;
        camera_ray = false;
        bounces += 1;
        if bounces >= rr_depth {
            let q = largest.min(1.0);
            let u = sampler.next_1d();
            if q < 1.0 {
                if u >= q {
                    break;
                }
                for b in &mut beta {
                    *b /= q;
                }
            }
        }
    }
    l
}
