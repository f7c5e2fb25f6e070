//! The reference backend: no BVH, no levels, no merged cards. At build every triangle of
//! the scene (world meshes, then every instance's prototype moved to world space) and every
//! quad light becomes one world-space record in double precision; a query tests the ray
//! against all of them (Möller-Trumbore in `f64`) and every sphere light, and applies the
//! alpha test with the materials' own lookups ([`AlphaMask::opaque`],
//! [`LeafMaterial::opaque`]), not the cell table of [`crate::accel`]. Slow and obviously
//! right: what the suite holds every other backend to.

use super::{Backend, SuiteHit, Surface};
use crate::accel::Ray;
use crate::error::RenderError;
use glam::{Affine3A, DVec3, Vec2, Vec3};
use lamina_core::{Light, Material, Mesh, Scene};

/// One world-space primitive: a triangle `v0, v1, v2` or, for a quad light, the
/// parallelogram `v0 + b1·(v1 - v0) + b2·(v2 - v0)`, `b1, b2 ∈ [0, 1]`.
struct RefPrim {
    v: [DVec3; 3],
    quad: bool,
    /// Texture coordinates at `v` (zero for a mesh without them).
    uv: [Vec2; 3],
    /// Unit geometric normal on the adaxial side (the winding's side; for a mirroring
    /// instance, the side of the transformed normal).
    normal: Vec3,
    what: Surface,
    /// The material whose alpha test applies; `None` for lights.
    material: Option<u32>,
}

/// The brute-force backend (see the module docs).
pub(crate) struct BruteForce {
    prims: Vec<RefPrim>,
    /// Centre, radius and light index of every sphere light.
    spheres: Vec<(DVec3, f64, u32)>,
    materials: Vec<Material>,
}

/// `p` through `m`, in `f64`.
fn transform(m: &Affine3A, p: Vec3) -> DVec3 {
    let [x, y, z] = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis]
        .map(|c| DVec3::new(c.x as f64, c.y as f64, c.z as f64));
    x * p.x as f64 + y * p.y as f64 + z * p.z as f64 + Vec3::from(m.translation).as_dvec3()
}

fn invalid(msg: String) -> RenderError {
    RenderError::InvalidScene(msg)
}

impl BruteForce {
    /// Adds the triangles of `mesh` placed by `m` (`None`: world space), after checking its
    /// indices. Triangles with a non-finite vertex or zero area (in the mesh's own space,
    /// as stored) are left out, as every backend must.
    fn push_mesh(
        &mut self,
        mesh: &Mesh,
        m: Option<(u32, &Affine3A)>,
        what: &str,
    ) -> Result<(), RenderError> {
        if mesh.material as usize >= self.materials.len() {
            return Err(invalid(format!(
                "{what}: material {} out of range",
                mesh.material
            )));
        }
        let n = mesh.positions.len();
        let has_uv = !mesh.uvs.is_empty();
        let has_normals = !mesh.normals.is_empty();
        for (ti, idx) in mesh.indices.iter().enumerate() {
            let i = idx.map(|i| i as usize);
            if i.iter().any(|&i| {
                i >= n
                    || (has_uv && i >= mesh.uvs.len())
                    || (has_normals && i >= mesh.normals.len())
            }) {
                return Err(invalid(format!(
                    "{what}, triangle {ti}: index out of range"
                )));
            }
            let p = i.map(|i| mesh.positions[i]);
            let degenerate = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero() == Vec3::ZERO;
            if !p.iter().all(|p| p.is_finite()) || degenerate {
                continue;
            }
            let (v, instance, mirror) = match m {
                None => (p.map(|p| p.as_dvec3()), None, false),
                Some((inst, m)) => (
                    p.map(|p| transform(m, p)),
                    Some(inst),
                    m.matrix3.determinant() < 0.0,
                ),
            };
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            self.prims.push(RefPrim {
                v,
                quad: false,
                uv: i.map(|i| if has_uv { mesh.uvs[i] } else { Vec2::ZERO }),
                normal: if mirror { -n } else { n }.as_vec3(),
                what: Surface::Mesh {
                    instance,
                    material: mesh.material,
                },
                material: Some(mesh.material),
            });
        }
        Ok(())
    }

    /// All opaque hits along `ray` with `t ∈ (0, tmax)`, in no particular order, leaving
    /// out primitive `skip`.
    pub(super) fn all_hits(&self, ray: &Ray, skip: Option<usize>) -> Vec<SuiteHit<usize>> {
        let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let tmax = ray.tmax as f64;
        let mut hits = Vec::new();
        for (i, p) in self.prims.iter().enumerate() {
            if Some(i) == skip {
                continue;
            }
            let Some((t, b1, b2)) = intersect(p, o, d, tmax) else {
                continue;
            };
            let (b1f, b2f) = (b1 as f32, b2 as f32);
            let uv = p.uv[0] * (1.0 - b1f - b2f) + p.uv[1] * b1f + p.uv[2] * b2f;
            if let Some(mat) = p.material
                && !self.opaque(mat, uv)
            {
                continue;
            }
            let point = p.v[0] + (p.v[1] - p.v[0]) * b1 + (p.v[2] - p.v[0]) * b2;
            hits.push(SuiteHit {
                t: t as f32,
                prim: i,
                what: p.what,
                uv,
                point: point.as_vec3(),
                normal: p.normal,
            });
        }
        for &(c, r, light) in &self.spheres {
            if let Some(t) = intersect_sphere(c, r, o, d, tmax) {
                hits.push(SuiteHit::sphere(t as f32, usize::MAX, light));
            }
        }
        hits
    }

    fn opaque(&self, material: u32, uv: Vec2) -> bool {
        match &self.materials[material as usize] {
            Material::Leaf { leaf, .. } => leaf.opaque(uv),
            m => m.alpha_mask().is_none_or(|a| a.opaque(uv)),
        }
    }
}

/// Möller-Trumbore in `f64`, closed at the edges: `(t, b1, b2)` for `t ∈ (0, tmax)`.
fn intersect(p: &RefPrim, o: DVec3, d: DVec3, tmax: f64) -> Option<(f64, f64, f64)> {
    let (e1, e2) = (p.v[1] - p.v[0], p.v[2] - p.v[0]);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let tv = o - p.v[0];
    let b1 = tv.dot(pv) / det;
    let q = tv.cross(e1);
    let b2 = d.dot(q) / det;
    let t = e2.dot(q) / det;
    let inside = b1 >= 0.0
        && b2 >= 0.0
        && if p.quad {
            b1 <= 1.0 && b2 <= 1.0
        } else {
            b1 + b2 <= 1.0
        };
    (inside && t > 0.0 && t < tmax).then_some((t, b1, b2))
}

/// The nearest `t ∈ (0, tmax)` where the ray meets the sphere.
fn intersect_sphere(c: DVec3, r: f64, o: DVec3, d: DVec3, tmax: f64) -> Option<f64> {
    // |o + t d - c|² = r²: a t² + 2 b t + k = 0.
    let oc = o - c;
    let (a, b, k) = (d.length_squared(), oc.dot(d), oc.length_squared() - r * r);
    let disc = b * b - a * k;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    [(-b - s) / a, (-b + s) / a]
        .into_iter()
        .find(|&t| t > 0.0 && t < tmax)
}

impl Backend for BruteForce {
    const NAME: &'static str = "brute force";
    type Prim = usize;

    fn build(scene: &Scene) -> Result<Self, RenderError> {
        let mut b = BruteForce {
            prims: Vec::new(),
            spheres: Vec::new(),
            materials: scene.materials.clone(),
        };
        for (mi, mesh) in scene.meshes.iter().enumerate() {
            b.push_mesh(mesh, None, &format!("mesh {mi}"))?;
        }
        for (li, light) in scene.lights.iter().enumerate() {
            match *light {
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    ..
                } => {
                    let v = [corner, corner + edge_u, corner + edge_v];
                    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                    if v.iter().all(|p| p.is_finite()) && n != Vec3::ZERO {
                        b.prims.push(RefPrim {
                            v: v.map(Vec3::as_dvec3),
                            quad: true,
                            uv: [Vec2::ZERO, Vec2::X, Vec2::Y],
                            normal: n,
                            what: Surface::QuadLight(li as u32),
                            material: None,
                        });
                    }
                }
                Light::Sphere { center, radius, .. } if center.is_finite() && radius > 0.0 => {
                    b.spheres
                        .push((center.as_dvec3(), radius as f64, li as u32));
                }
                _ => {}
            }
        }
        for (ii, inst) in scene.instances.iter().enumerate() {
            let Some(proto) = scene.prototypes.get(inst.prototype as usize) else {
                return Err(invalid(format!("instance {ii}: prototype out of range")));
            };
            let m = &inst.transform;
            if !(m.matrix3.determinant().abs() > 0.0 && m.is_finite() && m.inverse().is_finite()) {
                return Err(invalid(format!("instance {ii}: transform not invertible")));
            }
            for (mi, mesh) in proto.meshes.iter().enumerate() {
                b.push_mesh(
                    mesh,
                    Some((ii as u32, m)),
                    &format!("instance {ii}, mesh {mi}"),
                )?;
            }
        }
        Ok(b)
    }

    fn closest(&self, ray: &Ray, skip: Option<usize>) -> Option<SuiteHit<usize>> {
        self.all_hits(ray, skip)
            .into_iter()
            .min_by(|a, b| a.t.total_cmp(&b.t))
    }

    fn occluded(&self, ray: &Ray, skip: Option<usize>) -> bool {
        !self.all_hits(ray, skip).is_empty()
    }
}
