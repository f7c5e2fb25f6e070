//! The lamina offline renderer.
//!
//! [`render()`] turns a [`lamina_core::Scene`] into an [`Image`] of linear Rec.709 RGB
//! radiance (W m⁻² sr⁻¹); [`write_image`] stores it as EXR (linear float, the ground truth)
//! or PNG (8-bit sRGB after exposure and the scene's tone map).
//!
//! Modules, one concept each (pbrt-v4 style):
//! * [`sampler`]: per-pixel Owen-scrambled, index-shuffled 2D Sobol points (Burley 2020).
//! * [`camera`]: the pinhole / thin-lens camera.
//! * [`accel`]: the scene handed to lamina-accel (wide SIMD BVHs, opacity masks) plus the
//!   shading data of every primitive.
//! * [`lights`]: sun, point, quad, sphere and sky (constant or importance-sampled image).
//! * [`distribution`]: 1D and 2D piecewise-constant distributions.
//! * [`materials`]: scene materials to a [`materials::SurfaceBsdf`] at a hit.
//! * [`shading`]: the shading frame of a hit (interpolated vertex normals, sides decided by
//!   the geometric normal).
//! * [`integrators`]: `path` (unidirectional, NEE + MIS + Russian roulette), `paper`, and
//!   `spectral` (the path integrator over several channel sets at once).
//! * [`bands`]: a scene's materials, lights and sky in three bands or wavelength bins.
//! * [`spectral`]: `[film] spectral = "visible"` and `[film] bands` renders in one pass.
//! * [`film`]: pixel filters (importance-sampled) and the sample accumulator.
//! * [`output`]: EXR / PNG writing with tone maps, atomically (lamina-image's writer).
//! * [`render`](mod@render): tiles, passes, threads, time limit and cancellation.
//! * [`sensors`]: the scene's `[[sensor]]`s: BRF, irradiance, absorbed power, fisheye.
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]
// `!(x > 0.0)` is used on purpose throughout: it is also true for NaN, which must be
// rejected the same way as non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
#![warn(missing_docs)]

pub mod accel;
pub mod bands;
pub mod camera;
pub mod distribution;
pub mod film;
pub mod integrators;
pub mod lights;
pub mod materials;
pub mod output;
pub mod render;
pub mod sampler;
pub mod sensors;
pub mod shading;
pub mod spectral;

mod error;

pub use accel::{Accel, Hit, Ray};
pub use error::RenderError;
pub use output::write_image;
pub use render::{
    Crop, Image, Progress, RenderOptions, RenderOutput, RenderStats, SampleRange, render,
};
pub use spectral::{BandRender, render_bands};

#[cfg(test)]
mod tests;
