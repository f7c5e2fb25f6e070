//! The SSE kernel: 4-wide nodes and packs in `__m128` registers. SSE2 is part of the x86-64
//! baseline, so this kernel runs on every x86-64 CPU.

use super::{LRay, Lanes, LeafHits, MIN_DIR, ROBUST};
use crate::kernel::scalar::far_index;
use crate::layout::{Node, Pack};
use crate::top::QNode;
use std::arch::x86_64::*;

pub(crate) struct Sse;

/// The ray broadcast to four lanes, with the near/far plane indices.
#[derive(Clone, Copy)]
pub(crate) struct VRay {
    pub o: [__m128; 3],
    pub d: [__m128; 3],
    pub inv: [__m128; 3],
    pub near: [usize; 3],
    /// Origin and reciprocal direction as scalars (for quantised nodes' frames).
    pub so: [f32; 3],
    pub sinv: [f32; 3],
}

/// [`inverse_dir`] of the direction in lanes 0-2 of `d`, all lanes at once (one division
/// instead of three), and the near-plane indices: bit for bit the scalar form's answer.
///
/// # Safety
/// SSE2 only (every x86-64 CPU).
#[inline(always)]
pub(crate) unsafe fn inverse_dir4(d: __m128) -> (__m128, [usize; 3]) {
    // SAFETY: SSE2 only, part of x86-64.
    unsafe {
        let sign = _mm_set1_ps(-0.0);
        let min = _mm_set1_ps(MIN_DIR);
        let small = _mm_cmplt_ps(_mm_andnot_ps(sign, d), min);
        // `MIN_DIR` with the component's sign where it is smaller, else the component.
        let safe = _mm_or_ps(
            _mm_and_ps(small, _mm_or_ps(_mm_and_ps(sign, d), min)),
            _mm_andnot_ps(small, d),
        );
        let inv = _mm_div_ps(_mm_set1_ps(1.0), safe);
        let nonneg = _mm_movemask_ps(_mm_cmpge_ps(inv, _mm_setzero_ps())) as usize;
        let n = |a: usize| if nonneg & (1 << a) != 0 { a } else { 3 + a };
        (inv, [n(0), n(1), n(2)])
    }
}

#[inline(always)]
pub(crate) unsafe fn prep4(r: &LRay) -> VRay {
    // SAFETY: SSE2 only, part of every x86-64 CPU; the store writes all of `sinv`.
    unsafe {
        // One division for the three axes (`inverse_dir4`), each lane broadcast by a
        // shuffle.
        let (inv, near) = inverse_dir4(_mm_setr_ps(r.d[0], r.d[1], r.d[2], 1.0));
        let mut sinv = [0.0f32; 4];
        _mm_storeu_ps(sinv.as_mut_ptr(), inv);
        // Written out: `[T; N]::map` was not inlined here (2 % of a render in `try_map`).
        let b = |v: [f32; 3]| [_mm_set1_ps(v[0]), _mm_set1_ps(v[1]), _mm_set1_ps(v[2])];
        VRay {
            o: b(r.o),
            d: b(r.d),
            inv: [
                _mm_shuffle_ps::<0b00_00_00_00>(inv, inv),
                _mm_shuffle_ps::<0b01_01_01_01>(inv, inv),
                _mm_shuffle_ps::<0b10_10_10_10>(inv, inv),
            ],
            near,
            so: r.o,
            sinv: [sinv[0], sinv[1], sinv[2]],
        }
    }
}

/// The 4-lane Möller-Trumbore test of `p` (same arithmetic and order as
/// `scalar::lane_test`).
///
/// # Safety
/// SSE2 only (every x86-64 CPU).
#[inline(always)]
pub(crate) unsafe fn leaf4(p: &Pack, r: &VRay, tmax: f32, skip: u32) -> LeafHits {
    // SAFETY: `Pack` is `repr(C, align(64))` and every field read here is a `[f32; 4]` or
    // `[u32; 4]` at a 16-byte aligned offset (0, 16, .., 176), so each `_mm_load_ps` /
    // `_mm_load_si128` reads 16 valid, aligned bytes of `p`; the stores write whole
    // `[f32; 4]` arrays of `h`. The instructions are SSE/SSE2, part of x86-64.
    unsafe {
        let ld = |a: &[f32; 4]| _mm_load_ps(a.as_ptr());
        let e1 = [ld(&p.e1[0]), ld(&p.e1[1]), ld(&p.e1[2])];
        let e2 = [ld(&p.e2[0]), ld(&p.e2[1]), ld(&p.e2[2])];
        let cross = |a: [__m128; 3], b: [__m128; 3]| {
            [
                _mm_sub_ps(_mm_mul_ps(a[1], b[2]), _mm_mul_ps(a[2], b[1])),
                _mm_sub_ps(_mm_mul_ps(a[2], b[0]), _mm_mul_ps(a[0], b[2])),
                _mm_sub_ps(_mm_mul_ps(a[0], b[1]), _mm_mul_ps(a[1], b[0])),
            ]
        };
        let dot = |a: [__m128; 3], b: [__m128; 3]| {
            _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(a[0], b[0]), _mm_mul_ps(a[1], b[1])),
                _mm_mul_ps(a[2], b[2]),
            )
        };
        let pv = cross(r.d, e2);
        let det = dot(e1, pv);
        let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
        let tv = [
            _mm_sub_ps(r.o[0], ld(&p.v0[0])),
            _mm_sub_ps(r.o[1], ld(&p.v0[1])),
            _mm_sub_ps(r.o[2], ld(&p.v0[2])),
        ];
        let b1 = _mm_mul_ps(dot(tv, pv), inv);
        let q = cross(tv, e1);
        let b2 = _mm_mul_ps(dot(r.d, q), inv);
        let t = _mm_mul_ps(dot(e2, q), inv);
        let zero = _mm_setzero_ps();
        let one = _mm_set1_ps(1.0);
        let lim = _mm_add_ps(b2, _mm_mul_ps(ld(&p.tri), b1));
        let mut ok = _mm_cmpneq_ps(det, zero);
        ok = _mm_and_ps(ok, _mm_cmpge_ps(b1, zero));
        ok = _mm_and_ps(ok, _mm_cmple_ps(b1, one));
        ok = _mm_and_ps(ok, _mm_cmpge_ps(b2, zero));
        ok = _mm_and_ps(ok, _mm_cmple_ps(lim, one));
        ok = _mm_and_ps(ok, _mm_cmpgt_ps(t, zero));
        ok = _mm_and_ps(ok, _mm_cmplt_ps(t, _mm_set1_ps(tmax)));
        let ids = _mm_load_si128(p.id.as_ptr() as *const __m128i);
        let skipped = _mm_castsi128_ps(_mm_cmpeq_epi32(ids, _mm_set1_epi32(skip as i32)));
        ok = _mm_andnot_ps(skipped, ok);
        let mut h = LeafHits {
            mask: _mm_movemask_ps(ok) as u32,
            t: [0.0; 4],
            b1: [0.0; 4],
            b2: [0.0; 4],
        };
        _mm_storeu_ps(h.t.as_mut_ptr(), t);
        _mm_storeu_ps(h.b1.as_mut_ptr(), b1);
        _mm_storeu_ps(h.b2.as_mut_ptr(), b2);
        h
    }
}

impl Lanes<4> for Sse {
    type R = VRay;

    #[inline(always)]
    unsafe fn prep(r: &LRay) -> VRay {
        // SAFETY: SSE only (see `prep4`).
        unsafe { prep4(r) }
    }

    #[inline(always)]
    unsafe fn node(n: &Node<4>, r: &VRay, tmax: f32) -> (u32, [f32; 4]) {
        // SAFETY: `n.b[k]` is a `[f32; 4]` inside `n` (k < 6: `near` is 0..=5 by
        // construction in `inverse_dir`), so each unaligned load reads 16 valid bytes; the
        // store writes the whole `tn`. SSE only.
        unsafe {
            let slab = |a: usize| {
                let lo = _mm_loadu_ps(n.b[r.near[a]].as_ptr());
                let hi = _mm_loadu_ps(n.b[far_index(r.near[a])].as_ptr());
                let o = r.o[a];
                (
                    _mm_mul_ps(_mm_sub_ps(lo, o), r.inv[a]),
                    _mm_mul_ps(_mm_sub_ps(hi, o), r.inv[a]),
                )
            };
            let (x0, x1) = slab(0);
            let (y0, y1) = slab(1);
            let (z0, z1) = slab(2);
            let near = _mm_max_ps(_mm_max_ps(x0, y0), _mm_max_ps(z0, _mm_setzero_ps()));
            let far = _mm_min_ps(_mm_min_ps(x1, y1), _mm_min_ps(z1, _mm_set1_ps(tmax)));
            let hit = _mm_cmple_ps(near, _mm_mul_ps(far, _mm_set1_ps(ROBUST)));
            let mut tn = [0.0f32; 4];
            _mm_storeu_ps(tn.as_mut_ptr(), near);
            (_mm_movemask_ps(hit) as u32, tn)
        }
    }

    #[inline(always)]
    unsafe fn leaf(p: &Pack, r: &VRay, tmax: f32, skip: u32) -> LeafHits {
        // SAFETY: SSE2 only (see `leaf4`).
        unsafe { leaf4(p, r, tmax, skip) }
    }

    #[inline(always)]
    unsafe fn qnode(n: &QNode, r: &VRay, tmax: f32) -> (u32, [f32; 8]) {
        let (a, b) = super::qframe(n, r.so, r.sinv);
        // SAFETY: each 4-byte read is inside `n.q[k]` (an `[u8; 8]`, halves at 0 and 4,
        // read unaligned); the stores write whole `[f32; 4]` halves of `tn`. SSE2 only.
        unsafe {
            let zero = _mm_setzero_si128();
            let planes = |k: usize, half: usize| {
                let bytes = (n.q[k].as_ptr().add(4 * half) as *const i32).read_unaligned();
                let v = _mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(bytes), zero), zero);
                _mm_cvtepi32_ps(v)
            };
            let mut mask = 0u32;
            let mut tn = [0.0f32; 8];
            for half in 0..2 {
                let t = |ax: usize, k: usize| {
                    _mm_add_ps(
                        _mm_mul_ps(planes(k, half), _mm_set1_ps(a[ax])),
                        _mm_set1_ps(b[ax]),
                    )
                };
                let (x0, x1) = (t(0, r.near[0]), t(0, far_index(r.near[0])));
                let (y0, y1) = (t(1, r.near[1]), t(1, far_index(r.near[1])));
                let (z0, z1) = (t(2, r.near[2]), t(2, far_index(r.near[2])));
                let near = _mm_max_ps(_mm_max_ps(x0, y0), _mm_max_ps(z0, _mm_setzero_ps()));
                let far = _mm_min_ps(_mm_min_ps(x1, y1), _mm_min_ps(z1, _mm_set1_ps(tmax)));
                let hit = _mm_cmple_ps(near, _mm_mul_ps(far, _mm_set1_ps(ROBUST)));
                mask |= (_mm_movemask_ps(hit) as u32) << (4 * half);
                _mm_storeu_ps(tn.as_mut_ptr().add(4 * half), near);
            }
            (mask, tn)
        }
    }
}
