//! `[camera]` (required): a thin-lens perspective camera.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `position` | m, `[x, y, z]` | required | eye position |
//! | `look_at` | m | required | a point in the centre of the view; must differ from `position` |
//! | `up` | direction | `[0, 1, 0]` | up on the image; not parallel to the view direction |
//! | `fov` | degrees, (0, 179] | `40` | **horizontal** field of view |
//! | `aperture_radius` | m, >= 0 | `0` | thin-lens aperture radius; 0 = pinhole |
//! | `focus_distance` | m, > 0 | distance to `look_at` | distance of the plane in focus |

use crate::dict::{Dict, Keys, Kind, S, Table};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::Camera;
use glam::Vec3;

/// The keys of the table above.
pub(crate) const KEYS: Keys = Keys::plain(&[
    ("position", Kind::Vec3),
    ("look_at", Kind::Vec3),
    ("up", Kind::Vec3),
    ("fov", Kind::Num),
    ("aperture_radius", Kind::Num),
    ("focus_distance", Kind::Num),
]);

/// Checks the keys of `[camera]` and their types.
pub(crate) fn check(ld: &Loader, t: &S<Table>) -> Result<(), SceneError> {
    Dict::open(ld, "camera", None, t.span(), t.get_ref(), KEYS).map(drop)
}

/// Reads `[camera]`.
pub(crate) fn read(ld: &Loader, t: &S<Table>) -> Result<Camera, SceneError> {
    let d = Dict::open(ld, "camera", None, t.span(), t.get_ref(), KEYS)?;
    let position = d.req_vec3("position")?;
    let look_at = d.req_vec3_spanned("look_at")?;
    let forward = *look_at.get_ref() - position;
    if forward.length_squared() < 1e-12 {
        return Err(d.err(
            look_at.span(),
            "look_at",
            "must differ from camera.position",
        ));
    }
    let look_at = look_at.into_inner();
    let up = d.direction_opt("up")?.unwrap_or(Vec3::Y);
    if forward.normalize().cross(up).length_squared() < 1e-8 {
        let span = d.get("up").map_or(t.span(), |u| u.span());
        return Err(d.err(
            span,
            "up",
            "must not be parallel to the viewing direction (look_at - position)",
        ));
    }
    let fov_deg = d.float("fov", 0.0, 179.0, true, 40.0)?;
    let aperture_radius = d.float("aperture_radius", 0.0, 1e3, false, 0.0)?;
    let focus_distance = d.float("focus_distance", 0.0, 1e9, true, forward.length())?;
    d.finish()?;
    Ok(Camera {
        position,
        look_at,
        up,
        fov_deg,
        aperture_radius,
        focus_distance,
    })
}
