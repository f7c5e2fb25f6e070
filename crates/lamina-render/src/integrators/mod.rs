//! Light-transport algorithms and what they share: the prepared scene and the handling of
//! rays that hit an emitter.

pub mod paper;
pub mod path;
pub mod spectral;
pub(crate) mod wave;

use crate::accel::{Accel, FLAG_EMITTER, HitKind, ID_MASK, PrimRef, Ray, spawn_origin};
use crate::camera::CameraModel;
use crate::error::RenderError;
use crate::film::FilterSampler;
use crate::lights::{AnyLight, LightSample, LightSet};
use crate::sampler::PixelSampler;
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
    /// The scene in other channels (wavelength bins or bands) for spectral renders
    /// ([`spectral`]); empty for RGB.
    pub sets: Vec<spectral::ChannelSet>,
    /// The sets' sky maps interleaved (with sets and an image sky).
    pub sky_sets: Option<spectral::SkySets>,
}

impl<'a> SceneContext<'a> {
    /// Builds everything a render needs from `scene`, tracing with `backend`.
    pub fn new(scene: &'a Scene, backend: crate::accel::Backend) -> Result<Self, RenderError> {
        let camera = CameraModel::new(&scene.camera, &scene.film)?;
        let start = std::time::Instant::now();
        let accel = Accel::build_on(scene, backend)?;
        let accel_build = start.elapsed();
        Ok(SceneContext {
            scene,
            camera,
            accel,
            lights: LightSet::new(scene)?,
            filter: FilterSampler::new(scene.film.filter),
            accel_build,
            sets: Vec::new(),
            sky_sets: None,
        })
    }

    /// Adds the scene in other channels for a spectral render: each set must hold the
    /// scene's lights in order, with a sky map of the same size as the scene's (the
    /// integrator reads the sets' skies at the scene sky's texels).
    /// `slot[j]` is set `j`'s place in the interleaved sky maps ([`spectral::SkySets`]):
    /// the sets a path carries should be neighbours.
    pub(crate) fn with_sets(
        mut self,
        sets: Vec<spectral::ChannelSet>,
        slot: Vec<usize>,
    ) -> Result<Self, RenderError> {
        let sky_size = |l: &LightSet| match l.lights.last() {
            Some(crate::lights::AnyLight::Sky(s)) => s.size(),
            _ => None,
        };
        for (k, set) in sets.iter().enumerate() {
            if set.lights.lights.len() != self.lights.lights.len()
                || set.materials.len() != self.scene.materials.len()
                || sky_size(&set.lights) != sky_size(&self.lights)
            {
                return Err(RenderError::InvalidScene(format!(
                    "spectral channel set {k} does not match the scene's materials, lights or \
                     sky map (a bug: please report it)"
                )));
            }
        }
        self.sky_sets = match self.lights.lights.last() {
            Some(crate::lights::AnyLight::Sky(base)) => {
                spectral::SkySets::new(base, &sets, slot, self.lights.lights.len())
            }
            _ => None,
        };
        self.sets = sets;
        Ok(self)
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
        *rays += 1;
        !self.accel.occluded_skip(&Self::shadow_ray(p, n, ls), prim)
    }

    /// The shadow ray [`SceneContext::unoccluded`] traces from `p` (geometric normal `n`)
    /// toward light sample `ls`.
    #[inline]
    pub(crate) fn shadow_ray(p: Vec3, n: Vec3, ls: &LightSample) -> Ray {
        let tmax = if ls.dist.is_finite() {
            ls.dist * (1.0 - 1e-3)
        } else {
            f32::INFINITY
        };
        Ray {
            origin: spawn_origin(p, n, ls.wi),
            dir: ls.wi,
            tmax,
        }
    }

    /// If `kind` is an emitter (quad or sphere light) the ray hit at distance `t`, its
    /// radiance toward the ray and the solid-angle density with which next-event estimation
    /// from `ray.origin` draws that point: the light's own density times the probability
    /// that the light is drawn.
    #[inline]
    pub(crate) fn emitter(&self, kind: HitKind, ray: &Ray, t: f32) -> Option<(Vec3, f32)> {
        let light = self.emitter_light(kind)?;
        Some(match self.lights.lights.get(light) {
            Some(l) => {
                let (le, pdf) = l.hit(ray.origin, ray.dir, t);
                (le, pdf * self.lights.pick_prob(light))
            }
            None => (Vec3::ZERO, 0.0),
        })
    }

    /// The lights next-event estimation samples at a vertex: the index of the first, the
    /// lights, and the probability with which they were drawn. Every light it samples
    /// ([`LightSet::nee`](crate::lights::LightSet::nee): all, or all but a sky left to BSDF
    /// samples) with probability 1, or (`light_sampling = "one"`) one of them drawn by a 1D
    /// sample of `sampler`.
    #[inline]
    pub(crate) fn nee_lights(&self, sampler: &mut PixelSampler) -> (usize, &[AnyLight], f32) {
        let lights = self.lights.nee();
        match &self.lights.pick {
            None => (0, lights, 1.0),
            Some(pick) => {
                let (i, p) = pick.choose(sampler.next_1d());
                (i, &lights[i..i + 1], p)
            }
        }
    }

    /// The index of the light `kind` is, if it is an emitter (quad or sphere light).
    #[inline]
    pub(crate) fn emitter_light(&self, kind: HitKind) -> Option<usize> {
        match kind {
            HitKind::Sphere { light } => Some(light as usize),
            HitKind::Triangle { prim, .. } => {
                let flags = self.accel.flags(prim);
                (flags & FLAG_EMITTER != 0).then_some((flags & ID_MASK) as usize)
            }
        }
    }
}
