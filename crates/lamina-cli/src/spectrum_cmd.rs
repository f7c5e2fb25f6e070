//! `lamina spectrum`: the spectrum lamina gives an RGB value in spectral renders
//! (`[film] spectral = "visible"` and `bands`), as CSV `wavelength_nm,value`. A reflectance
//! (any RGB material coefficient) is `Σ_c rgb_c B_c(λ)`, the Jakob & Hanika basis of
//! `lamina_leaf::spectrum::bands`; an emission (`--emission d65|solar`) is that times the
//! illuminant's shape, in W m⁻² sr⁻¹ nm⁻¹ (W m⁻² nm⁻¹ for a sun) per unit of RGB radiance
//! with `Y = ∫ L ȳ dλ`. `visible` renders give RGB light the D65 shape, band renders the
//! solar one. Other renderers (bench/spectral/mitsuba_spectral.py) are given these spectra to
//! render the same scene.

use crate::output_file::claim;
use anyhow::{Context, bail};
use glam::Vec3;
use lamina_leaf::spectrum::bands::{Illuminant, rgb_emission_at, rgb_reflectance_at};
use std::io::Write;
use std::path::PathBuf;

/// `lamina spectrum`'s flags.
#[derive(clap::Args, Debug)]
pub struct SpectrumArgs {
    /// The linear Rec.709 value, `R,G,B` (a reflectance: each in [0, 1]; an emission: any
    /// non-negative value).
    #[arg(long, value_parser = parse_rgb, allow_hyphen_values = true)]
    pub rgb: Vec3,
    /// Treat the value as emission of this shape (`d65`: what `visible` renders use; `solar`:
    /// what band renders use) instead of a reflectance.
    #[arg(long, value_parser = parse_illuminant)]
    pub emission: Option<Illuminant>,
    /// Wavelengths `FIRST:LAST:STEP` in nm, inside 360-2500 nm.
    #[arg(long, default_value = "360:830:1", value_parser = parse_grid)]
    pub wavelengths: Grid,
    /// Output CSV `wavelength_nm,value`.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Replace an output file lamina did not write.
    #[arg(long)]
    pub force: bool,
}

/// Wavelengths in nm.
#[derive(Clone, Debug)]
pub struct Grid(pub Vec<f32>);

fn parse_rgb(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--rgb '{s}': expected three numbers R,G,B"))?;
    if v.len() != 3 {
        return Err(format!(
            "--rgb '{s}': expected three numbers R,G,B, got {}",
            v.len()
        ));
    }
    if v.iter().any(|x| !x.is_finite() || *x < 0.0) {
        return Err(format!(
            "--rgb '{s}': values must be finite and non-negative"
        ));
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

fn parse_illuminant(s: &str) -> Result<Illuminant, String> {
    match s {
        "d65" => Ok(Illuminant::D65),
        "solar" => Ok(Illuminant::Solar),
        _ => Err(format!("--emission '{s}': expected d65 or solar")),
    }
}

fn parse_grid(s: &str) -> Result<Grid, String> {
    crate::leaf_spectra_cmd::wavelength_grid(s, (360.0, 2500.0), "lamina's spectra cover", 21401)
        .map(Grid)
}

/// Runs `lamina spectrum`.
pub fn run(a: &SpectrumArgs) -> anyhow::Result<()> {
    if a.emission.is_none() && a.rgb.max_element() > 1.0 {
        bail!(
            "--rgb {},{},{}: a reflectance has each channel in [0, 1] (for light, add \
             --emission d65 or --emission solar)",
            a.rgb.x,
            a.rgb.y,
            a.rgb.z
        );
    }
    claim(&a.out, a.force, &[])?;
    let (what, f): (&str, Box<dyn Fn(f32) -> f32>) = match a.emission {
        None => ("reflectance", Box::new(|nm| rgb_reflectance_at(a.rgb, nm))),
        Some(ill) => (
            match ill {
                Illuminant::D65 => "emission, D65 shape (per nm, Y = ∫ L ȳ dλ)",
                Illuminant::Solar => "emission, solar shape (per nm, Y = ∫ L ȳ dλ)",
            },
            Box::new(move |nm| rgb_emission_at(a.rgb, nm, ill)),
        ),
    };
    let detail = format!(
        "spectrum of RGB {},{},{} as {what}",
        a.rgb.x, a.rgb.y, a.rgb.z
    );
    lamina_io::write_file(&a.out, |w| {
        writeln!(w, "{}", lamina_io::text_mark_line(&detail))?;
        writeln!(w, "wavelength_nm,value")?;
        for &nm in &a.wavelengths.0 {
            writeln!(w, "{nm},{:.7e}", f(nm))?;
        }
        Ok(())
    })
    .with_context(|| format!("writing {}", a.out.display()))?;
    eprintln!(
        "wrote {} ({} wavelengths, {what})",
        a.out.display(),
        a.wavelengths.0.len()
    );
    Ok(())
}
