//! The primitive records the traversal tests (one 64-byte [`Tri`] per triangle or
//! parallelogram), their intersection tests (Möller-Trumbore, spheres) and the detection of
//! cards: two triangles that form one parallelogram.

use super::FLAG_QUAD;
use super::PrimInfo;
use glam::{Vec2, Vec3, Vec3A};
use obvhs::triangle::Triangle;

/// Everything the traversal needs for one triangle, in one 64-byte cache line: the
/// Möller-Trumbore form (`v0`, `e1 = v1 - v0`, `e2 = v2 - v0`), the flags and the UVs of the
/// alpha test. Shading data stay in [`PrimInfo`], fetched only for the final hit.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Tri {
    pub(super) v0: [f32; 3],
    pub(super) e1: [f32; 3],
    pub(super) e2: [f32; 3],
    pub(super) flags: u32,
    pub(super) uv: [Vec2; 3],
}

const _: () = assert!(std::mem::size_of::<Tri>() == 64);

impl Tri {
    /// The traversal record of triangle (or parallelogram) `tr` with shading data `info`.
    pub(super) fn new(tr: &Triangle, info: &PrimInfo) -> Self {
        Tri {
            v0: tr.v0.to_array(),
            e1: (tr.v1 - tr.v0).to_array(),
            e2: (tr.v2 - tr.v0).to_array(),
            flags: info.flags,
            uv: info.uv,
        }
    }

    #[inline(always)]
    pub(super) fn uv_at(&self, b1: f32, b2: f32) -> Vec2 {
        self.uv[0] * (1.0 - b1 - b2) + self.uv[1] * b1 + self.uv[2] * b2
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) struct SphereGeom {
    pub(super) center: Vec3,
    pub(super) radius: f32,
    pub(super) light: u32,
}

/// Möller-Trumbore (for parallelograms without the `b1 + b2 <= 1` bound): `(t, b1, b2)`, `t = ∞` for a miss or `t ∉ (0, tmax)`.
#[inline(always)]
pub(super) fn intersect_tri(tri: &Tri, o: Vec3A, d: Vec3A, tmax: f32) -> (f32, f32, f32) {
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
pub(super) fn parallelogram(
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
pub(super) fn intersect_sphere(s: &SphereGeom, o: Vec3, d: Vec3, tmax: f32) -> f32 {
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
