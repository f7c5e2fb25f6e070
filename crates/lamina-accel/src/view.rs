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
use glam::{Vec2, Vec3, Vec3A};
use rayon::prelude::*;

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
        Some(ViewIndex {
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
