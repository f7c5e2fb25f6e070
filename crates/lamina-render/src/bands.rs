//! Rendering in spectral bands, three at a time: a copy of the scene whose every RGB value
//! is replaced by its values in three bands ([`lamina_leaf::spectrum::bands`] says how), so
//! that the RGB integrator, unchanged and at its own speed, renders band `i` in channel `i`.
//!
//! * Leaves made from PROSPECT pigments are rebuilt at the three band centres from their
//!   pigments ([`lamina_leaf::PigmentLeaf::material`]): truly spectral, 400-2500 nm.
//! * Every other material value (colours, colour maps, a leaf's colour maps and layer
//!   coefficients, PBR base and transmission colours) goes through the reflectance basis;
//!   lights and skies through the emission basis (band-mean spectral radiance per nm).
//! * A physical sky (`[sky] type = "sunsky"`, [`lamina_core::SpectralSky`]) is remade in the
//!   bands from its spectra, and so is the sun it brought.
//! * Geometry, alpha mattes, normal and bump maps, roughness and every scalar are kept.

use crate::RenderError;
use glam::{Vec3, Vec4};
use lamina_core::{ColorInput, Light, Material, Scene, Sky};
use lamina_leaf::spectrum::bands::{Band, BandBasis};
use lamina_leaf::{LeafMaterial, Texture};
use std::sync::Arc;

/// `scene` with its values in `bands` (channel `i` = band `i`).
pub fn band_scene(scene: &Scene, bands: [&Band; 3]) -> Result<Scene, RenderError> {
    let basis = BandBasis::new(bands);
    let centres = bands.map(|b| b.center());
    let mut s = scene.clone();
    for m in &mut s.materials {
        *m = band_material(m, &basis, centres)?;
    }
    for l in &mut s.lights {
        match l {
            Light::Sun { irradiance, .. } => *irradiance = basis.emission(*irradiance),
            Light::Point { intensity, .. } => *intensity = basis.emission(*intensity),
            Light::Quad { radiance, .. } | Light::Sphere { radiance, .. } => {
                *radiance = basis.emission(*radiance)
            }
        }
    }
    if let Some(sky) = &mut s.sky {
        match sky {
            Sky::Constant(c) => *c = basis.emission(*c),
            // A physical sky is remade in the bands, with its sun (the scene's last light).
            Sky::Image {
                map,
                spectral: Some(spectral),
                ..
            } => {
                *map = spectral.band_map(bands);
                if let Some(e) = spectral.band_sun(bands)
                    && let Some(Light::Sun { irradiance, .. }) = s.lights.last_mut()
                {
                    *irradiance = e;
                }
            }
            Sky::Image { map, .. } => *map = map_texture(map, |c| basis.emission(c)),
        }
    }
    Ok(s)
}

/// How `count` bands render: the indices of up to three bands per render, in order.
pub fn band_groups(count: usize) -> Vec<Vec<usize>> {
    (0..count)
        .collect::<Vec<_>>()
        .chunks(3)
        .map(<[usize]>::to_vec)
        .collect()
}

/// [`band_scene`] for the bands `group` of `bands` (one of [`band_groups`]); a group of
/// fewer than three repeats its last band in the spare channels.
pub fn group_scene(scene: &Scene, bands: &[Band], group: &[usize]) -> Result<Scene, RenderError> {
    let pick = |k: usize| &bands[group[k.min(group.len() - 1)]];
    band_scene(scene, [pick(0), pick(1), pick(2)])
}

/// A texture with `f` applied to the RGB of every texel (alpha kept).
fn map_texture(t: &Texture, f: impl Fn(Vec3) -> Vec3) -> Texture {
    let texels: Vec<Vec4> = t
        .texels()
        .iter()
        .map(|v| f(v.truncate()).extend(v.w))
        .collect();
    Texture::from_texels(t.width(), t.height(), texels, t.wrap)
}

fn band_color(c: &ColorInput, basis: &BandBasis) -> ColorInput {
    match c {
        ColorInput::Constant(v) => ColorInput::Constant(basis.reflectance(*v)),
        // The factor multiplies the map per channel: apply the basis to the product.
        ColorInput::Texture { map, factor } => ColorInput::Texture {
            map: map_texture(map, |t| basis.reflectance(t * *factor)),
            factor: Vec3::ONE,
        },
    }
}

fn band_material(
    m: &Material,
    basis: &BandBasis,
    centres: [f32; 3],
) -> Result<Material, RenderError> {
    let leaf_error = |name: &str, e: lamina_leaf::LeafError| {
        RenderError::InvalidScene(format!("leaf material '{name}' in bands: {e}"))
    };
    Ok(match m {
        Material::Diffuse {
            name,
            reflectance,
            alpha,
        } => Material::Diffuse {
            name: name.clone(),
            reflectance: band_color(reflectance, basis),
            alpha: alpha.clone(),
        },
        Material::DiffuseTransmission {
            name,
            reflectance,
            transmittance,
            alpha,
        } => Material::DiffuseTransmission {
            name: name.clone(),
            reflectance: band_color(reflectance, basis),
            transmittance: band_color(transmittance, basis),
            alpha: alpha.clone(),
        },
        Material::Pbr(p) => {
            let mut q = (**p).clone();
            q.base_color = band_color(&p.base_color, basis);
            q.transmission_color = band_color(&p.transmission_color, basis);
            Material::Pbr(Box::new(q))
        }
        Material::Leaf { name, leaf } => {
            let banded = match leaf.pigment_leaf() {
                Some(p) => p.material(centres).map_err(|e| leaf_error(name, e))?,
                None => band_rgb_leaf(leaf, basis).map_err(|e| leaf_error(name, e))?,
            };
            Material::Leaf {
                name: name.clone(),
                leaf: Arc::new(banded),
            }
        }
    })
}

/// An RGB leaf in bands: its colour maps and layer coefficients through the basis.
fn band_rgb_leaf(
    leaf: &LeafMaterial,
    basis: &BandBasis,
) -> Result<LeafMaterial, lamina_leaf::LeafError> {
    let mut maps = leaf.maps().clone();
    for t in [&mut maps.front, &mut maps.back, &mut maps.translucency]
        .into_iter()
        .flatten()
    {
        *t = map_texture(t, |c| basis.reflectance(c));
    }
    let mut params = *leaf.params();
    for layer in [&mut params.upper, &mut params.mesophyll, &mut params.lower] {
        layer.absorption = basis.reflectance(layer.absorption).max(Vec3::ZERO);
        layer.scattering = basis.reflectance(layer.scattering).max(Vec3::ZERO);
    }
    LeafMaterial::new(maps, params)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lamina_leaf::{LeafMaps, LeafParams, Pigments};

    fn band(name: &str, lo: f32, hi: f32) -> Band {
        Band::flat(name, lo, hi)
    }

    #[test]
    fn a_pigment_leaf_is_bright_in_the_nir_and_dark_in_the_red() {
        let leaf = LeafMaterial::from_parts(
            LeafMaps::default(),
            LeafParams::default(),
            Some(Pigments::default()),
        )
        .unwrap();
        let m = Material::Leaf {
            name: "l".into(),
            leaf: Arc::new(leaf),
        };
        let (red, green, nir) = (
            band("red", 650.0, 680.0),
            band("green", 540.0, 570.0),
            band("nir", 840.0, 870.0),
        );
        let basis = BandBasis::new([&red, &green, &nir]);
        let Material::Leaf { leaf, .. } = band_material(&m, &basis, [665.0, 555.0, 855.0]).unwrap()
        else {
            unreachable!()
        };
        let [front, _, trans] = leaf.map_colours(glam::Vec2::splat(0.5));
        // White-sky targets: red well, green peak, NIR plateau (NDVI > 0.6).
        assert!(front.z > 4.0 * front.x && front.y > front.x, "{front}");
        assert!(trans.z > 0.3, "{trans}");
        let ndvi = (front.z - front.x) / (front.z + front.x);
        assert!(ndvi > 0.6, "{ndvi}");
    }
}
