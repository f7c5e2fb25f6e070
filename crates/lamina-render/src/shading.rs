//! The local frame BSDFs are evaluated in at a hit, with shading normals (pbrt-v4 style).
//! This module implements the shading-frame invariant of ARCHITECTURE.md (*Invariants*);
//! the details:
//!
//! * **Frame**: `z` = the interpolated vertex normal ([`crate::Accel::shading_normal`])
//!   flipped to the side of the geometric normal, `x` = `dP/du` projected onto the plane
//!   orthogonal to it (Gram–Schmidt; any orthogonal tangent if `dP/du` is parallel to it).
//!   Without a shading normal it is exactly [`PrimInfo::frame`], the geometric frame.
//! * **Sides are geometric**: reflection against transmission, and for leaves adaxial
//!   against abaxial, are what the *geometric* normal says. A direction whose side of the
//!   geometric normal differs from its side of the shading normal is inconsistent
//!   ([`ShadingFrame::consistent`]): light samples there contribute nothing and a BSDF
//!   sample there ends the path, so light never leaks through a surface (a sun below a
//!   ground plane stays dark however its normals are tilted) and the BSDF never sees a
//!   reflection that is geometrically a transmission. If the outgoing direction itself is
//!   inconsistent (grazing views of a silhouette), the hit shades with the geometric frame
//!   instead, so silhouettes get facet shading rather than black seams.
//! * **Cosines**: the BSDF's `f · |cos θi|` uses the *shading* cosine `|wi · n_s|`, and
//!   nothing else multiplies a geometric cosine (pbrt-v4 does the same for camera paths;
//!   the adjoint correction `|wo·n_s||wi·n_g| / (|wo·n_g||wi·n_s|)` matters only for
//!   paths traced from lights, which lamina does not trace). Spawn offsets and the primitive
//!   a ray skips stay geometric.

use crate::accel::{Accel, PrimInfo, PrimRef};
use glam::{Vec2, Vec3};
use lamina_core::NormalMap;
use lamina_leaf::frame::Frame;

/// The shading normal at a hit (world space, unit, either side; `None` = the geometric
/// normal): the mesh's interpolated vertex normal ([`Accel::shading_normal`]), perturbed by
/// the material's tangent-space normal map when there is one. The map's frame is
/// `x = t`, `y = sign · (n × t)`, `z = n` with `n` the vertex normal (or the geometric
/// normal), `t` the vertex tangent or `dP/du` made orthogonal to `n`, and `sign` making
/// `y` point towards increasing `v` (the top of the image, glTF's convention)
/// ([`Accel::uv_tangent`]).
#[inline]
pub fn shading_normal(
    accel: &Accel,
    prim: PrimRef,
    bary: Vec2,
    info: &PrimInfo,
    normal_map: Option<&NormalMap>,
) -> Option<Vec3> {
    let ns = accel.shading_normal(prim, bary);
    let Some(map) = normal_map else {
        return ns;
    };
    let n = ns.unwrap_or(info.n);
    let (t, sign) = accel.uv_tangent(prim, bary);
    // `sign` is relative to the geometric normal; the vertex normal may point the other way.
    let sign = if n.dot(info.n) < 0.0 { -sign } else { sign };
    let t = (t - n * n.dot(t)).normalize_or_zero();
    if t == Vec3::ZERO {
        return ns;
    }
    let b = n.cross(t) * sign;
    let m = map.at(info.uv_at(bary));
    let mapped = (t * m.x + b * m.y + n * m.z).normalize_or_zero();
    if mapped == Vec3::ZERO || !mapped.is_finite() {
        ns
    } else {
        Some(mapped)
    }
}

/// The local frame of one hit and what decides which directions it may scatter to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingFrame {
    /// The frame BSDFs are evaluated in: `n` the shading normal on the geometric side (or
    /// the geometric normal), `s` along `dP/du`.
    pub frame: Frame,
    /// Unit geometric normal (the front, adaxial side).
    pub ng: Vec3,
    /// Whether `frame.n` differs from `ng` (then [`ShadingFrame::consistent`] checks sides).
    smooth: bool,
}

impl ShadingFrame {
    /// The frame of a hit with shading data `info`, shading normal `ns` (unit, world space,
    /// either side; `None` for flat shading) and unit direction `wo` towards the viewer.
    #[inline]
    pub fn new(info: &PrimInfo, ns: Option<Vec3>, wo: Vec3) -> Self {
        let geometric = Self::geometric(info.frame(), info.n);
        let Some(ns) = ns else {
            return geometric;
        };
        let ns = if ns.dot(info.n) < 0.0 { -ns } else { ns };
        // A view that the geometric and the shading normal put on different sides (a
        // silhouette): shade it flat rather than from the wrong side.
        if (wo.dot(info.n) > 0.0) != (wo.dot(ns) > 0.0) {
            return geometric;
        }
        ShadingFrame {
            frame: Frame::from_normal_tangent(ns, info.s),
            ng: info.n,
            smooth: true,
        }
    }

    /// The flat-shaded frame `frame` of a surface with unit geometric normal `ng`.
    #[inline]
    pub(crate) fn geometric(frame: Frame, ng: Vec3) -> Self {
        ShadingFrame {
            frame,
            ng,
            smooth: false,
        }
    }

    /// Whether the frame is a smooth (vertex or mapped) normal's rather than the
    /// geometric one: only then can [`ShadingFrame::consistent`] be false.
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.smooth
    }

    /// Whether the unit world direction `w` lies on the same side of the geometric and the
    /// shading normal (always true for flat shading). Light from, or scattering to, an
    /// inconsistent direction is zero.
    #[inline]
    pub fn consistent(&self, w: Vec3) -> bool {
        !self.smooth || (w.dot(self.ng) > 0.0) == (w.dot(self.frame.n) > 0.0)
    }

    /// World direction to the local (shading) frame.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.frame.to_local(v)
    }

    /// Local (shading) direction to world space.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.frame.to_world(v)
    }

    /// The sampled unit direction `v` (local) in world space, unit: as it comes out of the
    /// (orthonormal) frame when rounding left it within 1e-6 of unit in squared length, as
    /// it always does for a unit `v`, renormalized otherwise. A next ray's direction does
    /// not then wait on a square root and a division (the test is a branch the CPU
    /// predicts).
    #[inline]
    pub fn to_world_unit(&self, v: Vec3) -> Vec3 {
        let w = self.frame.to_world(v);
        if (w.length_squared() - 1.0).abs() <= 1e-6 {
            w
        } else {
            w.normalize()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn info() -> PrimInfo {
        PrimInfo {
            uv: [Vec2::ZERO; 3],
            n: Vec3::Z,
            s: Vec3::X,
            flags: 0,
        }
    }

    /// The shading normal is flipped to the geometric side, `x` stays along `dP/du` as far
    /// as it can, sides are checked against both normals, and a view that the two normals
    /// disagree on shades with the geometric frame.
    #[test]
    fn frame_sides_and_fallbacks() {
        let info = info();
        let tilt = 60f32.to_radians();
        let ns = Vec3::new(tilt.sin(), 0.0, tilt.cos());
        // No shading normal: exactly the geometric frame, every direction consistent.
        let flat = ShadingFrame::new(&info, None, Vec3::Z);
        assert_eq!(flat.frame, info.frame());
        assert!(flat.consistent(-Vec3::Z) && flat.consistent(Vec3::new(1.0, 0.0, -0.1)));
        // Either orientation of the vertex normal gives the same frame, on the +z side.
        for given in [ns, -ns] {
            let f = ShadingFrame::new(&info, Some(given), Vec3::Z);
            assert!((f.frame.n - ns).length() < 1e-6, "{}", f.frame.n);
            assert!(f.frame.s.dot(f.frame.n).abs() < 1e-6 && f.frame.s.x > 0.4);
            assert!((f.frame.t - Vec3::Y).length() < 1e-6);
            assert_eq!(f.ng, Vec3::Z);
            // Above both, below both: consistent. Below the surface but above the tilted
            // normal's plane (a sun under the ground): not.
            assert!(f.consistent(Vec3::Z) && f.consistent(-Vec3::Z));
            assert!(!f.consistent(Vec3::new(0.98, 0.0, -0.17)));
            assert!(!f.consistent(Vec3::new(-0.94, 0.0, 0.34)));
        }
        // A grazing view from the side the normal leans away from: geometric frame.
        let wo = Vec3::new(-0.9, 0.0, 0.3).normalize();
        let f = ShadingFrame::new(&info, Some(ns), wo);
        assert_eq!(f.frame, info.frame());
        assert!(f.consistent(Vec3::new(0.98, 0.0, -0.17)));
    }

    /// `to_world_unit` is `to_world` for unit local directions in a rotated frame (unit
    /// within 1e-6, no renormalization), and renormalizes a direction that is not unit.
    #[test]
    fn to_world_unit_keeps_unit_directions_and_mends_others() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let info = PrimInfo {
            n,
            s: n.any_orthonormal_vector(),
            ..info()
        };
        let frame = ShadingFrame::new(&info, None, n);
        for k in 0..1000 {
            let a = k as f32 * 0.37;
            let z = (k as f32 / 999.0) * 2.0 - 1.0;
            let r = (1.0 - z * z).sqrt();
            let v = Vec3::new(r * a.cos(), r * a.sin(), z);
            let w = frame.to_world_unit(v);
            assert_eq!(w, frame.to_world(v), "{v}");
            assert!((w.length_squared() - 1.0).abs() <= 1e-6);
            let long = frame.to_world_unit(v * 1.01);
            assert!((long.length() - 1.0).abs() < 1e-6 && (long - w).length() < 1e-5);
        }
    }
}
