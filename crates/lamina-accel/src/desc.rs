//! The geometry a [`crate::Accel`] is built from: plain primitives, prototypes, instances,
//! sphere lights and opacity masks. No materials, no lights' power: only what a ray can hit.

use crate::mask::OpacityMask;
use glam::{Affine3A, Vec2, Vec3};

/// The alpha test of one primitive: which matte decides where it exists, and the texture
/// coordinates at its three vertices (interpolated at a candidate hit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimAlpha {
    /// The caller's matte id: indexes [`SceneDesc::masks`] and is passed back to the
    /// [`crate::AlphaFilter`] for the cells the mask cannot decide.
    pub id: u32,
    /// Texture coordinates at `v[0]`, `v[1]`, `v[2]` of the [`Prim`].
    pub uv: [Vec2; 3],
}

/// One primitive: the triangle `v[0], v[1], v[2]` or, with `quad`, the parallelogram
/// `v[0] + b1·(v[1] - v[0]) + b2·(v[2] - v[0])`, `b1, b2 ∈ [0, 1]` (a leaf card or a quad
/// light, one test instead of two triangles). Hit from either side. Coordinates in the
/// space of its [`Geometry`] (metres for the world geometry).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prim {
    /// Vertices (for a parallelogram: the origin corner and its two neighbours).
    pub v: [Vec3; 3],
    /// A parallelogram rather than a triangle.
    pub quad: bool,
    /// The alpha test, for a primitive with a matte; `None`: opaque everywhere.
    pub alpha: Option<PrimAlpha>,
}

impl Prim {
    /// An opaque triangle.
    pub fn triangle(v: [Vec3; 3]) -> Self {
        Prim {
            v,
            quad: false,
            alpha: None,
        }
    }

    /// An opaque parallelogram `v0 + b1·e1 + b2·e2`, `b1, b2 ∈ [0, 1]`.
    pub fn parallelogram(v0: Vec3, e1: Vec3, e2: Vec3) -> Self {
        Prim {
            v: [v0, v0 + e1, v0 + e2],
            quad: true,
            alpha: None,
        }
    }

    /// Whether a ray can ever hit it: finite vertices and a non-zero area.
    pub fn is_valid(&self) -> bool {
        self.v.iter().all(|p| p.is_finite())
            && (self.v[1] - self.v[0])
                .cross(self.v[2] - self.v[0])
                .normalize_or_zero()
                != Vec3::ZERO
    }
}

/// A set of primitives in one space: the world geometry or one prototype. A primitive's id
/// in hits ([`crate::Hit::prim`]) and in skips is its index here; invalid primitives
/// ([`Prim::is_valid`] false) keep their index and are never hit.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    /// The primitives, in the caller's order.
    pub prims: Vec<Prim>,
}

/// One placement of a prototype.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Object (prototype) space to world space; finite and invertible. A mirroring one is
    /// fine (primitives are hit from both sides).
    pub object_to_world: Affine3A,
    /// Index into [`SceneDesc::prototypes`].
    pub prototype: u32,
}

/// A sphere (a sphere light), world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre (m).
    pub center: Vec3,
    /// Radius (m), positive.
    pub radius: f32,
}

/// Everything a ray can hit. Rays see the world geometry, every instance's prototype in
/// its placement, and the spheres.
#[derive(Clone, Debug, Default)]
pub struct SceneDesc {
    /// World-space primitives.
    pub world: Geometry,
    /// Prototypes, each in its own object space, stored once however many instances use it.
    pub prototypes: Vec<Geometry>,
    /// Placements of prototypes; an instance's id in hits is its index here.
    pub instances: Vec<Instance>,
    /// Spheres; a sphere's id in hits is its index here.
    pub spheres: Vec<Sphere>,
    /// Per matte id ([`PrimAlpha::id`]), its 3-state opacity mask, or `None` when the matte
    /// has none (every candidate hit then asks the [`crate::AlphaFilter`]). Ids past the
    /// end have none.
    pub masks: Vec<Option<OpacityMask>>,
}
