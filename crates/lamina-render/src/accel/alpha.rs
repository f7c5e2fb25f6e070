//! The alpha test: a material's matte or a leaf's alpha map, decided at the interpolated
//! texture coordinate, and the 3-state [`OpacityMask`] lamina-accel decides most candidate
//! hits with (opaque and transparent cells; only cells the outline crosses come back here).

use glam::Vec2;
use lamina_accel::{MaskWrap, OpacityMask};
use lamina_core::AlphaMask;
use lamina_leaf::{Texture, Wrap};
use std::sync::Arc;

/// The alpha test of one material.
#[derive(Clone, Debug)]
pub(super) enum AlphaTest {
    /// Opaque everywhere.
    None,
    /// A matte (`pbr`, `diffuse`, ... with `alpha`).
    Mask(AlphaMask),
    /// A leaf's alpha map ([`lamina_leaf::LeafMaterial::opaque`]).
    Leaf(Arc<lamina_leaf::LeafMaterial>),
}

/// The mask of `map` read through `channel`, opaque where the bilinear blend is at least
/// `cutoff` (the arithmetic of [`Texture::sample`]).
fn mask_of(map: &Texture, alpha_channel: bool, cutoff: f32) -> Option<OpacityMask> {
    let wrap = match map.wrap {
        Wrap::Repeat => MaskWrap::Repeat,
        Wrap::Clamp => MaskWrap::Clamp,
    };
    OpacityMask::from_texels(map.width(), map.height(), wrap, cutoff, |x, y| {
        let s = map.texel(x, y);
        if alpha_channel { s.w } else { s.x }
    })
}

impl AlphaTest {
    /// Whether the surface exists at `uv` (the exact test).
    #[inline]
    pub(super) fn opaque(&self, uv: Vec2) -> bool {
        match self {
            AlphaTest::None => true,
            AlphaTest::Mask(m) => m.opaque(uv),
            AlphaTest::Leaf(l) => l.opaque(uv),
        }
    }

    /// Whether there is a test at all.
    pub(super) fn is_some(&self) -> bool {
        match self {
            AlphaTest::None => false,
            AlphaTest::Mask(_) => true,
            AlphaTest::Leaf(l) => l.matte().is_some(),
        }
    }

    /// The opacity mask of the matte, exact at its texel grid; `None` for no matte and
    /// for mattes too large for a table.
    pub(super) fn mask(&self) -> Option<OpacityMask> {
        match self {
            AlphaTest::None => None,
            AlphaTest::Mask(m) => mask_of(&m.map, m.use_alpha_channel, m.cutoff),
            AlphaTest::Leaf(l) => {
                let (map, alpha_channel) = l.matte()?;
                mask_of(map, alpha_channel, 0.5)
            }
        }
    }
}
