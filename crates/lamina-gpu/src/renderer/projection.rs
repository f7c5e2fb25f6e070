//! Camera and light-view matrices (right-handed world, wgpu clip space with depth 0..1)
//! and the sphere of directions the sky-visibility maps are rendered from.

use glam::{Mat4, Vec3};
use lamina_scene::Camera;

/// `n` directions spread evenly over the sphere (a Fibonacci lattice, `+y` up), each
/// standing for `4 pi / n` sr of sky.
pub fn sphere_directions(n: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - (2 * i + 1) as f32 / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

/// World-to-clip matrix of the orthographic light camera looking along `-dir` at the
/// bounding sphere `(c, r)`: the sphere fills the map, depth 0..1 over its diameter.
pub(super) fn light_matrix(dir: Vec3, c: Vec3, r: f32) -> Mat4 {
    let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
    orthographic(r, r, 3.0 * r) * look_at(c + dir * (2.0 * r), c, up)
}

/// Right-handed view matrix: camera at `eye` looking at `center`, `-z` forward.
fn look_at(eye: Vec3, center: Vec3, up: Vec3) -> Mat4 {
    let f = (center - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    Mat4::from_cols(
        glam::Vec4::new(s.x, u.x, -f.x, 0.0),
        glam::Vec4::new(s.y, u.y, -f.y, 0.0),
        glam::Vec4::new(s.z, u.z, -f.z, 0.0),
        glam::Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// Right-handed perspective projection to wgpu's clip space (depth 0 at `near`, 1 at `far`).
fn perspective(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let fy = 1.0 / (0.5 * fov_y).tan();
    let r = far / (near - far);
    Mat4::from_cols(
        glam::Vec4::new(fy / aspect, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, fy, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, r, -1.0),
        glam::Vec4::new(0.0, 0.0, r * near, 0.0),
    )
}

/// Right-handed orthographic projection of the box `[-h, h]^2 x [near, far]` (depth 0..1).
fn orthographic(h: f32, near: f32, far: f32) -> Mat4 {
    let r = 1.0 / (near - far);
    Mat4::from_cols(
        glam::Vec4::new(1.0 / h, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, 1.0 / h, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, r, 0.0),
        glam::Vec4::new(0.0, 0.0, near * r, 1.0),
    )
}

/// World-to-clip matrix of a lamina camera for a `width x height` image (the camera's
/// field of view is horizontal; depth 0..1 between `near` and `far`).
pub fn camera_matrix(camera: &Camera, width: u32, height: u32, near: f32, far: f32) -> Mat4 {
    let aspect = width as f32 / height.max(1) as f32;
    let tan_x = (camera.fov_deg.to_radians() * 0.5).tan();
    let fov_y = 2.0 * (tan_x / aspect).atan();
    let view = look_at(camera.position, camera.look_at, camera.up);
    perspective(fov_y, aspect, near, far) * view
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projections_map_near_and_far_to_0_and_1() {
        let p = perspective(1.0, 1.5, 0.1, 10.0);
        let z = |d: f32| {
            let c = p * glam::Vec4::new(0.0, 0.0, -d, 1.0);
            c.z / c.w
        };
        assert!(z(0.1).abs() < 1e-5 && (z(10.0) - 1.0).abs() < 1e-5);
        let o = orthographic(2.0, 1.0, 3.0);
        let c = o * glam::Vec4::new(2.0, -2.0, -3.0, 1.0);
        assert!(
            (c - glam::Vec4::new(1.0, -1.0, 1.0, 1.0))
                .abs()
                .max_element()
                < 1e-6
        );
        // The camera looks down -z at its target, +x to the right.
        let v = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        assert!((v.transform_point3(Vec3::ZERO) - Vec3::new(0.0, 0.0, -5.0)).length() < 1e-6);
        assert!(v.transform_vector3(Vec3::X).x > 0.99);
    }
}
