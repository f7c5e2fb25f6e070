//! The sun and sky for lamina.
//!
//! This crate is where a physical sun and sky are computed from a place and a time. Today it
//! holds
//!
//! * [`solar_position`]: the sun's position by NREL's Solar Position Algorithm (SPA,
//!   Reda & Andreas 2004/2008), ±0.0003° over the years −2000 to 6000, as topocentric zenith
//!   (apparent, with atmospheric refraction, and geometric, without it), azimuth (degrees
//!   clockwise from north) and a unit vector toward the sun in lamina's world frame;
//! * [`spectral2`](mod@spectral2): the clear-sky solar spectrum at the ground by Bird & Riordan's SPCTRAL2
//!   (1984/1986): direct normal, direct horizontal and diffuse horizontal spectral
//!   irradiance at 122 wavelengths from 300 to 4000 nm, for a sun at a given apparent zenith
//!   through a given atmosphere (pressure, water, ozone, aerosol, ground albedo), with band
//!   integrals and resampling to a uniform grid.
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
//! The crate depends on nothing of lamina's; the scene loader and the renderers may call it.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod solar_position;
pub mod spectral2;

pub use solar_position::{
    LocalTime, Observer, SolarError, SolarPosition, SolarQuery, solar_position, sun_direction,
};
pub use spectral2::{
    AirMass, BandIrradiance, EarthSun, Formulation, ResampledSpectrum, Spectral2Error,
    Spectral2Query, Spectral2Spectrum, UniformGrid, spectral2,
};
