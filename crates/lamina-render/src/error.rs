//! Errors of rendering and image output.

use std::path::PathBuf;

/// Why a render or an image write failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The scene cannot be rendered (a value the loaders should have rejected).
    #[error("invalid scene: {0}")]
    InvalidScene(String),
    /// Invalid render options (e.g. zero samples per pixel).
    #[error("invalid render options: {0}")]
    InvalidOptions(String),
    /// The worker thread pool could not be created.
    #[error("cannot start {threads} render threads: {source}")]
    ThreadPool {
        /// Threads asked for.
        threads: usize,
        /// What rayon said.
        #[source]
        source: rayon::ThreadPoolBuildError,
    },
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

impl From<lamina_image::ImageWriteError> for RenderError {
    fn from(e: lamina_image::ImageWriteError) -> Self {
        use lamina_image::ImageWriteError as W;
        match e {
            W::UnsupportedFormat { path } => RenderError::UnsupportedFormat { path },
            W::BadImage {
                path,
                len,
                width,
                height,
            } => RenderError::BadImage {
                path,
                len,
                width,
                height,
            },
            W::Io { path, what, source } => RenderError::Io { path, what, source },
            W::Encode { path, source } => RenderError::Encode { path, source },
        }
    }
}
