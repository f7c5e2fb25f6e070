//! `type = "sun"`: a distant disc light (parallel light when its angular diameter is 0).
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `direction` | direction, non-zero | required | toward the sun |
//! | `irradiance` | colour, W m⁻² | required | on a surface facing the sun |
//! | `angular_diameter` | degrees, [0, 90] | `0.53` | the sun's disc; 0 = hard shadows |

use crate::dict::{Dict, Keys, Kind};
use crate::error::SceneError;
use crate::scene::Light;

/// The keys of the table above.
pub(crate) const KEYS: Keys = super::keys(&[
    ("direction", Kind::Vec3),
    ("irradiance", Kind::Color),
    ("angular_diameter", Kind::Num),
]);

/// Reads a sun.
pub(crate) fn read(d: &Dict) -> Result<Light, SceneError> {
    Ok(Light::Sun {
        direction: d.req_direction("direction")?,
        irradiance: d.req_color("irradiance")?,
        angular_diameter_deg: d.float("angular_diameter", 0.0, 90.0, false, 0.53)?,
    })
}
