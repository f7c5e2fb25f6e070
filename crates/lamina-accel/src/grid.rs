//! What the two projected grids share ([`crate::direction`] along a sun's axis,
//! [`crate::view`] from a camera's eye): the BVH's leaf packs placed in world space and
//! projected onto a 2D grid, each cell listing the packs whose outline touches it with a
//! sort key (a depth), and the pack tests of a query, the traversal's own.

use crate::kernel::Lanes;
use crate::layout::Blas;
use crate::traverse::{Levels, pack_any, pack_closest};
use crate::{AlphaFilter, Counter, NO_INSTANCE, PrimRef};
use glam::{Affine3A, Vec3, Vec3A};
use rayon::prelude::*;

/// Most leaf packs, placed in world space, a grid is built over. A grid pays for itself
/// on scenes of up to a few hundred thousand primitives (the benchmark scenes: a tenth
/// less time per frame from the sun's grid); on a 100 000-leaf instanced tree the sun's
/// grid saved 5 % of the frame but took ten times the tree's build time and six times its
/// memory, so larger scenes keep the walk.
pub const MAX_PACKS: usize = 1 << 18;
/// Most entries (pack, cell pairs, 8 bytes each) a grid may hold.
pub const MAX_ENTRIES: usize = 1 << 23;
/// Most cells one query visits before the tree walk is cheaper.
pub const MAX_CELLS: usize = 16;
/// Most cells of a grid.
const MAX_GRID: usize = 1 << 22;
/// Cell side relative to the median projected size of a primitive.
const CELL_OF_LANE: f32 = 0.5;
/// Most packs listed in one cell; a more crowded cell leaves its rays to the tree walk.
const MAX_CELL_ENTRIES: usize = 64;

/// What a built grid holds, for reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridStats {
    /// Unit axis: toward the light (a sun's grid), or the view direction (a camera's).
    pub axis: Vec3,
    /// The eye of a camera's grid; `None` for a sun's.
    pub eye: Option<Vec3>,
    /// Leaf packs listed (world and instances).
    pub packs: usize,
    /// Grid size in cells (across, up).
    pub cells: (usize, usize),
    /// Cell side: world units across the sun's axis; for a camera, units of the tangent
    /// of the angle from the view direction.
    pub cell: f32,
    /// Pack-in-cell entries.
    pub entries: usize,
    /// Bytes held.
    pub bytes: usize,
}

/// One pack placed in the world: the world level's (`inst == NO_INSTANCE`) or an
/// instance's.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PackRef {
    pub inst: u32,
    pub pack: u32,
}

/// A pack listed in a cell: its sort key in that cell (a depth) and the index of its
/// [`PackRef`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct Entry {
    pub key: f32,
    pub r: u32,
}

/// Every pack of `lv` placed in the world, and each instance's object-to-world transform;
/// `None` for none or more than [`MAX_PACKS`].
pub(crate) fn pack_refs<const W: usize>(lv: &Levels<W>) -> Option<(Vec<PackRef>, Vec<Affine3A>)> {
    let mut refs: Vec<PackRef> = (0..lv.world.packs.len() as u32)
        .map(|pack| PackRef {
            inst: NO_INSTANCE,
            pack,
        })
        .collect();
    for (i, r) in lv.recs.iter().enumerate() {
        if refs.len() > MAX_PACKS {
            return None;
        }
        let np = lv.protos[r.proto as usize].packs.len() as u32;
        refs.extend((0..np).map(|pack| PackRef {
            inst: i as u32,
            pack,
        }));
    }
    if refs.is_empty() || refs.len() > MAX_PACKS {
        return None;
    }
    let o2w = lv
        .recs
        .par_iter()
        .map(|r| Affine3A::from_cols_slice(&r.w2o).inverse())
        .collect();
    Some((refs, o2w))
}

/// The world-space corners of the primitives of pack `r`: per used lane 3 corners (a
/// triangle) or 4 in order around the outline (a parallelogram).
pub(crate) fn placed_corners<const W: usize>(
    lv: &Levels<W>,
    o2w: &[Affine3A],
    r: PackRef,
) -> Vec<(usize, [Vec3A; 4])> {
    let (blas, m): (&Blas<W>, Option<&Affine3A>) = if r.inst == NO_INSTANCE {
        (&lv.world, None)
    } else {
        let rec = &lv.recs[r.inst as usize];
        (&lv.protos[rec.proto as usize], Some(&o2w[r.inst as usize]))
    };
    let p = &blas.packs[r.pack as usize];
    let mut out = Vec::with_capacity(4);
    for l in 0..4 {
        if p.id[l] == u32::MAX {
            continue;
        }
        let g = |a: &[[f32; 4]; 3]| Vec3A::new(a[0][l], a[1][l], a[2][l]);
        let (mut v0, mut e1, mut e2) = (g(&p.v0), g(&p.e1), g(&p.e2));
        let quad = p.tri[l] == 0.0;
        if let (true, Some(live_uv)) = (quad, &lv.live_uv) {
            // A masked card: the sub-card over its live part (`crate::trim`), widened by a
            // few units in the last place so that rounding never cuts into it.
            if let Some(live) = crate::trim::live_lane(blas, live_uv, p, l) {
                let [a0, a1, b0, b1] = live.rect();
                let w = 8.0 * f64::from(f32::EPSILON);
                let (a0, a1) = ((a0 - w).max(0.0) as f32, (a1 + w).min(1.0) as f32);
                let (b0, b1) = ((b0 - w).max(0.0) as f32, (b1 + w).min(1.0) as f32);
                (v0, e1, e2) = (v0 + e1 * a0 + e2 * b0, e1 * (a1 - a0), e2 * (b1 - b0));
            }
        }
        // Around the outline: a parallelogram's far corner comes between its edge ends.
        let mut c = [v0, v0 + e1, v0 + e1 + e2, v0 + e2];
        if !quad {
            c[2] = v0 + e2;
        }
        if let Some(m) = m {
            for q in &mut c {
                *q = m.transform_point3a(*q);
            }
        }
        out.push((if quad { 4 } else { 3 }, c));
    }
    out
}

/// One primitive as a grid sees it: its projected outline and bounds, its depth range,
/// and for the sun's grid the plane `depth = c - gu·s - gv·t` over the projection
/// (`None` when seen nearly edge-on).
pub(crate) struct LaneFoot {
    pub dmin: f32,
    pub dmax: f32,
    pub plane: Option<[f32; 3]>,
    pub lo: [f32; 2],
    pub hi: [f32; 2],
    /// Projected corners in order around the outline (`k` of them used).
    pub poly: [[f32; 2]; 4],
    pub k: usize,
    /// +1 for a counter-clockwise outline, -1 for a clockwise one, 0 for one of no area
    /// (counted by its bounds).
    pub sign: f32,
    /// The lane's own rounding margin in projected units, on top of the grid's.
    pub pad: f32,
}

impl LaneFoot {
    /// The lane of projected corners `poly[..k]` with depths `depth[..k]`.
    pub fn new(poly: [[f32; 2]; 4], depth: [f32; 4], k: usize, plane: Option<[f32; 3]>) -> Self {
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        let (mut dmin, mut dmax) = (f32::INFINITY, f32::NEG_INFINITY);
        let mut area = 0.0;
        for i in 0..k {
            let (a, b) = (poly[i], poly[(i + 1) % k]);
            area += a[0] * b[1] - b[0] * a[1];
            lo = [lo[0].min(a[0]), lo[1].min(a[1])];
            hi = [hi[0].max(a[0]), hi[1].max(a[1])];
            dmin = dmin.min(depth[i]);
            dmax = dmax.max(depth[i]);
        }
        let box_area = (hi[0] - lo[0]) * (hi[1] - lo[1]);
        let sign = if !(area.abs() > 1e-4 * box_area) {
            0.0
        } else if area > 0.0 {
            1.0
        } else {
            -1.0
        };
        LaneFoot {
            dmin,
            dmax,
            plane,
            lo,
            hi,
            poly,
            k,
            sign,
            pad: 0.0,
        }
    }

    /// Largest projected extent.
    pub fn size(&self) -> f32 {
        (self.hi[0] - self.lo[0]).max(self.hi[1] - self.lo[1])
    }

    /// Whether the outline, widened by `pad`, may touch the rectangle `x × y`: its bounds
    /// overlap and no edge of the outline separates them. An outline of no area counts by
    /// its bounds.
    pub fn touches(&self, x: [f32; 2], y: [f32; 2], pad: f32) -> bool {
        let pad = pad + self.pad;
        let (x, y) = ([x[0] - pad, x[1] + pad], [y[0] - pad, y[1] + pad]);
        if self.lo[0] > x[1] || self.hi[0] < x[0] || self.lo[1] > y[1] || self.hi[1] < y[0] {
            return false;
        }
        if self.sign == 0.0 {
            return true;
        }
        let p = &self.poly[..self.k];
        for i in 0..self.k {
            let (a, b) = (p[i], p[(i + 1) % self.k]);
            // Outward normal of edge a→b.
            let n = [(b[1] - a[1]) * self.sign, (a[0] - b[0]) * self.sign];
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

/// A pack as a grid sees it: its lanes and their joint bounds.
pub(crate) struct Footprint {
    pub lo: [f32; 2],
    pub hi: [f32; 2],
    pub lanes: Vec<LaneFoot>,
}

impl Footprint {
    /// The footprint of `lanes`.
    pub fn new(lanes: Vec<LaneFoot>) -> Self {
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for l in &lanes {
            lo = [lo[0].min(l.lo[0] - l.pad), lo[1].min(l.lo[1] - l.pad)];
            hi = [hi[0].max(l.hi[0] + l.pad), hi[1].max(l.hi[1] + l.pad)];
        }
        Footprint { lo, hi, lanes }
    }
}

/// The median projected size of the lanes of `feet`; `None` without lanes.
pub(crate) fn median_size(feet: &[Footprint]) -> Option<f32> {
    let mut sizes: Vec<f32> = feet
        .iter()
        .flat_map(|f| &f.lanes)
        .map(LaneFoot::size)
        .collect();
    if sizes.is_empty() {
        return None;
    }
    let mid = sizes.len() / 2;
    Some(*sizes.select_nth_unstable_by(mid, f32::total_cmp).1)
}

/// What both grids hold: the packs they were built over (entries index them), the cells,
/// and a list apart (the sun's big packs, the packs crossing the eye's plane).
#[derive(Clone, Debug)]
pub(crate) struct Listing {
    pub refs: Vec<PackRef>,
    pub cells: Cells,
    pub apart: Vec<Entry>,
}

impl Listing {
    /// What it holds, for a grid along `axis` (and from `eye`).
    pub fn stats(&self, axis: Vec3, eye: Option<Vec3>) -> GridStats {
        GridStats {
            axis,
            eye,
            packs: self.refs.len(),
            cells: (self.cells.n[0], self.cells.n[1]),
            cell: self.cells.cell,
            entries: self.cells.len(),
            bytes: self.bytes(),
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.refs.len() * std::mem::size_of::<PackRef>()
            + self.cells.bytes()
            + self.apart.len() * std::mem::size_of::<Entry>()
    }
}

/// A uniform 2D grid of cells, each with its list of [`Entry`]s.
#[derive(Clone, Debug)]
pub(crate) struct Cells {
    /// Lower corner.
    pub lo: [f32; 2],
    pub cell: f32,
    inv_cell: f32,
    pub n: [usize; 2],
    /// Per cell (row-major, first axis fastest), its entries' range in `entries`.
    start: Vec<u32>,
    entries: Vec<Entry>,
    /// Bit per cell: too crowded for a list, its rays take the tree walk.
    walk: Vec<u64>,
}

impl Cells {
    /// A grid over `[lo, hi]` with cells about [`CELL_OF_LANE`] of `median` across, at
    /// most [`MAX_GRID`] of them.
    pub fn new(lo: [f32; 2], hi: [f32; 2], median: f32, min_cell: f32) -> Self {
        let ext = [hi[0] - lo[0], hi[1] - lo[1]];
        let mut cell = (median * CELL_OF_LANE)
            .max(ext[0].max(ext[1]) / 4096.0)
            .max(min_cell);
        let dims = |cell: f32| {
            [
                ((ext[0] / cell).ceil() as usize).max(1),
                ((ext[1] / cell).ceil() as usize).max(1),
            ]
        };
        while dims(cell)[0] * dims(cell)[1] > MAX_GRID {
            cell *= 1.25;
        }
        Cells {
            lo,
            cell,
            inv_cell: 1.0 / cell,
            n: dims(cell),
            start: Vec::new(),
            entries: Vec::new(),
            walk: Vec::new(),
        }
    }

    /// Upper corner.
    pub fn hi(&self) -> [f32; 2] {
        [
            self.lo[0] + self.n[0] as f32 * self.cell,
            self.lo[1] + self.n[1] as f32 * self.cell,
        ]
    }

    /// The cells `[first, last]` along axis `k` that `[a, b]` touches, clamped to the grid.
    #[inline(always)]
    pub fn span(&self, a: f32, b: f32, k: usize) -> (usize, usize) {
        let last = self.n[k] as f32 - 1.0;
        let f = |x: f32| ((x - self.lo[k]) * self.inv_cell).floor().clamp(0.0, last) as usize;
        (f(a), f(b))
    }

    /// The cells of `[smin, smax] × [tmin, tmax]`: `None` when that is more than
    /// [`MAX_CELLS`] or one of them is too crowded (the walk answers).
    #[inline(always)]
    pub fn cover(&self, s: [f32; 2], t: [f32; 2]) -> Option<([usize; 2], [usize; 2])> {
        let (x0, x1) = self.span(s[0], s[1], 0);
        let (y0, y1) = self.span(t[0], t[1], 1);
        self.listed([x0, x1], [y0, y1])
            .then_some(([x0, x1], [y0, y1]))
    }

    /// Whether the cells `[x0, x1] × [y0, y1]` are at most [`MAX_CELLS`], none of them too
    /// crowded: what [`Cells::cover`] serves.
    #[inline(always)]
    pub fn listed(&self, x: [usize; 2], y: [usize; 2]) -> bool {
        if (x[1] - x[0] + 1) * (y[1] - y[0] + 1) > MAX_CELLS {
            return false;
        }
        for y in y[0]..=y[1] {
            for x in x[0]..=x[1] {
                let c = y * self.n[0] + x;
                if self.walk[c / 64] & (1 << (c % 64)) != 0 {
                    return false;
                }
            }
        }
        true
    }

    /// `1 / cell`, the factor [`Cells::span`] scales by.
    #[inline(always)]
    pub fn inv_cell(&self) -> f32 {
        self.inv_cell
    }

    /// The entries of cell `(x, y)`.
    #[inline(always)]
    pub fn list(&self, x: usize, y: usize) -> &[Entry] {
        let c = y * self.n[0] + x;
        &self.entries[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// Entries held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.start.len() * 4
            + self.entries.len() * std::mem::size_of::<Entry>()
            + self.walk.len() * 8
    }

    /// Lists every pack of `feet` (index = its [`PackRef`]'s) in the cells its lanes'
    /// outlines touch (widened by `pad`), with key `key(lane, cell's s range, t range)`
    /// combined over the lanes touching the cell by max (`descending`) or min, sorted by key
    /// (`descending` or ascending; ties by pack). `false` (and nothing listed) for more than
    /// [`MAX_ENTRIES`].
    pub fn fill(
        &mut self,
        feet: &[Footprint],
        pad: f32,
        descending: bool,
        key: impl Fn(&LaneFoot, [f32; 2], [f32; 2]) -> f32 + Sync,
    ) -> bool {
        let (lo, hi, n, cell) = (self.lo, self.hi(), self.n, self.cell);
        // The cells a pack's bounds touch, clipped to the grid; `None` outside it.
        let range = |f: &Footprint| {
            let (a, b) = (
                [f.lo[0] - pad, f.lo[1] - pad],
                [f.hi[0] + pad, f.hi[1] + pad],
            );
            if f.lanes.is_empty() || b[0] < lo[0] || b[1] < lo[1] || a[0] > hi[0] || a[1] > hi[1] {
                return None;
            }
            Some((self.span(a[0], b[0], 0), self.span(a[1], b[1], 1)))
        };
        let count: usize = feet
            .par_iter()
            .map(|f| range(f).map_or(0, |((x0, x1), (y0, y1))| (x1 - x0 + 1) * (y1 - y0 + 1)))
            .sum();
        if count > MAX_ENTRIES {
            return false;
        }
        let worst = if descending {
            f32::NEG_INFINITY
        } else {
            f32::INFINITY
        };
        let cells_of = |out: &mut Vec<(u32, Entry)>, ri: usize, f: &Footprint| {
            let Some(((x0, x1), (y0, y1))) = range(f) else {
                return;
            };
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let cs = [lo[0] + x as f32 * cell, lo[0] + (x + 1) as f32 * cell];
                    let ct = [lo[1] + y as f32 * cell, lo[1] + (y + 1) as f32 * cell];
                    let mut k = worst;
                    for l in f.lanes.iter().filter(|l| l.touches(cs, ct, pad)) {
                        let v = key(l, [cs[0] - pad, cs[1] + pad], [ct[0] - pad, ct[1] + pad]);
                        k = if descending { k.max(v) } else { k.min(v) };
                    }
                    if k != worst {
                        out.push((
                            (y * n[0] + x) as u32,
                            Entry {
                                key: k,
                                r: ri as u32,
                            },
                        ));
                    }
                }
            }
        };
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
        let cells = n[0] * n[1];
        let mut count = vec![0u32; cells];
        for (c, _) in chunks.iter().flatten() {
            count[*c as usize] += 1;
        }
        // Cells too crowded for a list leave their rays to the walk, and keep no entries.
        let mut walk = vec![0u64; cells.div_ceil(64)];
        let mut start = vec![0u32; cells + 1];
        for (c, &k) in count.iter().enumerate() {
            let crowded = k as usize > MAX_CELL_ENTRIES;
            if crowded {
                walk[c / 64] |= 1 << (c % 64);
            }
            start[c + 1] = start[c] + if crowded { 0 } else { k };
        }
        let mut entries = vec![Entry { key: 0.0, r: 0 }; start[cells] as usize];
        let mut at: Vec<u32> = start[..cells].to_vec();
        for (c, e) in chunks.into_iter().flatten() {
            if walk[c as usize / 64] & (1 << (c % 64)) == 0 {
                entries[at[c as usize] as usize] = e;
                at[c as usize] += 1;
            }
        }
        let mut rest: &mut [Entry] = &mut entries;
        let mut lists: Vec<&mut [Entry]> = Vec::with_capacity(cells);
        for c in 0..cells {
            let (here, more) = rest.split_at_mut((start[c + 1] - start[c]) as usize);
            lists.push(here);
            rest = more;
        }
        lists
            .par_iter_mut()
            .for_each(|es| sort_entries(es, descending));
        drop(lists);
        self.start = start;
        self.entries = entries;
        self.walk = walk;
        true
    }
}

/// Sorts `es` by key (`descending` or ascending), ties by pack.
pub(crate) fn sort_entries(es: &mut [Entry], descending: bool) {
    es.sort_unstable_by(|p, q| {
        let by_key = if descending {
            q.key.total_cmp(&p.key)
        } else {
            p.key.total_cmp(&q.key)
        };
        by_key.then(p.r.cmp(&q.r))
    })
}

/// The pack tests of one query: the traversal's own leaf tests, with the ray moved into
/// each instance's space (kept while consecutive packs belong to the same instance).
pub(crate) struct PackTests<'a, K: Lanes<W>, const W: usize, F, C> {
    pub lv: &'a Levels<W>,
    pub refs: &'a [PackRef],
    pub o: Vec3A,
    pub d: Vec3A,
    pub skip: PrimRef,
    /// The world ray as the kernel prepared it, and the world primitive to skip.
    pub tr: &'a K::R,
    pub wskip: u32,
    pub f: &'a F,
    pub c: &'a C,
    /// The instance last entered, the ray in its space, and the primitive to skip there.
    pub local: Option<(u32, K::R, u32)>,
}

impl<'a, K: Lanes<W>, const W: usize, F: AlphaFilter, C: Counter> PackTests<'a, K, W, F, C> {
    /// The tests of the world ray `o + t·d` as the kernel prepared it (`tr`), skipping
    /// `skip` (`wskip` in the world level), in `lv`; entries index `refs`, set by the grid
    /// that runs them.
    #[inline(always)]
    pub fn new(
        lv: &'a Levels<W>,
        o: Vec3A,
        d: Vec3A,
        skip: PrimRef,
        tr: &'a K::R,
        wskip: u32,
        f: &'a F,
        c: &'a C,
    ) -> Self {
        PackTests {
            lv,
            refs: &[],
            o,
            d,
            skip,
            tr,
            wskip,
            f,
            c,
            local: None,
        }
    }

    /// Pack `r`'s level, the prepared ray there and the primitive to skip.
    #[inline(always)]
    fn level(&mut self, r: PackRef) -> (&'a crate::layout::Blas<W>, K::R, u32) {
        let lv: &'a Levels<W> = self.lv;
        if r.inst == NO_INSTANCE {
            return (&lv.world, *self.tr, self.wskip);
        }
        let (lr, ls) = match self.local {
            Some((i, lr, ls)) if i == r.inst => (lr, ls),
            _ => {
                let (_, l) = lv.enter(r.inst, self.o, self.d, self.skip);
                // SAFETY: `K`'s instruction set is available (the contract of the query
                // that made this value).
                let lr = unsafe { K::prep(&l) };
                self.local = Some((r.inst, lr, l.skip));
                (lr, l.skip)
            }
        };
        let proto = lv.recs[r.inst as usize].proto as usize;
        (&lv.protos[proto], lr, ls)
    }

    /// Whether entry `e`'s pack has an accepted hit within `tmax`.
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    pub unsafe fn any(&mut self, e: &Entry, tmax: f32) -> bool {
        let r = self.refs[e.r as usize];
        let (blas, lr, ls) = self.level(r);
        let p = &blas.packs[r.pack as usize];
        let (masks, f, c) = (&self.lv.masks, self.f, self.c);
        // SAFETY: forwarded.
        unsafe { pack_any::<K, W, F, C>(blas, masks, p, &lr, tmax, ls, f, c) }
    }

    /// The closest accepted hit of entry `e`'s pack within `tmax`: `(t, instance,
    /// primitive, b1, b2)`.
    ///
    /// # Safety
    /// `K`'s instruction set must be available.
    #[inline(always)]
    pub unsafe fn closest(&mut self, e: &Entry, tmax: f32) -> Option<(f32, u32, u32, f32, f32)> {
        let r = self.refs[e.r as usize];
        let (blas, lr, ls) = self.level(r);
        let p = &blas.packs[r.pack as usize];
        let (masks, f, c) = (&self.lv.masks, self.f, self.c);
        // SAFETY: forwarded.
        let (t, lane, b1, b2) =
            unsafe { pack_closest::<K, W, F, C>(blas, masks, p, &lr, tmax, ls, f, c) }?;
        Some((t, r.inst, p.id[lane], b1, b2))
    }
}
