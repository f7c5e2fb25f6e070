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
    /// PROSPECT's surface parameter: the top face's incidence cone, degrees (10-90; the
    /// standard model uses 40).
    #[arg(long)]
    pub alpha: Option<f64>,
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
        let inputs = lamina_leaf::PigmentInputs {
            model: self.model,
            n: self.n,
            cab: self.cab,
            car: self.car,
            anth: self.anth,
            cbrown: self.cbrown,
            cw: self.cw,
            cm: self.cm,
            prot: self.prot,
            cbc: self.cbc,
            alpha: self.alpha,
        };
        Ok(inputs.resolve("--", "--model pro")?)
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
    if p.alpha != Pigments::default().alpha {
        s += &format!(" alpha={}", p.alpha);
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

/// The band means a user checks a leaf spectrum by (those of the fit goal and of most leaf
/// papers, `lamina_leaf::fit::FIT_BANDS`), of a spectrum on PROSPECT's 1 nm grid, printed as
/// `name R T` rows.
pub fn print_band_means(r: &[f64], t: &[f64]) {
    use lamina_leaf::fit::{FIT_BANDS, band_means};
    let nm: Vec<f64> = (0..r.len()).map(LeafSpectrum::wavelength).collect();
    let (mr, mt) = (band_means(&nm, r), band_means(&nm, t));
    for (k, (name, _, _)) in FIT_BANDS.iter().enumerate() {
        eprintln!(
            "  {name:<22} R {:.4}  T {:.4}",
            mr[k].unwrap_or(f64::NAN),
            mt[k].unwrap_or(f64::NAN)
        );
    }
}

/// `lamina leaf prospect`.
pub fn run_prospect(args: &PigmentArgs, out: &Path, force: bool) -> anyhow::Result<()> {
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

/// A leaf `lamina leaf albedo` integrates: an RGB leaf (three channels) or a pigment leaf
/// (any wavelength).
pub enum LoadedLeaf {
    /// Colours from RGB maps or parameters.
    Rgb(Box<lamina_leaf::LeafMaterial>),
    /// Colours from PROSPECT pigments.
    Pigment(Box<lamina_leaf::PigmentLeaf>),
}

/// Loads a leaf folder (or its `leaf.toml`) or generates a species preset; errors name the
/// file or the species.
pub fn load_leaf(
    leaf: Option<&Path>,
    species: Option<lamina_leafmaps::Species>,
) -> anyhow::Result<LoadedLeaf> {
    use lamina_leaf::{LeafDescription, LeafMaps, LeafMaterial, PigmentLeaf};
    match (leaf, species) {
        (Some(path), None) => {
            let file = if path.is_dir() {
                path.join("leaf.toml")
            } else {
                path.to_owned()
            };
            let dir = file.parent().unwrap_or(Path::new("")).to_owned();
            let desc = LeafDescription::from_toml_file(&file)?;
            let maps = LeafMaps::load(&desc.maps, &dir)?;
            Ok(match desc.pigments {
                Some(p) => LoadedLeaf::Pigment(Box::new(
                    PigmentLeaf::new(p, desc.params, maps)
                        .with_context(|| format!("leaf '{}'", file.display()))?,
                )),
                None => LoadedLeaf::Rgb(Box::new(
                    LeafMaterial::new(maps, desc.params)
                        .with_context(|| format!("leaf '{}'", file.display()))?,
                )),
            })
        }
        (None, Some(s)) => {
            let g = lamina_leafmaps::generate(&lamina_leafmaps::LeafSpec::new(s, 1, 256));
            Ok(LoadedLeaf::Rgb(Box::new(
                LeafMaterial::new(g.maps, g.params).with_context(|| format!("species {s}"))?,
            )))
        }
        (Some(_), Some(_)) => bail!("give a leaf folder or --species, not both"),
        (None, None) => bail!("give a leaf folder (holding leaf.toml) or --species NAME"),
    }
}

/// Wavelengths in nm, from `--wavelengths A:B:STEP`.
#[derive(Clone, Debug)]
pub struct Wavelengths(pub Vec<f32>);

/// Parses `A:B:STEP` (nm) into the wavelengths `A, A + STEP, ... <= B`, inside 400-2500 nm.
pub fn parse_wavelengths(s: &str) -> Result<Wavelengths, String> {
    wavelength_grid(s, (400.0, 2500.0), "PROSPECT covers", 2101).map(Wavelengths)
}

/// `--wavelengths A:B:STEP` (nm) as the wavelengths `A, A + STEP, ... <= B`, with `A` and
/// `B` inside `range` (the errors say "`covers` LO-HI nm") and at most `max` of them.
pub fn wavelength_grid(
    s: &str,
    range: (f32, f32),
    covers: &str,
    max: usize,
) -> Result<Vec<f32>, String> {
    let parts: Vec<&str> = s.split(':').collect();
    let bad = || format!("--wavelengths '{s}': expected FIRST:LAST:STEP in nm, e.g. 400:2500:10");
    if parts.len() != 3 {
        return Err(bad());
    }
    let v: Vec<f32> = parts
        .iter()
        .map(|p| p.trim().parse::<f32>().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    let (a, b, step) = (v[0], v[1], v[2]);
    if !(a.is_finite() && b.is_finite() && step.is_finite()) || step <= 0.0 || b < a {
        return Err(format!(
            "--wavelengths '{s}': need FIRST <= LAST and STEP > 0"
        ));
    }
    if a < range.0 || b > range.1 {
        return Err(format!(
            "--wavelengths '{s}': {covers} {}-{} nm; keep FIRST and LAST inside it",
            range.0, range.1
        ));
    }
    let n = ((b - a) / step).floor() as usize + 1;
    if n > max {
        return Err(format!(
            "--wavelengths '{s}': {n} wavelengths; at most {max}"
        ));
    }
    Ok((0..n).map(|k| a + k as f32 * step).collect())
}

/// `(nm, R, T)` of a pigment leaf at `nodes`, three wavelengths per material, in parallel.
pub fn pigment_albedo(
    leaf: &lamina_leaf::PigmentLeaf,
    nodes: &[f32],
    opts: &lamina_leaf::albedo::AlbedoOptions,
) -> anyhow::Result<Vec<(f32, f32, f32)>> {
    use rayon::prelude::*;
    let triples: Vec<&[f32]> = nodes.chunks(3).collect();
    let parts: Vec<Vec<(f32, f32, f32)>> = triples
        .par_iter()
        .map(|triple| {
            let nm = [0, 1, 2].map(|k| triple[k.min(triple.len() - 1)]);
            let m = leaf.material(nm)?;
            let (r, t) = lamina_leaf::albedo::directional_albedo(&m, opts);
            Ok(triple
                .iter()
                .enumerate()
                .map(|(k, &l)| (l, r[k], t[k]))
                .collect())
        })
        .collect::<Result<_, lamina_leaf::LeafError>>()?;
    Ok(parts.into_iter().flatten().collect())
}

/// `lamina leaf albedo`'s flags.
#[derive(clap::Args, Debug)]
pub struct AlbedoArgs {
    /// Leaf folder (holding leaf.toml) or a leaf.toml file.
    pub leaf: Option<PathBuf>,
    /// A built-in species instead of a folder (seed 1, 256 px maps).
    #[arg(long, value_parser = parse_species)]
    pub species: Option<lamina_leafmaps::Species>,
    /// Incidence angle of the light from the leaf normal, degrees (0-89).
    #[arg(long, default_value_t = 8.0)]
    pub theta: f32,
    /// Which side the light comes from: adaxial (upper) or abaxial (lower).
    #[arg(long, default_value = "adaxial")]
    pub side: lamina_leaf::albedo::Side,
    /// Wavelengths FIRST:LAST:STEP, nm (a pigment leaf only) [default: 400:2500:10].
    #[arg(long, value_parser = parse_wavelengths)]
    pub wavelengths: Option<Wavelengths>,
    /// Direction samples in all (split over up to 1024 opaque texels).
    #[arg(long, default_value_t = 1 << 16)]
    pub samples: u32,
    /// Output CSV `wavelength_nm,reflectance,transmittance` (atomic; replaces only a file
    /// lamina wrote, see --force).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Replace an output file lamina did not write.
    #[arg(long)]
    pub force: bool,
}

fn parse_species(s: &str) -> Result<lamina_leafmaps::Species, String> {
    s.parse()
        .map_err(|e: lamina_leafmaps::UnknownSpecies| e.to_string())
}

/// `lamina leaf albedo`.
pub fn run_albedo(a: &AlbedoArgs) -> anyhow::Result<()> {
    use lamina_leaf::albedo::{AlbedoOptions, directional_albedo};
    if !(0.0..=89.0).contains(&a.theta) {
        bail!(
            "--theta {}: the incidence angle must be in [0, 89] degrees",
            a.theta
        );
    }
    let inputs: Vec<PathBuf> = a.leaf.iter().cloned().collect();
    claim(&a.out, a.force, &inputs)?;
    let t0 = std::time::Instant::now();
    let leaf = load_leaf(a.leaf.as_deref(), a.species)?;
    let opts = AlbedoOptions {
        theta_deg: a.theta,
        side: a.side,
        samples: a.samples.max(64),
        ..AlbedoOptions::default()
    };
    let side = format!("{:?}", a.side).to_lowercase();
    let (rows, detail) = match &leaf {
        LoadedLeaf::Rgb(m) => {
            if a.wavelengths.is_some() {
                bail!(
                    "--wavelengths applies to a leaf described by pigments; an RGB leaf has \
                     three channels (written at their nominal wavelengths)"
                );
            }
            let (r, t) = directional_albedo(m, &opts);
            let nm = lamina_leaf::spectrum::REC709_NOMINAL_NM;
            // Ascending wavelength: blue, green, red.
            let rows: Vec<(f32, f32, f32)> = [2usize, 1, 0]
                .iter()
                .map(|&c| (nm[c], r[c], t[c]))
                .collect();
            (
                rows,
                format!(
                    "RGB leaf, light at {} deg on the {side} side; rows are the linear Rec.709 \
                     channels blue, green, red at their nominal wavelengths",
                    a.theta
                ),
            )
        }
        LoadedLeaf::Pigment(p) => {
            let nodes = a
                .wavelengths
                .clone()
                .map(|w| w.0)
                .unwrap_or_else(|| (0..=210).map(|k| 400.0 + 10.0 * k as f32).collect());
            (
                pigment_albedo(p, &nodes, &opts)?,
                format!(
                    "pigment leaf ({}), light at {} deg on the {side} side",
                    describe(p.pigments()),
                    a.theta
                ),
            )
        }
    };
    claim(&a.out, a.force, &inputs)?;
    write_spectrum_csv(
        &a.out,
        &detail,
        rows.iter().map(|&(l, r, t)| (l as f64, r as f64, t as f64)),
    )
    .with_context(|| format!("writing '{}'", a.out.display()))?;
    eprintln!(
        "wrote {} ({} rows, {detail}) in {:.1} s",
        a.out.display(),
        rows.len(),
        t0.elapsed().as_secs_f64()
    );
    if rows.len() <= 3 {
        for (l, r, t) in &rows {
            eprintln!("  {l} nm  R {r:.4}  T {t:.4}");
        }
    }
    Ok(())
}

/// `lamina leaf fit`'s flags.
#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// Measured spectrum: columns wavelength (nm), R[, T], separated by commas or
    /// whitespace, an optional header line, any sampling inside 400-2500 nm.
    #[arg(long)]
    pub spectrum: PathBuf,
    /// Output leaf folder: leaf.toml (the fitted pigments), fit.csv and fit.png. An existing
    /// one is replaced only if lamina wrote it; see --force.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Write into a folder lamina did not write (replacing only leaf.toml, fit.csv and
    /// fit.png, keeping every other file).
    #[arg(long)]
    pub force: bool,
    /// How much the band means (blue 450-500, green 500-570, red 620-700, NIR 800-900, SWIR
    /// 1550-1750 nm) weigh: each band mean's error counts W times its band's width of
    /// spectrum. 0 fits per nanometre alone (the lowest RMSE; band means may be 0.01-0.03 off).
    #[arg(long, value_name = "W", default_value_t = lamina_leaf::fit::BAND_WEIGHT,
          value_parser = parse_band_weight, allow_hyphen_values = true)]
    pub band_weight: f64,
}

/// `--band-weight`: a number from 0 to 1000.
fn parse_band_weight(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(w) if (0.0..=1000.0).contains(&w) => Ok(w),
        _ => Err(format!("'{s}' is not a weight from 0 to 1000")),
    }
}

/// `x` rounded to four significant digits.
fn round4(x: f64) -> f64 {
    // Below 1e-6 every input is zero for the model (and the fit's bound).
    if x.abs() < 1e-6 || !x.is_finite() {
        return if x.is_finite() { 0.0 } else { x };
    }
    let scale = 10f64.powi(3 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

fn owns_fit_file(name: &str) -> bool {
    matches!(name, "leaf.toml" | "fit.csv" | "fit.png")
}

/// A PROSPECT fit with its pigments rounded to four significant digits (far below what a
/// measurement resolves) and the rendered leaf's R and T at `m`'s samples: the BSDF's
/// directional-hemispherical R and T at 8°, integrated as `lamina leaf albedo` does, at the
/// measured wavelengths (or every 5 nm and interpolated, for densely sampled spectra).
fn rendered_fit(
    mut fit: lamina_leaf::fit::ProspectFit,
    m: &lamina_leaf::measured::MeasuredSpectrum,
) -> anyhow::Result<(lamina_leaf::fit::ProspectFit, Vec<f64>, Vec<f64>)> {
    use lamina_leaf::albedo::AlbedoOptions;
    use lamina_leaf::{LeafMaps, LeafParams, PigmentLeaf};
    fit.pigments = Pigments::from_values(fit.pigments.values().map(round4));
    let leaf = PigmentLeaf::new(fit.pigments, LeafParams::default(), LeafMaps::default())?;
    let lo = m.nm[0] as f32;
    let hi = m.nm[m.nm.len() - 1] as f32;
    let nodes: Vec<f32> = if m.nm.len() <= 450 {
        m.nm.iter().map(|&l| l as f32).collect()
    } else {
        let n = ((hi - lo) / 5.0).ceil() as usize;
        (0..=n).map(|k| (lo + 5.0 * k as f32).min(hi)).collect()
    };
    let nodes = {
        let mut v = nodes;
        v.dedup();
        v
    };
    let albedo = pigment_albedo(&leaf, &nodes, &AlbedoOptions::default())?;
    let interp = |l: f64, pick: fn(&(f32, f32, f32)) -> f32| -> f64 {
        let i = albedo.partition_point(|x| (x.0 as f64) < l);
        if i == 0 {
            return pick(&albedo[0]) as f64;
        }
        if i >= albedo.len() {
            return pick(&albedo[albedo.len() - 1]) as f64;
        }
        let (a0, a1) = (&albedo[i - 1], &albedo[i]);
        let f = (l - a0.0 as f64) / (a1.0 as f64 - a0.0 as f64);
        pick(a0) as f64 + f * (pick(a1) as f64 - pick(a0) as f64)
    };
    let model_r = m.nm.iter().map(|&l| interp(l, |x| x.1)).collect();
    let model_t = m.nm.iter().map(|&l| interp(l, |x| x.2)).collect();
    Ok((fit, model_r, model_t))
}

/// `lamina leaf fit`.
pub fn run_fit(a: &FitArgs) -> anyhow::Result<()> {
    use lamina_leaf::LeafDescription;
    use lamina_leaf::fit::{FitOptions, fit_prospect_with};
    use lamina_leaf::measured::MeasuredSpectrum;
    let inputs = vec![a.spectrum.clone()];
    let spec = lamina_io::FolderSpec {
        kind: "leaf folder",
        owns: &owns_fit_file,
        marker: "leaf.toml",
        is_marked: &lamina_leafmaps::written_by_lamina,
        inputs: &inputs,
    };
    let mode = crate::output_file::replace_mode(a.force);
    lamina_io::check_folder(&a.out, &spec, mode)
        .with_context(|| format!("writing leaf folder '{}'", a.out.display()))?;
    let t0 = std::time::Instant::now();
    let m = MeasuredSpectrum::read(&a.spectrum)?;
    if m.dropped > 0 {
        eprintln!(
            "warning: {} sample(s) outside 400-2500 nm ignored",
            m.dropped
        );
    }
    if m.t.is_none() {
        eprintln!(
            "warning: '{}' has no transmittance column: fitting reflectance only; T is predicted by PROSPECT, not fitted",
            a.spectrum.display()
        );
    }
    let fit = fit_prospect_with(
        &m,
        &FitOptions {
            band_weight: a.band_weight,
        },
    );
    let t_fit = t0.elapsed().as_secs_f64();
    let (fit, model_r, model_t) = rendered_fit(fit, &m)?;
    let rmse = |a: &[f64], b: &[f64]| {
        (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
    };
    let rmse_r = rmse(&model_r, &m.r);
    let rmse_t = m.t.as_ref().map(|t| rmse(&model_t, t));

    // Write the folder: leaf.toml, fit.csv, fit.png.
    let staged = lamina_io::stage(&a.out, &spec, mode)
        .with_context(|| format!("writing leaf folder '{}'", a.out.display()))?;
    let dir = staged.path().to_owned();
    let desc = LeafDescription {
        generator: Some(format!("{} (leaf fit)", lamina_io::GENERATOR)),
        pigments: Some(fit.pigments),
        ..LeafDescription::default()
    };
    let mut toml_text = format!(
        "# Fitted by `lamina leaf fit --spectrum {}` (PROSPECT-D inversion, then the\n\
         # layered leaf model calibrated to it; see lamina-leaf's README, \"Pigment leaves\").\n\
         # RMSE of the rendered leaf's R and T at 8 deg against the measurement: R {rmse_r:.4}{}\n\
         # [params] are the default leaf's; with [pigments] their absorption is replaced by the\n\
         # pigments' (the rest, scattering, thickness, roughness..., is kept).\n",
        a.spectrum.display(),
        rmse_t.map_or(" (T not measured)".to_string(), |t| format!(", T {t:.4}"))
    );
    toml_text.push_str(&toml::to_string(&desc).context("leaf.toml")?);
    std::fs::write(dir.join("leaf.toml"), toml_text).context("writing leaf.toml")?;
    let mut csv = format!(
        "{}\nwavelength_nm,measured_r,measured_t,model_r,model_t\n",
        lamina_io::text_mark_line(&format!("leaf fit of {}", a.spectrum.display()))
    );
    for i in 0..m.nm.len() {
        let mt =
            m.t.as_ref()
                .map_or(String::new(), |t| format!("{:.6}", t[i]));
        csv += &format!(
            "{},{:.6},{mt},{:.6},{:.6}\n",
            m.nm[i], m.r[i], model_r[i], model_t[i]
        );
    }
    std::fs::write(dir.join("fit.csv"), csv).context("writing fit.csv")?;
    let pts =
        |v: &[f64]| -> Vec<(f64, f64)> { m.nm.iter().copied().zip(v.iter().copied()).collect() };
    let mut series = vec![
        crate::chart::Series {
            points: pts(&m.r),
            colour: [20, 140, 40],
            dotted: true,
            label: "MEASURED R",
            errors: Vec::new(),
        },
        crate::chart::Series {
            points: pts(&model_r),
            colour: [20, 140, 40],
            dotted: false,
            label: "MODEL R",
            errors: Vec::new(),
        },
    ];
    if let Some(t) = &m.t {
        series.push(crate::chart::Series {
            points: pts(t),
            colour: [30, 80, 220],
            dotted: true,
            label: "MEASURED T",
            errors: Vec::new(),
        });
    }
    series.push(crate::chart::Series {
        points: pts(&model_t),
        colour: [30, 80, 220],
        dotted: false,
        label: if m.t.is_some() {
            "MODEL T"
        } else {
            "MODEL T (PREDICTED)"
        },
        errors: Vec::new(),
    });
    let title = format!(
        "LEAF FIT: RMSE R {rmse_r:.4}{}",
        rmse_t.map_or(String::new(), |t| format!("  T {t:.4}"))
    );
    let img = crate::chart::draw(
        &crate::chart::Chart {
            x: (400.0, 2500.0),
            y: (0.0, 1.0),
            ticks: (200.0, 0.1),
            x_title: "WAVELENGTH (NM)",
            title: &title,
        },
        &series,
    );
    let png = lamina_io::image_out::encode(
        Path::new("fit.png"),
        img.as_raw(),
        img.width(),
        img.height(),
        image::ExtendedColorType::Rgb8,
    )
    .context("encoding fit.png")?;
    std::fs::write(dir.join("fit.png"), png).context("writing fit.png")?;
    for name in ["leaf.toml", "fit.csv", "fit.png"] {
        std::fs::File::open(dir.join(name))
            .and_then(|f| f.sync_all())
            .with_context(|| format!("writing {name}"))?;
    }
    let out = staged
        .commit(&spec)
        .with_context(|| format!("writing leaf folder '{}'", a.out.display()))?;

    eprintln!(
        "wrote {} (leaf.toml, fit.csv, fit.png) in {:.1} s (PROSPECT fit {:.2} s, {} iterations)",
        out.display(),
        t0.elapsed().as_secs_f64(),
        t_fit,
        fit.iterations
    );
    eprintln!("  pigments: {}", describe(&fit.pigments));
    eprintln!(
        "  RMSE over {} samples: R {rmse_r:.4}{}   (PROSPECT alone: R {:.4}{})",
        m.nm.len(),
        rmse_t.map_or("  T not measured".to_string(), |t| format!("  T {t:.4}")),
        fit.rmse_r,
        fit.rmse_t.map_or(String::new(), |t| format!("  T {t:.4}"))
    );
    eprintln!("  band means (measured -> model, error):");
    let bm = |v: &[f64]| lamina_leaf::fit::band_means(&m.nm, v);
    let (mr, gr) = (bm(&m.r), bm(&model_r));
    let mt = m.t.as_ref().map(|t| (bm(t), bm(&model_t)));
    for (k, (name, _, _)) in lamina_leaf::fit::FIT_BANDS.iter().enumerate() {
        let (Some(mr), Some(gr)) = (mr[k], gr[k]) else {
            eprintln!("    {name:<20} no samples");
            continue;
        };
        let t_part = mt.map_or(String::new(), |(mt, gt)| {
            let (mt, gt) = (mt[k].unwrap_or(0.0), gt[k].unwrap_or(0.0));
            format!("   T {mt:.4} -> {gt:.4} ({:+.4})", gt - mt)
        });
        eprintln!(
            "    {name:<20} R {mr:.4} -> {gr:.4} ({:+.4}){t_part}",
            gr - mr
        );
    }
    Ok(())
}
