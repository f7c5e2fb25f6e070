//! Light-transport algorithms and what they share: the prepared scene and the handling of
//! rays that hit an emitter.

pub mod paper;
pub mod path;

use crate::accel::{Accel, FLAG_EMITTER, HitKind, ID_MASK, PrimRef, Ray, spawn_origin};
use crate::camera::CameraModel;
use crate::error::RenderError;
use crate::film::FilterSampler;
use crate::lights::{AnyLight, LightSample, LightSet};
use glam::Vec3;
use lamina_core::Scene;

/// A scene prepared for rendering: BVH, lights, camera and pixel filter.
pub struct SceneContext<'a> {
    /// The scene (materials are read from it at every hit).
    pub scene: &'a Scene,
    /// The acceleration structure.
    pub accel: Accel,
    /// The lights, sky last.
    pub lights: LightSet,
    /// The camera.
    pub camera: CameraModel,
    /// The pixel filter sampler.
    pub filter: FilterSampler,
    /// Wall-clock time [`Accel::build`] took.
    pub accel_build: std::time::Duration,
}

impl<'a> SceneContext<'a> {
    /// Builds everything a render needs from `scene`.
    pub fn new(scene: &'a Scene) -> Result<Self, RenderError> {
        let camera = CameraModel::new(&scene.camera, &scene.film)?;
        let start = std::time::Instant::now();
        let accel = Accel::build(scene)?;
        let accel_build = start.elapsed();
        Ok(SceneContext {
            scene,
            camera,
            accel,
            lights: LightSet::new(scene)?,
            filter: FilterSampler::new(scene.film.filter),
            accel_build,
        })
    }

    /// Whether light sample `ls` reaches `p` (on primitive `prim`, geometric normal `n`)
    /// unblocked: traces one shadow ray, counted in `rays`, that stops just short of area
    /// lights and runs to infinity for distant ones.
    #[inline]
    pub(crate) fn unoccluded(
        &self,
        p: Vec3,
        n: Vec3,
        prim: PrimRef,
        ls: &LightSample,
        rays: &mut u64,
    ) -> bool {
        let tmax = if ls.dist.is_finite() {
            ls.dist * (1.0 - 1e-3)
        } else {
            f32::INFINITY
        };
        let shadow = Ray {
            origin: spawn_origin(p, n, ls.wi),
            dir: ls.wi,
            tmax,
        };
        *rays += 1;
        !self.accel.occluded_skip(&shadow, prim)
    }

    /// If `kind` is an emitter (quad or sphere light), its radiance toward the ray and the
    /// solid-angle density with which next-event estimation from `ray.origin` samples it.
    #[inline]
    pub(crate) fn emitter(&self, kind: HitKind, ray: &Ray, t: f32) -> Option<(Vec3, f32)> {
        let light = match kind {
            HitKind::Sphere { light } => light,
            HitKind::Triangle { prim, .. } => {
                let flags = self.accel.flags(prim);
                if flags & FLAG_EMITTER == 0 {
                    return None;
                }
                flags & ID_MASK
            }
        };
        Some(match self.lights.lights.get(light as usize) {
            Some(AnyLight::Quad(q)) => q.hit(ray.dir, t),
            Some(AnyLight::Sphere(s)) => s.hit(ray.origin, ray.dir, t),
            _ => (Vec3::ZERO, 0.0),
        })
    }
}
