//! Orthonormal frames: world <-> local shading space.

use glam::Vec3;

/// An orthonormal basis. `n` is the local `z` axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Local `x` (tangent).
    pub s: Vec3,
    /// Local `y` (bitangent), `n × s`.
    pub t: Vec3,
    /// Local `z` (normal).
    pub n: Vec3,
}

impl Frame {
    /// A frame around unit normal `n` with an arbitrary but deterministic tangent
    /// (Duff et al. 2017, "Building an orthonormal basis, revisited").
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame around unit normal `n` whose tangent is `tangent` made orthogonal to `n`.
    /// Falls back to [`Frame::from_normal`] when `tangent` is (nearly) parallel to `n`.
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Self {
        let s = tangent - n * n.dot(tangent);
        let len2 = s.length_squared();
        if len2.is_nan() || len2 <= 1e-12 {
            return Self::from_normal(n);
        }
        let s = s / len2.sqrt();
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// World direction to local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local coordinates to a world direction.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_invert() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.n).abs() < 1e-5 && f.t.dot(f.n).abs() < 1e-5);
            let v = Vec3::new(0.2, 0.7, -0.4).normalize();
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }
}
