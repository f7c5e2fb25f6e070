//! `type = "brf"`: the bidirectional reflectance factor `BRF = π L / E` of an area (the
//! HDRF when a sky lights the scene too): `L` the radiance leaving the area toward a view
//! direction, averaged over the area as a distant sensor sees it, `E` the irradiance the
//! sun and sky bring onto a horizontal surface. View directions are given by zenith and
//! azimuth relative to the sun's (0 = toward the sun's side: the hotspot is at view zenith
//! = sun zenith, relative azimuth 0).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `target` | `{ min = [x, z], max = [x, z] }`, m | the periodic cell | the area measured; required without a periodic domain; inside the cell |
//! | `planes` | array of `{ plane, zenith_max, step, file }` | none | sweeps through a plane: `plane = "principal"` (relative azimuth 0 for zenith ≥ 0, 180 for negative zenith) or `"orthogonal"` (90 and 270), view zenith from `-zenith_max` to `zenith_max` (degrees, < 90, default 75) in steps of `step` (default 2); each written to its `file` (`.csv`) |
//! | `directions` | array of `[zenith, relative_azimuth]`, degrees | none | single view directions, zenith in [0, 90); written to `file` |
//! | `file` | path, `.csv` | required with `directions` | the CSV of `directions` |
//! | `plot` | path, `.png` | none | a plot of every sweep's BRF with error bars (±2 standard errors) |
//!
//! Every CSV has RAMI's columns `sza,vza,raa,brf,std` (degrees, the BRF and its standard
//! error; `vza ≥ 0`, `raa` in [0, 360)) with a `channel` set, else
//! `sza,vza,raa,channel,brf,std`, one row per channel. `samples` (default 16384): rays per
//! view direction, in 32 independently scrambled batches whose spread gives the error.

use super::{Context, area, out_path};
use crate::dict::{Dict, Keys, Kind, Value};
use crate::error::SceneError;
use lamina_core::radiometry::{BrfDirection, BrfSweep, SensorKind};

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("target", Kind::Table),
    ("planes", Kind::Array),
    ("directions", Kind::Array),
    ("file", Kind::Str),
    ("plot", Kind::Str),
]);

/// The keys of one plane sweep.
const PLANE_KEYS: Keys = Keys::plain(&[
    ("plane", Kind::Str),
    ("zenith_max", Kind::Num),
    ("step", Kind::Num),
    ("file", Kind::Str),
]);

/// Most view directions of one sensor.
const MAX_DIRECTIONS: usize = 100_000;

/// Reads a BRF sensor.
pub(crate) fn read(d: &Dict, cx: &Context) -> Result<(SensorKind, u32), SceneError> {
    let target = area(d, "target", cx)?;
    if target.is_none() && cx.cell.is_none() {
        return Err(d.err(
            d.span.clone(),
            "target",
            "a brf sensor needs a `target` area when the scene has no periodic domain",
        ));
    }
    let mut sweeps = Vec::new();
    if let Some(planes) = d.array("planes")? {
        for (i, item) in planes.get_ref().iter().enumerate() {
            let at = d.key(&format!("planes[{i}]"));
            let Value::Table(t) = item.get_ref() else {
                return Err(d.ld.err(
                    item.span(),
                    at,
                    "each plane is a table { plane = \"principal\", zenith_max = 75, step = 2, file = \"brfpp.csv\" }",
                ));
            };
            let p = Dict::open(d.ld, at, None, item.span(), t, PLANE_KEYS)?;
            let plane = p.req_string("plane")?;
            let (label, az) = match *plane.get_ref() {
                "principal" => ("principal plane", 0.0),
                "orthogonal" => ("orthogonal plane", 90.0),
                other => {
                    return Err(p.err(
                        plane.span(),
                        "plane",
                        format!("'{other}': principal or orthogonal"),
                    ));
                }
            };
            let zmax = p.float("zenith_max", 0.0, 89.9, false, 75.0)?;
            let step = p.float("step", 0.0, 90.0, true, 2.0)?;
            let n = (2.0 * zmax / step + 1e-3).floor() as usize + 1;
            if n > MAX_DIRECTIONS {
                return Err(p.err(
                    item.span(),
                    "step",
                    format!("{n} directions; at most {MAX_DIRECTIONS}"),
                ));
            }
            let directions = (0..n)
                .map(|k| {
                    let s = -zmax + k as f32 * step;
                    let s = if s.abs() < 1e-4 { 0.0 } else { s };
                    BrfDirection {
                        zenith: s.abs(),
                        relative_azimuth: if s < 0.0 { az + 180.0 } else { az },
                        signed_zenith: s,
                    }
                })
                .collect();
            let file = out_path(&p, "file", &["csv"])?.ok_or_else(|| p.missing("file"))?;
            p.finish()?;
            sweeps.push(BrfSweep {
                label: label.to_string(),
                directions,
                file,
            });
        }
    }
    if let Some(dirs) = d.array("directions")? {
        let items = dirs.get_ref();
        if items.is_empty() || items.len() > MAX_DIRECTIONS {
            return Err(d.err(
                dirs.span(),
                "directions",
                format!("{} directions; give 1 to {MAX_DIRECTIONS}", items.len()),
            ));
        }
        let mut directions = Vec::new();
        for item in items.iter() {
            let bad = |msg: &str| d.err(item.span(), "directions", msg.to_string());
            let Value::Array(a) = item.get_ref() else {
                return Err(bad(
                    "each direction is [zenith, relative_azimuth] in degrees",
                ));
            };
            let nums: Option<Vec<f64>> = a.iter().map(|v| v.get_ref().number()).collect();
            let Some([z, az]) = nums.as_deref().and_then(|v| <[f64; 2]>::try_from(v).ok()) else {
                return Err(bad(
                    "each direction is [zenith, relative_azimuth] in degrees",
                ));
            };
            if !(z.is_finite() && az.is_finite()) {
                return Err(bad("angles must be finite"));
            }
            if !(0.0..90.0).contains(&z) {
                return Err(bad(&format!(
                    "view zenith {z}° is not above the horizon: give 0 <= zenith < 90"
                )));
            }
            directions.push(BrfDirection {
                zenith: z as f32,
                relative_azimuth: az.rem_euclid(360.0) as f32,
                signed_zenith: z as f32,
            });
        }
        let file = out_path(d, "file", &["csv"])?.ok_or_else(|| d.missing("file"))?;
        sweeps.push(BrfSweep {
            label: "directions".into(),
            directions,
            file,
        });
    } else if let Some(f) = d.get("file") {
        return Err(d.err(
            f.span(),
            "file",
            "`file` is where `directions` go: give `directions` too, or drop it",
        ));
    }
    if sweeps.is_empty() {
        return Err(d.err(
            d.span.clone(),
            "planes",
            "a brf sensor needs view directions: `planes` and/or `directions`",
        ));
    }
    let plot = out_path(d, "plot", &["png"])?;
    Ok((
        SensorKind::Brf {
            target,
            sweeps,
            plot,
        },
        16384,
    ))
}
