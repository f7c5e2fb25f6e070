//! Errors of rendering and image output.

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
    /// The work was cancelled (Ctrl-C) before it completed.
    #[error("cancelled")]
    Cancelled,
    /// Writing the image failed (lamina-image's error, message unchanged).
    #[error(transparent)]
    Image(#[from] lamina_image::ImageWriteError),
}
