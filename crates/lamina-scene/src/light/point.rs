//! `type = "point"`: an isotropic point light.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `position` | m, `[x, y, z]` | required | where the light is |
//! | `intensity` | colour, W sr⁻¹ | required | radiant intensity in every direction |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::Light;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[("position", Kind::Vec3), ("intensity", Kind::Color)]);

/// Reads a point light.
pub(crate) fn read(d: &Dict) -> Result<Light, SceneError> {
    Ok(Light::Point {
        position: d.req_vec3("position")?,
        intensity: d.req_color("intensity")?,
    })
}
