//! Contact sheets: a leaf folder's seven maps and two small renders on one PNG.
//!
//! Layout (3 x 3 tiles, each labelled): front, back, translucency / alpha, thickness,
//! extinction / bump, *lit from the front*, *lit from behind*. The maps are shown as stored
//! (colour maps in their sRGB encoding, data maps as grey values `v -> v`), the whole card
//! (also outside the matte). The renders shade the flat card per pixel with
//! [`lamina_leaf::LeafMaterial::bsdf`]`(uv).eval(wo, wi)` under one directional light of
//! irradiance `pi` at normal incidence (so a white Lambertian reflector would show as 1),
//! viewed head-on from the adaxial side, alpha-tested with 3x3 supersampling and composited
//! over a neutral grey. The front-lit light comes from the upper left at 30 degrees from the
//! normal on the viewer's side; the back-lit one from behind the leaf at 25 degrees, so only
//! light transmitted through the blade reaches the viewer. No ray tracer is involved.

use crate::LeafMapsError;
use crate::folder::MAP_FILES;
use crate::plane::{Plane, Rgb};
use glam::{Vec2, Vec3};
use image::RgbImage;
use lamina_leaf::texture::linear_to_srgb;
use lamina_leaf::{Bsdf, LeafDescription, LeafMaterial};
use std::path::Path;

/// Options of [`sheet`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SheetOptions {
    /// Tile size in pixels (each map is fitted into a square tile of this size).
    pub tile: u32,
    /// Exposure multiplier of the back-lit render (transmitted light is dimmer than
    /// reflected light; 1 shows both at the same exposure).
    pub backlit_exposure: f32,
}

impl Default for SheetOptions {
    fn default() -> Self {
        SheetOptions {
            tile: 256,
            backlit_exposure: 1.0,
        }
    }
}

const BG: [f32; 3] = [0.5, 0.5, 0.5];
const LABEL_H: usize = 14;

/// Renders the contact sheet of the leaf folder `dir` (which holds `leaf.toml`) and writes it
/// to `out` (`.png` or `.jpg`, checked before any work; written atomically). Maps missing
/// from the description show as empty tiles.
pub fn sheet(dir: &Path, out: &Path, opts: &SheetOptions) -> Result<(), LeafMapsError> {
    lamina_io::image_out::format_for(out)?;
    let img = sheet_image(dir, opts)?;
    save_rgb(out, &img)
}

/// Writes an RGB image atomically (type from the extension), creating the parent folder.
pub fn save_rgb(out: &Path, img: &RgbImage) -> Result<(), LeafMapsError> {
    lamina_io::image_out::format_for(out)?;
    if let Some(p) = out.parent()
        && !p.as_os_str().is_empty()
    {
        std::fs::create_dir_all(p).map_err(|source| LeafMapsError::Write {
            path: p.to_owned(),
            cause: source,
        })?;
    }
    Ok(lamina_io::save_image(out, img)?)
}

/// The contact sheet of the leaf folder `dir` as an image (see the module docs).
pub fn sheet_image(dir: &Path, opts: &SheetOptions) -> Result<RgbImage, LeafMapsError> {
    let desc = LeafDescription::from_toml_file(&dir.join("leaf.toml"))?;
    let material = LeafMaterial::load(&desc, dir)?;
    let t = opts.tile.clamp(32, 4096) as usize;
    let m = &desc.maps;
    let paths = [
        (&m.front, "FRONT"),
        (&m.back, "BACK"),
        (&m.translucency, "TRANSLUCENCY"),
        (&m.alpha, "ALPHA"),
        (&m.thickness, "THICKNESS"),
        (&m.extinction, "EXTINCTION"),
        (&m.bump, "BUMP"),
    ];
    // Card aspect from the alpha map (or the front), for the renders.
    let mut aspect = 1.0;
    let mut tiles: Vec<(Rgb, String)> = Vec::new();
    for (p, label) in paths {
        let tile = match p {
            Some(p) => {
                let path = dir.join(p);
                let img = crate::prepare::open_checked(&path)?.into_rgb32f();
                let (w, h) = (img.width() as usize, img.height() as usize);
                if label == "ALPHA" || (label == "FRONT" && aspect == 1.0) {
                    aspect = w as f32 / h as f32;
                }
                let plane = Plane {
                    width: w,
                    height: h,
                    data: img.pixels().map(|p| p.0).collect(),
                };
                fit(&plane, t)
            }
            None => Plane::filled(t, t, BG),
        };
        tiles.push((tile, label.to_string()));
    }
    let _ = MAP_FILES;
    tiles.push((
        render(&material, aspect, t, false, 1.0),
        "LIT FROM FRONT".into(),
    ));
    tiles.push((
        render(&material, aspect, t, true, opts.backlit_exposure),
        if opts.backlit_exposure == 1.0 {
            "LIT FROM BEHIND".into()
        } else {
            format!("LIT FROM BEHIND X{}", opts.backlit_exposure)
        },
    ));
    Ok(compose(&tiles, 3, t))
}

/// Side-by-side of several images (e.g. sheets of a real and a generated leaf), top-aligned
/// on a dark background.
pub fn side_by_side(images: &[RgbImage]) -> RgbImage {
    let gap = 8;
    let w: u32 =
        images.iter().map(|i| i.width()).sum::<u32>() + gap * images.len().saturating_sub(1) as u32;
    let h = images.iter().map(|i| i.height()).max().unwrap_or(1);
    let mut out = RgbImage::from_pixel(w.max(1), h, image::Rgb([30, 30, 30]));
    let mut x0 = 0;
    for img in images {
        for (x, y, p) in img.enumerate_pixels() {
            out.put_pixel(x0 + x, y, *p);
        }
        x0 += img.width() + gap;
    }
    out
}

/// Fits a stored-value image into a `t x t` tile (aspect kept, grey border).
fn fit(p: &Rgb, t: usize) -> Rgb {
    let s = (t as f32 / p.width as f32).min(t as f32 / p.height as f32);
    let (w, h) = (
        ((p.width as f32 * s).round() as usize).clamp(1, t),
        ((p.height as f32 * s).round() as usize).clamp(1, t),
    );
    let r = p.resample(w, h);
    let (ox, oy) = ((t - w) / 2, (t - h) / 2);
    Plane::from_fn(t, t, |x, y| {
        if x >= ox && x < ox + w && y >= oy && y < oy + h {
            r.get(x - ox, y - oy)
        } else {
            BG
        }
    })
}

/// Renders the card (see the module docs); output values are sRGB-encoded for display.
fn render(m: &LeafMaterial, aspect: f32, t: usize, backlit: bool, exposure: f32) -> Rgb {
    let (w, h) = if aspect >= 1.0 {
        (t, ((t as f32 / aspect).round() as usize).max(1))
    } else {
        (((t as f32 * aspect).round() as usize).max(1), t)
    };
    let (ox, oy) = ((t - w.min(t)) / 2, (t - h.min(t)) / 2);
    let wo = Vec3::Z;
    let wi = if backlit {
        Vec3::new(0.3, 0.25, -0.92).normalize()
    } else {
        Vec3::new(-0.35, 0.35, 0.87).normalize()
    };
    let e = std::f32::consts::PI * exposure;
    let bg = Vec3::from_array(BG);
    let ss = 3;
    Plane::from_fn(t, t, |x, y| {
        if x < ox || y < oy || x >= ox + w || y >= oy + h {
            return BG.map(linear_to_srgb);
        }
        let mut acc = Vec3::ZERO;
        for j in 0..ss {
            for i in 0..ss {
                let u = ((x - ox) as f32 + (i as f32 + 0.5) / ss as f32) / w as f32;
                let v = 1.0 - ((y - oy) as f32 + (j as f32 + 0.5) / ss as f32) / h as f32;
                let uv = Vec2::new(u, v);
                acc += if m.opaque(uv) {
                    let l = m.bsdf(uv).eval(wo, wi) * e;
                    if l.is_finite() { l } else { Vec3::ZERO }
                } else {
                    bg
                };
            }
        }
        let c = acc / (ss * ss) as f32;
        [
            linear_to_srgb(c.x.clamp(0.0, 1.0)),
            linear_to_srgb(c.y.clamp(0.0, 1.0)),
            linear_to_srgb(c.z.clamp(0.0, 1.0)),
        ]
    })
}

/// Draws `text` (upper case) with 2x2-pixel dots at `(x0, y0)`.
fn draw_text(img: &mut RgbImage, text: &str, x0: u32, y0: u32) {
    let mut x = x0;
    for c in text.chars() {
        let g = lamina_io::font::glyph(c).unwrap_or([0; 5]);
        for (r, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    for dy in 0..2 {
                        for dx in 0..2 {
                            let (px, py) = (x + col * 2 + dx, y0 + r as u32 * 2 + dy);
                            if px < img.width() && py < img.height() {
                                img.put_pixel(px, py, image::Rgb([235, 235, 235]));
                            }
                        }
                    }
                }
            }
        }
        x += 8;
    }
}

fn compose(tiles: &[(Rgb, String)], cols: usize, t: usize) -> RgbImage {
    let gap = 4;
    let rows = tiles.len().div_ceil(cols);
    let cell_h = t + LABEL_H;
    let w = cols * t + (cols + 1) * gap;
    let h = rows * cell_h + (rows + 1) * gap;
    let mut img = RgbImage::from_pixel(w as u32, h as u32, image::Rgb([40, 40, 40]));
    for (k, (tile, label)) in tiles.iter().enumerate() {
        let (cx, cy) = (k % cols, k / cols);
        let x0 = gap + cx * (t + gap);
        let y0 = gap + cy * (cell_h + gap);
        draw_text(&mut img, label, x0 as u32 + 2, y0 as u32 + 2);
        for y in 0..t {
            for x in 0..t {
                let c = tile.get(x, y);
                let px = c.map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
                img.put_pixel((x0 + x) as u32, (y0 + LABEL_H + y) as u32, image::Rgb(px));
            }
        }
    }
    img
}
