//! Shadow rays toward a distant light: a grid over the scene as seen from the light.
//!
//! Every shadow ray toward the sun runs (nearly) parallel to one axis. Seen along that
//! axis the scene is a 2D picture, and the primitives a ray can meet are those whose
//! picture covers the point where the ray's origin lands, *ahead* of the origin along the
//! axis. That is the "light buffer" of Haines & Greenberg (1986, "The light buffer: a
//! shadow-testing accelerator"), here exact and over the BVH's own leaf packs:
//!
//! * **Build** ([`DirIndex::build`]): each leaf pack of the world level and of every
//!   instance is placed in world space and projected onto the plane across the axis (`u`,
//!   `v`). A uniform grid over that plane lists, per cell, the packs whose projection
//!   touches it, each with the largest depth along the axis it reaches *inside that cell*
//!   (the planes of its primitives evaluated at the cell's corners), in decreasing order.
//! * **Query** ([`DirIndex::occluded`]): a ray whose direction points along the axis
//!   crosses the cells under its path from its origin to the top of the scene (one cell for
//!   a delta sun, a few for a sun of finite size); in each, the packs are tested in order
//!   until one is hit or the next lies wholly behind the origin. The pack test is the
//!   traversal's own (`pack_any`, with the instance transform, skip and
//!   alpha masks of a tree walk), and the cells are conservative, so the answer is the tree
//!   walk's, bit for bit; only the work differs: a few pack tests instead of a walk down
//!   the tree.
//! * **Eight at a time** (`DirIndex::occluded_rays`, behind `Accel::occluded_many`):
//!   shadow rays whose cells coincide, or join into at most `GROUP_CELLS` (a pixel's
//!   samples' rays toward a sun), run one list walk together, each pack tested against all
//!   of them with the rays in AVX2 lanes; the answers are the one-ray query's, bit for bit.
//!
//! A ray the grid serves poorly (pointing away from the axis, crossing more than
//! [`MAX_CELLS`](crate::grid::MAX_CELLS) cells, or a cell too crowded for a short list) is
//! left to the tree walk.
//! Primitives much larger than the typical one (a ground) do not size the grid: the grid
//! spans the others, lists the large ones in its cells too, and a ray that leaves its area
//! tests them. A ray toward a sun's disc drifts across the grid as it climbs; where a big
//! primitive tilted to the light (a ground) puts the top of the scene far above the others,
//! its cells end at the top of the small packs, and above that it tests the big ones (on
//! `examples/forest.toml`, 44 % less time per sun ray: 3.4 instead of 6.1 packs and 0.27
//! instead of 0.57 tree nodes). A pack that reaches into several of a ray's cells (a leaf
//! wider than a cell under a sun's disc), or that a ray meets in its cells and among the
//! big ones, is tested once per ray (`Seen`: on `examples/pigment_leaves.toml`, a close-up
//! of three cards, 1.0 instead of 3.6-4.1 pack tests per sun ray). Scenes of more than
//! [`MAX_PACKS`](crate::grid::MAX_PACKS) placed packs, or whose grid would exceed
//! [`MAX_ENTRIES`](crate::grid::MAX_ENTRIES), get none.

#[cfg(target_arch = "x86_64")]
use crate::PrimRef;
use crate::grid::{
    Cells, Entry, Footprint, GridStats, LaneFoot, Listing, PackRef, PackTests, median_size,
    sort_entries,
};
#[cfg(target_arch = "x86_64")]
use crate::kernel::LRay;
use crate::kernel::Lanes;
#[cfg(target_arch = "x86_64")]
use crate::kernel::avx2::{Avx2, Rays8, leaf_rays};
#[cfg(target_arch = "x86_64")]
use crate::layout::ALPHA;
use crate::traverse::Levels;
#[cfg(target_arch = "x86_64")]
use crate::traverse::alpha_opaque;
use crate::{AlphaFilter, Counter, Ray};
use glam::{Vec3, Vec3A};
use rayon::prelude::*;

/// Cells `x` range and `y` range (first and last, inclusive).
type Cover = ([usize; 2], [usize; 2]);

/// A primitive this many times the median size is "big": it does not size the grid.
const BIG: f32 = 64.0;
/// Most cells the shadow rays tested together run ([`DirIndex::occluded_rays`]), unless
/// one ray's own cells are more.
const GROUP_CELLS: usize = 4;
/// Fewest shadow rays [`DirIndex::occluded_rays`] tests together; the rays of a smaller
/// group run their own lists one by one, as the one-ray query does.
const MIN_GROUP: usize = 3;

/// The grid of one axis (module docs). Entry keys are the largest depth along the axis
/// the pack reaches in the cell; lists run deepest first.
#[derive(Clone, Debug)]
pub(crate) struct DirIndex {
    axis: Vec3A,
    u: Vec3A,
    v: Vec3A,
    /// Largest depth of any pack: a ray past it meets nothing.
    top: f32,
    /// Largest depth of the packs that are not big (those the grid is sized for): above
    /// it only the big packs (`grid.apart`) can block a ray.
    top_small: f32,
    /// Rounding margin (world units) on depths and cell bounds.
    pad: f32,
    /// The cells, and apart from them the packs larger than the grid is sized for (a
    /// ground): what a ray that leaves the grid's area may meet there; deepest reach first.
    grid: Listing,
    /// Whether every pack listed is the world level's (no instance's): what
    /// [`DirIndex::occluded_rays`] serves.
    world_only: bool,
    /// The short plan of rays along exactly the direction the grid was built for.
    along: Option<Along>,
}

/// What [`DirIndex::plan`] knows ahead of a ray whose direction is, bit for bit, the one
/// the grid was built for (a delta sun's shadow rays, nearly all of a sunlit render's):
/// that direction's components across the axis are rounding noise, so such a ray drifts
/// across the grid by less than `pad` on its way up from any origin at or above `lowest`,
/// and its cells are those under its origin widened by `2·pad` (a superset of the general
/// plan's, so the same answers), without the division and the drift's arithmetic on the
/// query's critical path.
#[derive(Clone, Copy, Debug)]
struct Along {
    /// The direction's bits.
    dir: [u32; 3],
    /// Lowest origin depth along the axis served this way.
    lowest: f32,
}

impl Along {
    /// The short plan for rays along `given` (the direction the grid was asked for, before
    /// its normalisation to `a`, with `u`, `v` across it), for a scene topped at depth
    /// `top` with rounding margin `pad` and cells of side `cell`; `None` where it does not
    /// apply (a direction away from the axis, a margin not below a cell).
    fn new(
        given: Vec3,
        a: Vec3A,
        u: Vec3A,
        v: Vec3A,
        top: f32,
        pad: f32,
        cell: f32,
    ) -> Option<Along> {
        // The products `plan` forms for such a ray, the same operations on the same values.
        let g = Vec3A::from(given);
        let (da, du, dv) = (g.dot(a), g.dot(u), g.dot(v));
        let across = du.abs().max(dv.abs());
        if !(da > 0.5 && across.is_finite() && pad < cell) {
            return None;
        }
        // From depth `d0` to the top the ray drifts `(top - d0) / da · across`: at most a
        // quarter of `pad` from `lowest` up (the factor of four, and the rest of the
        // `2·pad` the cells are widened by, cover the rounding of these products).
        let lowest = if across == 0.0 {
            f32::NEG_INFINITY
        } else {
            top - 0.25 * pad * da / across
        };
        (!lowest.is_nan()).then_some(Along {
            dir: given.to_array().map(f32::to_bits),
            lowest,
        })
    }
}

impl DirIndex {
    /// The grid for shadow rays along `axis` (toward the light) over `lv`'s packs; `None`
    /// for a zero or non-finite axis, or a scene [`crate::grid::pack_refs`] or
    /// [`Cells::fill`] refuses.
    pub(crate) fn build<const W: usize>(lv: &Levels<W>, axis: Vec3) -> Option<DirIndex> {
        let a = Vec3A::from(axis.normalize_or_zero());
        if a == Vec3A::ZERO || !a.is_finite() {
            return None;
        }
        let (u, v) = a.any_orthonormal_pair();
        let (refs, o2w) = crate::grid::pack_refs(lv)?;
        let foot = |r: &PackRef| -> Footprint {
            let lanes = crate::grid::placed_corners(lv, &o2w, *r)
                .into_iter()
                .map(|(k, c)| {
                    let mut poly = [[0.0f32; 2]; 4];
                    let mut depth = [0.0f32; 4];
                    for i in 0..k {
                        poly[i] = [c[i].dot(u), c[i].dot(v)];
                        depth[i] = c[i].dot(a);
                    }
                    let nrm = (c[1] - c[0]).cross(c[2] - c[0]);
                    let (nu, nv, na) = (nrm.dot(u), nrm.dot(v), nrm.dot(a));
                    // Seen nearly edge-on, the plane's depth is ill-conditioned: the
                    // lane's whole depth range serves instead.
                    let plane = (na.abs() > 0.05 * nrm.length())
                        .then(|| [nrm.dot(c[0]) / na, nu / na, nv / na]);
                    LaneFoot::new(poly, depth, k, plane)
                })
                .collect();
            Footprint::new(lanes)
        };
        let feet: Vec<Footprint> = refs.par_iter().map(foot).collect();
        let median = median_size(&feet)?;
        // Packs with a lane far larger than the typical one (a ground, a wall) are not
        // what sizes the grid: it spans the others, and rays that leave it test these.
        let big = |f: &Footprint| f.lanes.iter().any(|l| l.size() > BIG * median);
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        let (mut all_lo, mut all_hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        let (mut top, mut bottom) = (f32::NEG_INFINITY, f32::INFINITY);
        let mut top_small = f32::NEG_INFINITY;
        for f in feet.iter().filter(|f| !f.lanes.is_empty()) {
            let ordinary = !big(f);
            if ordinary {
                top_small = f.lanes.iter().fold(top_small, |m, l| m.max(l.dmax));
            }
            for k in 0..2 {
                all_lo[k] = all_lo[k].min(f.lo[k]);
                all_hi[k] = all_hi[k].max(f.hi[k]);
                if ordinary {
                    lo[k] = lo[k].min(f.lo[k]);
                    hi[k] = hi[k].max(f.hi[k]);
                }
            }
            for l in &f.lanes {
                top = top.max(l.dmax);
                bottom = bottom.min(l.dmin);
            }
        }
        if !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
            // Only large primitives: the grid spans them all.
            (lo, hi) = (all_lo, all_hi);
        }
        let finite = [all_lo, all_hi, lo, hi]
            .iter()
            .flatten()
            .all(|x| x.is_finite());
        if !(finite && top.is_finite() && bottom.is_finite() && median.is_finite()) {
            return None;
        }
        // Rounding of the placed corners and of a query's projection: a few hundred units
        // in the last place of the scene's largest coordinate.
        let scale = [all_lo[0], all_lo[1], all_hi[0], all_hi[1], top, bottom]
            .iter()
            .fold(0.0f32, |m, x| m.max(x.abs()));
        let pad = scale * 256.0 * f32::EPSILON + f32::MIN_POSITIVE;
        let lo = [lo[0] - 2.0 * pad, lo[1] - 2.0 * pad];
        let hi = [hi[0] + 2.0 * pad, hi[1] + 2.0 * pad];
        let mut cells = Cells::new(lo, hi, median, pad);
        // A pack's key in a cell: the largest depth its primitives' planes reach over the
        // cell's corners (within their own depth range).
        let filled = cells.fill(&feet, pad, true, |l, cs, ct| {
            let d = match l.plane {
                Some([c, gu, gv]) => {
                    let mut d = f32::NEG_INFINITY;
                    for s in cs {
                        for t in ct {
                            d = d.max(c - gu * s - gv * t);
                        }
                    }
                    // Rounding of the plane's terms, scaled by its slope.
                    (d + 4.0 * pad * (1.0 + gu.abs() + gv.abs())).min(l.dmax)
                }
                None => l.dmax,
            };
            d.max(l.dmin)
        });
        if !filled {
            return None;
        }
        let mut bigs: Vec<Entry> = feet
            .iter()
            .enumerate()
            .filter(|(_, f)| !f.lanes.is_empty() && big(f))
            .map(|(ri, f)| Entry {
                key: f.lanes.iter().fold(f32::NEG_INFINITY, |m, l| m.max(l.dmax)),
                r: ri as u32,
            })
            .collect();
        sort_entries(&mut bigs, true);
        let world_only = refs.iter().all(|r| r.inst == crate::NO_INSTANCE);
        let along = Along::new(axis, a, u, v, top + pad, pad, cells.cell);
        Some(DirIndex {
            axis: a,
            u,
            v,
            top: top + pad,
            // Only big packs: the grid spans them, and `top` serves.
            top_small: if top_small.is_finite() {
                (top_small + pad).min(top + pad)
            } else {
                top + pad
            },
            pad,
            grid: Listing {
                refs,
                cells,
                apart: bigs,
            },
            world_only,
            along,
        })
    }

    /// The lowest origin depth the short plan serves, if the grid has one (tests).
    #[cfg(test)]
    pub(crate) fn along_lowest(&self) -> Option<f32> {
        self.along.map(|a| a.lowest)
    }

    /// Whether `ray` takes the short plan (tests).
    #[cfg(test)]
    pub(crate) fn takes_short_plan(&self, ray: &Ray) -> bool {
        let d0 = Vec3A::from(ray.origin).dot(self.axis);
        d0 < self.top && self.along_serves(ray, d0)
    }

    /// Largest depth of any pack along the axis, with its margin (tests).
    #[cfg(test)]
    pub(crate) fn top(&self) -> f32 {
        self.top
    }

    /// The point at `s`, `q` across the axis and depth `d` along it (tests).
    #[cfg(test)]
    pub(crate) fn point(&self, s: f32, q: f32, d: f32) -> Vec3 {
        Vec3::from(self.u * s + self.v * q + self.axis * d)
    }

    /// The grid's lower corner, cell side and cells across (tests).
    #[cfg(test)]
    pub(crate) fn layout(&self) -> ([f32; 2], f32, [usize; 2]) {
        let c = &self.grid.cells;
        (c.lo, c.cell, c.n)
    }

    /// `ray`'s cells and whether it tests the packs apart, by the plan with the short one
    /// when `short`, else the general plan; `None` for a ray without lists (tests).
    #[cfg(test)]
    pub(crate) fn cells_of(&self, ray: &Ray, short: bool) -> Option<(Option<Cover>, bool)> {
        match self.plan_with(ray, short) {
            Plan::Lists {
                cover, off_grid, ..
            } => Some((cover, off_grid)),
            _ => None,
        }
    }

    /// What the grid holds.
    pub(crate) fn stats(&self) -> GridStats {
        self.grid.stats(Vec3::from(self.axis), None)
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> usize {
        self.grid.bytes()
    }

    /// Where `ray` stands with the grid: not served, answered without a pack test, or the
    /// cells (and the packs apart) whose lists it runs. One function for the one-ray and
    /// the eight-ray queries, so that both run the same lists for every ray.
    #[inline(always)]
    fn plan(&self, ray: &Ray) -> Plan {
        self.plan_with(ray, true)
    }

    /// [`DirIndex::plan`], with the short plan for rays along the grid's own direction
    /// when `short` (the general one for every ray otherwise: tests compare the two).
    #[inline(always)]
    fn plan_with(&self, ray: &Ray, short: bool) -> Plan {
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.dir);
        let da = d.dot(self.axis);
        if !(da > 0.0) {
            return Plan::Walk;
        }
        let d0 = o.dot(self.axis);
        if !(d0 < self.top) {
            // Past every primitive toward the light (or a NaN origin: the walk decides).
            return if d0 >= self.top {
                Plan::Answer(false)
            } else {
                Plan::Walk
            };
        }
        if short && self.along_serves(ray, d0) {
            // Along the grid's own direction: the drift is below `pad` (`Along`).
            let (s0, q0) = (o.dot(self.u), o.dot(self.v));
            let m = 2.0 * self.pad;
            return self.lists([s0 - m, s0 + m], [q0 - m, q0 + m], false, d0);
        }
        // Where the ray is when it climbs past the top of the scene (or ends).
        let t_all = ((self.top - d0) / da).min(ray.tmax);
        let (du, dv) = (d.dot(self.u), d.dot(self.v));
        // A ray across the axis (toward a sun's disc) drifts over the grid as it climbs.
        // Above the small packs only the big ones (`apart`) can block it, so where it
        // would drift across more than a cell (a big ground tilted to the light sets the
        // top far above the small packs), its cells end there and it tests those apart.
        let capped =
            self.top_small < self.top && t_all * du.abs().max(dv.abs()) > self.grid.cells.cell;
        let (t_end, past) = if capped {
            let t = if d0 < self.top_small {
                ((self.top_small - d0) / da).min(ray.tmax)
            } else {
                0.0
            };
            (t, t < t_all)
        } else {
            (t_all, false)
        };
        let (s0, q0) = (o.dot(self.u), o.dot(self.v));
        let (s1, q1) = (s0 + t_end * du, q0 + t_end * dv);
        let s = [s0.min(s1) - self.pad, s0.max(s1) + self.pad];
        let q = [q0.min(q1) - self.pad, q0.max(q1) + self.pad];
        self.lists(s, q, past, d0)
    }

    /// Whether `ray`, from origin depth `d0` below the top, takes the short plan
    /// ([`Along`]): its direction is the grid's own, bit for bit, and it starts no lower
    /// than the drift bound reaches.
    #[inline(always)]
    fn along_serves(&self, ray: &Ray, d0: f32) -> bool {
        self.along
            .as_ref()
            .is_some_and(|a| ray.dir.to_array().map(f32::to_bits) == a.dir && d0 >= a.lowest)
    }

    /// [`DirIndex::plan`]'s end: the lists of a ray over `s × q` across the axis, past the
    /// small packs' top when `past`, from origin depth `d0`.
    #[inline(always)]
    fn lists(&self, s: [f32; 2], q: [f32; 2], past: bool, d0: f32) -> Plan {
        if !(s[0] <= s[1] && q[0] <= q[1]) {
            return Plan::Walk; // NaN: the walk decides
        }
        let (lo, hi) = (self.grid.cells.lo, self.grid.cells.hi());
        let on_grid = s[1] >= lo[0] && s[0] <= hi[0] && q[1] >= lo[1] && q[0] <= hi[1];
        let off_grid = s[0] < lo[0] || s[1] > hi[0] || q[0] < lo[1] || q[1] > hi[1] || past;
        let cover = if on_grid {
            match self.grid.cells.cover(s, q) {
                Some(c) => Some(c),
                None => return Plan::Walk,
            }
        } else {
            None
        };
        Plan::Lists {
            cover,
            off_grid,
            behind: d0 - self.pad,
        }
    }

    /// Whether `ray` meets an accepted primitive within `(0, tmax)` (by `tests`, of the
    /// levels this grid was built over, skipping what they skip): `None` when the grid does
    /// not serve this ray (the tree walk answers it).
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    pub(crate) unsafe fn occluded<'a, const W: usize, K: Lanes<W>, F: AlphaFilter, C: Counter>(
        &'a self,
        ray: &Ray,
        tests: &mut PackTests<'a, K, W, F, C>,
    ) -> Option<bool> {
        match self.plan(ray) {
            Plan::Walk => None,
            Plan::Answer(a) => Some(a),
            Plan::Lists {
                cover,
                off_grid,
                behind,
            } => {
                // SAFETY: forwarded.
                Some(unsafe { self.run_lists(cover, off_grid, behind, ray.tmax, tests) })
            }
        }
    }

    /// Whether the packs of a ray's lists ([`Plan::Lists`]: the cells `cover`, the packs
    /// apart when `off_grid`; only those reaching above `behind`) block it within `tmax`
    /// (by `tests`, holding the ray).
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    unsafe fn run_lists<'a, const W: usize, K: Lanes<W>, F: AlphaFilter, C: Counter>(
        &'a self,
        cover: Option<Cover>,
        off_grid: bool,
        behind: f32,
        tmax: f32,
        tests: &mut PackTests<'a, K, W, F, C>,
    ) -> bool {
        // A pack reaching into several of the ray's cells (a leaf wider than a cell, under
        // a sun's disc), or listed in its cells and apart (a ground), is tested once
        // ([`Seen`]). One cell and nothing apart list each pack once: no bookkeeping there
        // (a walk of its own, so that the common case runs as it did without it).
        if several(cover, off_grid) {
            // SAFETY: forwarded.
            unsafe { self.walk_lists::<W, K, F, C, true>(cover, off_grid, behind, tmax, tests) }
        } else {
            // SAFETY: forwarded.
            unsafe { self.walk_lists::<W, K, F, C, false>(cover, off_grid, behind, tmax, tests) }
        }
    }

    /// [`DirIndex::run_lists`], packs met again skipped when `DEDUP`.
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    unsafe fn walk_lists<
        'a,
        const W: usize,
        K: Lanes<W>,
        F: AlphaFilter,
        C: Counter,
        const DEDUP: bool,
    >(
        &'a self,
        cover: Option<Cover>,
        off_grid: bool,
        behind: f32,
        tmax: f32,
        tests: &mut PackTests<'a, K, W, F, C>,
    ) -> bool {
        tests.refs = &self.grid.refs;
        // (No closure for the test: it would be compiled without the caller's target
        // features.)
        let mut seen = Seen::new();
        if let Some((x, y)) = cover {
            for y in y[0]..=y[1] {
                for x in x[0]..=x[1] {
                    for e in self.grid.cells.list(x, y) {
                        if e.key <= behind {
                            break;
                        }
                        if DEDUP && seen.untested(e.r, 1) == 0 {
                            continue;
                        }
                        // SAFETY: forwarded.
                        if unsafe { tests.any(e, tmax) } {
                            return true;
                        }
                    }
                }
            }
        }
        if off_grid {
            // Beyond the grid (or above the small packs) only the big packs reach.
            for e in &self.grid.apart {
                if e.key <= behind {
                    break;
                }
                if DEDUP && seen.untested(e.r, 1) == 0 {
                    continue;
                }
                // SAFETY: forwarded.
                if unsafe { tests.any(e, tmax) } {
                    return true;
                }
            }
        }
        false
    }

    /// [`DirIndex::plan`] of the rays of `todo` among `r`'s eight (`tmax` theirs) in SIMD
    /// lanes, the same operations in the same order, so the same numbers (no FMA; where
    /// `plan`'s `min` and `max` would drop a NaN, the operands stand so that these do too):
    /// each ray's plan (`Walk` outside `todo`), and in lanes the depths `behind` (`∞` for
    /// rays without lists).
    ///
    /// # Safety
    /// AVX2 must be available.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn plans8(
        &self,
        r: &Rays8,
        tmax: std::arch::x86_64::__m256,
        todo: u32,
    ) -> ([Plan; 8], std::arch::x86_64::__m256) {
        use std::arch::x86_64::*;
        let mut plans = [Plan::Walk; 8];
        let mut behind = [f32::INFINITY; 8];
        // SAFETY: AVX2 is available (caller); the stores write whole `[f32; 8]` /
        // `[i32; 8]` arrays.
        unsafe {
            let da = dot8(&r.d, self.axis);
            let d0 = dot8(&r.o, self.axis);
            let top = _mm256_set1_ps(self.top);
            // `((top - d0) / da).min(tmax)`: a NaN `tmax` yields the quotient.
            let t_all = _mm256_min_ps(tmax, _mm256_div_ps(_mm256_sub_ps(top, d0), da));
            let (du, dv) = (dot8(&r.d, self.u), dot8(&r.d, self.v));
            // `plan`'s cells capped at the small packs' top, for rays drifting across
            // more than a cell (served rays have no NaN in `du`, `dv`).
            let abs = _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX));
            let drift = _mm256_mul_ps(
                t_all,
                _mm256_max_ps(_mm256_and_ps(du, abs), _mm256_and_ps(dv, abs)),
            );
            let capped = if self.top_small < self.top {
                _mm256_cmp_ps::<_CMP_GT_OQ>(drift, _mm256_set1_ps(self.grid.cells.cell))
            } else {
                _mm256_setzero_ps()
            };
            let small = _mm256_set1_ps(self.top_small);
            let t_cap = _mm256_and_ps(
                _mm256_min_ps(tmax, _mm256_div_ps(_mm256_sub_ps(small, d0), da)),
                _mm256_cmp_ps::<_CMP_LT_OQ>(d0, small),
            );
            let t_end = _mm256_blendv_ps(t_all, t_cap, capped);
            let past = _mm256_and_ps(capped, _mm256_cmp_ps::<_CMP_LT_OQ>(t_cap, t_all));
            let past = _mm256_movemask_ps(past) as u32;
            let (s0, q0) = (dot8(&r.o, self.u), dot8(&r.o, self.v));
            let s1 = _mm256_add_ps(s0, _mm256_mul_ps(t_end, du));
            let q1 = _mm256_add_ps(q0, _mm256_mul_ps(t_end, dv));
            // `s0.min(s1)` and `s0.max(s1)`: a NaN `s1` yields `s0`.
            let pad = _mm256_set1_ps(self.pad);
            let ends = [
                _mm256_sub_ps(_mm256_min_ps(s1, s0), pad),
                _mm256_add_ps(_mm256_max_ps(s1, s0), pad),
                _mm256_sub_ps(_mm256_min_ps(q1, q0), pad),
                _mm256_add_ps(_mm256_max_ps(q1, q0), pad),
            ];
            // `Cells::span` of each end: a NaN lands in cell 0 as `as usize` puts it.
            let cells = &self.grid.cells;
            let inv = _mm256_set1_ps(cells.inv_cell());
            let mut at = [[0i32; 8]; 4];
            let mut e = [[0.0f32; 8]; 4];
            for (i, end) in ends.iter().enumerate() {
                let k = i / 2;
                let last = _mm256_set1_ps(cells.n[k] as f32 - 1.0);
                let x = _mm256_mul_ps(_mm256_sub_ps(*end, _mm256_set1_ps(cells.lo[k])), inv);
                let x = _mm256_min_ps(_mm256_max_ps(_mm256_floor_ps(x), _mm256_setzero_ps()), last);
                _mm256_storeu_si256(at[i].as_mut_ptr() as *mut __m256i, _mm256_cvttps_epi32(x));
                _mm256_storeu_ps(e[i].as_mut_ptr(), *end);
            }
            let (mut dal, mut d0l) = ([0.0f32; 8], [0.0f32; 8]);
            _mm256_storeu_ps(dal.as_mut_ptr(), da);
            _mm256_storeu_ps(d0l.as_mut_ptr(), d0);
            let (lo, hi) = (cells.lo, cells.hi());
            let mut m = todo;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                if !(dal[k] > 0.0) {
                    continue;
                }
                if !(d0l[k] < self.top) {
                    if d0l[k] >= self.top {
                        plans[k] = Plan::Answer(false);
                    }
                    continue;
                }
                let (s, q) = ([e[0][k], e[1][k]], [e[2][k], e[3][k]]);
                if !(s[0] <= s[1] && q[0] <= q[1]) {
                    continue;
                }
                let on_grid = s[1] >= lo[0] && s[0] <= hi[0] && q[1] >= lo[1] && q[0] <= hi[1];
                let off_grid = s[0] < lo[0]
                    || s[1] > hi[0]
                    || q[0] < lo[1]
                    || q[1] > hi[1]
                    || past & (1 << k) != 0;
                let cover = if on_grid {
                    let x = [at[0][k] as usize, at[1][k] as usize];
                    let y = [at[2][k] as usize, at[3][k] as usize];
                    if !cells.listed(x, y) {
                        continue;
                    }
                    Some((x, y))
                } else {
                    None
                };
                behind[k] = d0l[k] - self.pad;
                plans[k] = Plan::Lists {
                    cover,
                    off_grid,
                    behind: behind[k],
                };
            }
            (plans, _mm256_loadu_ps(behind.as_ptr()))
        }
    }

    /// [`DirIndex::occluded`] for the rays of `todo` (bit `k`: `rays[k]`, at most eight,
    /// leaving world primitive `skips[k]`, `u32::MAX` for none) at once, for a grid over
    /// the world level alone: rays that run the same lists are tested together, each pack
    /// against all of them with the rays in SIMD lanes ([`leaf_rays`], `leaf4`'s arithmetic
    /// turned around, so that every ray's hits are `occluded`'s bit for bit), each ray
    /// against the packs `occluded` tests it against (those reaching above its origin)
    /// until it is blocked. Returns the rays served (none for a grid listing instanced
    /// packs); for them, bit `k` of `occ` is set when `rays[k]` is blocked, cleared
    /// otherwise.
    ///
    /// # Safety
    /// AVX2 must be available.
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(crate) unsafe fn occluded_rays<F: AlphaFilter, C: Counter>(
        &self,
        lv: &Levels<8>,
        rays: &[Ray],
        skips: &[u32; 8],
        todo: u32,
        f: &F,
        c: &C,
        occ: &mut u32,
    ) -> u32 {
        use std::arch::x86_64::*;
        if !self.world_only {
            return 0;
        }
        let n = rays.len().min(8);
        let todo = todo & ((1u32 << n) - 1);
        let mut tmax = [0.0f32; 8];
        let mut os = [[0.0f32; 3]; 8];
        let mut ds = [[0.0f32; 3]; 8];
        for k in 0..n {
            os[k] = rays[k].origin.to_array();
            ds[k] = rays[k].dir.to_array();
            tmax[k] = rays[k].tmax;
        }
        // SAFETY: AVX2 is available (caller); the load reads all of `tmax`.
        let (r, tmaxv) = unsafe {
            (
                Rays8::new(&os[..n], &ds[..n]),
                _mm256_loadu_ps(tmax.as_ptr()),
            )
        };
        // SAFETY: AVX2 is available (caller).
        let (plans, behind) = unsafe { self.plans8(&r, tmaxv, todo) };
        let (mut served, mut lists) = (0u32, 0u32);
        for k in 0..n {
            match plans[k] {
                Plan::Walk => {}
                Plan::Answer(a) => {
                    served |= 1 << k;
                    *occ = (*occ & !(1 << k)) | (u32::from(a) << k);
                }
                Plan::Lists { .. } => {
                    served |= 1 << k;
                    lists |= 1 << k;
                    *occ &= !(1 << k);
                }
            }
        }
        if lists == 0 {
            return served;
        }
        // SAFETY: AVX2 is available (caller); the load reads all of `skips`.
        let rs = unsafe {
            SunRays {
                lv,
                refs: &self.grid.refs,
                r,
                tmax: tmaxv,
                behind,
                skip: _mm256_loadu_si256(skips.as_ptr() as *const __m256i),
                f,
                c,
            }
        };
        // SAFETY: AVX2 is available (caller).
        unsafe {
            let mut left = lists;
            while left != 0 {
                // The first ray left and those whose cells, joined to the group's, stay
                // within a few (a finite sun's rays from one spot drift across a cell
                // border apart): every ray of the group runs the lists of all the group's
                // cells. Packs a ray's own cells do not list cannot block it, so testing
                // them changes no answer.
                let k0 = left.trailing_zeros() as usize;
                let Plan::Lists {
                    mut cover,
                    mut off_grid,
                    ..
                } = plans[k0]
                else {
                    unreachable!("`lists` holds rays with lists only")
                };
                let mut group = 1u32 << k0;
                for k in k0 + 1..n {
                    let Plan::Lists {
                        cover: ck,
                        off_grid: ok,
                        ..
                    } = plans[k]
                    else {
                        continue;
                    };
                    if left & (1 << k) == 0 {
                        continue;
                    }
                    let joined = match (cover, ck) {
                        (None, None) => Some(None),
                        (Some(a), Some(b)) => {
                            let u = (
                                [a.0[0].min(b.0[0]), a.0[1].max(b.0[1])],
                                [a.1[0].min(b.1[0]), a.1[1].max(b.1[1])],
                            );
                            let cells = (u.0[1] - u.0[0] + 1) * (u.1[1] - u.1[0] + 1);
                            (u == a || cells <= GROUP_CELLS).then_some(Some(u))
                        }
                        _ => None,
                    };
                    if let Some(u) = joined {
                        cover = u;
                        off_grid |= ok;
                        group |= 1 << k;
                    }
                }
                left &= !group;
                if (group.count_ones() as usize) < MIN_GROUP {
                    // Too few to share the lanes: each runs its own lists as the one-ray
                    // query does (fewer operations than eight lanes of which one or two
                    // are used), from the plan already made.
                    let mut m = group;
                    while m != 0 {
                        let k = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let Plan::Lists {
                            cover,
                            off_grid,
                            behind,
                        } = plans[k]
                        else {
                            unreachable!("`lists` holds rays with lists only")
                        };
                        let wr = LRay {
                            o: os[k],
                            d: ds[k],
                            skip: skips[k],
                        };
                        let tr = Avx2::prep(&wr);
                        let skip = PrimRef {
                            inst: crate::NO_INSTANCE,
                            prim: skips[k],
                        };
                        let (o, d) = (Vec3A::from(os[k]), Vec3A::from(ds[k]));
                        let mut tests =
                            PackTests::<Avx2, 8, F, C>::new(lv, o, d, skip, &tr, skips[k], f, c);
                        if self.run_lists(cover, off_grid, behind, tmax[k], &mut tests) {
                            *occ |= 1 << k;
                        }
                    }
                    continue;
                }
                let mut open = group;
                // Packs met in several of the group's lists are tested once per ray, as
                // in `run_lists`.
                let several = several(cover, off_grid);
                let mut seen = Seen::new();
                if let Some((x, y)) = cover {
                    'cells: for y in y[0]..=y[1] {
                        for x in x[0]..=x[1] {
                            let list = self.grid.cells.list(x, y);
                            open &= !rs.run(list, open, several.then_some(&mut seen));
                            if open == 0 {
                                break 'cells;
                            }
                        }
                    }
                }
                if off_grid && open != 0 {
                    // Beyond the grid only the big packs reach.
                    open &= !rs.run(&self.grid.apart, open, several.then_some(&mut seen));
                }
                *occ |= group & !open;
            }
        }
        served
    }
}

/// Whether a walk over the cells `cover` and, when `off_grid`, the packs apart may meet a
/// pack twice: several cells, or cells and the packs apart (listed in their cells too).
#[inline(always)]
fn several(cover: Option<Cover>, off_grid: bool) -> bool {
    match cover {
        Some((x, y)) => off_grid || x[0] != x[1] || y[0] != y[1],
        None => false,
    }
}

/// The packs a walk over several lists has tested, and against which rays (bit `k`: ray
/// `k` of a group; bit 0 alone for one ray), the last [`Seen::SLOTS`] packs: a pack met
/// again among those is tested only against rays it was not tested against (an older one
/// may be tested again). A pack's test is the whole pack against the ray, so a second one
/// would answer as the first.
struct Seen {
    refs: [u32; Seen::SLOTS],
    rays: [u32; Seen::SLOTS],
    next: usize,
}

impl Seen {
    const SLOTS: usize = 4;

    #[inline(always)]
    fn new() -> Seen {
        Seen {
            refs: [u32::MAX; Seen::SLOTS],
            rays: [0; Seen::SLOTS],
            next: 0,
        }
    }

    /// The rays of `live` that pack reference `r` has not been tested against (among the
    /// last few packs), noted as tested now.
    #[inline(always)]
    fn untested(&mut self, r: u32, live: u32) -> u32 {
        for (s, m) in self.refs.iter().zip(self.rays.iter_mut()) {
            if *s == r {
                let new = live & !*m;
                *m |= live;
                return new;
            }
        }
        self.refs[self.next] = r;
        self.rays[self.next] = live;
        self.next = (self.next + 1) % Seen::SLOTS;
        live
    }
}

/// Up to eight shadow rays in SIMD lanes, for [`DirIndex::occluded_rays`] (methods, not
/// closures: a closure is compiled without its caller's AVX2 target feature, and its
/// intrinsics became calls).
#[cfg(target_arch = "x86_64")]
struct SunRays<'a, F, C> {
    lv: &'a Levels<8>,
    refs: &'a [PackRef],
    r: Rays8,
    /// Per ray: `tmax`, the depth no pack reaching at most that can block it, and the
    /// world primitive it leaves.
    tmax: std::arch::x86_64::__m256,
    behind: std::arch::x86_64::__m256,
    skip: std::arch::x86_64::__m256i,
    f: &'a F,
    c: &'a C,
}

#[cfg(target_arch = "x86_64")]
impl<F: AlphaFilter, C: Counter> SunRays<'_, F, C> {
    /// The rays of `live` (bit `k`: ray `k`) that entry `e`'s pack blocks: `pack_any`'s
    /// answer for each.
    ///
    /// # Safety
    /// AVX2 must be available.
    #[inline(always)]
    unsafe fn test(&self, e: &Entry, live: u32) -> u32 {
        use std::arch::x86_64::*;
        for _ in 0..live.count_ones() {
            self.c.count(crate::Event::Pack);
        }
        let world = &self.lv.world;
        let p = &world.packs[self.refs[e.r as usize].pack as usize];
        // SAFETY: AVX2 is available (caller).
        unsafe {
            // Every lane tested, each ray's own primitive dropped from its hits below
            // (`leaf_rays` passes over the empty lanes, whose id is `u32::MAX`).
            let h = leaf_rays(p, &self.r, self.tmax, u32::MAX);
            let mut blocked = 0u32;
            let mut l = None;
            for j in 0..4 {
                let own = _mm256_cmpeq_epi32(self.skip, _mm256_set1_epi32(p.id[j] as i32));
                let own = _mm256_movemask_ps(_mm256_castsi256_ps(own)) as u32;
                let hits = h.mask[j] & live & !own & !blocked;
                if hits == 0 {
                    continue;
                }
                let fl = p.flags[j];
                if fl & ALPHA == 0 {
                    blocked |= hits;
                    continue;
                }
                let l = l.get_or_insert_with(|| h.lanes());
                let mut m = hits;
                while m != 0 {
                    let k = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let (b1, b2) = (l.b1[j][k], l.b2[j][k]);
                    if alpha_opaque(world, &self.lv.masks, fl, b1, b2, self.f, self.c) {
                        blocked |= 1 << k;
                    }
                }
            }
            blocked
        }
    }

    /// The packs of `list` reaching above each ray's origin (deepest first, as
    /// `occluded` runs them), against the rays of `open`: the rays blocked.
    ///
    /// # Safety
    /// AVX2 must be available.
    #[inline(always)]
    unsafe fn run(&self, list: &[Entry], open: u32, seen: Option<&mut Seen>) -> u32 {
        use std::arch::x86_64::*;
        let mut live = open;
        let mut blocked = 0u32;
        let mut seen = seen;
        for e in list {
            // SAFETY: AVX2 is available (caller).
            unsafe {
                let above = _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_set1_ps(e.key), self.behind);
                live &= _mm256_movemask_ps(above) as u32;
                if live == 0 {
                    break;
                }
                let rays = match seen.as_deref_mut() {
                    Some(s) => s.untested(e.r, live),
                    None => live,
                };
                if rays == 0 {
                    continue;
                }
                let b = self.test(e, rays);
                blocked |= b;
                live &= !b;
            }
        }
        blocked
    }
}

/// `v · a` in eight lanes, as glam's `Vec3A::dot`: `(x x' + y y') + z z'`.
///
/// # Safety
/// AVX must be available.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn dot8(v: &[std::arch::x86_64::__m256; 3], a: Vec3A) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    // SAFETY: AVX is available (caller).
    unsafe {
        _mm256_add_ps(
            _mm256_add_ps(
                _mm256_mul_ps(v[0], _mm256_set1_ps(a.x)),
                _mm256_mul_ps(v[1], _mm256_set1_ps(a.y)),
            ),
            _mm256_mul_ps(v[2], _mm256_set1_ps(a.z)),
        )
    }
}

/// What [`DirIndex::plan`] finds for a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Plan {
    /// Not served: the tree walk answers.
    Walk,
    /// Answered without a pack test (blocked or not).
    Answer(bool),
    /// The lists of the cells `cover` (`x` range, `y` range; none when the ray stays off
    /// the grid's area) and, when it leaves that area (`off_grid`), the big packs apart;
    /// packs reaching no higher than `behind` cannot block it.
    Lists {
        cover: Option<Cover>,
        off_grid: bool,
        behind: f32,
    },
}
