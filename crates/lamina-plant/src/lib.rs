//! Procedural plants for lamina: a bush (after the paper's Fig. 5) or a broadleaf tree from
//! [`PlantParams`] and a seed.
//!
//! [`generate_plant`] grows a branching skeleton by space colonisation ([`skeleton`]),
//! gives it pipe-model radii, sweeps bark-textured generalized cylinders along it
//! ([`branches`]), places leaf cards along the twigs in a phyllotactic spiral, turned toward
//! the light and drooping ([`leaves`]), and generates the leaf variants' maps with
//! `lamina-leafmaps`. [`Plant::into_scene_parts`] turns the result into meshes and materials
//! for a [`lamina_core::Scene`]; [`write_glb`] exports it as binary glTF 2.0.
//!
//! Units: metres, `+y` up, the plant standing on `y = 0` around the origin.
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod branches;
mod glb;
pub mod instanced;
pub mod leaves;
pub mod params;
mod rng;
pub mod skeleton;

pub use glb::write_glb;
pub use params::{
    CrownShape, MAX_LEAF_MAP_TEXELS, MAX_LEAVES, MAX_PARAM_FILE_BYTES, PlantKind, PlantParams,
    Resolved,
};

/// The shared fault point of the loaders' guards (see [`lamina_leaf::guard::fault_point`]).
pub(crate) use lamina_leaf::guard::fault_point;

use glam::{Vec2, Vec3};
use lamina_core::cards::{LeafCard, append_cards};
use lamina_core::scene::{ColorInput, Material, Mesh};
use lamina_leaf::{LeafMaterial, Texture};
use lamina_leafmaps::{GeneratedLeaf, LeafSpec};
use std::sync::Arc;
use std::time::Instant;

/// Why a plant could not be made or written.
#[derive(Debug, thiserror::Error)]
pub enum PlantError {
    /// A parameter is out of range; names the field and what is allowed.
    #[error("invalid plant parameter '{field}': {reason}")]
    Param {
        /// The field of [`PlantParams`].
        field: &'static str,
        /// What is wrong and the allowed range.
        reason: String,
    },
    /// A parameter file is not valid TOML or has unknown fields.
    #[error("bad plant parameters: {0}")]
    Parse(String),
    /// A parameter file could not be read.
    #[error("cannot read '{path}': {source}")]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A parameter file is bad: names the file, with what was wrong.
    #[error("{}: {source}", path.display())]
    File {
        /// The parameter file.
        path: std::path::PathBuf,
        /// What was wrong with it.
        #[source]
        source: Box<PlantError>,
    },
    /// The leaf model rejected a generated leaf.
    #[error("leaf material: {0}")]
    Leaf(#[from] lamina_leaf::LeafError),
    /// A file could not be written.
    #[error("cannot write '{path}': {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// An image could not be encoded.
    #[error("cannot encode a texture: {0}")]
    Encode(#[from] image::ImageError),
    /// The glTF JSON could not be built.
    #[error("cannot serialise glTF JSON: {0}")]
    Json(#[from] serde_json::Error),
}

/// Counters and timings of a generated plant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlantStats {
    /// Attraction points of the space colonisation.
    pub attraction_points: u32,
    /// Skeleton nodes.
    pub nodes: usize,
    /// Growth step (m).
    pub step_m: f32,
    /// Triangles of the branch mesh.
    pub branch_triangles: usize,
    /// Leaves placed (all variants).
    pub leaves: usize,
    /// Radius of the thickest stem at the ground (m).
    pub trunk_radius_m: f32,
    /// Bounding box of the whole plant (m): min and max corner.
    pub bounds: [Vec3; 2],
    /// Seconds: skeleton growth.
    pub skeleton_s: f64,
    /// Seconds: branch mesh.
    pub mesh_s: f64,
    /// Seconds: leaf placement.
    pub leaves_s: f64,
    /// Seconds: leaf maps and materials (runs alongside the geometry).
    pub leaf_maps_s: f64,
    /// Seconds: the whole call.
    pub total_s: f64,
}

/// A generated plant.
#[derive(Clone, Debug)]
pub struct Plant {
    /// The branches: one world-space mesh with normals and bark UVs; material index 0 (bark).
    pub branches: Mesh,
    /// Leaf cards per variant (`leaves[i]` use `leaf_variants[i]`).
    pub leaves: Vec<Vec<LeafCard>>,
    /// The generated leaves (maps, parameters, card size).
    pub leaf_variants: Vec<GeneratedLeaf>,
    /// The leaf materials built from `leaf_variants`, one per variant.
    pub leaf_materials: Vec<Arc<LeafMaterial>>,
    /// The bark colour map (linear RGB, tiles in `u` and `v`).
    pub bark: Texture,
    /// The parameters used, defaults resolved.
    pub params: Resolved,
    /// Counters and timings.
    pub stats: PlantStats,
}

/// Grows a plant. Deterministic: the same parameters give the same plant. Errors only for
/// invalid parameters (see [`PlantParams::validate`]).
pub fn generate_plant(params: &PlantParams) -> Result<Plant, PlantError> {
    let start = Instant::now();
    let p = params.resolve()?;
    let ((skeleton, skeleton_s), maps) = rayon::join(
        || {
            let t = Instant::now();
            let sk = skeleton::grow(&p);
            (sk, t.elapsed().as_secs_f64())
        },
        || {
            let t = Instant::now();
            let leaves = leaf_variants(&p);
            (leaves, t.elapsed().as_secs_f64())
        },
    );
    let t = Instant::now();
    let (branches, (cards, leaves_s)) = rayon::join(
        || branches::branch_mesh(&skeleton),
        || {
            let sizes: Vec<Vec2> = maps
                .0
                .iter()
                .map(|l| Vec2::new(l.size_m.0, l.size_m.1))
                .collect();
            let t = Instant::now();
            let c = leaves::place_leaves(&p, &skeleton, &sizes);
            (c, t.elapsed().as_secs_f64())
        },
    );
    let mesh_s = t.elapsed().as_secs_f64();
    let (leaf_variants, leaf_maps_s) = maps;
    let leaf_materials = leaf_variants
        .iter()
        .map(|l| LeafMaterial::new(l.maps.clone(), l.params).map(Arc::new))
        .collect::<Result<Vec<_>, _>>()?;
    let bark = branches::bark_texture(256, p.seed);
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for q in &branches.positions {
        lo = lo.min(*q);
        hi = hi.max(*q);
    }
    for c in cards.iter().flatten() {
        let e = Vec3::splat(0.5 * c.width.max(c.height));
        lo = lo.min(c.center - e);
        hi = hi.max(c.center + e);
    }
    let trunk = (0..skeleton.pos.len())
        .filter(|&i| skeleton.parent[i] == skeleton::NONE)
        .map(|i| skeleton.radius[i])
        .fold(0.0f32, f32::max);
    let stats = PlantStats {
        attraction_points: p.attraction_points,
        nodes: skeleton.pos.len(),
        step_m: skeleton.step,
        branch_triangles: branches.indices.len(),
        leaves: cards.iter().map(Vec::len).sum(),
        trunk_radius_m: trunk,
        bounds: [lo, hi],
        skeleton_s,
        mesh_s,
        leaves_s,
        leaf_maps_s,
        total_s: start.elapsed().as_secs_f64(),
    };
    Ok(Plant {
        branches,
        leaves: cards,
        leaf_variants,
        leaf_materials,
        bark,
        params: p,
        stats,
    })
}

/// The leaf variants: the species with seeds derived from the plant's seed.
fn leaf_variants(p: &Resolved) -> Vec<GeneratedLeaf> {
    use rayon::prelude::*;
    (0..p.leaf_variants)
        .into_par_iter()
        .map(|i| {
            let seed = rng::hash3(p.seed, 0x1EAF_5EED, i as u64);
            lamina_leafmaps::generate(&LeafSpec::new(p.species, seed, p.leaf_resolution))
        })
        .collect()
}

impl Plant {
    /// Number of leaf cards over all variants.
    pub fn leaf_count(&self) -> usize {
        self.leaves.iter().map(Vec::len).sum()
    }

    /// The bark material: Lambertian with the bark texture.
    pub fn bark_material(&self) -> Material {
        Material::Diffuse {
            name: "bark".into(),
            reflectance: ColorInput::Texture {
                map: self.bark.clone(),
                factor: Vec3::ONE,
            },
            alpha: None,
        }
    }

    /// Meshes and materials ready to append to a scene whose material list already holds
    /// `first_material` entries: material `first_material` is the bark, material
    /// `first_material + 1 + i` the leaf variant `i`. Meshes: the branches, then one
    /// leaf-card mesh per variant that has leaves.
    pub fn into_scene_parts(self, first_material: u32) -> (Vec<Mesh>, Vec<Material>) {
        let mut materials = vec![self.bark_material()];
        let mut branches = self.branches;
        branches.material = first_material;
        let mut meshes = Vec::new();
        if !branches.indices.is_empty() {
            meshes.push(branches);
        }
        for (i, (cards, leaf)) in self.leaves.iter().zip(&self.leaf_materials).enumerate() {
            materials.push(Material::Leaf {
                name: format!("leaf_{}_{i}", self.params.species),
                leaf: leaf.clone(),
            });
            if cards.is_empty() {
                continue;
            }
            let mut mesh = Mesh {
                material: first_material + 1 + i as u32,
                ..Default::default()
            };
            append_cards(&mut mesh, cards);
            meshes.push(mesh);
        }
        (meshes, materials)
    }
}
