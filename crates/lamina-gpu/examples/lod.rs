//! What the GPU path's level of detail for leaves (stochastic simplification) keeps and
//! what it saves, on an instanced forest (`lamina_bench::frame_forest_scene`):
//!
//! 1. the forest at several `lod_pixels` settings (0 = every leaf): triangles drawn, GPU
//!    frame time, mean radiance, leaf coverage (the forest without its ground, against
//!    the sky), and MAE/SSIM of the displayed image against the one without LOD;
//! 2. a dolly (the camera moving toward the forest, `frames` frames): the mean change from
//!    one frame to the next (MAE of the displayed images) with and without LOD, and their
//!    ratio: leaves that pop would raise it.
//!
//! With an output folder it writes `lod.png` (without LOD left, with LOD right).
//!
//! `cargo run --release -p lamina-gpu --example lod -- [trees] [leaves per tree] [width]
//! [height] [out dir]` (defaults 25 20000 640 360).

use lamina_gpu::metrics::{coverage, mean_abs_error, mean_radiance, ssim};
use lamina_gpu::{FrameView, GpuContext, RenderSettings, Renderer};
use lamina_image::{Image, to_srgb8};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num = |k: usize, default: u32| -> Result<u32, String> {
        args.get(k).map_or(Ok(default), |s| {
            s.parse()
                .map_err(|e| format!("argument {} '{s}' is not a whole number: {e}", k + 1))
        })
    };
    let (trees, leaves, w, h) = (num(0, 25)?, num(1, 20_000)?, num(2, 640)?, num(3, 360)?);
    let out = args.get(4).map(std::path::PathBuf::from);
    let scene = lamina_bench::frame_forest_scene(trees, leaves, (w, h))?;
    let bare = lamina_scene::Scene {
        meshes: Vec::new(),
        ..scene.clone()
    };
    let background = match scene.sky {
        Some(lamina_scene::Sky::Constant(c)) => c,
        _ => glam::Vec3::ZERO,
    };
    let ctx = GpuContext::headless(&Default::default())?;
    println!("adapter: {}", ctx.adapter_name());
    println!(
        "{trees} trees x {leaves} leaves at {w}x{h}, 1x sampling; coverage: the forest without \
         its ground against the sky"
    );
    let settings = |lod_pixels| RenderSettings {
        supersample: 1,
        lod_pixels,
        ..Default::default()
    };
    let view = FrameView {
        camera: scene.camera,
        sun_dir: None,
        width: w,
        height: h,
    };
    println!(
        "{:>10} {:>12} {:>12} {:>9} {:>26} {:>9} {:>8} {:>7}",
        "lod px",
        "camera tris",
        "shadow tris",
        "GPU ms",
        "mean radiance (RGB)",
        "coverage",
        "MAE",
        "SSIM"
    );
    let mut reference: Option<(Image, Vec<u8>)> = None;
    let mut pair = Vec::new();
    for lod in [0.0, 1.0, 4.0] {
        let mut r = Renderer::new(&ctx, &scene, settings(lod))?;
        let img = r.render_view_image(&view)?;
        let drawn = r.drawn_triangles()?.unwrap_or([r.triangles(); 2]);
        r.render_and_wait(&view, Some(&scene.film))?;
        let t = Instant::now();
        let mut gpu = Vec::new();
        for _ in 0..3 {
            gpu.extend(r.render_and_wait(&view, Some(&scene.film))?);
        }
        let wall = t.elapsed().as_secs_f64() * 1000.0 / 3.0;
        let ms = if gpu.is_empty() {
            format!("{wall:.1}w")
        } else {
            format!(
                "{:.1}",
                gpu.iter().map(|t| t.total_ms()).sum::<f64>() / gpu.len() as f64
            )
        };
        let mut rb = Renderer::new(&ctx, &bare, settings(lod))?;
        let cov = coverage(&rb.render_view_image(&view)?.pixels, background, 0.01);
        let m = mean_radiance(&img.pixels);
        let shown = to_srgb8(&img, &scene.film);
        let (mae, s) = match &reference {
            Some((_, b)) => (
                mean_abs_error(&shown, b),
                ssim(&shown, b, w as usize, h as usize),
            ),
            None => (0.0, 1.0),
        };
        println!(
            "{:>10} {:>12} {:>12} {:>9} {:>8.4} {:>8.4} {:>8.4} {:>9.4} {:>8.4} {:>7.4}",
            if lod == 0.0 {
                "off".into()
            } else {
                format!("{lod}")
            },
            drawn[0],
            drawn[1],
            ms,
            m[0],
            m[1],
            m[2],
            cov,
            mae,
            s
        );
        if lod == 0.0 {
            reference = Some((img.clone(), shown));
        }
        if lod == 0.0 || lod == 1.0 {
            pair.push(img);
        }
    }
    // The dolly: from the scene's camera to 40 % closer, in `frames` steps.
    let frames = 16;
    let mut change = Vec::new();
    for lod in [0.0, 1.0] {
        let mut r = Renderer::new(&ctx, &scene, settings(lod))?;
        let mut last: Option<Vec<u8>> = None;
        let mut sum = 0.0;
        for k in 0..frames {
            let mut cam = scene.camera;
            let t = 0.4 * k as f32 / (frames - 1) as f32;
            cam.position = cam.position + (cam.look_at - cam.position) * t;
            let img = r.render_view_image(&FrameView {
                camera: cam,
                ..view
            })?;
            let shown = to_srgb8(&img, &scene.film);
            if let Some(prev) = &last {
                sum += mean_abs_error(&shown, prev);
            }
            last = Some(shown);
        }
        change.push(sum / (frames - 1) as f64);
    }
    println!(
        "dolly ({frames} frames, 40 % closer): mean frame-to-frame MAE {:.5} without LOD, {:.5} \
         with LOD 1 px: ratio {:.3}",
        change[0],
        change[1],
        change[1] / change[0]
    );
    if let Some(dir) = out {
        std::fs::create_dir_all(&dir)?;
        let path = dir.join("lod.png");
        let both = side_by_side(&pair[0], &pair[1]);
        lamina_image::write_image(&path, &both, &scene.film)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// `a` and `b` side by side with a 4-pixel black gap.
fn side_by_side(a: &Image, b: &Image) -> Image {
    let (w, h) = (a.width * 2 + 4, a.height);
    let mut pixels = vec![glam::Vec3::ZERO; (w * h) as usize];
    for y in 0..h {
        for x in 0..a.width {
            pixels[(y * w + x) as usize] = a.pixels[(y * a.width + x) as usize];
            pixels[(y * w + x + a.width + 4) as usize] = b.pixels[(y * b.width + x) as usize];
        }
    }
    Image {
        width: w,
        height: h,
        pixels,
    }
}
