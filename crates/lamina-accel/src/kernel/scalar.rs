//! The portable kernel: 4-wide nodes and packs in plain loops.

use super::{LRay, Lanes, LeafHits, ROBUST, inverse_dir};
use crate::layout::{Node, Pack};
use crate::top::QNode;

pub(crate) struct Scalar;

#[derive(Clone, Copy)]
pub(crate) struct SRay {
    o: [f32; 3],
    d: [f32; 3],
    inv: [f32; 3],
    near: [usize; 3],
}

/// The Möller-Trumbore test of lane `i` of `p` (the arithmetic every kernel repeats):
/// `(hit, t, b1, b2)`.
#[inline(always)]
pub(crate) fn lane_test(
    p: &Pack,
    i: usize,
    o: [f32; 3],
    d: [f32; 3],
    tmax: f32,
) -> (bool, f32, f32, f32) {
    let (e1, e2) = (
        [p.e1[0][i], p.e1[1][i], p.e1[2][i]],
        [p.e2[0][i], p.e2[1][i], p.e2[2][i]],
    );
    let cross = |a: [f32; 3], b: [f32; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    let inv = 1.0 / det;
    let tv = [o[0] - p.v0[0][i], o[1] - p.v0[1][i], o[2] - p.v0[2][i]];
    let b1 = dot(tv, pv) * inv;
    let q = cross(tv, e1);
    let b2 = dot(d, q) * inv;
    let t = dot(e2, q) * inv;
    let hit = det != 0.0
        && b1 >= 0.0
        && b1 <= 1.0
        && b2 >= 0.0
        && b2 + p.tri[i] * b1 <= 1.0
        && t > 0.0
        && t < tmax;
    (hit, t, b1, b2)
}

impl<const W: usize> Lanes<W> for Scalar {
    type R = SRay;

    #[inline(always)]
    unsafe fn prep(r: &LRay) -> SRay {
        let (inv, near) = inverse_dir(r.d);
        SRay {
            o: r.o,
            d: r.d,
            inv,
            near,
        }
    }

    #[inline(always)]
    unsafe fn node(n: &Node<W>, r: &SRay, tmax: f32) -> (u32, [f32; W]) {
        let mut mask = 0;
        let mut tn = [0.0; W];
        for i in 0..W {
            let mut near = 0.0f32;
            let mut far = tmax;
            for a in 0..3 {
                let lo = (n.b[r.near[a]][i] - r.o[a]) * r.inv[a];
                let hi = (n.b[far_index(r.near[a])][i] - r.o[a]) * r.inv[a];
                near = near.max(lo);
                far = far.min(hi);
            }
            tn[i] = near;
            if near <= far * ROBUST {
                mask |= 1 << i;
            }
        }
        (mask, tn)
    }

    #[inline(always)]
    unsafe fn qnode(n: &QNode, r: &SRay, tmax: f32) -> (u32, [f32; 8]) {
        qnode_scalar(n, r.o, r.inv, r.near, tmax)
    }

    #[inline(always)]
    unsafe fn leaf(p: &Pack, r: &SRay, tmax: f32, skip: u32) -> LeafHits {
        let mut h = LeafHits {
            mask: 0,
            t: [0.0; 4],
            b1: [0.0; 4],
            b2: [0.0; 4],
        };
        for i in 0..4 {
            let (hit, t, b1, b2) = lane_test(p, i, r.o, r.d, tmax);
            h.t[i] = t;
            h.b1[i] = b1;
            h.b2[i] = b2;
            if hit && p.id[i] != skip {
                h.mask |= 1 << i;
            }
        }
        h
    }
}

/// The scalar quantised-node test (every kernel could use it; the scalar kernel does).
#[inline(always)]
pub(crate) fn qnode_scalar(
    n: &QNode,
    o: [f32; 3],
    inv: [f32; 3],
    near_idx: [usize; 3],
    tmax: f32,
) -> (u32, [f32; 8]) {
    let (a, b) = super::qframe(n, o, inv);
    let mut mask = 0;
    let mut tn = [0.0; 8];
    for i in 0..8 {
        let mut near = 0.0f32;
        let mut far = tmax;
        for ax in 0..3 {
            near = near.max(n.q[near_idx[ax]][i] as f32 * a[ax] + b[ax]);
            far = far.min(n.q[far_index(near_idx[ax])][i] as f32 * a[ax] + b[ax]);
        }
        tn[i] = near;
        if near <= far * ROBUST {
            mask |= 1 << i;
        }
    }
    (mask, tn)
}

/// The far-plane index for near-plane index `near` (`axis` ↔ `3 + axis`).
#[inline(always)]
pub(crate) fn far_index(near: usize) -> usize {
    if near >= 3 { near - 3 } else { near + 3 }
}
