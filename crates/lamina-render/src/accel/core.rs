//! The ray-casting engine behind [`super::Accel`]: lamina-accel's wide BVHs (the
//! default) or, in builds with the `embree` feature, Intel Embree 3 through lamina-accel's
//! FFI, the benchmarks' baseline, selectable with [`Backend::Embree`] to compare on a
//! user's own scenes. Both answer the same queries on the same `SceneDesc` (lamina-accel's
//! agreement tests check them against each other); only the instance ids differ: the top
//! level's order for lamina-accel, the scene's order for Embree.

use glam::{Affine3A, Vec3};
use lamina_accel::{AccelError, AccelMemory, AlphaFilter, Hit, PrimRef, Ray, SceneDesc};

/// Which engine an [`super::Accel`] traces rays with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Backend {
    /// lamina-accel's wide SIMD BVH, the kernel chosen for this CPU.
    #[default]
    Lamina,
    /// Intel Embree 3 (Debian's `libembree-dev`), present in builds with lamina-render's
    /// `embree` feature ([`Backend::available`]).
    Embree,
}

impl Backend {
    /// The backend named `s` (`lamina` or `embree`).
    pub fn parse(s: &str) -> Option<Backend> {
        match s {
            "lamina" => Some(Backend::Lamina),
            "embree" => Some(Backend::Embree),
            _ => None,
        }
    }

    /// Whether this build has it (Embree needs the `embree` feature).
    pub fn available(self) -> bool {
        match self {
            Backend::Lamina => true,
            Backend::Embree => cfg!(feature = "embree"),
        }
    }

    /// Its name, as [`Backend::parse`] reads it.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Lamina => "lamina",
            Backend::Embree => "embree",
        }
    }
}

/// The engine and what the renderer needs of it. lamina-accel stays inline (not boxed):
/// every query reads it, and there is one per render.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub(super) enum Core {
    Lamina(lamina_accel::Accel),
    #[cfg(feature = "embree")]
    Embree(std::sync::Arc<EmbreeCore>),
}

/// Embree's structure plus what lamina-accel keeps itself: each instance's inverse
/// transform and prototype, by scene order (Embree's instance ids).
#[cfg(feature = "embree")]
#[derive(Debug)]
pub(super) struct EmbreeCore {
    accel: lamina_accel::embree::EmbreeAccel,
    w2o: Vec<Affine3A>,
    protos: Vec<u32>,
}

impl Core {
    /// Builds `backend` over `desc` (lamina-accel with traversal kernel `kernel`).
    pub fn build(
        desc: &SceneDesc,
        backend: Backend,
        kernel: lamina_accel::Kernel,
    ) -> Result<Core, AccelError> {
        match backend {
            Backend::Lamina => {
                let opts = lamina_accel::BuildOptions {
                    kernel,
                    ..Default::default()
                };
                lamina_accel::Accel::build_with(desc, opts).map(Core::Lamina)
            }
            #[cfg(feature = "embree")]
            Backend::Embree => {
                let accel = lamina_accel::embree::EmbreeAccel::build(desc)?;
                Ok(Core::Embree(std::sync::Arc::new(EmbreeCore {
                    accel,
                    // The inverse as lamina-accel computes it (`build` has checked it).
                    w2o: desc
                        .instances
                        .iter()
                        .map(|i| i.object_to_world.inverse())
                        .collect(),
                    protos: desc.instances.iter().map(|i| i.prototype).collect(),
                })))
            }
            #[cfg(not(feature = "embree"))]
            Backend::Embree => Err(AccelError::Embree(
                "this build of lamina has no Embree backend (build it with the `embree` feature \
                 and Debian's libembree-dev installed)"
                    .into(),
            )),
        }
    }

    /// Adds lamina-accel's grid for shadow rays along `axis` (see
    /// `lamina_accel::Accel::index_direction`); nothing on Embree.
    pub fn index_direction(&mut self, axis: glam::Vec3) -> Option<lamina_accel::GridStats> {
        match self {
            Core::Lamina(a) => a.index_direction(axis),
            #[cfg(feature = "embree")]
            Core::Embree(_) => None,
        }
    }

    /// Adds lamina-accel's grid for rays from a camera's eye (see
    /// `lamina_accel::Accel::index_view`); nothing on Embree.
    pub fn index_view(
        &mut self,
        eye: glam::Vec3,
        forward: glam::Vec3,
        up: glam::Vec3,
        window: [f32; 4],
    ) -> Option<lamina_accel::GridStats> {
        match self {
            Core::Lamina(a) => a.index_view(eye, forward, up, window),
            #[cfg(feature = "embree")]
            Core::Embree(_) => None,
        }
    }

    /// Which backend this is.
    pub fn backend(&self) -> Backend {
        match self {
            Core::Lamina(_) => Backend::Lamina,
            #[cfg(feature = "embree")]
            Core::Embree(_) => Backend::Embree,
        }
    }

    /// The closest accepted hit (see `lamina_accel::Accel::intersect`).
    #[inline(always)]
    pub fn intersect<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> Option<Hit> {
        match self {
            Core::Lamina(a) => a.intersect(ray, skip, f),
            #[cfg(feature = "embree")]
            Core::Embree(e) => e.accel.intersect(ray, skip, f),
        }
    }

    /// The closest accepted hit of each of `rays` (see
    /// `lamina_accel::Accel::intersect_many`), no primitive skipped.
    #[inline(always)]
    pub fn intersect_many<F: AlphaFilter>(&self, rays: &[Ray], f: &F, out: &mut [Option<Hit>]) {
        match self {
            Core::Lamina(a) => a.intersect_many(rays, f, out),
            #[cfg(feature = "embree")]
            Core::Embree(e) => {
                for (ray, out) in rays.iter().zip(out.iter_mut()) {
                    *out = e.accel.intersect(ray, PrimRef::NONE, f);
                }
            }
        }
    }

    /// The closest accepted hit of each ray from `eye` along `(d[0][k], d[1][k],
    /// d[2][k])` (see `lamina_accel::Accel::intersect_eye`).
    #[inline(always)]
    pub fn intersect_eye<F: AlphaFilter>(
        &self,
        eye: Vec3,
        d: [&[f32]; 3],
        f: &F,
        out: &mut [Option<Hit>],
    ) {
        match self {
            Core::Lamina(a) => a.intersect_eye(eye, d, f, out),
            #[cfg(feature = "embree")]
            Core::Embree(e) => {
                for (k, out) in out.iter_mut().enumerate() {
                    let ray = Ray::from_eye_lane(eye, d, k);
                    *out = e.accel.intersect(&ray, PrimRef::NONE, f);
                }
            }
        }
    }

    /// Whether any accepted hit lies along `ray` (see `lamina_accel::Accel::occluded`).
    #[inline(always)]
    pub fn occluded<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> bool {
        match self {
            Core::Lamina(a) => a.occluded(ray, skip, f),
            #[cfg(feature = "embree")]
            Core::Embree(e) => e.accel.occluded(ray, skip, f),
        }
    }

    /// Whether each of `rays`, leaving `skips[k]`, is blocked (see
    /// `lamina_accel::Accel::occluded_many`).
    #[inline(always)]
    pub fn occluded_many<F: AlphaFilter>(
        &self,
        rays: &[Ray],
        skips: &[PrimRef],
        f: &F,
        out: &mut [bool],
    ) {
        match self {
            Core::Lamina(a) => a.occluded_many(rays, skips, f, out),
            #[cfg(feature = "embree")]
            Core::Embree(e) => {
                for ((ray, skip), out) in rays.iter().zip(skips).zip(out.iter_mut()) {
                    *out = e.accel.occluded(ray, *skip, f);
                }
            }
        }
    }

    /// The world-to-object transform of instance `inst` (an id as hits report it).
    #[inline(always)]
    pub fn world_to_object(&self, inst: u32) -> Option<Affine3A> {
        match self {
            Core::Lamina(a) => a.world_to_object(inst),
            #[cfg(feature = "embree")]
            Core::Embree(e) => e.w2o.get(inst as usize).copied(),
        }
    }

    /// The prototype of instance `inst` (an id as hits report it).
    #[inline(always)]
    pub fn prototype_of(&self, inst: u32) -> u32 {
        match self {
            Core::Lamina(a) => a.prototype_of(inst),
            #[cfg(feature = "embree")]
            Core::Embree(e) => e.protos[inst as usize],
        }
    }

    /// For each instance id, its index in `desc.instances` (the scene `desc` was built
    /// from).
    pub fn scene_instances(&self, desc: &SceneDesc) -> Vec<u32> {
        match self {
            Core::Lamina(a) => a.scene_instances(desc),
            #[cfg(feature = "embree")]
            Core::Embree(_) => (0..desc.instances.len() as u32).collect(),
        }
    }

    /// Bytes held by level (Embree: all it counts in `world`, its instances in
    /// `instance_count`).
    pub fn memory(&self) -> AccelMemory {
        match self {
            Core::Lamina(a) => a.memory(),
            #[cfg(feature = "embree")]
            Core::Embree(e) => AccelMemory {
                world: e.accel.memory_bytes().unwrap_or(0),
                prototypes: 0,
                instances: e.w2o.len() * std::mem::size_of::<Affine3A>(),
                masks: 0,
                grids: 0,
                instance_count: e.w2o.len(),
            },
        }
    }

    /// lamina-accel's traversal kernel; `None` for Embree.
    pub fn kernel(&self) -> Option<lamina_accel::Kernel> {
        match self {
            Core::Lamina(a) => Some(a.kernel()),
            #[cfg(feature = "embree")]
            Core::Embree(_) => None,
        }
    }

    /// lamina-accel itself, for its statistics (counted traversals, tree shape); `None`
    /// for Embree.
    pub fn lamina(&self) -> Option<&lamina_accel::Accel> {
        match self {
            Core::Lamina(a) => Some(a),
            #[cfg(feature = "embree")]
            Core::Embree(_) => None,
        }
    }
}
