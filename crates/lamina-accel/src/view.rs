//! Camera rays: a grid over the picture the eye sees.
//!
//! A pinhole camera's rays all leave one point, the eye. Seen from there the scene is a
//! 2D picture (the perspective projection `(x/z, y/z)` in the camera's frame, `z` along
//! the view direction), and the primitives a ray can meet are those whose picture covers
//! the ray's direction. The grid lists, per cell of that picture, the leaf packs whose
//! projected outline touches it, nearest first (by the smallest depth `z` of their
//! primitives). A ray from the eye ([`ViewIndex::closest`]) tests the packs of the cell
//! under its direction in that order and stops at the first whose nearest depth lies
//! beyond the best hit so far: closest hit in a few pack tests instead of a walk down the
//! tree. The pack test is the traversal's own (instance transform, skip, alpha masks).
//!
//! Packs that cross the plane of the eye (a ground running under the camera) have no
//! picture: every ray tests them. Packs wholly behind the eye are never met. Rays that
//! do not start at the eye, or point outside the grid's window (the image, with a
//! margin), take the tree walk, as do rays under a cell too crowded for a list.
//!
//! Answers are the walk's (tests compare them for every kernel); only two primitives at
//! exactly the same distance along a ray may be reported in another order.

use crate::grid::{
    Cells, Entry, Footprint, GridStats, LaneFoot, Listing, PackTests, median_size, sort_entries,
};
use crate::kernel::Lanes;
use crate::traverse::{Best, Levels};
use crate::{AlphaFilter, Counter, Ray};
#[cfg(target_arch = "x86_64")]
use crate::{
    kernel::avx2::{Rays8, leaf_rays},
    layout::{ALPHA, Pack},
    mask::{OPAQUE, TRANSPARENT},
    traverse::{alpha_opaque, mask_state, nearest_lane},
};
use glam::{Vec2, Vec3, Vec3A};
use rayon::prelude::*;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// Most packs crossing the eye's plane (tested by every ray) a grid accepts.
const MAX_NEAR: usize = 16;

/// The grid of one eye (module docs). Entry keys are the pack's nearest depth along the
/// view direction; lists run nearest first.
#[derive(Clone, Debug)]
pub(crate) struct ViewIndex {
    eye: Vec3,
    right: Vec3A,
    up: Vec3A,
    fwd: Vec3A,
    /// Margin in picture units on a ray's projection.
    pad: f32,
    /// Margin in world units on depths.
    zpad: f32,
    /// The cells, and apart from them the packs crossing the eye's plane: every ray
    /// tests those.
    grid: Listing,
    /// Whether every listed pack is of the world level (no instances): what
    /// [`ViewIndex::closest_rays`] serves.
    world_only: bool,
}

impl ViewIndex {
    /// The grid for rays from `eye` looking along `forward` (`up` fixes the roll) over
    /// `lv`'s packs, covering the picture `window = [x0, x1, y0, y1]` (tangents of the
    /// angles right and up of the view direction). `None` for a degenerate frame or
    /// window, more than [`MAX_NEAR`] packs crossing the eye's plane, or a scene
    /// [`crate::grid::pack_refs`] or [`Cells::fill`] refuses.
    pub(crate) fn build<const W: usize>(
        lv: &Levels<W>,
        eye: Vec3,
        forward: Vec3,
        up: Vec3,
        window: [f32; 4],
    ) -> Option<ViewIndex> {
        let fwd = Vec3A::from(forward.normalize_or_zero());
        let right = fwd.cross(Vec3A::from(up)).normalize_or_zero();
        let ok = eye.is_finite()
            && fwd != Vec3A::ZERO
            && right != Vec3A::ZERO
            && window.iter().all(|w| w.is_finite())
            && window[0] < window[1]
            && window[2] < window[3];
        if !ok {
            return None;
        }
        let up = right.cross(fwd);
        let e = Vec3A::from(eye);
        let (refs, o2w) = crate::grid::pack_refs(lv)?;
        // World-space rounding: units in the last place of the scene's coordinates.
        let corners: Vec<Vec<(usize, [Vec3A; 4])>> = refs
            .par_iter()
            .map(|r| crate::grid::placed_corners(lv, &o2w, *r))
            .collect();
        let scale = corners
            .iter()
            .flatten()
            .flat_map(|(k, c)| c[..*k].iter())
            .fold(e.abs().max_element(), |m, q| m.max(q.abs().max_element()));
        if !scale.is_finite() {
            return None;
        }
        let zpad = scale * 256.0 * f32::EPSILON + f32::MIN_POSITIVE;
        // Nearer than this to the eye's plane a primitive counts as crossing it.
        let znear = 64.0 * zpad;
        // Per pack: its footprint, or `None` when it crosses the eye's plane.
        let feet: Vec<Option<Footprint>> = corners
            .par_iter()
            .map(|lanes| {
                let mut out = Vec::with_capacity(lanes.len());
                for (k, c) in lanes {
                    let mut poly = [[0.0f32; 2]; 4];
                    let mut depth = [0.0f32; 4];
                    let (mut zmin, mut zmax) = (f32::INFINITY, f32::NEG_INFINITY);
                    for i in 0..*k {
                        let rel = c[i] - e;
                        let z = rel.dot(fwd);
                        (zmin, zmax) = (zmin.min(z), zmax.max(z));
                        depth[i] = z;
                        poly[i] = [rel.dot(right) / z, rel.dot(up) / z];
                    }
                    if zmax <= 0.0 {
                        continue; // behind the eye: never met
                    }
                    if zmin <= znear {
                        return None;
                    }
                    let mut l = LaneFoot::new(poly, depth, *k, None);
                    // A corner's rounding (`zpad` in world units) seen from its depth.
                    l.pad = zpad / zmin;
                    out.push(l);
                }
                Some(Footprint::new(out))
            })
            .collect();
        let mut near: Vec<Entry> = feet
            .iter()
            .enumerate()
            .filter(|(_, f)| f.is_none())
            .map(|(r, _)| Entry {
                key: f32::NEG_INFINITY,
                r: r as u32,
            })
            .collect();
        if near.len() > MAX_NEAR {
            return None;
        }
        sort_entries(&mut near, false);
        let feet: Vec<Footprint> = feet
            .into_iter()
            .map(|f| f.unwrap_or_else(|| Footprint::new(Vec::new())))
            .collect();
        let median = median_size(&feet)?;
        // A ray's own projection: a few units in the last place of the window's extent.
        let pad = 64.0 * f32::EPSILON * (1.0 + window.iter().fold(0.0f32, |m, w| m.max(w.abs())));
        let mut cells = Cells::new(
            [window[0] - pad, window[2] - pad],
            [window[1] + pad, window[3] + pad],
            median,
            pad,
        );
        if !cells.fill(&feet, pad, false, |l, _, _| l.dmin) {
            return None;
        }
        let world_only = refs.iter().all(|r| r.inst == crate::NO_INSTANCE);
        Some(ViewIndex {
            world_only,
            eye,
            right,
            up,
            fwd,
            pad,
            zpad,
            grid: Listing {
                refs,
                cells,
                apart: near,
            },
        })
    }

    /// What the grid holds.
    pub(crate) fn stats(&self) -> GridStats {
        self.grid.stats(Vec3::from(self.fwd), Some(self.eye))
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> usize {
        self.grid.bytes()
    }

    /// The depth per unit length of `ray` along the view direction and the cells it
    /// crosses (`[x0, x1]`, `[y0, y1]`), or `None` when the grid does not serve it (not from
    /// the eye, outside the window, crowded cells).
    #[inline(always)]
    fn cells_of(&self, ray: &Ray) -> Option<(f32, [usize; 2], [usize; 2])> {
        if ray.origin != self.eye {
            return None;
        }
        let d = Vec3A::from(ray.dir);
        let z = d.dot(self.fwd);
        if !(z > 0.0) {
            return None;
        }
        let (s, t) = (d.dot(self.right) / z, d.dot(self.up) / z);
        let (s, t) = ([s - self.pad, s + self.pad], [t - self.pad, t + self.pad]);
        let (lo, hi) = (self.grid.cells.lo, self.grid.cells.hi());
        // Outside the window (or NaN): the walk answers.
        if !(s[0] >= lo[0] && s[1] <= hi[0] && t[0] >= lo[1] && t[1] <= hi[1]) {
            return None;
        }
        let (x, y) = self.grid.cells.cover(s, t)?;
        Some((z, x, y))
    }

    /// [`ViewIndex::cells_of`] for eight rays from the eye with directions `dv` (lane `k`:
    /// ray `k`, per axis), in lanes:
    /// their depths per unit length, the lanes the window serves (bit `k`), and per lane
    /// its cells `x0, x1, y0, y1` (meaningful in served lanes). The arithmetic is
    /// `cells_of`'s, operation by operation; whether the cells are listed is left to
    /// [`Cells::listed`].
    ///
    /// # Safety
    /// AVX2 must be available.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn cells_of_rays(&self, dv: &[__m256; 3]) -> (__m256, u32, [[i32; 8]; 4]) {
        let cells = &self.grid.cells;
        let (lo, hi) = (cells.lo, cells.hi());
        let last = [cells.n[0] as f32 - 1.0, cells.n[1] as f32 - 1.0];
        let mut out = [[0i32; 8]; 4];
        // SAFETY: AVX2 is available (caller); the stores write whole `[i32; 8]` rows.
        unsafe {
            // glam's `dot` on x86: `(x·x' + y·y') + z·z'`.
            macro_rules! dot {
                ($v:expr) => {
                    _mm256_add_ps(
                        _mm256_add_ps(
                            _mm256_mul_ps(dv[0], _mm256_set1_ps($v.x)),
                            _mm256_mul_ps(dv[1], _mm256_set1_ps($v.y)),
                        ),
                        _mm256_mul_ps(dv[2], _mm256_set1_ps($v.z)),
                    )
                };
            }
            let z = dot!(self.fwd);
            let s = _mm256_div_ps(dot!(self.right), z);
            let t = _mm256_div_ps(dot!(self.up), z);
            let pad = _mm256_set1_ps(self.pad);
            let (s0, s1) = (_mm256_sub_ps(s, pad), _mm256_add_ps(s, pad));
            let (t0, t1) = (_mm256_sub_ps(t, pad), _mm256_add_ps(t, pad));
            let ok = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(z, _mm256_setzero_ps()),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(s0, _mm256_set1_ps(lo[0])),
                ),
                _mm256_and_ps(
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_LE_OQ>(s1, _mm256_set1_ps(hi[0])),
                        _mm256_cmp_ps::<_CMP_GE_OQ>(t0, _mm256_set1_ps(lo[1])),
                    ),
                    _mm256_cmp_ps::<_CMP_LE_OQ>(t1, _mm256_set1_ps(hi[1])),
                ),
            );
            // `Cells::span`: `((x - lo) · inv_cell).floor().clamp(0, last)` (in the window,
            // never NaN; where not, the lane is not used).
            let inv = _mm256_set1_ps(cells.inv_cell());
            for (row, (x, k)) in out.iter_mut().zip([(s0, 0), (s1, 0), (t0, 1), (t1, 1)]) {
                let f =
                    _mm256_floor_ps(_mm256_mul_ps(_mm256_sub_ps(x, _mm256_set1_ps(lo[k])), inv));
                let f = _mm256_min_ps(
                    _mm256_max_ps(f, _mm256_setzero_ps()),
                    _mm256_set1_ps(last[k]),
                );
                _mm256_storeu_si256(row.as_mut_ptr() as *mut __m256i, _mm256_cvttps_epi32(f));
            }
            (z, _mm256_movemask_ps(ok) as u32, out)
        }
    }

    /// [`ViewIndex::closest`] for up to eight rays at once, each pack tested against
    /// several of them with the rays in SIMD lanes ([`leaf_rays`]), in groups of rays
    /// crossing the same cells (a pixel's camera rays mostly do), for a grid over the world
    /// level alone: for the rays it serves (bit `k` of the mask returned), `best[k]` and
    /// `found[k]` as `closest` leaves them for `rays[k]` (the same packs in the same order,
    /// the same arithmetic); the others are left to the caller (0: all of them, as for
    /// grids that list instanced packs).
    ///
    /// # Safety
    /// AVX2 must be available.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn closest_rays<F: AlphaFilter, C: Counter>(
        &self,
        lv: &Levels<8>,
        rays: &[Ray],
        f: &F,
        c: &C,
        best: &mut [Best; 8],
        found: &mut [bool; 8],
    ) -> u32 {
        let n = rays.len().min(8);
        if !self.world_only {
            return 0;
        }
        let mut os = [[0.0f32; 3]; 8];
        let mut ds = [[0.0f32; 3]; 8];
        let mut tmax = [0.0f32; 8];
        let mut from_eye = 0u32;
        for (k, ray) in rays.iter().take(8).enumerate() {
            os[k] = ray.origin.to_array();
            ds[k] = ray.dir.to_array();
            tmax[k] = ray.tmax;
            from_eye |= u32::from(ray.origin == self.eye) << k;
        }
        // SAFETY: AVX2 is available (caller); the load reads all of `tmax`.
        unsafe {
            let r = Rays8::new(&os[..n], &ds[..n]);
            let tmax = _mm256_loadu_ps(tmax.as_ptr());
            self.closest_lanes(lv, r, tmax, from_eye & ((1u32 << n) - 1), f, c, best, found)
        }
    }

    /// The eye this grid is for (world space): rays from elsewhere it never serves.
    pub(crate) fn eye(&self) -> Vec3 {
        self.eye
    }

    /// [`ViewIndex::closest_rays`] for the rays of lanes `todo` of `r` (from the eye,
    /// each within lane `k` of `tmax`), already in lanes (a camera's rays as the renderer
    /// makes them: no rays to take apart).
    ///
    /// # Safety
    /// AVX2 must be available; lanes `todo` of `r` start at [`ViewIndex::eye`].
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) unsafe fn closest_lanes<F: AlphaFilter, C: Counter>(
        &self,
        lv: &Levels<8>,
        r: Rays8,
        tmax: __m256,
        todo: u32,
        f: &F,
        c: &C,
        best: &mut [Best; 8],
        found: &mut [bool; 8],
    ) -> u32 {
        if !self.world_only {
            return 0;
        }
        // SAFETY: AVX2 is available (caller).
        let (zv, window, cell) = unsafe { self.cells_of_rays(&r.d) };
        let mut todo = window & todo;
        let mut served = 0u32;
        let packs = &lv.world.packs;
        let pack = |e: &Entry| &packs[self.grid.refs[e.r as usize].pack as usize];
        // SAFETY: AVX2 is available (caller).
        let mut b = unsafe { Bests::new(r, tmax) };
        // SAFETY: AVX2 is available (caller); each load reads one whole `[i32; 8]` row.
        let rows = unsafe { cell.map(|row| _mm256_loadu_si256(row.as_ptr() as *const __m256i)) };
        while todo != 0 {
            // The rays crossing the same cells as the first one left: all four of a lane's
            // cell bounds equal to the first's, compared in lanes.
            let k0 = todo.trailing_zeros() as usize;
            // SAFETY: AVX2 is available (caller).
            let same = unsafe {
                let eq = |i: usize| _mm256_cmpeq_epi32(rows[i], _mm256_set1_epi32(cell[i][k0]));
                let all = _mm256_and_si256(
                    _mm256_and_si256(eq(0), eq(1)),
                    _mm256_and_si256(eq(2), eq(3)),
                );
                _mm256_movemask_ps(_mm256_castsi256_ps(all)) as u32
            };
            let group = same & todo;
            todo &= !group;
            let x = [cell[0][k0] as usize, cell[1][k0] as usize];
            let y = [cell[2][k0] as usize, cell[3][k0] as usize];
            if !self.grid.cells.listed(x, y) {
                continue; // crowded: the walk answers these
            }
            served |= group;
            // SAFETY: AVX2 is available (caller).
            unsafe {
                for e in &self.grid.apart {
                    b.test(lv, pack(e), group, f, c);
                }
                let zpad = _mm256_set1_ps(self.zpad);
                for y in y[0]..=y[1] {
                    for x in x[0]..=x[1] {
                        let mut active = group;
                        for e in self.grid.cells.list(x, y) {
                            // Nearest first: once a pack starts beyond a ray's best hit, so
                            // do the rest, for that ray (`key > t·z + zpad`, as `closest`).
                            let lim = _mm256_add_ps(_mm256_mul_ps(b.t, zv), zpad);
                            let key = _mm256_set1_ps(e.key);
                            let beyond = _mm256_cmp_ps::<_CMP_GT_OQ>(key, lim);
                            active &= !(_mm256_movemask_ps(beyond) as u32);
                            if active == 0 {
                                break;
                            }
                            b.test(lv, pack(e), active, f, c);
                        }
                    }
                }
            }
        }
        // SAFETY: AVX2 is available (caller).
        unsafe { b.write(best, found) };
        served
    }

    /// The closest accepted hit of `ray` nearer than `best.t` (by `tests`, of the levels
    /// this grid was built over, skipping what they skip), written to `best`:
    /// `Some(found)`, or `None` when the grid does not serve this ray (the tree walk
    /// answers it).
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    pub(crate) unsafe fn closest<'a, const W: usize, K: Lanes<W>, F: AlphaFilter, C: Counter>(
        &'a self,
        ray: &Ray,
        tests: &mut PackTests<'a, K, W, F, C>,
        best: &mut Best,
    ) -> Option<bool> {
        let (z, x, y) = self.cells_of(ray)?;
        tests.refs = &self.grid.refs;
        let mut found = false;
        let mut take = |h: Option<(f32, u32, u32, f32, f32)>, best: &mut Best| {
            if let Some((t, inst, prim, b1, b2)) = h {
                *best = Best {
                    t,
                    prim,
                    inst,
                    bary: Vec2::new(b1, b2),
                };
                found = true;
            }
        };
        for e in &self.grid.apart {
            // SAFETY: forwarded.
            take(unsafe { tests.closest(e, best.t) }, best);
        }
        for y in y[0]..=y[1] {
            for x in x[0]..=x[1] {
                for e in self.grid.cells.list(x, y) {
                    // Nearest first: once a pack starts beyond the best hit, so do the rest.
                    if e.key > best.t * z + self.zpad {
                        break;
                    }
                    // SAFETY: forwarded.
                    take(unsafe { tests.closest(e, best.t) }, best);
                }
            }
        }
        Some(found)
    }
}

/// Eight rays' best hits so far, lanes being rays, for [`ViewIndex::closest_rays`].
#[cfg(target_arch = "x86_64")]
struct Bests {
    r: Rays8,
    t: __m256,
    prim: __m256i,
    b1: __m256,
    b2: __m256,
    /// Bit `k`: ray `k` has a hit.
    found: u32,
}

#[cfg(target_arch = "x86_64")]
impl Bests {
    /// Rays `r` with nothing found before lane `k` of `tmax`.
    ///
    /// # Safety
    /// AVX2 must be available.
    #[inline(always)]
    unsafe fn new(r: Rays8, tmax: __m256) -> Bests {
        // SAFETY: AVX2 is available (caller).
        unsafe {
            Bests {
                r,
                t: tmax,
                prim: _mm256_set1_epi32(-1),
                b1: _mm256_setzero_ps(),
                b2: _mm256_setzero_ps(),
                found: 0,
            }
        }
    }

    /// World pack `p` against the rays of `active` (bit `k`: ray `k`), each within its
    /// best `t`: for each, what [`crate::traverse::pack_closest`] gives it, taken as its
    /// best. In lanes: per ray the nearest primitive that hits and counts, ties to the
    /// lower one (`pack_closest`'s order), where an alpha-tested hit counts when its opacity
    /// mask cell is opaque and not when transparent. A ray with a hit the mask leaves
    /// undecided, no farther than that, is answered ray by ray as `pack_closest` does
    /// (the exact matte asked); the others never ask it. (Counted: every hit the masks
    /// decide, where `pack_closest` counts those it reaches in order.)
    ///
    /// # Safety
    /// AVX2 must be available.
    #[inline(always)]
    unsafe fn test<F: AlphaFilter, C: Counter>(
        &mut self,
        lv: &Levels<8>,
        p: &Pack,
        active: u32,
        f: &F,
        c: &C,
    ) {
        for _ in 0..active.count_ones() {
            c.count(crate::Event::Pack);
        }
        // SAFETY: AVX2 is available (caller); stores write whole `[f32; 8]` arrays.
        unsafe {
            // The world level skips nothing here (the rays leave no primitive):
            // `u32::MAX`, as `closest` passes for `PrimRef::NONE`.
            let h = leaf_rays(p, &self.r, self.t, u32::MAX);
            // Per primitive, the rays whose hit counts: all of them without alpha; with it,
            // those the opacity mask calls opaque (no exact lookup). `unknown`: hits only
            // the exact matte can decide.
            let mut accept = [0u32; 4];
            let mut unknown = [0u32; 4];
            let mut l = None;
            for j in 0..4 {
                let hits = h.mask[j] & active;
                if hits == 0 || p.flags[j] & ALPHA == 0 {
                    accept[j] = hits;
                    continue;
                }
                let l = l.get_or_insert_with(|| h.lanes());
                let mut m = hits;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let (b1, b2) = (l.b1[j][k], l.b2[j][k]);
                    match mask_state(&lv.world, &lv.masks, p.flags[j], b1, b2).2 {
                        OPAQUE => {
                            c.count(crate::Event::MaskOpaque);
                            accept[j] |= 1 << k;
                        }
                        TRANSPARENT => c.count(crate::Event::MaskTransparent),
                        _ => unknown[j] |= 1 << k,
                    }
                }
            }
            // Per ray the nearest accepted primitive, ties to the lower one
            // (`pack_closest`'s order).
            let act = lane_mask(active);
            let mut t = _mm256_set1_ps(f32::INFINITY);
            let mut take_any = _mm256_setzero_ps();
            let (mut prim, mut b1, mut b2) = (self.prim, self.b1, self.b2);
            for j in 0..4 {
                if accept[j] == 0 {
                    continue;
                }
                let take = _mm256_and_ps(
                    _mm256_and_ps(lane_mask(accept[j]), act),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(h.t[j], t),
                );
                t = _mm256_blendv_ps(t, h.t[j], take);
                let id = _mm256_castps_si256(_mm256_set1_ps(f32::from_bits(p.id[j])));
                prim = _mm256_castps_si256(_mm256_blendv_ps(
                    _mm256_castsi256_ps(prim),
                    _mm256_castsi256_ps(id),
                    take,
                ));
                b1 = _mm256_blendv_ps(b1, h.b1[j], take);
                b2 = _mm256_blendv_ps(b2, h.b2[j], take);
                take_any = _mm256_or_ps(take_any, take);
            }
            // A ray with an undecided hit no farther than that (at a tie it may come first
            // in `pack_closest`'s order) is answered ray by ray below, as `pack_closest`.
            let mut undecided = 0u32;
            for j in 0..4 {
                if unknown[j] != 0 {
                    let near = _mm256_cmp_ps::<_CMP_LE_OQ>(h.t[j], t);
                    undecided |= unknown[j] & _mm256_movemask_ps(near) as u32;
                }
            }
            let take_any = _mm256_andnot_ps(lane_mask(undecided), take_any);
            self.t = _mm256_blendv_ps(self.t, t, take_any);
            self.prim = _mm256_castps_si256(_mm256_blendv_ps(
                _mm256_castsi256_ps(self.prim),
                _mm256_castsi256_ps(prim),
                take_any,
            ));
            self.b1 = _mm256_blendv_ps(self.b1, b1, take_any);
            self.b2 = _mm256_blendv_ps(self.b2, b2, take_any);
            self.found |= _mm256_movemask_ps(take_any) as u32;
            if undecided == 0 {
                return;
            }
            let l = l.unwrap_or_else(|| h.lanes());
            let (mut bt, mut bp, mut bb1, mut bb2) = ([0.0f32; 8], [0u32; 8], [0.0; 8], [0.0; 8]);
            _mm256_storeu_ps(bt.as_mut_ptr(), self.t);
            _mm256_storeu_si256(bp.as_mut_ptr() as *mut __m256i, self.prim);
            _mm256_storeu_ps(bb1.as_mut_ptr(), self.b1);
            _mm256_storeu_ps(bb2.as_mut_ptr(), self.b2);
            let mut act = undecided;
            while act != 0 {
                let k = act.trailing_zeros() as usize;
                act &= act - 1;
                // `pack_closest` for ray `k`.
                let mut m = 0u32;
                for (j, mask) in h.mask.iter().enumerate() {
                    m |= ((mask >> k) & 1) << j;
                }
                while m != 0 {
                    let i = nearest_lane(m, |j| l.t[j][k]);
                    m &= !(1 << i);
                    let fl = p.flags[i];
                    let (b1, b2) = (l.b1[i][k], l.b2[i][k]);
                    if fl & ALPHA != 0 && !alpha_opaque(&lv.world, &lv.masks, fl, b1, b2, f, c) {
                        continue;
                    }
                    (bt[k], bp[k], bb1[k], bb2[k]) = (l.t[i][k], p.id[i], b1, b2);
                    self.found |= 1 << k;
                    break;
                }
            }
            self.t = _mm256_loadu_ps(bt.as_ptr());
            self.prim = _mm256_loadu_si256(bp.as_ptr() as *const __m256i);
            self.b1 = _mm256_loadu_ps(bb1.as_ptr());
            self.b2 = _mm256_loadu_ps(bb2.as_ptr());
        }
    }

    /// The rays' bests into `best` and `found`.
    ///
    /// # Safety
    /// AVX2 must be available.
    #[inline(always)]
    unsafe fn write(&self, best: &mut [Best; 8], found: &mut [bool; 8]) {
        let (mut t, mut prim, mut b1, mut b2) = ([0.0f32; 8], [0u32; 8], [0.0; 8], [0.0; 8]);
        // SAFETY: AVX2 is available (caller); each store writes a whole 32-byte array.
        unsafe {
            _mm256_storeu_ps(t.as_mut_ptr(), self.t);
            _mm256_storeu_si256(prim.as_mut_ptr() as *mut __m256i, self.prim);
            _mm256_storeu_ps(b1.as_mut_ptr(), self.b1);
            _mm256_storeu_ps(b2.as_mut_ptr(), self.b2);
        }
        for k in 0..8 {
            best[k] = Best {
                t: t[k],
                prim: prim[k],
                inst: crate::NO_INSTANCE,
                bary: Vec2::new(b1[k], b2[k]),
            };
            found[k] = self.found & (1 << k) != 0;
        }
    }
}

/// All-ones lanes where bit `k` of `bits` is set.
///
/// # Safety
/// AVX2 must be available.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn lane_mask(bits: u32) -> __m256 {
    // SAFETY: AVX2 is available (caller).
    unsafe {
        let bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let v = _mm256_and_si256(_mm256_set1_epi32(bits as i32), bit);
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(v, bit))
    }
}
