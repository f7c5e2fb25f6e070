//! The size limits of everything a scene loads. Each is checked before the allocation it
//! bounds, and exceeding one is an error naming the file or key and the limit (see
//! `docs/scene-format.md`, *Limits*). Limits of other crates that apply as well:
//! images ([`lamina_leaf::texture::MAX_IMAGE_SIDE`], [`lamina_leaf::texture::MAX_IMAGE_PIXELS`]),
//! `leaf.toml` ([`lamina_leaf::maps::MAX_DESCRIPTION_BYTES`]), plants
//! ([`lamina_plant::MAX_LEAVES`] per plant, [`lamina_plant::MAX_LEAF_MAP_TEXELS`],
//! [`lamina_plant::MAX_PARAM_FILE_BYTES`]).

/// Largest scene file (bytes): 64 MiB.
pub const MAX_SCENE_FILE_BYTES: u64 = 64 << 20;

/// Largest OBJ, MTL, leaf-card (CSV/JSON) or placements (CSV) file (bytes): 1 GiB.
pub const MAX_TEXT_FILE_BYTES: u64 = 1 << 30;

/// Largest `.gltf` / `.glb` file and external glTF buffer (bytes): 2 GiB.
pub const MAX_GLTF_FILE_BYTES: u64 = 2 << 30;

/// Most elements (vertices, indices) one glTF accessor may have, and most vertices and
/// triangles one glTF file may produce in all (every flattened use of a mesh counted): 2^26.
pub const MAX_GLTF_ELEMENTS: usize = 1 << 26;

/// Most glTF nodes visited in a file's node hierarchy (guards against cycles): 2^24.
pub const MAX_GLTF_NODES: usize = 1 << 24;

/// Most instances in a whole scene, over all objects (placements × the instances each
/// object already has): 2^27, about 9 GB of instance records and top-level BVH.
pub const MAX_INSTANCES: usize = crate::instances::MAX_INSTANCES;

/// Most leaves generated in a whole scene: the cards of all `leaf_cards` objects plus the
/// `leaf_count` of all `plant` objects (instances of them are not counted again): 20
/// million, about 3 GB of leaf-card geometry.
pub const MAX_SCENE_LEAVES: u64 = lamina_plant::MAX_LEAVES as u64;

/// Most texels of procedural leaf maps in a whole scene: the `resolution²` of every
/// `species` leaf material plus `leaf_variants × leaf_resolution²` of every plant: 2^25
/// (about 4 GB of maps).
pub const MAX_SCENE_LEAF_TEXELS: u64 = 1 << 25;

/// Largest `resolution` of a `species` leaf material (pixels, the maps' longer side).
pub const MAX_LEAF_RESOLUTION: i64 = 4096;

/// The scene-wide budgets, as the loader checks them (the constants above; tests use
/// smaller ones).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Budgets {
    pub(crate) instances: usize,
    pub(crate) leaves: u64,
    pub(crate) leaf_texels: u64,
}

impl Default for Budgets {
    fn default() -> Self {
        Budgets {
            instances: MAX_INSTANCES,
            leaves: MAX_SCENE_LEAVES,
            leaf_texels: MAX_SCENE_LEAF_TEXELS,
        }
    }
}
