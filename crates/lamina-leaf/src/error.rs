//! Errors of the leaf model: bad parameters and unreadable maps.

use crate::texture::TextureError;
use std::path::PathBuf;

/// Why a leaf description, its parameters or one of its maps was rejected.
#[derive(Debug, thiserror::Error)]
pub enum LeafError {
    /// A parameter is NaN, infinite or outside its allowed range.
    #[error("leaf parameter `{field}` = {value} is invalid: {allowed}")]
    InvalidParam {
        /// Dotted field name as written in a `leaf.toml` (e.g. `mesophyll.fraction`).
        field: &'static str,
        /// The offending value, formatted.
        value: String,
        /// The allowed range or rule, in words.
        allowed: String,
    },
    /// A PROSPECT input (pigment content or structure) is NaN or outside its published range.
    #[error("`{field}` = {value} is invalid: {allowed}")]
    InvalidPigment {
        /// The key or flag as the user wrote it (e.g. `pigments.cab`, `--cab`).
        field: String,
        /// The offending value, formatted.
        value: String,
        /// The allowed range or rule, in words.
        allowed: String,
    },
    /// One of the seven maps could not be loaded.
    #[error("leaf map `{map}` ('{path}') cannot be loaded: {source}")]
    Map {
        /// Which map (`front`, `back`, `translucency`, `alpha`, `thickness`, `extinction`, `bump`).
        map: &'static str,
        /// The file, as resolved against the base directory.
        path: PathBuf,
        /// What went wrong while reading it.
        #[source]
        source: Box<TextureError>,
    },
    /// A `leaf.toml` file could not be read.
    #[error("cannot read leaf description '{path}': {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: Box<std::io::Error>,
    },
    /// A `leaf.toml` file is not a valid description (unknown key, wrong type, ...).
    #[error("leaf description '{path}' is invalid: {source}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What the TOML parser said (names the key).
        #[source]
        source: Box<toml::de::Error>,
    },
    /// Loading panicked inside a dependency (a bug; the input is rejected).
    #[error("cannot load leaf '{path}': {message}")]
    Panicked {
        /// The file or folder being loaded.
        path: PathBuf,
        /// The panic message, in words.
        message: String,
    },
}
