//! The scene's `[[sensor]]`s, run by `lamina render`: their CSV files, fisheye images and
//! BRF plots written next to the scene file (each path as the scene names it).

use crate::interrupted::Interrupted;
use anyhow::{Context, Result, bail};
use lamina_io::interrupt;
use lamina_render::sensors::{self, MeasureOptions, Measurement, SensorOutput};
use lamina_scene::Scene;
use lamina_scene::radiometry::SensorKind;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Every file the sensors of `scene` write.
pub fn output_paths(scene: &Scene) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for s in &scene.radiometry.sensors {
        match &s.kind {
            SensorKind::Brf { sweeps, plot, .. } => {
                v.extend(sweeps.iter().map(|w| w.file.clone()));
                v.extend(plot.clone());
            }
            SensorKind::Irradiance { file, .. } | SensorKind::Absorbed { file, .. } => {
                v.push(file.clone())
            }
            SensorKind::Fisheye { file, gap_file, .. } => {
                v.push(file.clone());
                v.extend(gap_file.clone());
            }
        }
    }
    v
}

/// Checks that every sensor output may be written (folder exists; absent, lamina's, or
/// `force`; never an input), before any work.
pub fn check(scene: &Scene, force: bool, inputs: &[PathBuf]) -> Result<()> {
    let paths = output_paths(scene);
    for (i, p) in paths.iter().enumerate() {
        if paths[..i].contains(p) {
            bail!("two sensor outputs are the same file '{}'", p.display());
        }
        if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty())
            && !dir.is_dir()
        {
            bail!(
                "sensor output '{}': folder '{}' does not exist",
                p.display(),
                dir.display()
            );
        }
        crate::output_file::claim(p, force, inputs)?;
    }
    Ok(())
}

/// Runs the sensors of `scene` (loaded from `scene_path`) and writes their files. With
/// `spectral` (the film's `bands`), the sensors run once per group of three bands
/// (`lamina_render::bands::group_scene`, the same seed in every group) and every file holds
/// every band.
pub fn run(
    scene: &Scene,
    scene_path: &Path,
    spectral: Option<&lamina_scene::SpectralOutput>,
    flags: &crate::render_cmd::RenderFlags,
    sample_scale: Option<f64>,
    force: bool,
) -> Result<()> {
    let inputs = vec![scene_path.to_owned()];
    check(scene, force, &inputs)?;
    let quiet = flags.quiet;
    let terminal = std::io::stderr().is_terminal();
    let (names, groups): (Vec<String>, Vec<Vec<usize>>) = match spectral {
        None => (sensors::channel_names(), vec![vec![0, 1, 2]]),
        Some(sp) => (
            sp.bands.iter().map(|b| b.name.clone()).collect(),
            lamina_render::bands::band_groups(sp.bands.len()),
        ),
    };
    // results[g][s]: sensor s in band group g.
    let mut results: Vec<Vec<SensorOutput>> = Vec::new();
    for group in &groups {
        let label = if spectral.is_some() {
            let n: Vec<&str> = group.iter().map(|&i| names[i].as_str()).collect();
            format!(" [{}]", n.join(", "))
        } else {
            String::new()
        };
        let banded;
        let target = match spectral {
            None => scene,
            Some(sp) => {
                banded = lamina_render::bands::group_scene(scene, &sp.bands, group)
                    .with_context(|| format!("sensors in bands{label}"))?;
                &banded
            }
        };
        let last = std::sync::Mutex::new((usize::MAX, -1i32));
        let progress = Arc::new(move |i: usize, name: &str, f: f32| {
            if quiet {
                return;
            }
            let pct = (f * 100.0).floor() as i32;
            let mut l = last.lock().unwrap_or_else(|e| e.into_inner());
            let step = if terminal { 1 } else { 10 };
            if l.0 != i || pct >= l.1 + step {
                *l = (i, pct);
                if terminal {
                    eprint!("\rsensor '{name}'{label}: {pct:3}%");
                } else {
                    eprintln!("sensor '{name}'{label}: {pct}%");
                }
            }
        }) as sensors::SensorProgress;
        let opts = MeasureOptions {
            seed: flags.seed,
            threads: flags.threads.map(|t| t as usize),
            sample_scale,
            cancel: Some(interrupt::flag()),
            progress: Some(progress),
            accel: flags.accel,
        };
        let r = match sensors::measure(target, &opts) {
            Err(lamina_render::RenderError::Cancelled) => {
                return Err(
                    Interrupted("sensors interrupted, no sensor file written".into()).into(),
                );
            }
            r => r.context("measuring the sensors")?,
        };
        if !quiet && terminal {
            eprintln!();
        }
        results.push(r);
    }
    let detail = format!("{}", scene_path.display());
    for s in 0..scene.radiometry.sensors.len() {
        let outs: Vec<&SensorOutput> = results.iter().map(|g| &g[s]).collect();
        let first = outs[0];
        for (path, text) in sensors::csv_files_bands(&outs, &groups, &names) {
            crate::output_file::claim(&path, force, &inputs)?;
            let mark =
                lamina_io::text_mark_line(&format!("sensor '{}' of {detail}", first.sensor.name));
            lamina_io::write_bytes(&path, format!("{mark}\n{text}").as_bytes())
                .with_context(|| format!("writing '{}'", path.display()))?;
            eprintln!("wrote {}", path.display());
        }
        // The group holding the sensor's channel (the first band without one), and where.
        let c = first.sensor.channel.unwrap_or(0);
        let (g, k) = groups
            .iter()
            .enumerate()
            .find_map(|(g, idx)| idx.iter().position(|&i| i == c).map(|k| (g, k)))
            .unwrap_or((0, 0));
        let main = outs[g];
        match (&first.measurement, &first.sensor.kind) {
            (Measurement::Fisheye(_), SensorKind::Fisheye { file, .. }) => {
                crate::output_file::claim(file, force, &inputs)?;
                write_fisheye(file, &outs, &groups, &names, spectral, scene)
                    .with_context(|| format!("writing '{}'", file.display()))?;
                eprintln!("wrote {}", file.display());
            }
            (
                Measurement::Brf(_),
                SensorKind::Brf {
                    sweeps,
                    plot: Some(plot),
                    ..
                },
            ) => {
                if let Measurement::Brf(r) = &main.measurement {
                    crate::output_file::claim(plot, force, &inputs)?;
                    let img = brf_plot(main, k, &names[c], r, sweeps);
                    lamina_io::save_image(plot, &img)
                        .with_context(|| format!("writing '{}'", plot.display()))?;
                    eprintln!("wrote {}", plot.display());
                }
            }
            _ => {}
        }
        summary(main, k, &names[c]);
    }
    Ok(())
}

/// A fisheye image: RGB as the film writes it, or in bands one EXR channel per band (a PNG:
/// the film's false-colour bands).
fn write_fisheye(
    file: &Path,
    outs: &[&SensorOutput],
    groups: &[Vec<usize>],
    names: &[String],
    spectral: Option<&lamina_scene::SpectralOutput>,
    scene: &Scene,
) -> Result<()> {
    let image = |o: &SensorOutput| match &o.measurement {
        Measurement::Fisheye(r) => Some(r.image.clone()),
        _ => None,
    };
    let Some(sp) = spectral else {
        let img = image(outs[0]).context("not a fisheye result")?;
        return Ok(lamina_render::write_image(file, &img, &scene.film)?);
    };
    // Plane of every band.
    let mut planes: Vec<Vec<f32>> = vec![Vec::new(); names.len()];
    let (mut w, mut h) = (0, 0);
    for (o, group) in outs.iter().zip(groups) {
        let img = image(o).context("not a fisheye result")?;
        (w, h) = (img.width, img.height);
        for (k, &i) in group.iter().enumerate() {
            planes[i] = img.pixels.iter().map(|p| p[k]).collect();
        }
    }
    if crate::parts_cmd::is_exr(file) {
        let channels: Vec<(String, Vec<f32>)> = names.iter().cloned().zip(planes).collect();
        lamina_io::image_out::save_named_channels(file, w, h, &channels)?;
        return Ok(());
    }
    let [r, g, b] = sp.false_color.map(|i| &planes[i]);
    let pixels = (0..(w * h) as usize)
        .map(|p| glam::Vec3::new(r[p], g[p], b[p]))
        .collect();
    let img = lamina_render::Image {
        width: w,
        height: h,
        pixels,
    };
    Ok(lamina_render::write_image(file, &img, &scene.film)?)
}

/// One line per sensor: time, rays, and its headline numbers in channel `c` (named `name`)
/// of `out`.
fn summary(out: &SensorOutput, c: usize, name: &str) {
    let ch = |v: glam::DVec3| v.to_array()[c];
    let what = match &out.measurement {
        Measurement::Brf(r) => {
            let all: Vec<f64> = r.sweeps.iter().flatten().map(|e| ch(e.value)).collect();
            let err = r
                .sweeps
                .iter()
                .flatten()
                .map(|e| ch(e.std))
                .fold(0.0, f64::max);
            format!(
                "BRF {:.4} to {:.4} (largest standard error {err:.4})",
                all.iter().copied().fold(f64::INFINITY, f64::min),
                all.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            )
        }
        Measurement::Absorbed(r) => format!(
            "albedo {:.4} ± {:.4}, fabs {:.4} ± {:.4}, ftran {:.4} ± {:.4}",
            ch(r.albedo.value),
            ch(r.albedo.std),
            ch(r.fabs.value),
            ch(r.fabs.std),
            ch(r.ftran.value),
            ch(r.ftran.std)
        ),
        Measurement::Irradiance(r) => format!("{} cells", r.cells.len()),
        Measurement::Fisheye(r) => format!(
            "{}x{} image, gap fraction at the zenith {:.3}",
            r.image.width,
            r.image.height,
            r.gap.first().map_or(0.0, |g| g.0)
        ),
    };
    eprintln!(
        "sensor '{}': {:.2} s, {:.2} M rays: {what} ({name})",
        out.sensor.name,
        out.elapsed.as_secs_f64(),
        out.rays as f64 / 1e6
    );
}

/// The BRF of every sweep against the signed view zenith, ±2 standard errors as bars.
fn brf_plot(
    out: &SensorOutput,
    c: usize,
    channel: &str,
    r: &sensors::brf::BrfResult,
    sweeps: &[lamina_scene::radiometry::BrfSweep],
) -> image::RgbImage {
    let colours = [[200, 40, 40], [40, 90, 200], [30, 150, 60], [150, 60, 170]];
    let labels: Vec<String> = sweeps.iter().map(|s| s.label.to_uppercase()).collect();
    let series: Vec<crate::chart::Series> = sweeps
        .iter()
        .zip(&r.sweeps)
        .enumerate()
        .map(|(k, (s, est))| {
            let mut pts: Vec<(f64, f64, f64)> = s
                .directions
                .iter()
                .zip(est)
                .map(|(d, e)| {
                    (
                        d.signed_zenith as f64,
                        e.value.to_array()[c],
                        2.0 * e.std.to_array()[c],
                    )
                })
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            crate::chart::Series {
                points: pts.iter().map(|p| (p.0, p.1)).collect(),
                colour: colours[k % colours.len()],
                dotted: false,
                label: &labels[k],
                errors: pts.iter().map(|p| p.2).collect(),
            }
        })
        .collect();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in &series {
        for (p, e) in s.points.iter().zip(&s.errors) {
            lo = lo.min(p.1 - e);
            hi = hi.max(p.1 + e);
        }
    }
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        (lo, hi) = (0.0, 1.0);
    }
    let span = hi - lo;
    let tick = nice_step(span / 6.0);
    let (lo, hi) = ((lo / tick).floor() * tick, (hi / tick).ceil() * tick);
    let title = format!(
        "BRF, SUN ZENITH {:.0}: SENSOR {}, {}",
        r.sun_zenith,
        out.sensor.name.to_uppercase(),
        channel.to_uppercase()
    );
    crate::chart::draw(
        &crate::chart::Chart {
            x: (-90.0, 90.0),
            y: (lo.max(0.0).min(lo), hi),
            ticks: (15.0, tick),
            x_title: "VIEW ZENITH",
            title: &title,
        },
        &series,
    )
}

/// 1, 2 or 5 times a power of ten, at least `x`.
fn nice_step(x: f64) -> f64 {
    let p = 10f64.powf(x.max(1e-9).log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|s| *s >= x)
        .unwrap_or(10.0 * p)
}
