//! Wavefront OBJ meshes with their MTL materials (via `tobj`). Each shape is split by
//! `usemtl` into one [`Mesh`] per material; faces are triangulated. OBJ `vt` texture
//! coordinates have `v` up, as lamina's textures do.
//!
//! Their MTL materials become lamina materials as docs/scene-format.md (*OBJ and MTL*)
//! and the `mtl` module say.

use crate::error::{SceneError, guarded, read_text};
use crate::limits::MAX_TEXT_FILE_BYTES;
use crate::mtl::convert_material;
pub use crate::mtl::phong_exponent_to_roughness;
use crate::scene::{ColorInput, Material, Mesh};
use glam::{Vec2, Vec3};
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
///
/// The OBJ and each MTL file may have at most [`crate::limits::MAX_TEXT_FILE_BYTES`]; every
/// texture's size is checked before it is decoded; a panic inside tobj or a decoder is an
/// error naming the file.
pub fn load_obj(path: &Path) -> Result<ObjScene, SceneError> {
    guarded(path, || {
        let text = read_text(path, "OBJ", MAX_TEXT_FILE_BYTES)?;
        parse_obj_text(&text, path)
    })
}

/// [`load_obj`] for OBJ text in memory: `path` names it in errors and anchors its `mtllib`
/// files (read from disk). The entry point for fuzzing.
pub fn parse_obj(text: &str, path: &Path) -> Result<ObjScene, SceneError> {
    guarded(path, || parse_obj_text(text, path))
}

/// MTL text as tobj can read it: a colour statement with one number (`Kd 0.5`, which the
/// MTL format allows and means grey) written out as three, since tobj panics on it.
/// [`scan_mtl`] has rejected every other short colour statement.
fn normalise_mtl(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match (words.next(), words.next(), words.next()) {
            (Some(tag @ ("Ka" | "Kd" | "Ks" | "Ke")), Some(x), None) => {
                out.push_str(&format!("{tag} {x} {x} {x}"));
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// Checks an MTL file's size and its colour statements (`Ka`, `Kd`, `Ks`, `Ke`: one or
/// three numbers), which tobj would otherwise panic on or reject without a line.
fn scan_mtl(obj: &Path, obj_line: Option<usize>, file: &Path) -> Result<(), SceneError> {
    let text = read_text(file, "the MTL file", MAX_TEXT_FILE_BYTES)
        .map_err(|e| SceneError::new(obj, obj_line, "mtllib", e.message))?;
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(tag @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() else {
            continue;
        };
        let values: Vec<&str> = words.take(3).collect();
        let bad = |msg: String| SceneError::new(file, Some(i + 1), tag, msg);
        if values.len() != 1 && values.len() != 3 {
            return Err(bad(format!(
                "needs one number (grey) or three (r g b), got {}",
                values.len()
            )));
        }
        if let Some(v) = values.iter().find(|v| v.parse::<f32>().is_err()) {
            return Err(bad(format!(
                "'{v}' is not a number (spectral and xyz colours are not supported)"
            )));
        }
    }
    Ok(())
}

fn parse_obj_text(text: &str, path: &Path) -> Result<ObjScene, SceneError> {
    crate::error::fault_point("obj");
    let dir = path.parent().unwrap_or(Path::new("")).to_owned();
    prescan(path, text, &dir, true)?;
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
            // Checked by `prescan` (size and colour statements).
            let r = match std::fs::read_to_string(&file) {
                Ok(t) => tobj::load_mtl_buf(&mut std::io::Cursor::new(normalise_mtl(&t))),
                Err(_) => Err(tobj::LoadError::OpenFileFailed),
            };
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
    // Per material: the texture-coordinate transform of its maps (`-s`, `-o`).
    let mut uv_transforms = Vec::new();
    for m in &materials {
        let mtl = mtl_of(&m.name);
        let (mat, uv) = convert_material(&mtl, m, &mut out.warnings)?;
        out.materials.push(mat);
        out.material_names.push(m.name.clone());
        uv_transforms.push(uv);
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
    for mesh in &mut out.meshes {
        if let Some(Some((scale, offset))) = uv_transforms.get(mesh.material as usize) {
            for uv in &mut mesh.uvs {
                *uv = *uv * *scale + *offset;
            }
        }
    }
    Ok(out)
}

/// Checks what tobj would accept silently or report without a line: `mtllib` files that
/// do not exist, vertices that are not finite, faces that refer to vertices not (yet)
/// defined.
fn prescan(path: &Path, text: &str, dir: &Path, mtl: bool) -> Result<(), SceneError> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let ln = Some(i + 1);
        let line = line.trim();
        let mut words = line.split_whitespace();
        let Some(tag) = words.next() else { continue };
        match tag {
            "mtllib" if mtl => {
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
                scan_mtl(path, ln, &file)?;
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

/// Geometry only: every shape with `material`, MTL files not read.
/// The same checks and limits as [`load_obj`].
pub fn load_obj_meshes(path: &Path, material: u32) -> Result<Vec<Mesh>, SceneError> {
    guarded(path, || {
        crate::error::fault_point("obj_meshes");
        let text = read_text(path, "OBJ", MAX_TEXT_FILE_BYTES)?;
        let dir = path.parent().unwrap_or(Path::new(""));
        prescan(path, &text, dir, false)?;
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let (models, _materials) =
            tobj::load_obj_buf(&mut std::io::Cursor::new(text.as_bytes()), &opts, |_| {
                Err(tobj::LoadError::OpenFileFailed)
            })
            .map_err(|e| SceneError::new(path, None, "", format!("cannot load OBJ: {e}")))?;
        meshes(path, models, |_| material)
    })
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
