//! A picture of the leaf model.
//!
//! `cargo run --release -p lamina-leaf --example plot_model -- <out_dir>` writes
//!
//! * `rt_vs_angle.png`: directional reflectance (solid) and transmittance (dotted) against
//!   the incidence angle (0-90 degrees), per linear-RGB channel (red, green, blue curves),
//!   for light arriving on the adaxial side (left panel) and on the abaxial side (right
//!   panel); default parameters, no maps (the pure layer model), specular included in R.
//! * `rt_modes.png`: the same for the adaxial side, green channel only, for the three
//!   modes: layered (green), Eq. (1) (orange), diffuse (grey).
//! * `texel_patch.png`: a procedural leaf (midrib, secondary veins, thicker and more
//!   absorbing veins, bump-mapped veins, alpha matte, no back or translucency photo so both
//!   are derived): the adaxial side lit by a directional light from the front (left), the
//!   adaxial side lit from behind (middle, through-light), and the abaxial side lit on its
//!   own side (right, mirrored as seen from below).
//!
//! It also prints the normal-incidence R and T of the default leaf.

use glam::{Vec2, Vec3, Vec4};
use image::{Rgb, RgbImage};
use lamina_leaf::march::Pcg32;
use lamina_leaf::texture::linear_to_srgb;
use lamina_leaf::*;
use std::path::{Path, PathBuf};

/// Directional albedo `∫ eval(wo, wi) dωi`, split into reflection and transmission, by
/// jittered stratified sampling of the BSDF.
fn albedo(b: &LeafBsdf, wo: Vec3, n: u32) -> (Vec3, Vec3) {
    let (mut r, mut t) = (Vec3::ZERO, Vec3::ZERO);
    let lobes = 16;
    let total = (lobes * n * n) as f32;
    let mut rng = Pcg32::new(5);
    for l in 0..lobes {
        for i in 0..n {
            for j in 0..n {
                let u = Vec3::new(
                    (l as f32 + rng.next_f32()) / lobes as f32,
                    (i as f32 + rng.next_f32()) / n as f32,
                    (j as f32 + rng.next_f32()) / n as f32,
                );
                if let Some(s) = b.sample(wo, u) {
                    let w = s.f / s.pdf / total;
                    if s.wi.z * wo.z > 0.0 {
                        r += w;
                    } else {
                        t += w;
                    }
                }
            }
        }
    }
    (r, t)
}

/// 3x5 bitmap digits for tick labels.
const GLYPHS: [[u8; 5]; 11] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
    [0, 0, 0, 0, 2],
];

fn text(img: &mut RgbImage, x: i32, y: i32, s: &str, scale: i32, c: Rgb<u8>) {
    let mut cx = x;
    for ch in s.chars() {
        let g = match ch {
            '0'..='9' => GLYPHS[ch as usize - '0' as usize],
            '.' => GLYPHS[10],
            _ => {
                cx += 4 * scale;
                continue;
            }
        };
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            put(img, cx + col * scale + dx, y + row as i32 * scale + dy, c);
                        }
                    }
                }
            }
        }
        cx += 4 * scale;
    }
}

fn put(img: &mut RgbImage, x: i32, y: i32, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// A plot panel: maps data coordinates (x in degrees 0-90, y in `[0, y_max]`) to pixels.
struct Panel {
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
    y_max: f32,
}

impl Panel {
    fn px(&self, x: f32, y: f32) -> (f32, f32) {
        (
            self.x0 as f32 + x / 90.0 * self.w as f32,
            (self.y0 + self.h) as f32 - y / self.y_max * self.h as f32,
        )
    }

    fn axes(&self, img: &mut RgbImage) {
        let black = Rgb([0, 0, 0]);
        let grid = Rgb([225, 225, 225]);
        let mut y = 0.0;
        while y <= self.y_max + 1e-4 {
            let (_, py) = self.px(0.0, y);
            for x in self.x0..=self.x0 + self.w {
                put(img, x, py as i32, grid);
            }
            for x in self.x0 - 5..self.x0 {
                put(img, x, py as i32, black);
            }
            text(
                img,
                self.x0 - 40,
                py as i32 - 5,
                &format!("{y:.1}"),
                2,
                black,
            );
            y += 0.1;
        }
        for deg in (0..=90).step_by(15) {
            let (px, _) = self.px(deg as f32, 0.0);
            for yy in self.y0..self.y0 + self.h {
                if deg > 0 {
                    put(img, px as i32, yy, grid);
                }
            }
            for yy in self.y0 + self.h..self.y0 + self.h + 6 {
                put(img, px as i32, yy, black);
            }
            let s = format!("{deg}");
            text(
                img,
                px as i32 - 4 * s.len() as i32,
                self.y0 + self.h + 10,
                &s,
                2,
                black,
            );
        }
        for x in self.x0..=self.x0 + self.w {
            put(img, x, self.y0 + self.h, black);
        }
        for y in self.y0..=self.y0 + self.h {
            put(img, self.x0, y, black);
        }
    }

    /// Polyline, `dotted` draws every other 4-pixel stretch.
    fn curve(&self, img: &mut RgbImage, pts: &[(f32, f32)], c: Rgb<u8>, dotted: bool) {
        let mut len = 0.0f32;
        for w in pts.windows(2) {
            let (ax, ay) = self.px(w[0].0, w[0].1);
            let (bx, by) = self.px(w[1].0, w[1].1);
            let steps = ((bx - ax).abs().max((by - ay).abs()) * 2.0).ceil().max(1.0) as i32;
            for s in 0..=steps {
                let t = s as f32 / steps as f32;
                let (x, y) = (ax + (bx - ax) * t, ay + (by - ay) * t);
                len += 0.5;
                if dotted && (len / 4.0) as i32 % 2 == 1 {
                    continue;
                }
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        put(img, x as i32 + dx, y as i32 + dy, c);
                    }
                }
            }
        }
    }
}

const CHANNEL: [Rgb<u8>; 3] = [Rgb([220, 30, 30]), Rgb([20, 160, 40]), Rgb([30, 60, 220])];

fn plot_rt(out: &Path) {
    let m = LeafMaterial::new(LeafMaps::default(), LeafParams::default()).unwrap();
    let b = m.bsdf(Vec2::splat(0.5));
    let angles: Vec<f32> = (0..=45).map(|k| (k as f32 * 2.0).min(89.5)).collect();
    let mut img = RgbImage::from_pixel(1100, 480, Rgb([255, 255, 255]));
    for (panel_idx, below) in [false, true].into_iter().enumerate() {
        let panel = Panel {
            x0: 70 + panel_idx as i32 * 540,
            y0: 30,
            w: 460,
            h: 390,
            y_max: 0.5,
        };
        panel.axes(&mut img);
        let data: Vec<(f32, Vec3, Vec3)> = angles
            .iter()
            .map(|&a| {
                let mut wo = Vec3::new(a.to_radians().sin(), 0.0, a.to_radians().cos());
                if below {
                    wo.z = -wo.z;
                }
                let (r, t) = albedo(&b, wo, 40);
                (a, r, t)
            })
            .collect();
        for (c, &colour) in CHANNEL.iter().enumerate() {
            let r: Vec<(f32, f32)> = data.iter().map(|d| (d.0, d.1[c])).collect();
            let t: Vec<(f32, f32)> = data.iter().map(|d| (d.0, d.2[c])).collect();
            panel.curve(&mut img, &r, colour, false);
            panel.curve(&mut img, &t, colour, true);
        }
        if !below {
            let (r, t) = (data[0].1, data[0].2);
            println!(
                "default leaf, light on the adaxial side, normal incidence: R = {r:.4}, T = {t:.4}"
            );
        } else {
            let (r, t) = (data[0].1, data[0].2);
            println!(
                "default leaf, light on the abaxial side, normal incidence: R = {r:.4}, T = {t:.4}"
            );
        }
    }
    let path = out.join("rt_vs_angle.png");
    lamina_io::save_image(&path, &img).unwrap();
    println!("wrote {}", path.display());

    // The three modes, green channel, adaxial side.
    let mut img = RgbImage::from_pixel(560, 480, Rgb([255, 255, 255]));
    let panel = Panel {
        x0: 70,
        y0: 30,
        w: 460,
        h: 390,
        y_max: 0.5,
    };
    panel.axes(&mut img);
    for (mode, colour) in [
        (LeafMode::Layered, Rgb([20, 160, 40])),
        (LeafMode::Eq1, Rgb([240, 140, 0])),
        (LeafMode::Diffuse, Rgb([120, 120, 120])),
    ] {
        let p = LeafParams {
            mode,
            ..Default::default()
        };
        let b = LeafMaterial::new(LeafMaps::default(), p)
            .unwrap()
            .bsdf(Vec2::splat(0.5));
        let data: Vec<(f32, f32, f32)> = angles
            .iter()
            .map(|&a| {
                let wo = Vec3::new(a.to_radians().sin(), 0.0, a.to_radians().cos());
                let (r, t) = albedo(&b, wo, 32);
                (a, r.y, t.y)
            })
            .collect();
        let r: Vec<(f32, f32)> = data.iter().map(|d| (d.0, d.1)).collect();
        let t: Vec<(f32, f32)> = data.iter().map(|d| (d.0, d.2)).collect();
        panel.curve(&mut img, &r, colour, false);
        panel.curve(&mut img, &t, colour, true);
    }
    let path = out.join("rt_modes.png");
    lamina_io::save_image(&path, &img).unwrap();
    println!("wrote {}", path.display());
}

/// Procedural leaf maps on `[0, 1]^2`: an ellipse with a pointed tip, a midrib along `v`
/// and secondary veins.
fn leaf_maps(res: u32) -> LeafMaps {
    let vein = |u: f32, v: f32| -> f32 {
        let du = u - 0.5;
        let mid = (-(du / 0.012).powi(2)).exp();
        let vv = v - du.abs() * 0.9;
        let period = 0.11;
        let f = (vv / period).rem_euclid(1.0) - 0.5;
        let side = (-(f * period / 0.005).powi(2)).exp() * (du.abs() > 0.01) as i32 as f32;
        (mid + 0.7 * side).min(1.0)
    };
    let inside = |u: f32, v: f32| -> bool {
        let y = (v - 0.05) / 0.9; // 0 at the base, 1 at the tip
        if !(0.0..=1.0).contains(&y) {
            return false;
        }
        let half_width = 0.42 * (std::f32::consts::PI * y.powf(0.8)).sin();
        (u - 0.5).abs() < half_width
    };
    let mk = |f: &dyn Fn(f32, f32) -> Vec4| {
        let texels = (0..res * res)
            .map(|i| {
                let (x, y) = (i % res, i / res);
                // Row 0 is the top of the image: v = 1.
                let u = (x as f32 + 0.5) / res as f32;
                let v = 1.0 - (y as f32 + 0.5) / res as f32;
                f(u, v)
            })
            .collect();
        Some(Texture::from_texels(res, res, texels, Wrap::Clamp))
    };
    LeafMaps {
        front: mk(&|u, v| {
            let base = Vec3::new(0.035, 0.11, 0.015);
            let vc = Vec3::new(0.09, 0.2, 0.04);
            let mottle = 1.0 + 0.1 * (40.0 * u).sin() * (37.0 * v).cos();
            (base * mottle).lerp(vc, vein(u, v)).extend(1.0)
        }),
        back: None,
        translucency: None,
        alpha: mk(&|u, v| Vec4::splat(if inside(u, v) { 1.0 } else { 0.0 })),
        thickness: mk(&|u, v| Vec4::splat(0.4 + 0.6 * vein(u, v))),
        extinction: mk(&|u, v| Vec4::splat(0.4 + 0.6 * vein(u, v))),
        bump: mk(&|u, v| Vec4::splat(0.004 * vein(u, v))),
    }
}

fn render_patch(out: &Path) {
    let res = 256u32;
    let m = LeafMaterial::new(
        leaf_maps(res),
        LeafParams {
            bump_scale: 1.0,
            ..Default::default()
        },
    )
    .unwrap();
    let size = 320u32;
    let views = 3u32;
    let mut img = RgbImage::from_pixel(size * views, size, Rgb([0, 0, 0]));
    // A light 35 degrees off the normal, the viewer 8 degrees off it on the same azimuth
    // (away from the mirror direction, so the highlight shows only on tilted vein flanks).
    let light_front = Vec3::new(-0.57, 0.0, 0.82);
    let light_back = Vec3::new(-0.57, 0.0, -0.82);
    let view_front = Vec3::new(-0.14, 0.0, 0.99);
    let view_back = Vec3::new(-0.14, 0.0, -0.99);
    // 0: adaxial side lit from the front; 1: adaxial side lit from behind (through-light);
    // 2: abaxial side lit on the abaxial side.
    for view in 0..views {
        let (wo, wi, exposure) = match view {
            0 => (view_front, light_front, 3.0),
            1 => (view_front, light_back, 3.0),
            _ => (view_back, light_back, 3.0),
        };
        for y in 0..size {
            for x in 0..size {
                let mut uv = Vec2::new(
                    (x as f32 + 0.5) / size as f32,
                    1.0 - (y as f32 + 0.5) / size as f32,
                );
                if view == 2 {
                    // Seen from below the leaf appears mirrored.
                    uv.x = 1.0 - uv.x;
                }
                let bg = Vec3::new(0.02, 0.02, 0.025);
                let c = if m.opaque(uv) {
                    // Radiance for a light of irradiance E = exposure * pi (normal incidence).
                    m.bsdf(uv).eval(wo, wi) * (exposure * std::f32::consts::PI)
                } else {
                    bg
                };
                let px = c
                    .to_array()
                    .map(|v| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8);
                img.put_pixel(view * size + x, y, Rgb(px));
            }
        }
    }
    let path = out.join("texel_patch.png");
    lamina_io::save_image(&path, &img).unwrap();
    println!("wrote {}", path.display());
}

fn main() {
    let out: PathBuf = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "leaf_plots".into())
        .into();
    std::fs::create_dir_all(&out).expect("create the output directory");
    plot_rt(&out);
    render_patch(&out);
}
