//! The scene file's single tables: `[camera]`, `[film]`, `[integrator]`, `[sky]`.

pub(crate) mod camera;
pub(crate) mod domain;
pub(crate) mod film;
pub(crate) mod integrator;
pub(crate) mod sky;
