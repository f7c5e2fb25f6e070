//! Plants as instances: one curved leaf mesh per leaf variant, placed once per leaf by a
//! transform, instead of one flat card (two triangles) per leaf in world space.
//!
//! A leaf prototype lives on the *unit card*: `x ∈ [-½, ½]` across the blade (texture `u`),
//! `y ∈ [-½, ½]` from base to tip (texture `v`), `z` out of the adaxial side, bent along
//! the midrib (base and tip droop toward `-z`) and cupped across it (edges rise toward
//! `+z`), [`LEAF_COLUMNS`] x [`LEAF_ROWS`] quads. Each leaf's instance transform maps `x` to
//! `right · width`, `y` to `up · height` and `z` to `normal · height` (with `right = up ×
//! normal`, as in [`lamina_core::cards::append_cards`]), centred on the card: a
//! right-handed, non-mirroring transform, so the counter-clockwise (adaxial) face stays on
//! the card normal's side and `dP/du` runs along `right`. Flat cards and curved instances
//! therefore show the same leaf from the same side, with the same texture orientation.

use crate::Plant;
use glam::{Affine3A, Vec2, Vec3};
use lamina_core::cards::LeafCard;
use lamina_core::scene::{Instance, Material, Mesh, Prototype};

/// Quads across a curved leaf (along texture `u`).
pub const LEAF_COLUMNS: u32 = 4;
/// Quads along a curved leaf, base to tip (along texture `v`).
pub const LEAF_ROWS: u32 = 8;

/// How much a curved leaf bends, in units of the leaf's height (length base to tip).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafBend {
    /// Droop of base and tip below the centre along the midrib (fraction of the height):
    /// the midrib is the parabola `z = -4·midrib·y²` on the unit card.
    pub midrib: f32,
    /// Rise of the blade's edges above the midrib (fraction of the height): `z = 4·cup·x²`.
    pub cup: f32,
}

impl Default for LeafBend {
    /// A gently arched, slightly cupped leaf: tip and base 12 % of the length below the
    /// centre, edges 5 % above the midrib.
    fn default() -> Self {
        LeafBend {
            midrib: 0.12,
            cup: 0.05,
        }
    }
}

/// The curved unit-card leaf mesh of material `material` (see the module docs):
/// `(LEAF_COLUMNS + 1) x (LEAF_ROWS + 1)` vertices with `uv` over the card, two
/// counter-clockwise triangles per quad seen from `+z` (the adaxial side).
pub fn curved_leaf_mesh(bend: LeafBend, material: u32) -> Mesh {
    let (nc, nr) = (LEAF_COLUMNS, LEAF_ROWS);
    let mut mesh = Mesh {
        material,
        ..Default::default()
    };
    for j in 0..=nr {
        for i in 0..=nc {
            let uv = Vec2::new(i as f32 / nc as f32, j as f32 / nr as f32);
            let (x, y) = (uv.x - 0.5, uv.y - 0.5);
            let z = -4.0 * bend.midrib * y * y + 4.0 * bend.cup * x * x;
            mesh.positions.push(Vec3::new(x, y, z));
            mesh.uvs.push(uv);
        }
    }
    let at = |i: u32, j: u32| j * (nc + 1) + i;
    for j in 0..nr {
        for i in 0..nc {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            mesh.indices.push([a, b, c]);
            mesh.indices.push([a, c, d]);
        }
    }
    mesh
}

/// The object-to-world transform that places the unit-card leaf on `card` (see the module
/// docs): `x → right·width`, `y → up·height`, `z → normal·height`, origin → centre.
pub fn leaf_transform(card: &LeafCard) -> Affine3A {
    let right = card.up.cross(card.normal);
    Affine3A::from_cols(
        (right * card.width).into(),
        (card.up * card.height).into(),
        (card.normal * card.height).into(),
        card.center.into(),
    )
}

/// A plant as scene parts with instanced leaves.
#[derive(Clone, Debug)]
pub struct InstancedPlant {
    /// World-space meshes: the branches (if any).
    pub meshes: Vec<Mesh>,
    /// Materials: the bark, then one leaf material per variant (as
    /// [`Plant::into_scene_parts`]).
    pub materials: Vec<Material>,
    /// One curved leaf prototype per leaf variant (variant `i` is prototype
    /// `first_prototype + i`).
    pub prototypes: Vec<Prototype>,
    /// One instance per leaf.
    pub instances: Vec<Instance>,
}

impl Plant {
    /// The plant with instanced, curved leaves, ready to append to a scene that already
    /// holds `first_material` materials and `first_prototype` prototypes. Materials are
    /// numbered as in [`Plant::into_scene_parts`]: `first_material` the bark,
    /// `first_material + 1 + i` leaf variant `i`.
    pub fn into_instanced_parts(
        self,
        first_material: u32,
        first_prototype: u32,
        bend: LeafBend,
    ) -> InstancedPlant {
        let mut materials = vec![self.bark_material()];
        let mut branches = self.branches;
        branches.material = first_material;
        let mut meshes = Vec::new();
        if !branches.indices.is_empty() {
            meshes.push(branches);
        }
        let mut prototypes = Vec::with_capacity(self.leaves.len());
        let mut instances = Vec::with_capacity(self.leaves.iter().map(Vec::len).sum());
        for (i, (cards, leaf)) in self.leaves.iter().zip(&self.leaf_materials).enumerate() {
            let material = first_material + 1 + i as u32;
            materials.push(Material::Leaf {
                name: format!("leaf_{}_{i}", self.params.species),
                leaf: leaf.clone(),
            });
            let prototype = first_prototype + prototypes.len() as u32;
            prototypes.push(Prototype {
                name: format!("leaf_{}_{i}", self.params.species),
                meshes: vec![curved_leaf_mesh(bend, material)],
            });
            instances.extend(cards.iter().map(|c| Instance {
                prototype,
                transform: leaf_transform(c),
            }));
        }
        InstancedPlant {
            meshes,
            materials,
            prototypes,
            instances,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lamina_core::cards::{CardRow, append_cards};

    /// A flat leaf placed by its instance transform is exactly the card of
    /// `append_cards`: same corners, same uv, same adaxial (counter-clockwise) side.
    #[test]
    fn flat_instance_matches_card() {
        let card = LeafCard::new(&CardRow {
            center: [1.0, 2.0, 3.0],
            normal: [0.3, 1.0, -0.2],
            up: [1.0, 0.1, 0.4],
            width: 0.04,
            height: 0.09,
        })
        .unwrap();
        let mut flat = Mesh::default();
        append_cards(&mut flat, &[card]);
        let m = leaf_transform(&card);
        let leaf = curved_leaf_mesh(
            LeafBend {
                midrib: 0.0,
                cup: 0.0,
            },
            0,
        );
        let corner = |u: f32, v: f32| {
            let k = leaf.uvs.iter().position(|&w| w == Vec2::new(u, v)).unwrap();
            m.transform_point3(leaf.positions[k])
        };
        for (k, uv) in flat.uvs.iter().enumerate() {
            let p = corner(uv.x, uv.y);
            assert!((p - flat.positions[k]).length() < 1e-6, "{p} {k}");
        }
        for tri in &leaf.indices {
            let [a, b, c] = tri.map(|i| m.transform_point3(leaf.positions[i as usize]));
            let n = (b - a).cross(c - a);
            assert!(n.normalize().dot(card.normal) > 0.999);
        }
        assert!(m.matrix3.determinant() > 0.0);
    }

    /// A plant with flat (unbent) instanced leaves renders like the same plant with flat
    /// cards: same leaves, same sides, same texture orientation, through the renderer's
    /// two-level BVH. Only rounding separates them (the same random numbers per pixel).
    #[test]
    fn flat_instanced_plant_renders_like_cards() {
        use lamina_core::scene::*;
        let mut params = crate::PlantParams::bush(5);
        params.leaf_count = Some(300);
        params.leaf_resolution = 64;
        let plant = crate::generate_plant(&params).unwrap();
        let [lo, hi] = plant.stats.bounds;
        let c = 0.5 * (lo + hi);
        let scene = |meshes, materials, prototypes, instances| Scene {
            radiometry: Default::default(),
            camera: Camera {
                position: c + Vec3::new(0.3, 0.4, 1.0) * (hi - lo).length(),
                look_at: c,
                up: Vec3::Y,
                fov_deg: 40.0,
                aperture_radius: 0.0,
                focus_distance: 1.0,
            },
            film: Film {
                width: 48,
                height: 48,
                spp: 4,
                filter: PixelFilter::Box,
                exposure: 0.0,
                tonemap: ToneMap::Clamp,
                spectral: lamina_core::SpectralMode::Rgb,
            },
            integrator: Integrator::Path {
                max_depth: 3,
                rr_depth: 3,
                light_sampling: Default::default(),
                sky_sampling: Default::default(),
            },
            lights: vec![Light::Sun {
                direction: Vec3::new(0.5, 0.8, 0.6).normalize(),
                irradiance: Vec3::splat(3.0),
                angular_diameter_deg: 0.0,
            }],
            sky: Some(Sky::Constant(Vec3::new(0.2, 0.3, 0.4))),
            materials,
            meshes,
            prototypes,
            instances,
        };
        let (meshes, materials) = plant.clone().into_scene_parts(0);
        let flat = scene(meshes, materials, Vec::new(), Vec::new());
        let parts = plant.into_instanced_parts(
            0,
            0,
            LeafBend {
                midrib: 0.0,
                cup: 0.0,
            },
        );
        let inst = scene(
            parts.meshes,
            parts.materials,
            parts.prototypes,
            parts.instances,
        );
        let opts = lamina_render::RenderOptions {
            threads: Some(2),
            seed: 3,
            ..Default::default()
        };
        let a = lamina_render::render(&flat, &opts).unwrap().image;
        let b = lamina_render::render(&inst, &opts).unwrap().image;
        let (ma, mb) = (a.mean(), b.mean());
        assert!(ma.min_element() > 0.0);
        assert!(
            (ma - mb).abs().max_element() < 0.01 * ma.max_element(),
            "{ma} vs {mb}"
        );
        let peak = a.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max);
        let off = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(p, q)| (**p - **q).abs().max_element() > 1e-3 * peak)
            .count();
        assert!(
            off * 20 < a.pixels.len(),
            "{off} of {} pixels differ",
            a.pixels.len()
        );
    }

    #[test]
    fn curved_leaf_bends_as_documented() {
        let bend = LeafBend::default();
        let leaf = curved_leaf_mesh(bend, 3);
        assert_eq!(leaf.material, 3);
        assert_eq!(leaf.indices.len(), (2 * LEAF_COLUMNS * LEAF_ROWS) as usize);
        let at = |u: f32, v: f32| {
            let k = leaf.uvs.iter().position(|&w| w == Vec2::new(u, v)).unwrap();
            leaf.positions[k]
        };
        assert!((at(0.5, 1.0).z + bend.midrib).abs() < 1e-6, "tip droops");
        assert!((at(0.5, 0.5).z).abs() < 1e-6, "centre on the card");
        assert!((at(0.0, 0.5).z - bend.cup).abs() < 1e-6, "edges rise");
        // Every triangle faces +z (adaxial) and has dP/du along +x.
        for tri in &leaf.indices {
            let [a, b, c] = tri.map(|i| leaf.positions[i as usize]);
            assert!((b - a).cross(c - a).z > 0.0);
        }
    }
}
