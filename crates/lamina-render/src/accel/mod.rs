//! Ray casting for the renderer: the scene's meshes, cards, instances and lights handed to
//! lamina-accel (wide SIMD BVHs in two levels, opacity masks in the leaf test), plus the
//! shading data lamina-accel never sees.
//!
//! * **Two levels**: one level over every triangle of the world-space meshes plus the quad
//!   lights, one per prototype an instance uses (object space, built once however many
//!   instances use it), and lamina-accel's top level over the instances. A ray enters an
//!   instance in object space with its direction *not renormalised*, so `t` means the same
//!   in every space. A prototype of at most four primitives (a leaf card) has no tree.
//! * **Instance shading**: [`Accel::surface`] returns world-space data: the position
//!   through the object-to-world transform, the geometric normal through the inverse
//!   transpose (so a mirroring transform keeps the adaxial side on the side of the
//!   transformed normal, as for a mesh flattened with its winding reversed), the tangent
//!   `dP/du` through the transform, re-orthogonalised.
//! * **Alpha test on every ray kind**: a primitive whose material has a matte
//!   ([`lamina_core::AlphaMask`], or a leaf's [`lamina_leaf::LeafMaterial::opaque`]) is
//!   hit only where the matte is opaque at the interpolated texture coordinate.
//!   lamina-accel decides most candidates with the matte's 3-state opacity mask (exact at
//!   the texel grid, built here at load, `alpha.rs`); candidates in cells the matte's
//!   outline crosses come back to the exact lookup. [`Accel::intersect`] finds the
//!   closest opaque hit, [`Accel::occluded`] stops at the first one (any-hit).
//! * **Self-intersection**: rays leaving a surface skip the primitive they leave (a
//!   [`PrimRef`], instance and primitive: a planar triangle cannot be hit again by a ray
//!   leaving it) and start a small distance off the surface on the side they go (see
//!   [`spawn_origin`]), which guards against the neighbouring triangles of the same card.
//! * **Cards**: two consecutive triangles of a mesh that form a planar parallelogram with
//!   affine UVs (a leaf card, however it was split) become one parallelogram primitive, as
//!   do quad lights: half the primitives, and one intersection test per card.
//! * **Shading data**: per primitive (lamina-accel's id, the order pushed) its vertices,
//!   UVs, unit geometric normal, unit tangent along `dP/du` and material / light id, read
//!   once per final hit; precomputed at build time, per level.
//! * **Shading normals**: triangles whose mesh carries vertex normals that differ from the
//!   geometric normal keep them (level space) in a side table: per primitive a `u32`
//!   index into an array of `[Vec3; 3]`, and the index array exists only in a level with
//!   at least one such triangle. Cards, quad lights, meshes without normals and meshes
//!   whose normals equal the geometric normal store nothing and are never merged with
//!   smooth triangles. [`Accel::shading_normal`] interpolates them at the hit.
//!
//! Files: this one holds the public types, the build and the queries; `prims.rs` the
//! detection of cards, `alpha.rs` the alpha test and its masks, `blas.rs` one level's
//! primitives and shading tables. `tests/` is the acceleration-structure suite every
//! backend must pass.

mod alpha;
mod blas;
mod prims;
#[cfg(test)]
mod tests;

use crate::error::RenderError;
use alpha::AlphaTest;
use blas::{Blas, BlasBuilder};
use glam::{Affine3A, Vec2, Vec3, Vec3A};
use lamina_accel::{AccelError, Geometry, Instance, SceneDesc, Sphere};
use lamina_core::{Light, Material, Scene};
use lamina_leaf::frame::Frame;

pub use lamina_accel::Ray;

/// What a ray hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HitKind {
    /// A triangle or parallelogram primitive (mesh triangle, leaf card or quad light).
    Triangle {
        /// Which primitive (of the world meshes or of one instance), for
        /// [`Accel::surface`].
        prim: PrimRef,
        /// Barycentric coordinates of `v1` and `v2`.
        bary: Vec2,
    },
    /// A sphere light.
    Sphere {
        /// Index into [`Scene::lights`].
        light: u32,
    },
}

/// The closest opaque intersection along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (m, for a unit direction).
    pub t: f32,
    /// What was hit.
    pub kind: HitKind,
}

/// Flag in [`PrimInfo::flags`]: the material has an alpha matte.
pub const FLAG_ALPHA: u32 = 0x4000_0000;
/// Flag in [`PrimInfo::flags`]: the primitive is a quad light (id = light index).
pub const FLAG_EMITTER: u32 = 0x8000_0000;
/// Flag in [`PrimInfo::flags`]: the primitive is a parallelogram `v0 + b1·e1 + b2·e2`,
/// `b1, b2 ∈ [0, 1]` (a leaf card or quad light), not a triangle.
pub const FLAG_QUAD: u32 = 0x2000_0000;
/// Flag in [`PrimInfo::flags`]: the primitive's texture mapping is mirrored, i.e.
/// `(n × dP/du) · dP/dv < 0` for its geometric normal `n` (normal maps' bitangents flip).
pub const FLAG_UV_MIRRORED: u32 = 0x1000_0000;
/// Mask of the material or light index in [`PrimInfo::flags`].
pub const ID_MASK: u32 = 0x0fff_ffff;
pub use lamina_accel::{NO_INSTANCE, NO_PRIM};

/// A primitive of the scene: primitive `prim` (the order the level's meshes were pushed)
/// of the world meshes and quad lights (`inst == NO_INSTANCE`) or of the prototype of
/// instance `inst` (lamina-accel's instance id: the top level's order, not the index in
/// [`Scene::instances`]).
pub use lamina_accel::PrimRef;

/// Per-triangle shading data, precomputed at build time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimInfo {
    /// Texture coordinates at the three vertices (zero when the mesh has none).
    pub uv: [Vec2; 3],
    /// Unit geometric normal `(v1 - v0) × (v2 - v0)`, the front (adaxial) side.
    pub n: Vec3,
    /// Unit tangent along `dP/du`, orthogonal to `n` (along `v1 - v0` without UVs).
    pub s: Vec3,
    /// Material index (or light index for emitters) in the low 29 bits, plus
    /// [`FLAG_ALPHA`] / [`FLAG_EMITTER`] / [`FLAG_QUAD`] / [`FLAG_UV_MIRRORED`].
    pub flags: u32,
}

impl PrimInfo {
    /// Texture coordinates at barycentric `bary`.
    #[inline]
    pub fn uv_at(&self, bary: Vec2) -> Vec2 {
        self.uv[0] * (1.0 - bary.x - bary.y) + self.uv[1] * bary.x + self.uv[2] * bary.y
    }

    /// The shading frame: `z` the geometric normal, `x` along `dP/du`.
    #[inline]
    pub fn frame(&self) -> Frame {
        Frame {
            s: self.s,
            t: self.n.cross(self.s),
            n: self.n,
        }
    }
}

/// A ray origin `offset` off the surface at `p` (unit geometric normal `n`) on the side of
/// `dir`: `p ± n · 2·10⁻⁵ (1 + max|p|)`, a few hundred ulps of the position.
#[inline]
pub fn spawn_origin(p: Vec3, n: Vec3, dir: Vec3) -> Vec3 {
    let eps = 2e-5 * (1.0 + p.abs().max_element());
    if dir.dot(n) >= 0.0 {
        p + n * eps
    } else {
        p - n * eps
    }
}

/// Memory held by an [`Accel`], in bytes, by level: lamina-accel's trees, packs and
/// records plus, in `world` and `prototypes`, the renderer's shading records.
pub use lamina_accel::AccelMemory;

/// The acceleration structure of a scene: lamina-accel's levels plus the shading side of
/// every level.
#[derive(Clone, Debug)]
pub struct Accel {
    core: lamina_accel::Accel,
    world: Blas,
    prototypes: Vec<Blas>,
    alpha: Vec<AlphaTest>,
    /// Per lamina-accel sphere, its index in [`Scene::lights`].
    sphere_lights: Vec<u32>,
}

fn accel_error(e: AccelError) -> RenderError {
    RenderError::InvalidScene(e.to_string())
}

impl Accel {
    /// Builds the acceleration structure of `scene`: world meshes and quad lights, one
    /// level per prototype an instance uses, and the top level over the instances.
    /// Degenerate or non-finite triangles are left out. An error for out-of-range vertex,
    /// material or prototype indices and for instance transforms that are not finite and
    /// invertible.
    pub fn build(scene: &Scene) -> Result<Self, RenderError> {
        Self::build_with(scene, true)
    }

    /// [`Accel::build`], with `merge_cards = false` keeping every card as two triangles (for
    /// benchmarks; the images are the same).
    pub fn build_with(scene: &Scene, merge_cards: bool) -> Result<Self, RenderError> {
        Self::build_for(scene, merge_cards, lamina_accel::Kernel::best())
    }

    /// [`Accel::build_with`] for traversal kernel `kernel` (an error if this CPU lacks it):
    /// for tests and benchmarks of each kernel.
    pub fn build_for(
        scene: &Scene,
        merge_cards: bool,
        kernel: lamina_accel::Kernel,
    ) -> Result<Self, RenderError> {
        let alpha: Vec<AlphaTest> = scene
            .materials
            .iter()
            .map(|m| match m {
                Material::Leaf { leaf, .. } => AlphaTest::Leaf(leaf.clone()),
                m => m
                    .alpha_mask()
                    .cloned()
                    .map_or(AlphaTest::None, AlphaTest::Mask),
            })
            .collect();
        let mut world = BlasBuilder::default();
        world.push_meshes(&scene.meshes, &alpha, merge_cards, &|mi| {
            format!("mesh {mi}")
        })?;
        let mut spheres = Vec::new();
        let mut sphere_lights = Vec::new();
        for (li, light) in scene.lights.iter().enumerate() {
            match light {
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    ..
                } => {
                    world.push(
                        [*corner, *corner + *edge_u, *corner + *edge_v],
                        [Vec2::ZERO, Vec2::X, Vec2::Y],
                        None,
                        None,
                        FLAG_EMITTER | FLAG_QUAD | li as u32,
                    );
                }
                Light::Sphere { center, radius, .. } if center.is_finite() && *radius > 0.0 => {
                    spheres.push(Sphere {
                        center: *center,
                        radius: *radius,
                    });
                    sphere_lights.push(li as u32);
                }
                _ => {}
            }
        }

        // Only prototypes that some instance uses are collected.
        let mut used = vec![false; scene.prototypes.len()];
        for (ii, inst) in scene.instances.iter().enumerate() {
            let Some(u) = used.get_mut(inst.prototype as usize) else {
                return Err(RenderError::InvalidScene(format!(
                    "instance {ii} uses prototype {}, but there are {} prototypes",
                    inst.prototype,
                    scene.prototypes.len()
                )));
            };
            *u = true;
        }
        let prototypes = scene
            .prototypes
            .iter()
            .zip(&used)
            .enumerate()
            .map(|(pi, (proto, &used))| {
                let mut b = BlasBuilder::default();
                if used {
                    b.push_meshes(&proto.meshes, &alpha, merge_cards, &|mi| {
                        format!("prototype {pi} ('{}'), mesh {mi}", proto.name)
                    })?;
                }
                Ok(b)
            })
            .collect::<Result<Vec<BlasBuilder>, RenderError>>()?;
        let (proto_geometry, prototypes): (Vec<Geometry>, Vec<Blas>) =
            prototypes.into_iter().map(|b| (b.geometry, b.blas)).unzip();
        let desc = SceneDesc {
            world: world.geometry,
            prototypes: proto_geometry,
            instances: scene
                .instances
                .iter()
                .map(|i| Instance {
                    object_to_world: i.transform,
                    prototype: i.prototype,
                })
                .collect(),
            spheres,
            masks: alpha.iter().map(AlphaTest::mask).collect(),
        };
        let core = lamina_accel::Accel::build_with(
            &desc,
            lamina_accel::BuildOptions {
                kernel,
                ..Default::default()
            },
        )
        .map_err(accel_error)?;
        Ok(Accel {
            core,
            world: world.blas,
            prototypes,
            alpha,
            sphere_lights,
        })
    }

    /// The kernel lamina-accel traverses with (AVX2 8-wide, SSE 4-wide or scalar).
    pub fn kernel(&self) -> lamina_accel::Kernel {
        self.core.kernel()
    }

    /// Number of primitives stored: triangles, plus parallelograms for leaf cards (pairs of
    /// mesh triangles) and quad lights, of the world meshes and of every prototype once.
    pub fn primitive_count(&self) -> usize {
        self.world.prims.len() + self.prototypes.iter().map(|b| b.prims.len()).sum::<usize>()
    }

    /// Number of instances in the top level (instances of empty prototypes are dropped).
    pub fn instance_count(&self) -> usize {
        self.core.memory().instance_count
    }

    /// Bytes held by the BVHs, primitive records and shading records, by level.
    pub fn memory(&self) -> AccelMemory {
        let m = self.core.memory();
        AccelMemory {
            world: m.world + self.world.bytes(),
            prototypes: m.prototypes + self.prototypes.iter().map(Blas::bytes).sum::<usize>(),
            instances: m.instances,
            masks: m.masks,
            instance_count: m.instance_count,
        }
    }

    /// The world-to-object transform of instance `inst`.
    #[inline(always)]
    fn world_to_object(&self, inst: u32) -> Affine3A {
        self.core
            .world_to_object(inst)
            .expect("a PrimRef's instance comes from this Accel")
    }

    /// The surface at barycentric `bary` on primitive `prim` (from a [`HitKind::Triangle`]),
    /// in world space: the position (from the primitive's vertices, more precise than
    /// `origin + t·dir`) and the shading data. For an instance the geometric normal is
    /// transformed by the inverse transpose (so a mirroring transform keeps the adaxial
    /// side on the side of the transformed normal) and the tangent by the transform.
    #[inline]
    pub fn surface(&self, prim: PrimRef, bary: Vec2) -> (Vec3, PrimInfo) {
        let blas = self.blas_of(prim);
        let shade = &blas.prims[prim.prim as usize];
        let [v0, e1, e2] = shade.verts;
        let p = v0 + e1 * bary.x + e2 * bary.y;
        let info = shade.info;
        if prim.inst == NO_INSTANCE {
            return (p, info);
        }
        let w2o = self.world_to_object(prim.inst);
        let o2w = w2o.inverse();
        let n = (w2o.matrix3.transpose() * Vec3A::from(info.n)).normalize_or_zero();
        let s = o2w.matrix3 * Vec3A::from(info.s);
        let frame = Frame::from_normal_tangent(n.into(), s.into());
        (
            o2w.transform_point3(p),
            PrimInfo {
                n: frame.n,
                s: frame.s,
                ..info
            },
        )
    }

    /// The shading normal at barycentric `bary` on primitive `prim`, in world space: the
    /// mesh's vertex normals interpolated with `bary`, through the inverse transpose for an
    /// instance, unit length, *not* flipped to the geometric side (see
    /// [`crate::shading::ShadingFrame`]). `None` for a flat primitive (cards, quad lights,
    /// meshes without normals, normals equal to the geometric normal) and where the
    /// interpolated normal is degenerate or not finite: then the geometric normal shades.
    #[inline]
    pub fn shading_normal(&self, prim: PrimRef, bary: Vec2) -> Option<Vec3> {
        let blas = self.blas_of(prim);
        let k = *blas.nidx.get(prim.prim as usize)?;
        let vn = blas.normals.get(k as usize)?; // NO_NORMALS is out of range
        let n = vn[0] * (1.0 - bary.x - bary.y) + vn[1] * bary.x + vn[2] * bary.y;
        let n = if prim.inst == NO_INSTANCE {
            n
        } else {
            let w2o = self.world_to_object(prim.inst);
            (w2o.matrix3.transpose() * Vec3A::from(n)).into()
        };
        let len2 = n.length_squared();
        // Opposite vertex normals can cancel: below 1e-4 of unit length the direction is noise.
        (len2.is_finite() && len2 > 1e-8).then(|| n / len2.sqrt())
    }

    /// The tangent frame of normal maps at barycentric `bary` on primitive `prim`, world
    /// space: `(t, sign)` with `t` along increasing texture `u` (the mesh's interpolated
    /// vertex tangent where it has them, else `dP/du` of the primitive; neither unit nor
    /// orthogonal to any normal) and `sign = ±1` such that `sign · (n × t)` points towards
    /// increasing `v` for the geometric normal `n` that [`Accel::surface`] returns.
    #[inline]
    pub fn uv_tangent(&self, prim: PrimRef, bary: Vec2) -> (Vec3, f32) {
        let blas = self.blas_of(prim);
        let i = prim.prim as usize;
        let info = &blas.prims[i].info;
        let mut sign = if info.flags & FLAG_UV_MIRRORED != 0 {
            -1.0
        } else {
            1.0
        };
        let mut t = info.s;
        let vertex = blas
            .nidx
            .get(i)
            .and_then(|&k| Some((blas.tangents.get(k as usize)?, blas.normals[k as usize])));
        if let Some((vt, vn)) = vertex
            && vt[0].w != 0.0
        {
            let w = [1.0 - bary.x - bary.y, bary.x, bary.y];
            let tv = vt[0].truncate() * w[0] + vt[1].truncate() * w[1] + vt[2].truncate() * w[2];
            let nv = vn[0] * w[0] + vn[1] * w[1] + vn[2] * w[2];
            if tv.length_squared() > 1e-12 && tv.is_finite() {
                t = tv;
                // The mesh's handedness is relative to its vertex normal.
                sign = vt[0].w.signum() * if nv.dot(info.n) < 0.0 { -1.0 } else { 1.0 };
            }
        }
        if prim.inst == NO_INSTANCE {
            return (t, sign);
        }
        // (M⁻ᵀn × Mt)·Mb = det(M) (M⁻ᵀn)·(M⁻ᵀ(t × b)), and t × b is along n.
        let o2w = self.world_to_object(prim.inst).inverse();
        let det = o2w.matrix3.determinant();
        (
            (o2w.matrix3 * Vec3A::from(t)).into(),
            if det < 0.0 { -sign } else { sign },
        )
    }

    /// The flags (material or light id and `FLAG_*`) of primitive `prim`.
    #[inline]
    pub fn flags(&self, prim: PrimRef) -> u32 {
        self.blas_of(prim).prims[prim.prim as usize].info.flags
    }

    #[inline(always)]
    fn blas_of(&self, prim: PrimRef) -> &Blas {
        if prim.inst == NO_INSTANCE {
            &self.world
        } else {
            &self.prototypes[self.core.prototype_of(prim.inst) as usize]
        }
    }

    /// The closest opaque hit along `ray`, if any.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_skip(ray, PrimRef::NONE)
    }

    /// Whether any opaque surface lies along `ray` in `(0, tmax)`.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_skip(ray, PrimRef::NONE)
    }

    /// The exact alpha test lamina-accel asks for candidates its masks cannot decide.
    #[inline(always)]
    fn filter(&self) -> impl Fn(u32, Vec2) -> bool + '_ {
        |id, uv| self.alpha[id as usize].opaque(uv)
    }

    /// [`Accel::intersect`], ignoring primitive `skip` (the one the ray leaves).
    #[inline]
    pub fn intersect_skip(&self, ray: &Ray, skip: PrimRef) -> Option<Hit> {
        let h = self.core.intersect(ray, skip, &self.filter())?;
        let kind = if h.prim.inst == lamina_accel::SPHERE {
            HitKind::Sphere {
                light: self.sphere_lights[h.prim.prim as usize],
            }
        } else {
            HitKind::Triangle {
                prim: h.prim,
                bary: h.bary,
            }
        };
        Some(Hit { t: h.t, kind })
    }

    /// [`Accel::intersect`], counting lamina-accel's traversal steps into `stats` (for
    /// benchmarks: nodes and packs per ray, alpha lookups the masks saved).
    pub fn intersect_counted(&self, ray: &Ray, stats: &lamina_accel::TraversalStats) -> bool {
        self.core
            .intersect_counted(ray, PrimRef::NONE, &self.filter(), stats)
            .is_some()
    }

    /// [`Accel::occluded`], counting lamina-accel's traversal steps into `stats`.
    pub fn occluded_counted(&self, ray: &Ray, stats: &lamina_accel::TraversalStats) -> bool {
        self.core
            .occluded_counted(ray, PrimRef::NONE, &self.filter(), stats)
    }

    /// The SAH cost, wide nodes and leaf packs of the world level's tree.
    pub fn world_tree(&self) -> (f64, usize, usize) {
        let (n, p) = self.core.world_counts();
        (self.core.world_sah_cost(), n, p)
    }

    /// [`Accel::occluded`], ignoring primitive `skip` (the one the ray leaves).
    #[inline]
    pub fn occluded_skip(&self, ray: &Ray, skip: PrimRef) -> bool {
        self.core.occluded(ray, skip, &self.filter())
    }
}
