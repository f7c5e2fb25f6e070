//! Object transforms: scale, then rotations about x, y and z (degrees), then translation.

use glam::{Mat3, Mat4, Quat, Vec3};

/// An affine transform with its normal matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    /// Points: `m.transform_point3(p)`.
    pub m: Mat4,
    /// Normals: the inverse transpose of the linear part.
    pub normal: Mat3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform {
            m: Mat4::IDENTITY,
            normal: Mat3::IDENTITY,
        }
    }
}

impl Transform {
    /// `translate · Rz · Ry · Rx · scale`, angles in degrees. `scale` must have no zero
    /// component (checked by the loader).
    pub fn from_parts(scale: Vec3, rotate_deg: Vec3, translate: Vec3) -> Self {
        let r = Quat::from_rotation_z(rotate_deg.z.to_radians())
            * Quat::from_rotation_y(rotate_deg.y.to_radians())
            * Quat::from_rotation_x(rotate_deg.x.to_radians());
        Self::from_matrix(Mat4::from_scale_rotation_translation(scale, r, translate))
    }

    /// Any invertible affine matrix.
    pub fn from_matrix(m: Mat4) -> Self {
        let linear = Mat3::from_mat4(m);
        Transform {
            m,
            normal: linear.inverse().transpose(),
        }
    }

    /// Transforms a point.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.m.transform_point3(p)
    }

    /// Transforms a direction (not renormalised).
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.m.transform_vector3(v)
    }

    /// Transforms a unit normal (renormalised).
    #[inline]
    pub fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal * n).normalize_or_zero()
    }

    /// Whether the transform flips orientation (negative determinant): triangle winding
    /// must then be reversed to keep the front face.
    pub fn flips(&self) -> bool {
        Mat3::from_mat4(self.m).determinant() < 0.0
    }

    /// `self` after `inner` (apply `inner` first).
    pub fn then(&self, outer: &Transform) -> Transform {
        Self::from_matrix(outer.m * self.m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_is_scale_rotate_translate() {
        let t = Transform::from_parts(Vec3::splat(2.0), Vec3::new(0.0, 90.0, 0.0), Vec3::X);
        // (1,0,0) scaled to (2,0,0), rotated 90° about y to (0,0,-2), moved by +x.
        let p = t.point(Vec3::X);
        assert!((p - Vec3::new(1.0, 0.0, -2.0)).length() < 1e-5, "{p}");
        assert!(!t.flips());
        assert!(Transform::from_parts(Vec3::new(-1.0, 1.0, 1.0), Vec3::ZERO, Vec3::ZERO).flips());
    }

    #[test]
    fn normals_stay_perpendicular_under_nonuniform_scale() {
        let t = Transform::from_parts(Vec3::new(1.0, 4.0, 1.0), Vec3::ZERO, Vec3::ZERO);
        let tangent = t.vector(Vec3::new(1.0, 1.0, 0.0));
        let n = t.normal(Vec3::new(1.0, -1.0, 0.0).normalize());
        assert!(tangent.dot(n).abs() < 1e-5);
    }
}
