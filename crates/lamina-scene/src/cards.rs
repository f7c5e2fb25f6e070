//! Leaf-card files that plant-modelling tools can export, read into [`LeafCard`]s:
//! * **JSON**: an array of objects `{"center": [x,y,z], "normal": [..], "up": [..], "width": w,
//!   "height": h}`, or an object `{"cards": [...]}`.
//! * **CSV**: a header row `cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height` (any column order), then
//!   one card per row. Blank lines and lines starting with `#` are skipped.
//!
//! The card geometry itself ([`LeafCard`], [`append_cards`]) lives in `lamina-core`.

use crate::error::SceneError;
pub use lamina_core::cards::*;
use std::path::Path;

/// Most cards one leaf-card file may hold: the scene-wide limit on leaves
/// ([`crate::limits::MAX_SCENE_LEAVES`]).
pub const MAX_CARDS: usize = crate::limits::MAX_SCENE_LEAVES as usize;

/// Reads leaf cards from a `.json` or `.csv` file (at most
/// [`crate::limits::MAX_TEXT_FILE_BYTES`] and [`MAX_CARDS`] cards). Errors name the file,
/// the row (1-based line for CSV, 0-based card index for JSON) and what was wrong; a panic
/// in a parser is an error naming the file.
pub fn read_card_file(path: &Path) -> Result<Vec<LeafCard>, SceneError> {
    read_card_file_capped(path, MAX_CARDS)
}

/// [`read_card_file`] that stops with an error after `max` cards.
pub(crate) fn read_card_file_capped(path: &Path, max: usize) -> Result<Vec<LeafCard>, SceneError> {
    crate::error::guarded(path, || {
        crate::error::fault_point("cards");
        let text =
            crate::error::read_text(path, "leaf-card file", crate::limits::MAX_TEXT_FILE_BYTES)?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "json" => parse_json_capped(path, &text, max),
            "csv" => parse_csv_capped(path, &text, max),
            _ => Err(SceneError::new(
                path,
                None,
                "",
                "leaf-card files must end in .json or .csv",
            )),
        }
    })
}

/// Parses the text of a JSON leaf-card file (see the module docs); `path` names it in
/// errors. The entry point for fuzzing.
pub fn parse_json(path: &Path, text: &str) -> Result<Vec<LeafCard>, SceneError> {
    crate::error::guarded(path, || parse_json_capped(path, text, MAX_CARDS))
}

/// Parses the text of a CSV leaf-card file (see the module docs); `path` names it in
/// errors. The entry point for fuzzing.
pub fn parse_csv(path: &Path, text: &str) -> Result<Vec<LeafCard>, SceneError> {
    crate::error::guarded(path, || parse_csv_capped(path, text, MAX_CARDS))
}

/// Too many cards in `path`.
fn too_many(path: &Path, line: Option<usize>, max: usize) -> SceneError {
    SceneError::new(
        path,
        line,
        "",
        format!(
            "more than {max} leaf cards (at most {} leaves in a scene, cards and plant leaves together)",
            crate::limits::MAX_SCENE_LEAVES
        ),
    )
}

fn parse_json_capped(path: &Path, text: &str, max: usize) -> Result<Vec<LeafCard>, SceneError> {
    use serde::de::{self, Deserializer as _};
    use std::cell::RefCell;
    /// The top level, `[...]` or `{"cards": [...]}`; one card at a time, so that memory
    /// stays proportional to the cards (not to a JSON tree of the whole file).
    struct Top<'a> {
        path: &'a Path,
        max: usize,
        /// The error of a card, with its key, reported after serde unwinds.
        card_error: &'a RefCell<Option<SceneError>>,
    }
    struct Cards<'a>(&'a Top<'a>);
    impl<'de> de::DeserializeSeed<'de> for Cards<'_> {
        type Value = Vec<LeafCard>;
        fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
            d.deserialize_seq(self)
        }
    }
    impl<'de> de::Visitor<'de> for Cards<'_> {
        type Value = Vec<LeafCard>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an array of leaf cards")
        }
        fn visit_seq<A: de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            let top = self.0;
            let mut out = Vec::new();
            while let Some(v) = seq.next_element::<serde_json::Value>()? {
                let i = out.len();
                if i >= top.max {
                    *top.card_error.borrow_mut() = Some(too_many(top.path, None, top.max));
                    return Err(de::Error::custom("too many cards"));
                }
                let card = serde_json::from_value::<CardRow>(v)
                    .map_err(|e| e.to_string())
                    .and_then(|row| LeafCard::new(&row));
                match card {
                    Ok(c) => out.push(c),
                    Err(m) => {
                        *top.card_error.borrow_mut() =
                            Some(SceneError::new(top.path, None, format!("card {i}"), m));
                        return Err(de::Error::custom("bad card"));
                    }
                }
            }
            Ok(out)
        }
    }
    impl<'de> de::Visitor<'de> for &Top<'_> {
        type Value = Vec<LeafCard>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an array of leaf cards or {\"cards\": [...]}")
        }
        fn visit_seq<A: de::SeqAccess<'de>>(self, seq: A) -> Result<Self::Value, A::Error> {
            de::Visitor::visit_seq(Cards(self), seq)
        }
        fn visit_map<A: de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let mut cards = None;
            while let Some(k) = map.next_key::<String>()? {
                if k == "cards" && cards.is_none() {
                    cards = Some(map.next_value_seed(Cards(self))?);
                } else {
                    map.next_value::<de::IgnoredAny>()?;
                }
            }
            cards.ok_or_else(|| de::Error::missing_field("cards"))
        }
    }
    let card_error = RefCell::new(None);
    let top = Top {
        path,
        max,
        card_error: &card_error,
    };
    let mut d = serde_json::Deserializer::from_str(text);
    let cards = d.deserialize_any(&top).and_then(|c| d.end().map(|_| c));
    cards.map_err(|e| {
        card_error.take().unwrap_or_else(|| {
            SceneError::new(
                path,
                Some(e.line()),
                "",
                format!("not a JSON array of leaf cards (or {{\"cards\": [...]}}): {e}"),
            )
        })
    })
}

const CSV_COLUMNS: [&str; 11] = [
    "cx", "cy", "cz", "nx", "ny", "nz", "ux", "uy", "uz", "width", "height",
];

fn parse_csv_capped(path: &Path, text: &str, max: usize) -> Result<Vec<LeafCard>, SceneError> {
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.as_bytes());
    let headers = reader
        .headers()
        .map_err(|e| SceneError::new(path, Some(1), "header", e.to_string()))?
        .clone();
    let mut columns = [0usize; 11];
    for (slot, name) in columns.iter_mut().zip(CSV_COLUMNS) {
        *slot = headers
            .iter()
            .position(|h| h.eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                SceneError::new(
                    path,
                    Some(1),
                    "header",
                    format!("missing column '{name}' (need {})", CSV_COLUMNS.join(",")),
                )
            })?;
    }
    let mut cards = Vec::new();
    for record in reader.records() {
        let record = record.map_err(|e| {
            let line = e.position().map(|p| p.line() as usize);
            SceneError::new(path, line, "", e.to_string())
        })?;
        let line = record.position().map(|p| p.line() as usize);
        if cards.len() >= max {
            return Err(too_many(path, line, max));
        }
        let mut v = [0.0f32; 11];
        for ((slot, &col), name) in v.iter_mut().zip(&columns).zip(CSV_COLUMNS) {
            let field = record.get(col).ok_or_else(|| {
                SceneError::new(
                    path,
                    line,
                    name,
                    format!(
                        "row has {} fields, column '{name}' is missing",
                        record.len()
                    ),
                )
            })?;
            *slot = field.parse().map_err(|_| {
                SceneError::new(path, line, name, format!("'{field}' is not a number"))
            })?;
        }
        let row = CardRow {
            center: [v[0], v[1], v[2]],
            normal: [v[3], v[4], v[5]],
            up: [v[6], v[7], v[8]],
            width: v[9],
            height: v[10],
        };
        cards.push(LeafCard::new(&row).map_err(|m| SceneError::new(path, line, "", m))?);
    }
    Ok(cards)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_and_json_parse_and_report_rows() {
        let ok = "cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height\n0,0,0,0,0,1,0,1,0,0.1,0.2\n# comment\n1,0,0,0,1,0,0,0,1,0.1,0.2\n";
        assert_eq!(parse_csv(Path::new("c.csv"), ok).unwrap().len(), 2);
        let bad = "cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height\n0,0,0,0,0,1,0,1,0,0.1,0.2\n0,0,0,0,0,1,0,1,0,abc,0.2\n";
        let e = parse_csv(Path::new("c.csv"), bad).unwrap_err();
        assert_eq!(e.line, Some(3));
        assert!(e.to_string().contains("'abc' is not a number"), "{e}");
        let json = r#"[{"center":[0,0,0],"normal":[0,0,1],"up":[0,1,0],"width":0.1,"height":0.2},
                       {"center":[0,0,0],"normal":[0,0,1],"up":[0,1,0],"width":-1,"height":0.2}]"#;
        let e = parse_json(Path::new("c.json"), json).unwrap_err();
        assert_eq!(e.key, "card 1");
        assert!(e.to_string().contains("width"), "{e}");
    }
}
