//! Ray casting: compressed wide BVH8s (obvhs) in two levels, a short list of sphere lights,
//! and the alpha test.
//!
//! * **Two levels**: one BLAS over every triangle of the world-space meshes plus the quad
//!   lights, one BLAS per prototype (object space, built once however many instances use
//!   it), and a top-level BVH (TLAS) over the instances' world bounds. A query traverses
//!   the world BLAS first, then the TLAS with `tmax` already shortened; a TLAS leaf
//!   transforms the ray into its prototype's object space with the instance's 3x4
//!   world-to-object matrix *without renormalising the direction*, so `t` means the same
//!   in both spaces and one `tmax` serves all levels. A scene without instances has no
//!   TLAS and costs what a single BVH costs. Instance records are 52 bytes (matrix +
//!   prototype id), stored in TLAS leaf order.
//! * **Tiny BLASes**: a BLAS of at most four primitives (a leaf-card prototype is one
//!   parallelogram) has no BVH; a ray tests its primitives one after the other (closest
//!   hit, skip and alpha test as in a traversal), which costs less than starting a
//!   traversal and testing a root node for every instance the TLAS reaches.
//! * **Instance shading**: [`Accel::surface`] returns world-space data: the position
//!   through the object-to-world transform, the geometric normal through the inverse
//!   transpose (so a mirroring transform keeps the adaxial side on the side of the
//!   transformed normal, as for a mesh flattened with its winding reversed), the tangent
//!   `dP/du` through the transform, re-orthogonalised.
//! * **Alpha test on every ray kind**: a triangle whose material has a matte
//!   ([`lamina_core::AlphaMask`], or a leaf's [`lamina_leaf::LeafMaterial::opaque`]) is
//!   hit only where the matte is opaque at the interpolated texture coordinate; the
//!   traversal rejects the other hits and goes on. [`Accel::intersect`] finds the closest
//!   opaque hit, [`Accel::occluded`] stops at the first one (any-hit).
//! * **Self-intersection**: rays leaving a surface skip the primitive they leave (a
//!   [`PrimRef`], instance and primitive: a planar triangle cannot be hit again by a ray
//!   leaving it) and start a small distance off the
//!   surface on the side they go (see [`spawn_origin`]), which guards against the
//!   neighbouring triangles of the same card.
//! * **Cards**: two consecutive triangles of a mesh that form a planar parallelogram with
//!   affine UVs (a leaf card, however it was split) become one parallelogram primitive, as
//!   do quad lights: half the primitives, and one intersection test per card.
//! * **Layout**: primitives are stored in BVH leaf order, one 64-byte cache line each:
//!   `v0, e1, e2` for the Möller-Trumbore test plus the flags and UVs of the alpha test, so
//!   a candidate costs one cache line. Shading data (UVs, unit geometric normal, unit
//!   tangent along `dP/du`, material / light id) sit in a parallel array indexed by the same
//!   primitive id, read once per final hit. All of it is precomputed at build time, per
//!   BLAS.
//! * **Shading normals**: triangles whose mesh carries vertex normals that differ from the
//!   geometric normal keep them (BLAS space) in a side table: per primitive a `u32`
//!   index into an array of `[Vec3; 3]`, and the index array exists only in a BLAS with at
//!   least one such triangle. Cards, quad lights, meshes without normals and meshes whose
//!   normals equal the geometric normal store nothing and are never merged with smooth
//!   triangles. [`Accel::shading_normal`] interpolates them at the hit.
//!
//! Files: this one holds the public types, the build of the two levels and the queries;
//! `prims.rs` the primitive records and their intersection tests (and card detection),
//! `alpha.rs` the alpha test, `blas.rs` the bottom-level structures and their builder.
//! `tests/` is the acceleration-structure suite every backend must pass.

mod alpha;
mod blas;
mod prims;
#[cfg(test)]
mod tests;

use crate::error::RenderError;
use alpha::{AlphaTest, MaskCells};
use blas::{Blas, BlasBuilder, bvh_bytes};
use glam::{Affine3A, Vec2, Vec3, Vec3A};
use lamina_core::{Light, Material, Scene};
use lamina_leaf::frame::Frame;
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh},
    ray::{Ray as BvhRay, RayHit},
};
use prims::{SphereGeom, Tri, intersect_sphere, intersect_tri};

/// A ray: `origin + t·dir` for `t ∈ (0, tmax)`. `dir` must be unit length for distances to
/// be in metres (the integrators always pass unit directions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin (m).
    pub origin: Vec3,
    /// Direction (unit).
    pub dir: Vec3,
    /// Largest distance considered (m); `f32::INFINITY` for none.
    pub tmax: f32,
}

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
/// "No primitive" in [`PrimRef::prim`].
pub const NO_PRIM: u32 = u32::MAX;
/// [`PrimRef::inst`] of the world-space meshes and quad lights (not an instance).
pub const NO_INSTANCE: u32 = u32::MAX;

/// A primitive of the scene: primitive `prim` (BVH order) of the world meshes
/// (`inst == NO_INSTANCE`) or of the prototype of instance `inst` (top-level order).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PrimRef {
    /// Instance (top-level BVH order), or [`NO_INSTANCE`] for world geometry.
    pub inst: u32,
    /// Primitive within that BLAS (its BVH order), or [`NO_PRIM`].
    pub prim: u32,
}

impl PrimRef {
    /// No primitive: nothing to skip.
    pub const NONE: PrimRef = PrimRef {
        inst: NO_INSTANCE,
        prim: NO_PRIM,
    };
}

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

/// The obvhs ray for origin `o`, direction `d`, `t ∈ (0, tmax)`. Negative zeros in `d`
/// become positive zeros (`-0 + 0 = +0`): obvhs picks the ray octant with `d < 0` (false
/// for `-0`) but inverts `-0` to a large *negative* value, and with the two disagreeing
/// the traversal misses boxes it is inside (an axis-aligned `-Vec3::Z` ray missed half of a
/// sphere).
#[inline(always)]
fn bvh_ray(o: Vec3A, d: Vec3A, tmax: f32) -> BvhRay {
    BvhRay::new(o, d + Vec3A::ZERO, 0.0, tmax)
}

/// One placed prototype, as the traversal stores it: the world-to-object transform as a
/// 3x4 matrix (columns `x`, `y`, `z`, translation: `p_obj = x·p.x + y·p.y + z·p.z + w`) and
/// the prototype index. 52 bytes; the object-to-world transform is recomputed (one 3x3
/// inverse) only for a ray's final hit.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct InstanceRec {
    world_to_object: [f32; 12],
    prototype: u32,
}

const _: () = assert!(std::mem::size_of::<InstanceRec>() == 52);

impl InstanceRec {
    #[inline(always)]
    fn world_to_object(&self) -> Affine3A {
        Affine3A::from_cols_slice(&self.world_to_object)
    }
}

/// Memory held by an [`Accel`], in bytes (heap arrays: BVH nodes, primitive records,
/// shading records, instance records).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccelMemory {
    /// The BVH and primitives of the world-space meshes and quad lights.
    pub world: usize,
    /// The BVHs and primitives of all prototypes (object space), each stored once.
    pub prototypes: usize,
    /// The instance records (52 bytes each) plus the top-level BVH over them.
    pub instances: usize,
    /// Number of instances.
    pub instance_count: usize,
}

impl AccelMemory {
    /// All of it (bytes).
    pub fn total(&self) -> usize {
        self.world + self.prototypes + self.instances
    }

    /// Bytes per instance of the instance level (record + its share of the top-level
    /// BVH); 0 without instances.
    pub fn bytes_per_instance(&self) -> f64 {
        if self.instance_count == 0 {
            0.0
        } else {
            self.instances as f64 / self.instance_count as f64
        }
    }
}

/// The acceleration structure of a scene: a BLAS over the world-space meshes and quad
/// lights, one BLAS per prototype, and a top-level BVH over the instances.
#[derive(Clone, Debug)]
pub struct Accel {
    world: Blas,
    prototypes: Vec<Blas>,
    /// Top-level BVH over the instances' world bounds; `None` without instances.
    tlas: Option<CwBvh>,
    /// Instances in top-level leaf order: a TLAS primitive id indexes this directly.
    instances: Vec<InstanceRec>,
    alpha: Vec<AlphaTest>,
    spheres: Vec<SphereGeom>,
}

/// A ray in the space of one BLAS: origin, direction (not renormalised, so `t` is the
/// same as in world space) and the primitive to skip.
#[derive(Clone, Copy)]
struct LocalRay {
    o: Vec3A,
    d: Vec3A,
    skip: u32,
}

impl Accel {
    /// Builds the BVHs of `scene`: world meshes and quad lights, one per prototype, and
    /// the top level over the instances. Degenerate or non-finite triangles are left out.
    /// An error for out-of-range vertex, material or prototype indices and for
    /// instance transforms that are not finite and invertible.
    pub fn build(scene: &Scene) -> Result<Self, RenderError> {
        Self::build_with(scene, true)
    }

    /// [`Accel::build`], with `merge_cards = false` keeping every card as two triangles (for
    /// benchmarks; the images are the same).
    pub fn build_with(scene: &Scene, merge_cards: bool) -> Result<Self, RenderError> {
        let alpha: Vec<AlphaTest> = scene
            .materials
            .iter()
            .map(|m| match m {
                Material::Leaf { leaf, .. } => AlphaTest::Leaf(leaf.clone()),
                m => m.alpha_mask().cloned().map_or(AlphaTest::None, |m| {
                    let cells = MaskCells::new(&m);
                    AlphaTest::Mask(m, cells)
                }),
            })
            .collect();
        let mut world = BlasBuilder::default();
        world.push_meshes(&scene.meshes, &alpha, merge_cards, &|mi| {
            format!("mesh {mi}")
        })?;
        let mut spheres = Vec::new();
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
                    spheres.push(SphereGeom {
                        center: *center,
                        radius: *radius,
                        light: li as u32,
                    });
                }
                _ => {}
            }
        }
        let world = world.finish();

        // Only prototypes that some instance uses get a BVH.
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
                Ok(b.finish())
            })
            .collect::<Result<Vec<Blas>, RenderError>>()?;

        let mut recs = Vec::with_capacity(scene.instances.len());
        let mut inst_bounds = Vec::with_capacity(scene.instances.len());
        for (ii, inst) in scene.instances.iter().enumerate() {
            let m = inst.transform;
            let det = m.matrix3.determinant();
            let inv = m.inverse();
            if !(det.abs() > 0.0 && m.is_finite() && inv.is_finite()) {
                return Err(RenderError::InvalidScene(format!(
                    "instance {ii}: the transform is not finite and invertible"
                )));
            }
            let Some(b) = prototypes[inst.prototype as usize].bounds else {
                continue; // an empty prototype: nothing to hit
            };
            let mut wb = Aabb::empty();
            for k in 0..8 {
                let c = Vec3A::new(
                    if k & 1 == 0 { b.min.x } else { b.max.x },
                    if k & 2 == 0 { b.min.y } else { b.max.y },
                    if k & 4 == 0 { b.min.z } else { b.max.z },
                );
                wb.extend(m.transform_point3a(c));
            }
            let mut w2o = [0.0f32; 12];
            inv.write_cols_to_slice(&mut w2o);
            recs.push(InstanceRec {
                world_to_object: w2o,
                prototype: inst.prototype,
            });
            inst_bounds.push(wb);
        }
        let (tlas, instances) = if recs.is_empty() {
            (None, Vec::new())
        } else {
            let mut tlas = build_cwbvh(
                &inst_bounds,
                BvhBuildParams {
                    max_prims_per_leaf: 1,
                    ..BvhBuildParams::medium_build()
                },
                &mut Default::default(),
            );
            let order = std::mem::take(&mut tlas.primitive_indices);
            let instances = order.iter().map(|&i| recs[i as usize]).collect();
            (Some(tlas), instances)
        };
        Ok(Accel {
            world,
            prototypes,
            tlas,
            instances,
            alpha,
            spheres,
        })
    }

    /// Number of primitives stored: triangles, plus parallelograms for leaf cards (pairs of
    /// mesh triangles) and quad lights, of the world meshes and of every prototype once.
    pub fn primitive_count(&self) -> usize {
        self.world.tris.len() + self.prototypes.iter().map(|b| b.tris.len()).sum::<usize>()
    }

    /// Number of instances in the top level (instances of empty prototypes are dropped).
    pub fn instance_count(&self) -> usize {
        self.instances.len()
    }

    /// Bytes held by the BVHs and primitive records, by level.
    pub fn memory(&self) -> AccelMemory {
        AccelMemory {
            world: self.world.bytes(),
            prototypes: self.prototypes.iter().map(Blas::bytes).sum(),
            instances: self.tlas.as_ref().map_or(0, bvh_bytes)
                + self.instances.len() * std::mem::size_of::<InstanceRec>(),
            instance_count: self.instances.len(),
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
        let t = &blas.tris[prim.prim as usize];
        let p = Vec3::from_array(t.v0)
            + Vec3::from_array(t.e1) * bary.x
            + Vec3::from_array(t.e2) * bary.y;
        let info = blas.prims[prim.prim as usize];
        if prim.inst == NO_INSTANCE {
            return (p, info);
        }
        let w2o = self.instances[prim.inst as usize].world_to_object();
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
            let w2o = self.instances[prim.inst as usize].world_to_object();
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
        let info = &blas.prims[i];
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
        let o2w = self.instances[prim.inst as usize]
            .world_to_object()
            .inverse();
        let det = o2w.matrix3.determinant();
        (
            (o2w.matrix3 * Vec3A::from(t)).into(),
            if det < 0.0 { -sign } else { sign },
        )
    }

    /// The flags (material or light id and `FLAG_*`) of primitive `prim`.
    #[inline]
    pub fn flags(&self, prim: PrimRef) -> u32 {
        self.blas_of(prim).tris[prim.prim as usize].flags
    }

    #[inline(always)]
    fn blas_of(&self, prim: PrimRef) -> &Blas {
        if prim.inst == NO_INSTANCE {
            &self.world
        } else {
            &self.prototypes[self.instances[prim.inst as usize].prototype as usize]
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

    #[inline(always)]
    fn accept(&self, tri: &Tri, b1: f32, b2: f32) -> bool {
        if tri.flags & FLAG_ALPHA == 0 {
            return true;
        }
        self.alpha[(tri.flags & ID_MASK) as usize].opaque(tri.uv_at(b1, b2))
    }

    /// Closest opaque hit in `blas` with `t < tmax`: `(t, prim, bary)`.
    #[inline(always)]
    fn blas_closest(&self, blas: &Blas, r: LocalRay, tmax: f32) -> Option<(f32, u32, Vec2)> {
        let Some(bvh) = &blas.bvh else {
            let mut best = None;
            let mut tmax = tmax;
            for (i, tri) in blas.tris.iter().enumerate() {
                if i as u32 == r.skip {
                    continue;
                }
                let (t, b1, b2) = intersect_tri(tri, r.o, r.d, tmax);
                if t < tmax && self.accept(tri, b1, b2) {
                    tmax = t;
                    best = Some((t, i as u32, Vec2::new(b1, b2)));
                }
            }
            return best;
        };
        let bray = bvh_ray(r.o, r.d, tmax);
        let mut hit = RayHit::none();
        let mut bary = Vec2::ZERO;
        let found = bvh.ray_traverse(bray, &mut hit, |ray, id| {
            if id as u32 == r.skip {
                return f32::INFINITY;
            }
            let tri = &blas.tris[id];
            let (t, b1, b2) = intersect_tri(tri, r.o, r.d, ray.tmax);
            if t < ray.tmax && self.accept(tri, b1, b2) {
                bary = Vec2::new(b1, b2);
                t
            } else {
                f32::INFINITY
            }
        });
        found.then_some((hit.t, hit.primitive_id, bary))
    }

    /// Whether `blas` has an opaque hit with `t < tmax`.
    #[inline(always)]
    fn blas_occluded(&self, blas: &Blas, r: LocalRay, tmax: f32) -> bool {
        let Some(bvh) = &blas.bvh else {
            return blas.tris.iter().enumerate().any(|(i, tri)| {
                if i as u32 == r.skip {
                    return false;
                }
                let (t, b1, b2) = intersect_tri(tri, r.o, r.d, tmax);
                t < tmax && self.accept(tri, b1, b2)
            });
        };
        let bray = bvh_ray(r.o, r.d, tmax);
        !bvh.ray_traverse_miss(bray, |ray, id| {
            if id as u32 == r.skip {
                return f32::INFINITY;
            }
            let tri = &blas.tris[id];
            let (t, b1, b2) = intersect_tri(tri, r.o, r.d, ray.tmax);
            if t < ray.tmax && self.accept(tri, b1, b2) {
                t
            } else {
                f32::INFINITY
            }
        })
    }

    /// The ray of TLAS primitive `inst` in its prototype's object space.
    #[inline(always)]
    fn local_ray(&self, inst: usize, o: Vec3A, d: Vec3A, skip: PrimRef) -> (&Blas, LocalRay) {
        let rec = &self.instances[inst];
        let w2o = rec.world_to_object();
        (
            &self.prototypes[rec.prototype as usize],
            LocalRay {
                o: w2o.transform_point3a(o),
                d: w2o.transform_vector3a(d),
                skip: if skip.inst == inst as u32 {
                    skip.prim
                } else {
                    NO_PRIM
                },
            },
        )
    }

    /// [`Accel::intersect`], ignoring primitive `skip` (the one the ray leaves).
    #[inline]
    pub fn intersect_skip(&self, ray: &Ray, skip: PrimRef) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.dir);
        let world_skip = if skip.inst == NO_INSTANCE {
            skip.prim
        } else {
            NO_PRIM
        };
        let wr = LocalRay {
            o,
            d,
            skip: world_skip,
        };
        if let Some((t, prim, bary)) = self.blas_closest(&self.world, wr, tmax) {
            tmax = t;
            best = Some(Hit {
                t,
                kind: HitKind::Triangle {
                    prim: PrimRef {
                        inst: NO_INSTANCE,
                        prim,
                    },
                    bary,
                },
            });
        }
        if let Some(tlas) = &self.tlas {
            let bray = bvh_ray(o, d, tmax);
            let mut hit = RayHit::none();
            let (mut prim, mut bary) = (0, Vec2::ZERO);
            if tlas.ray_traverse(bray, &mut hit, |r, inst| {
                let (blas, lr) = self.local_ray(inst, o, d, skip);
                match self.blas_closest(blas, lr, r.tmax) {
                    Some((t, p, b)) => {
                        (prim, bary) = (p, b);
                        t
                    }
                    None => f32::INFINITY,
                }
            }) {
                tmax = hit.t;
                best = Some(Hit {
                    t: hit.t,
                    kind: HitKind::Triangle {
                        prim: PrimRef {
                            inst: hit.primitive_id,
                            prim,
                        },
                        bary,
                    },
                });
            }
        }
        for s in &self.spheres {
            let t = intersect_sphere(s, ray.origin, ray.dir, tmax);
            if t < tmax {
                tmax = t;
                best = Some(Hit {
                    t,
                    kind: HitKind::Sphere { light: s.light },
                });
            }
        }
        best
    }

    /// [`Accel::occluded`], ignoring primitive `skip` (the one the ray leaves).
    #[inline]
    pub fn occluded_skip(&self, ray: &Ray, skip: PrimRef) -> bool {
        for s in &self.spheres {
            if intersect_sphere(s, ray.origin, ray.dir, ray.tmax) < ray.tmax {
                return true;
            }
        }
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.dir);
        let world_skip = if skip.inst == NO_INSTANCE {
            skip.prim
        } else {
            NO_PRIM
        };
        let wr = LocalRay {
            o,
            d,
            skip: world_skip,
        };
        if self.blas_occluded(&self.world, wr, ray.tmax) {
            return true;
        }
        let Some(tlas) = &self.tlas else {
            return false;
        };
        let bray = bvh_ray(o, d, ray.tmax);
        !tlas.ray_traverse_miss(bray, |r, inst| {
            let (blas, lr) = self.local_ray(inst, o, d, skip);
            if self.blas_occluded(blas, lr, r.tmax) {
                0.0
            } else {
                f32::INFINITY
            }
        })
    }
}
