//! Bottom-level structures: the primitives of the world meshes or of one prototype, their
//! shading side tables (vertex normals and tangents) and the BVH over them.

use super::alpha::AlphaTest;
use super::prims::{Tri, parallelogram};
use super::{FLAG_ALPHA, FLAG_QUAD, FLAG_UV_MIRRORED, ID_MASK, PrimInfo};
use crate::error::RenderError;
use glam::{Vec2, Vec3, Vec4};
use lamina_core::Mesh;
use lamina_leaf::frame::Frame;
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh, node::CwBvhNode},
    triangle::Triangle,
};

/// One bottom-level structure: a BVH over primitives stored in its leaf order (see the
/// module docs), for the world-space meshes or for one prototype in its object space.
#[derive(Clone, Debug, Default)]
pub(super) struct Blas {
    /// The BVH over `tris`; `None` for an empty BLAS and for one of at most
    /// [`SMALL_BLAS`] primitives, whose primitives are tested directly.
    pub(super) bvh: Option<CwBvh>,
    pub(super) tris: Vec<Tri>,
    pub(super) prims: Vec<PrimInfo>,
    /// Per primitive (BVH order) an index into `normals`, or [`NO_NORMALS`] for a flat
    /// one. Empty when no primitive of this BLAS has vertex normals: such a BLAS (cards,
    /// normal-less meshes) stores nothing extra.
    pub(super) nidx: Vec<u32>,
    /// Vertex normals at `v0`, `v1`, `v2` of the smooth primitives (BLAS space, as the mesh
    /// gives them).
    pub(super) normals: Vec<[Vec3; 3]>,
    /// Vertex tangents (`w` = handedness, see [`Mesh::tangents`]) parallel to `normals`, or
    /// empty when no smooth primitive of this BLAS came with tangents; an all-zero entry
    /// means "none" (the tangent then comes from the UVs).
    pub(super) tangents: Vec<[Vec4; 3]>,
    /// Bounds of all primitives (in the BLAS's own space).
    pub(super) bounds: Option<Aabb>,
}

/// A BLAS of at most this many primitives (a leaf card: one parallelogram) has no BVH:
/// a ray tests its primitives one after the other, which costs less than setting up a
/// traversal and testing a root node (measured with `LAMINA_INSTANCES=1` in
/// benches/rays.rs).
pub(super) const SMALL_BLAS: usize = 4;

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

/// Collects primitives for a [`Blas`].
#[derive(Default)]
pub(super) struct BlasBuilder {
    pub(super) tris: Vec<Triangle>,
    pub(super) bounds: Vec<Aabb>,
    pub(super) prims: Vec<PrimInfo>,
    /// Per pushed primitive: its index into `normals` or [`NO_NORMALS`]; left empty while
    /// every primitive is flat.
    pub(super) nidx: Vec<u32>,
    pub(super) normals: Vec<[Vec3; 3]>,
    pub(super) tangents: Vec<[Vec4; 3]>,
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
        let mut bb = Aabb::from_points(&[v[0].into(), v[1].into(), v[2].into()]);
        if flags & FLAG_QUAD != 0 {
            bb.extend((v[1] + v[2] - v[0]).into());
        }
        self.bounds.push(bb);
        self.tris.push(Triangle {
            v0: v[0].into(),
            v1: v[1].into(),
            v2: v[2].into(),
        });
        self.prims.push(PrimInfo {
            uv,
            n,
            s: frame.s,
            flags,
        });
        debug_assert!(vn.is_none() || flags & FLAG_QUAD == 0);
        match vn {
            Some(vn) => {
                // The first smooth primitive: every earlier one was flat.
                self.nidx.resize(self.prims.len() - 1, NO_NORMALS);
                self.nidx.push(self.normals.len() as u32);
                self.normals.push(vn);
                if let Some(vt) = vt {
                    self.tangents
                        .resize(self.normals.len() - 1, [Vec4::ZERO; 3]);
                    self.tangents.push(vt);
                } else if !self.tangents.is_empty() {
                    self.tangents.push([Vec4::ZERO; 3]);
                }
            }
            None if !self.nidx.is_empty() => self.nidx.push(NO_NORMALS),
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
            if !matches!(alpha[mat], AlphaTest::None) {
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
        }
        Ok(())
    }

    pub(super) fn finish(self) -> Blas {
        if self.tris.is_empty() {
            return Blas::default();
        }
        let bounds = self.bounds.iter().fold(Aabb::empty(), |a, b| a.union(b));
        if self.tris.len() <= SMALL_BLAS {
            // Tested directly, in the order pushed: no BVH (see `Blas::bvh`).
            let tris = self
                .tris
                .iter()
                .zip(&self.prims)
                .map(|(tr, info)| Tri::new(tr, info))
                .collect();
            return Blas {
                bvh: None,
                tris,
                prims: self.prims,
                nidx: self.nidx,
                normals: self.normals,
                tangents: self.tangents,
                bounds: Some(bounds),
            };
        }
        // Small leaves (2 primitives): with alpha-tested cards every primitive in a leaf
        // costs an intersection plus a matte lookup, so a deeper tree pays off (measured
        // with benches/rays.rs: random rays +15 % per CPU-second).
        let mut bvh = build_cwbvh(
            &self.bounds,
            BvhBuildParams {
                max_prims_per_leaf: 2,
                collapse_traversal_cost: 1.0,
                ..BvhBuildParams::slow_build()
            },
            &mut Default::default(),
        );
        // Lay the triangles out in BVH leaf order so the traversal indexes them directly.
        let order = std::mem::take(&mut bvh.primitive_indices);
        let tris: Vec<Tri> = order
            .iter()
            .map(|&i| Tri::new(&self.tris[i as usize], &self.prims[i as usize]))
            .collect();
        let prims: Vec<PrimInfo> = order.iter().map(|&i| self.prims[i as usize]).collect();
        let nidx: Vec<u32> = if self.nidx.is_empty() {
            Vec::new()
        } else {
            order.iter().map(|&i| self.nidx[i as usize]).collect()
        };
        Blas {
            bvh: Some(bvh),
            tris,
            prims,
            nidx,
            normals: self.normals,
            tangents: self.tangents,
            bounds: Some(bounds),
        }
    }
}

impl Blas {
    pub(super) fn bytes(&self) -> usize {
        self.bvh.as_ref().map_or(0, bvh_bytes)
            + self.tris.len() * std::mem::size_of::<Tri>()
            + self.prims.len() * std::mem::size_of::<PrimInfo>()
            + self.nidx.len() * 4
            + self.normals.len() * std::mem::size_of::<[Vec3; 3]>()
            + self.tangents.len() * std::mem::size_of::<[Vec4; 3]>()
    }
}

/// Heap bytes of a BVH's nodes and index arrays.
pub(super) fn bvh_bytes(bvh: &CwBvh) -> usize {
    bvh.nodes.len() * std::mem::size_of::<CwBvhNode>()
        + bvh.primitive_indices.len() * 4
        + bvh.exact_node_aabbs.as_ref().map_or(0, |a| a.len()) * std::mem::size_of::<Aabb>()
}
