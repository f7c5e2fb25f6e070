//! `lamina leaf ...`: make leaf folders (the seven maps and `leaf.toml`) procedurally or from
//! captures, and contact sheets of them. The work is done by `lamina-leafmaps`.

use crate::leaf_spectra_cmd::{AlbedoArgs, FitArgs, PigmentArgs};
use crate::output_file::{claim, files_in, replace_mode};
use anyhow::Context;
use lamina_leafmaps::sheet::SheetOptions;
use lamina_leafmaps::{
    FolderWrite, LeafSpec, PrepareInput, Species, check_leaf_folder, generate, prepare, sheet,
};
use std::path::PathBuf;
use std::time::Instant;

/// Leaf map tools.
#[derive(clap::Subcommand, Debug)]
pub enum LeafCommand {
    /// Generate a procedural leaf folder (seven maps + leaf.toml) from a species preset.
    Generate {
        /// Species preset: beech, maple, oak, birch, ivy, grass, willow.
        #[arg(short, long, default_value = "beech", value_parser = parse_species)]
        species: Species,
        /// Random seed (the same seed gives the same leaf).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Pixels along the longer side of the card, 16-8192 (8192 needs about 3.5 GB).
        #[arg(short, long, default_value_t = 1024,
              value_parser = clap::value_parser!(u32).range(16..=8192))]
        resolution: u32,
        /// Output leaf folder. An existing one is replaced (atomically) only if lamina wrote
        /// it and it holds nothing else; see --force.
        #[arg(short, long)]
        out: PathBuf,
        /// Write into an existing folder that lamina did not write: replace only the seven
        /// maps and leaf.toml in it and keep every other file.
        #[arg(long)]
        force: bool,
        /// Also write a contact sheet PNG of the result.
        #[arg(long)]
        sheet: Option<PathBuf>,
    },
    /// Make a leaf folder from captures: a front photo and optionally a back photo, a
    /// through-light scan, a matte and a normal or bump map. Missing maps are derived and
    /// leaf.toml says how.
    Prepare {
        /// Adaxial (upper side) photograph, sRGB. Sets the output size.
        #[arg(long)]
        front: PathBuf,
        /// Abaxial (lower side) photograph, same layout as the front (not mirrored).
        #[arg(long)]
        back: Option<PathBuf>,
        /// Through-light (translucency) scan.
        #[arg(long)]
        translucency: Option<PathBuf>,
        /// Alpha matte (white = leaf); without it the leaf is segmented from the background.
        #[arg(long)]
        alpha: Option<PathBuf>,
        /// Use the --alpha matte exactly as given (by default an approximate matte is refined
        /// against the photo's background).
        #[arg(long)]
        no_refine_alpha: bool,
        /// Tangent-space normal map (OpenGL convention, green up).
        #[arg(long, conflicts_with = "bump")]
        normal: Option<PathBuf>,
        /// Bump (height) map, grey, white = up.
        #[arg(long)]
        bump: Option<PathBuf>,
        /// Resolution of the capture in dots per inch (makes --blur-radius millimetres).
        #[arg(long)]
        dpi: Option<f32>,
        /// Thickness blur (Gaussian sigma): mm with --dpi, else pixels [default: 0.5 mm, or
        /// 0.5 % of the image without --dpi].
        #[arg(long)]
        blur_radius: Option<f32>,
        /// Take the leaf model parameters from this species preset (default: a generic green leaf).
        #[arg(short, long, value_parser = parse_species)]
        species: Option<Species>,
        /// Output leaf folder. An existing one is replaced (atomically) only if lamina wrote
        /// it and it holds nothing else; see --force. It may not overwrite an input.
        #[arg(short, long)]
        out: PathBuf,
        /// Write into an existing folder that lamina did not write: replace only the seven
        /// maps and leaf.toml in it and keep every other file (inputs are never overwritten).
        #[arg(long)]
        force: bool,
        /// Also write a contact sheet PNG of the result.
        #[arg(long)]
        sheet: Option<PathBuf>,
    },
    /// Contact sheet of a leaf folder: its seven maps and renders lit from the front and
    /// from behind.
    Sheet {
        /// The leaf folder (holding leaf.toml).
        dir: PathBuf,
        /// Output image: .png or .jpg (written atomically). An existing file is replaced
        /// only if lamina wrote it; see --force.
        #[arg(short, long)]
        out: PathBuf,
        /// Replace an output file lamina did not write.
        #[arg(long)]
        force: bool,
        /// Tile size in pixels.
        #[arg(long, default_value_t = 256)]
        tile: u32,
        /// Exposure multiplier of the back-lit render.
        #[arg(long, default_value_t = 1.0)]
        backlit_exposure: f32,
    },
    /// A leaf's reflectance and transmittance, 400-2500 nm at 1 nm, from its pigments
    /// (PROSPECT-D or PROSPECT-PRO), as CSV `wavelength_nm,reflectance,transmittance`.
    Prospect {
        #[command(flatten)]
        pigments: PigmentArgs,
        /// Output CSV (written atomically). An existing file is replaced only if lamina wrote
        /// it; see --force.
        #[arg(short, long)]
        out: PathBuf,
        /// Replace an output file lamina did not write.
        #[arg(long)]
        force: bool,
    },
    /// A leaf's directional-hemispherical reflectance and transmittance, integrated from
    /// the BSDF the renderer evaluates, averaged over its opaque texels; CSV
    /// `wavelength_nm,reflectance,transmittance` (an RGB leaf: one row per channel at its
    /// nominal wavelength, 464/549/611 nm for blue/green/red).
    Albedo(AlbedoArgs),
    /// Fit a leaf to a measured R (and T) spectrum: PROSPECT pigments, written as a leaf
    /// folder with fit.csv and fit.png.
    Fit(FitArgs),
}

fn parse_species(s: &str) -> Result<Species, String> {
    s.parse::<Species>().map_err(|e| e.to_string())
}

/// A `--sheet` path must name an image type lamina writes and a file it may replace:
/// checked before the work. `inputs` are the command's input files.
fn check_sheet(
    path: Option<&std::path::Path>,
    force: bool,
    inputs: &[PathBuf],
) -> anyhow::Result<()> {
    if let Some(p) = path {
        lamina_io::image_out::format_for(p).context("--sheet")?;
        claim(p, force, inputs).context("--sheet")?;
    }
    Ok(())
}

/// Writes the contact sheet of leaf folder `dir` to `out`, which may not be one of the
/// folder's files and, unless `force`, must be absent or lamina's.
fn write_sheet(
    dir: &std::path::Path,
    out: &std::path::Path,
    options: &SheetOptions,
    force: bool,
) -> anyhow::Result<()> {
    claim(out, force, &files_in(dir))?;
    sheet(dir, out, options).with_context(|| format!("contact sheet of '{}'", dir.display()))?;
    eprintln!("wrote {}", out.display());
    Ok(())
}

/// Runs a `lamina leaf` subcommand. Warnings go to stderr; errors name the file concerned.
pub fn run(cmd: LeafCommand) -> anyhow::Result<()> {
    match cmd {
        LeafCommand::Generate {
            species,
            seed,
            resolution,
            out,
            force,
            sheet: sheet_png,
        } => {
            let t = Instant::now();
            let how = FolderWrite {
                replace: replace_mode(force),
                ..FolderWrite::default()
            };
            // Refuse before the work, not after it.
            check_leaf_folder(&out, &how)
                .with_context(|| format!("writing leaf folder '{}'", out.display()))?;
            check_sheet(sheet_png.as_deref(), force, &[])?;
            let leaf = generate(&LeafSpec::new(species, seed, resolution));
            let (w, h) = leaf.planes.size();
            leaf.write_folder_with(&out, &how)
                .with_context(|| format!("writing leaf folder '{}'", out.display()))?;
            eprintln!(
                "wrote {} ({species}, seed {seed}, {w}x{h} px, card {:.3} x {:.3} m) in {:.2} s",
                out.display(),
                leaf.size_m.0,
                leaf.size_m.1,
                t.elapsed().as_secs_f64()
            );
            if let Some(p) = sheet_png {
                write_sheet(&out, &p, &SheetOptions::default(), force)?;
            }
        }
        LeafCommand::Prepare {
            front,
            back,
            translucency,
            alpha,
            no_refine_alpha,
            normal,
            bump,
            dpi,
            blur_radius,
            species,
            out,
            force,
            sheet: sheet_png,
        } => {
            let t = Instant::now();
            let mut input = PrepareInput::new(front, &out);
            input.back = back;
            input.translucency = translucency;
            input.alpha = alpha;
            input.refine_alpha = !no_refine_alpha;
            input.normal = normal;
            input.bump = bump;
            input.dpi = dpi;
            input.blur_radius = blur_radius;
            input.replace = replace_mode(force);
            if let Some(s) = species {
                input.params = s.params();
            }
            check_sheet(sheet_png.as_deref(), force, &input.input_files())?;
            let r = prepare(&input).context("lamina leaf prepare")?;
            for w in &r.warnings {
                eprintln!("warning: {w}");
            }
            for p in &r.provenance {
                eprintln!("  {p}");
            }
            eprintln!(
                "wrote {} (alpha keeps {:.1} %) in {:.2} s",
                r.dir.display(),
                100.0 * r.alpha_fraction,
                t.elapsed().as_secs_f64()
            );
            if let Some(p) = sheet_png {
                write_sheet(&out, &p, &SheetOptions::default(), force)?;
            }
        }
        LeafCommand::Sheet {
            dir,
            out,
            force,
            tile,
            backlit_exposure,
        } => {
            let options = SheetOptions {
                tile,
                backlit_exposure,
            };
            write_sheet(&dir, &out, &options, force)?;
        }
        LeafCommand::Prospect {
            pigments,
            out,
            force,
        } => crate::leaf_spectra_cmd::run_prospect(&pigments, &out, force)?,
        LeafCommand::Albedo(a) => crate::leaf_spectra_cmd::run_albedo(&a)?,
        LeafCommand::Fit(a) => crate::leaf_spectra_cmd::run_fit(&a)?,
    }
    Ok(())
}
