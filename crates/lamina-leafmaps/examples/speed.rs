//! Timing of `generate` at 2048x2048 and `prepare` of a 4096x4096 capture.
//!
//! `cargo run --release -p lamina-leafmaps --example speed [PREPARE_SIZE] [GENERATE_SIZE]`
//! (set `RAYON_NUM_THREADS=2` to measure on two cores). The capture is synthetic: a
//! generated maple composited over a white background (front photo, no matte, so the
//! segmentation runs), its through-light colour as the scan, and a normal map made from its
//! bump, all written as PNG files under the system temp folder before timing starts.

use image::{Rgb, RgbImage};
use lamina_leaf::texture::linear_to_srgb;
use lamina_leafmaps::{LeafSpec, PrepareInput, Species, generate, prepare};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let psize: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(4096);
    let gsize: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2048);
    println!("threads: {}", rayon::current_num_threads());
    let tmp = std::env::temp_dir().join(format!("lamina_leafmaps_speed_{}", std::process::id()));
    std::fs::create_dir_all(&tmp)?;

    // generate at gsize.
    for s in [Species::Maple, Species::Beech] {
        let t = Instant::now();
        let leaf = generate(&LeafSpec::new(s, 1, gsize));
        let tg = t.elapsed().as_secs_f64();
        let t = Instant::now();
        leaf.write_folder(&tmp.join(format!("gen_{s}")))?;
        let tw = t.elapsed().as_secs_f64();
        let (w, h) = leaf.planes.size();
        println!("generate {s} {w}x{h}: {tg:.2} s (+ {tw:.2} s writing the folder)");
    }

    // A synthetic psize x psize capture.
    let leaf = generate(&LeafSpec::new(Species::Maple, 2, psize));
    let (w, h) = leaf.planes.size();
    let (cw, ch) = (psize, psize);
    let (ox, oy) = ((cw as usize - w) / 2, (ch as usize - h) / 2);
    let enc = |c: [f32; 3]| Rgb(c.map(|v| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8));
    let over = |map: &lamina_leafmaps::plane::Rgb, bg: [f32; 3]| {
        RgbImage::from_fn(cw, ch, |x, y| {
            let (x, y) = (x as usize, y as usize);
            if x < ox || y < oy || x >= ox + w || y >= oy + h {
                return enc(bg);
            }
            let a = leaf.planes.alpha.get(x - ox, y - oy);
            let c = map.get(x - ox, y - oy);
            enc(std::array::from_fn(|k| bg[k] + (c[k] - bg[k]) * a))
        })
    };
    let front = tmp.join("capture_front.png");
    lamina_io::save_image(&front, &over(&leaf.planes.front, [0.9, 0.9, 0.88]))?;
    let scan = tmp.join("capture_scan.png");
    lamina_io::save_image(&scan, &over(&leaf.planes.translucency, [1.0, 1.0, 1.0]))?;
    let bump = &leaf.planes.bump;
    let normal = RgbImage::from_fn(cw, ch, |x, y| {
        let (x, y) = (x as isize - ox as isize, y as isize - oy as isize);
        let inside = x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h;
        if !inside {
            return Rgb([128, 128, 255]);
        }
        let s = 40.0;
        let dx = s * (bump.get_clamped(x + 1, y) - bump.get_clamped(x - 1, y));
        let dy = -s * (bump.get_clamped(x, y + 1) - bump.get_clamped(x, y - 1));
        let n = glam::Vec3::new(-dx, -dy, 1.0).normalize();
        Rgb([n.x, n.y, n.z].map(|v| ((v * 0.5 + 0.5) * 255.0 + 0.5) as u8))
    });
    let normal_path = tmp.join("capture_normal.png");
    lamina_io::save_image(&normal_path, &normal)?;
    drop(leaf);

    for with_normal in [false, true] {
        let mut input = PrepareInput::new(&front, tmp.join("prepared"));
        input.translucency = Some(scan.clone());
        input.dpi = Some(600.0);
        if with_normal {
            input.normal = Some(normal_path.clone());
        }
        let t = Instant::now();
        let r = prepare(&input)?;
        println!(
            "prepare {cw}x{ch} (front + scan{}, segmented alpha keeps {:.1} %): {:.2} s including loading and writing",
            if with_normal { " + normal map" } else { "" },
            100.0 * r.alpha_fraction,
            t.elapsed().as_secs_f64()
        );
    }
    std::fs::remove_dir_all(&tmp)?;
    Ok(())
}
