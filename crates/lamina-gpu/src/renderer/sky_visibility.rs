//! Sky visibility, baked once at load (geometry and sky are static): for each of up to
//! [`MAX_SKY_DIRS`] directions spread over the sphere, the same two-layer depth and
//! transmittance maps as the sun's, so the camera pass can tell how much of the sky each
//! surface sees and through how many leaves (see `sky_visibility` in scene.wgsl).

use super::geometry::Geometry;
use super::layout::{D2_ARRAY, DEPTH_FORMAT, SHADOW_COLOR_FORMAT, texture_2d, uniform_buffer};
use super::lights::Globals;
use super::pipelines::ScenePipelines;
use super::projection::{light_matrix, sphere_directions};
use super::sun::{BakedView, encode_baked_view, layer_view};
use crate::context::GpuContext;
use crate::error::GpuError;
use glam::Vec3;

/// Most sky-visibility directions.
pub const MAX_SKY_DIRS: usize = 16;

/// The sky-visibility maps' matrices and directions (see `SkyVis` in scene.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SkyVis {
    view_proj: [[[f32; 4]; 4]; MAX_SKY_DIRS],
    dir: [[f32; 4]; MAX_SKY_DIRS],
    params: [f32; 4],
}

/// The sky-visibility maps (one array layer per direction) and their uniform buffer.
pub(super) struct SkyVisibility {
    /// Depth `d1`, depth `d2`, transmittance `c1`, transmittance `c2`, one layer each per
    /// direction.
    textures: [wgpu::Texture; 4],
    /// The same as 2D-array views, for the camera pass.
    pub array_views: [wgpu::TextureView; 4],
    /// The [`SkyVis`] uniform.
    pub buffer: wgpu::Buffer,
}

impl SkyVisibility {
    /// Empty maps of side `size` with `layers` layers (both already clamped).
    pub fn new(device: &wgpu::Device, size: u32, layers: u32) -> Self {
        let mk = |label: &str, format: wgpu::TextureFormat| {
            let usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            texture_2d(device, label, (size, size, layers), format, usage)
        };
        let textures = [
            mk("sky d1", DEPTH_FORMAT),
            mk("sky d2", DEPTH_FORMAT),
            mk("sky c1", SHADOW_COLOR_FORMAT),
            mk("sky c2", SHADOW_COLOR_FORMAT),
        ];
        let array_views = textures.each_ref().map(|t| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(D2_ARRAY),
                ..Default::default()
            })
        });
        let buffer = uniform_buffer(device, "sky visibility", std::mem::size_of::<SkyVis>());
        SkyVisibility {
            textures,
            array_views,
            buffer,
        }
    }

    /// Side of each map, in texels.
    pub fn map_size(&self) -> u32 {
        self.textures[0].width()
    }

    /// Renders the maps for `n` directions (at most [`MAX_SKY_DIRS`]) around the casters'
    /// bounding sphere `casters`, with `base` as the globals of every direction but its
    /// light matrix; writes the uniform and waits for validation.
    pub fn bake(
        &self,
        ctx: &GpuContext,
        n: usize,
        casters: (Vec3, f32),
        base: Globals,
        scene: (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
    ) -> Result<(), GpuError> {
        let dirs = sphere_directions(n.min(MAX_SKY_DIRS));
        let n = dirs.len();
        let (c, r) = casters;
        let size = self.textures[0].width();
        let mut vis = SkyVis {
            view_proj: [[[0.0; 4]; 4]; MAX_SKY_DIRS],
            dir: [[0.0; 4]; MAX_SKY_DIRS],
            params: [n as f32, size as f32, 2.0 * r / size as f32, 2.0 * r],
        };
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        for (k, d) in dirs.iter().enumerate() {
            let m = light_matrix(*d, c, r);
            vis.view_proj[k] = m.to_cols_array_2d();
            vis.dir[k] = d.extend(0.0).to_array();
            let mut g = base;
            g.light_view_proj = m.to_cols_array_2d();
            self.encode_direction(&ctx.device, &mut encoder, k, &g, scene);
        }
        ctx.queue
            .write_buffer(&self.buffer, 0, bytemuck::bytes_of(&vis));
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        ctx.queue.submit([encoder.finish()]);
        match pollster::block_on(scope.pop()) {
            None => Ok(()),
            Some(e) => Err(GpuError::Validation {
                what: "baking the sky-visibility maps".into(),
                message: e.to_string(),
            }),
        }
    }

    /// Records the two light-view layers of direction `k` with globals `g`.
    fn encode_direction(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        k: usize,
        g: &Globals,
        scene: (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
    ) {
        let [d1, d2, c1, c2] = &self.textures;
        let k = k as u32;
        let view = BakedView {
            g,
            depth: [layer_view(d1, k), layer_view(d2, k)],
            color: [layer_view(c1, k), layer_view(c2, k)],
            pipelines: (&scene.0.shadow_first, &scene.0.shadow_peel),
        };
        encode_baked_view(device, encoder, &view, scene);
    }
}
