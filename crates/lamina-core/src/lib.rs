//! The in-memory scene model of lamina: what scene files, importers, built-in scenes and
//! plant generators produce, and what the CPU and GPU renderers consume. Pure data and the
//! small geometric helpers that build it (leaf cards, transforms); no file formats here.
//!
//! Loading lives in `lamina-scene`, which re-exports these modules, so
//! `lamina_scene::Scene` and `lamina_core::Scene` are the same type.
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]

pub mod cards;
pub mod radiometry;
pub mod scene;
pub mod transform;

pub use radiometry::Radiometry;
pub use scene::*;
