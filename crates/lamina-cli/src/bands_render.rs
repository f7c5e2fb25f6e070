//! `lamina render` of a scene whose `[film]` asks for spectral `bands`: every band in one
//! render (`lamina_render::render_bands`: each camera path carries the bands three to a set,
//! over one BVH), then written as one EXR channel per band and a false-colour PNG.

use crate::render_cmd::{Outputs, RenderFlags, options, print_summary};
use anyhow::{Context, Result, bail};

use lamina_render::Image;
use lamina_scene::{Integrator, Scene, SpectralOutput};

/// Renders `scene` in the bands of `spectral` and writes `outputs`.
pub fn render_bands(
    scene: &Scene,
    spectral: &SpectralOutput,
    flags: &RenderFlags,
    label: &str,
    outputs: &Outputs,
    split: Option<&crate::parts_cmd::Split>,
) -> Result<()> {
    let bands = &spectral.bands;
    let names: Vec<&str> = bands.iter().map(|b| b.name.as_str()).collect();
    let band_label = format!("{label} [{}]", names.join(", "));
    // With the path integrator a band render is one render: Ctrl-C after its first pass
    // keeps the passes done, as for RGB. The paper integrator renders three bands at a
    // time, which a stop would leave unequal.
    let one_pass = matches!(scene.integrator, Integrator::Path { .. });
    let (mut opts, bar) = options(flags, &band_label, one_pass)?;
    if let Some(split) = split {
        split.apply(&mut opts);
    }
    let rendered = lamina_render::render_bands(scene, bands, &opts)
        .with_context(|| format!("rendering {band_label}"))?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    print_summary(
        &band_label,
        &rendered.stats,
        rendered.width,
        rendered.height,
    );
    if !one_pass && lamina_io::interrupt::interrupted() {
        return Err(crate::interrupted::Interrupted(
            "stopped while rendering bands three at a time (paper integrator): nothing written"
                .into(),
        )
        .into());
    }
    let (w, h) = (rendered.width, rendered.height);
    let n = (w * h) as usize;
    let planes = &rendered.planes;
    for out in &outputs.paths {
        crate::output_file::claim(out, outputs.force, &outputs.inputs)?;
        let ext = out
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if let (Some(split), "exr") = (split, ext.as_str()) {
            let part = lamina_farm::Part {
                info: split.done(&rendered.stats),
                sums: rendered.sums.clone().context("a part keeps its sums")?,
            };
            lamina_farm::write_part(out, &part)?;
        } else if ext == "exr" {
            let channels: Vec<(String, Vec<f32>)> = bands
                .iter()
                .zip(planes)
                .map(|(b, p)| (b.name.clone(), p.clone()))
                .collect();
            lamina_io::image_out::save_named_channels(out, w, h, &channels)
                .with_context(|| format!("writing '{}'", out.display()))?;
        } else if ext == "png" {
            let [r, g, b] = spectral.false_color;
            let pixels = (0..n)
                .map(|i| glam::Vec3::new(planes[r][i], planes[g][i], planes[b][i]))
                .collect();
            let image = Image {
                width: w,
                height: h,
                pixels,
            };
            lamina_render::write_image(out, &image, &scene.film)
                .with_context(|| format!("writing '{}'", out.display()))?;
        } else {
            bail!(
                "output '{}': use .exr (bands) or .png (false colour)",
                out.display()
            );
        }
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
