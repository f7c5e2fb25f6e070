//! The texel grids of the baked maps: evaluating a function at every texel centre (on
//! all cores), sizing grids under the device's texture limit, filling the matte's
//! transparent texels, and building box-filtered mip chains in linear space with 8-bit
//! sRGB or linear encoding.

use glam::Vec2;
use lamina_leaf::texture::linear_to_srgb;
use lamina_scene::ColorInput;

use super::MipMap;

/// Linear RGB + alpha at one texel, before encoding.
pub(super) type Texel = [f32; 4];

/// sRGB 8-bit encoding of linear colour (alpha linear).
pub(super) fn encode(c: Texel) -> [u8; 4] {
    let q = |x: f32| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [
        q(linear_to_srgb(c[0])),
        q(linear_to_srgb(c[1])),
        q(linear_to_srgb(c[2])),
        q(c[3]),
    ]
}

/// Builds the mip chain of a linear map by 2x2 box filtering (odd sides clamp).
pub(super) fn mip_chain(width: u32, height: u32, base: Vec<Texel>) -> MipMap {
    mip_chain_with(width, height, base, encode)
}

/// Linear 8-bit encoding (normal maps).
pub(super) fn encode_linear(c: Texel) -> [u8; 4] {
    c.map(|x| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
}

/// The flat normal map of materials without one.
pub(super) fn flat_normal() -> MipMap {
    mip_chain_with(1, 1, vec![[0.5, 0.5, 1.0, 1.0]], encode_linear)
}

/// [`mip_chain`] with the given 8-bit encoding.
pub(super) fn mip_chain_with(
    width: u32,
    height: u32,
    base: Vec<Texel>,
    encode: fn(Texel) -> [u8; 4],
) -> MipMap {
    let mut levels = vec![base.iter().map(|&t| encode(t)).collect::<Vec<_>>()];
    let (mut w, mut h, mut cur) = (width, height, base);
    while w > 1 || h > 1 {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut next = vec![[0.0; 4]; (nw * nh) as usize];
        for y in 0..nh {
            for x in 0..nw {
                let mut acc = [0.0f32; 4];
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(w - 1);
                    let sy = (2 * y + dy).min(h - 1);
                    let t = cur[(sy * w + sx) as usize];
                    for c in 0..4 {
                        acc[c] += 0.25 * t[c];
                    }
                }
                next[(y * nw + x) as usize] = acc;
            }
        }
        levels.push(next.iter().map(|&t| encode(t)).collect());
        (w, h, cur) = (nw, nh, next);
    }
    MipMap {
        width,
        height,
        levels,
    }
}

/// The bake resolution for maps of size `(w, h)` under the texture limit, with a warning
/// naming the material and the limit when it had to shrink.
pub(super) fn fit(
    name: &str,
    what: &str,
    w: u32,
    h: u32,
    limit: u32,
    warnings: &mut Vec<String>,
) -> (u32, u32) {
    let m = w.max(h);
    if m <= limit {
        return (w.max(1), h.max(1));
    }
    let s = limit as f32 / m as f32;
    let (nw, nh) = (
        ((w as f32 * s) as u32).clamp(1, limit),
        ((h as f32 * s) as u32).clamp(1, limit),
    );
    warnings.push(format!(
        "material '{name}': {what} is {w}x{h}, over the GPU's texture limit of {limit}; \
         downscaled to {nw}x{nh} for the GPU path"
    ));
    (nw, nh)
}

/// Evaluates `f(uv)` at every texel centre of a `w x h` map (top row first), on all cores.
pub(super) fn bake_texels(
    w: u32,
    h: u32,
    f: &(dyn Fn(Vec2) -> [Texel; 3] + Sync),
) -> [Vec<Texel>; 3] {
    let n = (w * h) as usize;
    let mut out = [vec![[0.0; 4]; n], vec![[0.0; 4]; n], vec![[0.0; 4]; n]];
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(16);
    let rows_per = (h as usize).div_ceil(threads).max(1);
    let [a, b, c] = &mut out;
    std::thread::scope(|s| {
        for (((ca, cb), cc), chunk) in a
            .chunks_mut(rows_per * w as usize)
            .zip(b.chunks_mut(rows_per * w as usize))
            .zip(c.chunks_mut(rows_per * w as usize))
            .zip(0..)
        {
            s.spawn(move || {
                for (i, ((ta, tb), tc)) in ca
                    .iter_mut()
                    .zip(cb.iter_mut())
                    .zip(cc.iter_mut())
                    .enumerate()
                {
                    let idx = chunk * rows_per * w as usize + i;
                    let (x, y) = ((idx % w as usize) as f32, (idx / w as usize) as f32);
                    let uv = Vec2::new((x + 0.5) / w as f32, 1.0 - (y + 0.5) / h as f32);
                    let [p, q, r] = f(uv);
                    (*ta, *tb, *tc) = (p, q, r);
                }
            });
        }
    });
    out
}

/// Gives the transparent texels (front alpha < 0.5) of all three maps the mean colour of
/// the opaque ones, so that bilinear filtering and mip levels at the matte's edge blend
/// leaf with leaf rather than with whatever the maps hold outside the blade (a bright rim
/// otherwise).
pub(super) fn fill_transparent(maps: &mut [Vec<Texel>; 3]) {
    let opaque: Vec<bool> = maps[0].iter().map(|t| t[3] >= 0.5).collect();
    let n = opaque.iter().filter(|&&o| o).count();
    if n == 0 || n == opaque.len() {
        return;
    }
    for m in maps.iter_mut() {
        let mut mean = [0.0f64; 3];
        for (t, _) in m.iter().zip(&opaque).filter(|(_, o)| **o) {
            for c in 0..3 {
                mean[c] += t[c] as f64 / n as f64;
            }
        }
        for (t, _) in m.iter_mut().zip(&opaque).filter(|(_, o)| !**o) {
            for c in 0..3 {
                t[c] = mean[c] as f32;
            }
        }
    }
}

/// The texel size of a colour input (1x1 for a constant).
pub(super) fn colour_size(c: &ColorInput) -> (u32, u32) {
    match c {
        ColorInput::Constant(_) => (1, 1),
        ColorInput::Texture { map, .. } | ColorInput::Mapped { map, .. } => {
            (map.width(), map.height())
        }
    }
}
