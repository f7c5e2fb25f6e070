//! The TOML scene-file schema: one struct per table, every value spanned so that errors
//! can name the line. Conversion into a [`crate::Scene`] (with validation) is in
//! [`crate::load`]. The reference for users is `docs/scene-format.md`.

use glam::Vec3;
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::fmt;
use toml::Spanned;

/// A spanned value: the value and its byte range in the file.
pub type S<T> = Spanned<T>;

/// A colour: one number (grey) or `[r, g, b]`, linear.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColorValue(pub Vec3);

impl<'de> Deserialize<'de> for ColorValue {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ColorValue;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of three numbers [r, g, b]")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<ColorValue, E> {
                Ok(ColorValue(Vec3::splat(v as f32)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<ColorValue, E> {
                Ok(ColorValue(Vec3::splat(v as f32)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<ColorValue, E> {
                Ok(ColorValue(Vec3::splat(v as f32)))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<ColorValue, A::Error> {
                let mut c = [0.0f32; 3];
                for (i, slot) in c.iter_mut().enumerate() {
                    *slot = seq
                        .next_element::<f32>()?
                        .ok_or_else(|| de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<de::IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(4, &self));
                }
                Ok(ColorValue(Vec3::from(c)))
            }
        }
        d.deserialize_any(V)
    }
}

/// The whole scene file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub camera: S<CameraTable>,
    pub film: Option<S<FilmTable>>,
    pub integrator: Option<S<IntegratorTable>>,
    pub sky: Option<S<SkyTable>>,
    #[serde(default)]
    pub light: Vec<S<LightTable>>,
    #[serde(default)]
    pub material: Vec<S<MaterialTable>>,
    #[serde(default)]
    pub object: Vec<S<ObjectTable>>,
}

/// `[camera]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraTable {
    pub position: S<[f32; 3]>,
    pub look_at: S<[f32; 3]>,
    pub up: Option<S<[f32; 3]>>,
    pub fov: Option<S<f32>>,
    pub aperture_radius: Option<S<f32>>,
    pub focus_distance: Option<S<f32>>,
}

/// `[film]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilmTable {
    pub width: Option<S<i64>>,
    pub height: Option<S<i64>>,
    pub spp: Option<S<i64>>,
    pub filter: Option<S<String>>,
    pub filter_radius: Option<S<f32>>,
    pub filter_sigma: Option<S<f32>>,
    pub exposure: Option<S<f32>>,
    pub tonemap: Option<S<String>>,
}

/// `[integrator]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorTable {
    #[serde(rename = "type")]
    pub kind: Option<S<String>>,
    pub max_depth: Option<S<i64>>,
    pub rr_depth: Option<S<i64>>,
    pub ambient: Option<S<ColorValue>>,
}

/// `[sky]`
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyTable {
    #[serde(rename = "type")]
    pub kind: S<String>,
    pub radiance: Option<S<ColorValue>>,
    pub file: Option<S<String>>,
    pub scale: Option<S<f32>>,
    pub rotation: Option<S<f32>>,
}

/// `[[light]]`: one flat table for every light type; which keys a type takes is checked
/// in [`crate::load`].
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightTable {
    #[serde(rename = "type")]
    pub kind: S<String>,
    pub direction: Option<S<[f32; 3]>>,
    pub irradiance: Option<S<ColorValue>>,
    pub angular_diameter: Option<S<f32>>,
    pub position: Option<S<[f32; 3]>>,
    pub intensity: Option<S<ColorValue>>,
    pub corner: Option<S<[f32; 3]>>,
    pub edge_u: Option<S<[f32; 3]>>,
    pub edge_v: Option<S<[f32; 3]>>,
    pub radiance: Option<S<ColorValue>>,
    pub two_sided: Option<S<bool>>,
    pub center: Option<S<[f32; 3]>>,
    pub radius: Option<S<f32>>,
}

/// `[[material]]`: one flat table for every material type.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialTable {
    pub name: S<String>,
    #[serde(rename = "type")]
    pub kind: S<String>,
    pub reflectance: Option<S<ColorValue>>,
    pub reflectance_map: Option<S<String>>,
    pub transmittance: Option<S<ColorValue>>,
    pub transmittance_map: Option<S<String>>,
    pub alpha: Option<S<String>>,
    pub alpha_cutoff: Option<S<f32>>,
    pub file: Option<S<String>>,
    pub species: Option<S<String>>,
    pub seed: Option<S<i64>>,
    pub resolution: Option<S<i64>>,
    pub maps: Option<S<toml::Table>>,
    pub params: Option<S<toml::Table>>,
    /// `pbr`: base colour (linear), multiplies `base_color_map` (sRGB) when both are given.
    pub base_color: Option<S<ColorValue>>,
    pub base_color_map: Option<S<String>>,
    /// `pbr`: metallic and perceptual roughness factors, multiplied by the blue and green
    /// channels of `metallic_roughness_map` (linear) when it is given.
    pub metallic: Option<S<f32>>,
    pub roughness: Option<S<f32>>,
    pub metallic_roughness_map: Option<S<String>>,
    pub ior: Option<S<f32>>,
    /// `pbr`: diffuse transmission factor and colour.
    pub transmission: Option<S<f32>>,
    pub transmission_color: Option<S<ColorValue>>,
    /// `pbr`: tangent-space normal map (linear, OpenGL/glTF convention) and its scale.
    pub normal_map: Option<S<String>>,
    pub normal_scale: Option<S<f32>>,
    /// `pbr`: the same as `alpha` (a matte image), under the name of the other maps.
    pub alpha_map: Option<S<String>>,
}

/// `transform = { ... }` on an object: scale, then rotations about x, y, z, then translate.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformTable {
    pub scale: Option<ColorValue>,
    pub rotate_x: Option<f32>,
    pub rotate_y: Option<f32>,
    pub rotate_z: Option<f32>,
    pub translate: Option<[f32; 3]>,
}

pub use lamina_core::cards::CardRow;

/// `[[object]]`: one flat table for every object type.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectTable {
    #[serde(rename = "type")]
    pub kind: S<String>,
    pub material: Option<S<String>>,
    pub file: Option<S<String>>,
    pub transform: Option<S<TransformTable>>,
    pub corner: Option<S<[f32; 3]>>,
    pub edge_u: Option<S<[f32; 3]>>,
    pub edge_v: Option<S<[f32; 3]>>,
    pub cards: Option<S<Vec<CardRow>>>,
    pub materials: Option<S<toml::Table>>,
    /// Name of the object (prototype name in messages).
    pub name: Option<S<String>>,
    /// `[object.plant]`: [`lamina_plant::PlantParams`] keys, each spanned for errors.
    pub plant: Option<S<PlantTable>>,
    /// Plant objects: `"cards"` (flat leaf cards, the default) or `"curved"` (one curved
    /// leaf mesh per leaf variant, placed by one instance per leaf).
    pub leaves: Option<S<String>>,
    /// The transform keys may also sit on the object itself (not with `transform`).
    pub scale: Option<S<ColorValue>>,
    pub rotate_x: Option<S<f32>>,
    pub rotate_y: Option<S<f32>>,
    pub rotate_z: Option<S<f32>>,
    pub translate: Option<S<[f32; 3]>>,
    /// Inline placements: the object becomes a prototype placed once per entry.
    pub instances: Option<S<Vec<S<TransformTable>>>>,
    /// A CSV file of placements (see `docs/scene-format.md`).
    pub instances_file: Option<S<String>>,
}

/// `[object.plant]`: plant parameters by name, keys and values spanned.
pub type PlantTable = std::collections::BTreeMap<S<String>, S<toml::Value>>;
