//! Wavefront OBJ meshes (via `tobj`). Every shape of the file becomes one [`Mesh`] with the
//! material the scene assigns; faces are triangulated. OBJ `vt` texture coordinates have
//! `v` up, as lamina's textures do.

use crate::error::SceneError;
use crate::scene::{ColorInput, Material, Mesh};
use glam::{Vec2, Vec3};
use std::path::Path;

/// An OBJ file as meshes (in the file's space) and materials.
#[derive(Debug, Default)]
pub struct ObjScene {
    /// One mesh per shape and material; `material` indexes [`ObjScene::materials`].
    pub meshes: Vec<Mesh>,
    /// The MTL materials, then one default material (grey diffuse) at the end.
    pub materials: Vec<Material>,
    /// Names parallel to `materials` (the default one is `"default"`).
    pub material_names: Vec<String>,
}

/// Loads an OBJ file with its materials.
pub fn load_obj(path: &Path) -> Result<ObjScene, SceneError> {
    let meshes = load_obj_meshes(path, 0)?;
    Ok(ObjScene {
        meshes,
        materials: vec![Material::Diffuse {
            name: "default".into(),
            reflectance: ColorInput::Constant(Vec3::splat(0.5)),
            alpha: None,
        }],
        material_names: vec!["default".into()],
    })
}

/// Loads all shapes of an OBJ file. Errors on unreadable files, non-finite vertices, index
/// arrays that point outside the vertex arrays, and files with no triangles.
pub fn load_obj_meshes(path: &Path, material: u32) -> Result<Vec<Mesh>, SceneError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _materials) = tobj::load_obj(path, &opts)
        .map_err(|e| SceneError::new(path, None, "", format!("cannot load OBJ: {e}")))?;
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
            indices.push([t[0], t[1], t[2]]);
        }
        if indices.is_empty() {
            continue;
        }
        meshes.push(Mesh {
            positions,
            normals,
            uvs,
            indices,
            material,
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
