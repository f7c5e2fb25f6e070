//! The sun and sky for lamina.
//!
//! This crate is where a physical sun and sky are computed from a place and a time. Today it
//! holds [`solar_position`]: the sun's position by NREL's Solar Position Algorithm (SPA,
//! Reda & Andreas 2004/2008), ±0.0003° over the years −2000 to 6000, as topocentric zenith
//! (apparent, with atmospheric refraction, and geometric, without it), azimuth (degrees
//! clockwise from north) and a unit vector toward the sun in lamina's world frame.
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
//! ```
//!
//! The crate depends on nothing of lamina's; the scene loader and the renderers may call it.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod solar_position;

pub use solar_position::{
    LocalTime, Observer, SolarError, SolarPosition, SolarQuery, solar_position, sun_direction,
};
