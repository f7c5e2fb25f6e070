//! `lamina leaf prospect | albedo | fit`: a leaf's spectra. PROSPECT from pigments, the
//! directional-hemispherical R and T that the renderer's BSDF gives, and a leaf fitted to
//! measured spectra. The science is in `lamina-leaf`; this file reads flags and writes files.

use crate::output_file::claim;
use anyhow::{Context, bail};
use lamina_leaf::prospect::{LeafSpectrum, PROSPECT_LEN};
use lamina_leaf::{Pigments, ProspectModel, prospect};
use std::io::Write;
use std::path::{Path, PathBuf};

/// PROSPECT's inputs on the command line. Every flag is optional: the defaults are a typical
/// green dicot leaf ([`Pigments::default`]); `--model pro` replaces `--cm` by `--prot` and
/// `--cbc`.
#[derive(clap::Args, Debug, Clone)]
pub struct PigmentArgs {
    /// Structure parameter N (number of elementary plates), 1-3.5.
    #[arg(long)]
    pub n: Option<f64>,
    /// Chlorophyll a+b, µg/cm².
    #[arg(long)]
    pub cab: Option<f64>,
    /// Carotenoids, µg/cm².
    #[arg(long)]
    pub car: Option<f64>,
    /// Anthocyanins, µg/cm².
    #[arg(long)]
    pub anth: Option<f64>,
    /// Brown pigments, arbitrary units (0-2).
    #[arg(long)]
    pub cbrown: Option<f64>,
    /// Equivalent water thickness, cm.
    #[arg(long)]
    pub cw: Option<f64>,
    /// Dry matter (leaf mass per area), g/cm² (PROSPECT-D only).
    #[arg(long)]
    pub cm: Option<f64>,
    /// Which model: d (PROSPECT-D, 2017) or pro (PROSPECT-PRO, 2021).
    #[arg(long, default_value = "d", value_parser = parse_model)]
    pub model: ProspectModel,
    /// Proteins, g/cm² (PROSPECT-PRO only) [default: 0.0012].
    #[arg(long)]
    pub prot: Option<f64>,
    /// Carbon-based constituents, g/cm² (PROSPECT-PRO only) [default: 0.0078].
    #[arg(long)]
    pub cbc: Option<f64>,
}

fn parse_model(s: &str) -> Result<ProspectModel, String> {
    match s.to_ascii_lowercase().as_str() {
        "d" | "prospect-d" => Ok(ProspectModel::D),
        "pro" | "prospect-pro" => Ok(ProspectModel::Pro),
        _ => Err(format!("unknown PROSPECT model '{s}': use d or pro")),
    }
}

impl PigmentArgs {
    /// The pigments the flags describe, checked against their published ranges; errors name
    /// the flag.
    pub fn pigments(&self) -> anyhow::Result<Pigments> {
        let d = Pigments::default();
        let mut p = Pigments {
            n: self.n.unwrap_or(d.n),
            cab: self.cab.unwrap_or(d.cab),
            car: self.car.unwrap_or(d.car),
            anth: self.anth.unwrap_or(d.anth),
            cbrown: self.cbrown.unwrap_or(d.cbrown),
            cw: self.cw.unwrap_or(d.cw),
            cm: self.cm.unwrap_or(d.cm),
            prot: 0.0,
            cbc: 0.0,
        };
        match self.model {
            ProspectModel::D => {
                for (flag, v) in [("--prot", self.prot), ("--cbc", self.cbc)] {
                    if v.is_some() {
                        bail!("{flag} is a PROSPECT-PRO input: add --model pro (and drop --cm)");
                    }
                }
            }
            ProspectModel::Pro => {
                if self.cm.is_some() {
                    bail!(
                        "--cm is PROSPECT-D's dry matter; PROSPECT-PRO splits it into --prot and \
                         --cbc (cm = prot + cbc)"
                    );
                }
                p.cm = 0.0;
                p.prot = self.prot.unwrap_or(0.0012);
                p.cbc = self.cbc.unwrap_or(0.0078);
                if p.prot == 0.0 && p.cbc == 0.0 {
                    bail!("--model pro needs --prot or --cbc above 0 (they are its dry matter)");
                }
            }
        }
        p.validate("--")?;
        Ok(p)
    }
}

/// Describes the pigments in one line (for file headers and messages).
pub fn describe(p: &Pigments) -> String {
    let mut s = format!(
        "{} N={} cab={} car={} anth={} cbrown={} cw={}",
        p.model(),
        p.n,
        p.cab,
        p.car,
        p.anth,
        p.cbrown,
        p.cw
    );
    match p.model() {
        ProspectModel::D => s += &format!(" cm={}", p.cm),
        ProspectModel::Pro => s += &format!(" prot={} cbc={}", p.prot, p.cbc),
    }
    s
}

/// Writes a spectrum CSV (`wavelength_nm,reflectance,transmittance`) atomically, with
/// lamina's mark and `detail` on its first line.
pub fn write_spectrum_csv(
    path: &Path,
    detail: &str,
    rows: impl Iterator<Item = (f64, f64, f64)>,
) -> anyhow::Result<()> {
    let rows: Vec<_> = rows.collect();
    lamina_io::write_file(path, |w| {
        writeln!(w, "{}", lamina_io::text_mark_line(detail))?;
        writeln!(w, "wavelength_nm,reflectance,transmittance")?;
        for (nm, r, t) in &rows {
            writeln!(w, "{nm},{r:.6},{t:.6}")?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Mean of `v` over the grid wavelengths in `[lo, hi]` nm.
fn band_mean(v: &[f64], lo: u32, hi: u32) -> f64 {
    let i0 = (lo - 400) as usize;
    let i1 = (hi - 400) as usize;
    v[i0..=i1].iter().sum::<f64>() / (i1 - i0 + 1) as f64
}

/// The band means a user checks a leaf spectrum by, printed as `name R T` rows.
pub fn print_band_means(r: &[f64], t: &[f64]) {
    for (name, lo, hi) in BANDS {
        eprintln!(
            "  {name:<22} R {:.4}  T {:.4}",
            band_mean(r, lo, hi),
            band_mean(t, lo, hi)
        );
    }
}

/// The bands of the fit goal (and of most leaf papers), nm.
pub const BANDS: [(&str, u32, u32); 5] = [
    ("blue 450-500 nm", 450, 500),
    ("green 500-570 nm", 500, 570),
    ("red 620-700 nm", 620, 700),
    ("NIR 800-900 nm", 800, 900),
    ("SWIR 1550-1750 nm", 1550, 1750),
];

/// `lamina leaf prospect`.
pub fn run_prospect(args: &PigmentArgs, out: &PathBuf, force: bool) -> anyhow::Result<()> {
    let p = args.pigments()?;
    claim(out, force, &[])?;
    let s: LeafSpectrum = prospect(&p);
    let detail = describe(&p);
    claim(out, force, &[])?;
    write_spectrum_csv(
        out,
        &detail,
        (0..PROSPECT_LEN).map(|i| (LeafSpectrum::wavelength(i), s.r[i], s.t[i])),
    )
    .with_context(|| format!("writing '{}'", out.display()))?;
    eprintln!("wrote {} ({detail}, 400-2500 nm at 1 nm)", out.display());
    print_band_means(&s.r, &s.t);
    Ok(())
}
