//! The paper's renderer (Franzke & Deussen): direct light only.
//!
//! At the first surface a camera ray hits, for each scene light (sun, point, quad,
//! sphere; one sample each, no MIS) the BSDF is evaluated with a shadow ray; the BSDF
//! itself gives front-lit, back-lit or through-light shading by the side of the light.
//! Multiple scattering is the ambient term `(R + T) · A`, with `(R, T)` the material's
//! diffuse albedo there and `A` the integrator's ambient radiance, or the sky's mean
//! radiance when none is given. The sky therefore lights surfaces only through the ambient
//! term (not as a sampled light, which would count it twice); camera rays that miss see the
//! sky and the sun's disc, and emitters are seen directly.

use super::SceneContext;
use crate::accel::{HitKind, ID_MASK, Ray};
use crate::lights::AnyLight;
use crate::materials::SurfaceBsdf;
use crate::sampler::PixelSampler;
use crate::shading::{ShadingFrame, shading_normal};
use glam::Vec3;
use lamina_leaf::Bsdf;

/// Radiance (W m⁻² sr⁻¹) arriving along the camera ray `ray`, with `ambient` the ambient
/// radiance. Adds the rays it traces to `rays`.
pub fn radiance(
    ctx: &SceneContext,
    ray: Ray,
    sampler: &mut PixelSampler,
    ambient: Vec3,
    rays: &mut u64,
) -> Vec3 {
    *rays += 1;
    let lights = &ctx.lights.lights;
    let Some(hit) = ctx.accel.intersect(&ray) else {
        return (ctx.lights.escaping.iter())
            .map(|&i| lights[i].escaped(ray.dir).0)
            .sum();
    };
    if let Some((le, _)) = ctx.emitter(hit.kind, &ray, hit.t) {
        return le;
    }
    let HitKind::Triangle { prim, bary } = hit.kind else {
        return Vec3::ZERO;
    };
    let (p, info) = ctx.accel.surface(prim, bary);
    let material = &ctx.scene.materials[(info.flags & ID_MASK) as usize];
    let ns = shading_normal(&ctx.accel, prim, bary, &info, material.normal_map());
    let frame = ShadingFrame::new(&info, ns, -ray.dir);
    let bsdf = SurfaceBsdf::at(material, info.uv_at(bary));
    let wo = frame.to_local(-ray.dir);
    let mut l = Vec3::ZERO;
    for light in lights.iter().filter(|l| !matches!(l, AnyLight::Sky(_))) {
        let u = sampler.next_2d_if(light.uses_sample());
        let Some(ls) = light.sample(p, u) else {
            continue;
        };
        if !(ls.pdf > 0.0) || !frame.consistent(ls.wi) {
            continue;
        }
        let f = bsdf.eval(wo, frame.to_local(ls.wi));
        if f == Vec3::ZERO || ls.li == Vec3::ZERO {
            continue;
        }
        if ctx.unoccluded(p, info.n, prim, &ls, rays) {
            l += f * ls.li / ls.pdf;
        }
    }
    let (r, t) = bsdf.diffuse_albedo();
    l + (r + t) * ambient
}
