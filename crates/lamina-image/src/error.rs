//! Errors of image output.

use std::path::PathBuf;

/// Why an image write failed. Every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum ImageWriteError {
    /// The output file's extension names no supported format.
    #[error("cannot write '{path}': unsupported image format (use .exr or .png)")]
    UnsupportedFormat {
        /// The requested output file.
        path: PathBuf,
    },
    /// The image's pixel count does not match its size.
    #[error("cannot write '{path}': image has {len} pixels, expected {width}x{height}")]
    BadImage {
        /// The requested output file.
        path: PathBuf,
        /// Pixels present.
        len: usize,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// Creating, writing or renaming the file failed.
    #[error("cannot write '{path}': {what}: {source}")]
    Io {
        /// The requested output file.
        path: PathBuf,
        /// The step that failed.
        what: &'static str,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The image encoder failed.
    #[error("cannot write '{path}': encoding failed: {source}")]
    Encode {
        /// The requested output file.
        path: PathBuf,
        /// What the encoder said.
        #[source]
        source: image::ImageError,
    },
}
