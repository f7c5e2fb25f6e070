//! `type = "leaf_cards"`: many leaves sharing one scene `material`.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `cards` | array of `{ center = [..], normal = [..], up = [..], width = w, height = h }` | none | inline cards. `normal` is the adaxial (upper) side, `up` points to the leaf tip (made perpendicular to `normal`), `center` in m, `width`/`height` in m. Texture `u` runs along `up × normal`, `v` from base (0) to tip (1) |
//! | `file` | path | none | a `.json` or `.csv` card file with the same fields, with or instead of `cards` |

use super::ObjectInput;
use crate::cards::{LeafCard, append_cards};
use crate::dict::{Dict, Keys, Kind, Value};
use crate::error::SceneError;
use crate::scene::Mesh;
use lamina_core::cards::CardRow;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[("file", Kind::Str), ("cards", Kind::Array)]);

/// The keys of one inline card.
const CARD: Keys = Keys::plain(&[
    ("center", Kind::Vec3),
    ("normal", Kind::Vec3),
    ("up", Kind::Vec3),
    ("width", Kind::Num),
    ("height", Kind::Num),
]);

/// Reads a leaf-card object.
pub(crate) fn read(o: &ObjectInput, material: u32) -> Result<Vec<Mesh>, SceneError> {
    let d = o.d;
    let mut cards: Vec<LeafCard> = Vec::new();
    let rows = d.array("cards")?;
    if let Some(rows) = &rows {
        for (j, row) in rows.get_ref().iter().enumerate() {
            let at = format!("{}.cards[{j}]", d.at);
            let Value::Table(t) = row.get_ref() else {
                return Err(d.ld.err(
                    row.span(),
                    at,
                    format!("must be a card table, got {}", row.get_ref().type_name()),
                ));
            };
            let c = Dict::open(d.ld, at.clone(), None, row.span(), t, CARD)?;
            let vec3 = |k: &str| {
                Ok::<_, SceneError>(
                    c.raw_vec3(k)?
                        .ok_or_else(|| c.missing(k))?
                        .into_inner()
                        .to_array(),
                )
            };
            let float = |k: &str| {
                Ok::<_, SceneError>(c.raw_float(k)?.ok_or_else(|| c.missing(k))?.into_inner())
            };
            let card = CardRow {
                center: vec3("center")?,
                normal: vec3("normal")?,
                up: vec3("up")?,
                width: float("width")?,
                height: float("height")?,
            };
            c.finish()?;
            cards.push(LeafCard::new(&card).map_err(|m| d.ld.err(rows.span(), at, m))?);
        }
    }
    let file = d.string("file")?;
    if let Some(f) = &file {
        let left = d.ld.leaves_left().saturating_sub(cards.len() as u64);
        let max = usize::try_from(left).unwrap_or(usize::MAX);
        cards.extend(crate::cards::read_card_file_capped(
            &d.ld.path(f.get_ref()),
            max,
        )?);
    }
    d.ld.spend_leaves(d.span.clone(), &d.key("cards"), cards.len() as u64)?;
    if rows.is_none() && file.is_none() {
        return Err(d.err(
            d.span.clone(),
            "cards",
            "a leaf_cards object needs 'cards' or 'file'",
        ));
    }
    let cards: Vec<LeafCard> = cards.iter().map(|c| c.transformed(o.transform)).collect();
    let mut mesh = Mesh {
        material,
        ..Default::default()
    };
    append_cards(&mut mesh, &cards);
    Ok(vec![mesh])
}
