//! Renders split into parts (`lamina render --part K/N`, `--crop X0,Y0,X1,Y1`) and
//! `lamina merge`: the CLI side of `lamina_farm`'s part files and merges.

use crate::render_cmd::{Outputs, RenderArgs};
use anyhow::{Context, Result, bail};
use lamina_farm::{Part, PartInfo};
use lamina_io::interrupt;
use lamina_render::{Crop, Image, RenderOptions, RenderOutput, RenderStats, SampleRange};
use lamina_scene::{Film, Scene, SpectralOutput};
use std::path::{Path, PathBuf};

/// Whether `path` names an EXR file (by the extension, as every image writer decides).
pub fn is_exr(path: &Path) -> bool {
    lamina_io::image_out::format_for(path).ok() == Some(image::ImageFormat::OpenExr)
}

/// What part of the render to make: the description its file will carry (the samples and
/// pixels asked for; the samples done are filled in after the render).
#[derive(Clone, Debug)]
pub struct Split {
    /// The description.
    pub info: PartInfo,
    /// Time spent hashing the scene.
    pub hash_time: std::time::Duration,
}

impl Split {
    /// The split `args` ask for (`None` without `--part` and `--crop`), checked against the
    /// loaded scene: `--crop` inside the image, every part holding at least one sample.
    pub fn new(
        args: &RenderArgs,
        scene: &Scene,
        spectral: Option<&SpectralOutput>,
    ) -> Result<Option<Split>> {
        if args.part.is_none() && args.crop.is_none() {
            return Ok(None);
        }
        let film = scene.film;
        let spp = args.flags.spp.unwrap_or(film.spp);
        let range = match args.part {
            None => SampleRange { start: 0, end: spp },
            Some((k, n)) => {
                if n > spp {
                    bail!(
                        "--part {k}/{n}: {n} parts of {spp} samples per pixel would leave some \
                         parts without a sample; use at most {spp} parts (or more --spp)"
                    );
                }
                SampleRange::part(k, n, spp)
            }
        };
        let crop = args.crop.unwrap_or(Crop::full(film.width, film.height));
        if crop.x1 > film.width || crop.y1 > film.height {
            bail!(
                "--crop {},{},{},{}: outside the {}x{} image (X1 at most {}, Y1 at most {})",
                crop.x0,
                crop.y0,
                crop.x1,
                crop.y1,
                film.width,
                film.height,
                film.width,
                film.height
            );
        }
        let (channels, false_color) = match spectral {
            None => (
                vec!["R".to_string(), "G".into(), "B".into()],
                ["R".to_string(), "G".into(), "B".into()],
            ),
            Some(s) => {
                let names: Vec<String> = s.bands.iter().map(|b| b.name.clone()).collect();
                let fc = s.false_color.map(|i| names[i].clone());
                (names, fc)
            }
        };
        let t = std::time::Instant::now();
        let scene_hash = lamina_farm::hash::debug_hash(&(scene, spectral));
        let hash_time = t.elapsed();
        let info = PartInfo {
            generator: lamina_io::GENERATOR.into(),
            scene: args
                .scene
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            scene_hash,
            seed: args.flags.seed,
            spp,
            samples: [range.start, range.end],
            samples_requested: [range.start, range.end],
            part: args.part.map(|(k, n)| [k, n]),
            width: film.width,
            height: film.height,
            crop: [crop.x0, crop.y0, crop.x1, crop.y1],
            filter: format!("{:?}", film.filter),
            exposure: film.exposure,
            tonemap: format!("{:?}", film.tonemap),
            channels,
            false_color,
        };
        Ok(Some(Split { info, hash_time }))
    }

    /// The samples asked for.
    pub fn range(&self) -> SampleRange {
        let [start, end] = self.info.samples_requested;
        SampleRange { start, end }
    }

    /// The pixels asked for.
    pub fn crop(&self) -> Crop {
        let [x0, y0, x1, y1] = self.info.crop;
        Crop { x0, y0, x1, y1 }
    }

    /// Restricts `opts` to the part, keeping the f64 sums.
    pub fn apply(&self, opts: &mut RenderOptions) {
        opts.samples = Some(self.range());
        opts.crop = Some(self.crop());
        opts.keep_sums = true;
    }

    /// The part an RGB render made.
    pub fn rgb_part(&self, out: &RenderOutput) -> Result<Part> {
        let sums = out.sums.as_ref().context("the render kept no sums")?;
        Ok(Part {
            info: self.done(&out.stats),
            sums: (0..3)
                .map(|c| sums.iter().map(|s| s[c]).collect())
                .collect(),
        })
    }

    /// The description with the samples that were rendered.
    pub fn done(&self, stats: &RenderStats) -> PartInfo {
        let mut info = self.info.clone();
        info.samples = [stats.sample_range.start, stats.sample_range.end];
        info
    }
}

/// Writes a part's outputs: `.exr` as the part file, `.png` as a preview of its pixels.
/// After Ctrl-C, writes what the completed passes hold (nothing when none completed) and
/// returns the interruption, as a whole render does.
pub fn write_part_result(
    outputs: &Outputs,
    part: &Part,
    stats: &RenderStats,
    preview: &Image,
    film: &Film,
) -> Result<()> {
    // The first pass always completes unless Ctrl-C cancelled it.
    let interrupted = interrupt::interrupted();
    if stats.passes_done == 0 {
        return Err(
            crate::interrupted::Interrupted("no pass completed, nothing written".into()).into(),
        );
    }
    for out in &outputs.paths {
        crate::output_file::claim(out, outputs.force, &outputs.inputs)?;
        if is_exr(out) {
            lamina_farm::write_part(out, part)?;
        } else {
            lamina_render::write_image(out, preview, film)
                .with_context(|| format!("writing '{}'", out.display()))?;
        }
        eprintln!(
            "wrote {} (samples {}..{} of {}, pixels {},{},{},{})",
            out.display(),
            part.info.samples[0],
            part.info.samples[1],
            part.info.spp,
            part.info.crop[0],
            part.info.crop[1],
            part.info.crop[2],
            part.info.crop[3]
        );
    }
    if interrupted || part.info.samples != part.info.samples_requested {
        let why = format!(
            "stopped early: the part holds samples {}..{} of the {}..{} asked for; `lamina \
             merge` will name the missing samples",
            part.info.samples[0],
            part.info.samples[1],
            part.info.samples_requested[0],
            part.info.samples_requested[1]
        );
        if interrupted {
            return Err(crate::interrupted::Interrupted(why).into());
        }
        eprintln!("warning: {why}");
    }
    Ok(())
}

/// One line with a part's costs: loading (with the scene hash), the BVH build, the
/// rendering of its samples, writing its files (and their size): the per-part overhead of
/// a split render is everything but the rendering.
pub fn print_timing(
    load: std::time::Duration,
    hash: std::time::Duration,
    stats: &RenderStats,
    write: std::time::Duration,
    paths: &[PathBuf],
) {
    let bytes: u64 = paths
        .iter()
        .filter_map(|p| std::fs::metadata(p).ok())
        .map(|m| m.len())
        .sum();
    eprintln!(
        "part timing: load {:.3} s (scene hash {:.3} s), BVH build {:.3} s, render {:.3} s, write {:.3} s ({:.2} MB written)",
        load.as_secs_f64(),
        hash.as_secs_f64(),
        stats.accel_build.as_secs_f64(),
        (stats.elapsed - stats.accel_build).as_secs_f64(),
        write.as_secs_f64(),
        bytes as f64 / 1e6
    );
}

/// `lamina merge PARTS... -o OUT`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Part files written by `lamina render --part K/N` and/or `--crop` (EXR).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output image(s): `.exr` (linear float, every channel) or `.png` (tone-mapped, as
    /// `lamina render` writes it). Repeatable.
    #[arg(short, long = "output", value_name = "OUT", required = true)]
    pub output: Vec<PathBuf>,
    /// Write the best image the parts present allow when some are missing (each pixel the
    /// mean of the samples it has); the EXR header and the output say what is missing.
    #[arg(long)]
    pub allow_missing: bool,
    /// Replace an output file that lamina did not write.
    #[arg(long)]
    pub force: bool,
}

/// Reads, checks and merges the parts, then writes the outputs.
pub fn run_merge(args: &MergeArgs) -> Result<()> {
    let outputs = Outputs {
        paths: args.output.clone(),
        force: args.force,
        inputs: args.parts.clone(),
    };
    outputs.check()?;
    let t0 = std::time::Instant::now();
    let merged = lamina_farm::merge_files(&args.parts, args.allow_missing)?;
    let s = &merged.summary;
    if !s.complete {
        eprintln!(
            "warning: parts are missing, the image holds {}-{} of {} samples per pixel: {}",
            s.spp_min, s.spp_max, s.spp, s.missing
        );
    }
    for out in &outputs.paths {
        crate::output_file::claim(out, outputs.force, &outputs.inputs)?;
        lamina_farm::merge::write_merged(out, &merged)?;
        eprintln!("wrote {}", out.display());
    }
    eprintln!(
        "merged {} parts of {} ({}x{}, {} spp{}) in {:.2} s",
        s.parts,
        merged.info.scene,
        merged.info.width,
        merged.info.height,
        s.spp,
        if s.complete {
            ", complete"
        } else {
            ", INCOMPLETE"
        },
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
