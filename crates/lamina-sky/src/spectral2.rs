//! Clear-sky spectral solar irradiance by SPCTRAL2, Bird & Riordan's simple spectral model.
//!
//! Bird, R. E. & Riordan, C., *Simple solar spectral model for direct and diffuse irradiance
//! on horizontal and tilted planes at the Earth's surface for cloudless atmospheres*, J.
//! Climate Appl. Meteor. 25, 87–97 (1986); the same model in more detail: SERI technical
//! report SERI/TR-215-2436 (1984). The comments give the report's equation numbers
//! (2-x: direct, 3-x: diffuse). Written here from those equations; the extraterrestrial
//! spectrum and the absorption coefficients are the report's tabulated values at its 122
//! wavelengths (its Table 2-1; NREL's `spectrl2_2.c` and pvlib carry the same numbers),
//! embedded at the end of this file.
//!
//! For a sun at apparent zenith `Z` the model gives, per wavelength λ (300–4000 nm, about
//! 10 nm resolution), in W m⁻² nm⁻¹:
//!
//! * the **direct normal** irradiance `I_d = H₀ D T_r T_a T_w T_o T_u` (eq. 2-1): the
//!   extraterrestrial spectrum `H₀` scaled to the Earth–sun distance (`D`), attenuated by
//!   Rayleigh scattering, aerosol extinction, water vapour, ozone and the uniformly mixed
//!   gases (O₂, CO₂);
//! * the **direct horizontal** irradiance `I_d cos Z`;
//! * the **diffuse horizontal** irradiance `I_s = I_r + I_a + I_g` (eq. 3-1): light scattered
//!   down once by the molecules (`I_r`, eq. 3-5) and the aerosol (`I_a`, eq. 3-6), and the
//!   light bounced between the ground and the sky (`I_g`, eq. 3-7), with the report's
//!   ultraviolet correction `C_s` (eq. 3-17).
//!
//! [`spectral2`] validates a [`Spectral2Query`] (every field, each error naming it) and
//! returns a [`Spectral2Spectrum`] on the model's [`WAVELENGTHS`]; [`Spectral2Spectrum::band`]
//! integrates it over a band (W m⁻²) and [`Spectral2Spectrum::resample`] puts it on a
//! [`UniformGrid`], both by linear interpolation between the model's wavelengths.
//!
//! ```
//! use lamina_sky::{EarthSun, Spectral2Query, UniformGrid};
//!
//! let mut query = Spectral2Query::new(30.0); // apparent zenith 30°, the default atmosphere
//! query.aod500 = 0.2; // a hazier day
//! query.earth_sun = EarthSun::DayOfYear(172);
//! let spectrum = query.compute()?;
//! // The direct/diffuse split per band, W/m².
//! for (start, end) in [(400.0, 500.0), (500.0, 600.0), (600.0, 700.0), (700.0, 2500.0)] {
//!     let band = spectrum.band(start, end)?;
//!     println!(
//!         "{start}-{end} nm: direct {:.1}, diffuse {:.1} W/m² ({:.0} % diffuse)",
//!         band.direct_horizontal,
//!         band.diffuse_horizontal,
//!         100.0 * band.diffuse_fraction()
//!     );
//! }
//! let all = spectrum.total(); // 300-4000 nm
//! assert!(all.direct_normal > 700.0 && all.direct_normal < 950.0);
//! // On a 5 nm grid for a spectral renderer.
//! let grid = UniformGrid::new(360.0, 2500.0, 5.0)?;
//! let resampled = spectrum.resample(&grid);
//! assert_eq!(resampled.direct_normal.len(), 429);
//! # Ok::<(), lamina_sky::Spectral2Error>(())
//! ```
//!
//! # The report and NREL's code
//! NREL's C implementation `spectrl2_2.c`, and pvlib's `pvlib.spectrum.spectrl2` that follows
//! it, differ from the report's printed equations in four places (pvlib's documentation lists
//! them). [`Formulation::Paper`], the default, is the report; [`Formulation::Pvlib`] is
//! pvlib 0.16.1, kept so that this code can be checked against pvlib to floating-point
//! precision:
//!
//! | | report ([`Formulation::Paper`]) | pvlib / `spectrl2_2.c` |
//! |---|---|---|
//! | Rayleigh, eq. 2-4 | `115.6406 − 1.335/λ²` | `115.6406 − 1.3366/λ²` |
//! | mixed gases, eq. 2-11 | `1 + 118.93 a_u M′` | `1 + 118.3 a_u M′` |
//! | sky reflectivity, eq. 3-8 | ozone: `T_o′ T_w′ T_aa′…` | mixed gases: `T_u′ T_w′ T_aa′…` |
//! | `C_s`, eqs. 3-5, 3-6, 3-1 | on `I_r` and `I_a` | on `I_r + I_a + I_g` |
//!
//! The last row differs only in the ground-reflected part of the direct beam below 450 nm.
//! The primed (`′`) transmittances of eq. 3-8 are those at an air mass of 1.8 (the report's
//! section 3.1): `M = 1.8`, and `M′ = 1.8 P/P₀` where the unprimed term uses `M′`, as pvlib
//! does; the ozone term `T_o′` takes an ozone mass of 1.8. (NREL's C code leaves the pressure
//! out of its primed terms, `M′ = 1.8` at any pressure; pvlib, and this code, do not.)
//!
//! # Air mass
//! The report uses Kasten's 1966 relative air mass (eq. 2-5, [`AirMass::Kasten1966`]);
//! NREL's later code and pvlib's default use Kasten & Young 1989
//! ([`AirMass::KastenYoung1989`], the default here), which is the better fit to the true air
//! mass near the horizon. The two agree within 0.13 % up to a zenith of 80° and 0.17 % up to
//! 85°; at 90° they give 36.5 and 37.9.
//!
//! # Units and conventions
//! Wavelengths in nm, spectral irradiance in W m⁻² nm⁻¹, band irradiance in W m⁻²; pressure
//! in hPa, precipitable water in cm, ozone in atm-cm; the zenith is the **apparent** solar
//! zenith in degrees ([`SolarPosition::zenith`], with refraction). The report's equations
//! take λ in µm; the code converts.

use thiserror::Error;

use crate::solar_position::SolarPosition;

/// The number of wavelengths the model is tabulated at.
pub const WAVELENGTH_COUNT: usize = 122;
const N: usize = WAVELENGTH_COUNT;

/// The shortest wavelength of the model, nm.
pub const MIN_WAVELENGTH: f64 = 300.0;
/// The longest wavelength of the model, nm.
pub const MAX_WAVELENGTH: f64 = 4000.0;

/// The relative optical air mass: the path through the atmosphere toward a sun at a given
/// zenith, relative to the path toward the zenith (at sea level, before the pressure
/// correction).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AirMass {
    /// Kasten & Young 1989 (*Revised optical air mass tables and approximation formula*,
    /// Applied Optics 28, 4735–4738): `M = 1 / (cos Z + 0.50572 (96.07995° − Z)^−1.6364)`, Z
    /// the apparent zenith in degrees. NREL's `spectrl2_2.c` and pvlib's default
    /// (`get_relative_airmass(..., model="kastenyoung1989")`).
    #[default]
    KastenYoung1989,
    /// Kasten 1966, the report's eq. 2-5: `M = 1 / (cos Z + 0.15 (93.885° − Z)^−1.253)`.
    Kasten1966,
}

impl AirMass {
    /// The relative air mass toward a sun at apparent zenith `zenith` degrees, `[0, 90]`
    /// (not validated here; above 90° the formulas have no meaning).
    pub fn relative(self, zenith: f64) -> f64 {
        let cos_z = zenith.to_radians().cos();
        match self {
            Self::KastenYoung1989 => 1.0 / (cos_z + 0.50572 * (96.07995 - zenith).powf(-1.6364)),
            Self::Kasten1966 => 1.0 / (cos_z + 0.15 * (93.885 - zenith).powf(-1.253)),
        }
    }
}

/// The Earth–sun distance, which scales the extraterrestrial spectrum by `D = (r₀/r)²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EarthSun {
    /// The day of the year, `1 ..= 366` (1 January = 1): `D` by Spencer's series, the report's
    /// eqs. 2-2 and 2-3, `D = 1.00011 + 0.034221 cos φ + 0.00128 sin φ + 0.000719 cos 2φ +
    /// 0.000077 sin 2φ` with the day angle `φ = 2π (d − 1)/365`.
    DayOfYear(u32),
    /// The distance in astronomical units, `[0.9, 1.1]` (the Earth's is 0.983–1.017):
    /// `D = 1/r²`. [`SolarPosition::earth_sun_distance`] gives it.
    Distance(f64),
}

impl Default for EarthSun {
    /// The mean distance, 1 AU (`D = 1`).
    fn default() -> Self {
        Self::Distance(1.0)
    }
}

impl EarthSun {
    /// The factor `D = (r₀/r)²` on the extraterrestrial spectrum (not validated here).
    pub fn factor(self) -> f64 {
        match self {
            Self::DayOfYear(day) => {
                let phi = 2.0 * std::f64::consts::PI * (f64::from(day) - 1.0) / 365.0;
                1.00011
                    + 0.034221 * phi.cos()
                    + 0.00128 * phi.sin()
                    + 0.000719 * (2.0 * phi).cos()
                    + 0.000077 * (2.0 * phi).sin()
            }
            Self::Distance(r) => 1.0 / (r * r),
        }
    }
}

/// Which version of the model's equations to evaluate (see the module documentation's
/// table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Formulation {
    /// The equations as the report prints them.
    #[default]
    Paper,
    /// pvlib 0.16.1's `pvlib.spectrum.spectrl2`, which follows NREL's `spectrl2_2.c`: the
    /// Rayleigh constant 1.3366, the mixed-gas constant 118.3, the mixed-gas term in the sky
    /// reflectivity, and `C_s` on the whole diffuse sum.
    Pvlib,
}

/// Everything the spectrum is computed from. [`Spectral2Query::new`] takes the zenith and
/// fills the rest with the defaults (the report's rural aerosol at an optical depth of 0.1,
/// sea level, the mean Earth–sun distance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spectral2Query {
    /// Apparent solar zenith (with refraction), degrees, `[0, 90]`: the sun must be above
    /// the horizon. [`SolarPosition::zenith`].
    pub zenith: f64,
    /// Surface air pressure, hPa, `[0, 1200]`; default [`Spectral2Query::DEFAULT_PRESSURE`].
    /// Scales the Rayleigh and mixed-gas air mass, `M′ = M P / 1013 hPa` (the report's `P₀`).
    pub pressure: f64,
    /// Precipitable water, cm, `[0, 20]`; default
    /// [`Spectral2Query::DEFAULT_PRECIPITABLE_WATER`].
    pub precipitable_water: f64,
    /// Total column ozone, atm-cm (1 atm-cm = 1000 Dobson units), `[0, 1]`; default
    /// [`Spectral2Query::DEFAULT_OZONE`].
    pub ozone: f64,
    /// Aerosol optical depth at 500 nm (base e), `[0, 10]`; default
    /// [`Spectral2Query::DEFAULT_AOD500`]. At other wavelengths `τ_a = aod500 (λ/500 nm)^−α`
    /// (eq. 2-7).
    pub aod500: f64,
    /// Ångström exponent `α` of the aerosol optical depth, `[-1, 4]`; default
    /// [`Spectral2Query::DEFAULT_ANGSTROM_EXPONENT`].
    pub angstrom_exponent: f64,
    /// Aerosol asymmetry factor (mean cosine of the scattering angle), `[0, 1)`; default
    /// [`Spectral2Query::DEFAULT_ASYMMETRY`]. Sets the forward-scattered fraction `F_s`
    /// (eqs. 3-11 to 3-15).
    pub asymmetry: f64,
    /// Aerosol single-scattering albedo at 400 nm, `[0, 1]`; default
    /// [`Spectral2Query::DEFAULT_SINGLE_SCATTERING_ALBEDO`].
    pub single_scattering_albedo: f64,
    /// The wavelength variation `ω′` of the single-scattering albedo, `[0, 1]`: `ω(λ) =
    /// ω₀.₄ exp(−ω′ ln²(λ/400 nm))` (eq. 3-16); default
    /// [`Spectral2Query::DEFAULT_ALBEDO_WAVELENGTH_VARIATION`].
    pub albedo_wavelength_variation: f64,
    /// Ground albedo (the same at every wavelength), `[0, 1]`; default
    /// [`Spectral2Query::DEFAULT_GROUND_ALBEDO`]. Only the ground–sky reflections `I_g` use
    /// it.
    pub ground_albedo: f64,
    /// The Earth–sun distance, as a day of the year or in AU; default 1 AU.
    pub earth_sun: EarthSun,
    /// The relative air mass formula; default [`AirMass::KastenYoung1989`].
    pub air_mass: AirMass,
    /// The report's equations or pvlib's; default [`Formulation::Paper`].
    pub formulation: Formulation,
}

impl Spectral2Query {
    /// Default pressure, hPa: the standard atmosphere at sea level.
    pub const DEFAULT_PRESSURE: f64 = 1013.25;
    /// Default precipitable water, cm.
    pub const DEFAULT_PRECIPITABLE_WATER: f64 = 1.42;
    /// Default ozone, atm-cm (344 Dobson units).
    pub const DEFAULT_OZONE: f64 = 0.344;
    /// Default aerosol optical depth at 500 nm: a clear day.
    pub const DEFAULT_AOD500: f64 = 0.1;
    /// Default Ångström exponent: the report's rural aerosol.
    pub const DEFAULT_ANGSTROM_EXPONENT: f64 = 1.14;
    /// Default aerosol asymmetry factor: the report's rural aerosol.
    pub const DEFAULT_ASYMMETRY: f64 = 0.65;
    /// Default single-scattering albedo at 400 nm: the report's rural aerosol.
    pub const DEFAULT_SINGLE_SCATTERING_ALBEDO: f64 = 0.945;
    /// Default wavelength variation of the single-scattering albedo: the report's rural
    /// aerosol.
    pub const DEFAULT_ALBEDO_WAVELENGTH_VARIATION: f64 = 0.095;
    /// Default ground albedo.
    pub const DEFAULT_GROUND_ALBEDO: f64 = 0.2;

    /// A query for a sun at apparent zenith `zenith` degrees, with every other input at its
    /// default.
    pub fn new(zenith: f64) -> Self {
        Self {
            zenith,
            pressure: Self::DEFAULT_PRESSURE,
            precipitable_water: Self::DEFAULT_PRECIPITABLE_WATER,
            ozone: Self::DEFAULT_OZONE,
            aod500: Self::DEFAULT_AOD500,
            angstrom_exponent: Self::DEFAULT_ANGSTROM_EXPONENT,
            asymmetry: Self::DEFAULT_ASYMMETRY,
            single_scattering_albedo: Self::DEFAULT_SINGLE_SCATTERING_ALBEDO,
            albedo_wavelength_variation: Self::DEFAULT_ALBEDO_WAVELENGTH_VARIATION,
            ground_albedo: Self::DEFAULT_GROUND_ALBEDO,
            earth_sun: EarthSun::default(),
            air_mass: AirMass::default(),
            formulation: Formulation::default(),
        }
    }

    /// A query for the sun at `sun`: its apparent zenith and its Earth–sun distance, every
    /// other input at its default.
    pub fn for_sun(sun: &SolarPosition) -> Self {
        Self {
            earth_sun: EarthSun::Distance(sun.earth_sun_distance),
            ..Self::new(sun.zenith)
        }
    }

    /// The spectrum for this query ([`spectral2`]).
    pub fn compute(&self) -> Result<Spectral2Spectrum, Spectral2Error> {
        spectral2(self)
    }
}

/// An input outside its range: a [`Spectral2Query`] field, or an argument of
/// [`UniformGrid::new`] or [`Spectral2Spectrum::band`]. Each names it
/// ([`Spectral2Error::field`]).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Spectral2Error {
    /// NaN or infinite.
    #[error("{field} is {value}, not a finite number")]
    NotFinite {
        /// The field or argument.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// Outside the range the model (or the wavelength range) takes.
    #[error("{field} = {value} is outside {range}")]
    OutOfRange {
        /// The field or argument.
        field: &'static str,
        /// Its value.
        value: f64,
        /// The range it takes, as text.
        range: &'static str,
    },
}

impl Spectral2Error {
    /// The name of the field or argument at fault: a [`Spectral2Query`] field's own name
    /// (`zenith`, `pressure`, ..., `earth_sun` for either kind of distance), or `start`,
    /// `end`, `step` for the wavelength arguments.
    pub fn field(&self) -> &'static str {
        match self {
            Self::NotFinite { field, .. } | Self::OutOfRange { field, .. } => field,
        }
    }
}

/// Checks that `value` is finite and within `[lo, hi]`.
fn check(
    field: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    range: &'static str,
) -> Result<(), Spectral2Error> {
    crate::input::check(field, value, lo, hi, range)
}

impl crate::input::InputError for Spectral2Error {
    fn not_finite(field: &'static str, value: f64) -> Self {
        Spectral2Error::NotFinite { field, value }
    }
    fn out_of_range(field: &'static str, value: f64, range: &'static str) -> Self {
        Spectral2Error::OutOfRange {
            field,
            value,
            range,
        }
    }
}

/// Validates every field of `q`, in the order they are declared.
fn validate(q: &Spectral2Query) -> Result<(), Spectral2Error> {
    // ln(1 − g) (eq. 3-14) needs g < 1: the largest f64 below 1 is 1 − ε/2.
    let below_one = 1.0 - f64::EPSILON / 2.0;
    #[rustfmt::skip]
    let fields = [
        ("zenith", q.zenith, 0.0, 90.0, "[0, 90] degrees (the sun above the horizon)"),
        ("pressure", q.pressure, 0.0, 1200.0, "[0, 1200] hPa"),
        ("precipitable_water", q.precipitable_water, 0.0, 20.0, "[0, 20] cm"),
        ("ozone", q.ozone, 0.0, 1.0, "[0, 1] atm-cm"),
        ("aod500", q.aod500, 0.0, 10.0, "[0, 10]"),
        ("angstrom_exponent", q.angstrom_exponent, -1.0, 4.0, "[-1, 4]"),
        ("asymmetry", q.asymmetry, 0.0, below_one, "[0, 1)"),
        ("single_scattering_albedo", q.single_scattering_albedo, 0.0, 1.0, "[0, 1]"),
        ("albedo_wavelength_variation", q.albedo_wavelength_variation, 0.0, 1.0, "[0, 1]"),
        ("ground_albedo", q.ground_albedo, 0.0, 1.0, "[0, 1]"),
    ];
    for (field, value, lo, hi, range) in fields {
        check(field, value, lo, hi, range)?;
    }
    match q.earth_sun {
        EarthSun::DayOfYear(day) => {
            if !(1..=366).contains(&day) {
                return Err(Spectral2Error::OutOfRange {
                    field: "earth_sun",
                    value: f64::from(day),
                    range: "day of year 1 ..= 366",
                });
            }
        }
        EarthSun::Distance(r) => check("earth_sun", r, 0.9, 1.1, "distance [0.9, 1.1] AU")?,
    }
    Ok(())
}

/// The model's output on its [`WAVELENGTHS`]: spectral irradiance, W m⁻² nm⁻¹, per
/// wavelength.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectral2Spectrum {
    /// The relative air mass `M` used (before the pressure correction).
    pub relative_air_mass: f64,
    /// The extraterrestrial spectrum at the query's Earth–sun distance, `H₀ D`, normal to
    /// the sun.
    pub extraterrestrial: [f64; N],
    /// Direct normal irradiance `I_d` (eq. 2-1), on a plane facing the sun.
    pub direct_normal: [f64; N],
    /// Direct horizontal irradiance, `I_d cos Z`.
    pub direct_horizontal: [f64; N],
    /// Diffuse horizontal irradiance `I_s` (eq. 3-1): the whole sky, without the direct
    /// beam. NREL's description of the model takes the direct beam to hold the circumsolar
    /// light within a 5° field of view (a pyrheliometer's); the diffuse does not.
    pub diffuse_horizontal: [f64; N],
}

/// One band's irradiance, W m⁻²: the spectra integrated over `[start, end]` nm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandIrradiance {
    /// The band's lower edge, nm.
    pub start: f64,
    /// The band's upper edge, nm.
    pub end: f64,
    /// Direct normal irradiance in the band.
    pub direct_normal: f64,
    /// Direct horizontal irradiance in the band.
    pub direct_horizontal: f64,
    /// Diffuse horizontal irradiance in the band.
    pub diffuse_horizontal: f64,
}

impl BandIrradiance {
    /// Global horizontal irradiance in the band: direct horizontal + diffuse horizontal.
    pub fn global_horizontal(&self) -> f64 {
        self.direct_horizontal + self.diffuse_horizontal
    }

    /// The diffuse share of the global horizontal irradiance, `[0, 1]` (0 where there is
    /// none).
    pub fn diffuse_fraction(&self) -> f64 {
        let global = self.global_horizontal();
        if global > 0.0 {
            self.diffuse_horizontal / global
        } else {
            0.0
        }
    }
}

/// A uniform wavelength grid inside the model's range: `start, start + step, ...` up to
/// `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformGrid {
    start: f64,
    step: f64,
    len: usize,
}

impl UniformGrid {
    /// Most samples a grid may have.
    pub const MAX_LEN: usize = 1_000_000;

    /// The grid `start, start + step, ...`, the last point the largest not above `end`
    /// (`end` itself when `end − start` is a whole number of steps, within 1e-9 of a step).
    /// `start` and `end` must lie in `[300, 4000]` nm with `start ≤ end`; `step` must be
    /// positive and give at most [`UniformGrid::MAX_LEN`] samples. `UniformGrid::new(360.0,
    /// 2500.0, 5.0)` has 429.
    pub fn new(start: f64, end: f64, step: f64) -> Result<Self, Spectral2Error> {
        check_band(start, end)?;
        check("step", step, f64::MIN_POSITIVE, f64::MAX, "(0, ∞) nm")?;
        let steps = ((end - start) / step + 1e-9).floor();
        if steps >= Self::MAX_LEN as f64 {
            return Err(Spectral2Error::OutOfRange {
                field: "step",
                value: step,
                range: "steps giving at most 1000000 samples",
            });
        }
        Ok(Self {
            start,
            step,
            len: steps as usize + 1,
        })
    }

    /// The first wavelength, nm.
    pub fn start(&self) -> f64 {
        self.start
    }

    /// The spacing, nm.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// The number of wavelengths.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the grid is empty (never: it has at least `start`).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The `i`th wavelength, nm: `start + i step`.
    pub fn wavelength(&self, i: usize) -> f64 {
        self.start + i as f64 * self.step
    }

    /// The wavelengths, nm.
    pub fn wavelengths(&self) -> impl ExactSizeIterator<Item = f64> + '_ {
        (0..self.len).map(|i| self.wavelength(i))
    }
}

/// A [`Spectral2Spectrum`] on a [`UniformGrid`], W m⁻² nm⁻¹ at each of the grid's
/// wavelengths.
#[derive(Debug, Clone, PartialEq)]
pub struct ResampledSpectrum {
    /// The grid.
    pub grid: UniformGrid,
    /// Direct normal irradiance.
    pub direct_normal: Vec<f64>,
    /// Direct horizontal irradiance.
    pub direct_horizontal: Vec<f64>,
    /// Diffuse horizontal irradiance.
    pub diffuse_horizontal: Vec<f64>,
}

/// Checks a band `[start, end]` inside the model's range.
fn check_band(start: f64, end: f64) -> Result<(), Spectral2Error> {
    check(
        "start",
        start,
        MIN_WAVELENGTH,
        MAX_WAVELENGTH,
        "[300, 4000] nm",
    )?;
    check("end", end, start, MAX_WAVELENGTH, "[start, 4000] nm")
}

/// The index `i` of the model's interval `[λᵢ, λᵢ₊₁]` holding `wavelength` (clamped to the
/// model's range).
fn interval(wavelength: f64) -> usize {
    WAVELENGTHS
        .partition_point(|&l| l <= wavelength)
        .clamp(1, N - 1)
        - 1
}

/// `values` at `wavelength` by linear interpolation between the model's wavelengths
/// (`wavelength` clamped to `[300, 4000]` nm).
fn interpolate(values: &[f64; N], wavelength: f64) -> f64 {
    let w = wavelength.clamp(MIN_WAVELENGTH, MAX_WAVELENGTH);
    let i = interval(w);
    let (x0, x1) = (WAVELENGTHS[i], WAVELENGTHS[i + 1]);
    let t = (w - x0) / (x1 - x0);
    values[i] + t * (values[i + 1] - values[i])
}

/// The integral over `[start, end]` (inside the model's range) of the linear interpolant
/// of `values`: the trapezoid rule on the model's wavelengths, exact on partial intervals.
fn integrate(values: &[f64; N], start: f64, end: f64) -> f64 {
    if end <= start {
        return 0.0;
    }
    let mut sum = 0.0;
    for i in interval(start)..=interval(end) {
        let lo = start.max(WAVELENGTHS[i]);
        let hi = end.min(WAVELENGTHS[i + 1]);
        if hi > lo {
            sum += 0.5 * (hi - lo) * (interpolate(values, lo) + interpolate(values, hi));
        }
    }
    sum
}

impl Spectral2Spectrum {
    /// The model's wavelengths, nm ([`WAVELENGTHS`]).
    pub fn wavelengths(&self) -> &'static [f64; N] {
        &WAVELENGTHS
    }

    /// Global horizontal irradiance per wavelength: direct horizontal + diffuse horizontal.
    pub fn global_horizontal(&self) -> [f64; N] {
        std::array::from_fn(|i| self.direct_horizontal[i] + self.diffuse_horizontal[i])
    }

    /// The irradiance in the band `[start, end]` nm, W m⁻²: the integral of the linear
    /// interpolation between the model's wavelengths (the trapezoid rule on them). `start`
    /// and `end` must lie in `[300, 4000]` nm with `start ≤ end`.
    pub fn band(&self, start: f64, end: f64) -> Result<BandIrradiance, Spectral2Error> {
        check_band(start, end)?;
        Ok(BandIrradiance {
            start,
            end,
            direct_normal: integrate(&self.direct_normal, start, end),
            direct_horizontal: integrate(&self.direct_horizontal, start, end),
            diffuse_horizontal: integrate(&self.diffuse_horizontal, start, end),
        })
    }

    /// The irradiance over the model's whole range, 300–4000 nm, W m⁻².
    pub fn total(&self) -> BandIrradiance {
        self.band(MIN_WAVELENGTH, MAX_WAVELENGTH)
            .expect("the model's range is a valid band")
    }

    /// The spectra on `grid`, by linear interpolation between the model's wavelengths.
    pub fn resample(&self, grid: &UniformGrid) -> ResampledSpectrum {
        let on_grid =
            |values: &[f64; N]| grid.wavelengths().map(|w| interpolate(values, w)).collect();
        ResampledSpectrum {
            grid: *grid,
            direct_normal: on_grid(&self.direct_normal),
            direct_horizontal: on_grid(&self.direct_horizontal),
            diffuse_horizontal: on_grid(&self.diffuse_horizontal),
        }
    }
}

/// The report's reference pressure `P₀`, hPa (eq. 2-5's pressure correction).
const REFERENCE_PRESSURE: f64 = 1013.0;
/// Height of the ozone layer's maximum, km (eq. 2-10).
const OZONE_HEIGHT: f64 = 22.0;
/// The Earth's radius in eq. 2-10, km.
const EARTH_RADIUS: f64 = 6370.0;
/// The air mass of the primed transmittances in the sky reflectivity (eq. 3-8).
const PRIMED_AIR_MASS: f64 = 1.8;

/// Water vapour transmittance (eq. 2-8) for absorption coefficient `a_w`, precipitable
/// water `w` cm and air mass `m`.
fn water_transmittance(a_w: f64, w: f64, m: f64) -> f64 {
    let x = a_w * w * m;
    (-0.2385 * x / (1.0 + 20.07 * x).powf(0.45)).exp()
}

/// Uniformly mixed gas transmittance (eq. 2-11) for absorption coefficient `a_u`,
/// pressure-corrected air mass `m_p` and the formulation's constant `k` (118.93 or 118.3).
fn mixed_gas_transmittance(a_u: f64, m_p: f64, k: f64) -> f64 {
    let x = a_u * m_p;
    (-1.41 * x / (1.0 + k * x).powf(0.45)).exp()
}

/// The clear-sky spectrum of SPCTRAL2 for `q`, after validating every field.
pub fn spectral2(q: &Spectral2Query) -> Result<Spectral2Spectrum, Spectral2Error> {
    validate(q)?;
    let paper = q.formulation == Formulation::Paper;
    // Eq. 2-4's 1.335 and eq. 2-11's 118.93 in the report; 1.3366 and 118.3 in NREL's code.
    let (rayleigh_k, mixed_k) = if paper {
        (1.335, 118.93)
    } else {
        (1.3366, 118.3)
    };

    let cos_z = q.zenith.to_radians().cos().max(0.0);
    let d = q.earth_sun.factor(); // eqs. 2-2, 2-3
    let m = q.air_mass.relative(q.zenith); // eq. 2-5
    let m_p = m * q.pressure / REFERENCE_PRESSURE;
    let m_p_primed = PRIMED_AIR_MASS * q.pressure / REFERENCE_PRESSURE;
    // Eq. 2-10: the ozone mass, the path through a thin layer at 22 km.
    let h = OZONE_HEIGHT / EARTH_RADIUS;
    let m_o = (1.0 + h) / (cos_z * cos_z + 2.0 * h).sqrt();

    // The aerosol's forward-scattered fraction: eqs. 3-14, 3-12, 3-13, 3-11, 3-15.
    let alg = (1.0 - q.asymmetry).ln();
    let afs = alg * (1.459 + alg * (0.1595 + alg * 0.4129));
    let bfs = alg * (0.0783 + alg * (-0.3824 - alg * 0.5874));
    let f_s = 1.0 - 0.5 * ((afs + bfs * cos_z) * cos_z).exp();
    let f_s_primed = 1.0 - 0.5 * ((afs + bfs / PRIMED_AIR_MASS) / PRIMED_AIR_MASS).exp();

    let mut out = Spectral2Spectrum {
        relative_air_mass: m,
        extraterrestrial: [0.0; N],
        direct_normal: [0.0; N],
        direct_horizontal: [0.0; N],
        diffuse_horizontal: [0.0; N],
    };
    for i in 0..N {
        let l = WAVELENGTHS[i] / 1000.0; // µm, as in the report's equations
        let h0 = EXTRATERRESTRIAL[i] * d;
        let (a_w, a_o, a_u) = (WATER_VAPOR[i], OZONE[i], MIXED_GAS[i]);

        // Eq. 2-4: Rayleigh optical depth per unit pressure-corrected air mass.
        let tau_r = 1.0 / (l.powi(4) * (115.6406 - rayleigh_k / (l * l)));
        let t_r = (-m_p * tau_r).exp();
        // Eqs. 2-6, 2-7: aerosol extinction.
        let tau_a = q.aod500 * (l / 0.5).powf(-q.angstrom_exponent);
        let t_a = (-tau_a * m).exp();
        let t_w = water_transmittance(a_w, q.precipitable_water, m); // eq. 2-8
        let t_o = (-a_o * q.ozone * m_o).exp(); // eq. 2-9
        let t_u = mixed_gas_transmittance(a_u, m_p, mixed_k); // eq. 2-11

        // Eq. 3-16: the single-scattering albedo; eqs. 3-9, 3-10: the aerosol's scattering
        // and absorption transmittances.
        let omega = q.single_scattering_albedo
            * (-q.albedo_wavelength_variation * (l / 0.4).ln().powi(2)).exp();
        let t_as = (-omega * tau_a * m).exp();
        let t_aa = (-(1.0 - omega) * tau_a * m).exp();

        // Eq. 3-8: the sky's reflectivity for light coming up from the ground, from the
        // transmittances at M = 1.8.
        let t_r_p = (-m_p_primed * tau_r).exp();
        let t_w_p = water_transmittance(a_w, q.precipitable_water, PRIMED_AIR_MASS);
        let t_as_p = (-omega * tau_a * PRIMED_AIR_MASS).exp();
        let t_aa_p = (-(1.0 - omega) * tau_a * PRIMED_AIR_MASS).exp();
        let gas_p = if paper {
            (-a_o * q.ozone * PRIMED_AIR_MASS).exp() // T_o′, the report
        } else {
            mixed_gas_transmittance(a_u, m_p_primed, mixed_k) // T_u′, NREL's code
        };
        let r_s = gas_p
            * t_w_p
            * t_aa_p
            * (0.5 * (1.0 - t_r_p) + (1.0 - f_s_primed) * t_r_p * (1.0 - t_as_p));

        // Eq. 2-1: direct normal.
        let i_d = h0 * t_r * t_a * t_w * t_o * t_u;

        // Eq. 3-17: the ultraviolet correction.
        let c_s = if WAVELENGTHS[i] <= 450.0 {
            (l + 0.55).powf(1.8)
        } else {
            1.0
        };
        // Eqs. 3-5, 3-6: Rayleigh- and aerosol-scattered light reaching the ground.
        let common = h0 * cos_z * t_o * t_u * t_w * t_aa;
        let mut i_r = common * (1.0 - t_r.powf(0.95)) * 0.5;
        let mut i_a = common * t_r.powf(1.5) * (1.0 - t_as) * f_s;
        if paper {
            i_r *= c_s;
            i_a *= c_s;
        }
        // Eq. 3-7: multiple reflections between the ground and the sky.
        let rg = q.ground_albedo;
        let i_g = (i_d * cos_z + i_r + i_a) * r_s * rg / (1.0 - r_s * rg);
        // Eq. 3-1.
        let i_s = if paper {
            i_r + i_a + i_g
        } else {
            (i_r + i_a + i_g) * c_s
        };

        out.extraterrestrial[i] = h0;
        out.direct_normal[i] = i_d;
        out.direct_horizontal[i] = i_d * cos_z;
        out.diffuse_horizontal[i] = i_s;
    }
    Ok(out)
}

/// The model's 122 wavelengths, nm (the report's Table 2-1; 5 nm apart in the ultraviolet,
/// about 10 nm in the visible, placed on absorption bands in the infrared).
#[rustfmt::skip]
pub const WAVELENGTHS: [f64; N] = [
    300.0, 305.0, 310.0, 315.0, 320.0, 325.0, 330.0, 335.0, 340.0, 345.0,
    350.0, 360.0, 370.0, 380.0, 390.0, 400.0, 410.0, 420.0, 430.0, 440.0,
    450.0, 460.0, 470.0, 480.0, 490.0, 500.0, 510.0, 520.0, 530.0, 540.0,
    550.0, 570.0, 593.0, 610.0, 630.0, 656.0, 667.6, 690.0, 710.0, 718.0,
    724.4, 740.0, 752.5, 757.5, 762.5, 767.5, 780.0, 800.0, 816.0, 823.7,
    831.5, 840.0, 860.0, 880.0, 905.0, 915.0, 925.0, 930.0, 937.0, 948.0,
    965.0, 980.0, 993.5, 1040.0, 1070.0, 1100.0, 1120.0, 1130.0, 1145.0, 1161.0,
    1170.0, 1200.0, 1240.0, 1270.0, 1290.0, 1320.0, 1350.0, 1395.0, 1442.5, 1462.5,
    1477.0, 1497.0, 1520.0, 1539.0, 1558.0, 1578.0, 1592.0, 1610.0, 1630.0, 1646.0,
    1678.0, 1740.0, 1800.0, 1860.0, 1920.0, 1960.0, 1985.0, 2005.0, 2035.0, 2065.0,
    2100.0, 2148.0, 2198.0, 2270.0, 2360.0, 2450.0, 2500.0, 2600.0, 2700.0, 2800.0,
    2900.0, 3000.0, 3100.0, 3200.0, 3300.0, 3400.0, 3500.0, 3600.0, 3700.0, 3800.0,
    3900.0, 4000.0,
];

/// The extraterrestrial spectrum at the mean Earth–sun distance, `H₀`, W m⁻² nm⁻¹ at each of
/// [`WAVELENGTHS`]: the report's Table 2-1 (Fröhlich & Wehrli's WRC spectrum, after Neckel &
/// Labs, at 10 nm resolution; NREL's code lists it in W m⁻² µm⁻¹).
#[rustfmt::skip]
pub const EXTRATERRESTRIAL: [f64; N] = [
    0.5359, 0.5583, 0.622, 0.6927, 0.7151, 0.8329, 0.9619, 0.9319, 0.9006, 0.9113,
    0.9755, 0.9759, 1.1199, 1.1038, 1.0338, 1.4791, 1.7013, 1.7404, 1.5872, 1.837,
    2.005, 2.043, 1.987, 2.027, 1.896, 1.909, 1.927, 1.831, 1.891, 1.898,
    1.892, 1.84, 1.768, 1.728, 1.658, 1.524, 1.531, 1.42, 1.399, 1.374,
    1.373, 1.298, 1.269, 1.245, 1.223, 1.205, 1.183, 1.148, 1.091, 1.062,
    1.038, 1.022, 0.9987, 0.9472, 0.8932, 0.8682, 0.8297, 0.8303, 0.814, 0.7869,
    0.7683, 0.767, 0.7576, 0.6881, 0.6407, 0.6062, 0.5859, 0.5702, 0.5641, 0.5442,
    0.5334, 0.5016, 0.4775, 0.4427, 0.44, 0.4168, 0.3914, 0.3589, 0.3275, 0.3175,
    0.3073, 0.3004, 0.2928, 0.2755, 0.2721, 0.2593, 0.2469, 0.244, 0.2435, 0.2348,
    0.2205, 0.1908, 0.1711, 0.1445, 0.1357, 0.123, 0.1238, 0.113, 0.1085, 0.0975,
    0.0924, 0.0824, 0.0746, 0.0683, 0.0638, 0.0495, 0.0485, 0.0386, 0.0366, 0.032,
    0.0281, 0.0248, 0.0221, 0.0196, 0.0175, 0.0157, 0.0141, 0.0127, 0.0115, 0.0104,
    0.0095, 0.0086,
];

/// Water vapour absorption coefficients `a_w` (eq. 2-8), the report's Table 2-1.
#[rustfmt::skip]
const WATER_VAPOR: [f64; N] = [
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.075, 0.0, 0.0, 0.0, 0.0, 0.016, 0.0125, 1.8,
    2.5, 0.061, 0.0008, 0.0001, 0.00001, 0.00001, 0.0006, 0.036, 1.6, 2.5,
    0.5, 0.155, 0.00001, 0.0026, 7.0, 5.0, 5.0, 27.0, 55.0, 45.0,
    4.0, 1.48, 0.1, 0.00001, 0.001, 3.2, 115.0, 70.0, 75.0, 10.0,
    5.0, 2.0, 0.002, 0.002, 0.1, 4.0, 200.0, 1000.0, 185.0, 80.0,
    80.0, 12.0, 0.16, 0.002, 0.0005, 0.0001, 0.00001, 0.0001, 0.001, 0.01,
    0.036, 1.1, 130.0, 1000.0, 500.0, 100.0, 4.0, 2.9, 1.0, 0.4,
    0.22, 0.25, 0.33, 0.5, 4.0, 80.0, 310.0, 15000.0, 22000.0, 8000.0,
    650.0, 240.0, 230.0, 100.0, 120.0, 19.5, 3.6, 3.1, 2.5, 1.4,
    0.17, 0.0045,
];

/// Ozone absorption coefficients `a_o`, cm⁻¹ (eq. 2-9), the report's Table 2-1.
#[rustfmt::skip]
const OZONE: [f64; N] = [
    10.0, 4.8, 2.7, 1.35, 0.8, 0.38, 0.16, 0.075, 0.04, 0.019,
    0.007, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.003, 0.006, 0.009, 0.014, 0.021, 0.03, 0.04, 0.048, 0.063, 0.075,
    0.085, 0.12, 0.119, 0.12, 0.09, 0.065, 0.051, 0.028, 0.018, 0.015,
    0.012, 0.01, 0.008, 0.007, 0.006, 0.005, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0,
];

/// Uniformly mixed gas absorption coefficients `a_u` (eq. 2-11), the report's Table 2-1.
#[rustfmt::skip]
const MIXED_GAS: [f64; N] = [
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.15, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 4.0, 0.35, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.05, 0.3, 0.02, 0.0002, 0.00011, 0.00001, 0.05, 0.011,
    0.005, 0.0006, 0.0, 0.005, 0.13, 0.04, 0.06, 0.13, 0.001, 0.0014,
    0.0001, 0.00001, 0.00001, 0.0001, 0.001, 4.3, 0.2, 21.0, 0.13, 1.0,
    0.08, 0.001, 0.00038, 0.001, 0.0005, 0.00015, 0.00014, 0.00066, 100.0, 150.0,
    0.13, 0.0095, 0.001, 0.8, 1.9, 1.3, 0.075, 0.01, 0.00195, 0.004,
    0.29, 0.025,
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solar_position::{LocalTime, Observer, SolarQuery, solar_position};

    /// The wavelengths the pvlib references are given at, nm.
    const REFERENCE_WAVELENGTHS: [f64; 8] =
        [300.0, 400.0, 450.0, 550.0, 762.5, 937.0, 1240.0, 2198.0];

    /// One reference case: pvlib 0.16.1's `spectrl2` on a horizontal surface
    /// (`scripts/spectral2_reference.py`), at [`REFERENCE_WAVELENGTHS`], and its 300–4000 nm
    /// trapezoid integrals `[direct normal, direct horizontal, diffuse horizontal]`, W m⁻².
    struct PvlibCase {
        name: &'static str,
        zenith: f64,
        day_of_year: u32,
        pressure: f64,
        precipitable_water: f64,
        ozone: f64,
        aod500: f64,
        alpha: f64,
        asymmetry: f64,
        ssa400: f64,
        ssa_variation: f64,
        ground_albedo: f64,
        air_mass: AirMass,
        relative_air_mass: f64,
        dni: [f64; 8],
        direct_h: [f64; 8],
        diffuse_h: [f64; 8],
        integrals: [f64; 3],
    }

    impl PvlibCase {
        fn query(&self, formulation: Formulation) -> Spectral2Query {
            Spectral2Query {
                zenith: self.zenith,
                pressure: self.pressure,
                precipitable_water: self.precipitable_water,
                ozone: self.ozone,
                aod500: self.aod500,
                angstrom_exponent: self.alpha,
                asymmetry: self.asymmetry,
                single_scattering_albedo: self.ssa400,
                albedo_wavelength_variation: self.ssa_variation,
                ground_albedo: self.ground_albedo,
                earth_sun: EarthSun::DayOfYear(self.day_of_year),
                air_mass: self.air_mass,
                formulation,
            }
        }
    }

    fn pvlib_cases() -> Vec<PvlibCase> {
        vec![
            // Generated by crates/lamina-sky/scripts/spectral2_reference.py
            // (pvlib 0.16.1).
            PvlibCase {
                name: "zenith 0, defaults, 21 June",
                zenith: 0.0,
                day_of_year: 172,
                pressure: 1013.25,
                precipitable_water: 1.42,
                ozone: 0.344,
                aod500: 0.1,
                alpha: 1.14,
                asymmetry: 0.65,
                ssa400: 0.945,
                ssa_variation: 0.095,
                ground_albedo: 0.2,
                air_mass: AirMass::KastenYoung1989,
                relative_air_mass: 9.9971199186e-01,
                dni: [
                    4.0837283822e-03,
                    8.7400106645e-01,
                    1.3842317122e+00,
                    1.4730944992e+00,
                    7.6018435696e-01,
                    3.7587903059e-01,
                    4.3099274617e-01,
                    6.8082166565e-02,
                ],
                direct_h: [
                    4.0837283822e-03,
                    8.7400106645e-01,
                    1.3842317122e+00,
                    1.4730944992e+00,
                    7.6018435696e-01,
                    3.7587903059e-01,
                    4.3099274617e-01,
                    6.8082166565e-02,
                ],
                diffuse_h: [
                    5.2216908108e-03,
                    3.2484747884e-01,
                    3.7537032588e-01,
                    2.2461987495e-01,
                    5.3299858691e-02,
                    1.7756528342e-02,
                    1.3622890268e-02,
                    8.9640402326e-04,
                ],
                integrals: [9.5553660622e+02, 9.5553660622e+02, 1.1472112014e+02],
            },
            PvlibCase {
                name: "zenith 30, hazy and humid, 1 January",
                zenith: 30.0,
                day_of_year: 1,
                pressure: 1013.25,
                precipitable_water: 3.5,
                ozone: 0.344,
                aod500: 0.3,
                alpha: 1.3,
                asymmetry: 0.65,
                ssa400: 0.945,
                ssa_variation: 0.095,
                ground_albedo: 0.2,
                air_mass: AirMass::KastenYoung1989,
                relative_air_mass: 1.1539922334e+00,
                dni: [
                    1.3025346933e-03,
                    6.3312336411e-01,
                    1.0765222975e+00,
                    1.2449446203e+00,
                    6.8508164642e-01,
                    2.1328112978e-01,
                    4.2769933870e-01,
                    6.8292340802e-02,
                ],
                direct_h: [
                    1.1280281337e-03,
                    5.4830091705e-01,
                    9.3229565736e-01,
                    1.0781536675e+00,
                    5.9329810946e-01,
                    1.8470687654e-01,
                    3.7039849249e-01,
                    5.9142902018e-02,
                ],
                diffuse_h: [
                    3.0602541263e-03,
                    4.4272316456e-01,
                    5.8502072733e-01,
                    4.2068881105e-01,
                    1.1898161219e-01,
                    2.5150699288e-02,
                    3.3287238153e-02,
                    2.0572907277e-03,
                ],
                integrals: [8.2207584377e+02, 7.1193856454e+02, 1.9903189098e+02],
            },
            PvlibCase {
                name: "zenith 60, clean and dry high site, 10 April",
                zenith: 60.0,
                day_of_year: 100,
                pressure: 850.0,
                precipitable_water: 0.5,
                ozone: 0.3,
                aod500: 0.05,
                alpha: 0.9,
                asymmetry: 0.7,
                ssa400: 0.9,
                ssa_variation: 0.05,
                ground_albedo: 0.35,
                air_mass: AirMass::KastenYoung1989,
                relative_air_mass: 1.9942928525e+00,
                dni: [
                    1.5461283810e-04,
                    7.0919361378e-01,
                    1.2288570365e+00,
                    1.3872422148e+00,
                    6.7974969013e-01,
                    4.2967818009e-01,
                    4.3429973678e-01,
                    7.0032198488e-02,
                ],
                direct_h: [
                    7.7306419049e-05,
                    3.5459680689e-01,
                    6.1442851827e-01,
                    6.9362110738e-01,
                    3.3987484507e-01,
                    2.1483909004e-01,
                    2.1714986839e-01,
                    3.5016099244e-02,
                ],
                diffuse_h: [
                    2.7214769902e-04,
                    2.0909889135e-01,
                    2.3598338353e-01,
                    1.3155732867e-01,
                    2.6837929660e-02,
                    1.1583881851e-02,
                    8.0034052959e-03,
                    6.4416989472e-04,
                ],
                integrals: [9.3424911275e+02, 4.6712455638e+02, 6.9302344011e+01],
            },
            PvlibCase {
                name: "zenith 80, defaults, 27 October",
                zenith: 80.0,
                day_of_year: 300,
                pressure: 1013.25,
                precipitable_water: 1.42,
                ozone: 0.344,
                aod500: 0.1,
                alpha: 1.14,
                asymmetry: 0.65,
                ssa400: 0.945,
                ssa_variation: 0.095,
                ground_albedo: 0.2,
                air_mass: AirMass::KastenYoung1989,
                relative_air_mass: 5.5860358799e+00,
                dni: [
                    3.4738045765e-12,
                    9.5315036272e-02,
                    3.0836101524e-01,
                    5.7573511966e-01,
                    3.0225221703e-01,
                    1.0226994020e-01,
                    3.5727630094e-01,
                    6.1112741110e-02,
                ],
                direct_h: [
                    6.0321983428e-13,
                    1.6551282353e-02,
                    5.3546328360e-02,
                    9.9975354348e-02,
                    5.2485546683e-02,
                    1.7758988746e-02,
                    6.2040378582e-02,
                    1.0612116126e-02,
                ],
                diffuse_h: [
                    5.9081406558e-10,
                    1.0713945232e-01,
                    1.3956953187e-01,
                    8.8935070106e-02,
                    1.7121864280e-02,
                    3.7167574980e-03,
                    7.9321696368e-03,
                    5.3847142307e-04,
                ],
                integrals: [5.0714254419e+02, 8.8064378615e+01, 4.4623418037e+01],
            },
            PvlibCase {
                name: "zenith 60, defaults, Kasten 1966 air mass, 3 July",
                zenith: 60.0,
                day_of_year: 184,
                pressure: 1013.25,
                precipitable_water: 1.42,
                ozone: 0.344,
                aod500: 0.1,
                alpha: 1.14,
                asymmetry: 0.65,
                ssa400: 0.945,
                ssa_variation: 0.095,
                ground_albedo: 0.2,
                air_mass: AirMass::Kasten1966,
                relative_air_mass: 1.9927643456e+00,
                dni: [
                    3.4782981914e-05,
                    5.3511690292e-01,
                    9.8919384113e-01,
                    1.1866895703e+00,
                    5.9021952388e-01,
                    2.5851876541e-01,
                    4.0771527068e-01,
                    6.5455497907e-02,
                ],
                direct_h: [
                    1.7391490957e-05,
                    2.6755845146e-01,
                    4.9459692056e-01,
                    5.9334478517e-01,
                    2.9510976194e-01,
                    1.2925938270e-01,
                    2.0385763534e-01,
                    3.2727748954e-02,
                ],
                diffuse_h: [
                    1.0562973054e-04,
                    2.2083190295e-01,
                    2.6710999489e-01,
                    1.6547471187e-01,
                    3.6945785202e-02,
                    1.0865290495e-02,
                    1.1095631120e-02,
                    7.3515032951e-04,
                ],
                integrals: [7.9500138063e+02, 3.9750069031e+02, 8.2268752251e+01],
            },
        ]
    }

    fn index_of(wavelength: f64) -> usize {
        WAVELENGTHS.iter().position(|&w| w == wavelength).unwrap()
    }

    fn relative(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    const COMPONENTS: [&str; 3] = ["direct normal", "direct horizontal", "diffuse horizontal"];

    /// `[direct normal, direct horizontal, diffuse horizontal]` of `s` at `wavelength`, one
    /// of the model's.
    fn at(s: &Spectral2Spectrum, wavelength: f64) -> [f64; 3] {
        let i = index_of(wavelength);
        [
            s.direct_normal[i],
            s.direct_horizontal[i],
            s.diffuse_horizontal[i],
        ]
    }

    fn reference(c: &PvlibCase, k: usize) -> [f64; 3] {
        [c.dni[k], c.direct_h[k], c.diffuse_h[k]]
    }

    fn totals(s: &Spectral2Spectrum) -> [f64; 3] {
        let t = s.total();
        [t.direct_normal, t.direct_horizontal, t.diffuse_horizontal]
    }

    /// The worst relative difference seen, with where it was.
    #[derive(Default)]
    struct Worst(f64, String);

    impl Worst {
        fn see(&mut self, d: f64, bar: f64, what: impl Fn() -> String) {
            assert!(
                d < bar,
                "{}: relative difference {d:.3e} >= {bar:.0e}",
                what()
            );
            if d > self.0 {
                *self = Self(d, what());
            }
        }
    }

    /// pvlib's formulation reproduces pvlib: every case, the three components at the
    /// reference wavelengths and the 300–4000 nm integrals within 1e-4 relative (measured:
    /// 5e-11, the rounding of the 11-digit references), the air mass within 1e-10.
    #[test]
    fn pvlib_formulation_agrees_with_pvlib() {
        let (mut spectral, mut integral) = (Worst::default(), Worst::default());
        for c in pvlib_cases() {
            let s = c.query(Formulation::Pvlib).compute().unwrap();
            assert!(
                relative(s.relative_air_mass, c.relative_air_mass) < 1e-10,
                "{}",
                c.name
            );
            for (k, &w) in REFERENCE_WAVELENGTHS.iter().enumerate() {
                for (j, (got, want)) in at(&s, w).into_iter().zip(reference(&c, k)).enumerate() {
                    spectral.see(relative(got, want), 1e-4, || {
                        format!("{}, {w} nm, {}", c.name, COMPONENTS[j])
                    });
                }
            }
            for (j, (got, want)) in totals(&s).into_iter().zip(c.integrals).enumerate() {
                integral.see(relative(got, want), 1e-4, || {
                    format!("{}, 300-4000 nm, {}", c.name, COMPONENTS[j])
                });
            }
        }
        println!("Formulation::Pvlib against pvlib 0.16.1, worst relative difference:");
        println!("  spectral  {:.2e} ({})", spectral.0, spectral.1);
        println!("  integrals {:.2e} ({})", integral.0, integral.1);
    }

    /// The report's direct beam is pvlib's times the effect of the report's two constants
    /// (1.335 in eq. 2-4, 118.93 in eq. 2-11), which this test computes on its own: within
    /// 1e-4 relative (measured: 5e-11). Without that factor the two differ by up to 2e-3
    /// at the reference wavelengths (the O₂ band at 762.5 nm near the horizon; the Rayleigh
    /// constant alone gives 1.2e-3 at 300 nm and zenith 80°), and by at most 1e-4 in the
    /// 300–4000 nm integral (measured: 6.7e-5).
    #[test]
    fn paper_direct_beam_is_pvlibs_with_the_reports_constants() {
        let (mut exact, mut raw, mut integral) =
            (Worst::default(), Worst::default(), Worst::default());
        for c in pvlib_cases() {
            let s = c.query(Formulation::Paper).compute().unwrap();
            let m_p = c.relative_air_mass * c.pressure / 1013.0;
            for (k, &w) in REFERENCE_WAVELENGTHS.iter().enumerate() {
                let i = index_of(w);
                let l = WAVELENGTHS[i] / 1000.0;
                let tau_r = |k: f64| 1.0 / (l.powi(4) * (115.6406 - k / (l * l)));
                let t_u = |k: f64| {
                    let x = MIXED_GAS[i] * m_p;
                    (-1.41 * x / (1.0 + k * x).powf(0.45)).exp()
                };
                let factor =
                    (-m_p * (tau_r(1.335) - tau_r(1.3366))).exp() * t_u(118.93) / t_u(118.3);
                let got = at(&s, w);
                let want = reference(&c, k);
                for (j, component) in COMPONENTS.iter().enumerate().take(2) {
                    let what = || format!("{}, {w} nm, {component}", c.name);
                    exact.see(relative(got[j], want[j] * factor), 1e-4, what);
                    raw.see(relative(got[j], want[j]), 3e-3, what);
                }
            }
            for (j, component) in COMPONENTS.iter().enumerate().take(2) {
                integral.see(relative(totals(&s)[j], c.integrals[j]), 1e-4, || {
                    format!("{}, 300-4000 nm, {component}", c.name)
                });
            }
        }
        println!("Formulation::Paper direct beam against pvlib 0.16.1, worst relative difference:");
        println!(
            "  with the report's constants applied {:.2e} ({})",
            exact.0, exact.1
        );
        println!(
            "  as is                               {:.2e} ({})",
            raw.0, raw.1
        );
        println!(
            "  300-4000 nm integrals               {:.2e} ({})",
            integral.0, integral.1
        );
    }

    /// The report's diffuse irradiance against pvlib's. They differ by design in the sky
    /// reflectivity (eq. 3-8: the ozone `T_o′` in the report, the mixed gases `T_u′` in
    /// pvlib), in where `C_s` applies below 450 nm, and in the mixed-gas constant; at each
    /// reference wavelength the bar is above the difference these make (the measured worst
    /// in the comment), and the 300–4000 nm integral is within 1e-3 (measured: 6.8e-4).
    #[test]
    fn paper_diffuse_against_pvlib() {
        // Per reference wavelength: the bar, and why the two differ there (the measured
        // worst difference over the cases in the comment).
        #[rustfmt::skip]
        let bars = [
            (0.25, "T_o': ozone leaves 0.2 % of the sky reflectivity at 300 nm"), // 1.8e-1
            (2e-2, "C_s on the ground-reflected beam, and T_o'"),                 // 1.3e-2
            (1e-3, "T_o', weak ozone absorption"),                                // 3.7e-4
            (1.5e-2, "T_o' in the ozone Chappuis band"),                          // 8.1e-3
            (7e-2, "the O2 A band: 118.93, and no T_u'"),                         // 4.8e-2
            (1e-4, "no ozone or mixed-gas absorption"),                           // 3.0e-6
            (5e-3, "no T_u' (a_u = 0.05)"),                                       // 3.6e-3
            (2e-4, "the mixed-gas constant (a_u = 0.00038)"),                     // 6.5e-5
        ];
        let mut worst: Vec<Worst> = (0..bars.len()).map(|_| Worst::default()).collect();
        let mut integral = Worst::default();
        for c in pvlib_cases() {
            let s = c.query(Formulation::Paper).compute().unwrap();
            for (k, (bar, _)) in bars.iter().enumerate() {
                worst[k].see(
                    relative(at(&s, REFERENCE_WAVELENGTHS[k])[2], c.diffuse_h[k]),
                    *bar,
                    || c.name.to_string(),
                );
            }
            integral.see(relative(totals(&s)[2], c.integrals[2]), 1e-3, || {
                c.name.to_string()
            });
        }
        println!(
            "Formulation::Paper diffuse horizontal against pvlib 0.16.1, worst relative difference:"
        );
        for (k, (bar, why)) in bars.iter().enumerate() {
            println!(
                "  {:6.1} nm {:.2e} (bar {bar}: {why}; {})",
                REFERENCE_WAVELENGTHS[k], worst[k].0, worst[k].1
            );
        }
        println!("  300-4000 nm {:.2e} ({})", integral.0, integral.1);
    }

    /// Where none of the documented differences act (no ozone, no mixed-gas absorption,
    /// above 450 nm) the two formulations agree: only the Rayleigh constant is left, under
    /// 1e-4.
    #[test]
    fn formulations_differ_only_where_documented() {
        for zenith in [0.0, 30.0, 60.0] {
            let mut q = Spectral2Query::new(zenith);
            q.ozone = 0.0;
            let paper = q.compute().unwrap();
            q.formulation = Formulation::Pvlib;
            let pvlib = q.compute().unwrap();
            for i in (0..N).filter(|&i| WAVELENGTHS[i] > 450.0 && MIXED_GAS[i] == 0.0) {
                for (p, v) in [
                    (paper.direct_normal[i], pvlib.direct_normal[i]),
                    (paper.diffuse_horizontal[i], pvlib.diffuse_horizontal[i]),
                ] {
                    assert!(
                        relative(p, v) < 1e-4,
                        "zenith {zenith}, {} nm: {p} vs {v}",
                        WAVELENGTHS[i]
                    );
                }
            }
        }
    }

    /// The physical sense of the defaults: the direct normal at the zenith is 900–1000
    /// W m⁻² at 1 AU, the extraterrestrial 300–4000 nm is most of the solar constant, and
    /// every value is finite, non-negative and below the extraterrestrial spectrum.
    #[test]
    fn defaults_are_physically_sensible() {
        let s = Spectral2Query::new(0.0).compute().unwrap();
        let t = s.total();
        let extraterrestrial = integrate(&s.extraterrestrial, 300.0, 4000.0);
        println!(
            "zenith 0°, defaults, 1 AU, 300-4000 nm: extraterrestrial {extraterrestrial:.1}, \
             direct normal {:.1}, diffuse horizontal {:.1}, global horizontal {:.1} W/m²",
            t.direct_normal,
            t.diffuse_horizontal,
            t.global_horizontal()
        );
        assert!((900.0..1000.0).contains(&t.direct_normal), "{t:?}");
        assert!((60.0..150.0).contains(&t.diffuse_horizontal), "{t:?}");
        assert!(
            (1250.0..1367.0).contains(&extraterrestrial),
            "{extraterrestrial}"
        );
        assert_eq!(t.direct_normal, t.direct_horizontal);
        // The visible (400-700 nm) is a bit under half of it, and more diffuse than the rest.
        let visible = s.band(400.0, 700.0).unwrap();
        let share = visible.global_horizontal() / t.global_horizontal();
        assert!((0.4..0.5).contains(&share), "{share}");
        assert!(visible.diffuse_fraction() > t.diffuse_fraction());

        let mut previous: Option<BandIrradiance> = None;
        for zenith in (0..=18).map(|z| f64::from(z) * 5.0) {
            for formulation in [Formulation::Paper, Formulation::Pvlib] {
                let q = Spectral2Query {
                    formulation,
                    ..Spectral2Query::new(zenith)
                };
                let s = q.compute().unwrap();
                for (i, &w) in WAVELENGTHS.iter().enumerate() {
                    let values = [
                        s.direct_normal[i],
                        s.direct_horizontal[i],
                        s.diffuse_horizontal[i],
                    ];
                    for v in values {
                        assert!(v.is_finite() && v >= 0.0, "zenith {zenith}, {w} nm: {v}");
                        assert!(v <= s.extraterrestrial[i], "zenith {zenith}, {w} nm");
                    }
                }
            }
            // Lower sun: less direct light, a larger diffuse share.
            let t = Spectral2Query::new(zenith).compute().unwrap().total();
            if let Some(p) = previous {
                assert!(t.direct_normal < p.direct_normal, "zenith {zenith}");
                assert!(t.direct_horizontal < p.direct_horizontal, "zenith {zenith}");
                assert!(
                    t.diffuse_fraction() > p.diffuse_fraction(),
                    "zenith {zenith}"
                );
            }
            previous = Some(t);
        }
        // At the horizon the direct horizontal and diffuse vanish with cos Z.
        let horizon = Spectral2Query::new(90.0).compute().unwrap().total();
        assert!(
            horizon.direct_horizontal < 1e-12 && horizon.diffuse_horizontal < 1e-12,
            "{horizon:?}"
        );
    }

    /// Each input moves the spectrum where it should.
    #[test]
    fn inputs_act_where_they_should() {
        let base = Spectral2Query::new(30.0);
        let s0 = base.compute().unwrap();
        let i = |w: f64| index_of(w);
        // More aerosol: less direct, more diffuse.
        let hazy = Spectral2Query {
            aod500: 0.5,
            ..base
        }
        .compute()
        .unwrap();
        assert!(hazy.total().direct_normal < 0.8 * s0.total().direct_normal);
        assert!(hazy.total().diffuse_horizontal > 1.5 * s0.total().diffuse_horizontal);
        // More water: less light in the 937 nm band, the same where water does not absorb.
        let wet = Spectral2Query {
            precipitable_water: 4.0,
            ..base
        }
        .compute()
        .unwrap();
        assert!(wet.direct_normal[i(937.0)] < 0.6 * s0.direct_normal[i(937.0)]);
        assert_eq!(wet.direct_normal[i(550.0)], s0.direct_normal[i(550.0)]);
        // More ozone: less UV-B.
        let ozone = Spectral2Query { ozone: 0.5, ..base }.compute().unwrap();
        assert!(ozone.direct_normal[i(305.0)] < 0.6 * s0.direct_normal[i(305.0)]);
        // A dark ground: no ground-sky reflections, less diffuse, the same direct.
        let dark = Spectral2Query {
            ground_albedo: 0.0,
            ..base
        }
        .compute()
        .unwrap();
        assert!(dark.total().diffuse_horizontal < s0.total().diffuse_horizontal);
        assert_eq!(dark.direct_normal, s0.direct_normal);
        // Lower pressure (a mountain): more direct blue light.
        let high = Spectral2Query {
            pressure: 700.0,
            ..base
        }
        .compute()
        .unwrap();
        assert!(high.direct_normal[i(400.0)] > 1.05 * s0.direct_normal[i(400.0)]);
        // Closer to the sun: everything scales by D.
        let near = Spectral2Query {
            earth_sun: EarthSun::Distance(0.98),
            ..base
        }
        .compute()
        .unwrap();
        let d = 1.0 / (0.98 * 0.98);
        for k in 0..N {
            assert!(relative(near.direct_normal[k], d * s0.direct_normal[k]) < 1e-12);
            assert!(relative(near.diffuse_horizontal[k], d * s0.diffuse_horizontal[k]) < 1e-12);
        }
    }

    /// Without air (pressure 0) and aerosol, nothing scatters: the direct beam is only
    /// absorbed by water and ozone, and there is no diffuse light at all.
    #[test]
    fn without_air_or_aerosol_nothing_scatters() {
        let q = Spectral2Query {
            pressure: 0.0,
            aod500: 0.0,
            ..Spectral2Query::new(40.0)
        };
        let s = q.compute().unwrap();
        let cos_z = 40f64.to_radians().cos();
        let h = 22.0 / 6370.0;
        let m_o = (1.0 + h) / (cos_z * cos_z + 2.0 * h).sqrt();
        let m = s.relative_air_mass;
        for i in 0..N {
            let x = WATER_VAPOR[i] * 1.42 * m;
            let t_w = (-0.2385 * x / (1.0 + 20.07 * x).powf(0.45)).exp();
            let t_o = (-OZONE[i] * 0.344 * m_o).exp();
            let want = EXTRATERRESTRIAL[i] * t_w * t_o;
            assert!(
                relative(s.direct_normal[i], want) < 1e-12,
                "{} nm",
                WAVELENGTHS[i]
            );
            assert_eq!(s.diffuse_horizontal[i], 0.0, "{} nm", WAVELENGTHS[i]);
        }
    }

    /// Both air-mass formulas against pvlib 0.16.1's `get_relative_airmass`.
    #[test]
    fn air_mass_agrees_with_pvlib() {
        let zeniths = [0.0, 45.0, 70.0, 85.0, 89.0, 90.0];
        let kasten_young = [
            0.9997119918558381,
            1.4125952520262743,
            2.9031466488030997,
            10.305791327930304,
            26.310555068385266,
            37.91960837783625,
        ];
        let kasten = [
            0.9994939325912029,
            1.4119233259420552,
            2.899946150705344,
            10.323080326274901,
            26.30979396448969,
            36.510324500288725,
        ];
        for (k, z) in zeniths.into_iter().enumerate() {
            assert!(
                relative(AirMass::KastenYoung1989.relative(z), kasten_young[k]) < 1e-12,
                "{z}"
            );
            assert!(
                relative(AirMass::Kasten1966.relative(z), kasten[k]) < 1e-12,
                "{z}"
            );
        }
    }

    /// Spencer's distance factor against pvlib 0.16.1's `get_extra_radiation(doy,
    /// method="spencer", solar_constant=1)`, and against the SPA's distance for the same
    /// days: Spencer's series is within about 1e-3 of it (pvlib's SPA distance over 2024,
    /// worst 1.04e-3 on 24 May).
    #[test]
    fn earth_sun_factor() {
        let days = [1, 80, 172, 266, 365, 366];
        let pvlib = [
            1.03505,
            1.0079001253344766,
            0.967442787915536,
            0.9930456726880935,
            1.0350198201507328,
            1.03505,
        ];
        for (day, want) in days.into_iter().zip(pvlib) {
            assert!(
                relative(EarthSun::DayOfYear(day).factor(), want) < 1e-12,
                "day {day}"
            );
        }
        assert_eq!(EarthSun::Distance(0.99).factor(), 1.0 / (0.99 * 0.99));
        assert_eq!(EarthSun::default().factor(), 1.0);

        // 2024: day 1 is 1 January, day 172 is 20 June.
        for (month, day, day_of_year) in [
            (1, 1, 1),
            (3, 20, 80),
            (5, 24, 145),
            (6, 20, 172),
            (10, 1, 275),
        ] {
            let time = LocalTime::new(2024, month, day, 12, 0, 0.0, 0.0);
            let sun = solar_position(&SolarQuery::new(Observer::new(0.0, 0.0), time)).unwrap();
            let spencer = EarthSun::DayOfYear(day_of_year).factor();
            let spa = EarthSun::Distance(sun.earth_sun_distance).factor();
            assert!(
                relative(spencer, spa) < 1.5e-3,
                "{month}-{day}: {spencer} vs {spa}"
            );
        }
    }

    /// [`Spectral2Query::for_sun`] takes the sun's apparent zenith and distance.
    #[test]
    fn query_for_a_solar_position() {
        let observer = Observer {
            latitude: 39.742476,
            longitude: -105.1786,
            elevation: 1830.14,
        };
        let time = LocalTime::new(2003, 10, 17, 12, 30, 30.0, -7.0);
        let sun = solar_position(&SolarQuery::new(observer, time)).unwrap();
        let q = Spectral2Query::for_sun(&sun);
        assert_eq!(q.zenith, sun.zenith);
        assert_eq!(q.earth_sun, EarthSun::Distance(sun.earth_sun_distance));
        assert_eq!(
            Spectral2Query {
                zenith: 0.0,
                earth_sun: EarthSun::default(),
                ..q
            },
            Spectral2Query::new(0.0)
        );
        let s = q.compute().unwrap();
        assert!(
            (600.0..1000.0).contains(&s.total().direct_normal),
            "{:?}",
            s.total()
        );
    }

    /// Band integrals: the trapezoid rule on the model's wavelengths, exact for the linear
    /// interpolation inside an interval, and additive.
    #[test]
    fn band_integrals() {
        let s = Spectral2Query::new(20.0).compute().unwrap();
        let f = &s.diffuse_horizontal;
        // A band on the model's wavelengths: the trapezoid sum.
        let (a, b) = (index_of(400.0), index_of(710.0));
        let trapezoid: f64 = (a..b)
            .map(|i| 0.5 * (WAVELENGTHS[i + 1] - WAVELENGTHS[i]) * (f[i] + f[i + 1]))
            .sum();
        let band = s.band(400.0, 710.0).unwrap();
        assert!(relative(band.diffuse_horizontal, trapezoid) < 1e-14);
        // Inside one interval: the linear interpolant's integral.
        let mid = 0.5 * (f[index_of(400.0)] + f[index_of(410.0)]);
        let part = s.band(400.0, 405.0).unwrap().diffuse_horizontal;
        assert!(relative(part, 2.5 * (f[index_of(400.0)] + mid)) < 1e-14);
        // Additive over any split, down to a zero-width band.
        let total = s.total();
        for split in [300.0, 301.7, 450.0, 762.5, 1000.3, 3999.0, 4000.0] {
            let lo = s.band(300.0, split).unwrap();
            let hi = s.band(split, 4000.0).unwrap();
            for (x, y, t) in [
                (lo.direct_normal, hi.direct_normal, total.direct_normal),
                (
                    lo.direct_horizontal,
                    hi.direct_horizontal,
                    total.direct_horizontal,
                ),
                (
                    lo.diffuse_horizontal,
                    hi.diffuse_horizontal,
                    total.diffuse_horizontal,
                ),
            ] {
                assert!(relative(x + y, t) < 1e-12, "split at {split}");
            }
        }
        assert_eq!(s.band(550.0, 550.0).unwrap().diffuse_horizontal, 0.0);
        assert_eq!((band.start, band.end), (400.0, 710.0));
        // The direct/diffuse split per band, as a renderer would print it.
        for (lo, hi) in [
            (400.0, 500.0),
            (500.0, 600.0),
            (600.0, 700.0),
            (700.0, 1100.0),
            (1100.0, 2500.0),
        ] {
            let b = s.band(lo, hi).unwrap();
            assert!(b.diffuse_fraction() > 0.0 && b.diffuse_fraction() < 1.0);
            assert!(
                relative(
                    b.global_horizontal(),
                    b.direct_horizontal + b.diffuse_horizontal
                ) < 1e-15
            );
        }
        // Blue light is more diffuse than red.
        let blue = s.band(400.0, 500.0).unwrap().diffuse_fraction();
        let red = s.band(600.0, 700.0).unwrap().diffuse_fraction();
        assert!(blue > 1.5 * red, "{blue} {red}");
    }

    /// Resampling to a uniform grid: the model's values at its wavelengths, linear between.
    #[test]
    fn resampling() {
        let s = Spectral2Query::new(45.0).compute().unwrap();
        let grid = UniformGrid::new(360.0, 2500.0, 5.0).unwrap();
        assert_eq!(grid.len(), 429);
        assert!(!grid.is_empty());
        assert_eq!((grid.start(), grid.step()), (360.0, 5.0));
        assert_eq!(grid.wavelength(428), 2500.0);
        assert_eq!(grid.wavelengths().len(), 429);
        let r = s.resample(&grid);
        assert_eq!(r.grid, grid);
        assert_eq!(r.direct_normal.len(), 429);
        for (k, w) in grid.wavelengths().enumerate() {
            if let Some(i) = WAVELENGTHS.iter().position(|&x| x == w) {
                assert_eq!(r.direct_normal[k], s.direct_normal[i], "{w}");
                assert_eq!(r.direct_horizontal[k], s.direct_horizontal[i], "{w}");
                assert_eq!(r.diffuse_horizontal[k], s.diffuse_horizontal[i], "{w}");
            }
        }
        // 365 nm lies halfway between 360 and 370.
        let mid = 0.5 * (s.direct_normal[index_of(360.0)] + s.direct_normal[index_of(370.0)]);
        assert!(relative(r.direct_normal[1], mid) < 1e-15);
        // 667.6 -> 690 nm: 680 is 56.25 % of the way.
        let (a, b) = (
            s.diffuse_horizontal[index_of(667.6)],
            s.diffuse_horizontal[index_of(690.0)],
        );
        let t = (680.0 - 667.6) / (690.0 - 667.6);
        assert!(relative(r.diffuse_horizontal[64], a + t * (b - a)) < 1e-14);
        // A grid that does not land on its end stops short of it; the full range works.
        let g = UniformGrid::new(300.0, 4000.0, 7.0).unwrap();
        assert_eq!(g.len(), 529);
        assert!(g.wavelength(g.len() - 1) <= 4000.0);
        let full = s.resample(&UniformGrid::new(300.0, 4000.0, 0.5).unwrap());
        assert_eq!(full.direct_normal[0], s.direct_normal[0]);
        assert_eq!(*full.direct_normal.last().unwrap(), s.direct_normal[N - 1]);
        assert_eq!(UniformGrid::new(500.0, 500.0, 1.0).unwrap().len(), 1);
    }

    /// Every invalid input is rejected by an error that names it.
    #[test]
    fn bad_inputs_name_their_field() {
        type Edit = fn(&mut Spectral2Query);
        let cases: [(&str, Edit); 25] = [
            ("zenith", |q| q.zenith = -0.1),
            ("zenith", |q| q.zenith = 90.5),
            ("zenith", |q| q.zenith = f64::NAN),
            ("pressure", |q| q.pressure = -1.0),
            ("pressure", |q| q.pressure = f64::INFINITY),
            ("precipitable_water", |q| q.precipitable_water = -0.1),
            ("precipitable_water", |q| q.precipitable_water = 25.0),
            ("ozone", |q| q.ozone = -0.01),
            ("ozone", |q| q.ozone = 1.5),
            ("aod500", |q| q.aod500 = -0.01),
            ("aod500", |q| q.aod500 = f64::NAN),
            ("angstrom_exponent", |q| q.angstrom_exponent = 5.0),
            ("asymmetry", |q| q.asymmetry = 1.0),
            ("asymmetry", |q| q.asymmetry = -0.1),
            ("single_scattering_albedo", |q| {
                q.single_scattering_albedo = 1.01
            }),
            ("single_scattering_albedo", |q| {
                q.single_scattering_albedo = f64::NEG_INFINITY
            }),
            ("albedo_wavelength_variation", |q| {
                q.albedo_wavelength_variation = -0.1
            }),
            ("ground_albedo", |q| q.ground_albedo = 1.1),
            ("ground_albedo", |q| q.ground_albedo = f64::NAN),
            ("earth_sun", |q| q.earth_sun = EarthSun::DayOfYear(0)),
            ("earth_sun", |q| q.earth_sun = EarthSun::DayOfYear(367)),
            ("earth_sun", |q| q.earth_sun = EarthSun::Distance(0.5)),
            ("earth_sun", |q| q.earth_sun = EarthSun::Distance(f64::NAN)),
            ("earth_sun", |q| q.earth_sun = EarthSun::Distance(-1.0)),
            ("pressure", |q| q.pressure = 1300.0),
        ];
        for (field, edit) in cases {
            let mut q = Spectral2Query::new(30.0);
            edit(&mut q);
            let err = spectral2(&q).expect_err(field);
            assert_eq!(err.field(), field, "{err}");
            assert!(
                err.to_string().contains(field),
                "{err} does not name {field}"
            );
        }
        // The edges are valid.
        let edges: [Edit; 8] = [
            |q| q.zenith = 0.0,
            |q| q.zenith = 90.0,
            |q| q.pressure = 0.0,
            |q| q.asymmetry = 0.0,
            |q| q.asymmetry = 0.999,
            |q| q.earth_sun = EarthSun::DayOfYear(366),
            |q| q.ground_albedo = 1.0,
            |q| q.single_scattering_albedo = 1.0,
        ];
        for edit in edges {
            let mut q = Spectral2Query::new(30.0);
            edit(&mut q);
            assert!(spectral2(&q).is_ok(), "{q:?}");
        }

        let s = Spectral2Query::new(30.0).compute().unwrap();
        let band = [
            ("start", s.band(299.0, 500.0)),
            ("start", s.band(f64::NAN, 500.0)),
            ("end", s.band(500.0, 4001.0)),
            ("end", s.band(500.0, 400.0)),
        ];
        for (field, result) in band {
            assert_eq!(result.expect_err(field).field(), field);
        }
        let grid = [
            ("start", UniformGrid::new(250.0, 500.0, 1.0)),
            ("end", UniformGrid::new(500.0, 5000.0, 1.0)),
            ("end", UniformGrid::new(500.0, 499.0, 1.0)),
            ("step", UniformGrid::new(300.0, 4000.0, 0.0)),
            ("step", UniformGrid::new(300.0, 4000.0, -5.0)),
            ("step", UniformGrid::new(300.0, 4000.0, f64::NAN)),
            ("step", UniformGrid::new(300.0, 4000.0, 1e-4)),
        ];
        for (field, result) in grid {
            let err = result.expect_err(field);
            assert_eq!(err.field(), field, "{err}");
            assert!(err.to_string().contains(field), "{err}");
        }
    }
}
