//! One level's primitives: the meshes (and quad lights) of the world or of one prototype
//! turned into lamina-accel's geometry (cards merged into parallelograms, alpha-tested
//! primitives tagged with their material) plus the shading side tables the renderer reads
//! for a final hit (vertices, UVs, frames, vertex normals and tangents).

use super::alpha::AlphaTest;
use super::prims::parallelogram;
use super::{FLAG_ALPHA, FLAG_QUAD, FLAG_UV_MIRRORED, ID_MASK, PrimInfo};
use crate::error::RenderError;
use glam::{Vec2, Vec3, Vec4};
use lamina_accel::{Geometry, Prim, PrimAlpha};
use lamina_core::Mesh;
use lamina_leaf::frame::Frame;

/// One primitive's shading data: its record and `v0`, `e1 = v1 - v0`, `e2 = v2 - v0`
/// (level space).
#[derive(Clone, Copy, Debug)]
pub(super) struct Shade {
    pub(super) info: PrimInfo,
    pub(super) verts: [Vec3; 3],
}

/// The shading side of one level (the world meshes and quad lights, or one prototype):
/// per primitive (lamina-accel's id: the order pushed) its vertices and shading record,
/// and the vertex normals and tangents of smooth triangles. lamina-accel holds the
/// geometry the traversal tests; this is what the renderer reads for a final hit.
#[derive(Clone, Debug, Default)]
pub(super) struct Blas {
    /// Per primitive its shading record and vertices, side by side: a final hit reads
    /// both, and one record is two cache lines where two arrays were three misses.
    pub(super) prims: Vec<Shade>,
    /// Per primitive an index into `normals`, or [`NO_NORMALS`] for a flat one. Empty when
    /// no primitive of this level has vertex normals: such a level (cards, normal-less
    /// meshes) stores nothing extra.
    pub(super) nidx: Vec<u32>,
    /// Vertex normals at `v0`, `v1`, `v2` of the smooth primitives (level space, as the
    /// mesh gives them).
    pub(super) normals: Vec<[Vec3; 3]>,
    /// Vertex tangents (`w` = handedness, see [`Mesh::tangents`]) parallel to `normals`, or
    /// empty when no smooth primitive of this level came with tangents; an all-zero entry
    /// means "none" (the tangent then comes from the UVs).
    pub(super) tangents: Vec<[Vec4; 3]>,
    /// Per mesh pushed, the number of primitives after it: primitive `i` belongs to the
    /// first mesh whose end is above `i` (none for the quad lights pushed after them).
    pub(super) mesh_ends: Vec<u32>,
}

/// "Flat primitive" in `Blas::nidx`.
pub(super) const NO_NORMALS: u32 = u32::MAX;

/// Vertex normals that differ from the geometric normal by less than this (cosine) count as
/// the geometric normal (< 0.08°): the triangle is stored flat, exactly as without normals.
pub(super) const FLAT_NORMAL_COS: f32 = 1.0 - 1e-6;

/// The vertex normals `vn` of the triangle `v` if they make it smooth: `None` when every
/// one points (within [`FLAT_NORMAL_COS`]) along the geometric normal, or all along its
/// opposite (flipped to the geometric side when shading, the same thing). They are kept as
/// given, not renormalised (like pbrt: interpolating, then transforming an instance's
/// normal is the same as interpolating the transformed normals of the flattened mesh);
/// where zero or non-finite ones make the interpolated normal degenerate, the hit falls
/// back to the geometric normal.
pub(super) fn smooth_normals(v: [Vec3; 3], vn: [Vec3; 3]) -> Option<[Vec3; 3]> {
    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
    let unit = vn.map(Vec3::normalize_or_zero);
    let flat = unit.iter().all(|m| m.dot(n) >= FLAT_NORMAL_COS)
        || unit.iter().all(|m| m.dot(n) <= -FLAT_NORMAL_COS);
    (!flat).then_some(vn)
}

/// Collects the primitives of one level: lamina-accel's geometry and the shading side.
#[derive(Default)]
pub(super) struct BlasBuilder {
    pub(super) geometry: Geometry,
    pub(super) blas: Blas,
}

impl BlasBuilder {
    /// Adds a triangle, or with [`FLAG_QUAD`] the parallelogram `v[0] + b1·e1 + b2·e2`;
    /// `uv` at `v`, `vn` the vertex normals of a smooth triangle (from [`smooth_normals`];
    /// never for a parallelogram) and `vt` its vertex tangents, if the mesh has them.
    /// Non-finite or degenerate ones are left out.
    pub(super) fn push(
        &mut self,
        v: [Vec3; 3],
        uv: [Vec2; 3],
        vn: Option<[Vec3; 3]>,
        vt: Option<[Vec4; 3]>,
        mut flags: u32,
    ) {
        if !v.iter().all(|p| p.is_finite()) {
            return;
        }
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let n = e1.cross(e2).normalize_or_zero();
        if n == Vec3::ZERO {
            return;
        }
        let (du1, du2, dv1, dv2) = (
            uv[1].x - uv[0].x,
            uv[2].x - uv[0].x,
            uv[1].y - uv[0].y,
            uv[2].y - uv[0].y,
        );
        let det = du1 * dv2 - du2 * dv1;
        let dpdu = if det.abs() > 1e-20 {
            (e1 * dv2 - e2 * dv1) / det
        } else {
            e1
        };
        let frame = Frame::from_normal_tangent(n, if dpdu.is_finite() { dpdu } else { e1 });
        if det.abs() > 1e-20 {
            let dpdv = (e2 * du1 - e1 * du2) / det;
            if n.cross(frame.s).dot(dpdv) < 0.0 {
                flags |= FLAG_UV_MIRRORED;
            }
        }
        self.geometry.prims.push(Prim {
            v,
            quad: flags & FLAG_QUAD != 0,
            alpha: (flags & FLAG_ALPHA != 0).then_some(PrimAlpha {
                id: flags & ID_MASK,
                uv,
            }),
        });
        let b = &mut self.blas;
        b.prims.push(Shade {
            info: PrimInfo {
                uv,
                n,
                s: frame.s,
                flags,
            },
            verts: [v[0], e1, e2],
        });
        debug_assert!(vn.is_none() || flags & FLAG_QUAD == 0);
        match vn {
            Some(vn) => {
                // The first smooth primitive: every earlier one was flat.
                b.nidx.resize(b.prims.len() - 1, NO_NORMALS);
                b.nidx.push(b.normals.len() as u32);
                b.normals.push(vn);
                if let Some(vt) = vt {
                    b.tangents.resize(b.normals.len() - 1, [Vec4::ZERO; 3]);
                    b.tangents.push(vt);
                } else if !b.tangents.is_empty() {
                    b.tangents.push([Vec4::ZERO; 3]);
                }
            }
            None if !b.nidx.is_empty() => b.nidx.push(NO_NORMALS),
            None => {}
        }
    }

    /// Adds every triangle of `meshes` (cards merged into parallelograms when
    /// `merge_cards`). `what` names the meshes in errors.
    pub(super) fn push_meshes(
        &mut self,
        meshes: &[Mesh],
        alpha: &[AlphaTest],
        merge_cards: bool,
        what: &dyn Fn(usize) -> String,
    ) -> Result<(), RenderError> {
        for (mi, mesh) in meshes.iter().enumerate() {
            let mat = mesh.material as usize;
            if mat >= alpha.len() || mat > ID_MASK as usize {
                return Err(RenderError::InvalidScene(format!(
                    "{} uses material {mat}, but there are {} materials",
                    what(mi),
                    alpha.len()
                )));
            }
            let mut flags = mat as u32;
            if alpha[mat].is_some() {
                flags |= FLAG_ALPHA;
            }
            let has_uv = !mesh.uvs.is_empty();
            let has_normals = !mesh.normals.is_empty();
            let has_tangents = has_normals && mesh.tangents.len() == mesh.positions.len();
            for (ti, idx) in mesh.indices.iter().enumerate() {
                let ok = idx.iter().all(|&i| {
                    (i as usize) < mesh.positions.len()
                        && (!has_uv || (i as usize) < mesh.uvs.len())
                        && (!has_normals || (i as usize) < mesh.normals.len())
                });
                if !ok {
                    return Err(RenderError::InvalidScene(format!(
                        "{}, triangle {ti}: vertex index out of range",
                        what(mi)
                    )));
                }
            }
            let pos = |i: u32| mesh.positions[i as usize];
            let tex = |i: u32| {
                if has_uv {
                    mesh.uvs[i as usize]
                } else {
                    Vec2::ZERO
                }
            };
            // Vertex normals that make a triangle smooth (none for a mesh without normals).
            let smooth = |idx: [u32; 3]| {
                if has_normals {
                    smooth_normals(idx.map(pos), idx.map(|i| mesh.normals[i as usize]))
                } else {
                    None
                }
            };
            let mut ti = 0;
            while ti < mesh.indices.len() {
                let idx = mesh.indices[ti];
                let vn = smooth(idx);
                // A card: this triangle and the next one, both flat, form a planar
                // parallelogram with affine UVs; one parallelogram primitive (which has no
                // vertex normals) replaces the two triangles.
                let card = mesh
                    .indices
                    .get(ti + 1)
                    .filter(|next| merge_cards && vn.is_none() && smooth(**next).is_none())
                    .and_then(|next| parallelogram(idx, *next, &pos, &tex));
                if let Some([o, a, b]) = card {
                    self.push(
                        [pos(o), pos(a), pos(b)],
                        [tex(o), tex(a), tex(b)],
                        None,
                        None,
                        flags | FLAG_QUAD,
                    );
                    ti += 2;
                    continue;
                }
                let vt = has_tangents.then(|| idx.map(|i| mesh.tangents[i as usize]));
                self.push(idx.map(pos), idx.map(tex), vn, vt, flags);
                ti += 1;
            }
            self.blas.mesh_ends.push(self.blas.prims.len() as u32);
        }
        Ok(())
    }
}

impl Blas {
    /// Heap bytes of the shading side.
    pub(super) fn bytes(&self) -> usize {
        self.prims.len() * std::mem::size_of::<Shade>()
            + self.nidx.len() * 4
            + self.normals.len() * std::mem::size_of::<[Vec3; 3]>()
            + self.tangents.len() * std::mem::size_of::<[Vec4; 3]>()
            + self.mesh_ends.len() * 4
    }

    /// The index (in push order) of the mesh primitive `prim` came from, `None` for a
    /// primitive pushed after the meshes (a quad light).
    pub(super) fn mesh_of(&self, prim: u32) -> Option<u32> {
        let i = self.mesh_ends.partition_point(|&end| end <= prim);
        (i < self.mesh_ends.len()).then_some(i as u32)
    }
}
