//! `type = "leaf"`: the three-layer leaf model with its seven maps, from a leaf folder's
//! `leaf.toml` (as written by `lamina leaf prepare` / `generate`) or a built-in procedural
//! species, with optional inline overrides of maps and parameters.
//!
//! | key | unit, range | default | meaning |
//! |---|---|---|---|
//! | `name` | string | required | the name objects use |
//! | `file` | path | none | a leaf folder's `leaf.toml`, as `lamina leaf prepare` or `lamina leaf generate` write it; its map paths are relative to its own folder |
//! | `species` | `beech`, `maple`, `oak`, `birch`, `ivy`, `grass`, `willow` | none | a built-in procedural leaf instead of `file` |
//! | `seed` | integer >= 0 | `1` | `species` only: the procedural leaf's seed |
//! | `resolution` | pixels, 16-4096 | `512` | `species` only: the maps' longer side |
//! | `maps` | table of paths | none | map paths overriding the file's: `front`, `back`, `translucency`, `alpha`, `thickness`, `extinction`, `bump` (relative to the scene file) |
//! | `params` | table | none | leaf parameters overriding the file's; see the lamina-leaf crate docs for each parameter, its unit and range |
//! | `pigments` | table | none | PROSPECT pigments `n`, `cab` (µg/cm²), `car`, `anth`, `cbrown`, `cw` (cm), `cm` (g/cm²), PRO's `prot`, `cbc` (g/cm²), each within its published range: the leaf's colours come from PROSPECT instead of colour maps (a `species` leaf then keeps only its shape maps: alpha, thickness, extinction, bump); see lamina-leaf's README, "Pigment leaves" |
//!
//! ```toml
//! [[material]]
//! name = "beech"
//! type = "leaf"
//! file = "leaves/beech/leaf.toml"     # optional; its map paths are relative to its folder
//! maps = { bump = "my_bump.png" }     # optional; relative to the scene file
//! params = { thickness_mm = 0.25 }    # optional; overrides single parameters
//! ```

use crate::dict::{Dict, Keys, Kind, Value, table_to_toml};
use crate::error::SceneError;
use crate::scene::Material;
use lamina_leaf::{LeafDescription, LeafMaps, LeafMaterial};
use std::path::Path;
use std::sync::Arc;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("name", Kind::Str),
    ("file", Kind::Str),
    ("species", Kind::Str),
    ("seed", Kind::Int),
    ("resolution", Kind::Int),
    ("maps", Kind::Table),
    ("params", Kind::Table),
    ("pigments", Kind::Table),
]);

/// Reads a leaf material.
pub(crate) fn read(d: &Dict, name: String) -> Result<Material, SceneError> {
    Ok(Material::Leaf {
        name,
        leaf: Arc::new(load_leaf_material(d)?),
    })
}

/// Reads a `leaf.toml` into a TOML table whose map paths are made absolute.
fn read_leaf_file(path: &Path) -> Result<toml::Table, SceneError> {
    let text = crate::error::read_text(
        path,
        "leaf description",
        lamina_leaf::maps::MAX_DESCRIPTION_BYTES,
    )?;
    let mut table: toml::Table =
        toml::from_str(&text).map_err(|e| crate::loader::toml_error(path, &text, &e))?;
    let dir = path.parent().unwrap_or(Path::new(""));
    absolutise_maps(&mut table, dir);
    // Check the file on its own, so its errors name its own lines.
    let _: LeafDescription =
        toml::from_str(&text).map_err(|e| crate::loader::toml_error(path, &text, &e))?;
    Ok(table)
}

/// The one key under `maps` that is not a file path: the addressing mode.
const WRAP_KEY: &str = "wrap";

/// Makes every map path under `maps` relative to `dir` (not `wrap`, which is a mode).
fn absolutise_maps(table: &mut toml::Table, dir: &Path) {
    if let Some(toml::Value::Table(maps)) = table.get_mut("maps") {
        for (k, v) in maps.iter_mut() {
            if k == WRAP_KEY {
                continue;
            }
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

/// The leaf of material dictionary `d`: its base description (file, species or defaults)
/// overlaid with the inline `maps` and `params`.
fn load_leaf_material(d: &Dict) -> Result<LeafMaterial, SceneError> {
    let cx = d.ld;
    let file = d.string("file")?;
    let species = d.string("species")?;
    if let (Some(_), Some(s)) = (&file, &species) {
        return Err(d.err(
            s.span(),
            "species",
            "give either 'file' or 'species', not both",
        ));
    }
    for name in ["seed", "resolution"] {
        if let (Some(v), None) = (d.get(name), &species) {
            return Err(d.err(
                v.span(),
                name,
                "only applies to a procedural leaf ('species')",
            ));
        }
    }
    // The base description: a leaf file, a procedural species, or the defaults.
    let mut generated = None;
    let mut table = match (&file, &species) {
        (Some(f), _) => read_leaf_file(&cx.path(f.get_ref()))?,
        (None, Some(s)) => {
            let species: lamina_leafmaps::Species =
                s.get_ref()
                    .parse()
                    .map_err(|e: lamina_leafmaps::UnknownSpecies| {
                        d.err(s.span(), "species", e.to_string())
                    })?;
            let seed = d.count("seed", 0, u32::MAX as i64, 1)?;
            let res = d.count("resolution", 16, crate::limits::MAX_LEAF_RESOLUTION, 512)?;
            // The scene-wide budget of procedural leaf maps, before they are generated.
            let span = d.get("resolution").map_or(s.span(), |r| r.span());
            cx.spend_leaf_texels(span, &d.key("resolution"), (res as u64).pow(2))?;
            let leaf = lamina_leafmaps::generate(&lamina_leafmaps::LeafSpec::new(
                species,
                seed as u64,
                res,
            ));
            let mut t = toml::Table::new();
            let params = toml::Table::try_from(leaf.params)
                .map_err(|e| cx.err(s.span(), d.at.clone(), e.to_string()))?;
            t.insert("params".into(), toml::Value::Table(params));
            generated = Some(leaf.maps);
            t
        }
        (None, None) => toml::Table::new(),
    };
    let mut over = toml::Table::new();
    let maps = d.table("maps")?;
    if let Some(maps) = &maps {
        let mut t = toml::Table::new();
        for (name, v) in maps.get_ref().iter() {
            match v.get_ref() {
                Value::String(s) if name.get_ref() == WRAP_KEY => {
                    t.insert(name.get_ref().clone(), toml::Value::String(s.clone()));
                }
                Value::String(s) => {
                    let joined = cx.base.join(s.as_str()).to_string_lossy().into_owned();
                    t.insert(name.get_ref().clone(), toml::Value::String(joined));
                }
                other => {
                    return Err(cx.err(
                        maps.span(),
                        format!("{}.maps.{}", d.at, name.get_ref()),
                        format!("must be a file path (string), got {}", other.type_name()),
                    ));
                }
            }
        }
        over.insert("maps".into(), toml::Value::Table(t));
    }
    let params = d.table("params")?;
    if let Some(params) = &params {
        over.insert(
            "params".into(),
            toml::Value::Table(table_to_toml(params.get_ref())),
        );
    }
    let pigments = d.table("pigments")?;
    if let Some(p) = &pigments {
        over.insert(
            "pigments".into(),
            toml::Value::Table(table_to_toml(p.get_ref())),
        );
    }
    merge(&mut table, over);
    let anchor = pigments
        .as_ref()
        .map(|s| s.span())
        .or(params.as_ref().map(|s| s.span()))
        .or(maps.as_ref().map(|s| s.span()))
        .or(file.as_ref().map(|f| f.span()))
        .or(species.as_ref().map(|f| f.span()))
        .unwrap_or(d.get("name").map_or(d.span.clone(), |n| n.span()));
    let key = d.at.clone();
    let desc: LeafDescription =
        toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| {
                cx.err(anchor.clone(), key.clone(), e.message().trim().to_string())
            })?;
    let fail = |e: lamina_leaf::LeafError| cx.err(anchor.clone(), key.clone(), e.to_string());
    match generated {
        None => LeafMaterial::load(&desc, Path::new("")).map_err(fail),
        Some(g) => {
            // Maps named in the scene replace the generated ones.
            let o = LeafMaps::load(&desc.maps, Path::new("")).map_err(fail)?;
            // With pigments the procedural colour maps give way to PROSPECT (colour maps
            // the scene names itself are still refused, by the pigment leaf).
            let generated_colour = |m: Option<lamina_leaf::Texture>| {
                if desc.pigments.is_some() { None } else { m }
            };
            let maps = LeafMaps {
                front: o.front.or(generated_colour(g.front)),
                back: o.back.or(generated_colour(g.back)),
                translucency: o.translucency.or(generated_colour(g.translucency)),
                alpha: o.alpha.or(g.alpha),
                thickness: o.thickness.or(g.thickness),
                extinction: o.extinction.or(g.extinction),
                bump: o.bump.or(g.bump),
            };
            LeafMaterial::from_parts(maps, desc.params, desc.pigments).map_err(fail)
        }
    }
}
