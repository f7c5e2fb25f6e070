//! Binary glTF 2.0 export of a [`Plant`].
//!
//! Layout: a 12-byte header (`glTF`, version 2, total length), a JSON chunk (padded with
//! spaces to 4 bytes) and a BIN chunk (padded with zeros) holding every vertex array, index
//! array and the PNG images. One mesh and node for the branches, one per leaf variant.
//!
//! Materials:
//! * `bark`: base colour = the bark texture (sRGB PNG, repeat addressing), metallic 0,
//!   roughness 0.9.
//! * `leaf_<species>_<i>`: base colour = the front map as sRGB with the alpha map in its
//!   alpha channel, `alphaMode` `MASK`, `alphaCutoff` 0.5, double-sided, and
//!   `KHR_materials_diffuse_transmission` with `diffuseTransmissionFactor` = the share of
//!   the leaf's scattered light that is transmitted (mean translucency over mean
//!   front reflectance plus mean translucency, inside the blade) and
//!   `diffuseTransmissionColorFactor` = mean translucency / factor (clamped to 1), so that
//!   the extension's `T = colour × factor` is the leaf's mean transmittance.
//!
//! Texture `v` is flipped to glTF's top-left origin. The file is written to a temporary
//! sibling and renamed into place, so a failure never leaves a half-written file.

use crate::{Plant, PlantError};
use glam::{Vec2, Vec3, Vec4};
use lamina_core::cards::append_cards;
use lamina_core::scene::Mesh;
use lamina_leaf::Texture;
use lamina_leaf::texture::linear_to_srgb;
use serde_json::{Value, json};
use std::path::Path;

const FLOAT: u32 = 5126;
const UINT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const REPEAT: u32 = 10497;
const CLAMP: u32 = 33071;
const LINEAR: u32 = 9729;
const LINEAR_MIPMAP_LINEAR: u32 = 9987;

#[derive(Default)]
struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
        });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.bin.extend_from_slice(bytes);
        self.views.push(v);
        self.views.len() - 1
    }

    fn floats(&mut self, data: &[f32], count: usize, kind: &str, bounds: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ARRAY_BUFFER));
        let mut a = json!({
            "bufferView": view,
            "componentType": FLOAT,
            "count": count,
            "type": kind,
        });
        if bounds {
            let comps = data.len() / count.max(1);
            let mut lo = vec![f32::MAX; comps];
            let mut hi = vec![f32::MIN; comps];
            for chunk in data.chunks(comps) {
                for (k, &x) in chunk.iter().enumerate() {
                    lo[k] = lo[k].min(x);
                    hi[k] = hi[k].max(x);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn indices(&mut self, tris: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = tris
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": UINT,
            "count": tris.len() * 3,
            "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    /// A primitive for `mesh` (normals required; uvs flipped to glTF's convention).
    fn primitive(&mut self, mesh: &Mesh, material: usize) -> Value {
        let pos: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
        let nrm: Vec<f32> = mesh.normals.iter().flat_map(|p| p.to_array()).collect();
        let uv: Vec<f32> = mesh.uvs.iter().flat_map(|t| [t.x, 1.0 - t.y]).collect();
        let n = mesh.positions.len();
        let p = self.floats(&pos, n, "VEC3", true);
        let nn = self.floats(&nrm, n, "VEC3", false);
        let t = self.floats(&uv, n, "VEC2", false);
        let i = self.indices(&mesh.indices);
        json!({
            "attributes": {"POSITION": p, "NORMAL": nn, "TEXCOORD_0": t},
            "indices": i,
            "material": material,
            "mode": 4,
        })
    }
}

/// PNG bytes of a texture: RGB (or RGBA with `alpha`) with the sRGB curve applied.
fn png(tex: &Texture, alpha: Option<&Texture>) -> Result<Vec<u8>, PlantError> {
    let (w, h) = (tex.width(), tex.height());
    let enc = |x: f32| (linear_to_srgb(x.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
    let mut out = std::io::Cursor::new(Vec::new());
    match alpha {
        Some(a) => {
            let mut img = image::RgbaImage::new(w, h);
            for (x, y, px) in img.enumerate_pixels_mut() {
                let c = tex.texel(x as i64, y as i64);
                let uv = Vec2::new(
                    (x as f32 + 0.5) / w as f32,
                    1.0 - (y as f32 + 0.5) / h as f32,
                );
                let al = a.scalar(uv).clamp(0.0, 1.0);
                *px = image::Rgba([enc(c.x), enc(c.y), enc(c.z), (al * 255.0 + 0.5) as u8]);
            }
            img.write_to(&mut out, image::ImageFormat::Png)?;
        }
        None => {
            let mut img = image::RgbImage::new(w, h);
            for (x, y, px) in img.enumerate_pixels_mut() {
                let c = tex.texel(x as i64, y as i64);
                *px = image::Rgb([enc(c.x), enc(c.y), enc(c.z)]);
            }
            img.write_to(&mut out, image::ImageFormat::Png)?;
        }
    }
    Ok(out.into_inner())
}

/// Mean of a colour map over the texels inside the blade (alpha ≥ 0.5).
fn mean_inside(tex: &Texture, alpha: Option<&Texture>) -> Vec3 {
    let (w, h) = (tex.width(), tex.height());
    let (mut sum, mut n) = (Vec4::ZERO, 0u64);
    for y in 0..h {
        for x in 0..w {
            let inside = alpha.is_none_or(|a| {
                let uv = Vec2::new(
                    (x as f32 + 0.5) / w as f32,
                    1.0 - (y as f32 + 0.5) / h as f32,
                );
                a.scalar(uv) >= 0.5
            });
            if inside {
                sum += tex.texel(x as i64, y as i64);
                n += 1;
            }
        }
    }
    if n == 0 {
        Vec3::ZERO
    } else {
        sum.truncate() / n as f32
    }
}

/// Writes `plant` as a binary glTF 2.0 file at `path` (see the module docs).
pub fn write_glb(plant: &Plant, path: &Path) -> Result<(), PlantError> {
    let mut b = Builder::default();
    let mut images = Vec::new();
    let mut textures = Vec::new();
    let mut materials = Vec::new();
    let mut meshes = Vec::new();
    let samplers = json!([
        {"magFilter": LINEAR, "minFilter": LINEAR_MIPMAP_LINEAR, "wrapS": REPEAT, "wrapT": REPEAT},
        {"magFilter": LINEAR, "minFilter": LINEAR_MIPMAP_LINEAR, "wrapS": CLAMP, "wrapT": CLAMP},
    ]);

    // Bark.
    let view = b.view(&png(&plant.bark, None)?, None);
    images.push(json!({"bufferView": view, "mimeType": "image/png", "name": "bark"}));
    textures.push(json!({"source": images.len() - 1, "sampler": 0}));
    materials.push(json!({
        "name": "bark",
        "pbrMetallicRoughness": {
            "baseColorTexture": {"index": textures.len() - 1},
            "metallicFactor": 0.0,
            "roughnessFactor": 0.9,
        },
    }));
    if !plant.branches.indices.is_empty() {
        let prim = b.primitive(&plant.branches, 0);
        meshes.push(json!({"name": "branches", "primitives": [prim]}));
    }

    // Leaf variants.
    for (i, (cards, leaf)) in plant.leaves.iter().zip(&plant.leaf_variants).enumerate() {
        let name = format!("leaf_{}_{i}", plant.params.species);
        let fallback = Texture::constant(Vec4::new(0.05, 0.12, 0.03, 1.0));
        let front = leaf.maps.front.as_ref().unwrap_or(&fallback);
        let alpha = leaf.maps.alpha.as_ref();
        let view = b.view(&png(front, alpha)?, None);
        images.push(json!({"bufferView": view, "mimeType": "image/png", "name": name}));
        textures.push(json!({"source": images.len() - 1, "sampler": 1}));
        let refl = mean_inside(front, alpha);
        let trans = leaf
            .maps
            .translucency
            .as_ref()
            .map_or(Vec3::splat(0.1), |t| mean_inside(t, alpha));
        let (rl, tl) = (refl.element_sum(), trans.element_sum());
        let factor = if rl + tl > 0.0 { tl / (rl + tl) } else { 0.0 };
        let colour = if factor > 0.0 {
            (trans / factor).clamp(Vec3::ZERO, Vec3::ONE)
        } else {
            Vec3::ONE
        };
        materials.push(json!({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorTexture": {"index": textures.len() - 1},
                "metallicFactor": 0.0,
                "roughnessFactor": leaf.params.roughness_adaxial.clamp(0.0, 1.0),
            },
            "alphaMode": "MASK",
            "alphaCutoff": 0.5,
            "doubleSided": true,
            "extensions": {
                "KHR_materials_diffuse_transmission": {
                    "diffuseTransmissionFactor": factor,
                    "diffuseTransmissionColorFactor": colour.to_array(),
                }
            },
        }));
        if cards.is_empty() {
            continue;
        }
        let mut mesh = Mesh::default();
        append_cards(&mut mesh, cards);
        mesh.normals = cards.iter().flat_map(|c| [c.normal; 4]).collect();
        let prim = b.primitive(&mesh, materials.len() - 1);
        meshes.push(json!({"name": name, "primitives": [prim]}));
    }

    let nodes: Vec<Value> = (0..meshes.len())
        .map(|i| json!({"mesh": i, "name": meshes[i]["name"].clone()}))
        .collect();
    while !b.bin.len().is_multiple_of(4) {
        b.bin.push(0);
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": lamina_io::GENERATOR},
        "extensionsUsed": ["KHR_materials_diffuse_transmission"],
        "scene": 0,
        "scenes": [{"name": "plant", "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "textures": textures,
        "images": images,
        "samplers": samplers,
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{"byteLength": b.bin.len()}],
    });
    let mut json_bytes = serde_json::to_vec(&doc)?;
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + b.bin.len();
    let total = u32::try_from(total).map_err(|_| PlantError::Io {
        path: path.to_owned(),
        source: std::io::Error::other("the plant is larger than the 4 GiB a GLB file can hold"),
    })?;
    let mut out = Vec::with_capacity(total as usize);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(b.bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b.bin);

    // Atomic: a temporary file in the same folder, synced, then renamed over `path`.
    lamina_io::write_bytes(path, &out).map_err(|e| PlantError::Io {
        path: path.to_owned(),
        source: std::io::Error::new(e.source.kind(), format!("{}: {}", e.what, e.source)),
    })
}
