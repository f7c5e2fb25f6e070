//! `[domain]`: the scene as one cell of an infinite periodic canopy (RAMI's "infinite"
//! scenes).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `periodic` | `{ min = [x, z], max = [x, z] }`, m | none | the cell: the scene's content over it repeats without end along x and z; rays leaving a side re-enter through the opposite one (camera, light and sensor paths alike). Objects crossing the cell's border are copied one cell over; objects outside it are moved in by whole cells; an object spanning the whole cell along an axis (a ground plane) is cut at the cell's sides; an object wider than the cell that does not span it is an error. Only the sun and the sky may light a periodic scene |

use crate::dict::{Dict, Keys, Kind, S, Table, Value};
use crate::error::SceneError;
use crate::loader::Loader;
use lamina_core::radiometry::{Periodic, Rect};

/// The keys of the table above.
pub(crate) const KEYS: Keys = Keys::plain(&[("periodic", Kind::Table)]);

/// The keys of a rectangle `{ min, max }`.
const RECT_KEYS: Keys = Keys::plain(&[("min", Kind::Array), ("max", Kind::Array)]);

/// Checks the keys of `[domain]` and their types.
pub(crate) fn check(ld: &Loader, t: &S<Table>) -> Result<(), SceneError> {
    Dict::open(ld, "domain", None, t.span(), t.get_ref(), KEYS).map(drop)
}

/// Reads `[domain]`.
pub(crate) fn read(ld: &Loader, t: Option<&S<Table>>) -> Result<Option<Periodic>, SceneError> {
    let Some(t) = t else { return Ok(None) };
    let d = Dict::open(ld, "domain", None, t.span(), t.get_ref(), KEYS)?;
    let cell = rect(&d, "periodic")?;
    d.finish()?;
    Ok(cell.map(|cell| Periodic { cell }))
}

/// `[x, z]`: two finite numbers (m), within ±1e7.
pub(crate) fn vec2(d: &Dict, name: &str) -> Result<Option<S<glam::Vec2>>, SceneError> {
    let Some(v) = d.get(name) else {
        return Ok(None);
    };
    let bad = || d.err(v.span(), name, "must be two numbers [x, z] (m)");
    let Value::Array(a) = v.get_ref() else {
        return Err(bad());
    };
    if a.len() != 2 {
        return Err(bad());
    }
    let mut out = [0.0f32; 2];
    for (o, x) in out.iter_mut().zip(a) {
        let n = x.get_ref().number().ok_or_else(bad)? as f32;
        if !n.is_finite() || n.abs() > 1e7 {
            return Err(d.err(
                v.span(),
                name,
                format!("{n}: coordinates must be finite, within ±1e7 m"),
            ));
        }
        *o = n;
    }
    Ok(Some(S::new(v.span(), glam::Vec2::from(out))))
}

/// A rectangle `{ min = [x, z], max = [x, z] }` at key `name` of `d`, with `max > min` on
/// both axes.
pub(crate) fn rect(d: &Dict, name: &str) -> Result<Option<Rect>, SceneError> {
    let Some(t) = d.table(name)? else {
        return Ok(None);
    };
    let r = Dict::open(d.ld, d.key(name), None, t.span(), t.get_ref(), RECT_KEYS)?;
    let min = vec2(&r, "min")?.ok_or_else(|| r.missing("min"))?;
    let max = vec2(&r, "max")?.ok_or_else(|| r.missing("max"))?;
    let (lo, hi) = (*min.get_ref(), *max.get_ref());
    if !(hi.x > lo.x && hi.y > lo.y) {
        return Err(r.err(
            max.span(),
            "max",
            format!(
                "[{}, {}] must be larger than min [{}, {}] in both x and z: the area has no size",
                hi.x, hi.y, lo.x, lo.y
            ),
        ));
    }
    r.finish()?;
    Ok(Some(Rect { min: lo, max: hi }))
}
