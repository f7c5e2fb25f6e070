//! Leaf maps for lamina: the seven maps of the leaf model (Franzke & Deussen, Sec. 4 and
//! Fig. 3) from real captures or procedurally, written as a *leaf folder* that a scene's
//! leaf material points at.
//!
//! * [`generate()`]: a procedural leaf from a [`Species`] preset (or a custom [`Preset`]) and
//!   a seed: outline, venation, mesophyll texture, paler back, translucency with dark veins,
//!   extinction, thickness, bump and alpha.
//! * [`prepare()`]: the seven maps from photographs: a front photo and optionally a back
//!   photo, a through-light scan, a matte and a normal or bump map; what is missing is
//!   derived (and `leaf.toml` says so).
//! * [`sheet()`]: a contact sheet of a leaf folder's maps with two small renders (lit from
//!   the front and from behind).
//!
//! # A leaf folder
//! `front.png`, `back.png`, `translucency.png` (sRGB, 8-bit RGB), `alpha.png`,
//! `thickness.png`, `extinction.png`, `bump.png` (linear, 16-bit grey) and `leaf.toml`, a
//! serialised [`lamina_leaf::LeafDescription`] with paths relative to the folder, whose
//! leading comments say where each map came from. Folders are written atomically: into a
//! temporary sibling folder that is renamed into place, so a failure never leaves a
//! half-written folder.
//!
//! # Conventions
//! Images: row 0 is the top of the card (the leaf tip); `u` to the right, `v` up, as in
//! [`lamina_leaf::Texture`]. The adaxial (upper, front) side faces the viewer of the
//! images; the abaxial (back) map is stored in the same texel layout (not mirrored), so the
//! back colour of texel `uv` is the underside of the same point. Bump heights are along the
//! adaxial normal (`+z`).
//!
//! Where this crate sits among the others, and the invariants it keeps: ARCHITECTURE.md.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod folder;
pub mod generate;
pub mod noise;
pub mod plane;
pub mod prepare;
pub mod sheet;
pub mod species;

pub use folder::{
    FolderWrite, GENERATOR, MapPlanes, check_leaf_folder, write_leaf_folder, written_by_lamina,
};
pub use generate::{GeneratedLeaf, LeafSpec, generate};
pub use lamina_io::Replace;
pub use prepare::{PrepareInput, Prepared, prepare};
pub use sheet::{SheetOptions, sheet};
pub use species::{Preset, Species, UnknownSpecies};

use std::path::PathBuf;

/// Phase timer: prints `phase: seconds` to stderr when the environment variable
/// `LAMINA_LEAFMAPS_TIMING` is set (for profiling the speed figures); silent otherwise.
pub(crate) struct PhaseTimer {
    on: bool,
    last: std::time::Instant,
}

impl PhaseTimer {
    pub(crate) fn new() -> Self {
        PhaseTimer {
            on: std::env::var_os("LAMINA_LEAFMAPS_TIMING").is_some(),
            last: std::time::Instant::now(),
        }
    }

    pub(crate) fn lap(&mut self, phase: &str) {
        if self.on {
            eprintln!("  {phase}: {:.3} s", self.last.elapsed().as_secs_f64());
        }
        self.last = std::time::Instant::now();
    }
}

/// Why a leaf folder could not be made or read. Every variant names the file concerned.
#[derive(Debug, thiserror::Error)]
pub enum LeafMapsError {
    /// An input image could not be opened or decoded.
    #[error("cannot read image '{path}': {cause}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the decoder said (part of the message, so not repeated as a source).
        cause: image::ImageError,
    },
    /// An input was read but cannot be used (empty, all black, a matte that keeps nothing...).
    #[error("unusable input '{path}': {reason}")]
    BadInput {
        /// The file.
        path: PathBuf,
        /// Why, in words.
        reason: String,
    },
    /// A file or folder could not be written.
    #[error("cannot write '{path}': {cause}")]
    Write {
        /// The file or folder.
        path: PathBuf,
        /// The I/O error (part of the message).
        cause: std::io::Error,
    },
    /// An image could not be encoded.
    #[error("cannot encode '{path}': {cause}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// What the encoder said (part of the message).
        cause: image::ImageError,
    },
    /// The leaf model rejected the description or a map.
    #[error(transparent)]
    Leaf(#[from] lamina_leaf::LeafError),
    /// `leaf.toml` could not be serialised.
    #[error("cannot serialise leaf.toml: {0}")]
    Toml(#[from] toml::ser::Error),
    /// The output folder may not be written (foreign files, an input in the way) or could
    /// not be put in place.
    #[error(transparent)]
    Folder(#[from] lamina_io::FolderError),
    /// An output image has a type lamina cannot write, or could not be encoded or written.
    #[error(transparent)]
    Output(#[from] lamina_io::ImageOutError),
    /// A bad option value.
    #[error("invalid option {option}: {reason}")]
    Option {
        /// The option (e.g. `resolution`).
        option: &'static str,
        /// Why, in words.
        reason: String,
    },
}
