//! Scene loading for lamina: TOML scene files (one reader per table type, each with its
//! parameter table; the reference is docs/scene-format.md), the files they refer to (OBJ +
//! MTL, glTF, leaf-card and placement files, leaf folders, plant parameters) and the
//! built-in scenes, into the in-memory [`Scene`] of lamina-core. Every error names the
//! file, line and key. The module map and the invariants are in ARCHITECTURE.md.

#![forbid(unsafe_code)]

pub mod builtin;
pub mod cards;
mod dict;
pub mod error;
mod gltf_accessor;
pub mod gltf_import;
mod gltf_material;
pub mod instances;
mod light;
pub mod limits;
mod loader;
#[cfg(test)]
mod loader_tests;
mod material;
mod mtl;
pub mod obj;
mod object;
pub mod overrides;
#[cfg(test)]
mod reference;
mod sensor;
mod table;

pub use error::SceneError;
pub use lamina_core::{radiometry, scene, transform};
pub use loader::{
    SpectralOutput, load_scene, load_scene_with_output, parse_scene, parse_scene_with_output,
    reload_settings,
};
pub use object::apply_transform;
pub use overrides::{Override, load_scene_with_overrides};
pub use scene::*;
