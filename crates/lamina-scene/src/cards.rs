//! Leaf cards: many leaves sharing one material, each a textured rectangle given by centre,
//! normal (the adaxial side), up (toward the leaf tip), width and height, in metres.
//!
//! They come inline in a scene file or from an external file that plant-modelling tools can
//! export:
//! * **JSON**: an array of objects `{"center": [x,y,z], "normal": [..], "up": [..], "width": w,
//!   "height": h}`, or an object `{"cards": [...]}`.
//! * **CSV**: a header row `cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height` (any column order), then
//!   one card per row. Blank lines and lines starting with `#` are skipped.

use crate::error::SceneError;
use crate::file::CardRow;
use crate::scene::Mesh;
use crate::transform::Transform;
use glam::{Vec2, Vec3};
use std::path::Path;

/// A validated leaf card in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafCard {
    /// Centre of the rectangle (m).
    pub center: Vec3,
    /// Unit normal on the adaxial (upper) side.
    pub normal: Vec3,
    /// Unit direction toward the tip, perpendicular to `normal`.
    pub up: Vec3,
    /// Width along `up × normal` (m).
    pub width: f32,
    /// Height along `up` (m).
    pub height: f32,
}

impl LeafCard {
    /// Validates a row: finite values, positive sizes, non-degenerate normal and an `up`
    /// not parallel to it (`up` is made perpendicular to `normal`). `Err` says what is wrong.
    pub fn new(row: &CardRow) -> Result<Self, String> {
        let all = row
            .center
            .iter()
            .chain(&row.normal)
            .chain(&row.up)
            .chain([&row.width, &row.height]);
        if all.into_iter().any(|v| !v.is_finite()) {
            return Err("every value must be a finite number".into());
        }
        if !(row.width > 0.0 && row.height > 0.0) {
            return Err(format!(
                "width and height must be > 0, got {} and {}",
                row.width, row.height
            ));
        }
        let n = Vec3::from(row.normal);
        if n.length_squared() < 1e-12 {
            return Err("normal has zero length".into());
        }
        let n = n.normalize();
        let up = Vec3::from(row.up);
        let up = up - n * n.dot(up);
        if up.length_squared() < 1e-10 * Vec3::from(row.up).length_squared().max(1e-30)
            || up.length_squared() < 1e-20
        {
            return Err("up is zero or parallel to normal".into());
        }
        Ok(LeafCard {
            center: Vec3::from(row.center),
            normal: n,
            up: up.normalize(),
            width: row.width,
            height: row.height,
        })
    }

    /// The card transformed (sizes scale with the transform's stretch along each axis).
    pub fn transformed(&self, t: &Transform) -> LeafCard {
        let right = self.up.cross(self.normal);
        let r = t.vector(right * self.width);
        let u = t.vector(self.up * self.height);
        let mut n = t.normal(self.normal);
        if t.flips() {
            n = -n;
        }
        LeafCard {
            center: t.point(self.center),
            normal: n,
            up: u.normalize_or_zero(),
            width: r.length(),
            height: u.length(),
        }
    }
}

/// Appends the two triangles of each card to `mesh`. Texture `u` runs along
/// `right = up × normal`, `v` along `up` (`v = 0` at the base, 1 at the tip), so the local
/// frame (dP/du, dP/dv, normal) is right-handed and the counter-clockwise face is adaxial.
pub fn append_cards(mesh: &mut Mesh, cards: &[LeafCard]) {
    mesh.positions.reserve(cards.len() * 4);
    mesh.uvs.reserve(cards.len() * 4);
    mesh.indices.reserve(cards.len() * 2);
    for c in cards {
        let right = c.up.cross(c.normal) * (0.5 * c.width);
        let up = c.up * (0.5 * c.height);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend([
            c.center - right - up,
            c.center + right - up,
            c.center + right + up,
            c.center - right + up,
        ]);
        mesh.uvs.extend([
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]);
        mesh.indices
            .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    }
}

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

    fn row() -> CardRow {
        CardRow {
            center: [0.0; 3],
            normal: [0.0, 0.0, 1.0],
            up: [0.0, 1.0, 0.0],
            width: 0.05,
            height: 0.1,
        }
    }

    #[test]
    fn card_geometry_frame_is_right_handed() {
        let mut mesh = Mesh::default();
        append_cards(&mut mesh, &[LeafCard::new(&row()).unwrap()]);
        let [a, b, c] = mesh.indices[0].map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize();
        assert!(
            (n - Vec3::Z).length() < 1e-6,
            "counter-clockwise face is the adaxial side"
        );
        // dP/du is +x = up × normal.
        assert!(((mesh.positions[1] - mesh.positions[0]).normalize() - Vec3::X).length() < 1e-6);
        assert!((mesh.positions[2].y - 0.05).abs() < 1e-6);
    }

    #[test]
    fn bad_rows_are_rejected() {
        let mut r = row();
        r.width = 0.0;
        assert!(LeafCard::new(&r).unwrap_err().contains("width"));
        let mut r = row();
        r.up = [0.0, 0.0, 2.0];
        assert!(LeafCard::new(&r).unwrap_err().contains("parallel"));
        let mut r = row();
        r.center[1] = f32::NAN;
        assert!(LeafCard::new(&r).unwrap_err().contains("finite"));
    }

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
