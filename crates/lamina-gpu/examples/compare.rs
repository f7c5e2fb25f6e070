//! The GPU image next to a converged offline render for the demo's three panels, with
//! MAE and SSIM. Writes `<dir>/<scene>.png` (left: GPU, right: offline) and prints a table.
//!
//! `cargo run --release -p lamina-gpu --example compare -- out/gpu-compare [size] [spp]`

#[path = "../tests/common/mod.rs"]
mod common;

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "out/gpu-compare".into()));
    let size: u32 = args.next().map_or(Ok(256), |s| s.parse())?;
    let spp: u32 = args.next().map_or(Ok(1024), |s| s.parse())?;
    std::fs::create_dir_all(&dir)?;
    let ctx = lamina_gpu::GpuContext::headless(&Default::default())?;
    println!("adapter: {}", ctx.adapter_name());
    println!("{size}x{size}, offline {spp} spp; metrics on the tone-mapped sRGB images");
    println!(
        "{:<16} {:>8} {:>8} {:>8} {:>9}",
        "scene", "MAE", "SSIM", "GPU s", "offline s"
    );
    for (name, scene) in common::demo_scenes(size, spp) {
        let c = common::compare(&ctx, &scene, spp);
        println!(
            "{:<16} {:>8.4} {:>8.4} {:>8.2} {:>9.1}",
            name, c.mae, c.ssim, c.gpu_s, c.cpu_s
        );
        let file = dir.join(format!("{}.png", name.replace(' ', "-")));
        lamina_render::write_image(&file, &common::side_by_side(&c.gpu, &c.cpu), &scene.film)?;
        println!("  wrote {}", file.display());
    }
    Ok(())
}
