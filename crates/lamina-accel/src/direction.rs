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
//!
//! A ray the grid serves poorly (pointing away from the axis, crossing more than
//! [`MAX_CELLS`](crate::grid::MAX_CELLS) cells, or a cell too crowded for a short list) is
//! left to the tree walk.
//! Primitives much larger than the typical one (a ground) do not size the grid: the grid
//! spans the others, lists the large ones in its cells too, and a ray that leaves its area
//! tests them. Scenes of more than [`MAX_PACKS`](crate::grid::MAX_PACKS) placed packs, or
//! whose grid would exceed [`MAX_ENTRIES`](crate::grid::MAX_ENTRIES), get none.

use crate::grid::{
    Cells, Entry, Footprint, GridStats, LaneFoot, Listing, PackRef, PackTests, median_size,
    sort_entries,
};
use crate::kernel::Lanes;
use crate::traverse::Levels;
use crate::{AlphaFilter, Counter, Ray};
use glam::{Vec3, Vec3A};
use rayon::prelude::*;

/// A primitive this many times the median size is "big": it does not size the grid.
const BIG: f32 = 64.0;

/// The grid of one axis (module docs). Entry keys are the largest depth along the axis
/// the pack reaches in the cell; lists run deepest first.
#[derive(Clone, Debug)]
pub(crate) struct DirIndex {
    axis: Vec3A,
    u: Vec3A,
    v: Vec3A,
    /// Largest depth of any pack: a ray past it meets nothing.
    top: f32,
    /// Rounding margin (world units) on depths and cell bounds.
    pad: f32,
    /// The cells, and apart from them the packs larger than the grid is sized for (a
    /// ground): what a ray that leaves the grid's area may meet there; deepest reach first.
    grid: Listing,
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
        Some(DirIndex {
            axis: a,
            u,
            v,
            top: top + pad,
            pad,
            grid: Listing {
                refs,
                cells,
                apart: bigs,
            },
        })
    }

    /// What the grid holds.
    pub(crate) fn stats(&self) -> GridStats {
        self.grid.stats(Vec3::from(self.axis), None)
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> usize {
        self.grid.bytes()
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
        let s = [s0.min(s1) - self.pad, s0.max(s1) + self.pad];
        let q = [q0.min(q1) - self.pad, q0.max(q1) + self.pad];
        if !(s[0] <= s[1] && q[0] <= q[1]) {
            return None; // NaN: the walk decides
        }
        let (lo, hi) = (self.grid.cells.lo, self.grid.cells.hi());
        let on_grid = s[1] >= lo[0] && s[0] <= hi[0] && q[1] >= lo[1] && q[0] <= hi[1];
        let off_grid = s[0] < lo[0] || s[1] > hi[0] || q[0] < lo[1] || q[1] > hi[1];
        let cover = if on_grid {
            Some(self.grid.cells.cover(s, q)?)
        } else {
            None
        };
        let behind = d0 - self.pad;
        tests.refs = &self.grid.refs;
        if let Some((x, y)) = cover {
            for y in y[0]..=y[1] {
                for x in x[0]..=x[1] {
                    for e in self.grid.cells.list(x, y) {
                        if e.key <= behind {
                            break;
                        }
                        // SAFETY: forwarded.
                        if unsafe { tests.any(e, ray.tmax) } {
                            return Some(true);
                        }
                    }
                }
            }
        }
        if off_grid {
            // Beyond the grid only the big packs reach.
            for e in &self.grid.apart {
                if e.key <= behind {
                    break;
                }
                // SAFETY: forwarded.
                if unsafe { tests.any(e, ray.tmax) } {
                    return Some(true);
                }
            }
        }
        Some(false)
    }
}
