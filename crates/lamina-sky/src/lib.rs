//! The sun and sky for lamina.
//!
//! This crate is where a physical sun and sky are computed from a place and a time:
//!
//! * [`solar_position()`]: the sun's position by NREL's Solar Position Algorithm (SPA,
//!   Reda & Andreas 2004/2008), ±0.0003° over the years −2000 to 6000, as topocentric
//!   zenith (apparent, with atmospheric refraction, and geometric, without it), azimuth
//!   (degrees clockwise from north) and a unit vector toward the sun in lamina's world frame.
//! * [`spectral2`](mod@spectral2): the clear-sky solar spectrum at the ground by Bird &
//!   Riordan's SPCTRAL2 (1984/1986): direct normal, direct horizontal and diffuse horizontal
//!   spectral irradiance at 122 wavelengths from 300 to 4000 nm, for a sun at a given
//!   apparent zenith through a given atmosphere (pressure, water, ozone, aerosol, ground
//!   albedo), with band integrals and resampling to a uniform grid.
//! * [`preetham`]: the clear sky of Preetham, Shirley & Smits (SIGGRAPH 99) for a sun
//!   position and a turbidity: [`PreethamSky`] gives the sky's chromaticity and luminance in
//!   every direction above the horizon, its radiance in CIE XYZ and linear Rec.709, and its
//!   spectral radiance (300–830 nm) through the CIE daylight basis.
//!
//! # World frame
//! lamina's scenes are **Y up**. This crate puts **x = east, y = up, z = south** (so north is
//! −z). The frame is right-handed (east × up = south), a camera looking along −z looks north,
//! and the `[sky]` image's azimuth `φ = atan2(x, −z)` (docs/scene-format.md) is then exactly
//! the compass azimuth that [`SolarPosition::azimuth`] gives. The vector
//! [`SolarPosition::direction`] points *toward* the sun, as a `type = "sun"` light's
//! `direction` does.
//!
//! ```
//! use lamina_sky::{LocalTime, Observer, SolarQuery, solar_position};
//!
//! // Golden, Colorado, 17 October 2003, 12:30:30 local standard time (UTC−7).
//! let observer = Observer { latitude: 39.742476, longitude: -105.1786, elevation: 1830.14 };
//! let time = LocalTime::new(2003, 10, 17, 12, 30, 30.0, -7.0);
//! let sun = solar_position(&SolarQuery::new(observer, time)).unwrap();
//! assert!((sun.zenith - 50.1078).abs() < 1e-3);
//! assert!((sun.azimuth - 194.3402).abs() < 1e-3);
//! assert!(sun.direction.y > 0.0 && sun.direction.z > 0.0); // up, and to the south
//!
//! // The clear-sky spectrum under that sun (default atmosphere: rural aerosol, AOD 0.1).
//! let spectrum = lamina_sky::Spectral2Query::for_sun(&sun).compute().unwrap();
//! let visible = spectrum.band(400.0, 700.0).unwrap(); // W/m²
//! assert!(visible.direct_horizontal > 2.0 * visible.diffuse_horizontal);
//! ```
//!
//! ```
//! use glam::DVec3;
//! use lamina_sky::PreethamSky;
//!
//! // The sun 40° from the zenith, due south; a clear sky (turbidity 3).
//! let sky = PreethamSky::new(40.0, 3.0).unwrap();
//! let zenith = sky.zenith_xyY(); // x, y and Y_z in kcd/m²
//! let north = DVec3::new(0.0, 0.5, -1.0); // 27° above the northern horizon
//! let rgb = sky.linear_rec709(north); // W m⁻² sr⁻¹, linear Rec.709
//! assert!(rgb.z > rgb.x); // blue, away from the sun
//! let l_550 = sky.spectral_radiance(north, 550.0); // W m⁻² sr⁻¹ nm⁻¹
//! assert!(zenith.luminance > 0.0 && l_550 > 0.0);
//! ```
//!
//! Of lamina's crates it depends on lamina-leaf only, for the CIE observer and the Rec.709
//! matrix (`lamina_leaf::spectrum`); the scene loader and the renderers may call it.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod input;
pub mod preetham;
pub mod solar_position;
pub mod spectral2;
pub mod sunsky;
pub mod time;

pub use preetham::{DaylightSpectrum, Perez, PreethamSky, SkyError, SkySpectrum, XyY};
pub use solar_position::{
    LocalTime, Observer, SolarError, SolarPosition, SolarQuery, solar_position, sun_direction,
};
pub use spectral2::{
    AirMass, BandIrradiance, EarthSun, Formulation, ResampledSpectrum, Spectral2Error,
    Spectral2Query, Spectral2Spectrum, UniformGrid, spectral2,
};
pub use sunsky::{SunSky, SunSkyError, SunSkyParams};
pub use time::parse_local_time;
