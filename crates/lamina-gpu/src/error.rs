//! Errors of the GPU path. Every message says what went wrong *and* what to do about it.

use thiserror::Error;

/// What can go wrong on the GPU path. None of these affects the offline renderer
/// (`lamina render` without `--gpu` needs no GPU at all).
#[derive(Debug, Error)]
pub enum GpuError {
    /// No Vulkan adapter was found (no GPU driver and no software rasteriser).
    #[error(
        "no GPU adapter found ({0}); install a Vulkan driver: on Debian/Ubuntu \
         `apt-get install -y mesa-vulkan-drivers` gives the lavapipe software rasteriser, \
         or install your GPU vendor's Vulkan driver. The offline renderer (`lamina render` \
         without --gpu) works without one"
    )]
    NoAdapter(String),
    /// The adapter refused to create a device with the limits the renderer needs.
    #[error("the GPU adapter '{adapter}' could not create a device: {message}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// A WGSL shader failed to parse or validate.
    #[error("shader '{label}' failed to compile: {message}")]
    Shader {
        /// Which shader (its label).
        label: String,
        /// The compiler's diagnostic.
        message: String,
    },
    /// A pipeline or another GPU object failed validation.
    #[error("GPU validation failed while {what}: {message}")]
    Validation {
        /// What the renderer was doing.
        what: String,
        /// wgpu's message.
        message: String,
    },
    /// The scene cannot be drawn (e.g. a mesh refers to a material that does not exist).
    #[error("scene: {0}")]
    Scene(String),
    /// A buffer is larger than the device allows.
    #[error(
        "{what} needs {bytes} bytes, over the device's buffer limit of {limit} bytes; \
         render fewer leaves or split the mesh"
    )]
    BufferTooLarge {
        /// Which buffer.
        what: String,
        /// Its size.
        bytes: u64,
        /// The device limit.
        limit: u64,
    },
    /// Reading the image back from the GPU failed.
    #[error("reading the image back from the GPU failed: {0}")]
    Readback(String),
}
