//! `type = "plant"` objects: the `[object.plant]` table to [`PlantParams`], with errors that
//! name the scene file, the line and the key (`object[0].plant.leaf_count`).

use crate::error::{LineIndex, SceneError};
use crate::file::{PlantTable, S};
use crate::load::{Ctx, toml_error};
use lamina_plant::{PlantError, PlantParams};

/// Keys of the `[[object]]` itself, easily written below `[object.plant]` by mistake.
const OBJECT_KEYS: &[&str] = &[
    "type",
    "name",
    "material",
    "materials",
    "transform",
    "scale",
    "rotate_x",
    "rotate_y",
    "rotate_z",
    "translate",
    "instances",
    "instances_file",
    "leaves",
];

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
    cx: &Ctx,
    p: &str,
    table: Option<&S<PlantTable>>,
    file: Option<&S<String>>,
    object_span: std::ops::Range<usize>,
) -> Result<PlantParams, SceneError> {
    let param_file = file
        .map(|f| {
            let path = cx.path(f);
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
            if matches!(origin, Origin::Scene(_)) && OBJECT_KEYS.contains(&k.as_str()) {
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
