//! `type = "fisheye"`: a hemispherical camera (hemispherical photographs, gap fraction).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `position` | m, `[x, y, z]` | required | the lens centre |
//! | `look` | `up`, `down` | `up` | the hemisphere seen: above (`+y`) or below |
//! | `projection` | `equidistant`, `equisolid` | `equidistant` | image radius `r = θ / 90°`, or `√2 sin(θ/2)` (equal areas for equal solid angles) |
//! | `resolution` | pixels, 8..8192 | `512` | image width and height; the hemisphere is the inscribed circle (north, `-z`, up; east, `+x`, right when looking up) |
//! | `file` | path, `.exr` or `.png` | required | the image (linear radiance, or the film's exposure and tone map) |
//! | `gap_file` | path, `.csv` | none | the gap fraction (rays that meet no surface) per 5° zenith ring: `zenith_min,zenith_max,gap_fraction,std` |
//!
//! `samples` (default 64): per pixel.

use super::{Context, out_path};
use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use lamina_core::radiometry::{FisheyeProjection, SensorKind};

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("position", Kind::Vec3),
    ("look", Kind::Str),
    ("projection", Kind::Str),
    ("resolution", Kind::Int),
    ("file", Kind::Str),
    ("gap_file", Kind::Str),
]);

/// Reads a fisheye sensor.
pub(crate) fn read(d: &Dict, _cx: &Context) -> Result<(SensorKind, u32), SceneError> {
    let position = d.req_vec3("position")?;
    let up = match d.string("look")? {
        None => true,
        Some(v) => match *v.get_ref() {
            "up" => true,
            "down" => false,
            other => {
                return Err(d.err(v.span(), "look", format!("'{other}': up or down")));
            }
        },
    };
    let projection = match d.string("projection")? {
        None => FisheyeProjection::Equidistant,
        Some(v) => match *v.get_ref() {
            "equidistant" => FisheyeProjection::Equidistant,
            "equisolid" => FisheyeProjection::Equisolid,
            other => {
                return Err(d.err(
                    v.span(),
                    "projection",
                    format!("'{other}': equidistant or equisolid"),
                ));
            }
        },
    };
    let resolution = d.count("resolution", 8, 8192, 512)?;
    let file = out_path(d, "file", &["exr", "png"])?.ok_or_else(|| d.missing("file"))?;
    let gap_file = out_path(d, "gap_file", &["csv"])?;
    Ok((
        SensorKind::Fisheye {
            position,
            up,
            projection,
            resolution,
            file,
            gap_file,
        },
        64,
    ))
}
