//! The AVX2 kernel: 8-wide nodes in `__m256` registers with an FMA slab test; leaves in
//! the SSE kernel's 4-wide test (VEX-encoded inside this kernel's functions).

use super::{LRay, Lanes, LeafHits, ROBUST};
use crate::kernel::scalar::far_index;
use crate::kernel::sse::{VRay, leaf4, prep4};
use crate::layout::{Node, Pack};
use crate::top::QNode;
use std::arch::x86_64::*;

pub(crate) struct Avx2;

/// The children whose slabs overlap within `(0, tmax)`: entry distance the largest near
/// plane, exit the smallest far plane, the exit widened by [`ROBUST`].
///
/// # Safety
/// AVX (part of the AVX2 kernel's instruction set).
#[inline(always)]
unsafe fn slab_hits(near: [__m256; 3], far: [__m256; 3], tmax: f32) -> (u32, [f32; 8]) {
    // SAFETY: the caller guarantees AVX; the store writes all of `tn`.
    unsafe {
        let n = _mm256_max_ps(
            _mm256_max_ps(near[0], near[1]),
            _mm256_max_ps(near[2], _mm256_setzero_ps()),
        );
        let f = _mm256_min_ps(
            _mm256_min_ps(far[0], far[1]),
            _mm256_min_ps(far[2], _mm256_set1_ps(tmax)),
        );
        let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(n, _mm256_mul_ps(f, _mm256_set1_ps(ROBUST)));
        let mut tn = [0.0f32; 8];
        _mm256_storeu_ps(tn.as_mut_ptr(), n);
        (_mm256_movemask_ps(hit) as u32, tn)
    }
}

/// The ray for 8-wide node tests and 4-wide leaf tests.
#[derive(Clone, Copy)]
pub(crate) struct WRay {
    /// `origin · inv` per axis (the FMA form `b·inv - o·inv`).
    oinv: [__m256; 3],
    inv: [__m256; 3],
    near: [usize; 3],
    four: VRay,
}

impl Lanes<8> for Avx2 {
    type R = WRay;

    #[inline(always)]
    unsafe fn prep(r: &LRay) -> WRay {
        // SAFETY: the caller guarantees AVX2 (trait contract); `_mm256_set1_ps` is AVX.
        unsafe {
            let four = prep4(r);
            let inv = four.sinv;
            WRay {
                oinv: [
                    _mm256_set1_ps(r.o[0] * inv[0]),
                    _mm256_set1_ps(r.o[1] * inv[1]),
                    _mm256_set1_ps(r.o[2] * inv[2]),
                ],
                inv: [
                    _mm256_set1_ps(inv[0]),
                    _mm256_set1_ps(inv[1]),
                    _mm256_set1_ps(inv[2]),
                ],
                near: four.near,
                four,
            }
        }
    }

    #[inline(always)]
    unsafe fn node(n: &Node<8>, r: &WRay, tmax: f32) -> (u32, [f32; 8]) {
        // SAFETY: `n.b[k]` (k < 6, see `inverse_dir`) is a `[f32; 8]` inside `n`, so each
        // unaligned load reads 32 valid bytes; the store writes all of `tn`. AVX2 + FMA are
        // guaranteed by the caller (trait contract).
        unsafe {
            let slab = |a: usize| {
                let lo = _mm256_loadu_ps(n.b[r.near[a]].as_ptr());
                let hi = _mm256_loadu_ps(n.b[far_index(r.near[a])].as_ptr());
                (
                    _mm256_fmsub_ps(lo, r.inv[a], r.oinv[a]),
                    _mm256_fmsub_ps(hi, r.inv[a], r.oinv[a]),
                )
            };
            let (x0, x1) = slab(0);
            let (y0, y1) = slab(1);
            let (z0, z1) = slab(2);
            slab_hits([x0, y0, z0], [x1, y1, z1], tmax)
        }
    }

    #[inline(always)]
    unsafe fn qnode(n: &QNode, r: &WRay, tmax: f32) -> (u32, [f32; 8]) {
        let (a, b) = super::qframe(n, r.four.so, r.four.sinv);
        // SAFETY: each 8-byte load reads all of `n.q[k]` (an `[u8; 8]`, unaligned load);
        // the store writes all of `tn`. AVX2 + FMA are guaranteed by the caller.
        unsafe {
            let t = |ax: usize, k: usize| {
                let q = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(
                    n.q[k].as_ptr() as *const __m128i
                )));
                _mm256_fmadd_ps(q, _mm256_set1_ps(a[ax]), _mm256_set1_ps(b[ax]))
            };
            let (x0, x1) = (t(0, r.near[0]), t(0, far_index(r.near[0])));
            let (y0, y1) = (t(1, r.near[1]), t(1, far_index(r.near[1])));
            let (z0, z1) = (t(2, r.near[2]), t(2, far_index(r.near[2])));
            slab_hits([x0, y0, z0], [x1, y1, z1], tmax)
        }
    }

    #[inline(always)]
    unsafe fn leaf(p: &Pack, r: &WRay, tmax: f32, skip: u32) -> LeafHits {
        // SAFETY: SSE2 only (see `leaf4`), a subset of AVX2.
        unsafe { leaf4(p, &r.four, tmax, skip) }
    }
}
