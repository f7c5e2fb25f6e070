//! Where a masked primitive can be hit: the part of it whose texture coordinates fall in
//! cells of its opacity mask that are not transparent everywhere.
//!
//! A leaf card's matte is mostly transparent margin (the demo bush's leaves cover 53 % of
//! their cards; the box of their opaque part is 86 % of the card). A candidate hit in a
//! transparent cell is always rejected, so a tree whose boxes bound only the live part of
//! each primitive gives the same answers, bit for bit, while rays through the margins no
//! longer enter those boxes (and the grids for sun and camera rays list a pack only under
//! its live part). The live part is found in barycentric coordinates `(b1, b2)`: the
//! primitive's domain (the unit triangle or square) clipped to the half-planes where the
//! interpolated `uv` lies in the box of the live cells, widened by one cell so that a hit
//! rounding into a live cell from just outside still enters the box.

use crate::build::Aabb;
use crate::desc::Prim;
use crate::layout::{ALPHA, ALPHA_IDENTITY_UV, Blas, FLAG_INDEX, Pack, prim_bounds};
use crate::mask::OpacityMask;
use glam::{DVec2, DVec3, Vec2};

/// Largest texture coordinate a primitive is cut for: the traversal interpolates uv in
/// `f32`, with an error of a few units in the last place of the largest coordinate, which
/// must stay well inside the one-cell margin (64: 3e-5 of a unit, an eighth of a cell of a
/// 4096-texel matte). Larger or non-finite ones keep the primitive whole.
const MAX_UV: f32 = 64.0;

/// Most vertices of a clipped domain: a square cut by four half-planes.
const MAX_VERTS: usize = 8;

/// A convex polygon in barycentric coordinates `(b1, b2)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Live {
    v: [DVec2; MAX_VERTS],
    n: usize,
}

impl Live {
    /// The vertices.
    pub(crate) fn verts(&self) -> &[DVec2] {
        &self.v[..self.n]
    }

    /// Its box in `(b1, b2)`: `[b1 min, b1 max, b2 min, b2 max]`.
    pub(crate) fn rect(&self) -> [f64; 4] {
        self.verts().iter().fold(
            [
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ],
            |r, p| [r[0].min(p.x), r[1].max(p.x), r[2].min(p.y), r[3].max(p.y)],
        )
    }

    /// The part where `a·b + c >= 0` (Sutherland–Hodgman, one edge).
    fn clip(&self, a: DVec2, c: f64) -> Live {
        let mut out = Live {
            v: [DVec2::ZERO; MAX_VERTS],
            n: 0,
        };
        let f = |p: DVec2| a.dot(p) + c;
        for i in 0..self.n {
            let (p, q) = (self.v[i], self.v[(i + 1) % self.n]);
            let (fp, fq) = (f(p), f(q));
            if fp >= 0.0 && out.n < MAX_VERTS {
                out.v[out.n] = p;
                out.n += 1;
            }
            if (fp >= 0.0) != (fq >= 0.0) && out.n < MAX_VERTS {
                out.v[out.n] = p + (q - p) * (fp / (fp - fq));
                out.n += 1;
            }
        }
        out
    }
}

/// The box in texture space of `mask`'s cells that are not transparent everywhere,
/// widened by one cell: `[u min, u max, v min, v max]`, infinite on a side where the
/// live cells reach a clamped edge (edge texels extend outward) or the cell that blends a
/// repeated matte's last texels with its first (live on both sides of the edge: that
/// axis is not cut). `None` when no cell is live.
fn live_uv_box(mask: &OpacityMask) -> Option<[f64; 4]> {
    let (xs, ys) = mask.live_cells()?;
    let (w, h) = mask.size();
    let (w, h) = (w as f64, h as f64);
    // Cell x (lower-left texel) blends lookups at `u·w - 0.5 ∈ [x, x + 1)`.
    let u = |x: i64| (x as f64 + 0.5) / w;
    // Row y at `(1 - v)·h - 0.5 ∈ [y, y + 1)`, so `v ∈ (1 - (y + 1.5)/h, 1 - (y + 0.5)/h]`.
    let v = |y: i64| 1.0 - (y as f64 + 0.5) / h;
    let (cu, cv) = (1.0 / w, 1.0 / h);
    let (last_x, last_y) = (mask.size().0 as i64 - 1, mask.size().1 as i64 - 1);
    // A live last cell of a repeated matte blends its last texels with its first: live on
    // both sides of the edge, the axis is not cut. Clamped, it reaches out on its side.
    let wraps = mask.wraps();
    let (x_out, y_out) = (wraps && xs.1 >= last_x, wraps && ys.1 >= last_y);
    let u0 = if x_out || xs.0 < 0 {
        f64::NEG_INFINITY
    } else {
        u(xs.0) - cu
    };
    let u1 = if x_out || xs.1 >= last_x {
        f64::INFINITY
    } else {
        u(xs.1 + 1) + cu
    };
    let v0 = if y_out || ys.1 >= last_y {
        f64::NEG_INFINITY
    } else {
        v(ys.1 + 1) - cv
    };
    let v1 = if y_out || ys.0 < 0 {
        f64::INFINITY
    } else {
        v(ys.0) + cv
    };
    Some([u0, u1, v0, v1])
}

/// What [`live`] needs of one opacity mask, found once per mask (a pass over its cells).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LiveUv {
    /// `[u min, u max, v min, v max]` of the live cells, widened by a cell.
    b: [f64; 4],
    /// The matte repeats.
    wraps: bool,
}

/// Per mask of `masks` (by matte id), its [`LiveUv`]: `None` for no mask or no live cell.
pub(crate) fn live_uvs(masks: &[Option<OpacityMask>]) -> Vec<Option<LiveUv>> {
    masks
        .iter()
        .map(|m| {
            let m = m.as_ref()?;
            Some(LiveUv {
                b: live_uv_box(m)?,
                wraps: m.wraps(),
            })
        })
        .collect()
}

/// The live part of the primitive with domain `quad` (unit square) or the unit triangle
/// whose texture coordinates at its three corners are `uv`, under the mask of `lu`:
/// `None` where nothing is cut away (the whole domain lives, the mask wraps and `uv`
/// leaves the unit square, or `uv` is not finite or beyond [`MAX_UV`]).
pub(crate) fn live(quad: bool, uv: [Vec2; 3], lu: &LiveUv) -> Option<Live> {
    let b = lu.b;
    if !uv.iter().all(|c| c.abs().max_element() <= MAX_UV) {
        return None;
    }
    if lu.wraps {
        let corners = [uv[0], uv[1], uv[2], uv[1] + uv[2] - uv[0]];
        let n = if quad { 4 } else { 3 };
        if !corners[..n]
            .iter()
            .all(|c| (0.0..=1.0).contains(&c.x) && (0.0..=1.0).contains(&c.y))
        {
            return None;
        }
    }
    let mut poly = Live {
        v: [DVec2::ZERO; MAX_VERTS],
        n: if quad { 4 } else { 3 },
    };
    poly.v[1] = DVec2::X;
    if quad {
        poly.v[2] = DVec2::ONE;
        poly.v[3] = DVec2::Y;
    } else {
        poly.v[2] = DVec2::Y;
    }
    let (o, du, dv) = (
        uv[0].as_dvec2(),
        (uv[1] - uv[0]).as_dvec2(),
        (uv[2] - uv[0]).as_dvec2(),
    );
    // Per axis of uv: `coord(b) = o + b1·d1 + b2·d2`, kept within `[lo, hi]`.
    let mut cut = false;
    for (axis, lo, hi) in [(0, b[0], b[1]), (1, b[2], b[3])] {
        let g = DVec2::new(du[axis], dv[axis]);
        let o = o[axis];
        if lo.is_finite() {
            poly = poly.clip(g, o - lo);
            cut = true;
        }
        if hi.is_finite() {
            poly = poly.clip(-g, hi - o);
            cut = true;
        }
    }
    // Texture coordinates too large for their differences (a clip at an infinite or NaN
    // crossing): keep the primitive whole.
    let finite = poly.verts().iter().all(|p| p.is_finite());
    (cut && finite && poly.n >= 3).then_some(poly)
}

/// [`live`] for a primitive of the scene description (`live`: [`live_uvs`] of the
/// scene's masks). A mask with no live cell keeps the primitive whole: it is never hit,
/// a case not worth a special path.
pub(crate) fn live_prim(p: &Prim, live_uv: &[Option<LiveUv>]) -> Option<Live> {
    let al = p.alpha?;
    live(p.quad, al.uv, live_uv.get(al.id as usize)?.as_ref()?)
}

/// The box of the live part of valid primitive `p` (its whole box where nothing is cut):
/// the cut polygon's corners placed in `f64`, widened by a few units in the last place of
/// its coordinates so that rounding to `f32` never cuts into it.
pub(crate) fn live_bounds(p: &Prim, live_uv: &[Option<LiveUv>]) -> Aabb {
    let full = prim_bounds(p);
    let Some(l) = live_prim(p, live_uv) else {
        return full;
    };
    let (v0, e1, e2) = (
        p.v[0].as_dvec3(),
        (p.v[1] - p.v[0]).as_dvec3(),
        (p.v[2] - p.v[0]).as_dvec3(),
    );
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for b in l.verts() {
        let q = v0 + e1 * b.x + e2 * b.y;
        (lo, hi) = (lo.min(q), hi.max(q));
    }
    let pad = (lo.abs().max(hi.abs()) + (hi - lo)) * (4.0 * f32::EPSILON as f64);
    let (lo, hi) = ((lo - pad).as_vec3(), (hi + pad).as_vec3());
    Aabb {
        min: lo.max(full.min),
        max: hi.min(full.max),
    }
}

/// [`live`] for lane `lane` of pack `p` of `blas`: its matte and texture coordinates read
/// from the lane's alpha flags (`None` for a lane without a matte).
pub(crate) fn live_lane<const W: usize>(
    blas: &Blas<W>,
    live_uv: &[Option<LiveUv>],
    p: &Pack,
    lane: usize,
) -> Option<Live> {
    let fl = p.flags[lane];
    if fl & ALPHA == 0 {
        return None;
    }
    let (id, uv) = if fl & ALPHA_IDENTITY_UV != 0 {
        (fl & FLAG_INDEX, [Vec2::ZERO, Vec2::X, Vec2::Y])
    } else {
        let rec = blas.alpha.get((fl & FLAG_INDEX) as usize)?;
        (rec.id, rec.uv.map(Vec2::from))
    };
    live(p.tri[lane] == 0.0, uv, live_uv.get(id as usize)?.as_ref()?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mask::MaskWrap;

    /// A `w x h` matte opaque in texels `x0..=x1`, `y0..=y1` (rows from the top).
    fn block(w: u32, h: u32, wrap: MaskWrap, x: [i64; 2], y: [i64; 2]) -> OpacityMask {
        OpacityMask::from_texels(w, h, wrap, 0.5, |tx, ty| {
            let (tx, ty) = match wrap {
                MaskWrap::Clamp => (tx.clamp(0, w as i64 - 1), ty.clamp(0, h as i64 - 1)),
                MaskWrap::Repeat => (tx.rem_euclid(w as i64), ty.rem_euclid(h as i64)),
            };
            f32::from((x[0]..=x[1]).contains(&tx) && (y[0]..=y[1]).contains(&ty))
        })
        .unwrap()
    }

    const ID: [Vec2; 3] = [Vec2::ZERO, Vec2::X, Vec2::Y];

    /// [`super::live`] under mask `m`.
    fn live(quad: bool, uv: [Vec2; 3], m: &OpacityMask) -> Option<Live> {
        let lu = live_uvs(&[Some(m.clone())])[0]?;
        super::live(quad, uv, &lu)
    }

    #[test]
    fn a_card_is_cut_to_its_live_cells_and_a_cell_more() {
        // Texels 4..=11 across, 2..=5 down of a 16 x 8 matte: the live cells (bilinear)
        // are 3..=11 across and 1..=5 down.
        let m = block(16, 8, MaskWrap::Clamp, [4, 11], [2, 5]);
        let r = live(true, ID, &m).unwrap().rect();
        let want = [
            3.5 / 16.0 - 1.0 / 16.0,
            12.5 / 16.0 + 1.0 / 16.0,
            1.0 - 6.5 / 8.0 - 1.0 / 8.0,
            1.0 - 1.5 / 8.0 + 1.0 / 8.0,
        ];
        for (a, b) in r.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{r:?} vs {want:?}");
        }
        // Every uv the mask calls live lies inside.
        for y in 0..400 {
            for x in 0..400 {
                let uv = Vec2::new(x as f32 / 399.0, y as f32 / 399.0);
                if m.classify(uv) != crate::mask::TRANSPARENT {
                    let (u, v) = (uv.x as f64, uv.y as f64);
                    assert!(u >= r[0] && u <= r[1] && v >= r[2] && v <= r[3], "{uv}");
                }
            }
        }
    }

    #[test]
    fn texture_coordinates_map_the_cut_into_the_domain() {
        let m = block(16, 16, MaskWrap::Clamp, [4, 11], [4, 11]);
        // A card whose uv runs backwards along b1 and covers half the matte along b2.
        let uv = [
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.5),
        ];
        let l = live(true, uv, &m).unwrap();
        let r = l.rect();
        // u = 1 - b1 lives in [2.5/16, 13.5/16]; v = b2/2 lives from 1 - 13.5/16 = 2.5/16,
        // so b2 from 5/16 up to the domain's end.
        let want = [2.5 / 16.0, 13.5 / 16.0, 5.0 / 16.0, 1.0];
        for (a, b) in r.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{r:?} vs {want:?}");
        }
        // A triangle: the cut polygon stays inside the unit triangle.
        let l = live(false, ID, &m).unwrap();
        assert!(
            l.verts()
                .iter()
                .all(|p| p.x >= -1e-12 && p.y >= -1e-12 && p.x + p.y <= 1.0 + 1e-12)
        );
        assert!(l.verts().len() >= 3);
    }

    #[test]
    fn nothing_is_cut_where_the_matte_reaches_its_edges_or_wraps_away() {
        // Opaque out to a clamped edge on every side: nothing to cut.
        let m = block(8, 8, MaskWrap::Clamp, [0, 7], [0, 7]);
        assert!(live(true, ID, &m).is_none());
        // Opaque to the left edge only: the cut is on the right and the rows.
        let m = block(8, 8, MaskWrap::Clamp, [0, 3], [2, 5]);
        let r = live(true, ID, &m).unwrap().rect();
        assert_eq!(r[0], 0.0);
        assert!(r[1] < 0.75, "{r:?} {:?}", m.live_cells());
        // A repeated matte over uv beyond the unit square: nothing is cut.
        let m = block(8, 8, MaskWrap::Repeat, [2, 5], [2, 5]);
        assert!(live(true, [Vec2::ZERO, Vec2::X * 2.0, Vec2::Y], &m).is_none());
        assert!(live(true, ID, &m).is_some());
        // Opaque texels on both sides of a repeated edge: that axis stays whole.
        let m = block(8, 8, MaskWrap::Repeat, [0, 7], [2, 5]);
        let r = live(true, ID, &m).unwrap().rect();
        assert_eq!((r[0], r[1]), (0.0, 1.0));
        assert!(r[2] > 0.0 && r[3] < 1.0);
        // No live cell: kept whole.
        let m = block(8, 8, MaskWrap::Clamp, [20, 21], [20, 21]);
        assert!(live(true, ID, &m).is_none());
        // Texture coordinates that are not finite, or too large for `f32` interpolation to
        // place within the margin: kept whole. Tiled a few times: cut.
        let m = block(8, 8, MaskWrap::Clamp, [2, 5], [2, 5]);
        for bad in [f32::NAN, f32::INFINITY, -f32::MAX, 65.0] {
            let uv = [Vec2::new(bad, 0.0), Vec2::X, Vec2::Y];
            assert!(live(true, uv, &m).is_none(), "{bad}");
            assert!(live(false, [Vec2::ZERO, Vec2::X, Vec2::new(0.5, bad)], &m).is_none());
        }
        assert!(live(true, [Vec2::ZERO, Vec2::X * 4.0, Vec2::Y], &m).is_some());
    }
}
