//! `type = "pbr"`: the glTF 2.0 metallic-roughness surface (pots, stems, bark, stones,
//! ground), with optional diffuse transmission and a normal map.
//!
//! | key | unit, range | default | meaning |
//! |---|---|---|---|
//! | `name` | string | required | the name objects use |
//! | `base_color` | colour in [0, 1] | `0.8` | diffuse colour of the dielectric part, specular colour (F0) of the metallic part; multiplies `base_color_map` |
//! | `base_color_map` | sRGB image | none | base-colour texture |
//! | `metallic` | [0, 1] | `0` | metalness |
//! | `roughness` | [0, 1] | `0.5` | perceptual roughness (GGX `alpha = roughness²`) |
//! | `metallic_roughness_map` | linear image | none | glTF `metallicRoughnessTexture`: green multiplies `roughness`, blue multiplies `metallic` |
//! | `ior` | [1, 3] | `1.5` | index of refraction of the dielectric part (1.5: 4 % reflection at normal incidence) |
//! | `transmission` | [0, 1] | `0` | diffuse transmission factor (`KHR_materials_diffuse_transmission`): the share of the diffuse light that goes through |
//! | `transmission_color` | colour in [0, 1] | `1` | colour of the transmitted light |
//! | `normal_map` | linear image | none | tangent-space normal map, OpenGL/glTF convention: `n = 2·rgb − 1`, +x along `u`, +y toward the top of the image (increasing `v`), +z along the surface normal |
//! | `normal_scale` | [0, 10] | `1` | multiplies the normal map's x and y (0 = flat); needs `normal_map` |
//! | `alpha` (or `alpha_map`) | image | none | matte: the first channel, or the alpha channel when the image has one |
//! | `alpha_cutoff` | [0, 1] | `0.5` | the surface exists where the matte is >= the cutoff; needs `alpha` |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::{ColorInput, Material, NormalMap, PbrMaterial};
use glam::Vec3;
use lamina_leaf::Encoding;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("name", Kind::Str),
    ("base_color", Kind::Color),
    ("base_color_map", Kind::Str),
    ("metallic", Kind::Num),
    ("roughness", Kind::Num),
    ("metallic_roughness_map", Kind::Str),
    ("ior", Kind::Num),
    ("transmission", Kind::Num),
    ("transmission_color", Kind::Color),
    ("normal_map", Kind::Str),
    ("normal_scale", Kind::Num),
    ("alpha", Kind::Str),
    ("alpha_map", Kind::Str),
    ("alpha_cutoff", Kind::Num),
]);

/// Reads a pbr material.
pub(crate) fn read(d: &Dict, name: String) -> Result<Material, SceneError> {
    let base_color = super::color_input(d, "base_color", Vec3::splat(0.8))?;
    let metallic = d.float("metallic", 0.0, 1.0, false, 0.0)?;
    let roughness = d.float("roughness", 0.0, 1.0, false, 0.5)?;
    let metallic_roughness = d
        .string("metallic_roughness_map")?
        .map(|f| {
            d.ld.texture(&f, &d.key("metallic_roughness_map"), Encoding::Linear)
        })
        .transpose()?;
    let ior = d.float("ior", 1.0, 3.0, false, 1.5)?;
    let transmission = d.float("transmission", 0.0, 1.0, false, 0.0)?;
    let transmission_color = d
        .color_opt("transmission_color", Some(1.0))?
        .unwrap_or(Vec3::ONE);
    let normal_map = match d.string("normal_map")? {
        Some(f) => Some(NormalMap {
            map: d.ld.texture(&f, &d.key("normal_map"), Encoding::Linear)?,
            scale: d.float("normal_scale", 0.0, 10.0, false, 1.0)?,
        }),
        None => {
            if let Some(s) = d.get("normal_scale") {
                return Err(d.err(
                    s.span(),
                    "normal_scale",
                    "needs a normal map ('normal_map = \"normals.png\"')",
                ));
            }
            None
        }
    };
    Ok(Material::Pbr(Box::new(PbrMaterial {
        name,
        base_color,
        metallic,
        roughness,
        metallic_roughness,
        ior,
        transmission,
        transmission_map: None,
        transmission_color: ColorInput::Constant(transmission_color),
        normal_map,
        alpha: super::alpha_mask(d, true)?,
    })))
}
