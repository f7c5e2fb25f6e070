//! `type = "sun"`: a distant disc light (parallel light when its angular diameter is 0).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `direction` | direction, non-zero | required unless `position` | toward the sun |
//! | `position` | table | none | the sun's direction from a place and a time instead of `direction` (NREL's Solar Position Algorithm, lamina-sky): `latitude` (degrees, north positive), `longitude` (degrees, east positive), `elevation` (m, default 0), `time` (local date and time with its UTC offset, ISO 8601: `"2024-06-21T14:30:00+02:00"`, or `Z` for UTC), `north` (the scene's horizontal north direction, default `[0, 0, -1]`: x east, y up, z south); the apparent (refracted) position; a sun below the horizon is an error |
//! | `irradiance` | colour, W m⁻² | required | on a surface facing the sun |
//! | `angular_diameter` | degrees, [0, 90] | `0.53` | the sun's disc; 0 = hard shadows |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::Light;
use glam::Vec3;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("direction", Kind::Vec3),
    ("position", Kind::Table),
    ("irradiance", Kind::Color),
    ("angular_diameter", Kind::Num),
]);

/// The keys of `position`.
const POSITION_KEYS: Keys = Keys::plain(&[
    ("latitude", Kind::Num),
    ("longitude", Kind::Num),
    ("elevation", Kind::Num),
    ("time", Kind::Str),
    ("north", Kind::Vec3),
]);

/// Reads a sun.
pub(crate) fn read(d: &Dict) -> Result<Light, SceneError> {
    let direction = match (d.get("direction"), d.table("position")?) {
        (Some(dir), Some(_)) => {
            return Err(d.err(
                dir.span(),
                "direction",
                "give either 'direction' or 'position', not both",
            ));
        }
        (_, Some(pos)) => from_position(d, pos)?,
        (_, None) => d.req_direction("direction")?,
    };
    Ok(Light::Sun {
        direction,
        irradiance: d.req_color("irradiance")?,
        angular_diameter_deg: d.float("angular_diameter", 0.0, 90.0, false, 0.53)?,
    })
}

/// A place and a time (`position = { latitude, longitude, elevation, time, north }`) and
/// the scene's frame there.
pub(crate) struct Place {
    /// Where on Earth.
    pub(crate) observer: lamina_sky::Observer,
    /// When.
    pub(crate) time: lamina_sky::LocalTime,
    /// The scene's horizontal north (unit).
    pub(crate) north: Vec3,
    /// The span of `time`, for errors about it.
    pub(crate) time_span: std::ops::Range<usize>,
}

impl Place {
    /// A direction in lamina-sky's frame (x east, y up, z south) in the scene's frame.
    pub(crate) fn to_scene(&self, v: glam::DVec3) -> Vec3 {
        let east = self.north.cross(Vec3::Y);
        east * v.x as f32 + Vec3::Y * v.y as f32 - self.north * v.z as f32
    }
}

/// Reads a `position` table (`key` the table's own key, e.g. `position`).
pub(crate) fn read_place(
    d: &Dict,
    key: &str,
    pos: toml::Spanned<&crate::dict::Table>,
) -> Result<Place, SceneError> {
    let p = Dict::open(
        d.ld,
        d.key(key),
        None,
        pos.span(),
        pos.get_ref(),
        POSITION_KEYS,
    )?;
    let latitude = p.req_float("latitude", -90.0, 90.0, false)?;
    let longitude = p.req_float("longitude", -180.0, 180.0, false)?;
    let elevation = p.float("elevation", -500.0, 9000.0, false, 0.0)?;
    let time_s = p.req_string("time")?;
    let time = lamina_sky::parse_local_time(time_s.get_ref())
        .map_err(|m| p.err(time_s.span(), "time", m))?;
    let north = p.direction_opt("north")?.unwrap_or(Vec3::NEG_Z);
    let north_h = Vec3::new(north.x, 0.0, north.z);
    if north_h.length() < 1e-3 {
        return Err(p.err(
            p.get("north").map_or(pos.span(), |v| v.span()),
            "north",
            "must be horizontal (y is up): it has no x or z component",
        ));
    }
    p.finish()?;
    Ok(Place {
        observer: lamina_sky::Observer {
            latitude: latitude as f64,
            longitude: longitude as f64,
            elevation: elevation as f64,
        },
        time,
        north: north_h.normalize(),
        time_span: time_s.span(),
    })
}

/// The direction toward the sun for `position = { ... }`.
fn from_position(d: &Dict, pos: toml::Spanned<&crate::dict::Table>) -> Result<Vec3, SceneError> {
    let place = read_place(d, "position", pos.clone())?;
    let sun = lamina_sky::solar_position(&lamina_sky::SolarQuery::new(place.observer, place.time))
        .map_err(|e| {
            d.err(
                pos.span(),
                &format!("position.{}", e.field()),
                e.to_string(),
            )
        })?;
    if sun.zenith >= 90.0 {
        return Err(d.err(
            place.time_span,
            "position.time",
            format!(
                "the sun is below the horizon then (zenith {:.2} degrees, azimuth {:.2}): \
                 choose a daytime, or light the scene another way",
                sun.zenith, sun.azimuth
            ),
        ));
    }
    Ok(place.to_scene(sun.direction).normalize())
}
