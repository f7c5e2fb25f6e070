//! 3-state opacity masks: for every bilinear cell of a matte (the square between four texel
//! centres) whether the matte is opaque everywhere in it, transparent everywhere, or
//! unknown (its outline crosses the cell). The leaf test decides opaque and transparent
//! cells itself; only unknown cells ask the caller's exact matte ([`crate::AlphaFilter`]).
//! After Gruen, Benthin & Woop (HPG 2020, sub-triangle opacity masks), with cells in
//! texture space rather than in barycentric space: one table per matte, shared by every
//! primitive that uses it, exact at the texel grid.

use glam::Vec2;

/// The cell is transparent everywhere: no hit.
pub const TRANSPARENT: u8 = 0;
/// The cell is opaque everywhere: a hit, no lookup.
pub const OPAQUE: u8 = 1;
/// The matte's outline crosses the cell: ask the exact matte.
pub const UNKNOWN: u8 = 2;

/// How a matte's texture coordinates outside `[0, 1]` read it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaskWrap {
    /// Tiled.
    Repeat,
    /// The edge texels extend outward.
    Clamp,
}

/// `v` wrapped into `0..n` (`n > 0`), as `rem_euclid`: without its two divisions where `v`
/// is already inside (a card's uv in `[0, 1]` is, but at its edge texels), for the divisions'
/// latency sat on the leaf test's path (about 4 % of the bush's closest-hit walks).
#[inline(always)]
fn wrapped(v: i64, n: i64) -> i64 {
    if (v as u64) < (n as u64) {
        v
    } else {
        v.rem_euclid(n)
    }
}

/// A 3-state opacity mask over a `width x height` matte sampled bilinearly at texel centres
/// (texel `(x, y)` at `u = (x + 0.5) / width`, `v = 1 - (y + 0.5) / height`: row 0 is the
/// top of the image, `v` grows upward), as [`OpacityMask::classify`] documents.
#[derive(Clone, Debug, PartialEq)]
pub struct OpacityMask {
    width: i64,
    height: i64,
    wrap: MaskWrap,
    /// `Repeat`: `height x width` cells indexed by the wrapped lower-left texel. `Clamp`:
    /// `(height + 1) x (width + 1)` cells for lower-left texels `-1 ..= size - 1`.
    cells: Vec<u8>,
}

impl OpacityMask {
    /// Largest table built (cells); [`OpacityMask::from_texels`] returns `None` above it.
    pub const MAX_CELLS: i64 = 1 << 26;

    /// The mask of a matte whose texel `(x, y)` (any integers: `value` applies the wrap)
    /// has opacity `value(x, y)`, opaque where the bilinear blend is at least `cutoff`. A
    /// margin of 1e-5 around the cutoff keeps rounding in the blend from ever flipping a
    /// decision (such cells are unknown). `None` for an empty or too large matte.
    pub fn from_texels(
        width: u32,
        height: u32,
        wrap: MaskWrap,
        cutoff: f32,
        value: impl Fn(i64, i64) -> f32,
    ) -> Option<Self> {
        let (w, h) = (width as i64, height as i64);
        if w == 0 || h == 0 || (w + 1) * (h + 1) > Self::MAX_CELLS {
            return None;
        }
        let (x_range, y_range) = match wrap {
            MaskWrap::Repeat => (0..w, 0..h),
            MaskWrap::Clamp => (-1..w, -1..h),
        };
        let (hi, lo) = (cutoff + 1e-5, cutoff - 1e-5);
        let mut cells = Vec::with_capacity(
            (x_range.end - x_range.start) as usize * (y_range.end - y_range.start) as usize,
        );
        for y in y_range {
            for x in x_range.clone() {
                let c = [
                    value(x, y),
                    value(x + 1, y),
                    value(x, y + 1),
                    value(x + 1, y + 1),
                ];
                cells.push(if c.iter().all(|&a| a >= hi) {
                    OPAQUE
                } else if c.iter().all(|&a| a < lo) {
                    TRANSPARENT
                } else {
                    UNKNOWN
                });
            }
        }
        Some(OpacityMask {
            width: w,
            height: h,
            wrap,
            cells,
        })
    }

    /// The class ([`OPAQUE`], [`TRANSPARENT`] or [`UNKNOWN`]) of the cell a bilinear lookup
    /// at `uv` blends: texel coordinates `x = u·width - 0.5`, `y = (1 - v)·height - 0.5`,
    /// lower-left texel `(⌊x⌋, ⌊y⌋)`. Non-finite `uv` is unknown.
    #[inline(always)]
    pub fn classify(&self, uv: Vec2) -> u8 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return UNKNOWN;
        }
        let (x0, y0) = (x.floor() as i64, y.floor() as i64);
        let i = match self.wrap {
            MaskWrap::Repeat => wrapped(y0, self.height) * self.width + wrapped(x0, self.width),
            MaskWrap::Clamp => {
                (y0.clamp(-1, self.height - 1) + 1) * (self.width + 1)
                    + x0.clamp(-1, self.width - 1)
                    + 1
            }
        };
        self.cells.get(i as usize).copied().unwrap_or(UNKNOWN)
    }

    /// The matte's size in texels (width, height).
    pub fn size(&self) -> (u32, u32) {
        (self.width as u32, self.height as u32)
    }

    /// Whether texture coordinates outside `[0, 1]` repeat the matte.
    pub fn wraps(&self) -> bool {
        self.wrap == MaskWrap::Repeat
    }

    /// The range of cells (by lower-left texel, as [`OpacityMask::classify`] finds them:
    /// `-1 ..= width - 1` clamped, `0 ..= width - 1` repeated) across and down that are not
    /// transparent everywhere: `((x min, x max), (y min, y max))`, `None` when every cell
    /// is transparent.
    pub fn live_cells(&self) -> Option<((i64, i64), (i64, i64))> {
        let (w, first) = match self.wrap {
            MaskWrap::Repeat => (self.width, 0),
            MaskWrap::Clamp => (self.width + 1, -1),
        };
        let mut r: Option<((i64, i64), (i64, i64))> = None;
        for (i, _) in self
            .cells
            .iter()
            .enumerate()
            .filter(|(_, c)| **c != TRANSPARENT)
        {
            let (x, y) = ((i as i64 % w) + first, (i as i64 / w) + first);
            r = Some(match r {
                None => ((x, x), (y, y)),
                Some(((x0, x1), (y0, y1))) => ((x0.min(x), x1.max(x)), (y0.min(y), y1.max(y))),
            });
        }
        r
    }

    /// Shares of the cells that are opaque, transparent and unknown.
    pub fn shares(&self) -> [f64; 3] {
        let n = self.cells.len().max(1) as f64;
        [OPAQUE, TRANSPARENT, UNKNOWN]
            .map(|c| self.cells.iter().filter(|&&x| x == c).count() as f64 / n)
    }

    /// Heap bytes.
    pub fn bytes(&self) -> usize {
        self.cells.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The wrap's fast path answers as `rem_euclid` inside, outside, at the edges and at
    /// the extremes a saturated `floor` gives.
    #[test]
    fn wrapped_is_rem_euclid() {
        for n in [1i64, 2, 3, 7, 64, 1000] {
            for v in (-3 * n - 2..=3 * n + 2).chain([i64::MIN, i64::MIN + 1, i64::MAX]) {
                assert_eq!(wrapped(v, n), v.rem_euclid(n), "{v} mod {n}");
            }
        }
    }

    /// A repeating mask classifies a point as the same point a whole number of tiles away.
    #[test]
    fn repeat_classifies_tiles_alike() {
        let (w, h) = (7u32, 5u32);
        let m = OpacityMask::from_texels(w, h, MaskWrap::Repeat, 0.5, |x, y| {
            let (x, y) = (x.rem_euclid(7), y.rem_euclid(5));
            ((x * 37 + y * 11) % 10) as f32 / 9.0
        })
        .unwrap();
        for i in 0..2000 {
            let uv = Vec2::new(
                (i % 50) as f32 / 50.0 + 0.003,
                (i / 50) as f32 / 40.0 + 0.002,
            );
            let here = m.classify(uv);
            for (du, dv) in [(-3.0, 0.0), (1.0, -2.0), (0.0, 5.0), (-1.0, -1.0)] {
                assert_eq!(m.classify(uv + Vec2::new(du, dv)), here, "{uv}");
            }
        }
    }
}
