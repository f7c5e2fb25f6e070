//! The unidirectional path tracer.
//!
//! * **Next-event estimation** at every scattering vertex to *every* light (sun, point,
//!   quad, sphere, sky), one sample each, or with `light_sampling = "one"` to one light
//!   drawn by estimated power ([`crate::lights::LightPick`]; its density then includes the
//!   probability of drawing it, for the estimate and for MIS), with a shadow ray that the
//!   alpha test lets through holes; opaque geometry blocks it (light *through* leaves
//!   arrives by the path's own transmission bounces instead). A sky left to BSDF samples
//!   (`sky_sampling`, by default a constant sky: [`lamina_core::SkySampling`]) gets no
//!   shadow rays; it is not among the lights NEE samples or draws from.
//! * **MIS**: light samples and BSDF samples of non-delta lights (area lights, the sun's
//!   disc, the sky) are combined with the power heuristic (β = 2), each light's density
//!   against the BSDF's; a BSDF sample that escapes to a sky NEE never samples counts in
//!   full. Delta lights (point, zero-diameter sun) get NEE only, weight 1.
//! * **Russian roulette** from `rr_depth` scattering events on: survival probability
//!   `min(1, max channel of the throughput)`, throughput divided by it.
//! * **max_depth** counts scattering events: 1 is direct light only (with the emission found
//!   by that vertex's BSDF sample), 0 only what camera rays see directly.
//! * Emitters end paths (they are black).
//! * **Shading normals** ([`ShadingFrame`]): BSDFs see the shading frame; light samples
//!   and BSDF samples on a different side of the geometric than of the shading normal are
//!   dropped (the sample ends the path).

use super::SceneContext;
use crate::accel::{FLAG_EMITTER, Hit, HitKind, ID_MASK, PrimRef, Ray, spawn_origin};
use crate::lights::power_heuristic;
use crate::materials::SurfaceBsdf;
use crate::sampler::PixelSampler;
use crate::shading::{ShadingFrame, shading_normal};
use glam::Vec3;
use lamina_leaf::Bsdf;

/// Radiance (W m⁻² sr⁻¹) arriving along the camera ray `ray`. Adds the rays it traces
/// (primary, indirect, shadow) to `rays`.
pub fn radiance(
    ctx: &SceneContext,
    ray: Ray,
    sampler: &mut PixelSampler,
    max_depth: u32,
    rr_depth: u32,
    rays: &mut u64,
) -> Vec3 {
    let start = Start::Camera(None);
    trace(ctx, ray, sampler, max_depth, rr_depth, rays, start)
}

/// [`radiance`] for a camera ray whose first intersection `hit` (what
/// [`crate::accel::Accel::intersect`] returns for it) was found beforehand: the same
/// value bit for bit, the ray still counted. A renderer that finds the first hits of
/// several samples one after the other lets the CPU overlap their independent ray walks.
pub fn radiance_hit(
    ctx: &SceneContext,
    ray: Ray,
    hit: Option<Hit>,
    sampler: &mut PixelSampler,
    max_depth: u32,
    rr_depth: u32,
    rays: &mut u64,
) -> Vec3 {
    let start = Start::Camera(Some(hit));
    trace(ctx, ray, sampler, max_depth, rr_depth, rays, start)
}

/// Radiance arriving along `ray` when `ray` was sampled with solid-angle density `pdf` at
/// a point whose light is also sampled by next-event estimation (a sensor's virtual
/// receiver): emitters and distant lights it reaches directly are weighted by the power
/// heuristic against their light-sampling density, as after a BSDF sample.
pub fn radiance_sampled(
    ctx: &SceneContext,
    ray: Ray,
    pdf: f32,
    sampler: &mut PixelSampler,
    max_depth: u32,
    rr_depth: u32,
    rays: &mut u64,
) -> Vec3 {
    let start = Start::Sampled(pdf);
    trace(ctx, ray, sampler, max_depth, rr_depth, rays, start)
}

/// How a path's first ray came to be.
enum Start {
    /// A camera ray, with its first hit if already found.
    Camera(Option<Option<Hit>>),
    /// Sampled with this solid-angle density at a point whose lights are sampled too.
    Sampled(f32),
}

fn trace(
    ctx: &SceneContext,
    mut ray: Ray,
    sampler: &mut PixelSampler,
    max_depth: u32,
    rr_depth: u32,
    rays: &mut u64,
    start: Start,
) -> Vec3 {
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let (mut prev_pdf, mut camera_ray, mut first_hit) = match start {
        Start::Camera(hit) => (0.0, true, hit),
        Start::Sampled(pdf) => (pdf, false, None),
    };
    let mut skip = PrimRef::NONE;
    let mut bounces = 0u32;
    let lights = &ctx.lights.lights;
    loop {
        *rays += 1;
        let hit = match first_hit.take() {
            Some(hit) => hit,
            None => ctx.accel.intersect_skip(&ray, skip),
        };
        let Some(hit) = hit else {
            for &i in &ctx.lights.escaping {
                let (le, pdf) = lights[i].escaped(ray.dir);
                if le != Vec3::ZERO {
                    let w = if camera_ray {
                        1.0
                    } else {
                        power_heuristic(prev_pdf, pdf * ctx.lights.pick_prob(i))
                    };
                    l += beta * le * w;
                }
            }
            break;
        };
        if let Some((le, pdf)) = ctx.emitter(hit.kind, &ray, hit.t) {
            let w = if camera_ray {
                1.0
            } else {
                power_heuristic(prev_pdf, pdf)
            };
            l += beta * le * w;
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
        let material = &ctx.scene.materials[(info.flags & ID_MASK) as usize];
        let ns = shading_normal(&ctx.accel, prim, bary, &info, material.normal_map());
        let frame = ShadingFrame::new(&info, ns, -ray.dir);
        let bsdf = SurfaceBsdf::at(material, info.uv_at(bary));
        let wo = frame.to_local(-ray.dir);

        let (_, picked, pick) = ctx.nee_lights(sampler);
        // The BSDF's numbers are the draws after the lights' (one each); drawn ahead and
        // the direction sampled now, they are ready when the shadow rays are done.
        let ahead = picked.len() as u32;
        let (u1, u2) = (sampler.peek_1d(ahead), sampler.peek_2d(ahead + 1));
        let sampled = bsdf.sample(wo, Vec3::new(u1, u2.x, u2.y));
        for light in picked {
            let u = sampler.next_2d_if(light.uses_sample());
            let Some(mut ls) = light.sample(p, u) else {
                continue;
            };
            ls.pdf *= pick;
            if !(ls.pdf > 0.0) || ls.li == Vec3::ZERO || !frame.consistent(ls.wi) {
                continue;
            }
            let wi = frame.to_local(ls.wi);
            let f = bsdf.eval(wo, wi);
            if f == Vec3::ZERO {
                continue;
            }
            if !ctx.unoccluded(p, info.n, prim, &ls, rays) {
                continue;
            }
            let w = if ls.delta {
                1.0
            } else {
                power_heuristic(ls.pdf, bsdf.pdf(wo, wi))
            };
            l += beta * f * ls.li * (w / ls.pdf);
        }

        sampler.skip(2);
        let Some(bs) = sampled else {
            break;
        };
        if !(bs.pdf > 0.0) {
            break;
        }
        let dir = frame.to_world_unit(bs.wi);
        if !frame.consistent(dir) {
            break; // its geometric side disagrees with the BSDF's: no light goes there
        }
        beta *= bs.f / bs.pdf;
        if !(beta.max_element() > 0.0) || !beta.is_finite() {
            break;
        }
        ray = Ray {
            origin: spawn_origin(p, info.n, dir),
            dir,
            tmax: f32::INFINITY,
        };
        skip = prim;
        prev_pdf = bs.pdf;
        camera_ray = false;
        bounces += 1;
        if bounces >= rr_depth {
            let q = beta.max_element().min(1.0);
            let u = sampler.next_1d();
            if q < 1.0 {
                if u >= q {
                    break;
                }
                beta /= q;
            }
        }
    }
    l
}
