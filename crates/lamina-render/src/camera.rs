//! The perspective camera: pinhole or thin lens.

use crate::error::RenderError;
use glam::{Vec2, Vec3};
use lamina_core::{Camera, Film};
use lamina_leaf::sampling::square_to_disk;

/// A camera prepared for generating rays.
///
/// Film coordinates are in pixels: `(0, 0)` is the top-left corner of the image, `x` to the
/// right, `y` down; the centre of pixel `(i, j)` is `(i + 0.5, j + 0.5)`.
#[derive(Clone, Copy, Debug)]
pub struct CameraModel {
    origin: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// `tan(fov_x / 2)`.
    tan_half: f32,
    inv_width: f32,
    aspect: f32,
    aperture: f32,
    focus: f32,
}

impl CameraModel {
    /// Prepares `camera` for a film of `film.width x film.height` pixels. An error for
    /// non-finite values, `look_at == position`, `up` parallel to the view direction, or a
    /// field of view outside `(0, 180)` degrees.
    pub fn new(camera: &Camera, film: &Film) -> Result<Self, RenderError> {
        let bad = |m: &str| Err(RenderError::InvalidScene(format!("camera: {m}")));
        let forward = (camera.look_at - camera.position).normalize_or_zero();
        if !camera.position.is_finite() || forward == Vec3::ZERO || !forward.is_finite() {
            return bad("look_at must differ from position and both be finite");
        }
        let right = forward.cross(camera.up).normalize_or_zero();
        if right == Vec3::ZERO || !right.is_finite() {
            return bad("up must not be parallel to the view direction");
        }
        if !(camera.fov_deg > 0.0 && camera.fov_deg < 180.0) {
            return bad("fov must be in (0, 180) degrees");
        }
        if film.width == 0 || film.height == 0 {
            return Err(RenderError::InvalidScene(
                "film size must be positive".into(),
            ));
        }
        let aperture = if camera.aperture_radius.is_finite() {
            camera.aperture_radius.max(0.0)
        } else {
            0.0
        };
        let focus = if camera.focus_distance.is_finite() && camera.focus_distance > 0.0 {
            camera.focus_distance
        } else {
            1.0
        };
        Ok(CameraModel {
            origin: camera.position,
            forward,
            right,
            up: right.cross(forward),
            tan_half: (camera.fov_deg.to_radians() * 0.5).tan(),
            inv_width: 1.0 / film.width as f32,
            aspect: film.height as f32 / film.width as f32,
            aperture,
            focus,
        })
    }

    /// For a pinhole camera (no aperture): the eye, the view direction, the up direction
    /// and the picture `[x0, x1, y0, y1]` its rays cover (tangents of the angles right
    /// and up of the view direction; the film with an 8-pixel margin for the pixel
    /// filter), as lamina-accel's camera grid takes them. `None` for a thin lens, whose
    /// rays leave the lens from different points.
    pub fn pinhole_view(&self) -> Option<(Vec3, Vec3, Vec3, [f32; 4])> {
        if self.aperture > 0.0 {
            return None;
        }
        let margin = 16.0 * self.inv_width;
        let (x, y) = (
            (1.0 + margin) * self.tan_half,
            (self.aspect + margin) * self.tan_half,
        );
        Some((self.origin, self.forward, self.up, [-x, x, -y, y]))
    }

    /// Whether [`CameraModel::generate_ray`] reads its `lens` sample: only a thin lens
    /// (aperture above zero) does. A pinhole's caller may skip drawing it.
    #[inline]
    pub fn uses_lens(&self) -> bool {
        self.aperture > 0.0
    }

    /// For a pinhole (no lens: [`CameraModel::uses_lens`] is false) the rays through film
    /// positions `(fx[k], fy[k])` (pixels) side by side: their common origin is returned,
    /// their unit directions go to `d` (per axis). Bit for bit [`CameraModel::generate_ray`]'s.
    #[inline(always)]
    pub fn pinhole_lanes<const N: usize>(
        &self,
        fx: &[f32; N],
        fy: &[f32; N],
        d: &mut [[f32; N]; 3],
    ) -> Vec3 {
        debug_assert!(!self.uses_lens());
        for k in 0..N {
            let nx = 2.0 * fx[k] * self.inv_width - 1.0;
            let ny = self.aspect - 2.0 * fy[k] * self.inv_width;
            let (a, b) = (nx * self.tan_half, ny * self.tan_half);
            let mut v = [0.0f32; 3];
            for (c, v) in v.iter_mut().enumerate() {
                *v = (self.forward[c] + self.right[c] * a) + self.up[c] * b;
            }
            // glam's `normalize`: `v * (1 / |v|)`, `|v|² = (x² + y²) + z²`.
            let inv = 1.0 / ((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]).sqrt();
            for c in 0..3 {
                d[c][k] = v[c] * inv;
            }
        }
        self.origin
    }

    /// The ray (origin, unit direction) through film position `film` (pixels), using
    /// `lens ∈ [0, 1)²` to pick a point on the lens.
    #[inline]
    pub fn generate_ray(&self, film: Vec2, lens: Vec2) -> (Vec3, Vec3) {
        let (o, d) = self.generate_ray_unnormalized(film, lens);
        (o, d.normalize())
    }

    /// [`CameraModel::generate_ray`] with the direction not yet normalized (any positive
    /// length): for a caller that normalizes several rays' directions together. Normalized
    /// as `glam::Vec3::normalize` does (`d · (1 / √(d·d))`), it is `generate_ray`'s, bit
    /// for bit.
    #[inline]
    pub fn generate_ray_unnormalized(&self, film: Vec2, lens: Vec2) -> (Vec3, Vec3) {
        let nx = 2.0 * film.x * self.inv_width - 1.0;
        let ny = self.aspect - 2.0 * film.y * self.inv_width;
        let d = self.forward + self.right * (nx * self.tan_half) + self.up * (ny * self.tan_half);
        if self.aperture > 0.0 {
            let focus_point = self.origin + d * self.focus;
            let l = square_to_disk(lens) * self.aperture;
            let o = self.origin + self.right * l.x + self.up * l.y;
            (o, focus_point - o)
        } else {
            (self.origin, d)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use lamina_core::{PixelFilter, ToneMap};

    /// A `w x h` film, 1 spp, box filter.
    fn box_film(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            spp: 1,
            filter: PixelFilter::Box,
            exposure: 0.0,
            tonemap: ToneMap::Clamp,
            spectral: lamina_core::SpectralMode::Rgb,
        }
    }

    /// A pinhole camera (no aperture) at `position` looking at `look_at`, `y` up.
    fn pinhole(position: Vec3, look_at: Vec3, fov_deg: f32) -> Camera {
        Camera {
            position,
            look_at,
            up: Vec3::Y,
            fov_deg,
            aperture_radius: 0.0,
            focus_distance: 1.0,
        }
    }

    #[test]
    fn centre_ray_looks_at_target_and_corners_match_fov() {
        let cam = pinhole(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), 90.0);
        let film = box_film(200, 100);
        let m = CameraModel::new(&cam, &film).unwrap();
        let (_, d) = m.generate_ray(Vec2::new(100.0, 50.0), Vec2::ZERO);
        assert!((d - Vec3::NEG_Z).length() < 1e-6);
        // Right edge at 45 degrees, top edge at atan(0.5).
        let (_, d) = m.generate_ray(Vec2::new(200.0, 50.0), Vec2::ZERO);
        assert!((d - Vec3::new(1.0, 0.0, -1.0).normalize()).length() < 1e-6);
        let (_, d) = m.generate_ray(Vec2::new(100.0, 0.0), Vec2::ZERO);
        assert!((d - Vec3::new(0.0, 0.5, -1.0).normalize()).length() < 1e-6);
        let mut bad = cam;
        bad.look_at = bad.position;
        assert!(CameraModel::new(&bad, &film).is_err());
    }

    #[test]
    fn pinhole_lanes_are_generate_ray() {
        let cam = pinhole(Vec3::new(0.35, 1.5, 3.7), Vec3::new(0.0, 0.95, 0.0), 50.0);
        let film = box_film(640, 360);
        let m = CameraModel::new(&cam, &film).unwrap();
        assert!(!m.uses_lens());
        let fx: [f32; 8] = std::array::from_fn(|k| k as f32 * 83.7 + 0.25);
        let fy: [f32; 8] = std::array::from_fn(|k| 359.9 - k as f32 * 51.3);
        let mut d = [[0.0f32; 8]; 3];
        let o = m.pinhole_lanes(&fx, &fy, &mut d);
        for k in 0..8 {
            let (ro, rd) = m.generate_ray(Vec2::new(fx[k], fy[k]), Vec2::ZERO);
            assert_eq!(o, ro);
            let lane = Vec3::new(d[0][k], d[1][k], d[2][k]);
            assert_eq!(
                lane.to_array().map(f32::to_bits),
                rd.to_array().map(f32::to_bits)
            );
        }
    }
}
