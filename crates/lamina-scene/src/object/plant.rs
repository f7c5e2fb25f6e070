//! `type = "plant"`: a procedural bush or tree (lamina-plant), standing on `y = 0` around
//! the origin before the transform. It adds the branch mesh with a bark material named
//! `bark` and one leaf-card mesh per leaf variant with its generated `leaf` material, named
//! `leaf_<species>_<i>` (`leaf_beech_0`, ...).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `plant` | table (`[object.plant]`) | none | the plant's parameters (see *`type = "plant"`* in docs/scene-format.md); they override the parameter `file`'s |
//! | `file` | path | none | a plant parameter file (TOML, the same keys) |
//! | `materials` | table | none | `{ bark = "my_bark", leaf_beech_0 = "my_leaf" }` replaces the plant's materials by name (`material` replaces all) |
//! | `leaves` | `"cards"`, `"curved"` | `"cards"` | flat leaf cards, or one curved leaf mesh per leaf variant placed by one instance per leaf |
//!
//! The `[object.plant]` table becomes [`PlantParams`] with errors that name the scene file,
//! the line and the key (`object[0].plant.leaf_count`).

use super::{Geometry, Imported, ObjectInput, apply_transform};
use crate::dict::{Keys, Kind, S, Table};
use crate::error::{LineIndex, SceneError};
use crate::loader::{Loader, toml_error};
use crate::scene::Instance;
use lamina_plant::{PlantError, PlantParams};

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("plant", Kind::Table),
    ("file", Kind::Str),
    ("materials", Kind::Table),
    ("leaves", Kind::Str),
]);

/// `[object.plant]`: plant parameters by name, keys and values spanned.
type PlantTable = std::collections::BTreeMap<S<String>, S<toml::Value>>;

/// A spanned scene table as a [`PlantTable`].
fn plant_table(t: &Table) -> PlantTable {
    t.iter()
        .map(|(k, v)| (k.clone(), S::new(v.span(), v.get_ref().to_toml())))
        .collect()
}

/// Reads a plant object: its parameters, the scene-wide budgets, then the plant.
pub(crate) fn read(o: &ObjectInput) -> Result<Imported, SceneError> {
    let d = o.d;
    let p = &d.at;
    let span = d.span.clone();
    let curved = curved_leaves(o)?;
    let table = d.table("plant")?;
    let table = table.map(|t| S::new(t.span(), plant_table(t.get_ref())));
    let file = d
        .string("file")?
        .map(|f| S::new(f.span(), f.get_ref().to_string()));
    let params = plant_params(d.ld, p, table.as_ref(), file.as_ref(), span.clone())?;
    // The scene-wide budgets, before anything is generated.
    let r = params
        .resolve()
        .map_err(|e| d.ld.err(span.clone(), format!("{p}.plant"), e.to_string()))?;
    let plant_span = table.as_ref().map_or(span.clone(), |x| x.span());
    d.ld.spend_leaves(
        plant_span.clone(),
        &format!("{p}.plant.leaf_count"),
        r.leaf_count as u64,
    )?;
    d.ld.spend_leaf_texels(
        plant_span,
        &format!("{p}.plant.leaf_resolution"),
        r.leaf_variants as u64 * (r.leaf_resolution as u64).pow(2),
    )?;
    let plant = lamina_plant::generate_plant(&params)
        .map_err(|e| d.ld.err(span.clone(), format!("{p}.plant"), e.to_string()))?;
    let xf = o.transform;
    let (geometry, mats) = if curved {
        let parts = plant.into_instanced_parts(0, 0, lamina_plant::instanced::LeafBend::default());
        let place = glam::Affine3A::from_mat4(xf.m);
        let mut meshes = parts.meshes;
        for m in &mut meshes {
            apply_transform(m, xf);
        }
        let instances = parts
            .instances
            .into_iter()
            .map(|i| Instance {
                transform: place * i.transform,
                ..i
            })
            .collect();
        let geometry = Geometry {
            meshes,
            prototypes: parts.prototypes,
            instances,
        };
        (geometry, parts.materials)
    } else {
        let (mut meshes, mats) = plant.into_scene_parts(0);
        for m in &mut meshes {
            apply_transform(m, xf);
        }
        let geometry = Geometry {
            meshes,
            ..Default::default()
        };
        (geometry, mats)
    };
    Ok(Imported {
        geometry,
        material_names: mats.iter().map(|m| m.name().to_owned()).collect(),
        materials: mats,
        source: "the plant",
    })
}

/// A plant object's `leaves`: `"cards"` (default) or `"curved"` (instanced curved
/// leaves; with `instances` each leaf instance is composed with every placement).
fn curved_leaves(o: &ObjectInput) -> Result<bool, SceneError> {
    let Some(l) = o.d.string("leaves")? else {
        return Ok(false);
    };
    match *l.get_ref() {
        "cards" => Ok(false),
        "curved" => Ok(true),
        other => Err(o.d.err(
            l.span(),
            "leaves",
            format!("must be \"cards\" or \"curved\", got \"{other}\""),
        )),
    }
}

/// Whether `k` is a key of the `[[object]]` itself, easily written below `[object.plant]`
/// by mistake.
fn object_key(k: &str) -> bool {
    ["type", "materials", "leaves"].contains(&k) || super::COMMON.iter().any(|&(c, _)| c == k)
}

/// A plant parameter file given by the object's `file`: its path, text and keys.
struct ParamFile {
    path: std::path::PathBuf,
    lines: LineIndex,
    table: PlantTable,
}

/// Where a plant key was given: for errors.
enum Origin<'a> {
    Scene(std::ops::Range<usize>),
    File(&'a ParamFile, std::ops::Range<usize>),
}

/// The plant parameters of object `p` (`object[3]`): the keys of the parameter `file` if
/// any, overridden by those of the `[object.plant]` table; the defaults of a bush for the
/// rest. Unknown keys, wrong types and out-of-range values are errors at the key's line
/// (in the scene file or the parameter file), with the lamina-plant validation message.
pub(crate) fn plant_params(
    cx: &Loader,
    p: &str,
    table: Option<&S<PlantTable>>,
    file: Option<&S<String>>,
    object_span: std::ops::Range<usize>,
) -> Result<PlantParams, SceneError> {
    let param_file = file
        .map(|f| {
            let path = cx.path(f.get_ref());
            let meta = std::fs::metadata(&path).ok();
            if meta.as_ref().is_some_and(|m| !m.is_file()) {
                return Err(cx.err(
                    f.span(),
                    format!("{p}.file"),
                    format!(
                        "plant parameter file '{}' is not a regular file",
                        path.display()
                    ),
                ));
            }
            let len = meta.map_or(0, |m| m.len());
            if len > lamina_plant::MAX_PARAM_FILE_BYTES {
                return Err(cx.err(
                    f.span(),
                    format!("{p}.file"),
                    format!(
                        "plant parameter file '{}' is {len} bytes, more than the {} supported",
                        path.display(),
                        lamina_plant::MAX_PARAM_FILE_BYTES
                    ),
                ));
            }
            let text = std::fs::read_to_string(&path).map_err(|e| {
                cx.err(
                    f.span(),
                    format!("{p}.file"),
                    format!("cannot read plant parameter file '{}': {e}", path.display()),
                )
            })?;
            let table: PlantTable =
                toml::from_str(&text).map_err(|e| toml_error(&path, &text, &e))?;
            Ok::<_, SceneError>(ParamFile {
                lines: LineIndex::new(&text),
                path,
                table,
            })
        })
        .transpose()?;
    // name -> (value, where it was given); scene keys override the file's.
    let mut keys: std::collections::BTreeMap<String, (toml::Value, Origin)> = Default::default();
    if let Some(f) = &param_file {
        for (k, v) in &f.table {
            keys.insert(
                k.get_ref().clone(),
                (v.get_ref().clone(), Origin::File(f, v.span())),
            );
        }
    }
    if let Some(t) = table {
        for (k, v) in t.get_ref() {
            keys.insert(
                k.get_ref().clone(),
                (v.get_ref().clone(), Origin::Scene(v.span())),
            );
        }
    }
    let at = |origin: &Origin, k: &str, msg: String| match origin {
        Origin::Scene(span) => cx.err(span.clone(), format!("{p}.plant.{k}"), msg),
        Origin::File(f, span) => SceneError::new(&f.path, Some(f.lines.line(span.start)), k, msg),
    };
    let mut all = toml::Table::new();
    for (k, (v, origin)) in &keys {
        // Each key alone (every field has a default) pins type errors to its line.
        let mut one = toml::Table::new();
        one.insert(k.clone(), v.clone());
        if let Err(e) = toml::Value::Table(one).try_into::<PlantParams>() {
            let msg = e.to_string();
            let mut msg = msg.trim().trim_end_matches('.').replace('\n', " ");
            if matches!(origin, Origin::Scene(_)) && object_key(k) {
                msg = format!(
                    "'{k}' is a key of the object, not of the plant: in TOML every key after the [object.plant] header belongs to the plant, so put it above that header"
                );
            }
            return Err(at(origin, k, msg));
        }
        all.insert(k.clone(), v.clone());
    }
    let whole = table.map_or(object_span, |t| t.span());
    let params: PlantParams = toml::Value::Table(all)
        .try_into()
        .map_err(|e| cx.err(whole.clone(), format!("{p}.plant"), e.to_string()))?;
    params.validate().map_err(|e| match e {
        PlantError::Param { field, reason } => match keys.get(field) {
            Some((_, origin)) => at(origin, field, reason),
            None => cx.err(whole.clone(), format!("{p}.plant.{field}"), reason),
        },
        other => cx.err(whole.clone(), format!("{p}.plant"), other.to_string()),
    })?;
    Ok(params)
}
