//! `type = "irradiance"`: up- and downwelling irradiance on a horizontal plane.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `height` | m | required | the plane `y = height` |
//! | `area` | `{ min = [x, z], max = [x, z] }`, m | the periodic cell | where on the plane; required without a periodic domain; inside the cell |
//! | `grid` | two integers `[nx, nz]`, 1..1024 each | `[1, 1]` | cells over the area, each measured on its own |
//! | `file` | path, `.csv` | required | rows `x_min,x_max,z_min,z_max,channel,down,down_std,up,up_std` (W m⁻², standard errors) |
//!
//! `samples` (default 4096): rays per cell and hemisphere, from points spread over the
//! cell, cosine-distributed: downwelling looks up, upwelling looks down.

use super::{Context, area, out_path};
use crate::dict::{Dict, Keys, Kind, Value};
use crate::error::SceneError;
use lamina_core::radiometry::SensorKind;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("height", Kind::Num),
    ("area", Kind::Table),
    ("grid", Kind::Array),
    ("file", Kind::Str),
]);

/// Reads an irradiance sensor.
pub(crate) fn read(d: &Dict, cx: &Context) -> Result<(SensorKind, u32), SceneError> {
    let height = d.req_float("height", -1e7, 1e7, false)?;
    let area = area(d, "area", cx)?;
    if area.is_none() && cx.cell.is_none() {
        return Err(d.err(
            d.span.clone(),
            "area",
            "an irradiance sensor needs an `area` when the scene has no periodic domain",
        ));
    }
    let mut grid = [1u32, 1];
    if let Some(g) = d.get("grid") {
        let bad = || {
            d.err(
                g.span(),
                "grid",
                "must be two integers [nx, nz], each 1 to 1024",
            )
        };
        let Value::Array(a) = g.get_ref() else {
            return Err(bad());
        };
        if a.len() != 2 {
            return Err(bad());
        }
        for (o, v) in grid.iter_mut().zip(a) {
            match v.get_ref() {
                Value::Integer(n) if (1..=1024).contains(n) => *o = *n as u32,
                _ => return Err(bad()),
            }
        }
    }
    let file = out_path(d, "file", &["csv"])?.ok_or_else(|| d.missing("file"))?;
    Ok((
        SensorKind::Irradiance {
            height,
            area,
            grid,
            file,
        },
        4096,
    ))
}
