//! `type = "sphere"`: a spherical area light.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `center` | m, `[x, y, z]` | required | centre of the sphere |
//! | `radius` | m, > 0 | required | its radius |
//! | `radiance` | colour, W m⁻² sr⁻¹ | required | emitted radiance, the same from every point and direction |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::Light;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("center", Kind::Vec3),
    ("radius", Kind::Num),
    ("radiance", Kind::Color),
]);

/// Reads a sphere light.
pub(crate) fn read(d: &Dict) -> Result<Light, SceneError> {
    Ok(Light::Sphere {
        center: d.req_vec3("center")?,
        radius: d.req_float("radius", 0.0, 1e9, true)?,
        radiance: d.req_color("radiance")?,
    })
}
