//! Frame time of the GPU path at 1920x1080 (or `--size`) for 10k, 100k, 1M and 10M leaves (or the counts
//! given), each without level of detail and with it (stochastic simplification below 1 and
//! 4 px² per leaf: `lamina render --gpu`'s and `lamina view`'s defaults), as a window's
//! frame draws it: the culling/LOD compute pass, the sun's two-layer
//! shadow/transmittance maps (2048²), the camera pass (with occlusion culling: its first
//! part, the depth pyramid, the late culling pass and its second part) and the tone-map
//! pass into an offscreen sRGB target, every frame (the sun may move); sky-visibility maps
//! are baked once at load and not counted. Occlusion culling is on (the default) in every
//! row but the last of each scene (4 px² with it off).
//!
//! Up to 1M leaves the scene is one generated tree (`lamina_bench::frame_tree_scene`); from
//! 5M on it is a forest of 100k-leaf trees, one prototype placed `n / 100k` times
//! (`lamina_bench::frame_forest_scene`). Prints the adapter, then one row per scene and LOD
//! setting: triangles drawn by the camera pass after culling and LOD, GPU milliseconds per
//! pass from timestamp queries (where the adapter has them; else `-`), the wall-clock frame
//! time (submit to GPU finished) and its fps, and the geometry's GPU memory.
//!
//! `cargo run --release -p lamina-gpu --example frame_bench -- [--frames N] [--size WxH]
//! [leaves...]` (`--frames`: timed frames per row; by default 5, 3 from 500k leaves and 1
//! from 5M, which suits software Vulkan; a real GPU wants more, e.g. 60. `--size`: the
//! frame in pixels, 1920x1080 by default, the same view at another size: comparing sizes
//! tells a pass bound by its pixels from one bound by its triangles).

use lamina_gpu::renderer::PassTimes;
use lamina_gpu::{FrameView, GpuContext, RenderSettings, Renderer};
use std::time::Instant;

/// Leaves per tree of the forests.
const FOREST_TREE: u32 = 100_000;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut frames_override = None;
    if let Some(k) = args.iter().position(|a| a == "--frames") {
        let v = args
            .get(k + 1)
            .ok_or("--frames needs a number of frames")?
            .parse::<u32>()
            .map_err(|e| format!("--frames: not a whole number: {e}"))?;
        if v == 0 {
            return Err("--frames: at least one frame".into());
        }
        frames_override = Some(v);
        args.drain(k..k + 2);
    }
    let (mut w, mut h) = (1920, 1080);
    if let Some(k) = args.iter().position(|a| a == "--size") {
        let v = args
            .get(k + 1)
            .ok_or("--size needs WIDTHxHEIGHT, e.g. 960x540")?;
        let parsed = v
            .split_once('x')
            .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
            .filter(|&(a, b)| a > 0 && b > 0);
        (w, h) = parsed
            .ok_or_else(|| format!("--size: '{v}' is not WIDTHxHEIGHT in pixels (e.g. 960x540)"))?;
        args.drain(k..k + 2);
    }
    let counts: Vec<u32> = args
        .iter()
        .map(|s| {
            s.parse()
                .map_err(|e| format!("'{s}' is not a leaf count (a whole number): {e}"))
        })
        .collect::<Result<_, _>>()?;
    let counts = if counts.is_empty() {
        vec![10_000, 100_000, 1_000_000, 10_000_000]
    } else {
        counts
    };
    let ctx = GpuContext::headless(&Default::default())?;
    println!("adapter: {}", ctx.adapter_name());
    println!(
        "{w}x{h}, shadow map 2048, frame = culling/LOD + sun shadow passes + camera pass + tone \
         map, GPU finished; LOD = leaves thinned out below 1 or 4 px² (off = every leaf)"
    );
    println!(
        "{:>9} {:>6} {:>4} {:>5} {:>11} {:>7} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8} {:>9}",
        "leaves",
        "trees",
        "LOD",
        "occl",
        "tris drawn",
        "load s",
        "cull ms",
        "shadow ms",
        "main ms",
        "post ms",
        "GPU ms",
        "wall ms",
        "wall fps",
        "geom MB"
    );
    for n in counts {
        let (scene, trees) = if n >= 5_000_000 {
            let trees = n.div_ceil(FOREST_TREE);
            let s = lamina_bench::frame_forest_scene(trees, FOREST_TREE, (w, h))?;
            (s, trees)
        } else {
            (lamina_bench::frame_tree_scene(n, (w, h))?, 1)
        };
        let t = Instant::now();
        // Load with LOD (the sky-visibility maps are baked with it), then time both.
        let mut r = Renderer::new(
            &ctx,
            &scene,
            RenderSettings {
                supersample: 1,
                lod_pixels: 1.0,
                ..Default::default()
            },
        )?;
        let view = FrameView {
            camera: scene.camera,
            sun_dir: None,
            width: w,
            height: h,
        };
        r.render_and_wait(&view, Some(&scene.film))?;
        let load = t.elapsed().as_secs_f64();
        let settings = [(0.0, true), (1.0, true), (4.0, true), (4.0, false)];
        for (lod, occlusion) in settings {
            r.set_lod_pixels(lod);
            r.set_occlusion_culling(occlusion);
            // Two frames to settle (occlusion culling skips what the one before found
            // hidden; the second counts what it draws), then the timed ones.
            r.render_and_wait(&view, Some(&scene.film))?;
            r.render_and_wait(&view, Some(&scene.film))?;
            let drawn = r.drawn_triangles()?.map_or(r.triangles(), |d| d[0]);
            let frames = frames_override.unwrap_or(match n {
                5_000_000.. => 1,
                500_000.. => 3,
                _ => 5,
            });
            let (mut wall, mut gpu) = (Vec::new(), Vec::<PassTimes>::new());
            for _ in 0..frames {
                let t = Instant::now();
                let times = r.render_and_wait(&view, Some(&scene.film))?;
                wall.push(t.elapsed().as_secs_f64() * 1000.0);
                gpu.extend(times);
            }
            let mean = |v: &mut dyn Iterator<Item = f64>| {
                let (s, k) = v.fold((0.0, 0), |(s, k), x| (s + x, k + 1));
                (k > 0).then(|| s / k as f64)
            };
            let col = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.2}"));
            let wall_ms = mean(&mut wall.iter().copied()).unwrap_or(f64::NAN);
            println!(
                "{:>9} {:>6} {:>4} {:>5} {:>11} {:>7.1} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9.1} {:>8.2} {:>9.1}",
                n,
                trees,
                if lod > 0.0 {
                    format!("{lod}")
                } else {
                    "off".into()
                },
                if r.occlusion_culling() { "on" } else { "off" },
                drawn,
                load,
                col(mean(&mut gpu.iter().filter_map(|t| t.cull_ms))),
                col(mean(&mut gpu.iter().map(|t| t.shadows_ms))),
                col(mean(&mut gpu.iter().map(|t| t.main_ms))),
                col(mean(&mut gpu.iter().filter_map(|t| t.post_ms))),
                col(mean(&mut gpu.iter().map(|t| t.total_ms()))),
                wall_ms,
                1000.0 / wall_ms,
                r.geometry_bytes() as f64 / 1e6
            );
        }
    }
    if !ctx
        .device
        .features()
        .contains(lamina_gpu::wgpu::Features::TIMESTAMP_QUERY)
    {
        println!("(this adapter has no timestamp queries: GPU columns are '-', wall clock only)");
    }
    Ok(())
}
