//! `[[material]]` (any number; `name` and `type` required; names unique): one module per
//! material type, each with its parameter table, and the inputs they share (colours with
//! optional maps, alpha mattes).

use crate::dict::{Dict, Key, Keys, S, Table, Value, open_typed};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::{AlphaMask, ColorInput, Material};
use glam::Vec3;
use lamina_leaf::Encoding;

mod diffuse;
mod diffuse_transmission;
mod leaf;
mod pbr;

/// The keys of a material type that takes `own`.
const fn keys(own: &'static [Key]) -> Keys {
    Keys {
        own,
        common: &[],
        typed: true,
    }
}

/// A material type's reader: the dictionary and the material's name.
type Reader = fn(&Dict, String) -> Result<Material, SceneError>;

/// Every material type: its name, keys and reader.
pub(crate) const TYPES: &[(&str, Keys, Reader)] = &[
    ("diffuse", diffuse::KEYS, diffuse::read),
    (
        "diffuse_transmission",
        diffuse_transmission::KEYS,
        diffuse_transmission::read,
    ),
    ("leaf", leaf::KEYS, leaf::read),
    ("pbr", pbr::KEYS, pbr::read),
];

/// The `name` of `[[material]]` number `i` (required, a string).
pub(crate) fn name<'a>(ld: &Loader, i: usize, t: &'a S<Table>) -> Result<S<&'a str>, SceneError> {
    match t.get_ref().iter().find(|(k, _)| k.get_ref() == "name") {
        None => Err(ld.err(
            t.span(),
            format!("material[{i}].name"),
            "missing field `name`",
        )),
        Some((_, v)) => match v.get_ref() {
            Value::String(s) => Ok(S::new(v.span(), s.as_str())),
            other => Err(ld.err(
                v.span(),
                format!("material[{i}].name"),
                format!("must be a string, got {}", other.type_name()),
            )),
        },
    }
}

/// Checks the keys and their types of `[[material]]` number `i` (before any table is read).
pub(crate) fn check(ld: &Loader, i: usize, t: &S<Table>) -> Result<(), SceneError> {
    open_typed(ld, "material", format!("material[{i}]"), t, TYPES).map(drop)
}

/// Reads `[[material]]` number `i`.
pub(crate) fn read(ld: &Loader, i: usize, t: &S<Table>) -> Result<Material, SceneError> {
    let name = name(ld, i, t)?.get_ref().to_string();
    let (d, read) = open_typed(ld, "material", format!("material[{i}]"), t, TYPES)?;
    d.get("name");
    let material = read(&d, name)?;
    d.finish()?;
    Ok(material)
}

/// A colour `name` in [0, 1] with an optional sRGB map `name_map` it multiplies; `default`
/// when neither is given.
pub(crate) fn color_input(d: &Dict, name: &str, default: Vec3) -> Result<ColorInput, SceneError> {
    let factor = d.color_opt(name, Some(1.0))?;
    let map_key = format!("{name}_map");
    Ok(match d.string(&map_key)? {
        Some(p) => ColorInput::Texture {
            map: d.ld.texture(&p, &d.key(&map_key), Encoding::Srgb)?,
            factor: factor.unwrap_or(Vec3::ONE),
        },
        None => ColorInput::Constant(factor.unwrap_or(default)),
    })
}

/// The alpha matte: `alpha` (or, where the type takes it, `alpha_map`: another name for
/// it) and `alpha_cutoff`.
pub(crate) fn alpha_mask(d: &Dict, takes_alpha_map: bool) -> Result<Option<AlphaMask>, SceneError> {
    let alpha = d.string("alpha")?;
    let alpha_map = if takes_alpha_map {
        d.string("alpha_map")?
    } else {
        None
    };
    let (p, map_key) = match (alpha, alpha_map) {
        (Some(_), Some(b)) => {
            return Err(d.err(
                b.span(),
                "alpha_map",
                "give either 'alpha' or 'alpha_map', not both",
            ));
        }
        (Some(a), None) => (a, "alpha"),
        (None, Some(b)) => (b, "alpha_map"),
        (None, None) => {
            if let Some(c) = d.get("alpha_cutoff") {
                return Err(d.err(
                    c.span(),
                    "alpha_cutoff",
                    "needs an alpha map ('alpha = \"matte.png\"')",
                ));
            }
            return Ok(None);
        }
    };
    let map = d.ld.texture(&p, &d.key(map_key), Encoding::Linear)?;
    let cutoff = d.float("alpha_cutoff", 0.0, 1.0, false, 0.5)?;
    // A matte with an alpha channel that is not all opaque is read from that channel.
    let use_alpha_channel = map.texels().iter().any(|t| t.w < 1.0);
    Ok(Some(AlphaMask {
        map,
        use_alpha_channel,
        cutoff,
    }))
}
