//! The errors of part files, merges and farms; each names the file, flag or part.
//!
//! Each message is whole: a cause is written into it and not also exposed as the error's
//! `source()`, so a chain printed with `{:#}` says it once.

use std::path::PathBuf;

/// What went wrong; every variant names the file or the flag concerned.
#[derive(Debug, thiserror::Error)]
pub enum FarmError {
    /// A part file could not be read.
    #[error("cannot read part '{path}': {cause}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
    },
    /// A file is not a valid part (not an EXR, no or bad `lamina.part` header, channels
    /// that do not match it).
    #[error("'{path}' is not a usable render part: {why}")]
    BadPart {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// A part could not be encoded (nothing was written).
    #[error("cannot encode part '{path}': {why}")]
    Encode {
        /// The file asked for.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// An output could not be written (the old file, if any, is untouched).
    #[error("{cause}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The write error (it names the file and the step that failed).
        cause: lamina_io::WriteError,
    },
    /// Parts that do not belong together, or overlap.
    #[error("{0}")]
    Mismatch(String),
    /// Parts are missing (and `--allow-missing` was not given).
    #[error("{0}")]
    Missing(String),
    /// A farm folder or its plan is wrong, or a Slurm command failed.
    #[error("{0}")]
    Farm(String),
}
