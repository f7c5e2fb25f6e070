//! `lamina`: render leaf and plant scenes.
//!
//! Errors are reported with their whole chain (`error: ...: ...`) and exit code 1; usage
//! errors exit with 2 (clap's convention); a command stopped by Ctrl-C exits with 130
//! (see [`lamina_io::interrupt`] for what Ctrl-C does when). Nothing here panics on bad
//! input. Where the binary sits among the crates, and the invariants they keep:
//! ARCHITECTURE.md.

#![forbid(unsafe_code)]

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod bands_render;
mod canopy_cmd;
mod chart;
mod demo;
mod farm_cmd;
mod gpu_cmd;
mod interrupted;
mod leaf_cmd;
mod leaf_spectra_cmd;
mod output_file;
mod parts_cmd;
mod plant_cmd;
mod render_cmd;
mod sensors_cmd;
mod sky_cmd;
mod spectrum_cmd;
mod view_cmd;

/// A renderer for plant leaves and whole plants.
#[derive(Parser, Debug)]
#[command(name = "lamina", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene file (TOML) to PNG and/or EXR.
    Render(render_cmd::RenderArgs),
    /// Merge parts of a render (`lamina render --part K/N`, `--crop`) into the image one
    /// render would have made: checks that they belong together, names missing parts.
    Merge(parts_cmd::MergeArgs),
    /// Renders on a cluster: Slurm job arrays of render parts with a merge job, their
    /// status, retries and merges.
    #[command(subcommand)]
    Farm(farm_cmd::FarmCommand),
    /// Open a window with the real-time (GPU) view of a scene: orbit the camera, move the sun.
    View(view_cmd::ViewArgs),
    /// Canopy scenes for radiative-transfer studies: RAMI's discrete canopies.
    #[command(subcommand)]
    Canopy(canopy_cmd::CanopyCommand),
    /// Render the built-in demo: a leaf lit from the front and from behind, and a bush.
    Demo(demo::DemoArgs),
    /// Leaf maps and spectra: procedural leaves, captures, contact sheets, PROSPECT.
    #[command(subcommand)]
    Leaf(leaf_cmd::LeafCommand),
    /// Procedural plants.
    #[command(subcommand)]
    Plant(PlantCommand),
    /// The sun and clear sky for a place and a time: the sun's position, the direct/diffuse
    /// split per band (SPCTRAL2), and the sky as an equirectangular EXR (Preetham).
    Sky(sky_cmd::SkyArgs),
    /// The spectrum lamina gives an RGB reflectance or light in spectral renders, as CSV
    /// `wavelength_nm,value` (to give another renderer the same scene).
    Spectrum(spectrum_cmd::SpectrumArgs),
}

#[derive(Subcommand, Debug)]
enum PlantCommand {
    /// Generate a bush or a tree and write it as binary glTF (.glb) for other tools.
    Generate(plant_cmd::PlantGenerateArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // One handler for the whole process, before any work (in "quit at once" mode).
    if let Err(e) = lamina_io::interrupt::install() {
        eprintln!("warning: {e}; Ctrl-C will end lamina without cleaning up");
    }
    let result = match cli.command {
        Command::Render(args) => render_cmd::run(args),
        Command::Merge(args) => parts_cmd::run_merge(&args),
        Command::Farm(cmd) => farm_cmd::run(cmd),
        Command::Demo(args) => demo::run(args),
        Command::Canopy(cmd) => canopy_cmd::run(cmd),
        Command::View(args) => view_cmd::run(args),
        Command::Leaf(cmd) => leaf_cmd::run(cmd),
        Command::Plant(PlantCommand::Generate(args)) => plant_cmd::run_generate(args),
        Command::Sky(args) => sky_cmd::run(&args),
        Command::Spectrum(args) => spectrum_cmd::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<interrupted::Interrupted>() => {
            eprintln!("{e}");
            ExitCode::from(lamina_io::interrupt::EXIT_CODE)
        }
        Err(e) => {
            eprintln!("error: {}", error_text(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes joined by ": ", as anyhow's `{:#}` writes them, leaving out a
/// cause whose text the message before it already ends with: lamina's library errors (a
/// failed write, an unreadable leaf map) say their cause in their own message and also
/// return it as their `source()`, and it should be printed once.
fn error_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let t = cause.to_string();
        if text.is_empty() {
            text = t;
        } else if !text.ends_with(&t) {
            text.push_str(": ");
            text.push_str(&t);
        }
    }
    text
}
