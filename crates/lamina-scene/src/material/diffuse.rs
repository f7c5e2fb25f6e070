//! `type = "diffuse"`: an opaque Lambertian surface.
//!
//! | key | unit, range | default | meaning |
//! |---|---|---|---|
//! | `name` | string | required | the name objects use |
//! | `reflectance` | colour in [0, 1] | `0.5` | albedo; multiplies `reflectance_map` when both are given |
//! | `reflectance_map` | sRGB image | none | albedo texture |
//! | `alpha` | image | none | matte: the first channel, or the alpha channel when the image has one |
//! | `alpha_cutoff` | [0, 1] | `0.5` | the surface exists where the matte is >= the cutoff; needs `alpha` |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::Material;
use glam::Vec3;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("name", Kind::Str),
    ("reflectance", Kind::Color),
    ("reflectance_map", Kind::Str),
    ("alpha", Kind::Str),
    ("alpha_cutoff", Kind::Num),
]);

/// Reads a diffuse material.
pub(crate) fn read(d: &Dict, name: String) -> Result<Material, SceneError> {
    let reflectance = super::color_input(d, "reflectance", Vec3::splat(0.5))?;
    Ok(Material::Diffuse {
        name,
        reflectance,
        alpha: super::alpha_mask(d, false)?,
    })
}
