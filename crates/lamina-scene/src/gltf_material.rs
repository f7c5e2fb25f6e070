//! glTF materials (metallic-roughness, `KHR_materials_diffuse_transmission`,
//! `KHR_materials_ior`, `KHR_materials_volume`) to lamina materials, and the images they
//! read, for [`crate::gltf_import`]; docs/scene-format.md (`type = "gltf"`) lists the
//! mapping.

use crate::error::SceneError;
use crate::scene::{AlphaMask, ColorInput, Material, NormalMap, PbrMaterial};
use glam::{Vec3, Vec4};
use lamina_leaf::{Encoding, Texture, Wrap};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// Decodes glTF image `index` to a texture (sRGB-decoded when `srgb`), cached.
fn image(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    tex: gltf::Texture,
    srgb: bool,
    cache: &mut HashMap<(usize, bool), Texture>,
) -> Result<Texture, SceneError> {
    let img = tex.source();
    let key = (img.index(), srgb);
    if let Some(t) = cache.get(&key) {
        return Ok(t.clone());
    }
    let fail = |msg: String| SceneError::new(path, None, format!("images[{}]", img.index()), msg);
    let encoding = if srgb {
        Encoding::Srgb
    } else {
        Encoding::Linear
    };
    // Decoded with the size checked from the header first (lamina_leaf::texture).
    let mut t = match img.source() {
        gltf::image::Source::View { view, .. } => {
            let data = buffers
                .get(view.buffer().index())
                .ok_or_else(|| fail("its buffer is missing".into()))?;
            let (start, len) = (view.offset(), view.length());
            let bytes = start
                .checked_add(len)
                .and_then(|end| data.0.get(start..end))
                .ok_or_else(|| {
                    fail(format!(
                        "bufferView {} (byteOffset {start}, byteLength {len}) is beyond its buffer ({} bytes)",
                        view.index(),
                        data.0.len()
                    ))
                })?;
            Texture::decode(bytes, encoding, path).map_err(|e| fail(e.to_string()))?
        }
        gltf::image::Source::Uri { uri, .. } => {
            if uri.starts_with("data:") {
                return Err(fail(
                    "data-URI images are not supported; use a .glb or an image file".into(),
                ));
            }
            let file = path
                .parent()
                .unwrap_or(Path::new(""))
                .join(crate::gltf_import::uri_path(uri).map_err(fail)?);
            Texture::load(&file, encoding).map_err(|e| fail(e.to_string()))?
        }
    };
    t.wrap = match tex.sampler().wrap_s() {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
        _ => Wrap::Repeat,
    };
    let _ = doc;
    cache.insert(key, t.clone());
    Ok(t)
}

fn ext_f32(v: Option<&serde_json::Value>, name: &str, default: f32) -> f32 {
    v.and_then(|v| v.get(name))
        .and_then(|x| x.as_f64())
        .map_or(default, |x| x as f32)
}

/// The texture that a `KHR_materials_diffuse_transmission` texture-info object refers to.
fn ext_texture<'a>(
    path: &Path,
    doc: &'a gltf::Document,
    info: Option<&serde_json::Value>,
    key: &str,
) -> Result<Option<gltf::Texture<'a>>, SceneError> {
    let Some(info) = info else { return Ok(None) };
    let index = info.get("index").and_then(|i| i.as_u64());
    let tex = index.and_then(|i| doc.textures().nth(i as usize));
    match tex {
        Some(t) => Ok(Some(t)),
        None => Err(SceneError::new(
            path,
            None,
            key,
            format!("texture index {index:?} does not exist"),
        )),
    }
}

/// `(texCoord, KHR_texture_transform)` of a texture reference, for checking that all of a
/// material's maps read the coordinates the mesh carries.
fn tex_coord_and_transform(t: &gltf::texture::Info) -> (u32, Option<[f32; 5]>) {
    let xf = t.texture_transform().map(|x| {
        let [ox, oy] = x.offset();
        let [sx, sy] = x.scale();
        [ox, oy, sx, sy, x.rotation()]
    });
    (t.tex_coord(), xf)
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn convert_material(
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    m: &gltf::Material,
    name: &str,
    cache: &mut HashMap<(usize, bool), Texture>,
    warnings: &mut Vec<String>,
) -> Result<Material, SceneError> {
    let pbr = m.pbr_metallic_roughness();
    let factor = Vec4::from(pbr.base_color_factor());
    let base_tex = pbr
        .base_color_texture()
        .map(|t| image(path, doc, buffers, t.texture(), true, cache))
        .transpose()?;
    // Every map is read with the mesh's first UV set after the base colour's transform
    // (see `read_mesh`): say so where a map asks for something else.
    let base_coords = pbr
        .base_color_texture()
        .map(|t| tex_coord_and_transform(&t));
    let mut check_coords = |what: &str, coords: (u32, Option<[f32; 5]>)| {
        let expected = base_coords.unwrap_or((0, coords.1));
        if coords.0 != 0 || coords != expected {
            warnings.push(format!(
                "material '{name}': the {what} map uses other texture coordinates or another \
                 KHR_texture_transform than the base colour; it is read with the base colour's"
            ));
        }
    };
    let mr_tex = match pbr.metallic_roughness_texture() {
        Some(t) => {
            check_coords("metallic-roughness", tex_coord_and_transform(&t));
            Some(image(path, doc, buffers, t.texture(), false, cache)?)
        }
        None => None,
    };
    let normal_map = match m.normal_texture() {
        Some(t) => {
            // (the gltf crate does not expose a normal texture's KHR_texture_transform)
            check_coords("normal", (t.tex_coord(), base_coords.and_then(|b| b.1)));
            let scale = t.scale();
            if !scale.is_finite() || scale.abs() > 100.0 {
                return Err(SceneError::new(
                    path,
                    None,
                    format!("materials[{}].normalTexture.scale", m.index().unwrap_or(0)),
                    format!("must be finite and within ±100, got {scale}"),
                ));
            }
            Some(NormalMap {
                map: image(path, doc, buffers, t.texture(), false, cache)?,
                scale,
            })
        }
        None => None,
    };
    let alpha = gltf_alpha(m, base_tex.as_ref(), factor, name, warnings);
    let base = match &base_tex {
        Some(t) => ColorInput::Texture {
            map: t.clone(),
            factor: factor.truncate(),
        },
        None => ColorInput::Constant(factor.truncate()),
    };
    let ext = m.extensions();
    let dt = ext.and_then(|e| e.get("KHR_materials_diffuse_transmission"));
    let volume = ext.and_then(|e| e.get("KHR_materials_volume"));
    if ext.is_some_and(|e| e.contains_key("KHR_materials_translucency")) {
        warnings.push(format!(
            "material '{name}': KHR_materials_translucency (not a ratified extension) ignored"
        ));
    }
    let mut out = PbrMaterial {
        name: name.into(),
        base_color: base,
        metallic: pbr.metallic_factor().clamp(0.0, 1.0),
        roughness: pbr.roughness_factor().clamp(0.0, 1.0),
        metallic_roughness: mr_tex,
        ior: 1.5,
        transmission: 0.0,
        transmission_map: None,
        transmission_color: ColorInput::Constant(Vec3::ONE),
        normal_map,
        alpha,
    };
    if let Some(ior) = ext.and_then(|e| e.get("KHR_materials_ior")) {
        let v = ext_f32(Some(ior), "ior", 1.5);
        if (1.0..=3.0).contains(&v) {
            out.ior = v;
        } else {
            warnings.push(format!(
                "material '{name}': KHR_materials_ior {v} outside [1, 3]; 1.5 used"
            ));
        }
    }
    let Some(dt) = dt else {
        return Ok(Material::Pbr(Box::new(out)));
    };
    add_diffuse_transmission(&mut out, dt, path, doc, buffers, m, cache)?;
    if let Some(leaf) = leaf_from_volume(volume, base_tex.as_ref(), &out, name, path, warnings)? {
        return Ok(leaf);
    }
    Ok(Material::Pbr(Box::new(out)))
}

/// A glTF material's alpha mode as a cut-out: `MASK` at its cutoff, `BLEND` at 0.5 (with a
/// warning), on the base colour's alpha times the factor's.
fn gltf_alpha(
    m: &gltf::Material,
    base_tex: Option<&Texture>,
    factor: Vec4,
    name: &str,
    warnings: &mut Vec<String>,
) -> Option<AlphaMask> {
    match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => None,
        mode => {
            let cutoff = if mode == gltf::material::AlphaMode::Mask {
                m.alpha_cutoff().unwrap_or(0.5)
            } else {
                0.5
            };
            if mode == gltf::material::AlphaMode::Blend {
                warnings.push(format!(
                    "material '{name}': alphaMode BLEND rendered as a cut-out at 0.5"
                ));
            }
            match base_tex {
                // The cut-out compares texture alpha times the factor's alpha with the cutoff.
                Some(t) => Some(AlphaMask {
                    map: t.clone(),
                    use_alpha_channel: true,
                    cutoff: (cutoff / factor.w.max(1e-6)).min(1.0),
                }),
                None if factor.w < cutoff => Some(AlphaMask {
                    map: Texture::constant(Vec4::ZERO),
                    use_alpha_channel: true,
                    cutoff: 0.5,
                }),
                None => None,
            }
        }
    }
}

/// `KHR_materials_diffuse_transmission` on `out`: factor, colour and their textures.
fn add_diffuse_transmission(
    out: &mut PbrMaterial,
    dt: &serde_json::Value,
    path: &Path,
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    m: &gltf::Material,
    cache: &mut HashMap<(usize, bool), Texture>,
) -> Result<(), SceneError> {
    let key = |k: &str| {
        format!(
            "materials[{}].extensions.KHR_materials_diffuse_transmission.{k}",
            m.index().unwrap_or(0)
        )
    };
    out.transmission = ext_f32(Some(dt), "diffuseTransmissionFactor", 0.0).clamp(0.0, 1.0);
    let c = dt
        .get("diffuseTransmissionColorFactor")
        .and_then(|v| serde_json::from_value::<[f32; 3]>(v.clone()).ok())
        .map_or(Vec3::ONE, Vec3::from)
        .clamp(Vec3::ZERO, Vec3::ONE);
    let t_tex = ext_texture(
        path,
        doc,
        dt.get("diffuseTransmissionTexture"),
        &key("diffuseTransmissionTexture"),
    )?;
    let c_tex = ext_texture(
        path,
        doc,
        dt.get("diffuseTransmissionColorTexture"),
        &key("diffuseTransmissionColorTexture"),
    )?;
    out.transmission_map = t_tex
        .map(|t| image(path, doc, buffers, t, false, cache))
        .transpose()?;
    out.transmission_color = match c_tex {
        Some(t) => ColorInput::Texture {
            map: image(path, doc, buffers, t, true, cache)?,
            factor: c,
        },
        None => ColorInput::Constant(c),
    };
    Ok(())
}

/// A diffuse-transmission material with a `KHR_materials_volume` thickness as a lamina
/// leaf (front map = base colour, thickness from the factor), or `None`.
fn leaf_from_volume(
    volume: Option<&serde_json::Value>,
    base_tex: Option<&Texture>,
    out: &PbrMaterial,
    name: &str,
    path: &Path,
    warnings: &mut Vec<String>,
) -> Result<Option<Material>, SceneError> {
    let Some(v) = volume else { return Ok(None) };
    let thickness_m = ext_f32(Some(v), "thicknessFactor", 0.0);
    if thickness_m > 0.0 {
        let params = lamina_leaf::LeafParams {
            thickness_mm: (thickness_m * 1000.0).clamp(0.01, 5.0),
            ..Default::default()
        };
        let maps = lamina_leaf::LeafMaps {
            front: base_tex.cloned(),
            alpha: out.alpha.as_ref().map(|a| a.map.clone()),
            ..Default::default()
        };
        if out.normal_map.is_some() {
            warnings.push(format!(
                "material '{name}': rendered as a lamina leaf, whose relief comes from a \
                 bump (height) map; the normal map is ignored"
            ));
        }
        let leaf = lamina_leaf::LeafMaterial::new(maps, params).map_err(|e| {
            SceneError::new(path, None, format!("material '{name}'"), e.to_string())
        })?;
        return Ok(Some(Material::Leaf {
            name: name.into(),
            leaf: Arc::new(leaf),
        }));
    }
    Ok(None)
}
