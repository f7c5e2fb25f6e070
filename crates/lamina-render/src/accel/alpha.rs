//! The alpha test: a material's matte or a leaf's alpha map, decided at the interpolated
//! texture coordinate, and the 3-state [`OpacityMask`] lamina-accel decides most candidate
//! hits with (opaque and transparent cells; only cells the outline crosses come back here).

use glam::Vec2;
use lamina_accel::{MaskWrap, OpacityMask};
use lamina_core::AlphaMask;
use lamina_leaf::{Texture, TextureChannel, Wrap};

/// The alpha test of one material.
#[derive(Clone, Debug)]
pub(super) enum AlphaTest {
    /// Opaque everywhere.
    None,
    /// A matte: a material's `alpha` ([`AlphaMask`]) or a leaf's alpha map
    /// ([`lamina_leaf::LeafMaterial::opaque`]).
    Matte(Matte),
}

/// A matte's test: the surface is there where the bilinear blend of one channel of `map`
/// is at least `cutoff`.
#[derive(Clone, Debug)]
pub(super) struct Matte {
    map: Texture,
    alpha_channel: bool,
    cutoff: f32,
    /// That channel on its own, which the exact test reads (a quarter of the texture's
    /// bytes: the lookups the opacity masks leave land at scattered texels); `None` for
    /// a matte of more than [`CHANNEL_TEXELS`] texels, whose copy would cost more memory
    /// than its lookups gain (the test reads the texture itself).
    channel: Option<TextureChannel>,
}

/// Largest matte (texels) whose channel the exact test keeps a copy of: 16 MiB of `f32`.
pub(super) const CHANNEL_TEXELS: u64 = 1 << 22;

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
    /// The test of a material's matte: [`AlphaMask::opaque`]'s.
    pub(super) fn of_mask(m: &AlphaMask) -> AlphaTest {
        AlphaTest::matte(&m.map, m.use_alpha_channel, m.cutoff, CHANNEL_TEXELS)
    }

    /// The test of a leaf: [`lamina_leaf::LeafMaterial::opaque`]'s (its matte at 0.5), or
    /// none for a leaf without an alpha map.
    pub(super) fn of_leaf(l: &lamina_leaf::LeafMaterial) -> AlphaTest {
        l.matte().map_or(AlphaTest::None, |(map, alpha)| {
            AlphaTest::matte(map, alpha, 0.5, CHANNEL_TEXELS)
        })
    }

    /// The test of `map`'s alpha channel (else its first) at `cutoff`, keeping that
    /// channel on its own when the map has at most `channel_texels` texels.
    pub(super) fn matte(
        map: &Texture,
        alpha_channel: bool,
        cutoff: f32,
        channel_texels: u64,
    ) -> AlphaTest {
        AlphaTest::Matte(Matte {
            map: map.clone(),
            alpha_channel,
            cutoff,
            channel: (u64::from(map.width()) * u64::from(map.height()) <= channel_texels)
                .then(|| map.channel(if alpha_channel { 3 } else { 0 })),
        })
    }

    /// Whether the surface exists at `uv` (the exact test).
    #[inline]
    pub(super) fn opaque(&self, uv: Vec2) -> bool {
        match self {
            AlphaTest::None => true,
            AlphaTest::Matte(m) => {
                let a = match &m.channel {
                    Some(c) => c.sample(uv),
                    None => {
                        let s = m.map.sample(uv);
                        if m.alpha_channel { s.w } else { s.x }
                    }
                };
                a >= m.cutoff
            }
        }
    }

    /// Whether there is a test at all.
    pub(super) fn is_some(&self) -> bool {
        matches!(self, AlphaTest::Matte(_))
    }

    /// The opacity mask of the matte, exact at its texel grid; `None` for no matte and
    /// for mattes too large for a table.
    pub(super) fn mask(&self) -> Option<OpacityMask> {
        match self {
            AlphaTest::None => None,
            AlphaTest::Matte(m) => mask_of(&m.map, m.alpha_channel, m.cutoff),
        }
    }
}
