//! `type = "quad"`: a parallelogram area light.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `corner`, `edge_u`, `edge_v` | m, `[x, y, z]` | required | the parallelogram `corner + s·edge_u + t·edge_v`, s, t in [0, 1] |
//! | `radiance` | colour, W m⁻² sr⁻¹ | required | emitted radiance |
//! | `two_sided` | bool | `false` | one-sided lights emit toward `edge_u × edge_v` |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::Light;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("corner", Kind::Vec3),
    ("edge_u", Kind::Vec3),
    ("edge_v", Kind::Vec3),
    ("radiance", Kind::Color),
    ("two_sided", Kind::Bool),
]);

/// Reads a quad light.
pub(crate) fn read(d: &Dict) -> Result<Light, SceneError> {
    let (corner, edge_u, edge_v) = super::parallelogram(d)?;
    Ok(Light::Quad {
        corner,
        edge_u,
        edge_v,
        radiance: d.req_color("radiance")?,
        two_sided: d.boolean("two_sided")?.unwrap_or(false),
    })
}
