//! Upload of the baked materials ([`crate::bake`]): per material its three albedo maps,
//! normal map, angular tables and uniforms as one bind group (group 1 of every pass), and
//! the card radius each material's meshes give it (the leaf-to-receiver form factor of the
//! transmittance maps).

use super::half::f32_to_half;
use super::layout::{
    D2, D2_ARRAY, FLOAT, buffer_entry, sampler_binding, sampler_entry, tex_entry, uniform_entry,
    view_entry,
};
use crate::bake::{self, BakedMaterial, LUT_LAYERS, LUT_N, MaterialUniform, MipMap};
use crate::context::GpuContext;
use crate::error::GpuError;
use glam::Vec3;
use lamina_scene::{Mesh, Scene};
use wgpu::util::DeviceExt;

/// The scene's materials on the GPU, indexed like `Scene::materials`.
pub(super) struct Materials {
    /// Layout of group 1 (see `MaterialParams` and the maps in scene.wgsl).
    pub layout: wgpu::BindGroupLayout,
    /// One bind group per scene material.
    pub groups: Vec<wgpu::BindGroup>,
}

/// The two samplers every material binds.
struct Samplers {
    /// Albedo and normal maps: repeating, trilinear.
    maps: wgpu::Sampler,
    /// Angular tables: clamped, bilinear.
    lut: wgpu::Sampler,
}

impl Materials {
    /// Bakes and uploads every material of `scene`; also returns the bake's warnings
    /// (downscaled maps).
    pub fn upload(ctx: &GpuContext, scene: &Scene) -> Result<(Self, Vec<String>), GpuError> {
        let layout = material_layout(&ctx.device);
        let samplers = samplers(&ctx.device);
        let radii = card_radii(scene);
        let mut warnings = Vec::new();
        let mut groups = Vec::new();
        for (mi, m) in scene.materials.iter().enumerate() {
            let mut b: BakedMaterial = bake::bake_material(m, ctx.max_texture_dim);
            b.uniform.shape[0] = radii[mi];
            warnings.extend(b.warnings.iter().cloned());
            let group = ctx.validated(&format!("uploading material '{}'", b.name), || {
                upload_material(ctx, &layout, &samplers, &b)
            })?;
            groups.push(group);
        }
        Ok((Materials { layout, groups }, warnings))
    }
}

fn material_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("material"),
        entries: &[
            tex_entry(0, FLOAT, D2),
            tex_entry(1, FLOAT, D2),
            tex_entry(2, FLOAT, D2),
            tex_entry(3, FLOAT, D2_ARRAY),
            sampler_entry(4),
            sampler_entry(5),
            uniform_entry(6),
            tex_entry(7, FLOAT, D2),
        ],
    })
}

fn samplers(device: &wgpu::Device) -> Samplers {
    Samplers {
        maps: device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("maps"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        }),
        lut: device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("lut"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        }),
    }
}

/// Card radius (m) per material: the mean area of two of its triangles (instances scaled
/// by their transform), as a disc; 0 for a material no mesh uses.
fn card_radii(scene: &Scene) -> Vec<f32> {
    let mut area = vec![(0.0f64, 0usize); scene.materials.len()];
    let mut add_area = |m: &Mesh, scale: f32| {
        if let Some(a) = area.get_mut(m.material as usize) {
            for t in &m.indices {
                let p = t.map(|i| m.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO));
                a.0 += (0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length() * scale) as f64;
                a.1 += 1;
            }
        }
    };
    scene.meshes.iter().for_each(|m| add_area(m, 1.0));
    for inst in &scene.instances {
        if let Some(p) = scene.prototypes.get(inst.prototype as usize) {
            let s = inst.transform.matrix3.determinant().abs().powf(2.0 / 3.0);
            p.meshes.iter().for_each(|m| add_area(m, s));
        }
    }
    area.iter()
        .map(|&(sum, n)| {
            if n > 0 {
                (2.0 * sum / n as f64 / std::f64::consts::PI).sqrt() as f32
            } else {
                0.0
            }
        })
        .collect()
}

/// One material's textures and uniform buffer, bound as group 1.
fn upload_material(
    ctx: &GpuContext,
    layout: &wgpu::BindGroupLayout,
    samplers: &Samplers,
    b: &BakedMaterial,
) -> wgpu::BindGroup {
    let device = &ctx.device;
    let srgb = wgpu::TextureFormat::Rgba8UnormSrgb;
    let front = upload_mips(ctx, "front", &b.front, srgb);
    let back = upload_mips(ctx, "back", &b.back, srgb);
    let trans = upload_mips(ctx, "trans", &b.trans, srgb);
    // Tangent-space normals are stored linearly.
    let normal = upload_mips(ctx, "normal", &b.normal, wgpu::TextureFormat::Rgba8Unorm);
    let lut_view = upload_lut(ctx, &b.lut);
    let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("material uniform"),
        contents: bytemuck::bytes_of::<MaterialUniform>(&b.uniform),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(&b.name),
        layout,
        entries: &[
            view_entry(0, &front),
            view_entry(1, &back),
            view_entry(2, &trans),
            view_entry(3, &lut_view),
            sampler_binding(4, &samplers.maps),
            sampler_binding(5, &samplers.lut),
            buffer_entry(6, &ubuf),
            view_entry(7, &normal),
        ],
    })
}

/// The angular tables as a `LUT_N x LUT_N x LUT_LAYERS` RGBA16F array texture.
fn upload_lut(ctx: &GpuContext, lut: &[[f32; 4]]) -> wgpu::TextureView {
    let lut_half: Vec<u16> = lut.iter().flatten().map(|&x| f32_to_half(x)).collect();
    let tex = ctx.device.create_texture_with_data(
        &ctx.queue,
        &wgpu::TextureDescriptor {
            label: Some("lut"),
            size: wgpu::Extent3d {
                width: LUT_N as u32,
                height: LUT_N as u32,
                depth_or_array_layers: LUT_LAYERS as u32,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(&lut_half),
    );
    tex.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(D2_ARRAY),
        ..Default::default()
    })
}

/// A baked map with all its mip levels, in `format`.
fn upload_mips(
    ctx: &GpuContext,
    label: &str,
    m: &MipMap,
    format: wgpu::TextureFormat,
) -> wgpu::TextureView {
    let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: m.width,
            height: m.height,
            depth_or_array_layers: 1,
        },
        mip_level_count: m.levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let (mut w, mut h) = (m.width, m.height);
    for (level, data) in m.levels.iter().enumerate() {
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: level as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(data),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * w),
                rows_per_image: Some(h),
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        (w, h) = ((w / 2).max(1), (h / 2).max(1));
    }
    tex.create_view(&wgpu::TextureViewDescriptor::default())
}
