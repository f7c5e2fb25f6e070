//! Renders the procedural leaf-card canopy of the benchmark to a PNG and an EXR.
//!
//! `cargo run --release -p lamina-render --example canopy -- [OUT_STEM] [CARDS] [SPP]`

#[path = "../benches/common/canopy.rs"]
mod canopy;

use lamina_render::{RenderOptions, render, write_image};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let stem = args.get(1).cloned().unwrap_or_else(|| "canopy".into());
    let cards: u32 = args.get(2).map_or(Ok(5000), |s| s.parse())?;
    let spp: u32 = args.get(3).map_or(Ok(32), |s| s.parse())?;
    let scene = canopy::canopy_scene(cards, 480, 320, spp);
    let out = render(&scene, &RenderOptions::default())?;
    let s = out.stats;
    println!(
        "{cards} cards, {}x{} at {} spp: {:.2} s, {:.2} Msamples/s, {:.2} Mrays/s",
        scene.film.width,
        scene.film.height,
        s.spp_done,
        s.elapsed.as_secs_f64(),
        s.samples as f64 / s.elapsed.as_secs_f64() / 1e6,
        s.rays as f64 / s.elapsed.as_secs_f64() / 1e6
    );
    for ext in ["png", "exr"] {
        write_image(
            &PathBuf::from(format!("{stem}.{ext}")),
            &out.image,
            &scene.film,
        )?;
    }
    Ok(())
}
