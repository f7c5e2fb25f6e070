//! `lamina render` of a scene whose `[film]` asks for spectral `bands`: the bands are rendered
//! three at a time (`lamina_render::bands::band_scene`, the same seed and samples for every
//! group), then written as one EXR channel per band and a false-colour PNG.

use crate::render_cmd::{Outputs, RenderFlags, options, render_scene};
use anyhow::{Context, Result, bail};

use lamina_render::Image;
use lamina_scene::{Scene, SpectralOutput};

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
    let (w, h) = match split {
        None => (scene.film.width, scene.film.height),
        Some(s) => (s.crop().width(), s.crop().height()),
    };
    let n = (w * h) as usize;
    let mut planes: Vec<Vec<f32>> = vec![Vec::new(); bands.len()];
    // With a split: each band's f64 sums, and the stats of the first group (every group
    // must hold the same samples).
    let mut sums: Vec<Vec<f64>> = vec![Vec::new(); bands.len()];
    let mut first_stats: Option<lamina_render::RenderStats> = None;
    let groups = lamina_render::bands::band_groups(bands.len());
    let t0 = std::time::Instant::now();
    for (g, idx) in groups.iter().enumerate() {
        let names: Vec<&str> = idx.iter().map(|&i| bands[i].name.as_str()).collect();
        let banded = lamina_render::bands::group_scene(scene, bands, idx)
            .with_context(|| format!("bands {}", names.join(", ")))?;
        let group_label = format!("{label} [{}]", names.join(", "));
        let (mut opts, bar) = options(flags, &group_label, false)?;
        if let Some(split) = split {
            split.apply(&mut opts);
        }
        let out = render_scene(&banded, &opts, bar, &group_label)?;
        if lamina_io::interrupt::interrupted() {
            return Err(crate::interrupted::Interrupted(format!(
                "stopped in band group {} of {}: nothing written",
                g + 1,
                groups.len()
            ))
            .into());
        }
        for (k, &i) in idx.iter().enumerate() {
            planes[i] = out.image.pixels.iter().map(|p| p[k]).collect();
            if let Some(s) = &out.sums {
                sums[i] = s.iter().map(|s| s[k]).collect();
            }
        }
        match &first_stats {
            Some(f) if f.sample_range != out.stats.sample_range => bail!(
                "band groups stopped at different samples ({}..{} and {}..{}): a part must \
                 hold the same samples in every band; render it without --time-limit",
                f.sample_range.start,
                f.sample_range.end,
                out.stats.sample_range.start,
                out.stats.sample_range.end
            ),
            Some(_) => {}
            None => first_stats = Some(out.stats),
        }
    }
    eprintln!(
        "{label}: {} bands in {} render(s), {:.2} s",
        bands.len(),
        groups.len(),
        t0.elapsed().as_secs_f64()
    );
    for out in &outputs.paths {
        crate::output_file::claim(out, outputs.force, &outputs.inputs)?;
        let ext = out
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if let (Some(split), "exr") = (split, ext.as_str()) {
            let stats = first_stats.as_ref().context("no band group rendered")?;
            let part = lamina_farm::Part {
                info: split.done(stats),
                sums: sums.clone(),
            };
            lamina_farm::write_part(out, &part)?;
        } else if ext == "exr" {
            let channels: Vec<(String, Vec<f32>)> = bands
                .iter()
                .zip(&planes)
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
