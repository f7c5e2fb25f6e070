//! Frame time of the GPU path for generated trees of 10k, 100k and 1M leaves (or the
//! counts given) at 1920x1080: the sun's two-layer shadow/transmittance maps (2048²) and
//! the camera pass, every frame (the sun may move); sky-visibility maps are baked once at
//! load and not counted. Prints the adapter and one row per tree.
//!
//! `cargo run --release -p lamina-gpu --example frame_bench -- [leaves...]`

use lamina_gpu::{FrameView, GpuContext, RenderSettings, Renderer};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let counts: Vec<u32> = std::env::args()
        .skip(1)
        .map(|s| s.parse())
        .collect::<Result<_, _>>()?;
    let counts = if counts.is_empty() {
        vec![10_000, 100_000, 1_000_000]
    } else {
        counts
    };
    let (w, h) = (1920, 1080);
    let ctx = GpuContext::headless(&Default::default())?;
    println!("adapter: {}", ctx.adapter_name());
    println!("{w}x{h}, shadow map 2048, frame = sun shadow passes + camera pass, GPU finished");
    println!(
        "{:>9} {:>11} {:>9} {:>10} {:>10} {:>10}",
        "leaves", "triangles", "load s", "frame ms", "min ms", "fps"
    );
    for n in counts {
        let scene = lamina_bench::frame_tree_scene(n, (w, h))?;
        let t = Instant::now();
        let mut r = Renderer::new(
            &ctx,
            &scene,
            RenderSettings {
                supersample: 1,
                ..Default::default()
            },
        )?;
        let view = FrameView {
            camera: scene.camera,
            sun_dir: None,
            width: w,
            height: h,
        };
        r.render_and_wait(&view)?;
        let load = t.elapsed().as_secs_f64();
        let frames = if n >= 500_000 { 3 } else { 5 };
        let mut times = Vec::new();
        for _ in 0..frames {
            let t = Instant::now();
            r.render_and_wait(&view)?;
            times.push(t.elapsed().as_secs_f64() * 1000.0);
        }
        let mean = times.iter().sum::<f64>() / times.len() as f64;
        let min = times.iter().cloned().fold(f64::INFINITY, f64::min);
        println!(
            "{:>9} {:>11} {:>9.1} {:>10.1} {:>10.1} {:>10.2}",
            n,
            r.triangles(),
            load,
            mean,
            min,
            1000.0 / mean
        );
    }
    Ok(())
}
