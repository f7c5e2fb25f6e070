//! The card: the pixel grid fitted around the outline, and the mapping between card space
//! (design units after the midrib bend) and pixels.

use super::outline::Outline;
use glam::Vec2;

/// The pixel grid of the card: `w x h` square pixels over card space, pixel `(0, 0)` at the
/// top left (the leaf tip is at the top).
#[derive(Clone, Copy, Debug)]
pub(super) struct PixelGrid {
    /// Width in pixels.
    pub(super) w: usize,
    /// Height in pixels.
    pub(super) h: usize,
    /// Card-space `x` of the left edge, design units.
    x0: f32,
    /// Card-space `y` of the top edge, design units.
    top: f32,
    /// Pixels per design unit (square pixels).
    pub(super) ppu: f32,
}

impl PixelGrid {
    /// Card-space position of the centre of pixel `(x, y)`.
    #[inline]
    pub(super) fn card(&self, x: usize, y: usize) -> Vec2 {
        Vec2::new(
            self.x0 + (x as f32 + 0.5) / self.ppu,
            self.top - (y as f32 + 0.5) / self.ppu,
        )
    }

    /// Pixel coordinates (continuous, `(0, 0)` the top-left corner) of card position `c`.
    #[inline]
    pub(super) fn pixel(&self, c: Vec2) -> Vec2 {
        Vec2::new((c.x - self.x0) * self.ppu, (self.top - c.y) * self.ppu)
    }

    /// Width and height of the card, design units.
    pub(super) fn card_size(&self) -> (f32, f32) {
        (self.w as f32 / self.ppu, self.h as f32 / self.ppu)
    }
}

/// Fits the card around `outline`: the bounding box of its inside (sampled on a 600 x 600
/// grid of card space), grown by one sample and a 3 % margin, as `res` pixels along its
/// longer side, with the outline centred.
pub(super) fn fit_card(outline: &Outline, res: usize) -> PixelGrid {
    let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
    let n = 600;
    for j in 0..=n {
        for i in 0..=n {
            let c = Vec2::new(
                -1.3 + 2.6 * i as f32 / n as f32,
                -0.8 + 2.0 * j as f32 / n as f32,
            );
            if outline.field(outline.to_design(c)) < 0.0 {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
    }
    let step = 2.6 / n as f32;
    lo -= Vec2::splat(step);
    hi += Vec2::splat(step);
    let ext = hi - lo;
    let margin = 0.03 * ext.max_element();
    let lo = lo - Vec2::splat(margin);
    let hi = hi + Vec2::splat(margin);
    let ext = hi - lo;
    let (w, h) = if ext.x >= ext.y {
        (res, ((res as f32 * ext.y / ext.x).round() as usize).max(8))
    } else {
        (((res as f32 * ext.x / ext.y).round() as usize).max(8), res)
    };
    let ppu = (w as f32 / ext.x).min(h as f32 / ext.y);
    // Centre the outline in the pixel grid.
    let card_w = w as f32 / ppu;
    let card_h = h as f32 / ppu;
    PixelGrid {
        w,
        h,
        x0: 0.5 * (lo.x + hi.x) - 0.5 * card_w,
        top: 0.5 * (lo.y + hi.y) + 0.5 * card_h,
        ppu,
    }
}
