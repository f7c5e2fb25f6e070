//! `type = "absorbed"`: where the light of the sun and sky goes: absorbed per material and
//! per object, reflected out of the top, transmitted to the ground.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `area` | `{ min = [x, z], max = [x, z] }`, m | the periodic cell | photons enter through this area at the top of the scene; required without a periodic domain; inside the cell |
//! | `ground` | an array of material names | none | the ground: `ftran` is the power arriving at it, and `fabs` counts every other material |
//! | `file` | path, `.csv` | required | rows `measure,channel,value,std`: `albedo`, `fabs`, `ftran`, `ftran_uncollided` (the first flights that reach the ground), `escaped`, `incident` (W m⁻²), `absorbed:material:NAME`, `absorbed:object:NAME` (fractions of the incident power; with `channel`, the columns are `measure,value,std`) |
//!
//! `samples` (default 1,000,000): photons, traced from the sun and sky through the scene
//! (light tracing, Russian roulette on their power); each hit deposits the expected
//! absorbed share `1 − albedo` of what arrives, so a bi-Lambertian leaf's absorption is
//! exact per hit. Only the sun and the sky are counted.

use super::{Context, area, out_path};
use crate::dict::{Dict, Keys, Kind, Value};
use crate::error::SceneError;
use lamina_core::radiometry::SensorKind;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("area", Kind::Table),
    ("ground", Kind::Array),
    ("file", Kind::Str),
]);

/// Reads an absorbed-power sensor.
pub(crate) fn read(d: &Dict, cx: &Context) -> Result<(SensorKind, u32), SceneError> {
    let area = area(d, "area", cx)?;
    if area.is_none() && cx.cell.is_none() {
        return Err(d.err(
            d.span.clone(),
            "area",
            "an absorbed sensor needs an `area` (where the light enters) when the scene has no periodic domain",
        ));
    }
    let mut ground = Vec::new();
    if let Some(g) = d.get("ground") {
        let Value::Array(names) = g.get_ref() else {
            return Err(d.err(g.span(), "ground", "must be an array of material names"));
        };
        for n in names {
            let Value::String(s) = n.get_ref() else {
                return Err(d.err(n.span(), "ground", "must be an array of material names"));
            };
            let Some(&m) = cx.materials.get(s) else {
                let mut known: Vec<&str> = cx.materials.keys().map(String::as_str).collect();
                known.sort_unstable();
                return Err(d.err(
                    n.span(),
                    "ground",
                    format!("no material named '{s}' ({})", known.join(", ")),
                ));
            };
            ground.push(m);
        }
    }
    let file = out_path(d, "file", &["csv"])?.ok_or_else(|| d.missing("file"))?;
    Ok((SensorKind::Absorbed { area, ground, file }, 1_000_000))
}
