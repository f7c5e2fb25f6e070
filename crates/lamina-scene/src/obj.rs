//! Wavefront OBJ meshes with their MTL materials (via `tobj`). Each shape is split by
//! `usemtl` into one [`Mesh`] per material; faces are triangulated. OBJ `vt` texture
//! coordinates have `v` up, as lamina's textures do.
//!
//! MTL to lamina (paths in an MTL file are relative to the MTL file):
//!
//! | MTL | lamina |
//! |---|---|
//! | `Kd` (linear RGB, clamped to [0, 1]; default 1 with a `map_Kd`, else 0.5) | diffuse reflectance |
//! | `map_Kd` (sRGB image) | reflectance texture, multiplied by `Kd` |
//! | alpha channel of `map_Kd` (when not all opaque) | alpha cut-out at 0.5 |
//! | `map_d` (image; its alpha channel if it has one, else its first channel) | alpha cut-out at 0.5 (takes precedence over `map_Kd`'s alpha) |
//! | `d` < 0.5 without maps (`Tr` > 0.5) | fully cut out (invisible), with a warning |
//! | `Tf` (transmission filter, RGB), when not black and not the exporters' default `1 1 1` | `diffuse_transmission` with transmittance `Tf`; reflectance lowered where `Kd + Tf` > 1 |
//!
//! Specular, shininess, bump/normal maps, `Ka`, `Ke`, `Ni` and `illum` are ignored.

use crate::error::SceneError;
use crate::scene::{AlphaMask, ColorInput, Material, Mesh};
use glam::{Vec2, Vec3, Vec4};
use lamina_leaf::{Encoding, Texture};
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// An OBJ file as meshes (in the file's space) and materials.
#[derive(Debug, Default)]
pub struct ObjScene {
    /// One mesh per shape and material; `material` indexes [`ObjScene::materials`].
    pub meshes: Vec<Mesh>,
    /// The MTL materials (in the order of the `mtllib` files and their `newmtl`s), then
    /// one default material (grey diffuse 0.5) at the end.
    pub materials: Vec<Material>,
    /// Names parallel to `materials` (the default one is `"default"`).
    pub material_names: Vec<String>,
    /// Things that were approximated, for the user.
    pub warnings: Vec<String>,
}

/// Loads an OBJ file with its MTL materials. Errors (naming the .obj or .mtl file, the line
/// where known, and the texture path): unreadable files, a missing `mtllib` file, a
/// `usemtl` of an undefined material, missing or corrupt textures, non-finite vertices,
/// face indices out of range, no triangles.
pub fn load_obj(path: &Path) -> Result<ObjScene, SceneError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::new(path, None, "", format!("cannot read OBJ: {e}")))?;
    let dir = path.parent().unwrap_or(Path::new("")).to_owned();
    prescan(path, &text, &dir)?;
    // Every MTL file tobj asks for, with the materials it defined (in tobj's order).
    let loaded: RefCell<Vec<(PathBuf, Vec<String>)>> = RefCell::new(Vec::new());
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, materials) =
        tobj::load_obj_buf(&mut std::io::Cursor::new(text.as_bytes()), &opts, |p| {
            let file = dir.join(p);
            let r = tobj::load_mtl(&file);
            if let Ok((mats, _)) = &r {
                loaded
                    .borrow_mut()
                    .push((file, mats.iter().map(|m| m.name.clone()).collect()));
            }
            r
        })
        .map_err(|e| SceneError::new(path, None, "", format!("cannot load OBJ: {e}")))?;
    let materials = materials.map_err(|e| {
        SceneError::new(
            path,
            None,
            "mtllib",
            format!("cannot load the MTL file: {e}"),
        )
    })?;
    let mtl_of = |name: &str| -> PathBuf {
        loaded
            .borrow()
            .iter()
            .rev()
            .find(|(_, names)| names.iter().any(|n| n == name))
            .map_or_else(|| path.to_owned(), |(f, _)| f.clone())
    };
    let mut out = ObjScene::default();
    for m in &materials {
        let mtl = mtl_of(&m.name);
        let mat = convert_material(&mtl, m, &mut out.warnings)?;
        out.materials.push(mat);
        out.material_names.push(m.name.clone());
    }
    for (i, line) in text.lines().enumerate() {
        if let Some(name) = line.trim().strip_prefix("usemtl") {
            let name = name.trim();
            if !out.material_names.iter().any(|n| n == name) {
                out.warnings.push(format!(
                    "line {}: usemtl '{name}' is not defined by any MTL file; grey default used",
                    i + 1
                ));
            }
        }
    }
    let default = out.materials.len() as u32;
    out.materials.push(Material::Diffuse {
        name: "default".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: None,
    });
    out.material_names.push("default".into());
    out.meshes = meshes(path, models, |id| {
        id.map_or(default, |i| (i as u32).min(default))
    })?;
    Ok(out)
}

/// Checks what tobj would accept silently or report without a line: `mtllib` files that
/// do not exist, vertices that are not finite, faces that refer to vertices not (yet)
/// defined.
fn prescan(path: &Path, text: &str, dir: &Path) -> Result<(), SceneError> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let ln = Some(i + 1);
        let line = line.trim();
        let mut words = line.split_whitespace();
        let Some(tag) = words.next() else { continue };
        match tag {
            "mtllib" => {
                let name = line["mtllib".len()..].trim();
                let file = dir.join(name);
                if let Err(e) = std::fs::metadata(&file) {
                    return Err(SceneError::new(
                        path,
                        ln,
                        "mtllib",
                        format!("cannot read the MTL file '{}': {e}", file.display()),
                    ));
                }
            }
            "v" | "vt" | "vn" => {
                let count = if tag == "vt" { 2 } else { 3 };
                for w in words.take(count) {
                    if !w.parse::<f32>().is_ok_and(f32::is_finite) {
                        return Err(SceneError::new(
                            path,
                            ln,
                            tag,
                            format!("'{w}' is not a finite number"),
                        ));
                    }
                }
                match tag {
                    "v" => nv += 1,
                    "vt" => nvt += 1,
                    _ => nvn += 1,
                }
            }
            "f" => {
                for w in words {
                    for (j, part) in w.split('/').enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let n = [nv, nvt, nvn].get(j).copied().unwrap_or(0);
                        let what = ["vertex", "texture coordinate", "normal"]
                            .get(j)
                            .copied()
                            .unwrap_or("index");
                        let ok = part
                            .parse::<i64>()
                            .is_ok_and(|k| (k > 0 && k <= n) || (k < 0 && -k <= n));
                        if !ok {
                            return Err(SceneError::new(
                                path,
                                ln,
                                "f",
                                format!(
                                    "{what} index '{part}' is out of range (1..{n} defined so far)"
                                ),
                            ));
                        }
                    }
                }
            }
            "usemtl" | "o" | "g" | "s" | "vp" | "l" | "p" | "#" => {}
            _ => {}
        }
    }
    Ok(())
}

/// MTL material to lamina material; see the module docs for the mapping.
fn convert_material(
    mtl: &Path,
    m: &tobj::Material,
    warnings: &mut Vec<String>,
) -> Result<Material, SceneError> {
    let dir = mtl.parent().unwrap_or(Path::new(""));
    let key = |k: &str| format!("newmtl {}: {k}", m.name);
    let texture = |k: &str, file: &str, enc: Encoding| -> Result<Texture, SceneError> {
        let p = dir.join(file.trim());
        Texture::load(&p, enc).map_err(|e| {
            SceneError::new(
                mtl,
                None,
                key(k),
                format!("cannot load texture '{}': {e}", p.display()),
            )
        })
    };
    let finite3 = |k: &str, v: [f32; 3]| -> Result<Vec3, SceneError> {
        let v = Vec3::from(v);
        if !v.is_finite() {
            return Err(SceneError::new(
                mtl,
                None,
                key(k),
                format!("must be finite, got {:?}", v.to_array()),
            ));
        }
        Ok(v.clamp(Vec3::ZERO, Vec3::ONE))
    };
    let kd = m.diffuse.map(|d| finite3("Kd", d)).transpose()?;
    let map_kd = m
        .diffuse_texture
        .as_deref()
        .map(|f| texture("map_Kd", f, Encoding::Srgb))
        .transpose()?;
    let has_alpha = |t: &Texture| t.texels().iter().any(|x| x.w < 1.0);
    let mut alpha = match &m.dissolve_texture {
        Some(f) => {
            let t = texture("map_d", f, Encoding::Linear)?;
            Some(AlphaMask {
                use_alpha_channel: has_alpha(&t),
                map: t,
                cutoff: 0.5,
            })
        }
        None => map_kd.as_ref().filter(|t| has_alpha(t)).map(|t| AlphaMask {
            map: t.clone(),
            use_alpha_channel: true,
            cutoff: 0.5,
        }),
    };
    let d = m
        .dissolve
        .or_else(|| {
            m.unknown_param
                .get("Tr")
                .and_then(|v| v.trim().parse::<f32>().ok())
                .map(|tr| 1.0 - tr)
        })
        .unwrap_or(1.0);
    if alpha.is_none() && d.is_finite() && d < 0.5 {
        warnings.push(format!(
            "material '{}': d = {d} (dissolve) without a map: rendered invisible",
            m.name
        ));
        alpha = Some(AlphaMask {
            map: Texture::constant(Vec4::ZERO),
            use_alpha_channel: false,
            cutoff: 0.5,
        });
    }
    let tf = match m.unknown_param.get("Tf") {
        Some(v) => {
            let n: Vec<f32> = v
                .split_whitespace()
                .map(|x| x.parse::<f32>())
                .collect::<Result<_, _>>()
                .map_err(|_| {
                    SceneError::new(mtl, None, key("Tf"), format!("not numbers: '{v}'"))
                })?;
            let c = match n[..] {
                [g] => [g; 3],
                [r, g, b, ..] => [r, g, b],
                _ => {
                    return Err(SceneError::new(
                        mtl,
                        None,
                        key("Tf"),
                        format!("not an RGB colour: '{v}'"),
                    ));
                }
            };
            let c = finite3("Tf", c)?;
            (c.max_element() > 0.0 && c != Vec3::ONE).then_some(c)
        }
        None => None,
    };
    let factor = kd.unwrap_or(if map_kd.is_some() {
        Vec3::ONE
    } else {
        Vec3::splat(0.5)
    });
    // Energy: reflectance + transmittance <= 1 per channel.
    let factor = match tf {
        Some(t) => factor.min(Vec3::ONE - t),
        None => factor,
    };
    let reflectance = match map_kd {
        Some(map) => ColorInput::Texture { map, factor },
        None => ColorInput::Constant(factor),
    };
    let name = m.name.clone();
    Ok(match tf {
        Some(t) => Material::DiffuseTransmission {
            name,
            reflectance,
            transmittance: ColorInput::Constant(t),
            alpha,
        },
        None => Material::Diffuse {
            name,
            reflectance,
            alpha,
        },
    })
}

/// Geometry only: every shape with `material`, MTL files not read.
pub fn load_obj_meshes(path: &Path, material: u32) -> Result<Vec<Mesh>, SceneError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _materials) = tobj::load_obj(path, &opts)
        .map_err(|e| SceneError::new(path, None, "", format!("cannot load OBJ: {e}")))?;
    meshes(path, models, |_| material)
}

/// tobj models to meshes, checked; `material` maps tobj's material id.
fn meshes(
    path: &Path,
    models: Vec<tobj::Model>,
    material: impl Fn(Option<usize>) -> u32,
) -> Result<Vec<Mesh>, SceneError> {
    let mut meshes = Vec::new();
    for model in models {
        let m = &model.mesh;
        let positions: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect();
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(SceneError::new(
                path,
                None,
                &model.name,
                "a vertex position is not a finite number",
            ));
        }
        let normals: Vec<Vec3> = m
            .normals
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0], p[1], p[2]).normalize_or_zero())
            .collect();
        let uvs: Vec<Vec2> = m
            .texcoords
            .chunks_exact(2)
            .map(|p| Vec2::new(p[0], p[1]))
            .collect();
        let n = positions.len();
        if (!normals.is_empty() && normals.len() != n) || (!uvs.is_empty() && uvs.len() != n) {
            return Err(SceneError::new(
                path,
                None,
                &model.name,
                "normal or texture-coordinate count differs from vertex count",
            ));
        }
        let mut indices = Vec::with_capacity(m.indices.len() / 3);
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= n) {
                return Err(SceneError::new(
                    path,
                    None,
                    &model.name,
                    "a face refers to a vertex that does not exist",
                ));
            }
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
            // Zero-area triangles can never be hit.
            if (b - a).cross(c - a) != Vec3::ZERO {
                indices.push([t[0], t[1], t[2]]);
            }
        }
        if indices.is_empty() {
            continue;
        }
        meshes.push(Mesh {
            positions,
            normals,
            tangents: Vec::new(),
            uvs,
            indices,
            material: material(m.material_id),
        });
    }
    if meshes.is_empty() {
        return Err(SceneError::new(
            path,
            None,
            "",
            "the OBJ file has no triangles",
        ));
    }
    Ok(meshes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(name: &str, text: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("lamina-obj-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn loads_a_quad_as_two_triangles() {
        let p = write(
            "q.obj",
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
        );
        let m = load_obj_meshes(&p, 7).unwrap();
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].indices.len(), 2);
        assert_eq!(m[0].uvs.len(), 4);
        assert_eq!(m[0].material, 7);
    }

    #[test]
    fn rejects_empty_and_nan() {
        let p = write("e.obj", "# nothing\n");
        assert!(
            load_obj_meshes(&p, 0)
                .unwrap_err()
                .to_string()
                .contains("no triangles")
        );
        let p = write("n.obj", "v nan 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
        let e = load_obj_meshes(&p, 0).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("finite") || e.contains("cannot load"), "{e}");
    }
}
