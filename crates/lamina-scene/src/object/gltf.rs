//! `type = "gltf"`: a glTF 2.0 `.gltf` or `.glb` scene (see the glTF section of
//! docs/scene-format.md for what is imported and how its materials map to lamina's).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `file` | path | required | the `.gltf` or `.glb`. A glTF mesh used by several nodes becomes one prototype with one instance per node (a mesh used once is placed in world space) |
//! | `materials` | table | none | `{ "glTF name" = "scene name", ... }` replaces glTF materials by name (`material` replaces them all) |

use super::{Geometry, Imported, ObjectInput};
use crate::dict::{Keys, Kind};
use crate::error::SceneError;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[("file", Kind::Str), ("materials", Kind::Table)]);

/// Reads a glTF object.
pub(crate) fn read(o: &ObjectInput) -> Result<Imported, SceneError> {
    let f = o.d.req_string("file")?;
    let path = o.d.ld.path(f.get_ref());
    // Meshes used by several nodes stay prototypes, also when the object itself is placed
    // many times (see `placement::place`).
    let g = crate::gltf_import::load_gltf(&path, o.transform)?;
    for w in &g.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(Imported {
        geometry: Geometry {
            meshes: g.meshes,
            prototypes: g.prototypes,
            instances: g.instances,
        },
        materials: g.materials,
        material_names: g.material_names,
        source: "the glTF file",
    })
}
