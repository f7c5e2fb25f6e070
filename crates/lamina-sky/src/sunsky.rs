//! A physical sun and clear sky for one place and time, from one atmosphere: the sun's
//! position from NREL's SPA ([`crate::solar_position`]), its spectral irradiance at the
//! ground and the sky's diffuse irradiance from SPCTRAL2 ([`crate::spectral2`]), and the
//! sky's distribution over directions from Preetham ([`crate::preetham`]).
//!
//! * **Sun**: the direct normal spectral irradiance `E_sun(λ)` (W m⁻² nm⁻¹), 300-4000 nm.
//!   In RGB, `E_sun` through the CIE 1931 observer into linear Rec.709 with `Y = ∫ E ȳ dλ`
//!   (lamina's RGB convention).
//! * **Sky**: Preetham's radiance `L_P(ω)` gives the shape and colour; its level is set so
//!   that the sky's horizontal irradiance equals SPCTRAL2's diffuse horizontal irradiance
//!   (ȳ-weighted): `L = s L_P` with `s = ∫ E_diff ȳ dλ / ∫ Y_P(ω) cos θ dω`. Spectrally,
//!   over 360-830 nm, the CIE daylight spectrum of Preetham's chromaticity at each
//!   direction (scaled by `s`); beyond 830 nm, where the daylight basis ends,
//!   `s Y_P(ω) E_diff(λ) / ∫ E_diff ȳ dλ`: SPCTRAL2's diffuse spectrum spread over the sky
//!   with Preetham's luminance (the sky's near-infrared colour does not vary with
//!   direction in this model). So the sky's horizontal irradiance in any band is
//!   SPCTRAL2's diffuse irradiance there, up to the visible part's daylight spectrum.
//!   Zero below the horizon (the ground is the scene's).
//!
//! Directions are in lamina-sky's frame: x east, y up, z south.

use crate::preetham::{DaylightSpectrum, PreethamSky, SkyError, xyz_to_linear_rec709};
use crate::solar_position::LocalTime;
use crate::solar_position::{Observer, SolarPosition, SolarQuery, solar_position};
use crate::spectral2::{ResampledSpectrum, Spectral2Query, Spectral2Spectrum, UniformGrid};
use glam::DVec3;
use lamina_leaf::spectrum::bands::Band;
use lamina_leaf::spectrum::cie_xyz_bar;

/// Where and when, and the atmosphere.
#[derive(Clone, Debug, PartialEq)]
pub struct SunSkyParams {
    /// The place.
    pub observer: Observer,
    /// Local time with its UTC offset.
    pub time: LocalTime,
    /// Preetham's turbidity, 1.7 (very clear) to 10 (hazy).
    pub turbidity: f64,
    /// Aerosol optical depth at 500 nm (SPCTRAL2).
    pub aod500: f64,
    /// Precipitable water, cm (SPCTRAL2).
    pub water: f64,
    /// Total ozone, atm-cm (SPCTRAL2).
    pub ozone: f64,
    /// Ground albedo for SPCTRAL2's ground-sky reflections.
    pub ground_albedo: f64,
    /// Surface air pressure, hPa; `None`: from the observer's elevation (standard
    /// atmosphere).
    pub pressure: Option<f64>,
}

impl SunSkyParams {
    /// The defaults of `lamina sky` (turbidity 3, AOD 0.1, water 1.42 cm, ozone 0.344
    /// atm-cm, ground albedo 0.2) for `observer` at `time`.
    pub fn new(observer: Observer, time: LocalTime) -> Self {
        SunSkyParams {
            observer,
            time,
            turbidity: 3.0,
            aod500: 0.1,
            water: 1.42,
            ozone: 0.344,
            ground_albedo: 0.2,
            pressure: None,
        }
    }
}

/// Why no sun and sky could be made: the input at fault (`field`) and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct SunSkyError {
    /// The input at fault (`latitude`, `time`, `turbidity`, `aod500`, ...).
    pub field: &'static str,
    /// What was wrong.
    pub message: String,
}

/// A sun and sky ready to evaluate.
#[derive(Clone, Debug)]
pub struct SunSky {
    sun: SolarPosition,
    preetham: PreethamSky,
    /// SPCTRAL2's spectra on its own wavelengths, 300-4000 nm.
    spectral2: Spectral2Spectrum,
    /// Surface air pressure used, hPa.
    pressure: f64,
    /// SPCTRAL2 at 1 nm over 300-2500 nm.
    spectrum: ResampledSpectrum,
    /// Preetham's radiance times this is the sky's (ȳ-weighted).
    scale: f64,
    /// `∫ E_diff ȳ dλ`, W m⁻² (the diffuse horizontal irradiance, ȳ-weighted).
    diffuse_y: f64,
}

/// Wavelengths where the sky's visible-range daylight spectrum hands over to SPCTRAL2's
/// diffuse shape.
const VISIBLE_END_NM: f64 = 830.0;

impl SunSky {
    /// The sun and sky of `p`. Errors name the input: a sun below the horizon is one
    /// (`time`).
    pub fn new(p: &SunSkyParams) -> Result<SunSky, SunSkyError> {
        let pressure = p.pressure.unwrap_or(
            1013.25
                * (1.0 - 2.25577e-5 * p.observer.elevation)
                    .max(0.0)
                    .powf(5.25588),
        );
        let mut sq = SolarQuery::new(p.observer, p.time);
        sq.pressure = pressure;
        let sun = solar_position(&sq).map_err(|e| SunSkyError {
            field: e.field(),
            message: e.to_string(),
        })?;
        if sun.zenith >= 90.0 {
            return Err(SunSkyError {
                field: "time",
                message: format!(
                    "the sun is below the horizon then (zenith {:.2} degrees): no clear-sky \
                     model applies",
                    sun.zenith
                ),
            });
        }
        let mut q = Spectral2Query::for_sun(&sun);
        q.pressure = pressure;
        q.aod500 = p.aod500;
        q.precipitable_water = p.water;
        q.ozone = p.ozone;
        q.ground_albedo = p.ground_albedo;
        let s = q.compute().map_err(|e| SunSkyError {
            field: e.field(),
            message: e.to_string(),
        })?;
        let grid = UniformGrid::new(300.0, 2500.0, 1.0).expect("a valid grid");
        let spectrum = s.resample(&grid);
        let preetham =
            PreethamSky::from_solar_position(&sun, p.turbidity).map_err(|e: SkyError| {
                SunSkyError {
                    field: e.field(),
                    message: e.to_string(),
                }
            })?;
        let diffuse_y: f64 = grid
            .wavelengths()
            .enumerate()
            .filter(|(_, nm)| (360.0..=830.0).contains(nm))
            .map(|(i, nm)| cie_xyz_bar(nm as f32).y as f64 * spectrum.diffuse_horizontal[i])
            .sum();
        // Preetham's horizontal irradiance (ȳ-weighted).
        let e_p = horizontal_irradiance(256, |d| preetham.xyz(d).y);
        let scale = if e_p > 0.0 { diffuse_y / e_p } else { 0.0 };
        Ok(SunSky {
            sun,
            preetham,
            spectral2: s,
            pressure,
            spectrum,
            scale,
            diffuse_y,
        })
    }

    /// The sun's position (apparent zenith, azimuth, direction).
    pub fn sun(&self) -> &SolarPosition {
        &self.sun
    }

    /// Unit vector toward the sun (x east, y up, z south).
    pub fn sun_direction(&self) -> DVec3 {
        self.sun.direction
    }

    /// The sun's direct normal irradiance in linear Rec.709, `Y = ∫ E ȳ dλ` (W m⁻²).
    pub fn sun_rgb(&self) -> DVec3 {
        let mut xyz = DVec3::ZERO;
        for (i, nm) in self.spectrum.grid.wavelengths().enumerate() {
            if (360.0..=830.0).contains(&nm) {
                xyz += cie_xyz_bar(nm as f32).as_dvec3() * self.spectrum.direct_normal[i];
            }
        }
        xyz_to_linear_rec709(xyz)
    }

    /// SPCTRAL2's spectra on its own wavelengths (300-4000 nm), for band integrals.
    pub fn spectral2(&self) -> &Spectral2Spectrum {
        &self.spectral2
    }

    /// The surface air pressure used for refraction and the spectrum, hPa.
    pub fn pressure(&self) -> f64 {
        self.pressure
    }

    /// The SPCTRAL2 spectra at 1 nm over 300-2500 nm (direct normal, direct and diffuse
    /// horizontal), W m⁻² nm⁻¹.
    pub fn spectrum(&self) -> &ResampledSpectrum {
        &self.spectrum
    }

    /// Diffuse horizontal irradiance, ȳ-weighted (W m⁻²): the sky's level.
    pub fn diffuse_y(&self) -> f64 {
        self.diffuse_y
    }

    /// SPCTRAL2 at `nm` (linear between its 1 nm samples): (direct normal, diffuse
    /// horizontal).
    fn at(&self, nm: f64) -> (f64, f64) {
        let x = (nm - 300.0).clamp(0.0, 2199.999);
        let i = x.floor() as usize;
        let t = x - i as f64;
        let s = &self.spectrum;
        let lerp = |v: &[f64]| v[i] + t * (v[i + 1] - v[i]);
        (lerp(&s.direct_normal), lerp(&s.diffuse_horizontal))
    }

    /// Band means `Σ w(λ) v(λ) / Σ w(λ)` at 1 nm over `band` of `v`.
    fn band_mean(band: &Band, v: impl Fn(f64) -> f64) -> f64 {
        let (lo, hi) = (band.lo_nm as f64, band.hi_nm as f64);
        let n = ((hi - lo).ceil() as usize).max(1);
        let step = (hi - lo) / n as f64;
        let (mut sum, mut sw) = (0.0, 0.0);
        for k in 0..n {
            let nm = lo + (k as f64 + 0.5) * step;
            let w = band.weight(nm as f32) as f64;
            sum += w * v(nm);
            sw += w;
        }
        if sw > 0.0 { sum / sw } else { 0.0 }
    }

    /// The sun's direct normal irradiance in `band`: its band mean, W m⁻² nm⁻¹.
    pub fn sun_band(&self, band: &Band) -> f64 {
        Self::band_mean(band, |nm| self.at(nm).0)
    }

    /// The sky's radiance toward `-dir` seen along `dir` (a direction in the sky), linear
    /// Rec.709 with `Y = ∫ L ȳ dλ`, W m⁻² sr⁻¹. Zero below the horizon.
    pub fn sky_rgb(&self, dir: DVec3) -> DVec3 {
        if dir.y <= 0.0 {
            return DVec3::ZERO;
        }
        (self.preetham.linear_rec709(dir) * self.scale).max(DVec3::ZERO)
    }

    /// The sky's band-mean spectral radiance along `dir` in `band`, W m⁻² sr⁻¹ nm⁻¹ (see
    /// the module docs). Zero below the horizon.
    pub fn sky_band(&self, dir: DVec3, band: &Band) -> f64 {
        let mut v = [0.0];
        self.sky_bands(dir, &[band], &mut v);
        v[0]
    }

    /// [`Self::sky_band`] for each of `bands` into `out`, the sky's spectrum along `dir`
    /// computed once. For many directions, make the [`SkyBandWeights`] once and call
    /// [`Self::sky_bands_weighted`].
    pub fn sky_bands(&self, dir: DVec3, bands: &[&Band], out: &mut [f64]) {
        self.sky_bands_weighted(dir, &self.sky_band_weights(bands), out);
    }

    /// The band means of `bands` as fixed weights on the sky spectrum's parts: what
    /// [`Self::sky_bands_weighted`] needs, made once for all directions.
    pub fn sky_band_weights(&self, bands: &[&Band]) -> SkyBandWeights {
        let bands = bands
            .iter()
            .map(|band| {
                // The band mean, as in `band_mean`: Σ w(λ) v(λ) / Σ w(λ) on the 1 nm
                // midpoints; below 830 nm v is linear in the daylight nodes, above it a
                // fixed spectrum times the direction's luminance.
                let (lo, hi) = (band.lo_nm as f64, band.hi_nm as f64);
                let n = ((hi - lo).ceil() as usize).max(1);
                let step = (hi - lo) / n as f64;
                let (mut nodes, mut nir, mut sw) = ([0.0; 54], 0.0, 0.0);
                for k in 0..n {
                    let nm = lo + (k as f64 + 0.5) * step;
                    let w = band.weight(nm as f32) as f64;
                    sw += w;
                    if nm <= VISIBLE_END_NM {
                        if let Some(hat) = DaylightSpectrum::node_weights(nm) {
                            for (row, h) in hat {
                                nodes[row] += w * h;
                            }
                        }
                    } else if self.diffuse_y > 0.0 {
                        nir += w * self.at(nm).1 / self.diffuse_y;
                    }
                }
                if sw > 0.0 {
                    nodes.iter_mut().for_each(|x| *x /= sw);
                    nir /= sw;
                } else {
                    (nodes, nir) = ([0.0; 54], 0.0);
                }
                let basis = crate::preetham::basis()
                    .map(|b| b.iter().zip(&nodes).map(|(s, w)| s * w).sum());
                BandWeights { nodes, basis, nir }
            })
            .collect();
        SkyBandWeights { bands }
    }

    /// [`Self::sky_band`] for each band of `weights` (made by [`Self::sky_band_weights`])
    /// into `out`, W m⁻² sr⁻¹ nm⁻¹: the sky's spectrum along `dir` computed once, each band
    /// a dot product over the 54 daylight nodes. Equal to the band means of
    /// [`Self::sky_band`] up to rounding.
    pub fn sky_bands_weighted(&self, dir: DVec3, weights: &SkyBandWeights, out: &mut [f64]) {
        if dir.y <= 0.0 {
            out.fill(0.0);
            return;
        }
        let (visible, y) = self.preetham.spectrum_and_y(dir);
        let shape = visible.shape();
        let (vis_scale, nir_scale) = (visible.scale() * self.scale, y * self.scale);
        if shape.is_unclamped() {
            // The nodes are `S0 + M1 S1 + M2 S2`: three numbers per band.
            let (m1, m2) = (shape.m1(), shape.m2());
            for (o, band) in out.iter_mut().zip(&weights.bands) {
                let [b0, b1, b2] = band.basis;
                let v = b0 + m1 * b1 + m2 * b2;
                *o = (v * vis_scale + nir_scale * band.nir).max(0.0);
            }
            return;
        }
        let nodes = shape.nodes();
        for (o, band) in out.iter_mut().zip(&weights.bands) {
            let v: f64 = nodes.iter().zip(&band.nodes).map(|(a, b)| a * b).sum();
            *o = (v * vis_scale + nir_scale * band.nir).max(0.0);
        }
    }
}

/// Bands' means of the sky spectrum as fixed weights ([`SunSky::sky_band_weights`]): the
/// sky's spectrum in a direction is linear in its 54 daylight nodes (300-830 nm) and, beyond
/// 830 nm, its luminance times a fixed spectrum, so each band mean is a dot product.
#[derive(Debug, Clone)]
pub struct SkyBandWeights {
    bands: Vec<BandWeights>,
}

#[derive(Debug, Clone)]
struct BandWeights {
    /// The weight of each daylight node in the band mean (the band's weights, divided by
    /// their sum).
    nodes: [f64; 54],
    /// `nodes` applied to the basis functions `S0`, `S1`, `S2`: the band mean of an
    /// unclamped daylight spectrum is `basis[0] + M1 basis[1] + M2 basis[2]`.
    basis: [f64; 3],
    /// The band mean of `at(nm).1 / diffuse_y` beyond 830 nm (times the luminance `Y` of
    /// the direction and the scale).
    nir: f64,
}

/// `∫ f(ω) cos θ dω` over the upper hemisphere (y up) by the midpoint rule on
/// `n x 2n` cells in (zenith, azimuth).
pub fn horizontal_irradiance(n: usize, f: impl Fn(DVec3) -> f64) -> f64 {
    use std::f64::consts::PI;
    let na = 2 * n;
    let mut e = 0.0;
    for j in 0..n {
        let th = 0.5 * PI * (j as f64 + 0.5) / n as f64;
        let w = th.sin() * th.cos() * (0.5 * PI / n as f64) * (2.0 * PI / na as f64);
        for i in 0..na {
            let az = 2.0 * PI * (i as f64 + 0.5) / na as f64;
            e += f(DVec3::new(
                th.sin() * az.sin(),
                th.cos(),
                th.sin() * az.cos(),
            )) * w;
        }
    }
    e
}

/// An equirectangular map `width x width / 2` of `f(direction in the sky's frame)`, in the
/// orientation of lamina's sky maps: pixel `(i, j)` looks along the scene direction
/// `d = (sin θ sin φ, cos θ, -sin θ cos φ)` with `φ = -π + 2π (i + ½) / width`,
/// `θ = π (j + ½) / height`; `to_sky` takes a scene direction into the sky's frame (x east,
/// y up, z south). Rows are computed in parallel.
pub fn bake_map(
    width: u32,
    to_sky: impl Fn(DVec3) -> DVec3 + Sync,
    f: impl Fn(DVec3) -> [f32; 3] + Sync,
) -> Vec<[f32; 3]> {
    let flat = bake_values(width, 3, to_sky, |d, out| out.copy_from_slice(&f(d)));
    flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
}

/// [`bake_map`] of `n` values per pixel: `f(direction, out)` fills a pixel's `n` values;
/// the result is pixel-major (`n` values per pixel).
pub fn bake_values(
    width: u32,
    n: usize,
    to_sky: impl Fn(DVec3) -> DVec3 + Sync,
    f: impl Fn(DVec3, &mut [f32]) + Sync,
) -> Vec<f32> {
    use rayon::prelude::*;
    let (w, h) = (width as usize, (width / 2).max(1) as usize);
    let mut out = vec![0.0f32; w * h * n];
    out.par_chunks_mut(w * n).enumerate().for_each(|(j, row)| {
        let th = std::f64::consts::PI * (j as f64 + 0.5) / h as f64;
        for (i, px) in row.chunks_exact_mut(n).enumerate() {
            let ph =
                -std::f64::consts::PI + 2.0 * std::f64::consts::PI * (i as f64 + 0.5) / w as f64;
            let d = DVec3::new(th.sin() * ph.sin(), th.cos(), -th.sin() * ph.cos());
            f(to_sky(d), px);
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paris_noon() -> SunSky {
        let p = SunSkyParams::new(
            Observer {
                latitude: 48.8566,
                longitude: 2.3522,
                elevation: 35.0,
            },
            crate::parse_local_time("2024-06-21T13:30:00+02:00").unwrap(),
        );
        SunSky::new(&p).unwrap()
    }

    /// Horizontal irradiance of `f` over the upper hemisphere.
    fn irradiance(f: impl Fn(DVec3) -> f64) -> f64 {
        horizontal_irradiance(128, f)
    }

    #[test]
    fn the_sky_carries_spectral2s_diffuse_irradiance_in_every_band() {
        let s = paris_noon();
        // ȳ-weighted, from the RGB sky: Y of linear Rec.709.
        let y = |c: DVec3| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
        let e_rgb = irradiance(|d| y(s.sky_rgb(d)));
        assert!(
            (e_rgb / s.diffuse_y() - 1.0).abs() < 0.01,
            "{e_rgb} vs {}",
            s.diffuse_y()
        );
        // In near-infrared bands the sky's irradiance is SPCTRAL2's diffuse, exactly by
        // construction; in a visible band, close (the daylight spectrum's shape).
        for (lo, hi, tol) in [
            (850.0, 880.0, 0.01),
            (1550.0, 1650.0, 0.01),
            (540.0, 570.0, 0.1),
        ] {
            let b = Band::flat("b", lo, hi);
            let e = irradiance(|d| s.sky_band(d, &b));
            let want = SunSky::band_mean(&b, |nm| s.at(nm).1);
            assert!((e / want - 1.0).abs() < tol, "{lo}-{hi} nm: {e} vs {want}");
        }
    }

    #[test]
    fn band_weights_equal_the_per_wavelength_band_means() {
        let response =
            lamina_leaf::spectrum::bands::Response::parse("600 0.1\n650 1\n700 0.3\n").unwrap();
        let bands = [
            Band::flat("blue", 450.0, 500.0),
            Band::flat("narrow", 512.3, 513.1),
            Band::flat("visible", 380.0, 780.0),
            Band::flat("across 830 nm", 780.0, 900.0),
            Band::flat("swir", 2100.0, 2280.0),
            Band::with_response("curve", response),
        ];
        let refs: Vec<&Band> = bands.iter().collect();
        let mut out = vec![0.0; bands.len()];
        // At noon the daylight basis is clamped nowhere; under a low sun it is, near the
        // horizon (in the ultraviolet rows): both ways of `sky_bands_weighted` are checked.
        let sunset = SunSky::new(&SunSkyParams::new(
            Observer {
                latitude: 48.8566,
                longitude: 2.3522,
                elevation: 35.0,
            },
            crate::parse_local_time("2024-06-21T21:45:00+02:00").unwrap(),
        ))
        .unwrap();
        let mut unclamped = [0usize; 2];
        for (which, s) in [paris_noon(), sunset].iter().enumerate() {
            let weights = s.sky_band_weights(&refs);
            // Directions over the whole sky, down to 3° above the horizon.
            let dirs = (0..16).flat_map(|i| {
                (0..8).map(move |j| (0.05 + 1.52 * f64::from(i) / 15.0, -3.0 + 0.8 * f64::from(j)))
            });
            for (th, ph) in dirs {
                let dir = DVec3::new(
                    f64::sin(th) * f64::sin(ph),
                    f64::cos(th),
                    f64::sin(th) * f64::cos(ph),
                );
                s.sky_bands_weighted(dir, &weights, &mut out);
                // The definition: the band mean of the spectrum evaluated at each wavelength.
                let visible = s.preetham.spectrum(dir);
                unclamped[which] += usize::from(visible.shape().is_unclamped());
                let y = s.preetham.xyz(dir).y;
                assert_eq!(s.preetham.spectrum_and_y(dir), (visible, y));
                for (b, got) in bands.iter().zip(&out) {
                    let want = SunSky::band_mean(b, |nm| {
                        if nm <= VISIBLE_END_NM {
                            visible.eval(nm) * s.scale
                        } else {
                            y * s.scale * s.at(nm).1 / s.diffuse_y
                        }
                    });
                    assert!(want > 0.0, "{}: {want}", b.name);
                    assert!(
                        (got / want - 1.0).abs() < 1e-12,
                        "{} at ({th}, {ph}): {got} vs {want}",
                        b.name
                    );
                }
            }
            s.sky_bands_weighted(DVec3::new(0.0, -0.2, 1.0).normalize(), &weights, &mut out);
            assert!(out.iter().all(|&x| x == 0.0), "below the horizon: {out:?}");
        }
        assert_eq!(unclamped[0], 128, "noon");
        assert!(
            (1..128).contains(&unclamped[1]),
            "sunset: {} of 128 unclamped",
            unclamped[1]
        );
    }

    #[test]
    fn sun_rgb_and_bands_agree_with_spectral2() {
        let s = paris_noon();
        let rgb = s.sun_rgb();
        // A clear high sun (`lamina sky` prints [169.30, 145.11, 120.45] for 14:30): in
        // the ȳ convention Y = ∫ E ȳ dλ, about 107 nm times the visible mean of E.
        let y = 0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z;
        assert!((130.0..170.0).contains(&y), "{rgb}");
        assert!(rgb.x > rgb.z, "{rgb}");
        let nir = s.sun_band(&Band::flat("nir", 850.0, 880.0));
        let direct = s.spectrum().direct_normal[565]; // 865 nm
        assert!((nir / direct - 1.0).abs() < 0.05, "{nir} vs {direct}");
        // Below the horizon: no sky.
        assert_eq!(
            s.sky_rgb(DVec3::new(0.0, -0.5, 0.8).normalize()),
            DVec3::ZERO
        );
    }

    #[test]
    fn a_sun_below_the_horizon_names_the_time() {
        let p = SunSkyParams::new(
            Observer {
                latitude: 48.8566,
                longitude: 2.3522,
                elevation: 0.0,
            },
            crate::parse_local_time("2024-06-21T02:00:00+02:00").unwrap(),
        );
        let e = SunSky::new(&p).unwrap_err();
        assert_eq!(e.field, "time");
        assert!(e.message.contains("below the horizon"), "{e}");
    }
}
