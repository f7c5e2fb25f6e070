//! Scene description for lamina: the in-memory [`Scene`], TOML scene files, leaf-card
//! files, OBJ meshes and the built-in scenes.

pub mod scene;

pub use scene::*;
