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

/// The six faces of a light's cube of shadow maps, `+x -x +y -y +z -z` in that order: the
/// axis each looks along (`forward`) and its `up`; its `right` is `forward x up`.
/// `cube_face` and `cube_axes` in scene.wgsl are the same table.
pub(super) const CUBE_FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::Y),
    (Vec3::NEG_X, Vec3::Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::Z),
    (Vec3::Z, Vec3::Y),
    (Vec3::NEG_Z, Vec3::Y),
];

/// World-to-clip matrix of face `face` of the cube around `center` (a 90° square view
/// along [`CUBE_FACES`]`[face]`, depth 0..1 from `range * 1e-4` to `range`): a point
/// `w` from the centre lands at `x = w.right / w.forward`, `y = w.up / w.forward` in
/// normalised device coordinates (what [`cube_lookup`] computes).
pub(super) fn cube_face_matrix(face: usize, center: Vec3, range: f32) -> Mat4 {
    let (f, u) = CUBE_FACES[face];
    let s = f.cross(u);
    let view = Mat4::from_cols(
        glam::Vec4::new(s.x, u.x, -f.x, 0.0),
        glam::Vec4::new(s.y, u.y, -f.y, 0.0),
        glam::Vec4::new(s.z, u.z, -f.z, 0.0),
        glam::Vec4::new(-s.dot(center), -u.dot(center), f.dot(center), 1.0),
    );
    perspective(std::f32::consts::FRAC_PI_2, 1.0, range * 1e-4, range) * view
}

/// The cube face a direction `w` (from the cube's centre, non-zero) falls on and its
/// normalised device coordinates there (each in -1..1), as scene.wgsl's `cube_face` and
/// `cube_texel` find them (the shader's mirror, for the test against the matrices).
#[cfg(test)]
fn cube_lookup(w: Vec3) -> (usize, f32, f32) {
    let a = w.abs();
    let face = if a.x >= a.y && a.x >= a.z {
        if w.x >= 0.0 { 0 } else { 1 }
    } else if a.y >= a.z {
        if w.y >= 0.0 { 2 } else { 3 }
    } else if w.z >= 0.0 {
        4
    } else {
        5
    };
    let (f, u) = CUBE_FACES[face];
    let z = w.dot(f);
    (face, w.dot(f.cross(u)) / z, w.dot(u) / z)
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

    /// The shader's face lookup (mirrored by `cube_lookup`) lands every direction where the
    /// face's matrix, which the cube's maps are rendered with, puts it: on that face, inside
    /// its square, in front of the light.
    #[test]
    fn cube_lookup_matches_the_face_matrices() {
        let center = Vec3::new(0.3, -1.2, 2.0);
        let range = 7.0;
        let mut seed = 1u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..2000 {
            let w = Vec3::new(rnd(), rnd(), rnd()) * 3.0;
            if w.length() < 1e-3 {
                continue;
            }
            let (face, x, y) = cube_lookup(w);
            assert!(
                x.abs() <= 1.0 + 1e-5 && y.abs() <= 1.0 + 1e-5,
                "{w} {x} {y}"
            );
            let c = cube_face_matrix(face, center, range) * (center + w).extend(1.0);
            let ndc = c.truncate() / c.w;
            assert!(c.w > 0.0, "{w}: behind face {face}");
            assert!(
                (ndc.x - x).abs() < 1e-4 && (ndc.y - y).abs() < 1e-4,
                "{w}: {ndc} vs {x} {y}"
            );
            assert!(ndc.z > 0.0 && ndc.z < 1.0, "{w}: depth {}", ndc.z);
        }
        // Every face of the table is used and its axes are perpendicular.
        for (k, (f, u)) in CUBE_FACES.iter().enumerate() {
            assert_eq!(cube_lookup(*f).0, k);
            assert!(f.dot(*u).abs() < 1e-6);
        }
    }
}
