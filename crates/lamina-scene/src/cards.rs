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

/// Reads leaf cards from a `.json` or `.csv` file. Errors name the file, the row (1-based
/// line for CSV, 0-based card index for JSON) and what was wrong.
pub fn read_card_file(path: &Path) -> Result<Vec<LeafCard>, SceneError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::new(path, None, "", format!("cannot read leaf-card file: {e}")))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "json" => parse_json(path, &text),
        "csv" => parse_csv(path, &text),
        _ => Err(SceneError::new(
            path,
            None,
            "",
            "leaf-card files must end in .json or .csv",
        )),
    }
}

fn parse_json(path: &Path, text: &str) -> Result<Vec<LeafCard>, SceneError> {
    #[derive(serde::Deserialize)]
    #[serde(untagged)]
    enum Doc {
        List(Vec<serde_json::Value>),
        Wrapped { cards: Vec<serde_json::Value> },
    }
    let doc: Doc = serde_json::from_str(text).map_err(|e| {
        SceneError::new(
            path,
            Some(e.line()),
            "",
            format!("not a JSON array of leaf cards (or {{\"cards\": [...]}}): {e}"),
        )
    })?;
    let rows = match doc {
        Doc::List(r) | Doc::Wrapped { cards: r } => r,
    };
    rows.into_iter()
        .enumerate()
        .map(|(i, v)| {
            let row: CardRow = serde_json::from_value(v)
                .map_err(|e| SceneError::new(path, None, format!("card {i}"), e.to_string()))?;
            LeafCard::new(&row).map_err(|m| SceneError::new(path, None, format!("card {i}"), m))
        })
        .collect()
}

const CSV_COLUMNS: [&str; 11] = [
    "cx", "cy", "cz", "nx", "ny", "nz", "ux", "uy", "uz", "width", "height",
];

fn parse_csv(path: &Path, text: &str) -> Result<Vec<LeafCard>, SceneError> {
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
