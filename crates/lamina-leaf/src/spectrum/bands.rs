//! Spectral bands and the way RGB scene values become band values.
//!
//! A [`Band`] is a named wavelength interval (a satellite band, a PAR window, a narrow
//! line). A render in bands renders three at a time through the RGB integrator, with every
//! scene value replaced by its band value:
//!
//! * **Reflectances and other RGB material values** (colours, colour maps, a leaf's layer
//!   coefficients) become spectra through a fixed linear basis: `s(λ) = Σ_c rgb_c B_c(λ)`,
//!   `B_c` the Jakob & Hanika spectra of the three primaries ([`super::upsample`]) divided by
//!   their sum, so that white stays exactly 1 at every wavelength and any RGB in `[0, 1]`
//!   stays in `[0, 1]`. Beyond 830 nm the basis holds its 830 nm value: an RGB material says
//!   nothing about the infrared, and this is the neutral guess. Pigment leaves (PROSPECT) are
//!   spectral by themselves and do not go through it.
//! * **Emission** (lights, skies) is the same basis times the shape of an illuminant
//!   ([`Illuminant`]), normalised so that an RGB white of 1 has `∫ E(λ) ȳ(λ) dλ = 1`: the
//!   convention of lamina's RGB radiance (`Y = ∫ L ȳ dλ`). Band renders use the shape of the
//!   ground-level solar spectrum (ASTM G173 global, [`super::solar_global`]): an RGB sun
//!   then has the sun's infrared. `spectral = "visible"` renders use D65, Rec.709's white, so
//!   that RGB white light stays exactly white through the CIE observer (an RGB scene keeps
//!   its look). A band's value is the band-mean spectral radiance in W m⁻² sr⁻¹ nm⁻¹.
//!
//! Band values are means over the band, integrated at 1 nm: plain means over `[lo, hi]` for
//! a band given by its edges, and means weighted by the relative spectral response for a
//! band given by a response curve ([`Response`], e.g. a satellite band's published SRF):
//! `v_b = ∫ v(λ) R(λ) dλ / ∫ R(λ) dλ`, the band-effective value.

use super::upsample::RgbSpectrum;
use super::{LAMBDA_MAX_NM, LAMBDA_MIN_NM, cie_xyz_bar, solar_global};
use glam::{Mat3, Vec3};
use std::sync::OnceLock;

/// A named wavelength band `[lo_nm, hi_nm]`, flat or weighted by a response curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Band {
    /// Its name: the EXR channel name.
    pub name: String,
    /// Shortest wavelength, nm (for a response curve: where it starts being non-zero).
    pub lo_nm: f32,
    /// Longest wavelength, nm (`> lo_nm`).
    pub hi_nm: f32,
    /// The relative spectral response, `None` for a flat band (every wavelength in
    /// `[lo_nm, hi_nm]` weighs the same).
    pub response: Option<Response>,
}

impl Band {
    /// A flat band over `[lo_nm, hi_nm]`.
    pub fn flat(name: impl Into<String>, lo_nm: f32, hi_nm: f32) -> Band {
        Band {
            name: name.into(),
            lo_nm,
            hi_nm,
            response: None,
        }
    }

    /// A band weighted by `response`, spanning where it is non-zero.
    pub fn with_response(name: impl Into<String>, response: Response) -> Band {
        let (lo_nm, hi_nm) = response.support();
        Band {
            name: name.into(),
            lo_nm,
            hi_nm,
            response: Some(response),
        }
    }

    /// The weight of wavelength `nm` in the band: 1 inside a flat band, the response
    /// otherwise.
    pub fn weight(&self, nm: f32) -> f32 {
        match &self.response {
            None => 1.0,
            Some(r) => r.at(nm),
        }
    }

    /// The band's centre, nm: the middle of a flat band, the response-weighted mean
    /// wavelength (centroid) of a response curve. Pigment leaves are evaluated here.
    pub fn center(&self) -> f32 {
        match &self.response {
            None => 0.5 * (self.lo_nm + self.hi_nm),
            Some(r) => r.centroid,
        }
    }
}

/// A relative spectral response curve: samples `(nm, weight)`, linear between them and
/// zero outside, scaled so that its peak is 1.
#[derive(Clone, Debug, PartialEq)]
pub struct Response {
    nm: Vec<f32>,
    weight: Vec<f32>,
    centroid: f32,
}

/// Why a response curve was refused: the 1-based line of its file (0 for the file as a
/// whole) and what was wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct ResponseError {
    /// 1-based line, or 0 when the whole file is at fault.
    pub line: usize,
    /// What was wrong, in words.
    pub message: String,
}

impl Response {
    /// A curve from samples; `lines[i]` is the file line of sample `i` (for errors).
    /// Checked: at least 2 samples, wavelengths finite, strictly increasing and inside
    /// 360-2500 nm, weights finite and `>= 0`, some weight above 0.
    pub fn new(samples: &[(f32, f32)], lines: &[usize]) -> Result<Response, ResponseError> {
        let line = |i: usize| lines.get(i).copied().unwrap_or(0);
        let err = |line: usize, message: String| ResponseError { line, message };
        if samples.len() < 2 {
            return Err(err(
                0,
                format!(
                    "{} sample(s): a response curve needs at least 2 (wavelength_nm, response)",
                    samples.len()
                ),
            ));
        }
        if samples.iter().all(|s| s.0 < 10.0) {
            return Err(err(
                0,
                "every wavelength is below 10: these look like micrometres; give nm".into(),
            ));
        }
        for (i, &(nm, w)) in samples.iter().enumerate() {
            if !(nm.is_finite() && (LAMBDA_MIN_NM..=LAMBDA_MAX_NM).contains(&nm)) {
                return Err(err(
                    line(i),
                    format!("wavelength {nm} nm is outside 360-2500 nm"),
                ));
            }
            if i > 0 && nm <= samples[i - 1].0 {
                return Err(err(
                    line(i),
                    format!(
                        "wavelength {nm} nm does not follow {} nm: wavelengths must increase",
                        samples[i - 1].0
                    ),
                ));
            }
            if !(w.is_finite() && w >= 0.0) {
                return Err(err(
                    line(i),
                    format!("response {w} at {nm} nm: must be a finite number >= 0"),
                ));
            }
        }
        let peak = samples.iter().map(|s| s.1).fold(0.0f32, f32::max);
        if peak <= 0.0 {
            return Err(err(0, "the response is 0 everywhere".into()));
        }
        let mut r = Response {
            nm: samples.iter().map(|s| s.0).collect(),
            weight: samples.iter().map(|s| s.1 / peak).collect(),
            centroid: 0.0,
        };
        let (lo, hi) = r.support();
        let (mut sw, mut swl) = (0.0f64, 0.0f64);
        for k in 0..(hi - lo).ceil().max(1.0) as usize {
            let nm = lo + k as f32 + 0.5;
            let w = r.at(nm) as f64;
            sw += w;
            swl += w * nm as f64;
        }
        r.centroid = if sw > 0.0 {
            (swl / sw) as f32
        } else {
            0.5 * (lo + hi)
        };
        Ok(r)
    }

    /// Parses a response file: two columns, wavelength (nm) and response, separated by
    /// commas, semicolons or white space; `#` comments and blank lines skipped; one header
    /// line allowed before the first sample.
    pub fn parse(text: &str) -> Result<Response, ResponseError> {
        let mut samples = Vec::new();
        let mut lines = Vec::new();
        for (line, s, fields) in crate::measured::table_lines(text) {
            let nums: Vec<Option<f32>> = fields.iter().map(|f| f.parse::<f32>().ok()).collect();
            if samples.is_empty() && lines.is_empty() && nums.iter().any(Option::is_none) {
                lines.push(0); // the header
                continue;
            }
            if fields.len() != 2 {
                return Err(ResponseError {
                    line,
                    message: format!(
                        "{} column(s); expected 2: wavelength_nm, response",
                        fields.len()
                    ),
                });
            }
            match (nums[0], nums[1]) {
                (Some(nm), Some(w)) => {
                    samples.push((nm, w));
                    lines.push(line);
                }
                _ => {
                    return Err(ResponseError {
                        line,
                        message: format!("'{s}' is not two numbers"),
                    });
                }
            }
        }
        if lines.first() == Some(&0) {
            lines.remove(0);
        }
        Response::new(&samples, &lines)
    }

    /// The response at `nm` (peak 1, zero outside the samples).
    pub fn at(&self, nm: f32) -> f32 {
        let i = self.nm.partition_point(|&x| x <= nm);
        if i == 0 || i == self.nm.len() && nm > self.nm[i - 1] {
            return 0.0;
        }
        if i == self.nm.len() {
            return self.weight[i - 1];
        }
        let (x0, x1) = (self.nm[i - 1], self.nm[i]);
        let t = (nm - x0) / (x1 - x0);
        self.weight[i - 1] + t * (self.weight[i] - self.weight[i - 1])
    }

    /// `(first, last)` wavelength where the response is not zero, nm.
    pub fn support(&self) -> (f32, f32) {
        let first = self.weight.iter().position(|&w| w > 0.0).unwrap_or(0);
        let last = self.weight.iter().rposition(|&w| w > 0.0).unwrap_or(0);
        (
            self.nm[first.saturating_sub(1)],
            self.nm[(last + 1).min(self.nm.len() - 1)],
        )
    }

    /// The response-weighted mean wavelength, nm.
    pub fn centroid(&self) -> f32 {
        self.centroid
    }
}

/// `B_R, B_G, B_B` (normalised to sum to 1) at `nm`.
fn basis(nm: f32) -> Vec3 {
    static PRIMARIES: OnceLock<[RgbSpectrum; 3]> = OnceLock::new();
    let p = PRIMARIES.get_or_init(|| [Vec3::X, Vec3::Y, Vec3::Z].map(|c| RgbSpectrum::fit(c).0));
    let v = Vec3::new(p[0].eval(nm), p[1].eval(nm), p[2].eval(nm));
    v / v.element_sum().max(1e-6)
}

/// The spectrum an RGB reflectance (or any RGB material coefficient) has at `nm` in spectral
/// renders: `Σ_c rgb_c B_c(λ)` (see the module docs). Band and bin values are its means.
pub fn rgb_reflectance_at(rgb: Vec3, nm: f32) -> f32 {
    basis(nm).dot(rgb)
}

/// The spectral radiance (or irradiance), per nm, of an RGB emission at `nm` when RGB light
/// takes the shape `illuminant`: [`rgb_reflectance_at`] times the shape, scaled so that an
/// RGB white of 1 has `∫ L ȳ dλ = 1` over 360-830 nm (see the module docs).
pub fn rgb_emission_at(rgb: Vec3, nm: f32, illuminant: Illuminant) -> f32 {
    rgb_reflectance_at(rgb, nm) * illuminant.at(nm) / illuminant.norm()
}

/// The spectral shape RGB emission takes in bands (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Illuminant {
    /// ASTM G173-03 global solar irradiance: what band renders use (an RGB sun gets the
    /// sun's near and short-wave infrared).
    #[default]
    Solar,
    /// CIE D65 (zero outside 360-830 nm): what visible renders use, so that RGB white
    /// emission is Rec.709 white through the CIE observer.
    D65,
}

impl Illuminant {
    /// The shape at `nm` (arbitrary scale).
    #[inline]
    fn at(self, nm: f32) -> f32 {
        match self {
            Illuminant::Solar => solar_global(nm),
            Illuminant::D65 => super::d65(nm),
        }
    }

    /// `∫ S ȳ dλ` over 360-830 nm (1 nm midpoints): the shape's normalisation.
    fn norm(self) -> f32 {
        static NORM: OnceLock<[f32; 2]> = OnceLock::new();
        let n = NORM.get_or_init(|| {
            [Illuminant::Solar, Illuminant::D65].map(|s| {
                (360..830)
                    .map(|k| {
                        let nm = k as f32 + 0.5;
                        s.at(nm) * cie_xyz_bar(nm).y
                    })
                    .sum()
            })
        });
        n[self as usize]
    }
}

/// The band means of the three basis spectra, for reflectance and for emission of shape
/// `illuminant`: `(refl, emit)` where `refl.dot(rgb)` is the band value of reflectance `rgb`.
fn band_means(b: &Band, illuminant: Illuminant) -> (Vec3, Vec3) {
    let lo = b.lo_nm.max(LAMBDA_MIN_NM);
    let hi = b.hi_nm.min(LAMBDA_MAX_NM).max(lo + 1e-3);
    let n = ((hi - lo).ceil() as usize).max(1);
    let step = (hi - lo) / n as f32;
    let (mut r, mut e, mut sw) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
    for k in 0..n {
        let nm = lo + (k as f32 + 0.5) * step;
        let w = b.weight(nm);
        let bs = basis(nm) * w;
        r += bs;
        e += bs * illuminant.at(nm);
        sw += w;
    }
    // (A flat band's weights are 1, so `sw` is `n` exactly: the plain mean.)
    let sw = sw.max(f32::MIN_POSITIVE);
    (r / sw, e / (sw * illuminant.norm()))
}

/// How RGB values become the values of three bands (one per channel of a band render).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandBasis {
    /// Row `i`: the weights of R, G, B in band `i`'s reflectance.
    refl: [Vec3; 3],
    /// Row `i`: the same for emission (W m⁻² sr⁻¹ nm⁻¹ per unit of RGB radiance).
    emit: [Vec3; 3],
}

impl BandBasis {
    /// The basis for `bands` (channel `i` of a band render is band `i`), emission of the
    /// solar shape.
    pub fn new(bands: [&Band; 3]) -> Self {
        Self::with_illuminant(bands, Illuminant::Solar)
    }

    /// The basis for `bands` with RGB emission of the shape `illuminant`.
    pub fn with_illuminant(bands: [&Band; 3], illuminant: Illuminant) -> Self {
        let m = bands.map(|b| band_means(b, illuminant));
        BandBasis {
            refl: m.map(|x| x.0),
            emit: m.map(|x| x.1),
        }
    }

    /// The three band values of an RGB reflectance (or any RGB material coefficient).
    #[inline]
    pub fn reflectance(&self, rgb: Vec3) -> Vec3 {
        Vec3::new(
            self.refl[0].dot(rgb),
            self.refl[1].dot(rgb),
            self.refl[2].dot(rgb),
        )
    }

    /// The linear map of [`Self::reflectance`]: row `i` holds the weights of R, G, B in
    /// band `i` (every entry in `[0, 1]`, rows summing to 1, so `[0, 1]³` maps into itself).
    #[inline]
    pub fn reflectance_matrix(&self) -> Mat3 {
        Mat3::from_cols(self.refl[0], self.refl[1], self.refl[2]).transpose()
    }

    /// The three band values (band-mean spectral radiance or irradiance, per nm) of an RGB
    /// emission.
    #[inline]
    pub fn emission(&self, rgb: Vec3) -> Vec3 {
        Vec3::new(
            self.emit[0].dot(rgb),
            self.emit[1].dot(rgb),
            self.emit[2].dot(rgb),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn band(lo: f32, hi: f32) -> Band {
        Band::flat(format!("{lo}-{hi}"), lo, hi)
    }

    #[test]
    fn per_wavelength_values_average_to_the_band_values() {
        let rgb = Vec3::new(0.2, 0.6, 0.1);
        let e = Vec3::new(3.0, 2.9, 2.7);
        for (lo, hi) in [
            (400.0, 450.0),
            (620.0, 700.0),
            (800.0, 900.0),
            (1550.0, 1750.0),
        ] {
            let b = band(lo, hi);
            for ill in [Illuminant::Solar, Illuminant::D65] {
                let basis = BandBasis::with_illuminant([&b, &b, &b], ill);
                let n = (hi - lo) as usize;
                let mean = |f: &dyn Fn(f32) -> f32| {
                    (0..n).map(|k| f(lo + k as f32 + 0.5)).sum::<f32>() / n as f32
                };
                let r = mean(&|nm| rgb_reflectance_at(rgb, nm));
                let em = mean(&|nm| rgb_emission_at(e, nm, ill));
                assert!(
                    (r - basis.reflectance(rgb).x).abs() < 1e-5,
                    "{lo}-{hi}: {r}"
                );
                let want = basis.emission(e).x;
                assert!(
                    (em - want).abs() <= 1e-5 * want.max(1e-3),
                    "{lo}-{hi} {ill:?}: {em} {want}"
                );
            }
        }
        // White light of 1 has Y = ∫ L ȳ dλ = 1 in either shape.
        for ill in [Illuminant::Solar, Illuminant::D65] {
            let y: f32 = (360..830)
                .map(|k| {
                    let nm = k as f32 + 0.5;
                    rgb_emission_at(Vec3::ONE, nm, ill) * cie_xyz_bar(nm).y
                })
                .sum();
            assert!((y - 1.0).abs() < 1e-4, "{ill:?}: {y}");
        }
    }

    #[test]
    fn a_box_response_equals_the_flat_band_and_a_skewed_one_moves_the_centre() {
        let flat = band(600.0, 700.0);
        let boxed = Band::with_response(
            "box",
            Response::parse("nm,r\n599.999,0\n600,1\n700,1\n700.001,0\n").unwrap(),
        );
        assert!((boxed.center() - 650.0).abs() < 0.01, "{}", boxed.center());
        let a = BandBasis::new([&flat, &flat, &flat]);
        let b = BandBasis::new([&boxed, &boxed, &boxed]);
        let c = Vec3::new(0.8, 0.3, 0.1);
        assert!((a.reflectance(c) - b.reflectance(c)).abs().max_element() < 2e-3);
        // A ramp toward the red weighs the red end more.
        let ramp = Band::with_response("ramp", Response::parse("600 0.1\n700 1\n").unwrap());
        assert!(ramp.center() > 660.0, "{}", ramp.center());
        let red = BandBasis::new([&ramp, &ramp, &ramp]).reflectance(Vec3::X).x;
        assert!(red > a.reflectance(Vec3::X).x, "{red}");
    }

    #[test]
    fn bad_response_files_name_the_line() {
        let cases = [
            ("500 1\n490 1\n", 2, "increase"),
            ("500 1\n510 -1\n", 2, ">= 0"),
            ("500 1\n510 NaN\n", 2, "finite"),
            ("500 1\n3000 1\n", 2, "360-2500"),
            ("500 1 2\n", 1, "3 column"),
            ("500 1\n", 0, "at least 2"),
            ("0.5 1\n0.6 1\n", 0, "micrometres"),
            ("500 0\n600 0\n", 0, "0 everywhere"),
            ("nm r\n500 1\nx y\n", 3, "not two numbers"),
        ];
        for (text, line, words) in cases {
            let e = Response::parse(text).unwrap_err();
            assert_eq!(e.line, line, "{text:?}: {e:?}");
            assert!(e.message.contains(words), "{text:?}: {e:?}");
        }
    }

    #[test]
    fn white_stays_white_and_colours_land_in_their_bands() {
        let (b, g, r, nir) = (
            band(440.0, 480.0),
            band(530.0, 570.0),
            band(620.0, 680.0),
            band(800.0, 900.0),
        );
        let m = BandBasis::new([&b, &g, &r]);
        assert!((m.reflectance(Vec3::ONE) - Vec3::ONE).abs().max_element() < 1e-5);
        let green = m.reflectance(Vec3::new(0.05, 0.4, 0.05));
        assert!(
            green.y > 2.0 * green.x && green.y > 2.0 * green.z,
            "{green}"
        );
        // NIR: the basis holds its 830 nm value, a grey stays that grey.
        let n = BandBasis::new([&nir, &nir, &nir]);
        assert!((n.reflectance(Vec3::splat(0.3)).x - 0.3).abs() < 1e-5);
    }

    #[test]
    fn white_light_has_unit_luminance_weighted_integral() {
        // Band-mean spectral radiance of RGB white, summed with ȳ over the visible, is 1.
        let bands: Vec<Band> = (0..47)
            .map(|k| band(360.0 + 10.0 * k as f32, 370.0 + 10.0 * k as f32))
            .collect();
        let mut y = 0.0;
        for bd in &bands {
            let e = BandBasis::new([bd, bd, bd]).emission(Vec3::ONE).x;
            let ybar: f32 = (0..10)
                .map(|i| cie_xyz_bar(bd.lo_nm + i as f32 + 0.5).y)
                .sum();
            y += e * ybar;
        }
        assert!((y - 1.0).abs() < 0.02, "{y}");
    }
}
