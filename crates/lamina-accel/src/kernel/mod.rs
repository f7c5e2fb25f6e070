//! The SIMD kernels: one node test and one leaf test per instruction set, behind one
//! trait so that a single traversal ([`crate::traverse`]) serves them all.
//!
//! * `avx2`: 8-wide nodes (`__m256`, FMA slab test), the leaf test in SSE registers.
//! * `sse`: 4-wide nodes and leaves (`__m128`; SSE2 is part of x86-64, always there).
//! * `scalar`: the same 4-wide layout in plain loops, for any CPU.
//!
//! All three leaf tests compute the same arithmetic in the same order (no FMA), so they
//! return bit-identical hits; the node tests differ only in rounding, which the
//! conservative far bound ([`ROBUST`]) absorbs.

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx2;
pub(crate) mod scalar;
#[cfg(target_arch = "x86_64")]
pub(crate) mod sse;

use crate::layout::{Node, Pack};
use crate::top::QNode;

/// A ray in the space of one level: origin, direction (not renormalised) and the
/// primitive id to skip (`u32::MAX`: none).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LRay {
    pub o: [f32; 3],
    pub d: [f32; 3],
    pub skip: u32,
}

/// The far distance of a slab test is scaled by this: `1 + 2γ₃` in pbrt's error terms
/// (Ize 2013, "Robust BVH ray traversal"), so rounding never culls a box the ray touches.
pub(crate) const ROBUST: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Direction components below this magnitude are replaced by it (keeping their sign, so
/// `-0` stays on the negative side) before inverting: the slab test then never computes
/// `0·∞`.
pub(crate) const MIN_DIR: f32 = 1e-20;

/// The safe reciprocal direction and the near-plane index of each axis (`axis` for a
/// non-negative direction, `3 + axis` for a negative one; `-0` counts as negative, like its
/// reciprocal).
#[inline(always)]
pub(crate) fn inverse_dir(d: [f32; 3]) -> ([f32; 3], [usize; 3]) {
    // Written out: `[T; N]::map` is not always inlined (it showed in profiles).
    let r = |c: f32| {
        1.0 / if c.abs() < MIN_DIR {
            MIN_DIR.copysign(c)
        } else {
            c
        }
    };
    let inv = [r(d[0]), r(d[1]), r(d[2])];
    let n = |a: usize| if inv[a] >= 0.0 { a } else { 3 + a };
    let near = [n(0), n(1), n(2)];
    (inv, near)
}

/// The lanes of a leaf test that hit: `mask` bit `i` for lane `i`, with distance and the
/// barycentric coordinates of `v1` and `v2`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LeafHits {
    pub mask: u32,
    pub t: [f32; 4],
    pub b1: [f32; 4],
    pub b2: [f32; 4],
}

/// One instruction set's node and leaf tests.
///
/// # Safety
/// Every function may use instructions of the kernel's instruction set: call them only on
/// a CPU that has it ([`crate::Kernel::available`]).
pub(crate) trait Lanes<const W: usize> {
    /// The ray as the kernel keeps it (broadcast registers).
    type R: Copy;
    /// Prepares `r`.
    unsafe fn prep(r: &LRay) -> Self::R;
    /// Which children of `n` the ray enters within `(0, tmax)` (bit `i` for child `i`) and
    /// the entry distances.
    unsafe fn node(n: &Node<W>, r: &Self::R, tmax: f32) -> (u32, [f32; W]);
    /// Which primitives of `p` the ray hits within `(0, tmax)`, not counting id `skip`.
    unsafe fn leaf(p: &Pack, r: &Self::R, tmax: f32, skip: u32) -> LeafHits;
    /// [`Lanes::node`] for a quantised top-level node (8 slots for every kernel).
    unsafe fn qnode(n: &QNode, r: &Self::R, tmax: f32) -> (u32, [f32; 8]);
}

/// The slab test of a quantised node in FMA form: per axis `t = q · a + b` with
/// `a = step · inv`, `b = (origin - o) · inv`.
#[inline(always)]
pub(crate) fn qframe(n: &QNode, o: [f32; 3], inv: [f32; 3]) -> ([f32; 3], [f32; 3]) {
    let s = n.steps();
    (
        [s[0] * inv[0], s[1] * inv[1], s[2] * inv[2]],
        [
            (n.origin[0] - o[0]) * inv[0],
            (n.origin[1] - o[1]) * inv[1],
            (n.origin[2] - o[2]) * inv[2],
        ],
    )
}
