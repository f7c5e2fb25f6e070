//! The traversal, written once over [`Lanes`] and the node width `W`: a fixed stack,
//! children entered nearest first (closest hit) or in any order (occlusion), the leaf test
//! with alpha decided by the opacity masks and only unknown cells asking the caller.

use crate::desc::Sphere;
use crate::grid::PackTests;
use crate::kernel::{LRay, Lanes};
use crate::layout::{
    ALPHA, ALPHA_IDENTITY_UV, Blas, EMPTY, FLAG_INDEX, InstRec, LEAF, Node, Pack, STACK, Tlas,
};
use crate::mask::{OPAQUE, OpacityMask, TRANSPARENT, UNKNOWN};
use crate::top::QNode;
use crate::{AlphaFilter, Counter, Event, Hit, NO_INSTANCE, PrimRef, Ray, SPHERE};
use glam::{Affine3A, Vec2, Vec3, Vec3A};
use std::marker::PhantomData;
use std::mem::MaybeUninit;

/// What a leaf visit tells the walk.
pub(crate) enum Step {
    /// Go on, with this (possibly shortened) `tmax`.
    Go(f32),
    /// Stop: an occluder was found.
    Stop,
}

/// A tree's nodes as the walk sees them: a node test and child codes by slot.
pub(crate) trait Nodes<K: Lanes<W>, const W: usize, const N: usize> {
    /// [`Lanes::node`] for node `i`.
    ///
    /// # Safety
    /// As [`walk`].
    unsafe fn test(&self, i: u32, r: &K::R, tmax: f32) -> (u32, [f32; N]);
    /// The child code in slot `slot` of node `i`.
    fn child(&self, i: u32, slot: usize) -> u32;
    /// Prefetches node `i`.
    fn prefetch_node(&self, i: u32);
}

impl<K: Lanes<W>, const W: usize> Nodes<K, W, W> for [Node<W>] {
    #[inline(always)]
    unsafe fn test(&self, i: u32, r: &K::R, tmax: f32) -> (u32, [f32; W]) {
        // SAFETY: forwarded.
        unsafe { K::node(&self[i as usize], r, tmax) }
    }
    #[inline(always)]
    fn child(&self, i: u32, slot: usize) -> u32 {
        self[i as usize].child[slot]
    }
    #[inline(always)]
    fn prefetch_node(&self, i: u32) {
        if let Some(n) = self.get(i as usize) {
            prefetch_whole(n);
        }
    }
}

impl<K: Lanes<W>, const W: usize> Nodes<K, W, 8> for [QNode] {
    #[inline(always)]
    unsafe fn test(&self, i: u32, r: &K::R, tmax: f32) -> (u32, [f32; 8]) {
        // SAFETY: forwarded.
        unsafe { K::qnode(&self[i as usize], r, tmax) }
    }
    #[inline(always)]
    fn child(&self, i: u32, slot: usize) -> u32 {
        self[i as usize].child(slot)
    }
    #[inline(always)]
    fn prefetch_node(&self, i: u32) {
        if let Some(n) = self.get(i as usize) {
            prefetch_ends(n);
        }
    }
}

/// Asks the memory system for the node or leaf behind child code `code` (pushed now, read
/// when popped).
#[inline(always)]
fn prefetch<K: Lanes<W>, const W: usize, const N: usize, T: Nodes<K, W, N> + ?Sized>(
    nodes: &T,
    code: u32,
    leaf: &impl Visit,
) {
    if code & LEAF == 0 {
        nodes.prefetch_node(code);
    } else if code != EMPTY {
        leaf.prefetch(code & !LEAF);
    }
}

/// Prefetches the whole cache lines that hold `*v`, for a type aligned to a cache line and a
/// whole number of them long (a node, a pack): a fixed number of prefetches, no loop.
#[inline(always)]
pub(crate) fn prefetch_whole<T>(v: &T) {
    const { assert!(std::mem::align_of::<T>() >= 64 && std::mem::size_of::<T>().is_multiple_of(64)) };
    #[cfg(target_arch = "x86_64")]
    {
        let p = v as *const T as *const i8;
        for k in 0..std::mem::size_of::<T>() / 64 {
            // SAFETY: a prefetch is a hint that never faults; the address, inside `*v`, is
            // only computed, never dereferenced. SSE is part of x86-64.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                    p.wrapping_add(64 * k),
                )
            };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v;
}

/// Prefetches the cache lines that hold `*v`, for a type that lies on at most two lines
/// wherever its alignment puts it (a quantised node, an instance record): its first and
/// its last byte, two prefetches and no loop.
#[inline(always)]
pub(crate) fn prefetch_ends<T>(v: &T) {
    const {
        let align = std::mem::align_of::<T>();
        assert!(align <= 64 && std::mem::size_of::<T>() + (64 - align) <= 128)
    };
    #[cfg(target_arch = "x86_64")]
    {
        let p = v as *const T as *const i8;
        // SAFETY: a prefetch is a hint that never faults; both addresses, inside `*v`, are
        // only computed, never dereferenced. SSE is part of x86-64.
        unsafe {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            _mm_prefetch::<{ _MM_HINT_T0 }>(p);
            _mm_prefetch::<{ _MM_HINT_T0 }>(p.wrapping_add(std::mem::size_of::<T>() - 1));
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v;
}

/// Prefetches the cache lines of `bytes` bytes at `p` into L1 (a plain loop: an iterator
/// adapter here cost 7 % of instanced-ray time).
#[inline(always)]
pub(crate) fn prefetch_lines(p: *const u8, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        let first = p as usize & !63;
        let end = p as usize + bytes;
        let mut line = first;
        while line < end {
            // SAFETY: a prefetch is a hint that never faults, whatever the address; the
            // address is only computed, never dereferenced. SSE is part of x86-64.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                    line as *const i8,
                )
            };
            line += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, bytes);
}

/// What the walk does at a leaf: called with the leaf's index and the current `tmax`.
/// A trait rather than a closure so that it is inlined (closures cannot be marked
/// `#[inline(always)]` on stable Rust, and were not inlined).
pub(crate) trait Visit {
    /// Visits leaf `k`.
    ///
    /// # Safety
    /// As [`walk`].
    unsafe fn leaf(&mut self, k: u32, tmax: f32) -> Step;

    /// Prefetches leaf `k` (pushed now, visited later).
    fn prefetch(&self, k: u32) {
        let _ = k;
    }
}

/// Walks the wide tree `nodes` from child code `root` with ray `r`, calling `leaf` for
/// every leaf code reached (with the current `tmax`). `ORDERED`: children are entered
/// nearest first and skipped once beyond `tmax`; otherwise in slot order.
///
/// # Safety
/// `K`'s instruction set must be available (see [`Lanes`]).
#[inline(always)]
pub(crate) unsafe fn walk<
    K: Lanes<W>,
    const W: usize,
    const N: usize,
    T: Nodes<K, W, N> + ?Sized,
    const ORDERED: bool,
    C: Counter,
>(
    nodes: &T,
    root: u32,
    r: &K::R,
    mut tmax: f32,
    c: &C,
    leaf: &mut impl Visit,
) {
    // Uninitialised: zeroing 4 KiB per walk cost 5 % of all ray time. Entries below `sp`
    // are always written before they are read.
    let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); STACK];
    let mut sp = 0usize;
    let mut cur = root;
    loop {
        if cur & LEAF == 0 {
            c.count(Event::Node);
            // SAFETY: forwarded from the caller's guarantee on `K`.
            let (mut m, tn) = unsafe { nodes.test(cur, r, tmax) };
            if m != 0 {
                if m & (m - 1) == 0 {
                    cur = nodes.child(cur, m.trailing_zeros() as usize);
                    continue;
                }
                if ORDERED && (m & (m - 1)).count_ones() == 1 {
                    // Two children, the common case: enter the nearer, push the farther.
                    let (i, j) = (
                        m.trailing_zeros() as usize,
                        (31 - m.leading_zeros()) as usize,
                    );
                    let (near, far) = if tn[j] < tn[i] { (j, i) } else { (i, j) };
                    let far_child = nodes.child(cur, far);
                    prefetch::<K, W, N, T>(nodes, far_child, leaf);
                    stack[sp] = MaybeUninit::new((far_child, tn[far]));
                    sp += 1;
                    cur = nodes.child(cur, near);
                    continue;
                }
                let base = sp;
                while m != 0 {
                    let i = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let entry = (nodes.child(cur, i), tn[i]);
                    prefetch::<K, W, N, T>(nodes, entry.0, leaf);
                    if ORDERED {
                        // Insertion into the pushed run, farthest at the bottom.
                        let mut j = sp;
                        // SAFETY: `base <= j - 1 < sp`: entries below `sp` are written.
                        while j > base && unsafe { stack[j - 1].assume_init() }.1 < entry.1 {
                            stack[j] = stack[j - 1];
                            j -= 1;
                        }
                        stack[j] = MaybeUninit::new(entry);
                    } else {
                        stack[sp] = MaybeUninit::new(entry);
                    }
                    sp += 1;
                }
                sp -= 1;
                // SAFETY: `sp` < the number of entries written (at least two were pushed).
                cur = unsafe { stack[sp].assume_init() }.0;
                continue;
            }
        } else if cur != EMPTY {
            // SAFETY: forwarded.
            match unsafe { leaf.leaf(cur & !LEAF, tmax) } {
                Step::Go(t) => tmax = t,
                Step::Stop => return,
            }
        }
        loop {
            if sp == 0 {
                return;
            }
            sp -= 1;
            // SAFETY: entries below the old `sp` are written.
            let (n, t) = unsafe { stack[sp].assume_init() };
            if !ORDERED || t <= tmax {
                cur = n;
                break;
            }
        }
    }
}

/// Whether the alpha-tested lane `flags` of a pack in `blas` is opaque at `(b1, b2)`.
#[inline(always)]
pub(crate) fn alpha_opaque<const W: usize, F: AlphaFilter, C: Counter>(
    blas: &Blas<W>,
    masks: &[Option<OpacityMask>],
    flags: u32,
    b1: f32,
    b2: f32,
    f: &F,
    c: &C,
) -> bool {
    let (id, uv, state) = mask_state(blas, masks, flags, b1, b2);
    match state {
        OPAQUE => {
            c.count(Event::MaskOpaque);
            true
        }
        TRANSPARENT => {
            c.count(Event::MaskTransparent);
            false
        }
        _ => {
            c.count(Event::AlphaLookup);
            f.opaque(id, uv)
        }
    }
}

/// What the opacity mask of the alpha-tested lane `flags` of a pack in `blas` says at
/// `(b1, b2)`, with no exact lookup: the matte's id, the uv there, and `OPAQUE`,
/// `TRANSPARENT` or `UNKNOWN` (no mask, or a cell the exact matte must decide).
#[inline(always)]
pub(crate) fn mask_state<const W: usize>(
    blas: &Blas<W>,
    masks: &[Option<OpacityMask>],
    flags: u32,
    b1: f32,
    b2: f32,
) -> (u32, Vec2, u8) {
    let (id, uv) = if flags & ALPHA_IDENTITY_UV != 0 {
        (flags & FLAG_INDEX, Vec2::new(b1, b2))
    } else {
        let rec = &blas.alpha[(flags & FLAG_INDEX) as usize];
        let b0 = 1.0 - b1 - b2;
        (
            rec.id,
            Vec2::new(
                rec.uv[0][0] * b0 + rec.uv[1][0] * b1 + rec.uv[2][0] * b2,
                rec.uv[0][1] * b0 + rec.uv[1][1] * b1 + rec.uv[2][1] * b2,
            ),
        )
    };
    let state = match masks.get(id as usize) {
        Some(Some(m)) => m.classify(uv),
        _ => UNKNOWN,
    };
    (id, uv, state)
}

/// The closest accepted lane of pack `p` with `t < tmax`: `(t, lane, b1, b2)`.
///
/// # Safety
/// As [`walk`].
#[inline(always)]
pub(crate) unsafe fn pack_closest<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter>(
    blas: &Blas<W>,
    masks: &[Option<OpacityMask>],
    p: &Pack,
    r: &K::R,
    tmax: f32,
    skip: u32,
    f: &F,
    c: &C,
) -> Option<(f32, usize, f32, f32)> {
    c.count(Event::Pack);
    // SAFETY: forwarded.
    let h = unsafe { K::leaf(p, r, tmax, skip) };
    let mut m = h.mask;
    while m != 0 {
        // Nearest remaining lane first: the first one accepted is the pack's closest.
        let i = nearest_lane(m, |j| h.t[j]);
        m &= !(1 << i);
        let fl = p.flags[i];
        if fl & ALPHA != 0 && !alpha_opaque(blas, masks, fl, h.b1[i], h.b2[i], f, c) {
            continue;
        }
        return Some((h.t[i], i, h.b1[i], h.b2[i]));
    }
    None
}

/// The lane of the non-empty lane set `m` (bit `i`: lane `i`) with the smallest `t(i)`,
/// ties to the lower lane: the order in which [`pack_closest`] tries its lanes.
#[inline(always)]
pub(crate) fn nearest_lane(m: u32, t: impl Fn(usize) -> f32) -> usize {
    let mut i = m.trailing_zeros() as usize;
    let mut rest = m & (m - 1);
    while rest != 0 {
        let j = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        if t(j) < t(i) {
            i = j;
        }
    }
    i
}

/// Whether pack `p` has an accepted lane with `t < tmax`.
///
/// # Safety
/// As [`walk`].
#[inline(always)]
pub(crate) unsafe fn pack_any<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter>(
    blas: &Blas<W>,
    masks: &[Option<OpacityMask>],
    p: &Pack,
    r: &K::R,
    tmax: f32,
    skip: u32,
    f: &F,
    c: &C,
) -> bool {
    c.count(Event::Pack);
    // SAFETY: forwarded.
    let h = unsafe { K::leaf(p, r, tmax, skip) };
    let mut m = h.mask;
    while m != 0 {
        let i = m.trailing_zeros() as usize;
        m &= m - 1;
        let fl = p.flags[i];
        if fl & ALPHA == 0 || alpha_opaque(blas, masks, fl, h.b1[i], h.b2[i], f, c) {
            return true;
        }
    }
    false
}

/// The best hit so far.
#[derive(Clone, Copy)]
pub(crate) struct Best {
    pub t: f32,
    pub prim: u32,
    pub inst: u32,
    pub bary: Vec2,
}

impl Best {
    /// Nothing found before `t`.
    #[inline(always)]
    pub(crate) fn none(t: f32) -> Best {
        Best {
            t,
            prim: u32::MAX,
            inst: NO_INSTANCE,
            bary: Vec2::ZERO,
        }
    }
}

/// One bottom level queried with one prepared ray: what both leaf visits share.
struct LevelQuery<'a, K: Lanes<W>, const W: usize, F, C> {
    blas: &'a Blas<W>,
    masks: &'a [Option<OpacityMask>],
    r: &'a K::R,
    /// The primitive id to skip (`u32::MAX`: none).
    skip: u32,
    f: &'a F,
    c: &'a C,
}

impl<K: Lanes<W>, const W: usize, F, C> LevelQuery<'_, K, W, F, C> {
    #[inline(always)]
    fn prefetch_pack(&self, k: u32) {
        if let Some(p) = self.blas.packs.get(k as usize) {
            prefetch_whole(p);
        }
    }
}

/// The leaf visit of [`blas_closest`].
struct ClosestVisit<'a, K: Lanes<W>, const W: usize, F, C> {
    q: LevelQuery<'a, K, W, F, C>,
    best: &'a mut Best,
    inst: u32,
    found: bool,
}

impl<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter> Visit
    for ClosestVisit<'_, K, W, F, C>
{
    #[inline(always)]
    fn prefetch(&self, k: u32) {
        self.q.prefetch_pack(k);
    }

    #[inline(always)]
    unsafe fn leaf(&mut self, k: u32, tmax: f32) -> Step {
        let q = &self.q;
        let p = &q.blas.packs[k as usize];
        // SAFETY: forwarded.
        let hit =
            unsafe { pack_closest::<K, W, F, C>(q.blas, q.masks, p, q.r, tmax, q.skip, q.f, q.c) };
        let Some((t, lane, b1, b2)) = hit else {
            return Step::Go(tmax);
        };
        *self.best = Best {
            t,
            prim: p.id[lane],
            inst: self.inst,
            bary: Vec2::new(b1, b2),
        };
        self.found = true;
        Step::Go(t)
    }
}

/// The leaf visit of [`blas_any`].
struct AnyVisit<'a, K: Lanes<W>, const W: usize, F, C> {
    q: LevelQuery<'a, K, W, F, C>,
    hit: bool,
}

impl<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter> Visit for AnyVisit<'_, K, W, F, C> {
    #[inline(always)]
    fn prefetch(&self, k: u32) {
        self.q.prefetch_pack(k);
    }

    #[inline(always)]
    unsafe fn leaf(&mut self, k: u32, tmax: f32) -> Step {
        let q = &self.q;
        let p = &q.blas.packs[k as usize];
        // SAFETY: forwarded.
        if unsafe { pack_any::<K, W, F, C>(q.blas, q.masks, p, q.r, tmax, q.skip, q.f, q.c) } {
            self.hit = true;
            Step::Stop
        } else {
            Step::Go(tmax)
        }
    }
}

/// Closest hit in `blas` for the prepared ray `r` (skipping id `skip`), improving `best`
/// (its `t` is the bound).
///
/// # Safety
/// As [`walk`].
#[inline(always)]
unsafe fn blas_closest<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter>(
    blas: &Blas<W>,
    masks: &[Option<OpacityMask>],
    r: &K::R,
    skip: u32,
    best: &mut Best,
    inst: u32,
    f: &F,
    c: &C,
) -> bool {
    if blas.root == EMPTY {
        return false;
    }
    let t0 = best.t;
    let q = LevelQuery::<K, W, F, C> {
        blas,
        masks,
        r,
        skip,
        f,
        c,
    };
    let mut v = ClosestVisit {
        q,
        best,
        inst,
        found: false,
    };
    // SAFETY: forwarded.
    unsafe { walk::<K, W, W, [Node<W>], true, C>(&blas.nodes, blas.root, r, t0, c, &mut v) };
    v.found
}

/// Whether `blas` has an accepted hit for the prepared ray `r` (skipping id `skip`)
/// within `tmax`.
///
/// # Safety
/// As [`walk`].
#[inline(always)]
unsafe fn blas_any<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter>(
    blas: &Blas<W>,
    masks: &[Option<OpacityMask>],
    r: &K::R,
    skip: u32,
    tmax: f32,
    f: &F,
    c: &C,
) -> bool {
    if blas.root == EMPTY {
        return false;
    }
    let q = LevelQuery::<K, W, F, C> {
        blas,
        masks,
        r,
        skip,
        f,
        c,
    };
    let mut v = AnyVisit { q, hit: false };
    // SAFETY: forwarded.
    unsafe { walk::<K, W, W, [Node<W>], false, C>(&blas.nodes, blas.root, r, tmax, c, &mut v) };
    v.hit
}

/// The top level's leaf visit for closest hits: the instance's prototype, in its space.
struct TlasClosest<'a, K, const W: usize, F, C> {
    kernel: PhantomData<K>,
    levels: &'a Levels<W>,
    o: Vec3A,
    d: Vec3A,
    skip: PrimRef,
    best: Best,
    found: bool,
    f: &'a F,
    c: &'a C,
}

impl<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter> Visit
    for TlasClosest<'_, K, W, F, C>
{
    #[inline(always)]
    fn prefetch(&self, i: u32) {
        self.levels.prefetch_record(i);
    }

    #[inline(always)]
    unsafe fn leaf(&mut self, i: u32, _: f32) -> Step {
        let v = self;
        v.c.count(Event::Instance);
        let (blas, lr) = v.levels.enter(i, v.o, v.d, v.skip);
        // SAFETY: forwarded.
        v.found |= unsafe {
            let r = K::prep(&lr);
            blas_closest::<K, W, F, C>(blas, &v.levels.masks, &r, lr.skip, &mut v.best, i, v.f, v.c)
        };
        Step::Go(v.best.t)
    }
}

/// The top level's leaf visit for occlusion.
struct TlasAny<'a, K, const W: usize, F, C> {
    kernel: PhantomData<K>,
    levels: &'a Levels<W>,
    o: Vec3A,
    d: Vec3A,
    skip: PrimRef,
    hit: bool,
    f: &'a F,
    c: &'a C,
}

impl<K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter> Visit for TlasAny<'_, K, W, F, C> {
    #[inline(always)]
    fn prefetch(&self, i: u32) {
        self.levels.prefetch_record(i);
    }

    #[inline(always)]
    unsafe fn leaf(&mut self, i: u32, tmax: f32) -> Step {
        let v = self;
        v.c.count(Event::Instance);
        let (blas, lr) = v.levels.enter(i, v.o, v.d, v.skip);
        // SAFETY: forwarded.
        let r = unsafe { K::prep(&lr) };
        // SAFETY: forwarded.
        if unsafe { blas_any::<K, W, F, C>(blas, &v.levels.masks, &r, lr.skip, tmax, v.f, v.c) } {
            v.hit = true;
            Step::Stop
        } else {
            Step::Go(tmax)
        }
    }
}

/// The levels of one node width.
#[derive(Clone, Debug)]
pub(crate) struct Levels<const W: usize> {
    pub world: Blas<W>,
    pub protos: Vec<Blas<W>>,
    pub tlas: Option<Tlas>,
    /// The instance records in the top level's order (instances of empty prototypes are
    /// left out): a hit's instance id indexes this.
    pub recs: Vec<InstRec>,
    pub spheres: Vec<Sphere>,
    pub masks: Vec<Option<OpacityMask>>,
    /// Where boxes and grids bound only masked primitives' live parts (`crate::trim`):
    /// each mask's live cells; `None` for whole primitives.
    pub live_uv: Option<Vec<Option<crate::trim::LiveUv>>>,
    /// Grids for shadow rays toward distant lights ([`crate::direction`]).
    pub dirs: Vec<crate::direction::DirIndex>,
    /// The grid for rays from a camera's eye ([`crate::view`]).
    pub view: Option<crate::view::ViewIndex>,
}

#[inline(always)]
fn to_local(rec: &InstRec, o: Vec3A, d: Vec3A, skip: PrimRef, inst: u32) -> LRay {
    let m = Affine3A::from_cols_slice(&rec.w2o);
    LRay {
        o: m.transform_point3a(o).to_array(),
        d: m.transform_vector3a(d).to_array(),
        skip: if skip.inst == inst {
            skip.prim
        } else {
            u32::MAX
        },
    }
}

/// Nearest `t ∈ (0, tmax)` where the ray meets sphere `s`, or `∞` (stable form: Hearn &
/// Baker, Ray Tracing Gems ch. 7).
#[inline]
pub(crate) fn intersect_sphere(s: &Sphere, o: Vec3, d: Vec3, tmax: f32) -> f32 {
    let oc = o - s.center;
    let a = d.length_squared();
    if !(a > 0.0 && s.radius > 0.0) {
        return f32::INFINITY;
    }
    let b = oc.dot(d) / a;
    let perp = oc - d * b;
    let disc = s.radius * s.radius - perp.length_squared();
    if disc < 0.0 {
        return f32::INFINITY;
    }
    let c = (oc.length_squared() - s.radius * s.radius) / a;
    let q = -b - (disc / a).sqrt().copysign(b);
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

impl<const W: usize> Levels<W> {
    /// Prefetches instance record `i`: with a million instances nearly every first read of
    /// one is a cache miss (a third of a camera ray's time in the tree benchmark).
    #[inline(always)]
    fn prefetch_record(&self, i: u32) {
        if let Some(r) = self.recs.get(i as usize) {
            prefetch_ends(r);
        }
    }

    /// Instance `i`'s prototype and the ray in its object space.
    #[inline(always)]
    pub(crate) fn enter(&self, i: u32, o: Vec3A, d: Vec3A, skip: PrimRef) -> (&Blas<W>, LRay) {
        let rec = &self.recs[i as usize];
        (
            &self.protos[rec.proto as usize],
            to_local(rec, o, d, skip, i),
        )
    }

    /// The closest accepted hit by walking the world level and the top level, improving
    /// `best`; whether one was found.
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    unsafe fn walk_closest<K: Lanes<W>, F: AlphaFilter, C: Counter>(
        &self,
        o: Vec3A,
        d: Vec3A,
        skip: PrimRef,
        tr: &K::R,
        wskip: u32,
        best: &mut Best,
        f: &F,
        c: &C,
    ) -> bool {
        // SAFETY: forwarded.
        let mut found = unsafe {
            blas_closest::<K, W, F, C>(&self.world, &self.masks, tr, wskip, best, NO_INSTANCE, f, c)
        };
        if let Some(tlas) = &self.tlas {
            let t0 = best.t;
            let mut v = TlasClosest::<K, W, F, C> {
                kernel: PhantomData,
                levels: self,
                o,
                d,
                skip,
                best: *best,
                found: false,
                f,
                c,
            };
            // SAFETY: forwarded.
            unsafe { walk::<K, W, 8, [QNode], true, C>(&tlas.nodes, tlas.root, tr, t0, c, &mut v) };
            *best = v.best;
            found |= v.found;
        }
        found
    }

    /// The closest accepted hit.
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    pub(crate) unsafe fn closest<K: Lanes<W>, F: AlphaFilter, C: Counter>(
        &self,
        ray: &Ray,
        skip: PrimRef,
        f: &F,
        c: &C,
    ) -> Option<Hit> {
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.dir);
        let mut best = Best::none(ray.tmax);
        let wr = LRay {
            o: ray.origin.to_array(),
            d: ray.dir.to_array(),
            skip: if skip.inst == NO_INSTANCE {
                skip.prim
            } else {
                u32::MAX
            },
        };
        // One prepared world ray serves the world level and the top level.
        // SAFETY: forwarded.
        let tr = unsafe { K::prep(&wr) };
        let from_eye = match &self.view {
            Some(v) => {
                let mut tests = PackTests::<K, W, F, C>::new(self, o, d, skip, &tr, wr.skip, f, c);
                // SAFETY: forwarded.
                unsafe { v.closest(ray, &mut tests, &mut best) }
            }
            None => None,
        };
        let found = match from_eye {
            Some(found) => found,
            // SAFETY: forwarded.
            None => unsafe {
                self.walk_closest::<K, F, C>(o, d, skip, &tr, wr.skip, &mut best, f, c)
            },
        };
        self.finish(ray, best, found)
    }

    /// The hit of `ray` from the best triangle or card hit `best` (`found`), after the
    /// spheres (tested last, against `best.t`).
    #[inline(always)]
    fn finish(&self, ray: &Ray, mut best: Best, mut found: bool) -> Option<Hit> {
        for (k, s) in self.spheres.iter().enumerate() {
            let t = intersect_sphere(s, ray.origin, ray.dir, best.t);
            if t < best.t {
                best = Best {
                    t,
                    prim: k as u32,
                    inst: SPHERE,
                    bary: Vec2::ZERO,
                };
                found = true;
            }
        }
        found.then_some(Hit {
            t: best.t,
            prim: PrimRef {
                inst: best.inst,
                prim: best.prim,
            },
            bary: best.bary,
        })
    }

    /// Whether any accepted hit lies within `(0, tmax)`.
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    pub(crate) unsafe fn occluded<K: Lanes<W>, F: AlphaFilter, C: Counter>(
        &self,
        ray: &Ray,
        skip: PrimRef,
        f: &F,
        c: &C,
    ) -> bool {
        for s in &self.spheres {
            if intersect_sphere(s, ray.origin, ray.dir, ray.tmax) < ray.tmax {
                return true;
            }
        }
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.dir);
        let wr = LRay {
            o: ray.origin.to_array(),
            d: ray.dir.to_array(),
            skip: if skip.inst == NO_INSTANCE {
                skip.prim
            } else {
                u32::MAX
            },
        };
        // One prepared world ray serves the world level and the top level.
        // SAFETY: forwarded.
        let tr = unsafe { K::prep(&wr) };
        if !self.dirs.is_empty() {
            let mut tests = PackTests::<K, W, F, C>::new(self, o, d, skip, &tr, wr.skip, f, c);
            for ix in &self.dirs {
                // SAFETY: forwarded.
                if let Some(hit) = unsafe { ix.occluded(ray, &mut tests) } {
                    return hit;
                }
            }
        }
        // SAFETY: forwarded.
        if unsafe { blas_any::<K, W, F, C>(&self.world, &self.masks, &tr, wr.skip, ray.tmax, f, c) }
        {
            return true;
        }
        let Some(tlas) = &self.tlas else {
            return false;
        };
        let mut v = TlasAny::<K, W, F, C> {
            kernel: PhantomData,
            levels: self,
            o,
            d,
            skip,
            hit: false,
            f,
            c,
        };
        // SAFETY: forwarded.
        unsafe {
            walk::<K, W, 8, [QNode], false, C>(&tlas.nodes, tlas.root, &tr, ray.tmax, c, &mut v)
        };
        v.hit
    }
}

#[cfg(target_arch = "x86_64")]
impl Levels<8> {
    /// [`Levels::closest`] of each of `rays` with no primitive skipped, into `out` (as
    /// long): rays from a pinhole's eye eight at a time through
    /// [`crate::view::ViewIndex::closest_rays`] where it serves them, the others one by one.
    /// The same answers, bit for bit.
    ///
    /// # Safety
    /// AVX2 and FMA must be available.
    #[inline(always)]
    pub(crate) unsafe fn closest_rays<F: AlphaFilter, C: Counter>(
        &self,
        rays: &[Ray],
        f: &F,
        c: &C,
        out: &mut [Option<Hit>],
    ) {
        use crate::kernel::avx2::Avx2;
        for (rays, out) in rays.chunks(8).zip(out.chunks_mut(8)) {
            let mut best = [Best::none(0.0); 8];
            let mut found = [false; 8];
            let served = match &self.view {
                // SAFETY: AVX2 is available (caller).
                Some(v) => unsafe { v.closest_rays(self, rays, f, c, &mut best, &mut found) },
                None => 0,
            };
            for (k, (ray, out)) in rays.iter().zip(out.iter_mut()).enumerate() {
                *out = if served & (1 << k) != 0 {
                    self.finish(ray, best[k], found[k])
                } else {
                    // SAFETY: AVX2 and FMA are available (caller).
                    unsafe { self.closest::<Avx2, F, C>(ray, PrimRef::NONE, f, c) }
                };
            }
        }
    }

    /// [`Levels::closest`] of the rays from `eye` along `d[0][k], d[1][k], d[2][k]` (no
    /// limit, no primitive skipped) into `out[k]` (all as long): eight at a time through
    /// [`crate::view::ViewIndex::closest_lanes`] where the grid is this eye's, straight
    /// from the lanes; the others one by one. The same answers, bit for bit.
    ///
    /// # Safety
    /// AVX2 and FMA must be available.
    #[inline(always)]
    pub(crate) unsafe fn closest_eye<F: AlphaFilter, C: Counter>(
        &self,
        eye: Vec3,
        d: [&[f32]; 3],
        f: &F,
        c: &C,
        out: &mut [Option<Hit>],
    ) {
        use crate::kernel::avx2::{Avx2, Rays8};
        use std::arch::x86_64::*;
        let view = self.view.as_ref().filter(|v| v.eye() == eye);
        for (g, out) in out.chunks_mut(8).enumerate() {
            let n = out.len();
            let at = g * 8;
            // The group's directions per axis; lanes past `n` repeat the first ray.
            let mut lanes = [[0.0f32; 8]; 3];
            for (lane, axis) in lanes.iter_mut().zip(d) {
                let part = &axis[at..at + n];
                *lane = [part[0]; 8];
                lane[..n].copy_from_slice(part);
            }
            let ray = |k: usize| Ray::from_eye_lane(eye, [&lanes[0], &lanes[1], &lanes[2]], k);
            let mut best = [Best::none(0.0); 8];
            let mut found = [false; 8];
            let served = match view {
                // SAFETY: AVX2 is available (caller); each load reads a whole `[f32; 8]`;
                // every lane starts at the grid's eye.
                Some(v) => unsafe {
                    let load = |a: usize| _mm256_loadu_ps(lanes[a].as_ptr());
                    let o = [
                        _mm256_set1_ps(eye.x),
                        _mm256_set1_ps(eye.y),
                        _mm256_set1_ps(eye.z),
                    ];
                    let r = Rays8 {
                        o,
                        d: [load(0), load(1), load(2)],
                    };
                    let tmax = _mm256_set1_ps(f32::INFINITY);
                    v.closest_lanes(self, r, tmax, (1u32 << n) - 1, f, c, &mut best, &mut found)
                },
                None => 0,
            };
            for (k, out) in out.iter_mut().enumerate() {
                *out = if served & (1 << k) != 0 {
                    self.finish(&ray(k), best[k], found[k])
                } else {
                    // SAFETY: AVX2 and FMA are available (caller).
                    unsafe { self.closest::<Avx2, F, C>(&ray(k), PrimRef::NONE, f, c) }
                };
            }
        }
    }

    /// [`Levels::occluded`] of each of `rays`, leaving primitive `skips[k]`, into `out`
    /// (all as long): rays toward a distant light eight at a time through
    /// [`crate::direction::DirIndex::occluded_rays`] where it serves them, the others one
    /// by one. The same answers, bit for bit.
    ///
    /// # Safety
    /// AVX2 and FMA must be available.
    #[inline(always)]
    pub(crate) unsafe fn occluded_rays<F: AlphaFilter, C: Counter>(
        &self,
        rays: &[Ray],
        skips: &[PrimRef],
        f: &F,
        c: &C,
        out: &mut [bool],
    ) {
        use crate::kernel::avx2::Avx2;
        for ((rays, skips), out) in rays.chunks(8).zip(skips.chunks(8)).zip(out.chunks_mut(8)) {
            let n = rays.len();
            // Unserved rays, one bit each; spheres (tested first by `occluded`) leave every
            // ray to the one-ray query.
            let mut left = if self.spheres.is_empty() {
                (1u32 << n) - 1
            } else {
                0
            };
            let mut world_skip = [u32::MAX; 8];
            for (w, s) in world_skip.iter_mut().zip(skips) {
                if s.inst == NO_INSTANCE {
                    *w = s.prim;
                }
            }
            let mut occ = 0u32;
            let mut served = 0u32;
            for ix in &self.dirs {
                if left == 0 {
                    break;
                }
                // SAFETY: AVX2 is available (caller).
                let s = unsafe { ix.occluded_rays(self, rays, &world_skip, left, f, c, &mut occ) };
                served |= s;
                left &= !s;
            }
            for (k, ((ray, skip), out)) in rays.iter().zip(skips).zip(out.iter_mut()).enumerate() {
                *out = if served & (1 << k) != 0 {
                    occ & (1 << k) != 0
                } else {
                    // SAFETY: AVX2 and FMA are available (caller).
                    unsafe { self.occluded::<Avx2, F, C>(ray, *skip, f, c) }
                };
            }
        }
    }
}
