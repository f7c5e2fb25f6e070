//! Overrides of a scene file's values from the command line (`lamina render --set
//! KEY=VALUE`, parameter sweeps of `lamina farm`): each sets one key of the scene file's
//! TOML before it is read, so the value goes through the same reader, checks and error
//! messages as if it had been typed into the file.
//!
//! `KEY` is a dotted path as in error messages: `film.spp`, `camera.fov`,
//! `light[0].irradiance`, `object[2].material`, `light[0].position.time` (`[i]` picks the
//! i-th `[[light]]`, `[[material]]` or `[[object]]` table, from 0). `VALUE` is a TOML value:
//! `64`, `0.5`, `[0, -1, 0.3]`, `"beech"` (strings need their quotes), `{ latitude = 48.9
//! }`. A key the table lacks is added (the table's reader then says whether it takes it);
//! a missing table (`[sky]`) is created. The edit keeps every other line of the file, so
//! errors elsewhere still name the right line.

use crate::error::SceneError;
use crate::error::guarded;
use crate::limits::Budgets;
use crate::loader::{SpectralOutput, parse_with_output};
use lamina_core::Scene;
use std::path::Path;
use toml_edit::{DocumentMut, Item, TableLike};

/// One `KEY=VALUE` override, as typed.
#[derive(Clone, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub struct Override {
    /// The dotted key (`light[0].irradiance`).
    pub key: String,
    /// The TOML value text (`[3, 3, 3]`).
    pub value: String,
}

impl std::str::FromStr for Override {
    type Err = String;

    /// Splits `KEY=VALUE` at the first `=` and checks that the key is a path and the value
    /// a TOML value.
    fn from_str(s: &str) -> Result<Self, String> {
        let (key, value) = s
            .split_once('=')
            .ok_or_else(|| format!("'{s}' is not KEY=VALUE (e.g. film.spp=64)"))?;
        let o = Override {
            key: key.trim().to_string(),
            value: value.trim().to_string(),
        };
        path_of(&o.key)?;
        value_item(&o)?;
        Ok(o)
    }
}

impl std::fmt::Display for Override {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}={}", self.key, self.value)
    }
}

/// `light[0].irradiance` → `[("light", Some(0)), ("irradiance", None)]`.
fn path_of(key: &str) -> Result<Vec<(String, Option<usize>)>, String> {
    let mut out = Vec::new();
    for seg in key.split('.') {
        let (name, index) = match seg.split_once('[') {
            None => (seg, None),
            Some((name, rest)) => {
                let i = rest
                    .strip_suffix(']')
                    .and_then(|i| i.parse::<usize>().ok())
                    .ok_or_else(|| {
                        format!("key '{key}': '{seg}' is not NAME or NAME[INDEX] (e.g. light[0])")
                    })?;
                (name, Some(i))
            }
        };
        let ok = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if !ok {
            return Err(format!(
                "key '{key}': '{seg}' is not a key name (letters, digits, _ and -)"
            ));
        }
        out.push((name.to_string(), index));
    }
    if out.last().is_some_and(|l| l.1.is_some()) {
        return Err(format!(
            "key '{key}': names a whole table; set one of its keys (e.g. {key}.irradiance)"
        ));
    }
    Ok(out)
}

/// The value as a TOML item.
fn value_item(o: &Override) -> Result<Item, String> {
    let doc: DocumentMut = format!("v = {}", o.value).parse().map_err(|_| {
        format!(
            "{}: '{}' is not a TOML value (numbers as 2.5, vectors as [0, 1, 0], text in \
             quotes: \"beech\")",
            o.key, o.value
        )
    })?;
    let item = doc.get("v").cloned().unwrap_or(Item::None);
    if !item.is_value() {
        return Err(format!(
            "{}: '{}' is not a single TOML value",
            o.key, o.value
        ));
    }
    Ok(item)
}

/// The scene text with `overrides` applied in order. Errors name `file` and the key: a
/// path through something that is not a table, an index past the tables there are.
pub fn apply_overrides(
    text: &str,
    file: &Path,
    overrides: &[Override],
) -> Result<String, SceneError> {
    if overrides.is_empty() {
        return Ok(text.to_string());
    }
    let err = |key: &str, msg: String| SceneError::new(file, None, key, format!("--set: {msg}"));
    let mut doc: DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| err("", format!("the scene is not valid TOML: {e}")))?;
    for o in overrides {
        let path = path_of(&o.key).map_err(|m| err(&o.key, m))?;
        let value = value_item(o).map_err(|m| err(&o.key, m))?;
        let mut table: &mut dyn TableLike = doc.as_table_mut();
        let (last, inner) = path.split_last().expect("a path has a segment");
        for (name, index) in inner {
            if !table.contains_key(name) && index.is_none() {
                table.insert(name, Item::Table(toml_edit::Table::new()));
            }
            let item = table
                .get_mut(name)
                .ok_or_else(|| err(&o.key, format!("the scene has no [[{name}]] tables")))?;
            table = match (index, item) {
                (Some(i), Item::ArrayOfTables(a)) => {
                    let n = a.len();
                    a.get_mut(*i).ok_or_else(|| {
                        err(
                            &o.key,
                            format!(
                                "the scene has {n} [[{name}]] table(s), so {name}[{i}] is not one"
                            ),
                        )
                    })?
                }
                (None, item) if item.is_table_like() => {
                    item.as_table_like_mut().expect("table-like")
                }
                _ => {
                    return Err(err(
                        &o.key,
                        format!(
                            "'{name}' is not {} in the scene",
                            if index.is_some() {
                                "a list of [[tables]]"
                            } else {
                                "a table"
                            }
                        ),
                    ));
                }
            };
        }
        let key = &last.0;
        if table
            .get(key)
            .is_some_and(|i| i.is_table() || i.is_array_of_tables())
        {
            return Err(err(
                &o.key,
                format!("'{key}' is a table; set one of its keys"),
            ));
        }
        // Inline tables hold values, not items.
        table.insert(key, value);
    }
    Ok(doc.to_string())
}

/// [`crate::load_scene_with_output`] with `overrides` applied to the file's text first.
pub fn load_scene_with_overrides(
    path: &Path,
    overrides: &[Override],
) -> Result<(Scene, Option<SpectralOutput>), SceneError> {
    guarded(path, || {
        let text =
            crate::error::read_text(path, "scene file", crate::limits::MAX_SCENE_FILE_BYTES)?;
        let text = apply_overrides(&text, path, overrides)?;
        parse_with_output(&text, path, Budgets::default())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = "# a scene\n[camera]\nposition = [0, 0, 2]\nlook_at = [0, 0, 0]\n\n\
        [film]\nwidth = 8\nheight = 6\n\n[[light]]\ntype = \"sun\"\ndirection = [0, 0, 1]\n\
        irradiance = 2\n\n[[light]]\ntype = \"sun\"\ndirection = [1, 0, 1]\nirradiance = 1\n";

    fn o(s: &str) -> Override {
        s.parse().unwrap()
    }

    fn apply(list: &[&str]) -> Result<String, SceneError> {
        let v: Vec<Override> = list.iter().map(|s| o(s)).collect();
        apply_overrides(SCENE, Path::new("s.toml"), &v)
    }

    #[test]
    fn overrides_set_keys_and_keep_the_rest() {
        let t = apply(&[
            "film.spp=64",
            "light[1].irradiance=[3, 2, 1]",
            "film.width = 16",
        ])
        .unwrap();
        assert!(t.contains("spp = 64") && t.contains("width = 16"), "{t}");
        assert!(
            t.contains("irradiance = [3, 2, 1]") && t.contains("irradiance = 2"),
            "{t}"
        );
        // Lines before the edits are where they were.
        assert_eq!(
            t.lines().take(4).collect::<Vec<_>>(),
            SCENE.lines().take(4).collect::<Vec<_>>()
        );
        let t = apply(&["sky.type=\"constant\"", "sky.radiance=0.5"]).unwrap();
        let doc: toml::Table = toml::from_str(&t).unwrap();
        assert_eq!(doc["sky"]["radiance"].as_float(), Some(0.5));
        let t = apply(&["light[0].position.time=\"2024-06-21T12:00:00Z\""]).unwrap();
        assert!(t.contains("2024-06-21T12:00:00Z"), "{t}");
    }

    #[test]
    fn bad_overrides_name_the_key() {
        for (s, words) in [
            ("film.spp", "KEY=VALUE"),
            ("film.spp=sixty", "not a TOML value"),
            ("light[x].irradiance=2", "NAME[INDEX]"),
            ("light[0]=2", "whole table"),
            ("fi lm.spp=2", "not a key name"),
        ] {
            let e = s.parse::<Override>().unwrap_err();
            assert!(e.contains(words), "{s}: {e}");
        }
        for (s, words) in [
            ("light[2].irradiance=1", "2 [[light]] table(s)"),
            ("material[0].name=\"x\"", "no [[material]] tables"),
            ("film.width.x=1", "'width' is not a table"),
            ("camera=1", "set one of its keys"),
            ("film[0].spp=1", "not a list of [[tables]]"),
        ] {
            let e = apply(&[s]).unwrap_err().to_string();
            assert!(
                e.starts_with("s.toml: ") && e.contains("--set") && e.contains(words),
                "{s}: {e}"
            );
        }
    }
}
