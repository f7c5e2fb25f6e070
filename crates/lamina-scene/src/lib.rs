//! Scene description for lamina: the in-memory [`Scene`], TOML scene files, leaf-card
//! files, OBJ meshes and the built-in scenes.

pub mod builtin;
pub mod cards;
mod dict;
pub mod error;
mod gltf_accessor;
pub mod gltf_import;
pub mod instances;
mod light;
pub mod limits;
mod loader;
#[cfg(test)]
mod loader_tests;
mod material;
pub mod obj;
mod object;
#[cfg(test)]
mod reference;
mod table;

pub use error::SceneError;
pub use lamina_core::{scene, transform};
pub use loader::{load_scene, parse_scene};
pub use object::apply_transform;
pub use scene::*;
