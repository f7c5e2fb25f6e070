//! The detection of cards: two triangles of a mesh that form one planar parallelogram with
//! affine texture coordinates (a leaf card, however it was split), which lamina-accel then
//! tests as one primitive.

use glam::{Vec2, Vec3};

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
