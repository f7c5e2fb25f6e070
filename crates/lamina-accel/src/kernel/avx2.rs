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
/// plane, exit the smallest far plane. `far` and `tmax_far` come already widened by
/// [`ROBUST`] (folded into the far planes' FMAs, so that no multiply of its own sits on the
/// walk's critical path).
///
/// Integer max, min and compare (one cycle each, against four for their float forms on
/// Intel cores): for floats of which one is `>= 0` the integer order of the bits is the
/// float order, and the entry maximum includes 0; an exit below 0 (whatever the integer
/// order among negatives) is below every entry, as it is in floats.
///
/// # Safety
/// AVX2 (part of the AVX2 kernel's instruction set).
#[inline(always)]
unsafe fn slab_hits(near: [__m256; 3], far: [__m256; 3], tmax_far: f32) -> (u32, [f32; 8]) {
    // SAFETY: the caller guarantees AVX2; the store writes all of `tn`.
    unsafe {
        let i = |v: __m256| _mm256_castps_si256(v);
        let n = _mm256_max_epi32(
            _mm256_max_epi32(i(near[0]), i(near[1])),
            _mm256_max_epi32(i(near[2]), _mm256_setzero_si256()),
        );
        let f = _mm256_min_epi32(
            _mm256_min_epi32(i(far[0]), i(far[1])),
            _mm256_min_epi32(i(far[2]), _mm256_set1_epi32(tmax_far.to_bits() as i32)),
        );
        let miss = _mm256_cmpgt_epi32(n, f);
        let mut tn = [0.0f32; 8];
        _mm256_storeu_ps(tn.as_mut_ptr(), _mm256_castsi256_ps(n));
        (
            !(_mm256_movemask_ps(_mm256_castsi256_ps(miss)) as u32) & 0xff,
            tn,
        )
    }
}

/// The ray for 8-wide node tests and 4-wide leaf tests.
#[derive(Clone, Copy)]
pub(crate) struct WRay {
    /// `origin · inv` per axis (the FMA form `b·inv - o·inv`).
    oinv: [__m256; 3],
    inv: [__m256; 3],
    /// `oinv` and `inv` scaled by [`ROBUST`], for the far planes: the exit distance comes
    /// out widened without a multiply of its own on the node test's critical path.
    oinv_far: [__m256; 3],
    inv_far: [__m256; 3],
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
                oinv_far: [
                    _mm256_set1_ps(r.o[0] * inv[0] * ROBUST),
                    _mm256_set1_ps(r.o[1] * inv[1] * ROBUST),
                    _mm256_set1_ps(r.o[2] * inv[2] * ROBUST),
                ],
                inv_far: [
                    _mm256_set1_ps(inv[0] * ROBUST),
                    _mm256_set1_ps(inv[1] * ROBUST),
                    _mm256_set1_ps(inv[2] * ROBUST),
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
                    _mm256_fmsub_ps(hi, r.inv_far[a], r.oinv_far[a]),
                )
            };
            let (x0, x1) = slab(0);
            let (y0, y1) = slab(1);
            let (z0, z1) = slab(2);
            slab_hits([x0, y0, z0], [x1, y1, z1], tmax * ROBUST)
        }
    }

    #[inline(always)]
    unsafe fn qnode(n: &QNode, r: &WRay, tmax: f32) -> (u32, [f32; 8]) {
        let (a, b) = super::qframe(n, r.four.so, r.four.sinv);
        // SAFETY: each 8-byte load reads all of `n.q[k]` (an `[u8; 8]`, unaligned load);
        // the store writes all of `tn`. AVX2 + FMA are guaranteed by the caller.
        unsafe {
            let t = |ax: usize, k: usize, scale: f32| {
                let q = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(
                    n.q[k].as_ptr() as *const __m128i
                )));
                _mm256_fmadd_ps(
                    q,
                    _mm256_set1_ps(a[ax] * scale),
                    _mm256_set1_ps(b[ax] * scale),
                )
            };
            let (x0, x1) = (t(0, r.near[0], 1.0), t(0, far_index(r.near[0]), ROBUST));
            let (y0, y1) = (t(1, r.near[1], 1.0), t(1, far_index(r.near[1]), ROBUST));
            let (z0, z1) = (t(2, r.near[2], 1.0), t(2, far_index(r.near[2]), ROBUST));
            slab_hits([x0, y0, z0], [x1, y1, z1], tmax * ROBUST)
        }
    }

    #[inline(always)]
    unsafe fn leaf(p: &Pack, r: &WRay, tmax: f32, skip: u32) -> LeafHits {
        // SAFETY: SSE2 only (see `leaf4`), a subset of AVX2.
        unsafe { leaf4(p, &r.four, tmax, skip) }
    }
}

/// Eight rays broadcast across lanes (lane `k` = ray `k`), for [`leaf_rays`].
#[derive(Clone, Copy)]
pub(crate) struct Rays8 {
    pub o: [__m256; 3],
    pub d: [__m256; 3],
}

impl Rays8 {
    /// The rays `o[k] + t·d[k]` in lanes `k` (lanes past `o.len()` repeat ray 0).
    ///
    /// # Safety
    /// AVX must be available.
    #[inline(always)]
    pub(crate) unsafe fn new(o: &[[f32; 3]], d: &[[f32; 3]]) -> Rays8 {
        // Per axis, the rays' coordinates side by side (lanes past the rays repeat ray 0).
        let mut soa = [
            [o[0][0]; 8],
            [o[0][1]; 8],
            [o[0][2]; 8],
            [d[0][0]; 8],
            [d[0][1]; 8],
            [d[0][2]; 8],
        ];
        for (k, (o, d)) in o.iter().zip(d).enumerate().take(8) {
            for a in 0..3 {
                soa[a][k] = o[a];
                soa[3 + a][k] = d[a];
            }
        }
        // SAFETY: each load reads a whole `[f32; 8]` row of `soa`; AVX is available
        // (caller).
        unsafe {
            Rays8 {
                o: [
                    _mm256_loadu_ps(soa[0].as_ptr()),
                    _mm256_loadu_ps(soa[1].as_ptr()),
                    _mm256_loadu_ps(soa[2].as_ptr()),
                ],
                d: [
                    _mm256_loadu_ps(soa[3].as_ptr()),
                    _mm256_loadu_ps(soa[4].as_ptr()),
                    _mm256_loadu_ps(soa[5].as_ptr()),
                ],
            }
        }
    }
}

/// The primitives of a pack against eight rays: per primitive `j`, `mask[j]` bit `k` when
/// ray `k` hits it within `(0, tmax[k])` (primitive id `skip` never), with lane `k` of
/// `t[j]`, `b1[j]`, `b2[j]` (vectors, so that they stay in registers rather than go
/// through memory; [`RayHits::lanes`] spells them out where single lanes are read).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayHits {
    pub mask: [u32; 4],
    pub t: [__m256; 4],
    pub b1: [__m256; 4],
    pub b2: [__m256; 4],
}

/// [`RayHits`] with its vectors stored as arrays: `t[j][k]`, `b1[j][k]`, `b2[j][k]`.
pub(crate) struct RayHitLanes {
    pub t: [[f32; 8]; 4],
    pub b1: [[f32; 8]; 4],
    pub b2: [[f32; 8]; 4],
}

impl RayHits {
    /// The vectors as arrays, for reading ray by ray.
    ///
    /// # Safety
    /// AVX must be available.
    #[inline(always)]
    pub(crate) unsafe fn lanes(&self) -> RayHitLanes {
        let mut l = RayHitLanes {
            t: [[0.0; 8]; 4],
            b1: [[0.0; 8]; 4],
            b2: [[0.0; 8]; 4],
        };
        // SAFETY: AVX is available (caller); each store writes a whole `[f32; 8]` row.
        unsafe {
            for j in 0..4 {
                _mm256_storeu_ps(l.t[j].as_mut_ptr(), self.t[j]);
                _mm256_storeu_ps(l.b1[j].as_mut_ptr(), self.b1[j]);
                _mm256_storeu_ps(l.b2[j].as_mut_ptr(), self.b2[j]);
            }
        }
        l
    }
}

// Macros, not closures: a closure is a function of its own, compiled without the AVX2
// target feature of the function it is written in, and when not inlined its intrinsics
// became calls (a tenth of a render).
macro_rules! cross8 {
    ($a:expr, $b:expr) => {{
        let (a, b) = ($a, $b);
        [
            _mm256_sub_ps(_mm256_mul_ps(a[1], b[2]), _mm256_mul_ps(a[2], b[1])),
            _mm256_sub_ps(_mm256_mul_ps(a[2], b[0]), _mm256_mul_ps(a[0], b[2])),
            _mm256_sub_ps(_mm256_mul_ps(a[0], b[1]), _mm256_mul_ps(a[1], b[0])),
        ]
    }};
}
macro_rules! dot8 {
    ($a:expr, $b:expr) => {{
        let (a, b) = ($a, $b);
        _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])),
            _mm256_mul_ps(a[2], b[2]),
        )
    }};
}
macro_rules! splat3 {
    ($v:expr, $j:expr) => {
        [
            _mm256_set1_ps($v[0][$j]),
            _mm256_set1_ps($v[1][$j]),
            _mm256_set1_ps($v[2][$j]),
        ]
    };
}

/// [`leaf4`] turned around: each primitive of `p` against eight rays at once, lanes being
/// rays. The arithmetic is `leaf4`'s, operation by operation and in the same order (no
/// FMA), so every ray's `t`, `b1`, `b2` and hit decision are bit for bit those `leaf4`
/// gives that ray.
///
/// # Safety
/// AVX2 must be available.
#[inline(always)]
pub(crate) unsafe fn leaf_rays(p: &Pack, r: &Rays8, tmax: __m256, skip: u32) -> RayHits {
    // SAFETY: AVX is available (caller).
    unsafe {
        let zero = _mm256_setzero_ps();
        let mut h = RayHits {
            mask: [0; 4],
            t: [zero; 4],
            b1: [zero; 4],
            b2: [zero; 4],
        };
        let one = _mm256_set1_ps(1.0);
        for j in 0..4 {
            if p.id[j] == skip {
                continue; // leaf4 drops it after the test: never a hit
            }
            let (v0, e1, e2) = (splat3!(p.v0, j), splat3!(p.e1, j), splat3!(p.e2, j));
            let pv = cross8!(r.d, e2);
            let det = dot8!(e1, pv);
            let inv = _mm256_div_ps(one, det);
            let tv = [
                _mm256_sub_ps(r.o[0], v0[0]),
                _mm256_sub_ps(r.o[1], v0[1]),
                _mm256_sub_ps(r.o[2], v0[2]),
            ];
            let b1 = _mm256_mul_ps(dot8!(tv, pv), inv);
            let q = cross8!(tv, e1);
            let b2 = _mm256_mul_ps(dot8!(r.d, q), inv);
            let t = _mm256_mul_ps(dot8!(e2, q), inv);
            let lim = _mm256_add_ps(b2, _mm256_mul_ps(_mm256_set1_ps(p.tri[j]), b1));
            let mut ok = _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero);
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(b1, zero));
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(b1, one));
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(b2, zero));
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(lim, one));
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero));
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LT_OQ>(t, tmax));
            h.mask[j] = _mm256_movemask_ps(ok) as u32;
            (h.t[j], h.b1[j], h.b2[j]) = (t, b1, b2);
        }
        h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The float slab test `slab_hits` stands for: entry the largest of the near distances
    /// and 0, exit the smallest of the far distances and `tmax_far`, a hit when entry <=
    /// exit.
    fn reference(near: [[f32; 8]; 3], far: [[f32; 8]; 3], tmax_far: f32) -> (u32, [f32; 8]) {
        let mut mask = 0;
        let mut tn = [0.0; 8];
        for k in 0..8 {
            let n = near[0][k].max(near[1][k]).max(near[2][k]).max(0.0);
            let f = far[0][k].min(far[1][k]).min(far[2][k]).min(tmax_far);
            tn[k] = n;
            if n <= f {
                mask |= 1 << k;
            }
        }
        (mask, tn)
    }

    #[test]
    fn integer_slab_test_is_the_float_one() {
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            return;
        }
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        // Distances as slab tests give them: either sign, zeros of both signs, tiny and
        // huge ones, infinities, and ties between entry and exit.
        let special = [
            0.0,
            -0.0,
            1e-30,
            -1e-30,
            f32::MIN_POSITIVE,
            1e30,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        let draw = |r: u64, shared: f32| -> f32 {
            match r % 8 {
                0 => special[(r >> 8) as usize % special.len()],
                1 => shared,
                _ => ((r >> 16) as u32 as f32 / u32::MAX as f32 - 0.3) * 10.0,
            }
        };
        for _ in 0..20_000 {
            let shared = draw(next(), 1.0);
            let mut near = [[0.0f32; 8]; 3];
            let mut far = [[0.0f32; 8]; 3];
            for a in 0..3 {
                for k in 0..8 {
                    near[a][k] = draw(next(), shared);
                    far[a][k] = draw(next(), shared);
                }
            }
            let tmax_far = if next() % 3 == 0 {
                f32::INFINITY
            } else {
                draw(next(), shared).abs()
            };
            // SAFETY: AVX2 and FMA are present (checked above); each load reads a whole
            // `[f32; 8]`.
            let (mask, tn) = unsafe {
                let v = |x: &[f32; 8]| _mm256_loadu_ps(x.as_ptr());
                slab_hits(
                    [v(&near[0]), v(&near[1]), v(&near[2])],
                    [v(&far[0]), v(&far[1]), v(&far[2])],
                    tmax_far,
                )
            };
            let (want_mask, want_tn) = reference(near, far, tmax_far);
            // A box whose exit is at t = 0 touches the ray's origin only; where that exit is
            // -0 the float test keeps it and the integer one drops it (-0 is the smallest
            // integer): nothing lies there at t > 0, so either answer is right.
            let touch = (0..8)
                .filter(|&k| far[0][k].min(far[1][k]).min(far[2][k]).min(tmax_far) == 0.0)
                .fold(0u32, |m, k| m | 1 << k);
            assert_eq!(
                mask & !touch,
                want_mask & !touch,
                "{near:?} {far:?} {tmax_far}"
            );
            for k in 0..8 {
                assert_eq!(tn[k], want_tn[k], "lane {k}");
            }
        }
    }
}
