//! Leaf optics for lamina.
//!
//! The leaf model of Franzke & Deussen as a BSDF: [`LeafMaterial`] holds a leaf's seven maps
//! ([`LeafMaps`]) and physical parameters ([`LeafParams`]); [`LeafMaterial::bsdf`] gives the
//! [`LeafBsdf`] at a texel, which implements [`Bsdf`]. The layer physics lives in
//! [`layers`] (the slab), [`analytic`] (closed-form single scattering), [`march`] (the paper's
//! ray march of the same integral), [`diffusion`] (Kubelka-Munk + adding) and [`specular`]
//! (GGX); [`material`] documents how the maps and the physics combine. See the crate's
//! README for the parameters, the defaults and the pictures.
//!
//! Everything here is pure math on local directions: no rays, no scenes. The renderer
//! (`lamina-render`) and the GPU path call into this crate; it calls into nothing of theirs.
//!
//! # Conventions
//! * **Local frame**: directions are unit vectors in the frame the caller evaluates in: `z`
//!   the surface normal on the leaf's adaxial (upper, front) side, `x` the tangent along
//!   increasing texture `u`, `y = z × x`. The renderer passes its *shading* frame (the
//!   interpolated vertex normal, or the geometric normal where there is none); which side
//!   is adaxial is always decided by the geometric normal. The rule is stated once, in
//!   ARCHITECTURE.md (*Invariants*, the shading frame).
//! * **Directions point away from the surface**: `wo` toward the viewer, `wi` toward the light.
//! * **Colours** are linear Rec.709 / sRGB-primaries RGB, stored in [`glam::Vec3`].
//! * [`Bsdf::eval`] returns the BSDF *times the cosine foreshortening* `f(wo, wi) |cos θi|`,
//!   as Mitsuba 3 does, so that a leaf's bump-mapped normal stays internal to the leaf BSDF:
//!   the integrator never sees it (its own shading normals come in through the frame).
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod albedo;
pub mod analytic;
pub mod bsdf;
pub mod diffusion;
pub mod error;
mod fastexp;
pub mod fit;
pub mod frame;
pub mod guard;
pub mod lambert;
pub mod layers;
pub mod leaf_bsdf;
pub mod maps;
pub mod march;
pub mod material;
pub mod measured;
mod packed;
pub mod params;
pub mod pbr;
pub mod pigment_leaf;
pub mod prospect;
pub mod sampling;
pub mod spectrum;
pub mod specular;
#[doc(hidden)]
pub mod testing;
pub mod texture;

pub use bsdf::{Bsdf, BsdfSample};
pub use error::LeafError;
pub use lambert::{DiffuseTransmission, Lambertian};
pub use leaf_bsdf::LeafBsdf;
pub use maps::{LeafDescription, LeafMapPaths, LeafMaps};
pub use material::{LeafMaterial, TexelBsdf};
pub use params::{LayerParams, LeafMode, LeafParams};
pub use pbr::PbrBsdf;
pub use pigment_leaf::PigmentLeaf;
pub use prospect::{LeafSpectrum, PigmentInputs, Pigments, ProspectModel, prospect};
pub use texture::{Encoding, Texture, TextureChannel, TextureError, Wrap};
