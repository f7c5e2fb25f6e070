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
//!   traversal's own ([`crate::traverse::pack_any`], with the instance transform, skip and
//!   alpha masks of a tree walk), and the cells are conservative, so the answer is the tree
//!   walk's, bit for bit; only the work differs: a few pack tests instead of a walk down
//!   the tree.
//!
//! A ray the grid serves poorly (pointing away from the axis, crossing more than
//! [`MAX_CELLS`] cells, or a cell too crowded for a short list) is left to the tree walk.
//! Primitives much larger than the typical one (a ground) do not size the grid: the grid
//! spans the others, lists the large ones in its cells too, and a ray that leaves its area
//! tests them. Scenes of more than [`MAX_PACKS`] placed packs, or whose grid would exceed
//! [`MAX_ENTRIES`], get none.

use crate::kernel::Lanes;
use crate::layout::Pack;
use crate::traverse::{Levels, pack_any};
use crate::{AlphaFilter, Counter, NO_INSTANCE, PrimRef, Ray};
use glam::{Affine3A, Vec3, Vec3A};
use rayon::prelude::*;

/// Most cells one query crosses before the tree walk is cheaper.
pub const MAX_CELLS: usize = 16;
/// Most leaf packs, placed in world space, a grid is built over. The grid pays for
/// itself on scenes of up to a few hundred thousand primitives (the benchmark scenes: a
/// tenth less time per frame); on a 100 000-leaf instanced tree it saved 5 % of the frame
/// but took ten times the tree's build time and six times its memory, so larger scenes
/// keep the walk.
pub const MAX_PACKS: usize = 1 << 18;
/// Most grid entries (pack, cell pairs, 8 bytes each) a grid may hold.
pub const MAX_ENTRIES: usize = 1 << 23;
/// Most cells of a grid.
const MAX_GRID: usize = 1 << 22;
/// Cell side relative to the median projected size of a primitive.
const CELL_OF_LANE: f32 = 0.5;
/// A primitive this many times the median size is "big": it does not size the grid.
const BIG: f32 = 64.0;
/// Most packs listed in one cell; a more crowded cell leaves its rays to the tree walk.
const MAX_CELL_ENTRIES: usize = 64;

/// One pack of the grid: the world's (`inst == NO_INSTANCE`) or an instance's.
#[derive(Clone, Copy, Debug)]
struct PackRef {
    inst: u32,
    pack: u32,
}

/// A pack listed in a cell: the largest depth along the axis it reaches in the cell, and
/// the index of its [`PackRef`].
#[derive(Clone, Copy, Debug)]
struct Entry {
    dmax: f32,
    r: u32,
}

/// What a built grid holds, for reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionStats {
    /// Unit axis toward the light.
    pub axis: Vec3,
    /// Leaf packs listed (world and instances).
    pub packs: usize,
    /// Grid size (cells across `u`, across `v`).
    pub cells: (usize, usize),
    /// Cell side (world units).
    pub cell: f32,
    /// Pack-in-cell entries.
    pub entries: usize,
    /// Bytes held.
    pub bytes: usize,
}

/// The grid of one axis (module docs).
#[derive(Clone, Debug)]
pub(crate) struct DirIndex {
    axis: Vec3A,
    u: Vec3A,
    v: Vec3A,
    /// Lower corner of the grid in (u, v).
    lo: [f32; 2],
    cell: f32,
    inv_cell: f32,
    n: [usize; 2],
    /// Largest depth of any pack: a ray past it meets nothing.
    top: f32,
    /// Rounding margin (world units) on depths and cell bounds.
    pad: f32,
    refs: Vec<PackRef>,
    /// Per cell (row-major, `u` fastest), its entries' range in `entries`.
    start: Vec<u32>,
    entries: Vec<Entry>,
    /// Bit per cell: too crowded for a list, its rays take the tree walk.
    walk: Vec<u64>,
    /// The packs larger than the grid is sized for (a ground): what a ray that leaves the
    /// grid's area may meet there; deepest reach first.
    big: Vec<Entry>,
}

/// The primitives of one pack placed in world space: per used lane its corners (3, or 4
/// for a parallelogram).
fn pack_corners(p: &Pack, m: Option<&Affine3A>) -> Vec<(usize, [Vec3A; 4])> {
    let mut out = Vec::with_capacity(4);
    for l in 0..4 {
        if p.id[l] == u32::MAX {
            continue;
        }
        let g = |a: &[[f32; 4]; 3]| Vec3A::new(a[0][l], a[1][l], a[2][l]);
        let (v0, e1, e2) = (g(&p.v0), g(&p.e1), g(&p.e2));
        let quad = p.tri[l] == 0.0;
        let mut c = [v0, v0 + e1, v0 + e2, if quad { v0 + e1 + e2 } else { v0 }];
        if let Some(m) = m {
            for q in &mut c {
                *q = m.transform_point3a(*q);
            }
        }
        out.push((if quad { 4 } else { 3 }, c));
    }
    out
}

/// A pack as the grid sees it: per lane, its projected corners and depth range and the
/// plane `depth = c - gu·u - gv·v` (`None` when the lane is seen edge-on).
struct Footprint {
    lo: [f32; 2],
    hi: [f32; 2],
    lanes: Vec<LaneFoot>,
}

struct LaneFoot {
    dmin: f32,
    dmax: f32,
    plane: Option<[f32; 3]>,
    /// Projected bounds.
    lo: [f32; 2],
    hi: [f32; 2],
    /// Projected corners in order around the outline (3 or 4 used).
    poly: [[f32; 2]; 4],
    k: usize,
    /// +1 for a counter-clockwise outline, -1 for a clockwise one.
    sign: f32,
}

impl LaneFoot {
    /// Whether the lane's outline may touch the rectangle `[x0, x1] × [y0, y1]`
    /// (separating-axis test on the outline's edges; the caller has checked the bounds).
    /// An outline seen edge-on (no plane) counts by its bounds.
    fn touches(&self, x: [f32; 2], y: [f32; 2]) -> bool {
        if self.plane.is_none() {
            return true;
        }
        let (p, sign) = (&self.poly[..self.k], self.sign);
        for i in 0..self.k {
            let (a, b) = (p[i], p[(i + 1) % self.k]);
            // Outward normal of edge a→b for a counter-clockwise outline.
            let n = [(b[1] - a[1]) * sign, (a[0] - b[0]) * sign];
            // The rectangle's corner least outward; outside the edge if even it is.
            let cx = if n[0] >= 0.0 { x[0] } else { x[1] };
            let cy = if n[1] >= 0.0 { y[0] } else { y[1] };
            if n[0] * (cx - a[0]) + n[1] * (cy - a[1]) > 0.0 {
                return false;
            }
        }
        true
    }
}

impl DirIndex {
    /// The grid for shadow rays along `axis` (toward the light) over `lv`'s packs; `None`
    /// for a scene with no packs, a zero or non-finite axis, more than [`MAX_PACKS`] packs
    /// or a grid over [`MAX_ENTRIES`].
    pub(crate) fn build<const W: usize>(lv: &Levels<W>, axis: Vec3) -> Option<DirIndex> {
        let a = Vec3A::from(axis.normalize_or_zero());
        if a == Vec3A::ZERO || !a.is_finite() {
            return None;
        }
        let (u, v) = a.any_orthonormal_pair();
        let mut refs: Vec<PackRef> = (0..lv.world.packs.len() as u32)
            .map(|pack| PackRef {
                inst: NO_INSTANCE,
                pack,
            })
            .collect();
        for (i, r) in lv.recs.iter().enumerate() {
            let np = lv.protos[r.proto as usize].packs.len() as u32;
            refs.extend((0..np).map(|pack| PackRef {
                inst: i as u32,
                pack,
            }));
            if refs.len() > MAX_PACKS {
                return None;
            }
        }
        if refs.is_empty() || refs.len() > MAX_PACKS {
            return None;
        }
        let o2w: Vec<Affine3A> = lv
            .recs
            .par_iter()
            .map(|r| Affine3A::from_cols_slice(&r.w2o).inverse())
            .collect();
        let foot = |r: &PackRef| -> Footprint {
            let (p, m) = if r.inst == NO_INSTANCE {
                (&lv.world.packs[r.pack as usize], None)
            } else {
                let rec = &lv.recs[r.inst as usize];
                (
                    &lv.protos[rec.proto as usize].packs[r.pack as usize],
                    Some(&o2w[r.inst as usize]),
                )
            };
            let mut f = Footprint {
                lo: [f32::INFINITY; 2],
                hi: [f32::NEG_INFINITY; 2],
                lanes: Vec::with_capacity(4),
            };
            for (k, c) in pack_corners(p, m) {
                let (mut dmin, mut dmax) = (f32::INFINITY, f32::NEG_INFINITY);
                let mut poly = [[0.0f32; 2]; 4];
                // Around the outline: a parallelogram's far corner (c[3]) comes between
                // its two edge ends.
                let order: &[usize] = if k == 4 { &[0, 1, 3, 2] } else { &[0, 1, 2] };
                let (mut llo, mut lhi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
                for (j, &i) in order.iter().enumerate() {
                    let q = c[i];
                    let (s, t, d) = (q.dot(u), q.dot(v), q.dot(a));
                    poly[j] = [s, t];
                    llo = [llo[0].min(s), llo[1].min(t)];
                    lhi = [lhi[0].max(s), lhi[1].max(t)];
                    dmin = dmin.min(d);
                    dmax = dmax.max(d);
                }
                f.lo = [f.lo[0].min(llo[0]), f.lo[1].min(llo[1])];
                f.hi = [f.hi[0].max(lhi[0]), f.hi[1].max(lhi[1])];
                let nrm = (c[1] - c[0]).cross(c[2] - c[0]);
                let (nu, nv, na) = (nrm.dot(u), nrm.dot(v), nrm.dot(a));
                // Seen nearly edge-on, the plane's depth is ill-conditioned: the lane's
                // whole depth range serves instead.
                let plane = (na.abs() > 0.05 * nrm.length()).then(|| {
                    let c0 = nrm.dot(c[0]) / na;
                    [c0, nu / na, nv / na]
                });
                // Orientation of the outline: the sign of its area.
                let mut area = 0.0;
                for i in 0..order.len() {
                    let (a, b) = (poly[i], poly[(i + 1) % order.len()]);
                    area += a[0] * b[1] - b[0] * a[1];
                }
                f.lanes.push(LaneFoot {
                    dmin,
                    dmax,
                    plane,
                    lo: llo,
                    hi: lhi,
                    poly,
                    k,
                    sign: if area >= 0.0 { 1.0 } else { -1.0 },
                });
            }
            f
        };
        let feet: Vec<Footprint> = refs.par_iter().map(foot).collect();
        let mut sizes: Vec<f32> = feet
            .iter()
            .flat_map(|f| &f.lanes)
            .map(|l| (l.hi[0] - l.lo[0]).max(l.hi[1] - l.lo[1]))
            .collect();
        if sizes.is_empty() {
            return None;
        }
        let mid = sizes.len() / 2;
        let median = *sizes.select_nth_unstable_by(mid, f32::total_cmp).1;
        // Packs with a lane far larger than the typical one (a ground, a wall) are not
        // what sizes the grid: it spans the others, and rays that leave it test these.
        let big = |f: &Footprint| {
            f.lanes
                .iter()
                .any(|l| (l.hi[0] - l.lo[0]).max(l.hi[1] - l.lo[1]) > BIG * median)
        };
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        let (mut all_lo, mut all_hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        let (mut top, mut bottom) = (f32::NEG_INFINITY, f32::INFINITY);
        for f in feet.iter().filter(|f| !f.lanes.is_empty()) {
            let ordinary = !big(f);
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
        lo = [lo[0] - 2.0 * pad, lo[1] - 2.0 * pad];
        hi = [hi[0] + 2.0 * pad, hi[1] + 2.0 * pad];
        let ext = [hi[0] - lo[0], hi[1] - lo[1]];
        let mut cell = (median * CELL_OF_LANE)
            .max(ext[0].max(ext[1]) / 4096.0)
            .max(pad);
        let dims = |cell: f32| {
            [
                ((ext[0] / cell).ceil() as usize).max(1),
                ((ext[1] / cell).ceil() as usize).max(1),
            ]
        };
        while dims(cell)[0] * dims(cell)[1] > MAX_GRID {
            cell *= 1.25;
        }
        let n = dims(cell);
        let mut ix = DirIndex {
            axis: a,
            u,
            v,
            lo,
            cell,
            inv_cell: 1.0 / cell,
            n,
            top: top + pad,
            pad,
            refs,
            start: Vec::new(),
            entries: Vec::new(),
            walk: Vec::new(),
            big: Vec::new(),
        };
        let grid_hi = [lo[0] + n[0] as f32 * cell, lo[1] + n[1] as f32 * cell];
        // The cells a pack's bounds touch, clipped to the grid; `None` outside it.
        let range = |f: &Footprint| {
            let (a, b) = (
                [f.lo[0] - pad, f.lo[1] - pad],
                [f.hi[0] + pad, f.hi[1] + pad],
            );
            if f.lanes.is_empty()
                || b[0] < lo[0]
                || b[1] < lo[1]
                || a[0] > grid_hi[0]
                || a[1] > grid_hi[1]
            {
                return None;
            }
            Some((ix.span(a[0], b[0], 0), ix.span(a[1], b[1], 1)))
        };
        // The cells of each pack, with its depth in each; then sorted into cells.
        let cells_of = |out: &mut Vec<(u32, Entry)>, ri: usize, f: &Footprint| {
            let Some(((x0, x1), (y0, y1))) = range(f) else {
                return;
            };
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let cu = [
                        ix.lo[0] + x as f32 * cell - pad,
                        ix.lo[0] + (x + 1) as f32 * cell + pad,
                    ];
                    let cv = [
                        ix.lo[1] + y as f32 * cell - pad,
                        ix.lo[1] + (y + 1) as f32 * cell + pad,
                    ];
                    let mut dmax = f32::NEG_INFINITY;
                    for l in &f.lanes {
                        let inside = l.lo[0] - pad <= cu[1]
                            && l.hi[0] + pad >= cu[0]
                            && l.lo[1] - pad <= cv[1]
                            && l.hi[1] + pad >= cv[0];
                        if !inside
                            || !l.touches([cu[0] - pad, cu[1] + pad], [cv[0] - pad, cv[1] + pad])
                        {
                            continue;
                        }
                        let d = match l.plane {
                            Some([c, gu, gv]) => {
                                let mut d = f32::NEG_INFINITY;
                                for s in cu {
                                    for t in cv {
                                        d = d.max(c - gu * s - gv * t);
                                    }
                                }
                                // Rounding of the plane's terms, scaled by its slope.
                                (d + 4.0 * pad * (1.0 + gu.abs() + gv.abs())).min(l.dmax)
                            }
                            None => l.dmax,
                        };
                        dmax = dmax.max(d.max(l.dmin));
                    }
                    if dmax == f32::NEG_INFINITY {
                        continue;
                    }
                    out.push(((y * n[0] + x) as u32, Entry { dmax, r: ri as u32 }));
                }
            }
        };
        let count: usize = feet
            .par_iter()
            .map(|f| range(f).map_or(0, |((x0, x1), (y0, y1))| (x1 - x0 + 1) * (y1 - y0 + 1)))
            .sum();
        if count > MAX_ENTRIES {
            return None;
        }
        // In chunks of packs, in order (deterministic), then bucketed by cell.
        const CHUNK: usize = 4096;
        let chunks: Vec<Vec<(u32, Entry)>> = feet
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(k, fs)| {
                let mut out = Vec::with_capacity(fs.len() * 8);
                for (j, f) in fs.iter().enumerate() {
                    cells_of(&mut out, k * CHUNK + j, f);
                }
                out
            })
            .collect();
        let mut count = vec![0u32; n[0] * n[1]];
        for (c, _) in chunks.iter().flatten() {
            count[*c as usize] += 1;
        }
        // Cells too crowded for a list leave their rays to the walk, and keep no entries.
        let mut walk = vec![0u64; count.len().div_ceil(64)];
        let mut start = vec![0u32; n[0] * n[1] + 1];
        for (c, &k) in count.iter().enumerate() {
            let crowded = k as usize > MAX_CELL_ENTRIES;
            if crowded {
                walk[c / 64] |= 1 << (c % 64);
            }
            start[c + 1] = start[c] + if crowded { 0 } else { k };
        }
        let mut entries = vec![Entry { dmax: 0.0, r: 0 }; start[n[0] * n[1]] as usize];
        let mut at: Vec<u32> = start[..n[0] * n[1]].to_vec();
        for (c, e) in chunks.into_iter().flatten() {
            if walk[c as usize / 64] & (1 << (c % 64)) == 0 {
                entries[at[c as usize] as usize] = e;
                at[c as usize] += 1;
            }
        }
        // Within a cell, deepest reach first (ties by pack: a deterministic order).
        let mut rest: &mut [Entry] = &mut entries;
        let mut cells: Vec<&mut [Entry]> = Vec::with_capacity(n[0] * n[1]);
        for c in 0..n[0] * n[1] {
            let (here, more) = rest.split_at_mut((start[c + 1] - start[c]) as usize);
            cells.push(here);
            rest = more;
        }
        cells.par_iter_mut().for_each(|es| {
            es.sort_unstable_by(|p, q| q.dmax.total_cmp(&p.dmax).then(p.r.cmp(&q.r)))
        });
        drop(cells);
        ix.walk = walk;
        ix.entries = entries;
        ix.start = start;
        let mut bigs: Vec<Entry> = feet
            .iter()
            .enumerate()
            .filter(|(_, f)| !f.lanes.is_empty() && big(f))
            .map(|(ri, f)| Entry {
                dmax: f.lanes.iter().fold(f32::NEG_INFINITY, |m, l| m.max(l.dmax)),
                r: ri as u32,
            })
            .collect();
        bigs.sort_unstable_by(|p, q| q.dmax.total_cmp(&p.dmax).then(p.r.cmp(&q.r)));
        ix.big = bigs;
        Some(ix)
    }

    /// The cells `[first, last]` along grid axis `k` that `[a, b]` touches, clamped to the
    /// grid (`(1, 0)`-style empty ranges are not produced: callers clamp first).
    #[inline(always)]
    fn span(&self, a: f32, b: f32, k: usize) -> (usize, usize) {
        let last = self.n[k] as f32 - 1.0;
        let f = |x: f32| ((x - self.lo[k]) * self.inv_cell).floor().clamp(0.0, last) as usize;
        (f(a), f(b))
    }

    /// What the grid holds.
    pub(crate) fn stats(&self) -> DirectionStats {
        DirectionStats {
            axis: Vec3::from(self.axis),
            packs: self.refs.len(),
            cells: (self.n[0], self.n[1]),
            cell: self.cell,
            entries: self.entries.len(),
            bytes: self.bytes(),
        }
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> usize {
        self.refs.len() * std::mem::size_of::<PackRef>()
            + self.start.len() * 4
            + (self.entries.len() + self.big.len()) * std::mem::size_of::<Entry>()
            + self.walk.len() * 8
    }

    /// Whether `ray` meets an accepted primitive of `lv` (the levels this grid was built
    /// over) within `(0, tmax)`, not counting `skip`: `None` when the grid does not serve
    /// this ray (the tree walk answers it). `tr` is the world ray as the kernel prepared
    /// it, `wskip` the world primitive to skip.
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    pub(crate) unsafe fn occluded<const W: usize, K: Lanes<W>, F: AlphaFilter, C: Counter>(
        &self,
        lv: &Levels<W>,
        ray: &Ray,
        skip: PrimRef,
        tr: &K::R,
        wskip: u32,
        f: &F,
        c: &C,
    ) -> Option<bool> {
        let o = Vec3A::from(ray.origin);
        let d = Vec3A::from(ray.dir);
        let da = d.dot(self.axis);
        if !(da > 0.0) {
            return None;
        }
        let d0 = o.dot(self.axis);
        if !(d0 < self.top) {
            // Past every primitive toward the light (or a NaN origin: the walk decides).
            return (d0 >= self.top).then_some(false);
        }
        // Where the ray is when it climbs past the top of the scene (or ends).
        let t_end = ((self.top - d0) / da).min(ray.tmax);
        let (s0, q0) = (o.dot(self.u), o.dot(self.v));
        let (s1, q1) = (s0 + t_end * d.dot(self.u), q0 + t_end * d.dot(self.v));
        let (smin, smax) = (s0.min(s1) - self.pad, s0.max(s1) + self.pad);
        let (qmin, qmax) = (q0.min(q1) - self.pad, q0.max(q1) + self.pad);
        if !(smin <= smax && qmin <= qmax) {
            return None; // NaN: the walk decides
        }
        let (gx1, gy1) = (
            self.lo[0] + self.n[0] as f32 * self.cell,
            self.lo[1] + self.n[1] as f32 * self.cell,
        );
        let on_grid = smax >= self.lo[0] && smin <= gx1 && qmax >= self.lo[1] && qmin <= gy1;
        let off_grid = smin < self.lo[0] || smax > gx1 || qmin < self.lo[1] || qmax > gy1;
        let (x0, x1) = self.span(smin, smax, 0);
        let (y0, y1) = self.span(qmin, qmax, 1);
        if on_grid {
            if (x1 - x0 + 1) * (y1 - y0 + 1) > MAX_CELLS {
                return None;
            }
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let c = y * self.n[0] + x;
                    if self.walk[c / 64] & (1 << (c % 64)) != 0 {
                        return None;
                    }
                }
            }
        }
        let behind = d0 - self.pad;
        // The ray in the space of the instance last tested (packs of one instance often
        // follow each other) and the primitive to skip there.
        let mut local: Option<(u32, K::R, u32)> = None;
        let mut test = |e: &Entry| {
            let r = self.refs[e.r as usize];
            // SAFETY (the kernel calls): `K`'s instruction set is available (this
            // function's contract). Packs and records are indexed in range: the grid was
            // built from these levels.
            if r.inst == NO_INSTANCE {
                let p = &lv.world.packs[r.pack as usize];
                unsafe {
                    pack_any::<K, W, F, C>(&lv.world, &lv.masks, p, tr, ray.tmax, wskip, f, c)
                }
            } else {
                let (lr, ls) = match local {
                    Some((i, lr, ls)) if i == r.inst => (lr, ls),
                    _ => {
                        let (_, l) = lv.enter(r.inst, o, d, skip);
                        let lr = unsafe { K::prep(&l) };
                        local = Some((r.inst, lr, l.skip));
                        (lr, l.skip)
                    }
                };
                let blas = &lv.protos[lv.recs[r.inst as usize].proto as usize];
                let p = &blas.packs[r.pack as usize];
                unsafe { pack_any::<K, W, F, C>(blas, &lv.masks, p, &lr, ray.tmax, ls, f, c) }
            }
        };
        if on_grid {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let cell = y * self.n[0] + x;
                    let (a, b) = (self.start[cell] as usize, self.start[cell + 1] as usize);
                    for e in &self.entries[a..b] {
                        if e.dmax <= behind {
                            break;
                        }
                        if test(e) {
                            return Some(true);
                        }
                    }
                }
            }
        }
        if off_grid {
            // Beyond the grid only the big packs reach.
            for e in &self.big {
                if e.dmax <= behind {
                    break;
                }
                if test(e) {
                    return Some(true);
                }
            }
        }
        Some(false)
    }
}
