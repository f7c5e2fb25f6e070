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
    /// `(height + 1) x (width + 1)` cells for lower-left texels `-1 ..= size - 1`. Two bits
    /// a cell, [`CELLS_PER_WORD`] to a word from its low bits up, the last word's spare
    /// cells [`UNKNOWN`]: a quarter of a byte a cell, so that the cells the leaf tests read
    /// stay in the first-level cache (a byte a cell, the bush's three mattes took 124 KB).
    cells: Vec<u64>,
    /// Cells held (the words' spare cells not counted).
    len: usize,
}

/// Cells in one word of [`OpacityMask`]'s table.
const CELLS_PER_WORD: usize = 32;

/// The class of cell `i` in a packed table (`UNKNOWN` past its end).
#[inline(always)]
fn cell_in(words: &[u64], i: u64) -> u8 {
    match words.get((i / CELLS_PER_WORD as u64) as usize) {
        Some(w) => ((w >> ((i % CELLS_PER_WORD as u64) * 2)) & 3) as u8,
        None => UNKNOWN,
    }
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
        let len = (x_range.end - x_range.start) as usize * (y_range.end - y_range.start) as usize;
        let mut cells = vec![0u64; len.div_ceil(CELLS_PER_WORD)];
        let mut i = 0;
        for y in y_range {
            for x in x_range.clone() {
                let c = [
                    value(x, y),
                    value(x + 1, y),
                    value(x, y + 1),
                    value(x + 1, y + 1),
                ];
                let class = if c.iter().all(|&a| a >= hi) {
                    OPAQUE
                } else if c.iter().all(|&a| a < lo) {
                    TRANSPARENT
                } else {
                    UNKNOWN
                };
                cells[i / CELLS_PER_WORD] |= (class as u64) << ((i % CELLS_PER_WORD) * 2);
                i += 1;
            }
        }
        for j in len..cells.len() * CELLS_PER_WORD {
            cells[j / CELLS_PER_WORD] |= (UNKNOWN as u64) << ((j % CELLS_PER_WORD) * 2);
        }
        Some(OpacityMask {
            width: w,
            height: h,
            wrap,
            cells,
            len,
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
        // (A negative index, which the wrap and the clamp never give, reads past the end.)
        cell_in(&self.cells, i as u64)
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
        for i in (0..self.len).filter(|&i| cell_in(&self.cells, i as u64) != TRANSPARENT) {
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
        let n = self.len.max(1) as f64;
        let mut count = [0usize; 3];
        for i in 0..self.len {
            count[cell_in(&self.cells, i as u64) as usize] += 1;
        }
        [OPAQUE, TRANSPARENT, UNKNOWN].map(|c| count[c as usize] as f64 / n)
    }

    /// Heap bytes.
    pub fn bytes(&self) -> usize {
        self.cells.len() * std::mem::size_of::<u64>()
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

    /// The class of the cell with lower-left texel `(x, y)` (wrap applied by `value`), as
    /// `from_texels` decides it, for the packed table to be checked against.
    fn class_of(value: &impl Fn(i64, i64) -> f32, x: i64, y: i64) -> u8 {
        let c = [
            value(x, y),
            value(x + 1, y),
            value(x, y + 1),
            value(x + 1, y + 1),
        ];
        if c.iter().all(|&a| a >= 0.5 + 1e-5) {
            OPAQUE
        } else if c.iter().all(|&a| a < 0.5 - 1e-5) {
            TRANSPARENT
        } else {
            UNKNOWN
        }
    }

    /// Two bits a cell, 32 to a word: every cell of mattes whose tables end inside a word,
    /// at its end and one cell past it reads back the class it was built with, through
    /// `classify` at the cell's centre, in both wrap modes; `shares` counts the cells the
    /// table holds (not the word's spare ones) and `bytes` is a quarter of a byte a cell.
    #[test]
    fn packed_cells_read_back_as_built() {
        for (w, h) in [
            (1u32, 1u32),
            (7, 5),
            (31, 1),
            (32, 1),
            (33, 1),
            (15, 2),
            (16, 2),
            (40, 9),
        ] {
            for wrap in [MaskWrap::Repeat, MaskWrap::Clamp] {
                let (wi, hi) = (w as i64, h as i64);
                let texel = move |x: i64, y: i64| -> f32 {
                    let (x, y) = match wrap {
                        MaskWrap::Repeat => (x.rem_euclid(wi), y.rem_euclid(hi)),
                        MaskWrap::Clamp => (x.clamp(0, wi - 1), y.clamp(0, hi - 1)),
                    };
                    [0.0, 1.0, 0.2, 0.9, 0.6][((x * 7 + y * 3 + x * y) % 5) as usize]
                };
                let m = OpacityMask::from_texels(w, h, wrap, 0.5, texel).unwrap();
                let first = if wrap == MaskWrap::Repeat { 0 } else { -1 };
                let mut count = [0usize; 3];
                for y in first..hi {
                    for x in first..wi {
                        let want = class_of(&texel, x, y);
                        count[want as usize] += 1;
                        // The centre of the cell: texel coordinates x + 0.5, y + 0.5.
                        let uv = Vec2::new(
                            (x as f32 + 1.0) / w as f32,
                            1.0 - (y as f32 + 1.0) / h as f32,
                        );
                        assert_eq!(m.classify(uv), want, "{w}x{h} {wrap:?} cell ({x}, {y})");
                    }
                }
                let n = count.iter().sum::<usize>() as f64;
                let want = [OPAQUE, TRANSPARENT, UNKNOWN].map(|c| count[c as usize] as f64 / n);
                assert_eq!(m.shares(), want, "{w}x{h} {wrap:?}");
                assert_eq!(m.bytes(), (count.iter().sum::<usize>()).div_ceil(32) * 8);
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
