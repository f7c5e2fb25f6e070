//! `lamina render --gpu`: the real-time (wgpu) image of a scene, written with the same
//! film size, exposure and tone map as the offline renderer's.

use anyhow::{Context, Result};
use lamina_gpu::{ContextOptions, GpuContext, RenderSettings};
use std::time::Instant;

/// Renders `scene` on the GPU and writes every output (already checked by the caller).
pub fn render_gpu(
    scene: &lamina_scene::Scene,
    label: &str,
    outputs: &crate::render_cmd::Outputs,
) -> Result<()> {
    let t = Instant::now();
    let ctx = GpuContext::headless(&ContextOptions::default())?;
    let (image, warnings) = lamina_gpu::render_scene(&ctx, scene, RenderSettings::default())
        .with_context(|| format!("rendering {label} on the GPU"))?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "{label}: {}x{} on the GPU ({}) in {:.2} s (upload included)",
        image.width,
        image.height,
        ctx.adapter_name(),
        t.elapsed().as_secs_f64()
    );
    crate::render_cmd::write_all(outputs, &image, &scene.film)
}
