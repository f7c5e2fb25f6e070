//! `lamina render`: load a scene file, render it with a progress bar, write the images.

use crate::interrupted::Interrupted;
use anyhow::{Context, Result, bail};
use indicatif::{ProgressBar, ProgressStyle};
use lamina_io::interrupt::{self, Mode};
use lamina_render::{Image, RenderOptions, RenderOutput, RenderStats};
use lamina_scene::{Film, Scene};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// Options shared by every command that renders.
#[derive(clap::Args, Debug, Clone)]
pub struct RenderFlags {
    /// Samples per pixel (overrides the scene's film.spp).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Random seed: the same scene, seed and sample count give the same image.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Stop after this many seconds and write what is done (whole passes; the first pass,
    /// one sample per pixel, always completes).
    #[arg(long, value_name = "SECONDS")]
    pub time_limit: Option<f64>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
    /// The ray-casting engine: `lamina` (its own, the default) or `embree` (Intel Embree 3,
    /// for comparison; in builds with the `embree` feature).
    #[arg(long, value_name = "ENGINE", default_value = "lamina", value_parser = parse_accel)]
    pub accel: lamina_render::accel::Backend,
    /// Follow every path on its own, even where the wavefront path tracer (pixel samples
    /// side by side) serves the scene: the same image bit for bit, for timing.
    #[arg(long)]
    pub one_path_at_a_time: bool,
}

/// Parses `--accel ENGINE`.
fn parse_accel(s: &str) -> Result<lamina_render::accel::Backend, String> {
    lamina_render::accel::Backend::parse(s)
        .ok_or_else(|| format!("'{s}' is not a ray-casting engine: use lamina or embree"))
}

/// `lamina render SCENE`.
#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// The scene file (TOML; see docs/scene-format.md).
    pub scene: PathBuf,
    /// Output image(s): `.png` (tone-mapped sRGB) or `.exr` (linear float). Repeatable.
    /// Default: the scene's name with `.png`, in the current directory.
    #[arg(short, long = "output", value_name = "OUT")]
    pub output: Vec<PathBuf>,
    /// Render with the real-time GPU approximation (wgpu; Mesa's lavapipe runs it without a
    /// GPU) instead of the offline path tracer. Same film size, exposure and tone map.
    #[arg(long)]
    pub gpu: bool,
    /// With --gpu: level of detail for foliage. A plant whose leaves look smaller than
    /// this many pixels of the image drops a random share of them and enlarges the rest,
    /// keeping its leaf area (stochastic simplification); 0 draws every leaf. Default 1.
    #[arg(long, value_name = "PIXELS", allow_negative_numbers = true, value_parser = crate::gpu_cmd::parse_lod)]
    pub lod: Option<f32>,
    /// Replace an output file that lamina did not write (without it, such a file is kept
    /// and the render refused; lamina's own earlier outputs are always replaced).
    #[arg(long)]
    pub force: bool,
    /// Render part K of N (0-based) of the samples: sample indices ⌊K·spp/N⌋ to
    /// ⌊(K+1)·spp/N⌋ of the full render, written as a part EXR that `lamina merge` adds up
    /// to exactly the single render of the same seed and spp.
    #[arg(long, value_name = "K/N", value_parser = parse_part)]
    pub part: Option<(u32, u32)>,
    /// Render only the pixels x0 ≤ x < x1, y0 ≤ y < y1 (from the top-left corner), written
    /// as a part EXR (data window = the crop) that `lamina merge` stitches with no seam.
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_crop)]
    pub crop: Option<lamina_render::Crop>,
    /// Set a key of the scene file before it is read (repeatable): `film.spp=64`,
    /// `light[0].irradiance=[3, 3, 3]`, `material[1].species="maple"` (strings in quotes).
    /// The value goes through the same checks as in the file.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<lamina_scene::Override>,
    /// Skip the scene's `[[sensor]]`s (by default they run, and a scene with sensors
    /// renders its image only when `-o` names one).
    #[arg(long)]
    pub no_sensors: bool,
    /// Multiply every sensor's sample count by this (e.g. 0.1 for a quick look).
    #[arg(long, value_name = "K")]
    pub sensor_scale: Option<f64>,
    #[command(flatten)]
    pub flags: RenderFlags,
}

/// `--part K/N`: two integers, K below N.
fn parse_part(s: &str) -> std::result::Result<(u32, u32), String> {
    let (k, n) = s
        .split_once('/')
        .ok_or_else(|| format!("'{s}' is not K/N (e.g. 0/4 for the first of four parts)"))?;
    let num = |t: &str, what: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("'{s}': {what} '{t}' is not a whole number"))
    };
    let (k, n) = (num(k, "K")?, num(n, "N")?);
    if n == 0 || k >= n {
        return Err(format!(
            "'{s}': K must be below N (parts are numbered 0 to N-1)"
        ));
    }
    Ok((k, n))
}

/// `--crop X0,Y0,X1,Y1`: four integers, a non-empty rectangle (checked against the image
/// once the scene is loaded).
fn parse_crop(s: &str) -> std::result::Result<lamina_render::Crop, String> {
    let v: Vec<&str> = s.split(',').collect();
    if v.len() != 4 {
        return Err(format!("'{s}' is not X0,Y0,X1,Y1 (four pixel coordinates)"));
    }
    let mut n = [0u32; 4];
    for (i, t) in v.iter().enumerate() {
        n[i] = t
            .trim()
            .parse()
            .map_err(|_| format!("'{s}': '{t}' is not a whole number of pixels"))?;
    }
    if n[0] >= n[2] || n[1] >= n[3] {
        return Err(format!(
            "'{s}': the crop is empty (X0 must be below X1 and Y0 below Y1)"
        ));
    }
    Ok(lamina_render::Crop {
        x0: n[0],
        y0: n[1],
        x1: n[2],
        y1: n[3],
    })
}

/// Checks output paths before any work: known extension, existing directory, and a file
/// already there only when lamina wrote it or `force` ([`crate::output_file::claim`]).
pub fn check_outputs(outputs: &[PathBuf], force: bool, inputs: &[PathBuf]) -> Result<()> {
    for out in outputs {
        let ext = out
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if ext != "png" && ext != "exr" {
            bail!(
                "output '{}': unknown image type (use .png or .exr)",
                out.display()
            );
        }
        let dir = match out.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            bail!(
                "output '{}': directory '{}' does not exist",
                out.display(),
                dir.display()
            );
        }
        if out.is_dir() {
            bail!("output '{}' is a folder: name an image file", out.display());
        }
        crate::output_file::claim(out, force, inputs)?;
    }
    Ok(())
}

/// Builds render options from flags, with Ctrl-C wired to cancellation and progress shown
/// as a bar on a terminal, or as one line per pass when stderr is not one (logs, batch
/// jobs) unless `--quiet`.
///
/// With `keep_partial`, the process switches to [`Mode::Stop`] once the first pass is done:
/// from then on the first Ctrl-C stops the render at a pass boundary and the image of the
/// completed passes is kept. Without it (a render whose partial image would be of no use,
/// like the demo's first panels) Ctrl-C keeps quitting at once.
pub fn options(
    flags: &RenderFlags,
    label: &str,
    keep_partial: bool,
) -> Result<(RenderOptions, Option<ProgressBar>)> {
    let time_limit = match flags.time_limit {
        None => None,
        Some(s) if s.is_finite() && s > 0.0 => Some(Duration::from_secs_f64(s)),
        Some(s) => bail!("--time-limit must be a positive number of seconds, got {s}"),
    };
    let terminal = std::io::stderr().is_terminal();
    let bar = (!flags.quiet && terminal).then(|| {
        let bar = ProgressBar::new(1);
        bar.set_style(
            ProgressStyle::with_template(
                "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} spp (ETA {eta})",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        bar.set_message(label.to_string());
        bar
    });
    let log_passes = !flags.quiet && !terminal;
    let label = label.to_string();
    let bar_cb = bar.clone();
    let progress = Arc::new(move |p: lamina_render::Progress| {
        if keep_partial && p.passes_done == 1 {
            interrupt::set_mode(Mode::Stop);
        }
        if let Some(bar) = &bar_cb {
            bar.set_length(p.spp_total as u64);
            bar.set_position(p.spp_done as u64);
        }
        if log_passes {
            eprintln!(
                "{label}: pass {}/{} done, {}/{} spp, {:.2} s",
                p.passes_done,
                p.passes_total,
                p.spp_done,
                p.spp_total,
                p.elapsed.as_secs_f64()
            );
        }
    }) as Arc<dyn Fn(lamina_render::Progress) + Send + Sync>;
    let opts = RenderOptions {
        spp: flags.spp,
        threads: flags.threads.map(|t| t as usize),
        seed: flags.seed,
        time_limit,
        cancel: Some(interrupt::flag()),
        progress: Some(progress),
        accel: flags.accel,
        one_path_at_a_time: flags.one_path_at_a_time,
        // Someone watching the bar may stop the render early: a first image after one
        // sample per pixel. Logs and batch jobs render in passes of 16 (faster, the same
        // image); a time limit makes the render progressive anyway.
        progressive: bar.is_some(),
        ..Default::default()
    };
    Ok((opts, bar))
}

/// Renders with a progress bar and prints the summary line.
pub fn render_scene(
    scene: &Scene,
    opts: &RenderOptions,
    bar: Option<ProgressBar>,
    label: &str,
) -> Result<RenderOutput> {
    let out = lamina_render::render(scene, opts).with_context(|| format!("rendering {label}"))?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    print_summary(label, &out.stats, scene.film.width, scene.film.height);
    Ok(out)
}

/// One line: time, samples per second, rays per second.
pub fn print_summary(label: &str, s: &RenderStats, width: u32, height: u32) {
    let secs = s.elapsed.as_secs_f64().max(1e-9);
    let setup = if s.spectral_setup.is_zero() {
        String::new()
    } else {
        format!(
            " ({:.2} s of it making the spectral channels' materials and lights)",
            s.spectral_setup.as_secs_f64()
        )
    };
    eprintln!(
        "{label}: {width}x{height}, {} spp in {:.2} s{setup}: {:.2} M samples/s, {:.2} M rays/s{}",
        s.spp_done,
        secs,
        s.samples as f64 / secs / 1e6,
        s.rays as f64 / secs / 1e6,
        if s.stopped_early {
            " (stopped early: partial image)"
        } else {
            ""
        }
    );
}

/// Where a render's image goes: the files, `--force`, and the command's inputs (which are
/// never overwritten).
#[derive(Clone, Debug, Default)]
pub struct Outputs {
    /// The image files (`.png`, `.exr`).
    pub paths: Vec<PathBuf>,
    /// `--force`: replace files lamina did not write.
    pub force: bool,
    /// The command's input files.
    pub inputs: Vec<PathBuf>,
}

impl Outputs {
    /// [`check_outputs`] of these outputs.
    pub fn check(&self) -> Result<()> {
        check_outputs(&self.paths, self.force, &self.inputs)
    }
}

/// Writes `image` to every output, each checked again just before it is written.
pub fn write_all(outputs: &Outputs, image: &Image, film: &Film) -> Result<()> {
    for out in &outputs.paths {
        crate::output_file::claim(out, outputs.force, &outputs.inputs)?;
        lamina_render::write_image(out, image, film)
            .with_context(|| format!("writing '{}'", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

/// After a render that Ctrl-C may have stopped: writes the image if it holds at least one
/// completed pass, and returns [`Interrupted`] (exit code 130) if Ctrl-C was pressed.
pub fn write_result(outputs: &Outputs, out: &RenderOutput, film: &Film) -> Result<()> {
    let s = &out.stats;
    if !interrupt::interrupted() {
        return write_all(outputs, &out.image, film);
    }
    if s.passes_done == 0 {
        return Err(Interrupted("no pass completed, nothing written".into()).into());
    }
    write_all(outputs, &out.image, film)?;
    Err(Interrupted(format!(
        "{} of {} passes completed ({} spp), the pass in progress was dropped; \
         the image written holds the completed passes",
        s.passes_done, s.passes_total, s.spp_done
    ))
    .into())
}

pub fn run(args: RenderArgs) -> Result<()> {
    let splitting = args.part.is_some() || args.crop.is_some();
    let paths = if args.output.is_empty() {
        let stem = args
            .scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "render".into());
        let name = match (args.part, args.crop) {
            (None, None) => format!("{stem}.png"),
            (part, crop) => {
                let mut n = stem;
                if let Some((k, parts)) = part {
                    n.push_str(&format!("-part-{k}-of-{parts}"));
                }
                if let Some(c) = crop {
                    n.push_str(&format!("-crop-{}-{}-{}-{}", c.x0, c.y0, c.x1, c.y1));
                }
                format!("{n}.exr")
            }
        };
        vec![PathBuf::from(name)]
    } else {
        args.output.clone()
    };
    if args.lod.is_some() && !args.gpu {
        bail!(
            "--lod is the GPU path's level of detail; the offline renderer always traces every \
             leaf (add --gpu, or drop --lod)"
        );
    }
    if args.gpu {
        crate::gpu_cmd::check_flags(&args.flags)?;
    }
    if splitting {
        if args.gpu {
            bail!("--part and --crop split the offline render; they do not apply to --gpu");
        }
        if !paths.iter().any(|p| crate::parts_cmd::is_exr(p)) {
            bail!(
                "--part and --crop write a part file: name an .exr output (-o part.exr) for \
                 `lamina merge`; a .png shows only this part"
            );
        }
    }
    let outputs = Outputs {
        paths,
        force: args.force,
        inputs: vec![args.scene.clone()],
    };
    if let Some(k) = args.sensor_scale
        && !(k > 0.0 && k.is_finite())
    {
        bail!("--sensor-scale must be a positive number, got {k}");
    }
    // A scene with sensors and no -o measures only: its default image is not checked.
    if !args.output.is_empty() {
        outputs.check()?;
    }
    if !args.flags.quiet && !std::io::stderr().is_terminal() {
        eprintln!("loading {}", args.scene.display());
    }
    let load_start = std::time::Instant::now();
    let (scene, spectral) = lamina_scene::load_scene_with_overrides(&args.scene, &args.set)?;
    let label = args.scene.display().to_string();
    let sensors = !args.no_sensors && !scene.radiometry.sensors.is_empty();
    if sensors {
        if args.gpu || splitting {
            bail!(
                "the scene has [[sensor]]s, which the offline renderer measures whole: drop \
                 --gpu / --part / --crop, or pass --no-sensors"
            );
        }
        crate::sensors_cmd::check(&scene, args.force, &outputs.inputs)?;
        if args.output.is_empty() {
            if let Some(s) = args.flags.time_limit {
                bail!(
                    "--time-limit {s} stops an image's render, and this run only measures the \
                     scene's [[sensor]]s (each takes its own `samples`): drop --time-limit, or \
                     add -o FILE for an image"
                );
            }
            return crate::sensors_cmd::run(
                &scene,
                &args.scene,
                spectral.as_ref(),
                &args.flags,
                args.sensor_scale,
                args.force,
            );
        }
    }
    if args.output.is_empty() {
        outputs.check()?;
    }
    let split = crate::parts_cmd::Split::new(&args, &scene, spectral.as_ref())?;
    // A part's overheads (what each node of a cluster pays before and after its share of
    // the samples): loading includes the scene hash.
    let load_time = load_start.elapsed();
    if let Some(spectral) = &spectral {
        if args.gpu {
            bail!("--gpu renders RGB only: the scene's [film] asks for spectral bands");
        }
        crate::bands_render::render_bands(
            &scene,
            spectral,
            &args.flags,
            &label,
            &outputs,
            split.as_ref(),
        )?;
        if sensors {
            crate::sensors_cmd::run(
                &scene,
                &args.scene,
                Some(spectral),
                &args.flags,
                args.sensor_scale,
                args.force,
            )?;
        }
        return Ok(());
    }
    if args.gpu {
        if scene.film.spectral == lamina_scene::SpectralMode::Visible {
            bail!(
                "--gpu renders RGB only: the scene's [film] asks for spectral = \"visible\" \
                 (drop --gpu, or render with --set film.spectral=rgb)"
            );
        }
        return crate::gpu_cmd::render_gpu(&scene, &label, &outputs, args.flags.spp, args.lod);
    }
    if !args.flags.quiet && !std::io::stderr().is_terminal() {
        eprintln!(
            "{label}: loaded, rendering {}x{}",
            scene.film.width, scene.film.height
        );
    }
    let (mut opts, bar) = options(&args.flags, &label, true)?;
    if let Some(split) = &split {
        split.apply(&mut opts);
    }
    let out = render_scene(&scene, &opts, bar, &label)?;
    match &split {
        None => {
            write_result(&outputs, &out, &scene.film)?;
            if sensors {
                crate::sensors_cmd::run(
                    &scene,
                    &args.scene,
                    None,
                    &args.flags,
                    args.sensor_scale,
                    args.force,
                )?;
            }
            Ok(())
        }
        Some(split) => {
            let part = split.rgb_part(&out)?;
            let t = std::time::Instant::now();
            crate::parts_cmd::write_part_result(
                &outputs,
                &part,
                &out.stats,
                &out.image,
                &scene.film,
            )?;
            if !args.flags.quiet {
                crate::parts_cmd::print_timing(
                    load_time,
                    split.hash_time,
                    &out.stats,
                    t.elapsed(),
                    &outputs.paths,
                );
            }
            Ok(())
        }
    }
}
