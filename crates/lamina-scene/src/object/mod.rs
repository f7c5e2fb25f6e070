//! `[[object]]` (any number; `type` required): one module per object type, each with its
//! parameter table; the keys every object takes (`name`, `material`, the transform,
//! `instances`, `instances_file`) are read here and in [`placement`].
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `name` | string | `object[i]` | the prototype's name in messages (placed objects) |
//! | `material` | a scene material's name | required for `quad` and `leaf_cards` | the object's material; on `obj`, `gltf` and `plant` it replaces all of theirs |
//! | `transform` | table | none | `{ scale, rotate_x, rotate_y, rotate_z, translate }`: scale (one number or `[x, y, z]`), then rotations about x, y, z (degrees), then the translation (m) |
//! | `scale`, `rotate_x`, `rotate_y`, `rotate_z`, `translate` | as in `transform` | none | the same keys on the object itself (not together with `transform`) |
//! | `instances` | array of transform tables | none | the object becomes a prototype placed once per entry, each after the object's own transform |
//! | `instances_file` | path | none | a CSV file of placements (see *Instancing* below), with or instead of `instances` |

use crate::dict::{Dict, Key, Keys, Kind, S, Table, open_typed, type_entry};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::{Instance, Material, Mesh, Prototype};
use crate::transform::Transform;
use std::collections::HashMap;

mod gltf;
mod leaf_cards;
mod materials;
mod obj;
pub(crate) mod placement;
pub(crate) mod plant;
mod quad;

pub(crate) use materials::Imported;

/// The keys every object type takes, after its own.
pub(crate) const COMMON: &[(&str, Kind)] = &[
    ("name", Kind::Str),
    ("material", Kind::Str),
    ("transform", Kind::Table),
    ("scale", Kind::Color),
    ("rotate_x", Kind::Num),
    ("rotate_y", Kind::Num),
    ("rotate_z", Kind::Num),
    ("translate", Kind::Vec3),
    ("instances", Kind::Array),
    ("instances_file", Kind::Str),
];

/// The keys of an object type that takes `own` besides [`COMMON`].
const fn keys(own: &'static [Key]) -> Keys {
    Keys {
        own,
        common: COMMON,
        typed: true,
    }
}

/// What one `[[object]]` adds to the scene: world-space meshes, and prototypes with their
/// instances (`Instance::prototype` local to `prototypes`).
#[derive(Debug, Default)]
pub(crate) struct Geometry {
    pub(crate) meshes: Vec<Mesh>,
    pub(crate) prototypes: Vec<Prototype>,
    pub(crate) instances: Vec<Instance>,
}

/// What an object type's reader gets: the object's dictionary, its transform, and the
/// scene's materials by name.
pub(crate) struct ObjectInput<'a, 'd> {
    pub(crate) d: &'a Dict<'d>,
    pub(crate) transform: &'a Transform,
    pub(crate) materials: &'a HashMap<String, u32>,
}

impl ObjectInput<'_, '_> {
    /// The index of the scene material named by the string at `name` (key `key`).
    pub(crate) fn lookup(&self, name: &S<&str>, key: &str) -> Result<u32, SceneError> {
        self.materials.get(*name.get_ref()).copied().ok_or_else(|| {
            let mut names: Vec<_> = self.materials.keys().cloned().collect();
            names.sort();
            self.d.ld.err(
                name.span(),
                key,
                format!(
                    "no material named '{}' (defined: {})",
                    name.get_ref(),
                    names.join(", ")
                ),
            )
        })
    }

    /// The object's required `material`.
    pub(crate) fn material(&self) -> Result<u32, SceneError> {
        let m = self.d.req_string("material")?;
        self.lookup(&m, &self.d.key("material"))
    }
}

/// How an object type makes its geometry.
pub(crate) enum Reader {
    /// One scene material (`material`), world-space meshes.
    Simple(fn(&ObjectInput, u32) -> Result<Vec<Mesh>, SceneError>),
    /// Geometry with its own materials, bound to the scene's by `material`/`materials`.
    Imported(fn(&ObjectInput) -> Result<Imported, SceneError>),
}

/// Every object type: its name, keys and reader.
pub(crate) const TYPES: &[(&str, Keys, Reader)] = &[
    ("quad", quad::KEYS, Reader::Simple(quad::read)),
    (
        "leaf_cards",
        leaf_cards::KEYS,
        Reader::Simple(leaf_cards::read),
    ),
    ("obj", obj::KEYS, Reader::Imported(obj::read)),
    ("gltf", gltf::KEYS, Reader::Imported(gltf::read)),
    ("plant", plant::KEYS, Reader::Imported(plant::read)),
];

/// Checks the keys and their types of `[[object]]` number `i` (before any table is read).
pub(crate) fn check(ld: &Loader, i: usize, t: &S<Table>) -> Result<(), SceneError> {
    let at = format!("object[{i}]");
    let (kind, keys, reader) = type_entry(ld, "object", &at, t, TYPES)?;
    if let Some(e) = materials_on_simple(ld, &at, t, reader) {
        return Err(e);
    }
    let siblings = crate::dict::sibling_keys(TYPES);
    Dict::open_among(
        ld,
        at,
        Some(kind.into_inner()),
        t.span(),
        t.get_ref(),
        keys,
        siblings,
    )
    .map(drop)
}

/// The error for `materials` on an object type that takes one scene material.
fn materials_on_simple(ld: &Loader, at: &str, t: &S<Table>, reader: &Reader) -> Option<SceneError> {
    if !matches!(reader, Reader::Simple(_)) {
        return None;
    }
    let (_, m) = t
        .get_ref()
        .iter()
        .find(|(k, _)| k.get_ref() == "materials")?;
    Some(ld.err(
        m.span(),
        format!("{at}.materials"),
        "only gltf, obj and plant objects take 'materials'; use 'material'",
    ))
}

/// Reads `[[object]]` number `i`; imported materials are appended to `scene_materials`.
pub(crate) fn read(
    ld: &Loader,
    i: usize,
    t: &S<Table>,
    materials: &HashMap<String, u32>,
    scene_materials: &mut Vec<Material>,
) -> Result<Geometry, SceneError> {
    let (d, reader) = open_typed(ld, "object", format!("object[{i}]"), t, TYPES)?;
    let transform = placement::object_transform(&d)?;
    let placements = placement::placements(&d)?;
    let geometry = read_geometry(&d, reader, &transform, materials, scene_materials)?;
    let name = d
        .string("name")?
        .map_or_else(|| d.at.clone(), |n| n.get_ref().to_string());
    let user_placed = placements.is_some();
    let geometry = match placements {
        None => geometry,
        Some(placements) => placement::place(&d, name, geometry, &placements)?,
    };
    placement::check_extent(&d, &geometry, user_placed)?;
    d.finish()?;
    Ok(geometry)
}

/// The object's geometry in world space (before its placements), its materials bound.
fn read_geometry(
    d: &Dict,
    reader: &Reader,
    transform: &Transform,
    materials: &HashMap<String, u32>,
    scene_materials: &mut Vec<Material>,
) -> Result<Geometry, SceneError> {
    let input = ObjectInput {
        d,
        transform,
        materials,
    };
    Ok(match reader {
        Reader::Simple(read) => {
            let material = input.material()?;
            Geometry {
                meshes: read(&input, material)?,
                ..Default::default()
            }
        }
        Reader::Imported(read) => {
            let imported = read(&input)?;
            materials::bind(&input, imported, scene_materials)?
        }
    })
}

/// Transforms a mesh in place, keeping its front faces in front.
pub fn apply_transform(mesh: &mut Mesh, t: &Transform) {
    if *t == Transform::default() {
        return;
    }
    for p in &mut mesh.positions {
        *p = t.point(*p);
    }
    for n in &mut mesh.normals {
        *n = t.normal(*n);
    }
    // A tangent follows the surface like a position difference; a mirror flips the
    // bitangent's handedness (see `Mesh::tangents`).
    let w = if t.flips() { -1.0 } else { 1.0 };
    for tg in &mut mesh.tangents {
        *tg = t.vector(tg.truncate()).normalize_or_zero().extend(tg.w * w);
    }
    if t.flips() {
        for tri in &mut mesh.indices {
            tri.swap(1, 2);
        }
    }
}
