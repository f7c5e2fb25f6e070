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
mod core;
mod prims;
#[cfg(test)]
mod tests;

use self::core::Core;
use crate::error::RenderError;
use alpha::AlphaTest;
use blas::{Blas, BlasBuilder};
use glam::{Affine3A, Vec2, Vec3, Vec3A};
use lamina_accel::{AccelError, Geometry, Instance, SceneDesc, Sphere};

pub use self::core::Backend;
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
    core: Core,
    world: Blas,
    prototypes: Vec<Blas>,
    alpha: Vec<AlphaTest>,
    /// Per lamina-accel sphere, its index in [`Scene::lights`].
    sphere_lights: Vec<u32>,
    /// The periodic domain rays wrap around, if the scene has one.
    wrap: Option<Wrap>,
    /// Provenance, kept for scenes that measure (`scene.radiometry` not empty): per world
    /// mesh pushed (the scene's, then periodic copies) the scene mesh index, and per
    /// instance id (the top level's order) the scene instance index it places or copies.
    origins: Option<Origins>,
}

/// Where primitives came from (see [`Accel::scene_mesh`], [`Accel::scene_instance`]).
#[derive(Clone, Debug, Default)]
struct Origins {
    meshes: Vec<u32>,
    instances: Vec<u32>,
}

/// A periodic domain as the traversal uses it: the cell (x, z) and the height range of the
/// geometry (rays outside it meet nothing).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Wrap {
    min: Vec2,
    max: Vec2,
    ymin: f32,
    ymax: f32,
}

/// Most cells a ray crosses in a periodic domain before it counts as escaped (a ray
/// running almost horizontally through an empty layer).
pub const MAX_WRAPS: u32 = 4096;

impl Wrap {
    /// `p` moved by whole cells into the cell (x, z), unchanged when already inside.
    #[inline]
    fn wrap_point(&self, mut p: Vec3) -> Vec3 {
        let size = self.max - self.min;
        if p.x < self.min.x || p.x > self.max.x {
            p.x =
                (self.min.x + (p.x - self.min.x).rem_euclid(size.x)).clamp(self.min.x, self.max.x);
        }
        if p.z < self.min.y || p.z > self.max.y {
            p.z =
                (self.min.y + (p.z - self.min.y).rem_euclid(size.y)).clamp(self.min.y, self.max.y);
        }
        p
    }

    /// Runs `segment(ray, skip)` over the pieces of `ray` inside the cell, one cell after
    /// the other (each piece ends at a side wall, the next starts at the opposite wall),
    /// within the height range of the geometry; returns the first `Some`, with the
    /// distance travelled before its piece.
    #[inline]
    fn trace<R>(
        &self,
        ray: &Ray,
        skip: PrimRef,
        mut segment: impl FnMut(&Ray, PrimRef) -> Option<R>,
    ) -> Option<(f32, R)> {
        let d = ray.dir;
        let (mut t0, mut t1) = (0.0f32, ray.tmax);
        if d.y != 0.0 {
            let (a, b) = (
                (self.ymin - ray.origin.y) / d.y,
                (self.ymax - ray.origin.y) / d.y,
            );
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        } else if ray.origin.y < self.ymin || ray.origin.y > self.ymax {
            return None;
        }
        if !(t0 <= t1) {
            return None;
        }
        // Start where the ray enters the height range (a camera far above the canopy).
        let mut t = if t0 > 0.0 { t0 } else { 0.0 };
        let mut o = self.wrap_point(if t > 0.0 {
            ray.origin + d * t
        } else {
            ray.origin
        });
        let mut skip = skip;
        for _ in 0..MAX_WRAPS {
            let tx = if d.x > 0.0 {
                (self.max.x - o.x) / d.x
            } else if d.x < 0.0 {
                (self.min.x - o.x) / d.x
            } else {
                f32::INFINITY
            };
            let tz = if d.z > 0.0 {
                (self.max.y - o.z) / d.z
            } else if d.z < 0.0 {
                (self.min.y - o.z) / d.z
            } else {
                f32::INFINITY
            };
            let wall = tx.min(tz).max(0.0);
            let rest = t1 - t;
            let piece = Ray {
                origin: o,
                dir: d,
                tmax: wall.min(rest),
            };
            if let Some(r) = segment(&piece, skip) {
                return Some((t, r));
            }
            if wall >= rest {
                return None;
            }
            t += wall;
            o += d * wall;
            if tx <= tz {
                o.x = if d.x > 0.0 { self.min.x } else { self.max.x };
            }
            if tz <= tx {
                o.z = if d.z > 0.0 { self.min.y } else { self.max.y };
            }
            o = o.clamp(
                Vec3::new(self.min.x, f32::NEG_INFINITY, self.min.y),
                Vec3::new(self.max.x, f32::INFINITY, self.max.y),
            );
            // The primitive left behind is one cell away now: another copy may be hit.
            skip = PrimRef::NONE;
        }
        None
    }
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

    /// [`Accel::build`] on ray-casting engine `backend` (an error naming the missing
    /// feature for [`Backend::Embree`] in a build without it).
    pub fn build_on(scene: &Scene, backend: Backend) -> Result<Self, RenderError> {
        Self::build_engine(scene, true, lamina_accel::Kernel::best(), backend)
    }

    /// [`Accel::build_with`] for traversal kernel `kernel` (an error if this CPU lacks it):
    /// for tests and benchmarks of each kernel.
    pub fn build_for(
        scene: &Scene,
        merge_cards: bool,
        kernel: lamina_accel::Kernel,
    ) -> Result<Self, RenderError> {
        Self::build_engine(scene, merge_cards, kernel, Backend::Lamina)
    }

    fn build_engine(
        scene: &Scene,
        merge_cards: bool,
        kernel: lamina_accel::Kernel,
        backend: Backend,
    ) -> Result<Self, RenderError> {
        let alpha: Vec<AlphaTest> = scene
            .materials
            .iter()
            .map(|m| match m {
                Material::Leaf { leaf, .. } => AlphaTest::of_leaf(leaf),
                m => m.alpha_mask().map_or(AlphaTest::None, AlphaTest::of_mask),
            })
            .collect();
        let copies = match &scene.radiometry.periodic {
            Some(p) => Some(
                lamina_core::radiometry::periodic_copies(scene, &p.cell)
                    .map_err(|e| RenderError::InvalidScene(periodic_message(&e)))?,
            ),
            None => None,
        };
        let mut world = BlasBuilder::default();
        world.push_meshes(&scene.meshes, &alpha, merge_cards, &|mi| {
            format!("mesh {mi}")
        })?;
        let mut mesh_origins: Vec<u32> = (0..scene.meshes.len() as u32).collect();
        if let Some(c) = &copies {
            world.push_meshes(&c.meshes, &alpha, merge_cards, &|mi| {
                format!("periodic copy of mesh {}", c.mesh_origins[mi])
            })?;
            mesh_origins.extend(&c.mesh_origins);
        }
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
        let mut instance_origins: Vec<u32> = (0..scene.instances.len() as u32).collect();
        let mut instances: Vec<Instance> = scene
            .instances
            .iter()
            .map(|i| Instance {
                object_to_world: i.transform,
                prototype: i.prototype,
            })
            .collect();
        if let Some(c) = &copies {
            for (o, i) in &c.instances {
                instance_origins.push(*o);
                instances.push(Instance {
                    object_to_world: i.transform,
                    prototype: i.prototype,
                });
            }
        }
        let desc = SceneDesc {
            world: world.geometry,
            prototypes: proto_geometry,
            instances,
            spheres,
            masks: alpha.iter().map(AlphaTest::mask).collect(),
        };
        let mut core = Core::build(&desc, backend, kernel).map_err(accel_error)?;
        // Sun shadow rays, most of a sunlit scene's shadow rays, take the grid along the
        // sun instead of a tree walk (same answers).
        let mut axes: Vec<Vec3> = Vec::new();
        for l in &scene.lights {
            if let Light::Sun { direction, .. } = l {
                let a = direction.normalize_or_zero();
                if a != Vec3::ZERO && !axes.contains(&a) {
                    axes.push(a);
                    core.index_direction(a);
                }
            }
        }
        // Camera rays from a pinhole take the grid from the eye (same answers).
        if let Some((eye, forward, up, window)) =
            crate::camera::CameraModel::new(&scene.camera, &scene.film)
                .ok()
                .and_then(|c| c.pinhole_view())
        {
            core.index_view(eye, forward, up, window);
        }
        let measuring = scene.radiometry != lamina_core::Radiometry::default();
        let origins = measuring.then(|| Origins {
            meshes: mesh_origins,
            instances: core
                .scene_instances(&desc)
                .into_iter()
                .map(|k| instance_origins[k as usize])
                .collect(),
        });
        let wrap = match (&scene.radiometry.periodic, &copies) {
            (Some(p), Some(c)) => Some(Wrap {
                min: p.cell.min,
                max: p.cell.max,
                // A margin so that surfaces at the extremes are inside the range.
                ymin: c.y_range.0 - 1e-3 * (1.0 + c.y_range.0.abs()),
                ymax: c.y_range.1 + 1e-3 * (1.0 + c.y_range.1.abs()),
            }),
            _ => None,
        };
        Ok(Accel {
            core,
            world: world.blas,
            prototypes,
            alpha,
            sphere_lights,
            wrap,
            origins,
        })
    }

    /// The kernel lamina-accel traverses with (AVX2 8-wide, SSE 4-wide or scalar); `None`
    /// on Embree.
    pub fn kernel(&self) -> Option<lamina_accel::Kernel> {
        self.core.kernel()
    }

    /// The ray-casting engine it traces with.
    pub fn backend(&self) -> Backend {
        self.core.backend()
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
            grids: m.grids,
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

    /// Asks for [`Accel::surface`]'s record of `prim` ahead of the call (a cache hint).
    #[inline]
    pub fn prefetch_surface(&self, prim: PrimRef) {
        let blas = self.blas_of(prim);
        if let Some(s) = blas.prims.get(prim.prim as usize) {
            lamina_accel::wide::prefetch(s);
        }
        // And its entry of the vertex normals' index, which [`Accel::shading_normal`]
        // reads next (an empty index, no level's primitive with normals, is not read).
        if let Some(k) = blas.nidx.get(prim.prim as usize) {
            lamina_accel::wide::prefetch(k);
        }
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

    /// [`Accel::intersect`], ignoring primitive `skip` (the one the ray leaves). In a
    /// periodic domain the ray wraps around the cell (see [`Accel::periodic`]); `t` is then
    /// the distance travelled, and the hit's surface lies inside the cell.
    #[inline]
    pub fn intersect_skip(&self, ray: &Ray, skip: PrimRef) -> Option<Hit> {
        if let Some(w) = &self.wrap {
            let (t, h) = w.trace(ray, skip, |r, s| self.intersect_once(r, s))?;
            return Some(Hit { t: t + h.t, ..h });
        }
        self.intersect_once(ray, skip)
    }

    /// The periodic cell `(min, max)` of (x, z) rays wrap around, if the scene has one.
    /// Rays that leave the cell through a side re-enter through the opposite side; rays
    /// outside the height range of the geometry meet nothing; a ray crossing more than
    /// [`MAX_WRAPS`] cells is taken as escaped.
    pub fn periodic(&self) -> Option<(Vec2, Vec2)> {
        self.wrap.map(|w| (w.min, w.max))
    }

    /// The lowest and highest `y` of the geometry of a periodic scene (m), with a small
    /// margin; `None` without a periodic domain.
    pub fn periodic_heights(&self) -> Option<(f32, f32)> {
        self.wrap.map(|w| (w.ymin, w.ymax))
    }

    /// The scene mesh (index into [`Scene::meshes`]) a world primitive comes from, or the
    /// scene instance (index into [`Scene::instances`]) an instance primitive belongs to:
    /// `(Some(mesh), None)` or `(None, Some(instance))`, periodic copies mapped to what they
    /// copy. `(None, None)` for quad lights, spheres, and for scenes that measure nothing
    /// (their provenance is not kept).
    pub fn origin(&self, prim: PrimRef) -> (Option<u32>, Option<u32>) {
        let Some(o) = &self.origins else {
            return (None, None);
        };
        if prim.inst == NO_INSTANCE {
            let mesh = self.world.mesh_of(prim.prim);
            (mesh.and_then(|m| o.meshes.get(m as usize).copied()), None)
        } else {
            (None, o.instances.get(prim.inst as usize).copied())
        }
    }

    /// [`Accel::intersect`] of each of `rays` into `out` (as long; at most
    /// [`Accel::MANY`]): the same answers, but a pinhole's camera rays from one pixel are
    /// tested together (see `lamina_accel::Accel::intersect_many`).
    ///
    /// # Panics
    /// When `out` is not as long as `rays` or they are more than [`Accel::MANY`].
    pub fn intersect_many(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert!(rays.len() == out.len() && rays.len() <= Self::MANY);
        if self.wrap.is_some() {
            for (ray, out) in rays.iter().zip(out.iter_mut()) {
                *out = self.intersect(ray);
            }
            return;
        }
        let mut hits = [None; Self::MANY];
        self.core
            .intersect_many(rays, &self.filter(), &mut hits[..rays.len()]);
        for (h, out) in hits.iter().zip(out.iter_mut()) {
            *out = h.map(|h| self.hit(h));
        }
    }

    /// [`Accel::intersect`] of the rays from `eye` along `(d[0][k], d[1][k], d[2][k])` (a
    /// pinhole's camera rays in lanes, world space) into `out[k]`, all as long: the same
    /// answers as [`Accel::intersect_many`] of those rays, bit for bit, from the lanes
    /// themselves (`lamina_accel::Accel::intersect_eye`).
    ///
    /// # Panics
    /// When the arrays of `d` and `out` are not all as long, or longer than
    /// [`Accel::MANY_EYE`].
    pub fn intersect_eye(&self, eye: Vec3, d: [&[f32]; 3], out: &mut [Option<Hit>]) {
        let n = out.len();
        assert!(d.iter().all(|a| a.len() == n) && n <= Self::MANY_EYE);
        if self.wrap.is_some() {
            for (k, out) in out.iter_mut().enumerate() {
                *out = self.intersect(&Ray::from_eye_lane(eye, d, k));
            }
            return;
        }
        let mut hits = [None; Self::MANY_EYE];
        self.core
            .intersect_eye(eye, d, &self.filter(), &mut hits[..n]);
        for (h, out) in hits.iter().zip(out.iter_mut()) {
            *out = h.map(|h| self.hit(h));
        }
    }

    /// Most rays one [`Accel::intersect_eye`] takes.
    pub const MANY_EYE: usize = 16;

    /// Most rays one [`Accel::intersect_many`] takes.
    pub const MANY: usize = 8;

    #[inline]
    fn intersect_once(&self, ray: &Ray, skip: PrimRef) -> Option<Hit> {
        let h = self.core.intersect(ray, skip, &self.filter())?;
        Some(self.hit(h))
    }

    /// The renderer's hit from lamina-accel's.
    #[inline(always)]
    fn hit(&self, h: lamina_accel::Hit) -> Hit {
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
        Hit { t: h.t, kind }
    }

    /// [`Accel::intersect_skip`], counting lamina-accel's traversal steps into `stats` (for
    /// benchmarks: nodes and packs per ray, alpha lookups the masks saved; Embree counts
    /// nothing). Whether the ray hits; a periodic domain's wrapping is not followed.
    pub fn intersect_counted(
        &self,
        ray: &Ray,
        skip: PrimRef,
        stats: &lamina_accel::TraversalStats,
    ) -> bool {
        let f = self.filter();
        match self.core.lamina() {
            Some(a) => a.intersect_counted(ray, skip, &f, stats).is_some(),
            None => self.core.intersect(ray, skip, &f).is_some(),
        }
    }

    /// [`Accel::occluded_skip`], counting lamina-accel's traversal steps into `stats`
    /// (as [`Accel::intersect_counted`]).
    pub fn occluded_counted(
        &self,
        ray: &Ray,
        skip: PrimRef,
        stats: &lamina_accel::TraversalStats,
    ) -> bool {
        let f = self.filter();
        match self.core.lamina() {
            Some(a) => a.occluded_counted(ray, skip, &f, stats),
            None => self.core.occluded(ray, skip, &f),
        }
    }

    /// [`Accel::intersect_many`], counting lamina-accel's traversal steps into `stats`
    /// (as [`Accel::intersect_counted`]): how many of `rays` hit.
    ///
    /// # Panics
    /// When `rays` are more than [`Accel::MANY`].
    pub fn intersect_many_counted(
        &self,
        rays: &[Ray],
        stats: &lamina_accel::TraversalStats,
    ) -> usize {
        assert!(rays.len() <= Self::MANY);
        let f = self.filter();
        let mut hits = [None; Self::MANY];
        let out = &mut hits[..rays.len()];
        match self.core.lamina() {
            Some(a) => a.intersect_many_counted(rays, &f, stats, out),
            None => self.core.intersect_many(rays, &f, out),
        }
        out.iter().filter(|h| h.is_some()).count()
    }

    /// The SAH cost, wide nodes and leaf packs of the world level's tree (zeros on Embree,
    /// whose tree is not exposed).
    pub fn world_tree(&self) -> (f64, usize, usize) {
        self.core.lamina().map_or((0.0, 0, 0), |a| {
            let (n, p) = a.world_counts();
            (a.world_sah_cost(), n, p)
        })
    }

    /// [`Accel::occluded`], ignoring primitive `skip` (the one the ray leaves).
    #[inline]
    pub fn occluded_skip(&self, ray: &Ray, skip: PrimRef) -> bool {
        if let Some(w) = &self.wrap {
            return w
                .trace(ray, skip, |r, s| {
                    self.core.occluded(r, s, &self.filter()).then_some(())
                })
                .is_some();
        }
        self.core.occluded(ray, skip, &self.filter())
    }

    /// [`Accel::occluded_skip`] of each of `rays`, leaving `skips[k]`, into `out` (all as
    /// long): the same answers, bit for bit. lamina-accel tests sun shadow rays that run
    /// the same cells of its grid along the sun together (a pixel's samples' first
    /// vertices), eight at a time; other rays, periodic scenes and Embree one by one.
    ///
    /// # Panics
    /// When `skips` or `out` is not as long as `rays`.
    pub fn occluded_many(&self, rays: &[Ray], skips: &[PrimRef], out: &mut [bool]) {
        assert!(rays.len() == skips.len() && rays.len() == out.len());
        if self.wrap.is_some() {
            for ((ray, skip), out) in rays.iter().zip(skips).zip(out.iter_mut()) {
                *out = self.occluded_skip(ray, *skip);
            }
            return;
        }
        self.core.occluded_many(rays, skips, &self.filter(), out);
    }

    /// [`Accel::occluded_many`], counting lamina-accel's traversal steps into `stats`
    /// (as [`Accel::intersect_counted`]): how many of `rays` are blocked.
    pub fn occluded_many_counted(
        &self,
        rays: &[Ray],
        skips: &[PrimRef],
        stats: &lamina_accel::TraversalStats,
    ) -> usize {
        let f = self.filter();
        let mut out = vec![false; rays.len()];
        match self.core.lamina() {
            Some(a) => a.occluded_many_counted(rays, skips, &f, stats, &mut out),
            None => self.core.occluded_many(rays, skips, &f, &mut out),
        }
        out.iter().filter(|&&b| b).count()
    }
}

/// A periodic-domain error as the renderer reports it.
fn periodic_message(e: &lamina_core::radiometry::PeriodicError) -> String {
    match (e.mesh, e.instance) {
        (Some(m), _) => format!("periodic domain: mesh {m}: {}", e.message),
        (_, Some(i)) => format!("periodic domain: instance {i}: {}", e.message),
        _ => format!("periodic domain: {}", e.message),
    }
}
