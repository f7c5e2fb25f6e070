//! `type = "quad"`: a parallelogram with one scene `material`.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `corner`, `edge_u`, `edge_v` | m, `[x, y, z]` | required | the parallelogram `corner + s·edge_u + t·edge_v`, front face toward `edge_u × edge_v`, `uv = (s, t)` |

use super::{ObjectInput, apply_transform};
use crate::dict::{Keys, Kind};
use crate::error::SceneError;
use crate::scene::Mesh;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("corner", Kind::Vec3),
    ("edge_u", Kind::Vec3),
    ("edge_v", Kind::Vec3),
]);

/// Reads a quad.
pub(crate) fn read(o: &ObjectInput, material: u32) -> Result<Vec<Mesh>, SceneError> {
    let (corner, edge_u, edge_v) = crate::light::parallelogram(o.d)?;
    let mut mesh = Mesh::quad(corner, edge_u, edge_v, material);
    apply_transform(&mut mesh, o.transform);
    Ok(vec![mesh])
}
