//! `type = "obj"`: a Wavefront OBJ mesh with its MTL materials (see the OBJ and MTL
//! section of docs/scene-format.md for how MTL maps to lamina's materials).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `file` | path | required | the `.obj`; faces are triangulated. Without an MTL (or for faces before any `usemtl`) the material is grey `diffuse` 0.5, named `default` |
//! | `materials` | table | none | `{ "MTL name" = "scene name", ... }` replaces MTL materials by name (`material` replaces them all) |

use super::{Geometry, Imported, ObjectInput, apply_transform};
use crate::dict::{Keys, Kind};
use crate::error::SceneError;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[("file", Kind::Str), ("materials", Kind::Table)]);

/// Reads an OBJ object.
pub(crate) fn read(o: &ObjectInput) -> Result<Imported, SceneError> {
    let f = o.d.req_string("file")?;
    let path = o.d.ld.path(f.get_ref());
    let obj = crate::obj::load_obj(&path)?;
    for w in &obj.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    let mut meshes = obj.meshes;
    for m in &mut meshes {
        apply_transform(m, o.transform);
    }
    Ok(Imported {
        geometry: Geometry {
            meshes,
            ..Default::default()
        },
        materials: obj.materials,
        material_names: obj.material_names,
        source: "the OBJ file",
    })
}
