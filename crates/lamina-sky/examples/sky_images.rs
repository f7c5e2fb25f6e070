//! Pictures of the Preetham clear sky.
//!
//! `cargo run --release -p lamina-sky --example sky_images -- <out_dir>` writes, for the sun
//! at elevations 60°, 30°, 10° and 3° in the west (azimuth 270°) and turbidities 2.5 and 6:
//!
//! * `sky_e<elevation>_t<turbidity>.png`: an equirectangular (latitude-longitude) picture of
//!   the whole sphere, 512 x 256, in the convention of a `[sky]` image (top row the zenith,
//!   the horizon across the middle, `u = 0` at azimuth −180° = south, then west at u = 1/4,
//!   north at 1/2, east at 3/4); the lower half, below the horizon, is black (the model
//!   has no ground). Tone-mapped with one fixed exposure for all of them (radiance ×
//!   2^−4.5, then the ACES curve of lamina's films, then sRGB), so a low sun's sky is
//!   darker, as it is.
//! * `sky_e<elevation>_t<turbidity>.exr`: the same as linear Rec.709 radiance, W m⁻² sr⁻¹
//!   (usable as a `[sky] type = "image"` file).
//!
//! It prints the zenith's xyY and the radiance near the sun, 90° from it and at the horizon.

use glam::DVec3;
use image::{Rgb, Rgb32FImage, RgbImage};
use lamina_leaf::texture::linear_to_srgb;
use lamina_sky::{PreethamSky, sun_direction};
use std::path::PathBuf;

const WIDTH: u32 = 512;
const HEIGHT: u32 = 256;
/// The fixed exposure, in stops.
const EXPOSURE_EV: f64 = -4.5;
const SUN_AZIMUTH: f64 = 270.0;

/// The ACES filmic curve (Narkowicz's fit), as lamina-image's `ToneMap::Aces`.
fn aces(x: f64) -> f64 {
    let x = x.max(0.0);
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// The direction of pixel `(i, j)`: `φ = 2π u − π` (compass azimuth), `θ = π v`.
fn pixel_direction(i: u32, j: u32) -> DVec3 {
    let u = (f64::from(i) + 0.5) / f64::from(WIDTH);
    let v = (f64::from(j) + 0.5) / f64::from(HEIGHT);
    sun_direction(180.0 * v, 360.0 * u - 180.0)
}

fn main() {
    let out: PathBuf = std::env::args_os()
        .nth(1)
        .expect("usage: sky_images <out_dir>")
        .into();
    std::fs::create_dir_all(&out).unwrap();
    let scale = 2f64.powf(EXPOSURE_EV);
    for turbidity in [2.5, 6.0] {
        for elevation in [60.0, 30.0, 10.0, 3.0] {
            let sky = PreethamSky::with_azimuth(90.0 - elevation, SUN_AZIMUTH, turbidity).unwrap();
            let mut png = RgbImage::new(WIDTH, HEIGHT);
            let mut exr = Rgb32FImage::new(WIDTH, HEIGHT);
            for j in 0..HEIGHT {
                for i in 0..WIDTH {
                    let rgb = sky.linear_rec709(pixel_direction(i, j));
                    exr.put_pixel(i, j, Rgb(rgb.as_vec3().to_array()));
                    let px = rgb.to_array().map(|c| {
                        let s = linear_to_srgb(aces(c * scale) as f32);
                        (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
                    });
                    png.put_pixel(i, j, Rgb(px));
                }
            }
            let name = format!("sky_e{elevation:02}_t{turbidity}");
            lamina_io::save_image(&out.join(format!("{name}.png")), &png).unwrap();
            lamina_io::save_image(&out.join(format!("{name}.exr")), &exr).unwrap();

            let z = sky.zenith_xyY();
            let at = |zenith: f64, dphi: f64| {
                sky.linear_rec709(sun_direction(zenith, SUN_AZIMUTH + dphi))
            };
            let near = at(90.0 - elevation - 3.0, 0.0);
            let dark = at(elevation, 180.0);
            let horizon_sun = at(89.5, 0.0);
            let horizon_side = at(89.5, 90.0);
            let f = |v: DVec3| format!("({:.2}, {:.2}, {:.2})", v.x, v.y, v.z);
            println!(
                "{name}: zenith x {:.4} y {:.4} Y {:.3} kcd/m²; RGB (W m⁻² sr⁻¹) 3° above the sun \
                 {}, 90° from it {}, horizon below the sun {}, horizon 90° in azimuth {}",
                z.x,
                z.y,
                z.luminance,
                f(near),
                f(dark),
                f(horizon_sun),
                f(horizon_side)
            );
        }
    }
}
