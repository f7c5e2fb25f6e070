//! The GPU image of glTF (metallic-roughness) squares next to the offline render, with MAE
//! and SSIM: a glossy terracotta dielectric, the same with a rippled normal map, a rough
//! gold metal and a smooth black dielectric. Writes `<dir>/pbr-<name>.png` (left: GPU,
//! right: offline) and prints the red channel along the highlight's row.
//!
//! `cargo run --release -p lamina-gpu --example pbr_compare -- out/gpu-pbr [size] [spp]`

#[path = "../tests/common/mod.rs"]
mod common;

use glam::Vec3;
use lamina_scene::PbrMaterial;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "out/gpu-pbr".into()));
    let size: u32 = args.next().map_or(Ok(192), |s| s.parse())?;
    let spp: u32 = args.next().map_or(Ok(256), |s| s.parse())?;
    std::fs::create_dir_all(&dir)?;
    let ctx = lamina_gpu::GpuContext::headless(&Default::default())?;
    println!("adapter: {}", ctx.adapter_name());
    let mut rippled = PbrMaterial::uniform("rippled", Vec3::new(0.55, 0.22, 0.1), 0.0, 0.35);
    rippled.normal_map = Some(common::ripple_normal_map());
    let materials = [
        PbrMaterial::uniform("terracotta", Vec3::new(0.55, 0.22, 0.1), 0.0, 0.35),
        rippled,
        PbrMaterial::uniform("gold", Vec3::new(1.0, 0.77, 0.33), 1.0, 0.5),
        PbrMaterial::uniform("black", Vec3::ZERO, 0.0, 0.2),
    ];
    for m in materials {
        let name = m.name.clone();
        let scene = common::pbr_square(m, size, spp);
        let c = common::compare(&ctx, &scene, spp);
        let row = |img: &lamina_render::Image| {
            let y = (size as f32 * 0.35) as u32;
            (0..8)
                .map(|k| img.pixels[(y * size + k * size / 8) as usize])
                .map(|p| format!("{:.3}", p.x))
                .collect::<Vec<_>>()
                .join(" ")
        };
        println!(
            "{name:<12} MAE {:.4} SSIM {:.4}  GPU {:.2} s, offline {:.1} s",
            c.mae, c.ssim, c.gpu_s, c.cpu_s
        );
        println!("  red along the highlight row, GPU:     {}", row(&c.gpu));
        println!("  red along the highlight row, offline: {}", row(&c.cpu));
        let file = dir.join(format!("pbr-{name}.png"));
        lamina_render::write_image(&file, &common::side_by_side(&c.gpu, &c.cpu), &scene.film)?;
    }
    Ok(())
}
