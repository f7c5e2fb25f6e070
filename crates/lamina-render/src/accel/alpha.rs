//! The alpha test of the traversal: a material's matte (with an exact per-cell shortcut) or
//! a leaf's opacity, decided at the interpolated texture coordinate.

use glam::Vec2;
use lamina_core::AlphaMask;
use std::sync::Arc;

/// Cell classes of a [`MaskCells`] table.
pub(super) const CELL_TRANSPARENT: u8 = 0;
pub(super) const CELL_OPAQUE: u8 = 1;
pub(super) const CELL_MIXED: u8 = 2;

/// An exact shortcut for [`AlphaMask::opaque`]: for every bilinear cell (the square between
/// four texel centres) whether the mask is opaque everywhere in it (all four corners at
/// least the cutoff: a bilinear blend stays within its corners), transparent everywhere (all
/// below), or mixed. Only mixed cells, along the matte's outline, need the filtered lookup;
/// the others cost one byte read instead of four texel fetches.
#[derive(Clone, Debug)]
pub(super) struct MaskCells {
    pub(super) width: i64,
    pub(super) height: i64,
    pub(super) repeat: bool,
    /// `Repeat`: `height x width` cells indexed by the wrapped lower-left texel. `Clamp`:
    /// `(height + 1) x (width + 1)` cells for lower-left texels `-1 ..= size - 1`.
    pub(super) cells: Vec<u8>,
}

impl MaskCells {
    /// Largest table built (cells); bigger mattes use the filtered lookup only.
    const MAX_CELLS: i64 = 1 << 26;

    pub(super) fn new(mask: &AlphaMask) -> Option<Self> {
        let t = &mask.map;
        let (w, h) = (t.width() as i64, t.height() as i64);
        let repeat = t.wrap == lamina_leaf::Wrap::Repeat;
        let (x_range, y_range) = if repeat { (0..w, 0..h) } else { (-1..w, -1..h) };
        if (w + 1) * (h + 1) > Self::MAX_CELLS {
            return None;
        }
        // A margin keeps rounding in the bilinear blend from ever flipping a decision.
        let (hi, lo) = (mask.cutoff + 1e-5, mask.cutoff - 1e-5);
        let value = |x: i64, y: i64| {
            let s = t.texel(x, y);
            if mask.use_alpha_channel { s.w } else { s.x }
        };
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
                    CELL_OPAQUE
                } else if c.iter().all(|&a| a < lo) {
                    CELL_TRANSPARENT
                } else {
                    CELL_MIXED
                });
            }
        }
        Some(MaskCells {
            width: w,
            height: h,
            repeat,
            cells,
        })
    }

    /// The class of the cell [`lamina_leaf::Texture::sample`] blends at `uv` (same
    /// arithmetic, so the same cell).
    #[inline(always)]
    pub(super) fn classify(&self, uv: Vec2) -> u8 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return CELL_MIXED;
        }
        let (x0, y0) = (x.floor() as i64, y.floor() as i64);
        let i = if self.repeat {
            y0.rem_euclid(self.height) * self.width + x0.rem_euclid(self.width)
        } else {
            (y0.clamp(-1, self.height - 1) + 1) * (self.width + 1)
                + x0.clamp(-1, self.width - 1)
                + 1
        };
        self.cells.get(i as usize).copied().unwrap_or(CELL_MIXED)
    }
}

#[derive(Clone, Debug)]
pub(super) enum AlphaTest {
    None,
    Mask(AlphaMask, Option<MaskCells>),
    Leaf(Arc<lamina_leaf::LeafMaterial>),
}

impl AlphaTest {
    #[inline]
    pub(super) fn opaque(&self, uv: Vec2) -> bool {
        match self {
            AlphaTest::None => true,
            AlphaTest::Mask(m, cells) => match cells.as_ref().map(|c| c.classify(uv)) {
                Some(CELL_OPAQUE) => true,
                Some(CELL_TRANSPARENT) => false,
                _ => m.opaque(uv),
            },
            AlphaTest::Leaf(l) => l.opaque(uv),
        }
    }
}
