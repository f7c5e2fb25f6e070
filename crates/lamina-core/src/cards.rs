//! Leaf cards: many leaves sharing one material, each a textured rectangle given by centre,
//! normal (the adaxial side), up (toward the leaf tip), width and height, in metres.
//! Card files (JSON, CSV) are read by `lamina-scene`.

use crate::scene::Mesh;
use crate::transform::Transform;
use glam::{Vec2, Vec3};
use serde::Deserialize;

/// One leaf card as written in a scene or card file: a rectangle with its adaxial side
/// facing `normal`, its tip toward `up`, sizes in metres. Unvalidated; see [`LeafCard::new`].
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CardRow {
    /// Centre of the rectangle (m).
    pub center: [f32; 3],
    /// Normal on the adaxial side (any length > 0).
    pub normal: [f32; 3],
    /// Toward the tip (any length > 0, not parallel to `normal`).
    pub up: [f32; 3],
    /// Width (m).
    pub width: f32,
    /// Height, base to tip (m).
    pub height: f32,
}

/// A validated leaf card in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafCard {
    /// Centre of the rectangle (m).
    pub center: Vec3,
    /// Unit normal on the adaxial (upper) side.
    pub normal: Vec3,
    /// Unit direction toward the tip, perpendicular to `normal`.
    pub up: Vec3,
    /// Width along `up × normal` (m).
    pub width: f32,
    /// Height along `up` (m).
    pub height: f32,
}

impl LeafCard {
    /// Validates a row: finite values, positive sizes, non-degenerate normal and an `up`
    /// not parallel to it (`up` is made perpendicular to `normal`). `Err` says what is wrong.
    pub fn new(row: &CardRow) -> Result<Self, String> {
        let all = row
            .center
            .iter()
            .chain(&row.normal)
            .chain(&row.up)
            .chain([&row.width, &row.height]);
        if all.into_iter().any(|v| !v.is_finite()) {
            return Err("every value must be a finite number".into());
        }
        if !(row.width > 0.0 && row.height > 0.0) {
            return Err(format!(
                "width and height must be > 0, got {} and {}",
                row.width, row.height
            ));
        }
        let n = Vec3::from(row.normal);
        if n.length_squared() < 1e-12 {
            return Err("normal has zero length".into());
        }
        // Huge finite components (1e30) would overflow the squared length: scale them down
        // first (only then, so that ordinary cards stay bit for bit what they were).
        let tame = |v: Vec3| {
            if v.length_squared().is_finite() {
                v
            } else {
                v / v.abs().max_element()
            }
        };
        let n = tame(n).normalize();
        let up = tame(Vec3::from(row.up));
        let up_len2 = up.length_squared();
        let up = up - n * n.dot(up);
        if up.length_squared() < 1e-10 * up_len2.max(1e-30) || up.length_squared() < 1e-20 {
            return Err("up is zero or parallel to normal".into());
        }
        Ok(LeafCard {
            center: Vec3::from(row.center),
            normal: n,
            up: up.normalize(),
            width: row.width,
            height: row.height,
        })
    }

    /// The card transformed (sizes scale with the transform's stretch along each axis).
    pub fn transformed(&self, t: &Transform) -> LeafCard {
        let right = self.up.cross(self.normal);
        let r = t.vector(right * self.width);
        let u = t.vector(self.up * self.height);
        let mut n = t.normal(self.normal);
        if t.flips() {
            n = -n;
        }
        LeafCard {
            center: t.point(self.center),
            normal: n,
            up: u.normalize_or_zero(),
            width: r.length(),
            height: u.length(),
        }
    }
}

/// Appends the two triangles of each card to `mesh`. Texture `u` runs along
/// `right = up × normal`, `v` along `up` (`v = 0` at the base, 1 at the tip), so the local
/// frame (dP/du, dP/dv, normal) is right-handed and the counter-clockwise face is adaxial.
pub fn append_cards(mesh: &mut Mesh, cards: &[LeafCard]) {
    mesh.positions.reserve(cards.len() * 4);
    mesh.uvs.reserve(cards.len() * 4);
    mesh.indices.reserve(cards.len() * 2);
    for c in cards {
        let right = c.up.cross(c.normal) * (0.5 * c.width);
        let up = c.up * (0.5 * c.height);
        let base = mesh.positions.len() as u32;
        mesh.positions.extend([
            c.center - right - up,
            c.center + right - up,
            c.center + right + up,
            c.center - right + up,
        ]);
        mesh.uvs.extend([
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ]);
        mesh.indices
            .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row() -> CardRow {
        CardRow {
            center: [0.0; 3],
            normal: [0.0, 0.0, 1.0],
            up: [0.0, 1.0, 0.0],
            width: 0.05,
            height: 0.1,
        }
    }

    #[test]
    fn card_geometry_frame_is_right_handed() {
        let mut mesh = Mesh::default();
        append_cards(&mut mesh, &[LeafCard::new(&row()).unwrap()]);
        let [a, b, c] = mesh.indices[0].map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize();
        assert!(
            (n - Vec3::Z).length() < 1e-6,
            "counter-clockwise face is the adaxial side"
        );
        // dP/du is +x = up × normal.
        assert!(((mesh.positions[1] - mesh.positions[0]).normalize() - Vec3::X).length() < 1e-6);
        assert!((mesh.positions[2].y - 0.05).abs() < 1e-6);
    }

    #[test]
    fn bad_rows_are_rejected() {
        let mut r = row();
        r.width = 0.0;
        assert!(LeafCard::new(&r).unwrap_err().contains("width"));
        let mut r = row();
        r.up = [0.0, 0.0, 2.0];
        assert!(LeafCard::new(&r).unwrap_err().contains("parallel"));
        let mut r = row();
        r.center[1] = f32::NAN;
        assert!(LeafCard::new(&r).unwrap_err().contains("finite"));
    }
}
