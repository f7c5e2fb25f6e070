//! `lamina sky`: the sun and clear sky for a place and a time. Prints the sun's position and
//! the clear-sky spectrum's direct/diffuse split per band (SPCTRAL2), the sun's irradiance as
//! a scene light would take it, and writes the sky (Preetham) as an equirectangular EXR that a
//! scene's `[sky] type = "image"` uses. The models are in `lamina-sky`.

use crate::output_file::claim;
use anyhow::{Context, bail};
use std::path::PathBuf;

/// `lamina sky`'s flags.
#[derive(clap::Args, Debug)]
pub struct SkyArgs {
    /// Latitude, degrees, north positive.
    #[arg(long, allow_hyphen_values = true)]
    pub latitude: f64,
    /// Longitude, degrees, east positive.
    #[arg(long, allow_hyphen_values = true)]
    pub longitude: f64,
    /// Local date and time with its UTC offset, ISO 8601 (e.g. 2024-06-21T14:30:00+02:00).
    #[arg(long)]
    pub time: String,
    /// Height above sea level, m (sets the air pressure by the barometric formula unless
    /// --pressure is given).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub elevation: f64,
    /// Surface air pressure, hPa, for refraction and the spectrum [default: from
    /// --elevation, standard atmosphere].
    #[arg(long)]
    pub pressure: Option<f64>,
    /// Linke-style turbidity of the Preetham sky (1.7 very clear to 10 hazy).
    #[arg(long, default_value_t = 3.0)]
    pub turbidity: f64,
    /// Aerosol optical depth at 500 nm (SPCTRAL2).
    #[arg(long, default_value_t = 0.1)]
    pub aod: f64,
    /// Precipitable water, cm (SPCTRAL2).
    #[arg(long, default_value_t = 1.42)]
    pub water: f64,
    /// Total ozone, atm-cm (SPCTRAL2).
    #[arg(long, default_value_t = 0.344)]
    pub ozone: f64,
    /// Ground albedo (SPCTRAL2's ground-sky reflections).
    #[arg(long, default_value_t = 0.2)]
    pub ground_albedo: f64,
    /// Width of the sky image, pixels (height is half).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(16..=16384))]
    pub width: u32,
    /// Output sky image (.exr, linear radiance W m⁻² sr⁻¹ in linear Rec.709 with Y = ∫ L ȳ dλ).
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Also write the sun's spectrum at the ground as CSV
    /// `wavelength_nm,direct_normal,direct_horizontal,diffuse_horizontal` (W m⁻² nm⁻¹, 5 nm).
    #[arg(long)]
    pub spectrum: Option<PathBuf>,
    /// Replace output files lamina did not write.
    #[arg(long)]
    pub force: bool,
}

/// Bands the split is printed for, nm.
const BANDS: [(&str, f64, f64); 8] = [
    ("UV 300-400 nm", 300.0, 400.0),
    ("blue 400-500 nm", 400.0, 500.0),
    ("green 500-600 nm", 500.0, 600.0),
    ("red 600-700 nm", 600.0, 700.0),
    ("PAR 400-700 nm", 400.0, 700.0),
    ("NIR 700-1300 nm", 700.0, 1300.0),
    ("SWIR 1300-2500 nm", 1300.0, 2500.0),
    ("all 300-4000 nm", 300.0, 4000.0),
];

/// `lamina sky`.
pub fn run(a: &SkyArgs) -> anyhow::Result<()> {
    use lamina_sky::{Observer, UniformGrid};
    for p in a.out.iter().chain(a.spectrum.iter()) {
        claim(p, a.force, &[])?;
    }
    if let Some(o) = &a.out
        && !o.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
    {
        bail!(
            "-o '{}': the sky image is linear radiance: name an .exr file",
            o.display()
        );
    }
    let time = lamina_sky::parse_local_time(&a.time).map_err(|m| anyhow::anyhow!("--time: {m}"))?;
    let observer = Observer {
        latitude: a.latitude,
        longitude: a.longitude,
        elevation: a.elevation,
    };
    // One model of the sun and sky, as `[sky] type = "sunsky"` makes them: SPA, SPCTRAL2
    // and Preetham, with one air pressure for refraction and for the spectrum.
    let mut params = lamina_sky::SunSkyParams::new(observer, time);
    params.turbidity = a.turbidity;
    params.aod500 = a.aod;
    params.water = a.water;
    params.ozone = a.ozone;
    params.ground_albedo = a.ground_albedo;
    params.pressure = a.pressure;
    let model = lamina_sky::SunSky::new(&params).map_err(|e| {
        let flag = match e.field {
            "aod500" => "aod",
            "precipitable_water" => "water",
            f => f,
        };
        anyhow::anyhow!("--{}: {e}", flag.replace('_', "-"))
    })?;
    let sun = model.sun();
    eprintln!(
        "sun at {:.4}° N {:.4}° E, {}: zenith {:.3}° (apparent; geometric {:.3}°), azimuth {:.3}° \
         (clockwise from north), elevation {:.3}°",
        a.latitude,
        a.longitude,
        a.time,
        sun.zenith,
        sun.geometric_zenith,
        sun.azimuth,
        sun.elevation()
    );
    let d = sun.direction;
    eprintln!(
        "  direction toward the sun (x east, y up, z south): [{:.5}, {:.5}, {:.5}]",
        d.x, d.y, d.z
    );

    // The solar spectrum at the ground.
    let s = model.spectral2();
    eprintln!(
        "clear-sky irradiance (SPCTRAL2, AOD500 {}, water {} cm, ozone {} atm-cm, {:.1} hPa, air mass {:.3}), W/m²:",
        a.aod,
        a.water,
        a.ozone,
        model.pressure(),
        s.relative_air_mass
    );
    eprintln!(
        "  {:<18} {:>10} {:>11} {:>11} {:>9}",
        "band", "direct ⟂", "direct hor.", "diffuse hor.", "diffuse %"
    );
    for (name, lo, hi) in BANDS {
        let b = s.band(lo, hi).map_err(|e| anyhow::anyhow!("{e}"))?;
        eprintln!(
            "  {name:<18} {:>10.2} {:>11.2} {:>11.2} {:>8.1} %",
            b.direct_normal,
            b.direct_horizontal,
            b.diffuse_horizontal,
            100.0 * b.diffuse_fraction()
        );
    }
    // The sun as an RGB light: the direct normal spectrum through the CIE observer,
    // Y = ∫ E ȳ dλ.
    let rgb = model.sun_rgb();
    eprintln!(
        "  the sun for a scene: type = \"sun\", position = {{ latitude = {}, longitude = {}, time = \"{}\" }}, \
         irradiance = [{:.2}, {:.2}, {:.2}]",
        a.latitude, a.longitude, a.time, rgb.x, rgb.y, rgb.z
    );

    if let Some(path) = &a.spectrum {
        let grid = UniformGrid::new(300.0, 4000.0, 5.0).map_err(|e| anyhow::anyhow!("{e}"))?;
        let r = s.resample(&grid);
        claim(path, a.force, &[])?;
        lamina_io::write_file(path, |w| {
            use std::io::Write;
            writeln!(
                w,
                "{}",
                lamina_io::text_mark_line(&format!(
                    "SPCTRAL2 clear sky at {} {} {}",
                    a.latitude, a.longitude, a.time
                ))
            )?;
            writeln!(
                w,
                "wavelength_nm,direct_normal,direct_horizontal,diffuse_horizontal"
            )?;
            for (i, nm) in grid.wavelengths().enumerate() {
                writeln!(
                    w,
                    "{nm},{:.6},{:.6},{:.6}",
                    r.direct_normal[i], r.direct_horizontal[i], r.diffuse_horizontal[i]
                )?;
            }
            Ok(())
        })
        .with_context(|| format!("writing '{}'", path.display()))?;
        eprintln!("wrote {}", path.display());
    }

    if let Some(path) = &a.out {
        // Preetham gives the sky's shape and colour; its level is put on SPCTRAL2's diffuse
        // horizontal irradiance (the same ȳ weighting), so that sun and sky come from one
        // atmosphere. The frame is lamina-sky's (x east, y up, z south): a scene's default.
        let (w, h) = (a.width, (a.width / 2).max(1));
        let px = lamina_sky::sunsky::bake_map(w, |d| d, |d| model.sky_rgb(d).as_vec3().to_array());
        let mut img = image::Rgb32FImage::new(w, h);
        for (k, c) in px.iter().enumerate() {
            img.put_pixel(k as u32 % w, k as u32 / w, image::Rgb(*c));
        }
        claim(path, a.force, &[])?;
        lamina_io::save_image(path, &img)
            .with_context(|| format!("writing '{}'", path.display()))?;
        eprintln!(
            "wrote {} ({w}x{h}): the Preetham sky (turbidity {}) at SPCTRAL2's diffuse \
             horizontal irradiance ({:.2} W/m², ȳ-weighted); use it as [sky] type = \"image\", \
             file = \"{}\" (or [sky] type = \"sunsky\" with the same position, which also \
             renders it spectrally)",
            path.display(),
            a.turbidity,
            model.diffuse_y(),
            path.display()
        );
    }
    Ok(())
}
