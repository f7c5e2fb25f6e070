//! `[[sensor]]` (any number; `type` required): radiometric measurements written beside the
//! picture, one module per sensor type, each with its parameter table. The keys every
//! sensor takes are read here.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `name` | string | `sensor[i]` | the sensor's name in messages and progress |
//! | `samples` | count, 1..2^31 | per type | Monte Carlo samples (see each type) |
//! | `channel` | a film channel: `R`, `G`, `B`, or a band of `[film] bands` | every channel | write only this channel, in the single-value layout (RAMI's `brf std` columns) |
//!
//! Output files are relative to the scene file. Values are per film channel: linear
//! Rec.709 R, G, B, or the film's bands (each file then holds every band; the sensors run
//! three bands at a time, as band images do, and irradiance is band-mean spectral
//! irradiance, W m⁻² nm⁻¹; BRFs and fractions are ratios either way).

use crate::dict::{Dict, Key, Keys, Kind, S, Table, open_typed};
use crate::error::SceneError;
use crate::loader::Loader;
use lamina_core::radiometry::{Rect, Sensor, SensorKind};
use std::collections::HashMap;

mod absorbed;
mod brf;
mod fisheye;
mod irradiance;

/// The keys every sensor type takes, after its own.
pub(crate) const COMMON: &[Key] = &[
    ("name", Kind::Str),
    ("samples", Kind::Int),
    ("channel", Kind::Str),
];

/// The keys of a sensor type that takes `own` besides [`COMMON`].
const fn keys(own: &'static [Key]) -> Keys {
    Keys {
        own,
        common: COMMON,
        typed: true,
    }
}

/// What sensor readers need from the rest of the scene.
pub(crate) struct Context<'a> {
    /// The periodic cell, if any.
    pub(crate) cell: Option<Rect>,
    /// Material indices by name.
    pub(crate) materials: &'a HashMap<String, u32>,
}

/// A sensor type's reader: the measurement and its default sample count.
type Reader = fn(&Dict, &Context) -> Result<(SensorKind, u32), SceneError>;

/// Every sensor type: its name, keys and reader.
pub(crate) const TYPES: &[(&str, Keys, Reader)] = &[
    ("brf", brf::KEYS, brf::read),
    ("irradiance", irradiance::KEYS, irradiance::read),
    ("absorbed", absorbed::KEYS, absorbed::read),
    ("fisheye", fisheye::KEYS, fisheye::read),
];

/// Checks the keys and their types of `[[sensor]]` number `i`.
pub(crate) fn check(ld: &Loader, i: usize, t: &S<Table>) -> Result<(), SceneError> {
    open_typed(ld, "sensor", format!("sensor[{i}]"), t, TYPES).map(drop)
}

/// Reads `[[sensor]]` number `i`; `channels` are the film's channel names.
pub(crate) fn read(
    ld: &Loader,
    i: usize,
    t: &S<Table>,
    cx: &Context,
    channels: &[String],
) -> Result<Sensor, SceneError> {
    let (d, read) = open_typed(ld, "sensor", format!("sensor[{i}]"), t, TYPES)?;
    let name = d
        .string("name")?
        .map_or_else(|| format!("sensor[{i}]"), |s| s.get_ref().to_string());
    let (kind, default_samples) = read(&d, cx)?;
    let samples = d.count("samples", 1, i32::MAX as i64, default_samples)?;
    let channel = match d.string("channel")? {
        None => None,
        Some(c) => Some(
            channels
                .iter()
                .position(|n| n == c.get_ref())
                .ok_or_else(|| {
                    d.err(
                        c.span(),
                        "channel",
                        format!(
                            "'{}' is not a channel of the film ({})",
                            c.get_ref(),
                            channels.join(", ")
                        ),
                    )
                })?,
        ),
    };
    d.finish()?;
    Ok(Sensor {
        name,
        samples,
        channel,
        kind,
    })
}

/// The area a sensor measures over: `key` if given (inside the periodic cell), else the
/// cell; an error when neither is there and `required`.
pub(crate) fn area(d: &Dict, key: &str, cx: &Context) -> Result<Option<Rect>, SceneError> {
    let r = crate::table::domain::rect(d, key)?;
    if let (Some(r), Some(cell)) = (r, cx.cell)
        && !cell.contains_rect(&r)
    {
        let v = d.get(key).expect("read above");
        return Err(d.err(
            v.span(),
            key,
            format!(
                "[{}, {}]..[{}, {}] reaches outside the periodic cell [{}, {}]..[{}, {}]",
                r.min.x, r.min.y, r.max.x, r.max.y, cell.min.x, cell.min.y, cell.max.x, cell.max.y
            ),
        ));
    }
    Ok(r)
}

/// A required output path (relative to the scene file) at `key`, with one of `exts`.
pub(crate) fn out_path(
    d: &Dict,
    key: &str,
    exts: &[&str],
) -> Result<Option<std::path::PathBuf>, SceneError> {
    let Some(f) = d.string(key)? else {
        return Ok(None);
    };
    let ext = std::path::Path::new(f.get_ref())
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !ext.as_deref().is_some_and(|e| exts.contains(&e)) {
        return Err(d.err(
            f.span(),
            key,
            format!(
                "'{}': the file must end in .{}",
                f.get_ref(),
                exts.join(" or .")
            ),
        ));
    }
    Ok(Some(d.ld.path(f.get_ref())))
}
