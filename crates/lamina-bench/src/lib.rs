//! Scale benchmarks for lamina: scenes of whole procedural trees in two representations
//! (flat leaf cards in world space, and instanced curved leaves), and the measurements the
//! `scale` binary reports; ([`frame`]) the tree the GPU path's frame time is measured on;
//! and ([`rays`]) the scenes and rays of the `rays` benchmark (lamina-accel against Embree).
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod frame;
pub mod rays;
pub mod report;

pub use frame::{frame_forest_scene, frame_tree_scene};

use glam::Vec3;
use lamina_core::{Camera, ColorInput, Film, Integrator, Light, Material, Mesh, Scene, Sky};
use lamina_plant::Plant;
use lamina_plant::instanced::LeafBend;
use serde::{Deserialize, Serialize};

/// How the leaves of a tree are put into the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Representation {
    /// One flat card (two triangles, merged into one parallelogram primitive) per leaf, in
    /// world space: the path scene files and `into_scene_parts` take.
    Flat,
    /// One curved leaf mesh (64 triangles) per leaf variant, placed by one instance per leaf.
    Instanced,
    /// Flat cards as instances: one unit-card prototype per leaf variant, one instance per
    /// leaf. The same geometry as [`Representation::Flat`], so the difference measures the
    /// two-level BVH's own cost.
    InstancedCards,
    /// A forest: `copies` instances of one whole tree (its branches and flat leaf cards in
    /// one prototype), on a grid, each turned about `+y`.
    Forest,
    /// The same forest with curved leaves: the branches one prototype placed per tree, every
    /// curved leaf instance composed with every tree's placement (as scene files do for an
    /// instanced plant with `leaves = "curved"`): one record per leaf per tree.
    ForestCurved,
}

impl Representation {
    /// Whether this is one of the forests (several trees).
    pub fn is_forest(self) -> bool {
        matches!(self, Representation::Forest | Representation::ForestCurved)
    }
}

impl std::fmt::Display for Representation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Representation::Flat => "flat",
            Representation::Instanced => "instanced",
            Representation::InstancedCards => "instanced-cards",
            Representation::Forest => "forest",
            Representation::ForestCurved => "forest-curved",
        })
    }
}

/// One measured level: a tree of `leaves` leaves in one representation.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Measurement {
    /// Leaves requested of the generator (per tree).
    pub leaves: u64,
    /// The representation.
    pub representation: Representation,
    /// Trees in the scene (1 except for the forest).
    pub trees: u64,
    /// Triangles in the scene as rendered (instances counted with their prototype's
    /// triangles each time).
    pub triangles: u64,
    /// Triangles stored once: world meshes plus each prototype once.
    pub unique_triangles: u64,
    /// BVH primitives stored (cards merged into parallelograms).
    pub primitives: u64,
    /// Instances in the top-level BVH.
    pub instances: u64,
    /// Seconds to generate the plant (skeleton, branches, leaves, leaf maps).
    pub generate_s: f64,
    /// Seconds to build the BVHs.
    pub bvh_build_s: f64,
    /// Bytes of all BVH nodes and primitive / instance records.
    pub bvh_bytes: u64,
    /// Of `bvh_bytes`: the world-space meshes' BVH and records (branches, ground, flat
    /// cards).
    #[serde(default)]
    pub bvh_world_bytes: u64,
    /// Of `bvh_bytes`: the prototypes' BVHs and records (each once).
    #[serde(default)]
    pub bvh_prototype_bytes: u64,
    /// Of `bvh_bytes`: the instance records and the top-level BVH.
    #[serde(default)]
    pub bvh_instance_bytes: u64,
    /// `bvh_bytes` divided by the number of leaves in the scene.
    pub bvh_bytes_per_leaf: f64,
    /// Bytes of the instance level per instance (record + top-level BVH share); 0 for flat.
    pub bytes_per_instance: f64,
    /// Peak resident memory of the process that measured this level (VmHWM), bytes.
    pub peak_rss_bytes: u64,
    /// Rays traced per second while rendering (BVH build excluded), millions.
    pub mrays_per_s: f64,
    /// Seconds to render the frame (BVH build excluded).
    pub render_s: f64,
    /// Samples per pixel rendered.
    pub spp: u32,
    /// Image width and height (pixels).
    pub resolution: [u32; 2],
    /// Worker threads.
    pub threads: usize,
}

/// The scene of one benchmark level: `plant` in `representation` on a ground quad under
/// Tree `k` of a forest on a `side`-wide square grid `spacing` apart, turned about `+y`.
fn forest_placement(k: u32, side: u32, spacing: f32) -> glam::Affine3A {
    let (i, j) = ((k % side) as f32, (k / side) as f32);
    let offset = Vec3::new((i - 0.5 * (side - 1) as f32) * spacing, 0.0, -j * spacing);
    let turn = glam::Quat::from_rotation_y(k as f32 * 2.399);
    glam::Affine3A::from_rotation_translation(turn, offset)
}

/// a sun and a constant sky, the camera framing the whole tree (or the forest), path
/// tracing with `max_depth` 6.
pub fn tree_scene(
    plant: Plant,
    representation: Representation,
    copies: u32,
    width: u32,
    height: u32,
    spp: u32,
) -> Scene {
    let [lo, hi] = plant.stats.bounds;
    let mut materials = vec![Material::Diffuse {
        name: "ground".into(),
        reflectance: ColorInput::Constant(Vec3::new(0.10, 0.08, 0.05)),
        alpha: None,
    }];
    let mut meshes = Vec::new();
    let mut prototypes = Vec::new();
    let mut instances = Vec::new();
    // Forest: a square grid of trees `spacing` apart.
    let side = (copies.max(1) as f32).sqrt().ceil() as u32;
    let spacing = 1.1 * (hi.x - lo.x).max(hi.z - lo.z);
    match representation {
        Representation::Flat => {
            let (m, mats) = plant.into_scene_parts(1);
            materials.extend(mats);
            meshes.extend(m);
        }
        Representation::Instanced => {
            let parts = plant.into_instanced_parts(1, 0, LeafBend::default());
            materials.extend(parts.materials);
            meshes.extend(parts.meshes);
            prototypes.extend(parts.prototypes);
            instances.extend(parts.instances);
        }
        Representation::InstancedCards => {
            let parts = plant.into_instanced_parts(1, 0, LeafBend::default());
            materials.extend(parts.materials);
            meshes.extend(parts.meshes);
            for mut p in parts.prototypes {
                let material = p.meshes[0].material;
                p.meshes = vec![Mesh::quad(
                    Vec3::new(-0.5, -0.5, 0.0),
                    Vec3::X,
                    Vec3::Y,
                    material,
                )];
                prototypes.push(p);
            }
            instances.extend(parts.instances);
        }
        Representation::ForestCurved => {
            let parts = plant.into_instanced_parts(1, 0, LeafBend::default());
            materials.extend(parts.materials);
            prototypes.extend(parts.prototypes);
            let branches = prototypes.len() as u32;
            prototypes.push(lamina_core::Prototype {
                name: "branches".into(),
                meshes: parts.meshes,
            });
            for k in 0..copies {
                let place = forest_placement(k, side, spacing);
                instances.push(lamina_core::Instance {
                    prototype: branches,
                    transform: place,
                });
                instances.extend(parts.instances.iter().map(|i| lamina_core::Instance {
                    prototype: i.prototype,
                    transform: place * i.transform,
                }));
            }
        }
        Representation::Forest => {
            let (m, mats) = plant.into_scene_parts(1);
            materials.extend(mats);
            prototypes.push(lamina_core::Prototype {
                name: "tree".into(),
                meshes: m,
            });
            for k in 0..copies {
                instances.push(lamina_core::Instance {
                    prototype: 0,
                    transform: forest_placement(k, side, spacing),
                });
            }
        }
    }
    // Frame the tree (or the first row of the forest plus its depth).
    let size = hi - lo;
    let (mut blo, mut bhi) = (lo, hi);
    if representation.is_forest() {
        let half = 0.5 * (side - 1) as f32 * spacing;
        blo = Vec3::new(lo.x - half, lo.y, lo.z - (side - 1) as f32 * spacing);
        bhi = Vec3::new(hi.x + half, hi.y, hi.z);
    }
    let center = 0.5 * (blo + bhi);
    let radius = 0.5 * (bhi - blo).length();
    let fov_deg: f32 = 40.0;
    // Fit the box's height and width (with a 10 % margin) into the view, plus half its depth.
    let tan_h = (0.5 * fov_deg).to_radians().tan();
    let tan_v = tan_h * height as f32 / width as f32;
    let ext = bhi - blo;
    let dist = (0.55 * ext.y / tan_v).max(0.55 * ext.x.max(ext.z) / tan_h) + 0.5 * ext.z.max(ext.x);
    let dir = Vec3::new(0.35, 0.12, 1.0).normalize();
    let ground_half = 30.0 * radius.max(size.y);
    meshes.insert(
        0,
        Mesh::quad(
            Vec3::new(center.x - ground_half, 0.0, center.z + ground_half),
            Vec3::new(2.0 * ground_half, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -2.0 * ground_half),
            0,
        ),
    );
    let eye = center + dir * dist;
    Scene {
        radiometry: Default::default(),
        camera: Camera {
            position: eye,
            look_at: center,
            up: Vec3::Y,
            fov_deg,
            aperture_radius: 0.0,
            focus_distance: dist,
        },
        film: Film::new(width, height, spp),
        integrator: Integrator::Path {
            max_depth: 6,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: Vec3::new(0.5, 0.8, 0.6).normalize(),
            irradiance: Vec3::new(3.2, 3.0, 2.7),
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.16, 0.22, 0.32))),
        materials,
        meshes,
        prototypes,
        instances,
    }
}

/// Triangles of `scene` as rendered (each instance counts its prototype's triangles) and
/// stored once (world meshes plus each prototype once).
pub fn triangle_counts(scene: &Scene) -> (u64, u64) {
    let tris = |ms: &[Mesh]| ms.iter().map(|m| m.indices.len() as u64).sum::<u64>();
    let world = tris(&scene.meshes);
    let per_proto: Vec<u64> = scene.prototypes.iter().map(|p| tris(&p.meshes)).collect();
    let placed: u64 = scene
        .instances
        .iter()
        .map(|i| per_proto.get(i.prototype as usize).copied().unwrap_or(0))
        .sum();
    (world + placed, world + per_proto.iter().sum::<u64>())
}

/// Peak resident set size of this process (VmHWM in `/proc/self/status`), bytes; 0 where
/// it cannot be read (not Linux).
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_counts_count_instances() {
        let mut plant_params = lamina_plant::PlantParams::bush(3);
        plant_params.leaf_count = Some(200);
        plant_params.leaf_resolution = 64;
        let plant = lamina_plant::generate_plant(&plant_params).unwrap();
        let leaves = plant.leaf_count() as u64;
        let branch = plant.branches.indices.len() as u64;
        let variants = plant.leaves.len() as u64;
        let flat = tree_scene(plant.clone(), Representation::Flat, 1, 64, 36, 1);
        assert_eq!(
            triangle_counts(&flat),
            (2 + branch + 2 * leaves, 2 + branch + 2 * leaves)
        );
        let inst = tree_scene(plant, Representation::Instanced, 1, 64, 36, 1);
        assert_eq!(inst.instances.len() as u64, leaves);
        assert_eq!(
            triangle_counts(&inst),
            (2 + branch + 64 * leaves, 2 + branch + 64 * variants)
        );
        assert!(peak_rss_bytes() > 0 || !cfg!(target_os = "linux"));
    }
}
