//! `[[light]]` (any number): one module per light type, each with its parameter table.

use crate::dict::{Dict, Key, Keys, S, Table, open_typed};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::Light;

mod point;
mod quad;
mod sphere;
pub(crate) mod sun;

/// The keys of a light type that takes `own`.
const fn keys(own: &'static [Key]) -> Keys {
    Keys {
        own,
        common: &[],
        typed: true,
    }
}

/// A light type's reader.
type Reader = fn(&Dict) -> Result<Light, SceneError>;

/// Every light type: its name, keys and reader.
pub(crate) const TYPES: &[(&str, Keys, Reader)] = &[
    ("sun", sun::KEYS, sun::read),
    ("point", point::KEYS, point::read),
    ("quad", quad::KEYS, quad::read),
    ("sphere", sphere::KEYS, sphere::read),
];

/// Checks the keys and their types of `[[light]]` number `i` (before any table is read).
pub(crate) fn check(ld: &Loader, i: usize, t: &S<Table>) -> Result<(), SceneError> {
    open_typed(ld, "light", format!("light[{i}]"), t, TYPES).map(drop)
}

/// Reads `[[light]]` number `i`.
pub(crate) fn read(ld: &Loader, i: usize, t: &S<Table>) -> Result<Light, SceneError> {
    let (d, read) = open_typed(ld, "light", format!("light[{i}]"), t, TYPES)?;
    let light = read(&d)?;
    d.finish()?;
    Ok(light)
}

/// The required `corner`, `edge_u`, `edge_v` of a parallelogram, with edges that span a
/// non-zero area (quad lights and quad objects).
pub(crate) fn parallelogram(d: &Dict) -> Result<(glam::Vec3, glam::Vec3, glam::Vec3), SceneError> {
    let c = d.req_vec3("corner")?;
    let u = d.req_vec3_spanned("edge_u")?;
    let v = d.req_vec3("edge_v")?;
    if u.get_ref().cross(v).length_squared() < 1e-16 {
        return Err(d.err(
            u.span(),
            "edge_u",
            "edge_u and edge_v must span a non-zero area",
        ));
    }
    Ok((c, u.into_inner(), v))
}
