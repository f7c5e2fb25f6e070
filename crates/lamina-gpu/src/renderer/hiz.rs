//! The camera's depth pyramid for occlusion culling (`shaders/hiz.wgsl`): an R32F mip
//! chain (level 0 at least half the target's size, a power of two per axis) whose level
//! `m` texel holds the farthest depth of the `2^(m+1)`-pixel square it covers, built after the camera pass's first part from its depth, read by the late
//! culling pass ([`super::culling::Phase::Late`]). Made for the camera target's size, with
//! the targets.

use super::layout::{D2, DEPTH, UNFILTERED, view_entry};
use crate::context::GpuContext;
use crate::error::GpuError;

/// The pyramid's two compute pipelines and their layouts (made once).
pub(super) struct HiZPipelines {
    first: wgpu::ComputePipeline,
    down: wgpu::ComputePipeline,
    first_layout: wgpu::BindGroupLayout,
    down_layout: wgpu::BindGroupLayout,
}

impl HiZPipelines {
    /// Compiles `hiz.wgsl`.
    pub fn new(ctx: &GpuContext) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let module = ctx.compile_wgsl("hiz.wgsl", include_str!("../shaders/hiz.wgsl"))?;
        let texture = |binding, sample_type| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Texture {
                sample_type,
                view_dimension: D2,
                multisampled: false,
            },
            count: None,
        };
        let store = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::StorageTexture {
                access: wgpu::StorageTextureAccess::WriteOnly,
                format: wgpu::TextureFormat::R32Float,
                view_dimension: D2,
            },
            count: None,
        };
        let layout = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            })
        };
        let first_layout = layout("depth pyramid level 0", &[texture(0, DEPTH), store(1)]);
        let down_layout = layout("depth pyramid level", &[texture(2, UNFILTERED), store(3)]);
        let pipeline = |layout: &wgpu::BindGroupLayout, entry| {
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("depth pyramid"),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("depth pyramid"),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let (first, down) = ctx.validated("building the depth pyramid pipelines", || {
            (
                pipeline(&first_layout, "first"),
                pipeline(&down_layout, "down"),
            )
        })?;
        Ok(HiZPipelines {
            first,
            down,
            first_layout,
            down_layout,
        })
    }
}

/// The pyramid of one target size: its levels' bind groups, and the culling pass's group 1.
pub(super) struct HiZ {
    /// Per level: the group that writes it (from the depth, or from the level below), and
    /// its size in texels.
    levels: Vec<(wgpu::BindGroup, (u32, u32))>,
    /// Group 1 of the late culling pass: every level.
    pub cull_group: wgpu::BindGroup,
}

impl HiZ {
    /// The pyramid over `depth` (a `width x height` Depth32Float target with texture
    /// binding), bound for the culling pass through `cull_layout`.
    pub fn new(
        device: &wgpu::Device,
        pipelines: &HiZPipelines,
        depth: &wgpu::TextureView,
        (width, height): (u32, u32),
        cull_layout: &wgpu::BindGroupLayout,
    ) -> Self {
        // Level 0 a power of two per axis at least half the target, so that every level
        // halves the one below exactly (mip sizes round down); its texels past the
        // target's edge repeat the edge (never looked up: footprints are clamped).
        let base = |n: u32| n.div_ceil(2).max(1).next_power_of_two();
        let mut sizes = vec![(base(width), base(height))];
        while let Some(&(w, h)) = sizes.last()
            && (w > 1 || h > 1)
        {
            sizes.push(((w / 2).max(1), (h / 2).max(1)));
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("depth pyramid"),
            size: wgpu::Extent3d {
                width: sizes[0].0,
                height: sizes[0].1,
                depth_or_array_layers: 1,
            },
            mip_level_count: sizes.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let level = |m: usize| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                base_mip_level: m as u32,
                mip_level_count: Some(1),
                ..Default::default()
            })
        };
        let views: Vec<wgpu::TextureView> = (0..sizes.len()).map(level).collect();
        let levels = sizes
            .iter()
            .enumerate()
            .map(|(m, &size)| {
                let (layout, src, dst) = if m == 0 {
                    (&pipelines.first_layout, (0, depth), 1)
                } else {
                    (&pipelines.down_layout, (2, &views[m - 1]), 3)
                };
                let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("depth pyramid level"),
                    layout,
                    entries: &[view_entry(src.0, src.1), view_entry(dst, &views[m])],
                });
                (group, size)
            })
            .collect();
        let cull_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth pyramid"),
            layout: cull_layout,
            entries: &[view_entry(0, &texture.create_view(&Default::default()))],
        });
        HiZ { levels, cull_group }
    }

    /// Levels of the pyramid.
    pub fn level_count(&self) -> u32 {
        self.levels.len() as u32
    }

    /// Records the pyramid's build (one dispatch per level, each reading the one before).
    pub fn encode(&self, encoder: &mut wgpu::CommandEncoder, pipelines: &HiZPipelines) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("depth pyramid"),
            timestamp_writes: None,
        });
        for (m, (group, (w, h))) in self.levels.iter().enumerate() {
            pass.set_pipeline(if m == 0 {
                &pipelines.first
            } else {
                &pipelines.down
            });
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
    }
}
