//! Scene description for lamina: the in-memory [`Scene`], TOML scene files, leaf-card
//! files, OBJ meshes and the built-in scenes.

pub mod builtin;
pub mod cards;
pub mod error;
pub mod file;
mod gltf_accessor;
pub mod gltf_import;
pub mod instances;
mod leaf;
pub mod limits;
pub mod load;
#[cfg(test)]
mod loader_tests;
pub mod obj;
mod plant_object;

pub use error::SceneError;
pub use lamina_core::{scene, transform};
pub use load::{load_scene, parse_scene};
pub use scene::*;
