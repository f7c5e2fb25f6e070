//! Binding an imported object's own materials (OBJ/MTL, glTF, a plant's) to the scene's.

use super::{Geometry, ObjectInput};
use crate::dict::{S, Value};
use crate::error::SceneError;
use crate::scene::Material;
use std::collections::HashMap;

/// Geometry with its own materials (`Mesh::material` indexes `materials`), from a file or
/// a generator.
pub(crate) struct Imported {
    pub(crate) geometry: Geometry,
    pub(crate) materials: Vec<Material>,
    pub(crate) material_names: Vec<String>,
    /// "the glTF file", for messages.
    pub(crate) source: &'static str,
}

/// Binds an imported object's materials to the scene: the object's `material` replaces
/// all of them, `materials = { "their name" = "scene name" }` replaces them by name, and
/// the rest are appended to the scene's materials (only those some mesh uses).
pub(crate) fn bind(
    o: &ObjectInput,
    imported: Imported,
    scene_materials: &mut Vec<Material>,
) -> Result<Geometry, SceneError> {
    let d = o.d;
    let all = d
        .string("material")?
        .map(|m| o.lookup(&m, &d.key("material")))
        .transpose()?;
    let mut by_name: HashMap<&str, u32> = HashMap::new();
    if let Some(table) = d.table("materials")? {
        for (their_name, v) in table.get_ref().iter() {
            let their_name = their_name.get_ref().as_str();
            let key = d.key(&format!("materials.{their_name}"));
            let Value::String(scene_name) = v.get_ref() else {
                return Err(d.ld.err(
                    table.span(),
                    key,
                    "must be the name of a scene material (a string)",
                ));
            };
            if !imported.material_names.iter().any(|n| n == their_name) {
                let have = imported.material_names.join(", ");
                return Err(d.ld.err(
                    table.span(),
                    key,
                    format!(
                        "{} has no material '{their_name}' (it has: {have})",
                        imported.source
                    ),
                ));
            }
            let target = o.lookup(&S::new(table.span(), scene_name.as_str()), &key)?;
            by_name.insert(their_name, target);
        }
    }
    let mut g = imported.geometry;
    let mut used = vec![false; imported.materials.len()];
    for m in g
        .meshes
        .iter()
        .chain(g.prototypes.iter().flat_map(|pr| pr.meshes.iter()))
    {
        if let Some(u) = used.get_mut(m.material as usize) {
            *u = true;
        }
    }
    let mut remap: Vec<u32> = Vec::with_capacity(imported.materials.len());
    for (i, (mat, name)) in imported
        .materials
        .into_iter()
        .zip(&imported.material_names)
        .enumerate()
    {
        let target = all.or_else(|| by_name.get(name.as_str()).copied());
        remap.push(match target {
            Some(t) => t,
            None if used[i] => {
                scene_materials.push(mat);
                scene_materials.len() as u32 - 1
            }
            None => u32::MAX,
        });
    }
    for m in g
        .meshes
        .iter_mut()
        .chain(g.prototypes.iter_mut().flat_map(|pr| pr.meshes.iter_mut()))
    {
        m.material = remap.get(m.material as usize).copied().unwrap_or(u32::MAX);
    }
    Ok(g)
}
