//! The wgpu instance, adapter, device and queue, and the one place shaders are compiled.
//!
//! Headless rendering asks for any Vulkan adapter (a GPU, or Mesa's lavapipe, a CPU
//! rasteriser, on machines without one). Errors are captured with wgpu error scopes and
//! returned as [`GpuError`] instead of wgpu's default panic.

use crate::error::GpuError;
use std::sync::Arc;

/// A device ready to render: what [`crate::Renderer`] needs from wgpu.
#[derive(Clone, Debug)]
pub struct GpuContext {
    /// The wgpu instance (needed to create window surfaces).
    pub instance: wgpu::Instance,
    /// The adapter (physical device or software rasteriser).
    pub adapter: wgpu::Adapter,
    /// The logical device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Largest 2D texture side the renderer may use (the device limit, or a lower override
    /// for tests); larger leaf maps are downscaled with a warning.
    pub max_texture_dim: u32,
}

/// Options for creating a [`GpuContext`].
#[derive(Clone, Debug, Default)]
pub struct ContextOptions {
    /// Cap the texture side below the device limit (tests use this to exercise the
    /// oversized-texture path); `None` keeps the device limit.
    pub max_texture_dim: Option<u32>,
    /// Backends to look for adapters on; `None` is Vulkan (GPUs and lavapipe). Tests pass
    /// `Some(Backends::empty())` to exercise the no-adapter path.
    pub backends: Option<wgpu::Backends>,
}

impl GpuContext {
    /// A context for headless rendering (no window).
    pub fn headless(opts: &ContextOptions) -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = opts.backends.unwrap_or(wgpu::Backends::VULKAN);
        Self::with_instance(wgpu::Instance::new(desc), None, opts)
    }

    /// A context on `instance` whose adapter can present to `surface` (when given).
    pub fn with_instance(
        instance: wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
        opts: &ContextOptions,
    ) -> Result<Self, GpuError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            apply_limit_buckets: false,
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let alimits = adapter.limits();
        // Ask for what the adapter has for the sizes that grow with the scene (1M-leaf
        // plants need vertex buffers of a few hundred MB); the rest stays at the defaults.
        let limits = wgpu::Limits {
            max_texture_dimension_2d: alimits.max_texture_dimension_2d,
            max_buffer_size: alimits.max_buffer_size,
            max_storage_buffer_binding_size: alimits.max_storage_buffer_binding_size,
            ..wgpu::Limits::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("lamina-gpu"),
            // Timestamp queries time the passes (GPU frame time) where the adapter has them.
            // Indirect draws with a first instance draw the culling pass's lists.
            required_features: adapter.features()
                & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::INDIRECT_FIRST_INSTANCE),
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            message: e.to_string(),
        })?;
        // Errors outside an error scope would panic in wgpu's default handler; every call
        // that can fail on bad input runs inside a scope, so what reaches this is a bug.
        device.on_uncaptured_error(Arc::new(|e: wgpu::Error| {
            eprintln!("lamina-gpu: uncaptured GPU error: {e}");
        }));
        let max_texture_dim = opts
            .max_texture_dim
            .unwrap_or(u32::MAX)
            .min(device.limits().max_texture_dimension_2d);
        Ok(GpuContext {
            instance,
            adapter,
            device,
            queue,
            max_texture_dim,
        })
    }

    /// The adapter's name and backend, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan)`.
    pub fn adapter_name(&self) -> String {
        let info = self.adapter.get_info();
        format!("{} ({:?})", info.name, info.backend)
    }

    /// Compiles WGSL `source` inside a validation error scope: a parse or validation error
    /// comes back as [`GpuError::Shader`] naming `label`, never as a panic.
    pub fn compile_wgsl(&self, label: &str, source: &str) -> Result<wgpu::ShaderModule, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        match pollster::block_on(scope.pop()) {
            None => Ok(module),
            Some(e) => Err(GpuError::Shader {
                label: label.to_string(),
                message: e.to_string(),
            }),
        }
    }

    /// Runs `f` (creating pipelines, bind groups, textures) inside a validation error scope
    /// and turns a captured error into [`GpuError::Validation`] naming `what`.
    pub fn validated<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let v = f();
        match pollster::block_on(scope.pop()) {
            None => Ok(v),
            Some(e) => Err(GpuError::Validation {
                what: what.to_string(),
                message: e.to_string(),
            }),
        }
    }
}

/// A Vulkan-only wgpu instance (lavapipe included), with a display handle when a window
/// will be used.
pub fn new_instance(display: Option<Box<dyn wgpu::wgt::WgpuHasDisplayHandle>>) -> wgpu::Instance {
    let mut desc = match display {
        Some(d) => wgpu::InstanceDescriptor::new_with_display_handle(d),
        None => wgpu::InstanceDescriptor::new_without_display_handle(),
    };
    desc.backends = wgpu::Backends::VULKAN;
    wgpu::Instance::new(desc)
}

/// How tests get a context: `Ok(None)` (after printing a skip note) when no adapter exists
/// and the `CI` variable is unset; an error naming the install command when `CI` is set.
pub fn context_for_tests(opts: &ContextOptions) -> Result<Option<GpuContext>, GpuError> {
    match GpuContext::headless(opts) {
        Ok(c) => Ok(Some(c)),
        Err(GpuError::NoAdapter(m)) if std::env::var_os("CI").is_none() => {
            eprintln!("skipped: no Vulkan adapter ({m}); apt-get install -y mesa-vulkan-drivers");
            Ok(None)
        }
        Err(e) => Err(e),
    }
}
