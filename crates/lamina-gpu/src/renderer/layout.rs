//! What the passes agree on: the texture formats of the render targets and light-view
//! maps, and shorthand for bind-group-layout and bind-group entries.

/// The camera pass's target: linear radiance (W m⁻² sr⁻¹), RGBA16F.
pub(super) const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Depth of the camera and light-view passes.
pub(super) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Transmittance maps: rgb = diffuse transmittance of the occluder, a = its card radius (m).
pub(super) const SHADOW_COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// A filterable float texture.
pub(super) const FLOAT: wgpu::TextureSampleType =
    wgpu::TextureSampleType::Float { filterable: true };
/// A float texture read with `textureLoad` only.
pub(super) const UNFILTERED: wgpu::TextureSampleType =
    wgpu::TextureSampleType::Float { filterable: false };
/// A depth texture.
pub(super) const DEPTH: wgpu::TextureSampleType = wgpu::TextureSampleType::Depth;
/// A 2D texture view.
pub(super) const D2: wgpu::TextureViewDimension = wgpu::TextureViewDimension::D2;
/// A 2D array texture view.
pub(super) const D2_ARRAY: wgpu::TextureViewDimension = wgpu::TextureViewDimension::D2Array;

/// A texture read by the fragment stage.
pub(super) fn tex_entry(
    binding: u32,
    sample: wgpu::TextureSampleType,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: sample,
            view_dimension: dim,
            multisampled: false,
        },
        count: None,
    }
}

/// A uniform buffer read by both stages.
pub(super) fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A filtering sampler used by the fragment stage.
pub(super) fn sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// A bind-group entry binding a texture view.
pub(super) fn view_entry(binding: u32, v: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(v),
    }
}

/// A bind-group entry binding a whole buffer.
pub(super) fn buffer_entry(binding: u32, b: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: b.as_entire_binding(),
    }
}

/// A bind-group entry binding a sampler.
pub(super) fn sampler_binding(binding: u32, s: &wgpu::Sampler) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::Sampler(s),
    }
}

/// A 2D texture (or 2D array of `layers`) of `width x height` texels, one mip level.
pub(super) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height, layers): (u32, u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// A uniform buffer of `size` bytes the queue writes into.
pub(super) fn uniform_buffer(device: &wgpu::Device, label: &str, size: usize) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}
