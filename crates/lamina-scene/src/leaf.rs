//! Leaf materials in scene files: from a leaf folder's `leaf.toml` (as written by
//! `lamina leaf prepare` / `generate`), with optional inline overrides of maps and
//! parameters, or entirely inline.
//!
//! ```toml
//! [[material]]
//! name = "beech"
//! type = "leaf"
//! file = "leaves/beech/leaf.toml"     # optional; its map paths are relative to its folder
//! maps = { bump = "my_bump.png" }     # optional; relative to the scene file
//! params = { thickness_mm = 0.25 }    # optional; overrides single parameters
//! ```

use crate::error::SceneError;
use crate::file::{MaterialTable, S};
use crate::load::Ctx;
use lamina_leaf::{LeafDescription, LeafMaps, LeafMaterial};
use std::path::Path;

/// Reads a `leaf.toml` into a TOML table whose map paths are made absolute.
fn read_leaf_file(path: &Path) -> Result<toml::Table, SceneError> {
    let text = crate::error::read_text(
        path,
        "leaf description",
        lamina_leaf::maps::MAX_DESCRIPTION_BYTES,
    )?;
    let mut table: toml::Table =
        toml::from_str(&text).map_err(|e| crate::load::toml_error(path, &text, &e))?;
    let dir = path.parent().unwrap_or(Path::new(""));
    absolutise_maps(&mut table, dir);
    // Check the file on its own, so its errors name its own lines.
    let _: LeafDescription =
        toml::from_str(&text).map_err(|e| crate::load::toml_error(path, &text, &e))?;
    Ok(table)
}

/// Makes every string under `maps` relative to `dir`.
fn absolutise_maps(table: &mut toml::Table, dir: &Path) {
    if let Some(toml::Value::Table(maps)) = table.get_mut("maps") {
        for (_, v) in maps.iter_mut() {
            if let toml::Value::String(s) = v {
                let joined = dir.join(s.as_str()).to_string_lossy().into_owned();
                *s = joined;
            }
        }
    }
}

/// Overlays `over` onto `base`, table by table.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

pub(crate) fn load_leaf_material(
    cx: &Ctx,
    key: &str,
    m: &MaterialTable,
) -> Result<LeafMaterial, SceneError> {
    if let (Some(_), Some(s)) = (&m.file, &m.species) {
        return Err(cx.err(
            s.span(),
            format!("{key}.species"),
            "give either 'file' or 'species', not both",
        ));
    }
    for (v, name) in [(&m.seed, "seed"), (&m.resolution, "resolution")] {
        if let (Some(v), None) = (v, &m.species) {
            return Err(cx.err(
                v.span(),
                format!("{key}.{name}"),
                "only applies to a procedural leaf ('species')",
            ));
        }
    }
    // The base description: a leaf file, a procedural species, or the defaults.
    let mut generated = None;
    let mut table = match (&m.file, &m.species) {
        (Some(f), _) => read_leaf_file(&cx.path(f))?,
        (None, Some(s)) => {
            let species: lamina_leafmaps::Species =
                s.get_ref()
                    .parse()
                    .map_err(|e: lamina_leafmaps::UnknownSpecies| {
                        cx.err(s.span(), format!("{key}.species"), e.to_string())
                    })?;
            let seed = cx.opt_count(&m.seed, &format!("{key}.seed"), 0, u32::MAX as i64, 1)?;
            let res_key = format!("{key}.resolution");
            let res = cx.opt_count(
                &m.resolution,
                &res_key,
                16,
                crate::limits::MAX_LEAF_RESOLUTION,
                512,
            )?;
            // The scene-wide budget of procedural leaf maps, before they are generated.
            let span = m.resolution.as_ref().map_or(s.span(), |r| r.span());
            cx.spend_leaf_texels(span, &res_key, (res as u64).pow(2))?;
            let leaf = lamina_leafmaps::generate(&lamina_leafmaps::LeafSpec::new(
                species,
                seed as u64,
                res,
            ));
            let mut t = toml::Table::new();
            let params = toml::Table::try_from(leaf.params)
                .map_err(|e| cx.err(s.span(), key, e.to_string()))?;
            t.insert("params".into(), toml::Value::Table(params));
            generated = Some(leaf.maps);
            t
        }
        (None, None) => toml::Table::new(),
    };
    let mut over = toml::Table::new();
    if let Some(maps) = &m.maps {
        let mut t = maps.get_ref().clone();
        for (name, v) in t.iter_mut() {
            match v {
                toml::Value::String(s) => {
                    let joined = cx.base.join(s.as_str()).to_string_lossy().into_owned();
                    *s = joined;
                }
                other => {
                    let got = other.type_str();
                    return Err(cx.err(
                        maps.span(),
                        format!("{key}.maps.{name}"),
                        format!("must be a file path (string), got a {got}"),
                    ));
                }
            }
        }
        over.insert("maps".into(), toml::Value::Table(t));
    }
    if let Some(params) = &m.params {
        over.insert(
            "params".into(),
            toml::Value::Table(params.get_ref().clone()),
        );
    }
    merge(&mut table, over);
    let span_of = |s: &Option<S<toml::Table>>| s.as_ref().map(|s| s.span());
    let anchor = span_of(&m.params)
        .or(span_of(&m.maps))
        .or(m.file.as_ref().map(|f| f.span()))
        .or(m.species.as_ref().map(|f| f.span()))
        .unwrap_or(m.name.span());
    let desc: LeafDescription =
        toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| {
                cx.err(anchor.clone(), key, e.message().trim().to_string())
            })?;
    let fail = |e: lamina_leaf::LeafError| cx.err(anchor.clone(), key, e.to_string());
    match generated {
        None => LeafMaterial::load(&desc, Path::new("")).map_err(fail),
        Some(g) => {
            // Maps named in the scene replace the generated ones.
            let o = LeafMaps::load(&desc.maps, Path::new("")).map_err(fail)?;
            let maps = LeafMaps {
                front: o.front.or(g.front),
                back: o.back.or(g.back),
                translucency: o.translucency.or(g.translucency),
                alpha: o.alpha.or(g.alpha),
                thickness: o.thickness.or(g.thickness),
                extinction: o.extinction.or(g.extinction),
                bump: o.bump.or(g.bump),
            };
            LeafMaterial::new(maps, desc.params).map_err(fail)
        }
    }
}
