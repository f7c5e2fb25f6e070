//! `type = "plant"` objects: the `[object.plant]` table to [`PlantParams`], with errors that
//! name the scene file, the line and the key (`object[0].plant.leaf_count`).

use crate::error::SceneError;
use crate::file::{PlantTable, S};
use crate::load::Ctx;
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
];

/// The plant parameters of object `p` (`object[3]`): the defaults of a bush when there is
/// no `[object.plant]` table. Unknown keys, wrong types and out-of-range values are errors
/// at the key's line, with the lamina-plant validation message.
pub(crate) fn plant_params(
    cx: &Ctx,
    p: &str,
    table: Option<&S<PlantTable>>,
    object_span: std::ops::Range<usize>,
) -> Result<PlantParams, SceneError> {
    let key = |k: &str| format!("{p}.plant.{k}");
    let mut all = toml::Table::new();
    if let Some(t) = table {
        for (k, v) in t.get_ref() {
            // Each key alone (every field has a default) pins type errors to its line.
            let mut one = toml::Table::new();
            one.insert(k.get_ref().clone(), v.get_ref().clone());
            if let Err(e) = toml::Value::Table(one).try_into::<PlantParams>() {
                let msg = e.to_string();
                let mut msg = msg.trim().trim_end_matches('.').replace('\n', " ");
                if OBJECT_KEYS.contains(&k.get_ref().as_str()) {
                    msg = format!(
                        "'{}' is a key of the object, not of the plant: in TOML every key after the [object.plant] header belongs to the plant, so put it above that header",
                        k.get_ref()
                    );
                }
                return Err(cx.err(v.span(), key(k.get_ref()), msg));
            }
            all.insert(k.get_ref().clone(), v.get_ref().clone());
        }
    }
    let whole = table.map_or(object_span, |t| t.span());
    let params: PlantParams = toml::Value::Table(all)
        .try_into()
        .map_err(|e| cx.err(whole.clone(), format!("{p}.plant"), e.to_string()))?;
    params.validate().map_err(|e| match e {
        PlantError::Param { field, reason } => {
            let span = table
                .and_then(|t| t.get_ref().iter().find(|(k, _)| k.get_ref() == field))
                .map_or(whole.clone(), |(_, v)| v.span());
            cx.err(span, key(field), reason)
        }
        other => cx.err(whole.clone(), format!("{p}.plant"), other.to_string()),
    })?;
    Ok(params)
}
