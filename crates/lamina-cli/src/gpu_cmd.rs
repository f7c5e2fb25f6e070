//! `lamina render --gpu`: the real-time (wgpu) image of a scene, written with the same
//! film size, exposure and tone map as the offline renderer's.

use anyhow::{Context, Result};
use lamina_gpu::{ContextOptions, GpuContext, RenderSettings};
use std::time::Instant;

/// The render flags that mean nothing to the GPU path are refused, with why: it draws one
/// deterministic frame (no random numbers, no progressive passes, no CPU threads).
/// `--spp` applies (see [`supersample_for`]).
pub fn check_flags(flags: &crate::render_cmd::RenderFlags) -> Result<()> {
    if flags.seed != 0 {
        anyhow::bail!(
            "--seed does not apply to --gpu: the GPU image has no random numbers (it is the \
             same on every run)"
        );
    }
    if flags.threads.is_some() {
        anyhow::bail!(
            "--threads does not apply to --gpu: the GPU draws the frame (--threads sets the \
             path tracer's CPU threads)"
        );
    }
    if flags.accel != lamina_render::accel::Backend::Lamina {
        anyhow::bail!(
            "--accel does not apply to --gpu: the GPU rasterises (--accel picks the path \
             tracer's ray-casting engine)"
        );
    }
    if flags.time_limit.is_some() {
        anyhow::bail!(
            "--time-limit does not apply to --gpu: a GPU frame is drawn whole, not in \
             progressive passes that could stop early"
        );
    }
    Ok(())
}

/// Parses `--lod PIXELS`: the projected leaf area (pixels of the image) below which the
/// GPU path thins a plant's leaves out; 0 draws every leaf.
pub fn parse_lod(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(v) if v.is_finite() && (0.0..=1e4).contains(&v) => Ok(v),
        Ok(v) => Err(format!(
            "{v} is not a leaf area in pixels from 0 (every leaf) to 10000"
        )),
        Err(e) => Err(format!("'{s}' is not a number: {e}")),
    }
}

/// Largest supersampled target side, in pixels (the texture limit every Vulkan device
/// offers is at least 8192).
const MAX_TARGET_SIDE: u32 = 8192;

/// The supersampling factor per axis for `--spp N` on a `width x height` film: the square
/// grid `s x s` nearest to `N` samples per pixel, at most what keeps the target within
/// [`MAX_TARGET_SIDE`]; without `--spp`, the GPU path's default (2 x 2).
pub fn supersample_for(spp: Option<u32>, width: u32, height: u32) -> u32 {
    let max = (MAX_TARGET_SIDE / width.max(height).max(1)).max(1);
    match spp {
        None => RenderSettings::default().supersample.min(max),
        Some(n) => ((n as f64).sqrt().round() as u32).clamp(1, max),
    }
}

/// Renders `scene` on the GPU and writes every output (already checked by the caller).
/// `spp`: `--spp`, as supersampling ([`supersample_for`]).
pub fn render_gpu(
    scene: &lamina_scene::Scene,
    label: &str,
    outputs: &crate::render_cmd::Outputs,
    spp: Option<u32>,
    lod: Option<f32>,
) -> Result<()> {
    let t = Instant::now();
    let ss = supersample_for(spp, scene.film.width, scene.film.height);
    if let Some(n) = spp
        && n != ss * ss
    {
        eprintln!(
            "note: --spp {n} on the GPU is supersampling on a square grid: {ss}x{ss} = {} \
             samples per pixel{}",
            ss * ss,
            if (n as f64).sqrt().round() as u32 > ss {
                format!(" (at most {ss} per axis at this film size)")
            } else {
                String::new()
            }
        );
    }
    let ctx = GpuContext::headless(&ContextOptions::default())?;
    let settings = RenderSettings {
        supersample: ss,
        lod_pixels: lod.unwrap_or(RenderSettings::default().lod_pixels),
        ..RenderSettings::default()
    };
    let (image, warnings) = lamina_gpu::render_scene(&ctx, scene, settings)
        .with_context(|| format!("rendering {label} on the GPU"))?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "{label}: {}x{}, {} samples per pixel ({ss}x{ss} supersampling), on the GPU ({}) in \
         {:.2} s (upload included)",
        image.width,
        image.height,
        ss * ss,
        ctx.adapter_name(),
        t.elapsed().as_secs_f64()
    );
    crate::render_cmd::write_all(outputs, &image, &scene.film)
}

#[cfg(test)]
mod tests {
    use super::supersample_for;

    #[test]
    fn spp_becomes_the_nearest_square_grid_within_the_target_limit() {
        assert_eq!(supersample_for(None, 480, 360), 2);
        assert_eq!(supersample_for(Some(1), 480, 360), 1);
        assert_eq!(supersample_for(Some(16), 480, 360), 4);
        assert_eq!(supersample_for(Some(10), 480, 360), 3);
        // 8192 / 1920 = 4 per axis at most for 1080p.
        assert_eq!(supersample_for(Some(64), 1920, 1080), 4);
        assert_eq!(supersample_for(None, 8192, 100), 1);
    }
}
