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

use crate::error::RenderError;
use glam::{Affine3A, Vec2, Vec3, Vec3A, Vec4};
use lamina_core::{AlphaMask, Light, Material, Mesh, Scene};
use lamina_leaf::frame::Frame;
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh, node::CwBvhNode},
    ray::{Ray as BvhRay, RayHit},
    triangle::Triangle,
};
use std::sync::Arc;

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

/// Everything the traversal needs for one triangle, in one 64-byte cache line: the
/// Möller-Trumbore form (`v0`, `e1 = v1 - v0`, `e2 = v2 - v0`), the flags and the UVs of the
/// alpha test. Shading data stay in [`PrimInfo`], fetched only for the final hit.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Tri {
    v0: [f32; 3],
    e1: [f32; 3],
    e2: [f32; 3],
    flags: u32,
    uv: [Vec2; 3],
}

const _: () = assert!(std::mem::size_of::<Tri>() == 64);

impl Tri {
    /// The traversal record of triangle (or parallelogram) `tr` with shading data `info`.
    fn new(tr: &Triangle, info: &PrimInfo) -> Self {
        Tri {
            v0: tr.v0.to_array(),
            e1: (tr.v1 - tr.v0).to_array(),
            e2: (tr.v2 - tr.v0).to_array(),
            flags: info.flags,
            uv: info.uv,
        }
    }

    #[inline(always)]
    fn uv_at(&self, b1: f32, b2: f32) -> Vec2 {
        self.uv[0] * (1.0 - b1 - b2) + self.uv[1] * b1 + self.uv[2] * b2
    }
}

/// Cell classes of a [`MaskCells`] table.
const CELL_TRANSPARENT: u8 = 0;
const CELL_OPAQUE: u8 = 1;
const CELL_MIXED: u8 = 2;

/// An exact shortcut for [`AlphaMask::opaque`]: for every bilinear cell (the square between
/// four texel centres) whether the mask is opaque everywhere in it (all four corners at
/// least the cutoff: a bilinear blend stays within its corners), transparent everywhere (all
/// below), or mixed. Only mixed cells, along the matte's outline, need the filtered lookup;
/// the others cost one byte read instead of four texel fetches.
#[derive(Clone, Debug)]
struct MaskCells {
    width: i64,
    height: i64,
    repeat: bool,
    /// `Repeat`: `height x width` cells indexed by the wrapped lower-left texel. `Clamp`:
    /// `(height + 1) x (width + 1)` cells for lower-left texels `-1 ..= size - 1`.
    cells: Vec<u8>,
}

impl MaskCells {
    /// Largest table built (cells); bigger mattes use the filtered lookup only.
    const MAX_CELLS: i64 = 1 << 26;

    fn new(mask: &AlphaMask) -> Option<Self> {
        let t = &mask.map;
        let (w, h) = (t.width() as i64, t.height() as i64);
        let repeat = t.wrap == lamina_leaf::Wrap::Repeat;
        let (x_range, y_range) = if repeat { (0..w, 0..h) } else { (-1..w, -1..h) };
        if (w + 1) * (h + 1) > Self::MAX_CELLS {
            return None;
        }
        // A margin keeps rounding in the bilinear blend from ever flipping a decision.
        let (hi, lo) = (mask.cutoff + 1e-5, mask.cutoff - 1e-5);
        let value = |x: i64, y: i64| {
            let s = t.texel(x, y);
            if mask.use_alpha_channel { s.w } else { s.x }
        };
        let mut cells = Vec::with_capacity(
            (x_range.end - x_range.start) as usize * (y_range.end - y_range.start) as usize,
        );
        for y in y_range {
            for x in x_range.clone() {
                let c = [
                    value(x, y),
                    value(x + 1, y),
                    value(x, y + 1),
                    value(x + 1, y + 1),
                ];
                cells.push(if c.iter().all(|&a| a >= hi) {
                    CELL_OPAQUE
                } else if c.iter().all(|&a| a < lo) {
                    CELL_TRANSPARENT
                } else {
                    CELL_MIXED
                });
            }
        }
        Some(MaskCells {
            width: w,
            height: h,
            repeat,
            cells,
        })
    }

    /// The class of the cell [`lamina_leaf::Texture::sample`] blends at `uv` (same
    /// arithmetic, so the same cell).
    #[inline(always)]
    fn classify(&self, uv: Vec2) -> u8 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return CELL_MIXED;
        }
        let (x0, y0) = (x.floor() as i64, y.floor() as i64);
        let i = if self.repeat {
            y0.rem_euclid(self.height) * self.width + x0.rem_euclid(self.width)
        } else {
            (y0.clamp(-1, self.height - 1) + 1) * (self.width + 1)
                + x0.clamp(-1, self.width - 1)
                + 1
        };
        self.cells.get(i as usize).copied().unwrap_or(CELL_MIXED)
    }
}

#[derive(Clone, Debug)]
enum AlphaTest {
    None,
    Mask(AlphaMask, Option<MaskCells>),
    Leaf(Arc<lamina_leaf::LeafMaterial>),
}

impl AlphaTest {
    #[inline]
    fn opaque(&self, uv: Vec2) -> bool {
        match self {
            AlphaTest::None => true,
            AlphaTest::Mask(m, cells) => match cells.as_ref().map(|c| c.classify(uv)) {
                Some(CELL_OPAQUE) => true,
                Some(CELL_TRANSPARENT) => false,
                _ => m.opaque(uv),
            },
            AlphaTest::Leaf(l) => l.opaque(uv),
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct SphereGeom {
    center: Vec3,
    radius: f32,
    light: u32,
}

/// Möller-Trumbore (for parallelograms without the `b1 + b2 <= 1` bound): `(t, b1, b2)`, `t = ∞` for a miss or `t ∉ (0, tmax)`.
#[inline(always)]
fn intersect_tri(tri: &Tri, o: Vec3A, d: Vec3A, tmax: f32) -> (f32, f32, f32) {
    const MISS: (f32, f32, f32) = (f32::INFINITY, 0.0, 0.0);
    let (v0, e1, e2) = (
        Vec3A::from_array(tri.v0),
        Vec3A::from_array(tri.e1),
        Vec3A::from_array(tri.e2),
    );
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return MISS;
    }
    let inv = 1.0 / det;
    let tv = o - v0;
    let b1 = tv.dot(p) * inv;
    if !(0.0..=1.0).contains(&b1) {
        return MISS;
    }
    let q = tv.cross(e1);
    let b2 = d.dot(q) * inv;
    let inside = if tri.flags & FLAG_QUAD != 0 {
        b2 <= 1.0
    } else {
        b1 + b2 <= 1.0
    };
    if !(b2 >= 0.0 && inside) {
        return MISS;
    }
    let t = e2.dot(q) * inv;
    if t > 0.0 && t < tmax {
        (t, b1, b2)
    } else {
        MISS
    }
}

/// If triangles `t1` and `t2` (index triples) together form a planar parallelogram with
/// affine texture coordinates, wound like `t1`, the parallelogram as `[origin, origin + e1,
/// origin + e2]` vertex indices (its fourth corner is `origin + e1 + e2`).
fn parallelogram(
    t1: [u32; 3],
    t2: [u32; 3],
    pos: &impl Fn(u32) -> Vec3,
    tex: &impl Fn(u32) -> Vec2,
) -> Option<[u32; 3]> {
    let [i0, i1, i2] = t1;
    let rot = |k: usize| [t2[k % 3], t2[(k + 1) % 3], t2[(k + 2) % 3]];
    let mut quad = None;
    for k in 0..3 {
        let [a, b, c] = rot(k);
        // Shared diagonal i0-i2: t2 = (i0, i2, x); corners i0, i1, i2, x.
        if a == i0 && b == i2 && c != i1 && c != i0 && c != i2 {
            quad = Some(([i0, i1, c], i2));
        }
        // Shared diagonal i1-i2: t2 = (i1, x, i2); corners i0, i1, x, i2.
        if a == i1 && c == i2 && b != i0 && b != i1 && b != i2 {
            quad = Some(([i0, i1, i2], b));
        }
    }
    let ([o, a, b], far) = quad?;
    let (po, pa, pb, pf) = (pos(o), pos(a), pos(b), pos(far));
    let (e1, e2) = (pa - po, pb - po);
    let scale = e1.length() + e2.length();
    let n = e1.cross(e2);
    if !(scale > 0.0 && n.length_squared() > 0.0) || (pa + pb - po - pf).length() > 1e-5 * scale {
        return None;
    }
    // Same winding as t1, so the front side stays the front side.
    let n1 = (pos(i1) - pos(i0)).cross(pos(i2) - pos(i0));
    if n.dot(n1) <= 0.0 {
        return None;
    }
    let (uo, ua, ub, uf) = (tex(o), tex(a), tex(b), tex(far));
    let uv_scale = (ua - uo).length() + (ub - uo).length();
    if (ua + ub - uo - uf).length() > 1e-5 * uv_scale + 1e-7 {
        return None;
    }
    Some([o, a, b])
}

/// Nearest `t ∈ (0, tmax)` where the ray meets the sphere, or `∞`.
#[inline]
fn intersect_sphere(s: &SphereGeom, o: Vec3, d: Vec3, tmax: f32) -> f32 {
    let oc = o - s.center;
    let b = oc.dot(d);
    // Distance² from the centre to the line, computed stably (Hearn & Baker / Ray Tracing Gems).
    let perp = oc - d * b;
    let disc = s.radius * s.radius - perp.length_squared();
    if disc < 0.0 {
        return f32::INFINITY;
    }
    let c = oc.length_squared() - s.radius * s.radius;
    let q = -b - disc.sqrt().copysign(b);
    let (t0, t1) = if q != 0.0 { (c / q, q) } else { (0.0, 0.0) };
    let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    if t0 > 0.0 && t0 < tmax {
        t0
    } else if t1 > 0.0 && t1 < tmax {
        t1
    } else {
        f32::INFINITY
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

/// One bottom-level structure: a BVH over primitives stored in its leaf order (see the
/// module docs), for the world-space meshes or for one prototype in its object space.
#[derive(Clone, Debug, Default)]
struct Blas {
    /// The BVH over `tris`; `None` for an empty BLAS and for one of at most
    /// [`SMALL_BLAS`] primitives, whose primitives are tested directly.
    bvh: Option<CwBvh>,
    tris: Vec<Tri>,
    prims: Vec<PrimInfo>,
    /// Per primitive (BVH order) an index into `normals`, or [`NO_NORMALS`] for a flat
    /// one. Empty when no primitive of this BLAS has vertex normals: such a BLAS (cards,
    /// normal-less meshes) stores nothing extra.
    nidx: Vec<u32>,
    /// Vertex normals at `v0`, `v1`, `v2` of the smooth primitives (BLAS space, as the mesh
    /// gives them).
    normals: Vec<[Vec3; 3]>,
    /// Vertex tangents (`w` = handedness, see [`Mesh::tangents`]) parallel to `normals`, or
    /// empty when no smooth primitive of this BLAS came with tangents; an all-zero entry
    /// means "none" (the tangent then comes from the UVs).
    tangents: Vec<[Vec4; 3]>,
    /// Bounds of all primitives (in the BLAS's own space).
    bounds: Option<Aabb>,
}

/// A BLAS of at most this many primitives (a leaf card: one parallelogram) has no BVH:
/// a ray tests its primitives one after the other, which costs less than setting up a
/// traversal and testing a root node (measured with `LAMINA_INSTANCES=1` in
/// benches/rays.rs).
const SMALL_BLAS: usize = 4;

/// "Flat primitive" in `Blas::nidx`.
const NO_NORMALS: u32 = u32::MAX;

/// Vertex normals that differ from the geometric normal by less than this (cosine) count as
/// the geometric normal (< 0.08°): the triangle is stored flat, exactly as without normals.
const FLAT_NORMAL_COS: f32 = 1.0 - 1e-6;

/// The vertex normals `vn` of the triangle `v` if they make it smooth: `None` when every
/// one points (within [`FLAT_NORMAL_COS`]) along the geometric normal, or all along its
/// opposite (flipped to the geometric side when shading, the same thing). They are kept as
/// given, not renormalised (like pbrt: interpolating, then transforming an instance's
/// normal is the same as interpolating the transformed normals of the flattened mesh);
/// where zero or non-finite ones make the interpolated normal degenerate, the hit falls
/// back to the geometric normal.
fn smooth_normals(v: [Vec3; 3], vn: [Vec3; 3]) -> Option<[Vec3; 3]> {
    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
    let unit = vn.map(Vec3::normalize_or_zero);
    let flat = unit.iter().all(|m| m.dot(n) >= FLAT_NORMAL_COS)
        || unit.iter().all(|m| m.dot(n) <= -FLAT_NORMAL_COS);
    (!flat).then_some(vn)
}

/// Collects primitives for a [`Blas`].
#[derive(Default)]
struct BlasBuilder {
    tris: Vec<Triangle>,
    bounds: Vec<Aabb>,
    prims: Vec<PrimInfo>,
    /// Per pushed primitive: its index into `normals` or [`NO_NORMALS`]; left empty while
    /// every primitive is flat.
    nidx: Vec<u32>,
    normals: Vec<[Vec3; 3]>,
    tangents: Vec<[Vec4; 3]>,
}

impl BlasBuilder {
    /// Adds a triangle, or with [`FLAG_QUAD`] the parallelogram `v[0] + b1·e1 + b2·e2`;
    /// `uv` at `v`, `vn` the vertex normals of a smooth triangle (from [`smooth_normals`];
    /// never for a parallelogram) and `vt` its vertex tangents, if the mesh has them.
    /// Non-finite or degenerate ones are left out.
    fn push(
        &mut self,
        v: [Vec3; 3],
        uv: [Vec2; 3],
        vn: Option<[Vec3; 3]>,
        vt: Option<[Vec4; 3]>,
        mut flags: u32,
    ) {
        if !v.iter().all(|p| p.is_finite()) {
            return;
        }
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let n = e1.cross(e2).normalize_or_zero();
        if n == Vec3::ZERO {
            return;
        }
        let (du1, du2, dv1, dv2) = (
            uv[1].x - uv[0].x,
            uv[2].x - uv[0].x,
            uv[1].y - uv[0].y,
            uv[2].y - uv[0].y,
        );
        let det = du1 * dv2 - du2 * dv1;
        let dpdu = if det.abs() > 1e-20 {
            (e1 * dv2 - e2 * dv1) / det
        } else {
            e1
        };
        let frame = Frame::from_normal_tangent(n, if dpdu.is_finite() { dpdu } else { e1 });
        if det.abs() > 1e-20 {
            let dpdv = (e2 * du1 - e1 * du2) / det;
            if n.cross(frame.s).dot(dpdv) < 0.0 {
                flags |= FLAG_UV_MIRRORED;
            }
        }
        let mut bb = Aabb::from_points(&[v[0].into(), v[1].into(), v[2].into()]);
        if flags & FLAG_QUAD != 0 {
            bb.extend((v[1] + v[2] - v[0]).into());
        }
        self.bounds.push(bb);
        self.tris.push(Triangle {
            v0: v[0].into(),
            v1: v[1].into(),
            v2: v[2].into(),
        });
        self.prims.push(PrimInfo {
            uv,
            n,
            s: frame.s,
            flags,
        });
        debug_assert!(vn.is_none() || flags & FLAG_QUAD == 0);
        match vn {
            Some(vn) => {
                // The first smooth primitive: every earlier one was flat.
                self.nidx.resize(self.prims.len() - 1, NO_NORMALS);
                self.nidx.push(self.normals.len() as u32);
                self.normals.push(vn);
                if let Some(vt) = vt {
                    self.tangents
                        .resize(self.normals.len() - 1, [Vec4::ZERO; 3]);
                    self.tangents.push(vt);
                } else if !self.tangents.is_empty() {
                    self.tangents.push([Vec4::ZERO; 3]);
                }
            }
            None if !self.nidx.is_empty() => self.nidx.push(NO_NORMALS),
            None => {}
        }
    }

    /// Adds every triangle of `meshes` (cards merged into parallelograms when
    /// `merge_cards`). `what` names the meshes in errors.
    fn push_meshes(
        &mut self,
        meshes: &[Mesh],
        alpha: &[AlphaTest],
        merge_cards: bool,
        what: &dyn Fn(usize) -> String,
    ) -> Result<(), RenderError> {
        for (mi, mesh) in meshes.iter().enumerate() {
            let mat = mesh.material as usize;
            if mat >= alpha.len() || mat > ID_MASK as usize {
                return Err(RenderError::InvalidScene(format!(
                    "{} uses material {mat}, but there are {} materials",
                    what(mi),
                    alpha.len()
                )));
            }
            let mut flags = mat as u32;
            if !matches!(alpha[mat], AlphaTest::None) {
                flags |= FLAG_ALPHA;
            }
            let has_uv = !mesh.uvs.is_empty();
            let has_normals = !mesh.normals.is_empty();
            let has_tangents = has_normals && mesh.tangents.len() == mesh.positions.len();
            for (ti, idx) in mesh.indices.iter().enumerate() {
                let ok = idx.iter().all(|&i| {
                    (i as usize) < mesh.positions.len()
                        && (!has_uv || (i as usize) < mesh.uvs.len())
                        && (!has_normals || (i as usize) < mesh.normals.len())
                });
                if !ok {
                    return Err(RenderError::InvalidScene(format!(
                        "{}, triangle {ti}: vertex index out of range",
                        what(mi)
                    )));
                }
            }
            let pos = |i: u32| mesh.positions[i as usize];
            let tex = |i: u32| {
                if has_uv {
                    mesh.uvs[i as usize]
                } else {
                    Vec2::ZERO
                }
            };
            // Vertex normals that make a triangle smooth (none for a mesh without normals).
            let smooth = |idx: [u32; 3]| {
                if has_normals {
                    smooth_normals(idx.map(pos), idx.map(|i| mesh.normals[i as usize]))
                } else {
                    None
                }
            };
            let mut ti = 0;
            while ti < mesh.indices.len() {
                let idx = mesh.indices[ti];
                let vn = smooth(idx);
                // A card: this triangle and the next one, both flat, form a planar
                // parallelogram with affine UVs; one parallelogram primitive (which has no
                // vertex normals) replaces the two triangles.
                let card = mesh
                    .indices
                    .get(ti + 1)
                    .filter(|next| merge_cards && vn.is_none() && smooth(**next).is_none())
                    .and_then(|next| parallelogram(idx, *next, &pos, &tex));
                if let Some([o, a, b]) = card {
                    self.push(
                        [pos(o), pos(a), pos(b)],
                        [tex(o), tex(a), tex(b)],
                        None,
                        None,
                        flags | FLAG_QUAD,
                    );
                    ti += 2;
                    continue;
                }
                let vt = has_tangents.then(|| idx.map(|i| mesh.tangents[i as usize]));
                self.push(idx.map(pos), idx.map(tex), vn, vt, flags);
                ti += 1;
            }
        }
        Ok(())
    }

    fn finish(self) -> Blas {
        if self.tris.is_empty() {
            return Blas::default();
        }
        let bounds = self.bounds.iter().fold(Aabb::empty(), |a, b| a.union(b));
        if self.tris.len() <= SMALL_BLAS {
            // Tested directly, in the order pushed: no BVH (see `Blas::bvh`).
            let tris = self
                .tris
                .iter()
                .zip(&self.prims)
                .map(|(tr, info)| Tri::new(tr, info))
                .collect();
            return Blas {
                bvh: None,
                tris,
                prims: self.prims,
                nidx: self.nidx,
                normals: self.normals,
                tangents: self.tangents,
                bounds: Some(bounds),
            };
        }
        // Small leaves (2 primitives): with alpha-tested cards every primitive in a leaf
        // costs an intersection plus a matte lookup, so a deeper tree pays off (measured
        // with benches/rays.rs: random rays +15 % per CPU-second).
        let mut bvh = build_cwbvh(
            &self.bounds,
            BvhBuildParams {
                max_prims_per_leaf: 2,
                collapse_traversal_cost: 1.0,
                ..BvhBuildParams::slow_build()
            },
            &mut Default::default(),
        );
        // Lay the triangles out in BVH leaf order so the traversal indexes them directly.
        let order = std::mem::take(&mut bvh.primitive_indices);
        let tris: Vec<Tri> = order
            .iter()
            .map(|&i| Tri::new(&self.tris[i as usize], &self.prims[i as usize]))
            .collect();
        let prims: Vec<PrimInfo> = order.iter().map(|&i| self.prims[i as usize]).collect();
        let nidx: Vec<u32> = if self.nidx.is_empty() {
            Vec::new()
        } else {
            order.iter().map(|&i| self.nidx[i as usize]).collect()
        };
        Blas {
            bvh: Some(bvh),
            tris,
            prims,
            nidx,
            normals: self.normals,
            tangents: self.tangents,
            bounds: Some(bounds),
        }
    }
}

impl Blas {
    fn bytes(&self) -> usize {
        self.bvh.as_ref().map_or(0, bvh_bytes)
            + self.tris.len() * std::mem::size_of::<Tri>()
            + self.prims.len() * std::mem::size_of::<PrimInfo>()
            + self.nidx.len() * 4
            + self.normals.len() * std::mem::size_of::<[Vec3; 3]>()
            + self.tangents.len() * std::mem::size_of::<[Vec4; 3]>()
    }
}

/// Heap bytes of a BVH's nodes and index arrays.
fn bvh_bytes(bvh: &CwBvh) -> usize {
    bvh.nodes.len() * std::mem::size_of::<CwBvhNode>()
        + bvh.primitive_indices.len() * 4
        + bvh.exact_node_aabbs.as_ref().map_or(0, |a| a.len()) * std::mem::size_of::<Aabb>()
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;
    use lamina_leaf::{Texture, Wrap};

    #[test]
    fn cards_become_parallelograms() {
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(1.5, 2.0, 0.0), // makes a trapezoid with 0, 1, 2
        ];
        let uv = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y, Vec2::ONE];
        let pos = |i: u32| p[i as usize];
        let tex = |i: u32| uv[i as usize];
        // Diagonal 0-2, both rotations of the second triangle.
        assert_eq!(
            parallelogram([0, 1, 2], [0, 2, 3], &pos, &tex),
            Some([0, 1, 3])
        );
        assert_eq!(
            parallelogram([0, 1, 2], [2, 3, 0], &pos, &tex),
            Some([0, 1, 3])
        );
        // Diagonal 1-3.
        assert_eq!(
            parallelogram([0, 1, 3], [1, 2, 3], &pos, &tex),
            Some([0, 1, 3])
        );
        // Not a parallelogram, opposite winding, unrelated triangles.
        assert_eq!(parallelogram([0, 1, 4], [0, 4, 3], &pos, &tex), None);
        assert_eq!(parallelogram([0, 1, 2], [0, 3, 2], &pos, &tex), None);
        assert_eq!(parallelogram([0, 1, 2], [1, 2, 4], &pos, &tex), None);
        // Non-affine texture coordinates.
        let bent = |i: u32| {
            if i == 3 {
                Vec2::new(0.2, 1.0)
            } else {
                uv[i as usize]
            }
        };
        assert_eq!(parallelogram([0, 1, 2], [0, 2, 3], &pos, &bent), None);
    }

    /// The cell table agrees with the filtered lookup everywhere, for both wrap modes,
    /// both channels, inside and outside `[0, 1]`.
    #[test]
    fn mask_cells_agree_with_filtered_lookup() {
        let (w, h) = (7u32, 5u32);
        let texels: Vec<Vec4> = (0..w * h)
            .map(|i| {
                let v = ((i * 37 + 11) % 10) as f32 / 9.0;
                Vec4::new(v, 0.0, 0.0, 1.0 - v)
            })
            .collect();
        for wrap in [Wrap::Repeat, Wrap::Clamp] {
            for use_alpha_channel in [false, true] {
                let mask = AlphaMask {
                    map: Texture::from_texels(w, h, texels.clone(), wrap),
                    use_alpha_channel,
                    cutoff: 0.5,
                };
                let cells = MaskCells::new(&mask).unwrap();
                let test = AlphaTest::Mask(mask.clone(), Some(cells));
                let mut decided = 0;
                for i in 0..4000 {
                    let uv = Vec2::new(
                        i as f32 / 4000.0 * 1.6 - 0.3,
                        ((i * 7919) % 4000) as f32 / 4000.0 * 1.6 - 0.3,
                    );
                    assert_eq!(test.opaque(uv), mask.opaque(uv), "{wrap:?} {uv}");
                    if let AlphaTest::Mask(_, Some(c)) = &test {
                        decided += (c.classify(uv) != CELL_MIXED) as u32;
                    }
                }
                assert!(decided > 0);
            }
        }
    }
}
