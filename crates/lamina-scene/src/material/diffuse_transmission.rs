//! `type = "diffuse_transmission"`: Lambertian reflection plus Lambertian transmission,
//! two-sided (pbrt-v4 `diffusetransmission`, glTF `KHR_materials_diffuse_transmission`).
//!
//! | key | unit, range | default | meaning |
//! |---|---|---|---|
//! | `name` | string | required | the name objects use |
//! | `reflectance` | colour in [0, 1] | `0.25` | reflected share; multiplies `reflectance_map` |
//! | `reflectance_map` | sRGB image | none | reflectance texture |
//! | `transmittance` | colour in [0, 1] | `0.25` | transmitted share; multiplies `transmittance_map`. Constant `reflectance + transmittance` must be <= 1 per channel |
//! | `transmittance_map` | sRGB image | none | transmittance texture |
//! | `alpha` | image | none | matte: the first channel, or the alpha channel when the image has one |
//! | `alpha_cutoff` | [0, 1] | `0.5` | the surface exists where the matte is >= the cutoff; needs `alpha` |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::{ColorInput, Material};
use glam::Vec3;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("name", Kind::Str),
    ("reflectance", Kind::Color),
    ("reflectance_map", Kind::Str),
    ("transmittance", Kind::Color),
    ("transmittance_map", Kind::Str),
    ("alpha", Kind::Str),
    ("alpha_cutoff", Kind::Num),
]);

/// Reads a diffuse-transmission material.
pub(crate) fn read(d: &Dict, name: String) -> Result<Material, SceneError> {
    let reflectance = super::color_input(d, "reflectance", Vec3::splat(0.25))?;
    let transmittance = super::color_input(d, "transmittance", Vec3::splat(0.25))?;
    if let (ColorInput::Constant(r), ColorInput::Constant(tr)) = (&reflectance, &transmittance)
        && (*r + *tr).max_element() > 1.0 + 1e-6
    {
        let span = d.get("transmittance").map_or(d.span.clone(), |v| v.span());
        return Err(d.err(
            span,
            "transmittance",
            format!(
                "reflectance + transmittance must be <= 1 per channel (energy), got {:?}",
                (*r + *tr).to_array()
            ),
        ));
    }
    Ok(Material::DiffuseTransmission {
        name,
        reflectance,
        transmittance,
        alpha: super::alpha_mask(d, false)?,
    })
}
