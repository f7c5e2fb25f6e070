//! A scene in three spectral bands (or visible wavelength bins): its every RGB value replaced
//! by its values in the three ([`lamina_leaf::spectrum::bands`] says how), channel `i` = band
//! `i`. [`crate::spectral`] makes one such channel set per three bands or bins and carries
//! them all along each path; the paper integrator renders a copy of the scene made of one
//! set ([`group_scene`]) through the RGB renderer, three bands at a time.
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
use lamina_leaf::spectrum::bands::{Band, BandBasis, Illuminant};
use lamina_leaf::{LeafMaterial, Texture};
use std::sync::Arc;

/// What a scene is in three bands: its materials, lights and sky in scene order (channel
/// `i` = band `i`); the geometry is the scene's own.
#[derive(Clone, Debug)]
pub struct BandValues {
    /// The scene's materials in the bands.
    pub materials: Vec<Material>,
    /// The scene's lights in the bands (a physical sky's sun, its last light, remade).
    pub lights: Vec<Light>,
    /// The sky in the bands.
    pub sky: Option<Sky>,
}

/// The values of `scene` in `bands`, RGB emission taking the shape of `illuminant`. Maps
/// are shared with the scene, not copied: colour maps go through the band basis as they
/// are read ([`ColorInput::Mapped`], [`LeafMaterial::variant`]); a pigment leaf's
/// per-band materials share its data maps ([`lamina_leaf::PigmentLeaf::material_like`]).
pub fn band_values(
    scene: &Scene,
    bands: [&Band; 3],
    illuminant: Illuminant,
) -> Result<BandValues, RenderError> {
    band_values_with(scene, bands, illuminant, None)
}

/// [`band_values`] with the map of a physical sky in the bands already made (`sky_map`,
/// from [`lamina_core::SpectralSky::band_maps`]), if the scene has such a sky.
pub fn band_values_with(
    scene: &Scene,
    bands: [&Band; 3],
    illuminant: Illuminant,
    sky_map: Option<Texture>,
) -> Result<BandValues, RenderError> {
    band_values_prebuilt(scene, bands, illuminant, sky_map, |_| None)
}

/// [`band_values_with`], with the scene's leaf materials in these bands taken from
/// `prebuilt(i)` (material `i`) where it has them ([`band_leaves`] makes them for many
/// band triples at once).
pub fn band_values_prebuilt(
    scene: &Scene,
    bands: [&Band; 3],
    illuminant: Illuminant,
    sky_map: Option<Texture>,
    prebuilt: impl Fn(usize) -> Option<Arc<LeafMaterial>>,
) -> Result<BandValues, RenderError> {
    let basis = BandBasis::with_illuminant(bands, illuminant);
    let centres = bands.map(|b| b.center());
    let materials = scene
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| match (m, prebuilt(i)) {
            (Material::Leaf { name, .. }, Some(leaf)) => Ok(Material::Leaf {
                name: name.clone(),
                leaf,
            }),
            _ => band_material(m, &basis, centres),
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut lights = scene.lights.clone();
    for l in &mut lights {
        match l {
            Light::Sun { irradiance, .. } => *irradiance = basis.emission(*irradiance),
            Light::Point { intensity, .. } => *intensity = basis.emission(*intensity),
            Light::Quad { radiance, .. } | Light::Sphere { radiance, .. } => {
                *radiance = basis.emission(*radiance)
            }
        }
    }
    let mut sky = scene.sky.clone();
    if let Some(sky) = &mut sky {
        match sky {
            Sky::Constant(c) => *c = basis.emission(*c),
            // A physical sky is remade in the bands, with its sun (the scene's last light).
            Sky::Image {
                map,
                spectral: Some(spectral),
                ..
            } => {
                *map = sky_map.unwrap_or_else(|| spectral.band_map(bands));
                if let Some(e) = spectral.band_sun(bands)
                    && let Some(Light::Sun { irradiance, .. }) = lights.last_mut()
                {
                    *irradiance = e;
                }
            }
            Sky::Image { map, .. } => *map = map_texture(map, |c| basis.emission(c)),
        }
    }
    Ok(BandValues {
        materials,
        lights,
        sky,
    })
}

/// `scene` with its values in `bands` (channel `i` = band `i`), RGB emission of the solar
/// shape ([`band_values`]).
pub fn band_scene(scene: &Scene, bands: [&Band; 3]) -> Result<Scene, RenderError> {
    let v = band_values(scene, bands, Illuminant::Solar)?;
    let mut s = scene.clone();
    s.materials = v.materials;
    s.lights = v.lights;
    s.sky = v.sky;
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
        // The factor multiplies the map per channel: the basis applies to the product.
        ColorInput::Texture { map, factor } => ColorInput::Mapped {
            map: map.clone(),
            matrix: basis.reflectance_matrix() * glam::Mat3::from_diagonal(*factor),
        },
        ColorInput::Mapped { map, matrix } => ColorInput::Mapped {
            map: map.clone(),
            matrix: basis.reflectance_matrix() * *matrix,
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
                Some(p) => p
                    .material_like(centres, leaf)
                    .map_err(|e| leaf_error(name, e))?,
                None => band_rgb_leaf(leaf, basis).map_err(|e| leaf_error(name, e))?,
            };
            Material::Leaf {
                name: name.clone(),
                leaf: Arc::new(banded),
            }
        }
    })
}

/// An RGB leaf in bands: its colours (maps, or the RGB model's own albedos) through the
/// basis as they are read, and its layer coefficients through it too, so that the layers'
/// angular shapes and map responses are the bands': scattering linearly, absorption in the
/// transmittance of the layer, `e^{-σ_a(λ) d} = Σ_c B_c(λ) e^{-σ_a,c d}` (`d` the layer's
/// nominal thickness) — what an absorption coefficient means to the eye is how much light
/// crosses the layer, and a linear mix of coefficients would let the strongly absorbed
/// channels darken the others (a green leaf would turn dark in the green).
fn band_rgb_leaf(
    leaf: &LeafMaterial,
    basis: &BandBasis,
) -> Result<LeafMaterial, lamina_leaf::LeafError> {
    leaf.variant(band_rgb_params(leaf, basis), basis.reflectance_matrix())
}

/// The layer parameters of [`band_rgb_leaf`].
fn band_rgb_params(leaf: &LeafMaterial, basis: &BandBasis) -> lamina_leaf::LeafParams {
    let mut params = *leaf.params();
    let thickness = params.thickness_mm;
    for layer in [&mut params.upper, &mut params.mesophyll, &mut params.lower] {
        let d = (thickness * layer.fraction).max(1e-6);
        let t = (-layer.absorption * d).exp();
        let tb = basis.reflectance(t).clamp(Vec3::splat(1e-30), Vec3::ONE);
        layer.absorption = (-tb.ln() / d).max(Vec3::ZERO);
        layer.scattering = basis.reflectance(layer.scattering).max(Vec3::ZERO);
    }
    params
}

/// Every leaf material of `scene` in each band triple of `groups`, as [`band_values_with`]
/// makes them (bit for bit), built together per leaf so that their precomputations share
/// the work the channel sets have in common ([`lamina_leaf::PigmentLeaf::materials_like`],
/// [`LeafMaterial::variant_each`]), `threads` batches per leaf run in parallel on the
/// current rayon pool. `result[i][j]`: material `i` in group `j` (empty for materials that
/// are not leaves).
pub fn band_leaves(
    scene: &Scene,
    groups: &[[&Band; 3]],
    illuminant: Illuminant,
    threads: usize,
) -> Result<Vec<Vec<Arc<LeafMaterial>>>, RenderError> {
    use rayon::prelude::*;
    let chunk = groups.len().div_ceil(threads.max(1)).max(1);
    let jobs: Vec<(usize, usize)> = scene
        .materials
        .iter()
        .enumerate()
        .filter(|(_, m)| matches!(m, Material::Leaf { .. }))
        .flat_map(|(i, _)| (0..groups.len()).step_by(chunk).map(move |j| (i, j)))
        .collect();
    let built = jobs
        .par_iter()
        .map(|&(i, j0)| {
            let Material::Leaf { name, leaf } = &scene.materials[i] else {
                unreachable!("only leaves have jobs")
            };
            let part = &groups[j0..(j0 + chunk).min(groups.len())];
            let made = match leaf.pigment_leaf() {
                Some(p) => {
                    let nms: Vec<[f32; 3]> = part.iter().map(|g| g.map(|b| b.center())).collect();
                    p.materials_like(&nms, leaf)
                }
                None => leaf.variant_each(
                    part.iter()
                        .map(|g| {
                            let basis = BandBasis::with_illuminant(*g, illuminant);
                            (band_rgb_params(leaf, &basis), basis.reflectance_matrix())
                        })
                        .collect(),
                ),
            };
            made.map_err(|e| {
                RenderError::InvalidScene(format!("leaf material '{name}' in bands: {e}"))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let mut out: Vec<Vec<Arc<LeafMaterial>>> = vec![Vec::new(); scene.materials.len()];
    for (&(i, _), made) in jobs.iter().zip(built) {
        out[i].extend(made.into_iter().map(Arc::new));
    }
    Ok(out)
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
