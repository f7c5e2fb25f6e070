//! The acceleration-structure suite: what any ray-casting backend of lamina must answer,
//! checked against a brute-force reference.
//!
//! * [`Backend`] is the interface the suite needs: build from a [`Scene`]'s primitives,
//!   the closest opaque hit (distance, primitive, instance, texture coordinates, point,
//!   normal) and any-hit (`occluded`), both alpha-tested and able to skip the primitive a
//!   ray leaves.
//! * [`reference::BruteForce`] implements it by testing every primitive, in `f64`, with
//!   no BVH; [`CurrentAccel`] wraps [`Accel`] (lamina-accel's wide BVHs in two levels).
//! * [`checks`] holds the suite: generic functions over `B: Backend` that compare `B` with
//!   the reference on thousands of seeded random rays over the scene kinds of
//!   [`random_scenes`] (triangles, alpha-masked cards, instances, lights), continuation
//!   rays, `tmax` limits, back faces, edges, degenerate and empty scenes, build errors.
//! * [`accel_api`] keeps the tests of [`Accel`]'s own API beyond the trait (surface
//!   frames, shading normals, UV tangents, card merging, the matte's cell table, memory).
//!
//! A new backend plugs in with an `impl Backend` (usually a thin wrapper, like
//! [`CurrentAccel`]) and one line: `backend_suite!(my_backend, MyBackend);` below, which
//! makes one `#[test]` per check (`accel::tests::my_backend::...`).

mod accel_api;
mod checks;
mod random_scenes;
mod reference;

use super::{Accel, FLAG_EMITTER, HitKind, ID_MASK, NO_INSTANCE, PrimRef, Ray};
use crate::error::RenderError;
use glam::{Vec2, Vec3};
use lamina_core::Scene;
use std::fmt::Debug;

/// What a closest hit lies on, in scene terms every backend can name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Surface {
    /// A mesh triangle: the instance (index into [`Scene::instances`]; `None` for the world
    /// meshes) and the mesh's material index.
    Mesh {
        /// Index into [`Scene::instances`], `None` for [`Scene::meshes`].
        instance: Option<u32>,
        /// The mesh's material (index into [`Scene::materials`]).
        material: u32,
    },
    /// A quad light (index into [`Scene::lights`]).
    QuadLight(u32),
    /// A sphere light (index into [`Scene::lights`]).
    SphereLight(u32),
}

/// A closest hit as the suite compares it. `P` is the backend's own primitive handle, only
/// ever given back to the same backend (to skip the primitive a ray leaves).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SuiteHit<P> {
    /// Distance along the ray (in units of its direction's length).
    pub t: f32,
    /// The backend's handle of the primitive hit.
    pub prim: P,
    /// The surface hit.
    pub what: Surface,
    /// Texture coordinates at the hit (zero on a sphere light).
    pub uv: Vec2,
    /// World-space hit point (zero on a sphere light).
    pub point: Vec3,
    /// Unit world-space geometric normal on the adaxial side, never flipped toward the ray
    /// (zero on a sphere light).
    pub normal: Vec3,
}

impl<P> SuiteHit<P> {
    /// A hit on sphere light `light`.
    fn sphere(t: f32, prim: P, light: u32) -> Self {
        SuiteHit {
            t,
            prim,
            what: Surface::SphereLight(light),
            uv: Vec2::ZERO,
            point: Vec3::ZERO,
            normal: Vec3::ZERO,
        }
    }
}

/// A ray-casting backend the suite checks. Rays are `origin + t·dir`, `t ∈ (0, tmax)`; a
/// triangle is hit from either side; a primitive whose material has an alpha matte (or a
/// leaf with an alpha map) is hit only where it is opaque; non-finite and zero-area
/// triangles are never hit.
pub(crate) trait Backend: Sized {
    /// Name in failure messages.
    const NAME: &'static str;
    /// The backend's handle of one primitive.
    type Prim: Copy + PartialEq + Debug;
    /// Builds the backend for `scene`'s meshes, instances and quad / sphere lights; an
    /// error for out-of-range indices and transforms that are not finite and invertible.
    fn build(scene: &Scene) -> Result<Self, RenderError>;
    /// The closest opaque hit along `ray`, not counting primitive `skip`.
    fn closest(&self, ray: &Ray, skip: Option<Self::Prim>) -> Option<SuiteHit<Self::Prim>>;
    /// Whether any opaque hit lies along `ray`, not counting primitive `skip`.
    fn occluded(&self, ray: &Ray, skip: Option<Self::Prim>) -> bool;
}

/// [`Accel`] (lamina-accel's wide BVHs) as a [`Backend`], built for kernel `K`: 0 the
/// best this CPU runs (AVX2 8-wide here), 1 SSE 4-wide, 2 scalar 4-wide; 3 on Embree
/// (lamina-render's `embree` feature). A kernel the CPU
/// lacks falls back to the best one (the suite then checks that one twice).
pub(crate) struct CurrentAccel<const K: u8 = 0> {
    accel: Accel,
    /// Per instance id (lamina-accel's top-level order), its index in [`Scene::instances`].
    scene_instance: Vec<u32>,
}

impl<const K: u8> Backend for CurrentAccel<K> {
    const NAME: &'static str = match K {
        0 => "lamina-accel (best kernel)",
        1 => "lamina-accel (SSE kernel)",
        3 => "Embree 3",
        _ => "lamina-accel (scalar kernel)",
    };
    type Prim = PrimRef;

    fn build(scene: &Scene) -> Result<Self, RenderError> {
        use lamina_accel::Kernel;
        let kernel = match K {
            1 => Kernel::Sse,
            2 => Kernel::Scalar,
            _ => Kernel::best(),
        };
        let kernel = if kernel.available() {
            kernel
        } else {
            Kernel::best()
        };
        let accel = if K == 3 {
            Accel::build_on(scene, crate::accel::Backend::Embree)?
        } else {
            Accel::build_for(scene, true, kernel)?
        };
        // lamina-accel stores the inverse transform as `Instance::transform.inverse()`
        // computes it: the same computation here finds each id's instance, bit for bit.
        let mut taken = vec![false; scene.instances.len()];
        let scene_instance = (0..accel.instance_count() as u32)
            .map(|id| {
                let w2o = accel.world_to_object(id);
                let k = (0..scene.instances.len())
                    .find(|&k| {
                        let inst = &scene.instances[k];
                        !taken[k]
                            && accel.core.prototype_of(id) == inst.prototype
                            && inst.transform.inverse() == w2o
                    })
                    .expect("every instance id comes from a scene instance");
                taken[k] = true;
                k as u32
            })
            .collect();
        Ok(CurrentAccel {
            accel,
            scene_instance,
        })
    }

    fn closest(&self, ray: &Ray, skip: Option<PrimRef>) -> Option<SuiteHit<PrimRef>> {
        let hit = self
            .accel
            .intersect_skip(ray, skip.unwrap_or(PrimRef::NONE))?;
        let (prim, bary) = match hit.kind {
            HitKind::Sphere { light } => {
                return Some(SuiteHit::sphere(hit.t, PrimRef::NONE, light));
            }
            HitKind::Triangle { prim, bary } => (prim, bary),
        };
        let (point, info) = self.accel.surface(prim, bary);
        let id = info.flags & ID_MASK;
        let what = if info.flags & FLAG_EMITTER != 0 {
            Surface::QuadLight(id)
        } else {
            Surface::Mesh {
                instance: (prim.inst != NO_INSTANCE)
                    .then(|| self.scene_instance[prim.inst as usize]),
                material: id,
            }
        };
        Some(SuiteHit {
            t: hit.t,
            prim,
            what,
            uv: info.uv_at(bary),
            point,
            normal: info.n,
        })
    }

    fn occluded(&self, ray: &Ray, skip: Option<PrimRef>) -> bool {
        self.accel.occluded_skip(ray, skip.unwrap_or(PrimRef::NONE))
    }
}

/// One `#[test]` per check of [`checks`] for backend `$backend`, in module `$name`.
macro_rules! backend_suite {
    ($name:ident, $backend:ty) => {
        mod $name {
            use super::checks;
            #[test]
            fn triangles_match_reference() {
                checks::triangles_match_reference::<$backend>();
            }
            #[test]
            fn alpha_masked_cards_match_reference() {
                checks::alpha_masked_cards_match_reference::<$backend>();
            }
            #[test]
            fn instances_match_reference() {
                checks::instances_match_reference::<$backend>();
            }
            #[test]
            fn continuation_rays_match_reference() {
                checks::continuation_rays_match_reference::<$backend>();
            }
            #[test]
            fn tmax_limits_match_reference() {
                checks::tmax_limits_match_reference::<$backend>();
            }
            #[test]
            fn edges_back_faces_and_grazing_rays() {
                checks::edges_back_faces_and_grazing_rays::<$backend>();
            }
            #[test]
            fn degenerate_and_empty_scenes() {
                checks::degenerate_and_empty_scenes::<$backend>();
            }
            #[test]
            fn build_errors() {
                checks::build_errors::<$backend>();
            }
        }
    };
}

backend_suite!(current, super::CurrentAccel);
backend_suite!(current_sse, super::CurrentAccel<1>);
backend_suite!(current_scalar, super::CurrentAccel<2>);
#[cfg(feature = "embree")]
backend_suite!(embree, super::CurrentAccel<3>);
backend_suite!(brute_force, super::reference::BruteForce);
