//! The scene-file reference can never drift from the code: every table reader's
//! doc-comment parameter table lists exactly the keys its [`Keys`] list holds, and
//! docs/scene-format.md holds exactly the rows of those tables, in the section of each.

use crate::dict::Keys;

/// One reader: its source (for the doc comment), its keys, and the heading of its section
/// in docs/scene-format.md.
struct Reader {
    source: &'static str,
    keys: Keys,
    heading: &'static str,
}

macro_rules! reader {
    ($file:literal, $keys:expr, $heading:literal) => {
        Reader {
            source: include_str!($file),
            keys: $keys,
            heading: $heading,
        }
    };
}

fn readers() -> Vec<Reader> {
    use crate::{light, material, object, table};
    let mut v = vec![
        reader!("table/camera.rs", table::camera::KEYS, "## `[camera]`"),
        reader!("table/film.rs", table::film::KEYS, "## `[film]`"),
        reader!(
            "table/integrator.rs",
            every(&[table::integrator::PATH, table::integrator::PAPER]),
            "## `[integrator]`"
        ),
        reader!(
            "table/sky.rs",
            every(&[table::sky::CONSTANT, table::sky::IMAGE, table::sky::SUNSKY]),
            "## `[sky]`"
        ),
        reader!("object/mod.rs", common_object_keys(), "## `[[object]]`"),
    ];
    let lights = [
        include_str!("light/sun.rs"),
        include_str!("light/point.rs"),
        include_str!("light/quad.rs"),
        include_str!("light/sphere.rs"),
    ];
    for ((name, keys, _), source) in light::TYPES.iter().zip(lights) {
        v.push(Reader {
            source,
            keys: *keys,
            heading: leak(format!("### `[[light]]` `type = \"{name}\"`")),
        });
    }
    let materials = [
        include_str!("material/diffuse.rs"),
        include_str!("material/diffuse_transmission.rs"),
        include_str!("material/leaf.rs"),
        include_str!("material/pbr.rs"),
    ];
    for ((name, keys, _), source) in material::TYPES.iter().zip(materials) {
        v.push(Reader {
            source,
            keys: *keys,
            heading: leak(format!("### `type = \"{name}\"`")),
        });
    }
    let objects = [
        include_str!("object/quad.rs"),
        include_str!("object/leaf_cards.rs"),
        include_str!("object/obj.rs"),
        include_str!("object/gltf.rs"),
        include_str!("object/plant.rs"),
    ];
    for ((name, keys, _), source) in object::TYPES.iter().zip(objects) {
        v.push(Reader {
            source,
            keys: Keys {
                common: &[],
                ..*keys
            },
            heading: leak(format!("### `[[object]]` `type = \"{name}\"`")),
        });
    }
    v.push(reader!(
        "table/domain.rs",
        table::domain::KEYS,
        "## `[domain]`"
    ));
    v.push(reader!(
        "sensor/mod.rs",
        Keys::plain(crate::sensor::COMMON),
        "## `[[sensor]]`"
    ));
    let sensors = [
        include_str!("sensor/brf.rs"),
        include_str!("sensor/irradiance.rs"),
        include_str!("sensor/absorbed.rs"),
        include_str!("sensor/fisheye.rs"),
    ];
    for ((name, keys, _), source) in crate::sensor::TYPES.iter().zip(sensors) {
        v.push(Reader {
            source,
            keys: Keys {
                common: &[],
                ..*keys
            },
            heading: leak(format!("### `[[sensor]]` `type = \"{name}\"`")),
        });
    }
    v
}

/// A table whose types share one parameter table: all their keys.
fn every(types: &[Keys]) -> Keys {
    let own: Vec<crate::dict::Key> = types.iter().flat_map(|k| k.own.iter().copied()).collect();
    Keys {
        own: Box::leak(own.into_boxed_slice()),
        common: &[],
        typed: true,
    }
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// The keys every object takes, as the object module's own table lists them.
fn common_object_keys() -> Keys {
    Keys::plain(crate::object::COMMON)
}

/// The parameter-table rows of a module's doc comment (`//! | ... |`), header and rule
/// dropped.
fn doc_rows(source: &str) -> Vec<String> {
    let rows: Vec<String> = source
        .lines()
        .filter_map(|l| l.strip_prefix("//! "))
        .take_while(|_| true)
        .filter(|l| l.starts_with('|'))
        .map(str::to_string)
        .collect();
    rows.into_iter().skip(2).collect()
}

/// The backticked names in a row's first column (`| `width`, `height` | ...`).
fn row_keys(row: &str) -> Vec<String> {
    let first = row.trim_start_matches('|').split('|').next().unwrap_or("");
    let first = first.split(" (or ").next().unwrap_or(first);
    first
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// The table rows of the section under `heading` in docs/scene-format.md.
fn md_rows(md: &str, heading: &str) -> Option<Vec<String>> {
    let mut lines = md.lines().skip_while(|l| !l.starts_with(heading));
    lines.next()?;
    let rows: Vec<String> = lines
        .take_while(|l| !l.starts_with('#'))
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .map(str::to_string)
        .collect();
    Some(rows.into_iter().skip(2).collect())
}

#[test]
fn every_reader_documents_exactly_its_keys_and_the_reference_matches() {
    let md = include_str!("../../../docs/scene-format.md");
    let mut problems = Vec::new();
    for r in readers() {
        let rows = doc_rows(r.source);
        let mut documented: Vec<String> = rows.iter().flat_map(|row| row_keys(row)).collect();
        // `alpha` (or `alpha_map`) documents both.
        for row in &rows {
            if let Some(alt) = row.split(" (or `").nth(1).and_then(|s| s.split('`').next()) {
                documented.push(alt.to_string());
            }
        }
        documented.sort();
        let mut keys: Vec<String> = r.keys.own.iter().map(|(k, _)| k.to_string()).collect();
        if r.keys.typed {
            keys.push("type".into());
        }
        keys.sort();
        // The type tables of lights, materials and objects are chosen by `type`, which the
        // family's section documents; a typed table with one `type` row documents it.
        if r.keys.typed && !documented.contains(&"type".to_string()) {
            keys.retain(|k| k != "type");
        }
        if documented != keys {
            problems.push(format!(
                "{}: the doc comment's table lists {documented:?}, the reader takes {keys:?}",
                r.heading
            ));
        }
        match md_rows(md, r.heading) {
            None => problems.push(format!(
                "docs/scene-format.md has no section '{}'",
                r.heading
            )),
            Some(md_rows) if md_rows != rows => problems.push(format!(
                "docs/scene-format.md, section '{}', differs from the reader's doc comment; it should read:\n{}",
                r.heading,
                rows.join("\n")
            )),
            Some(_) => {}
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n\n"));
}
