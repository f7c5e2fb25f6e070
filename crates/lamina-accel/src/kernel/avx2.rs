//! The AVX2 kernel: 8-wide nodes in `__m256` registers with an FMA slab test; leaves in
//! the SSE kernel's 4-wide test (VEX-encoded inside this kernel's functions).

use super::{LRay, Lanes, LeafHits, ROBUST};
use crate::kernel::scalar::far_index;
use crate::kernel::sse::{VRay, inverse_dir4, leaf4};
use crate::layout::{Node, Pack};
use crate::top::QNode;
use std::arch::x86_64::*;

pub(crate) struct Avx2;

// `Avx2::qnode` reads a quantised node's origin and exponent bytes with two loads.
const _: () = {
    assert!(std::mem::offset_of!(QNode, origin) == 0);
    assert!(std::mem::offset_of!(QNode, exp) == 12);
    assert!(std::mem::offset_of!(QNode, inner) == 15);
};

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

/// Lane `a` (0-3) of `v` in all eight lanes (one permute).
///
/// # Safety
/// AVX2 (part of the AVX2 kernel's instruction set).
#[inline(always)]
unsafe fn lane(v: __m128, a: usize) -> __m256 {
    // SAFETY: the caller guarantees AVX2; the upper half the cast leaves undefined is never
    // selected (`a < 4`).
    unsafe { _mm256_permutevar8x32_ps(_mm256_castps128_ps256(v), _mm256_set1_epi32(a as i32)) }
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
    /// Origin, `inv` and `inv · ROBUST` per axis in lanes 0-2 of one register (lane 3 is
    /// 0): a quantised node's frame for all three axes at once.
    qo: __m128,
    qinv: __m128,
    qinv_far: __m128,
    four: VRay,
}

impl Lanes<8> for Avx2 {
    type R = WRay;

    #[inline(always)]
    unsafe fn prep(r: &LRay) -> WRay {
        // In vector registers throughout (one division for the three axes, each lane
        // broadcast once, the 4-wide copies the low halves of the 8-wide ones): an
        // instance's entry prepares one of these, and the scalar form's three divisions
        // and twenty-one broadcasts were a tenth of a tree's camera ray.
        // SAFETY: the caller guarantees AVX2 (trait contract).
        unsafe {
            let o = _mm_setr_ps(r.o[0], r.o[1], r.o[2], 0.0);
            let d = _mm_setr_ps(r.d[0], r.d[1], r.d[2], 1.0);
            let (inv, near) = inverse_dir4(d);
            let robust = _mm256_set1_ps(ROBUST);
            let o8 = [lane(o, 0), lane(o, 1), lane(o, 2)];
            let d8 = [lane(d, 0), lane(d, 1), lane(d, 2)];
            let inv8 = [lane(inv, 0), lane(inv, 1), lane(inv, 2)];
            // The same products, rounded the same way, as `o[a] * inv[a] * ROBUST` in
            // scalars.
            let oinv = [
                _mm256_mul_ps(o8[0], inv8[0]),
                _mm256_mul_ps(o8[1], inv8[1]),
                _mm256_mul_ps(o8[2], inv8[2]),
            ];
            let low = |v: [__m256; 3]| {
                [
                    _mm256_castps256_ps128(v[0]),
                    _mm256_castps256_ps128(v[1]),
                    _mm256_castps256_ps128(v[2]),
                ]
            };
            let mut sinv = [0.0f32; 4];
            _mm_storeu_ps(sinv.as_mut_ptr(), inv);
            WRay {
                oinv_far: [
                    _mm256_mul_ps(oinv[0], robust),
                    _mm256_mul_ps(oinv[1], robust),
                    _mm256_mul_ps(oinv[2], robust),
                ],
                inv_far: [
                    _mm256_mul_ps(inv8[0], robust),
                    _mm256_mul_ps(inv8[1], robust),
                    _mm256_mul_ps(inv8[2], robust),
                ],
                oinv,
                inv: inv8,
                near,
                qo: o,
                qinv: inv,
                qinv_far: _mm_mul_ps(inv, _mm256_castps256_ps128(robust)),
                four: VRay {
                    o: low(o8),
                    d: low(d8),
                    inv: low(inv8),
                    near,
                    so: r.o,
                    sinv: [sinv[0], sinv[1], sinv[2]],
                },
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
        // The frame of all three axes in one register each, without a trip through scalar
        // registers (that trip, three dependent scalar multiplies and a move per axis, was
        // the longest chain of the test): lanes 0-2 hold x, y, z.
        // SAFETY: `QNode` is `repr(C)` with `origin` at offset 0 and `exp`, `inner` at
        // 12-15 (asserted at compile time below), so the 16-byte load at `n` and the 4-byte
        // load at byte 12 read valid bytes of `*n`; each 8-byte load reads all of `n.q[k]`
        // (an `[u8; 8]`, unaligned load). AVX2 + FMA are guaranteed by the caller.
        unsafe {
            let base = n as *const QNode as *const u8;
            let head = _mm_loadu_ps(base as *const f32);
            // The steps `2^exp`: the exponent bytes sign-extended, biased and shifted into
            // place (lane 3, from `inner`, is garbage and never read).
            let exp = _mm_cvtepi8_epi32(_mm_cvtsi32_si128(std::ptr::read_unaligned(
                base.add(12) as *const i32
            )));
            let step = _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_add_epi32(
                exp,
                _mm_set1_epi32(127),
            )));
            let rel = _mm_sub_ps(head, r.qo);
            let (a, a_far) = (_mm_mul_ps(step, r.qinv), _mm_mul_ps(step, r.qinv_far));
            let (b, b_far) = (_mm_mul_ps(rel, r.qinv), _mm_mul_ps(rel, r.qinv_far));
            let t = |ax: usize, k: usize, a: __m128, b: __m128| {
                let q = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(
                    n.q[k].as_ptr() as *const __m128i
                )));
                _mm256_fmadd_ps(q, lane(a, ax), lane(b, ax))
            };
            let near = |ax: usize| t(ax, r.near[ax], a, b);
            let far = |ax: usize| t(ax, far_index(r.near[ax]), a_far, b_far);
            slab_hits(
                [near(0), near(1), near(2)],
                [far(0), far(1), far(2)],
                tmax * ROBUST,
            )
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
    use crate::Kernel;

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

    fn xorshift(seed: u64) -> impl FnMut() -> u64 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        }
    }

    /// A direction component as rays bring them: ordinary, zeros of both signs, tiny ones
    /// around `MIN_DIR`, subnormal, huge, infinite and NaN.
    fn component(r: u64) -> f32 {
        let special = [
            0.0,
            -0.0,
            1e-21,
            -1e-21,
            crate::kernel::MIN_DIR,
            -crate::kernel::MIN_DIR,
            1e-45,
            -1e-38,
            3e38,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        if r.is_multiple_of(4) {
            special[(r >> 8) as usize % special.len()]
        } else {
            ((r >> 16) as u32 as f32 / u32::MAX as f32 - 0.5) * 4.0
        }
    }

    #[test]
    fn vector_preps_are_the_scalar_one() {
        if !Kernel::Avx2.available() {
            return;
        }
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15);
        for _ in 0..20_000 {
            let d = [component(next()), component(next()), component(next())];
            let o = [component(next()), component(next()), component(next())];
            let r = LRay { o, d, skip: 0 };
            let (inv, near) = super::super::inverse_dir(d);
            // SAFETY: AVX2 and the rest of the kernel's set are present (checked above).
            let w = unsafe { Avx2::prep(&r) };
            let lane0 = |v: __m256| {
                let mut x = [0.0f32; 8];
                // SAFETY: AVX is present; the store writes all of `x`.
                unsafe { _mm256_storeu_ps(x.as_mut_ptr(), v) };
                assert!(x.iter().all(|e| e.to_bits() == x[0].to_bits()), "{x:?}");
                x[0]
            };
            let low = |v: __m128| {
                let mut x = [0.0f32; 4];
                // SAFETY: SSE is present; the store writes all of `x`.
                unsafe { _mm_storeu_ps(x.as_mut_ptr(), v) };
                x
            };
            let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            assert_eq!(w.near, near, "{d:?}");
            assert_eq!(w.four.near, near);
            // The SSE kernel's preparation, from the same vector inverse.
            // SAFETY: SSE2 is part of x86-64.
            let v = unsafe { crate::kernel::sse::prep4(&r) };
            assert_eq!(v.near, near, "{d:?}");
            for a in 0..3 {
                let want = [
                    inv[a],
                    inv[a] * ROBUST,
                    o[a] * inv[a],
                    o[a] * inv[a] * ROBUST,
                    o[a],
                    d[a],
                ];
                let got = [
                    lane0(w.inv[a]),
                    lane0(w.inv_far[a]),
                    lane0(w.oinv[a]),
                    lane0(w.oinv_far[a]),
                    low(w.four.o[a])[1],
                    low(w.four.d[a])[2],
                ];
                for (g, e) in got.iter().zip(&want) {
                    assert!(same(*g, *e), "{d:?} {o:?} axis {a}: {got:?} vs {want:?}");
                }
                assert!(same(low(w.four.inv[a])[3], inv[a]));
                assert!(same(w.four.sinv[a], inv[a]));
                assert!(same(low(w.qinv)[a], inv[a]));
                assert!(same(low(w.qinv_far)[a], inv[a] * ROBUST));
                assert!(same(low(w.qo)[a], o[a]));
                assert!(same(v.sinv[a], inv[a]) && same(low(v.inv[a])[a], inv[a]));
            }
        }
    }

    #[test]
    fn vector_quantised_test_is_the_scalar_one() {
        if !Kernel::Avx2.available() {
            return;
        }
        let mut next = xorshift(0x2545_f491_4f6c_dd1d);
        let mut unit = move || (next() >> 40) as f32 / (1u64 << 24) as f32;
        let (mut hits, mut slots) = (0, 0);
        for case in 0..20_000 {
            // A node over up to eight random boxes at one of several scales and offsets,
            // quantised by the top level's own code.
            let (scale, offset) =
                [(1.0f32, 0.0f32), (1e-3, 5.0), (100.0, -1e4), (0.01, 300.0)][case % 4];
            let mut v = || glam::Vec3::new(unit(), unit(), unit()) * 10.0 * scale + offset;
            let boxes: Vec<crate::build::Aabb> = (0..1 + case % 8)
                .map(|_| crate::build::Aabb::of_points(&[v(), v()]))
                .collect();
            let n = crate::top::node_over(&boxes);
            // Rays from outside or inside the node toward a point in one of its boxes.
            let b = boxes[case % boxes.len()];
            let f = (v() - glam::Vec3::splat(offset)) / (10.0 * scale);
            let target = b.min + (b.max - b.min) * f.clamp(glam::Vec3::ZERO, glam::Vec3::ONE);
            let o = v() + (v() - glam::Vec3::splat(offset)) * if case % 3 == 0 { 0.0 } else { 2.0 };
            let d = (target - o).to_array();
            // Some rays along an axis, with zeros of both signs.
            let d = match case % 5 {
                0 => [d[0], 0.0, -0.0],
                1 => [-0.0, d[1], 0.0],
                _ => d,
            };
            let o = o.to_array();
            let tmax = if case % 2 == 0 {
                f32::INFINITY
            } else {
                unit() * 100.0 * scale
            };
            let (inv, near) = super::super::inverse_dir(d);
            let (want_mask, want_tn) = crate::kernel::scalar::qnode_scalar(&n, o, inv, near, tmax);
            // SAFETY: AVX2 and the rest of the kernel's set are present (checked above).
            let (mask, tn) = unsafe { Avx2::qnode(&n, &Avx2::prep(&LRay { o, d, skip: 0 }), tmax) };
            hits += want_mask.count_ones();
            slots += boxes.len() as u32;
            assert_eq!(mask >> boxes.len(), 0, "an unused slot was hit");
            let (qa, qb) = super::super::qframe(&n, o, inv);
            for k in 0..boxes.len() {
                // The magnitude the slot's plane distances are computed from: the FMA here
                // and the multiply and add of the scalar form round differently, by a few
                // units in the last place of this.
                let mag = (0..6)
                    .map(|p| (n.q[p][k] as f32 * qa[p % 3]).abs() + qb[p % 3].abs())
                    .fold(0.0f32, f32::max);
                let close = |a: f32, b: f32| (a - b).abs() <= 4.0 * f32::EPSILON * mag + 1e-30;
                assert!(
                    close(tn[k], want_tn[k]),
                    "slot {k}: entry {} vs {} ({mag})",
                    tn[k],
                    want_tn[k]
                );
                if (mask ^ want_mask) & (1 << k) != 0 {
                    // The two may part only where entry and (widened) exit meet.
                    let exit = (0..3)
                        .map(|ax| n.q[far_index(near[ax])][k] as f32 * qa[ax] + qb[ax])
                        .fold(tmax, f32::min)
                        * ROBUST;
                    assert!(
                        close(exit, want_tn[k]),
                        "slot {k}: {mask:08b} vs {want_mask:08b}, entry {} exit {exit}",
                        want_tn[k]
                    );
                }
            }
        }
        // Both answers are tested, hits and misses.
        assert!(
            hits > slots / 10 && hits < slots * 9 / 10,
            "{hits} of {slots} hit"
        );
    }
}
