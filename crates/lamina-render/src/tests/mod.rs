//! End-to-end tests of the renderer on small scenes built in code, one file per concept.
//! Unit tests of a single module sit in that module (`camera`, `sampler`, `film`,
//! `distribution`, `shading`, `lights::sky`, `render`).
//!
//! * [`scenes`]: the shared builders (cards, spheres, films, cameras, options, the small
//!   canopy, instanced / flattened twins). Start here.
//! * [`integrators`]: path and paper against closed forms; the furnace.
//! * [`lights`]: area and point lights against closed-form irradiance; the image sky.
//! * [`alpha`]: alpha mattes seen by camera and shadow rays.
//! * [`instancing`]: instanced scenes render like flattened ones.
//! * [`shading_normals`]: interpolated vertex normals.
//! * [`normal_maps`]: tangent frames and normal-mapped renders.
//! * [`render_loop`]: determinism, time limits, cancellation, option errors.
//! * [`output`]: EXR / PNG files.
//!
//! The acceleration structure's suite is `crate::accel::tests`.

mod alpha;
mod instancing;
mod integrators;
mod lights;
mod normal_maps;
mod output;
mod parts;
mod render_loop;
pub(crate) mod scenes;
mod shading_normals;
mod spectral;
mod wavefront;
