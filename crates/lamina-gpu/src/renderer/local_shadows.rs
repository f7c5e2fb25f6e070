//! Shadows of point, sphere and quad lights: for each such light with a slot
//! ([`super::lights::MAX_SHADOWED_LIGHTS`] at most), a cube of the same two-layer
//! translucent maps as the sun's, baked once at load (lights and geometry are static; only
//! the sun moves per frame).
//!
//! Each of a cube's six 90° faces ([`CUBE_FACES`]) holds, like the sun's maps, the nearest
//! alpha-tested occluder (layer 1) and the next one behind it (layer 2, depth peeling):
//! depth and transmittance colour with card radius. Depth is the distance from the light's
//! centre over the cube's range, written by the fragment shader (`fs_cube_first`,
//! `fs_cube_peel`), so it is linear and the same on every face: the camera pass compares
//! distances across face seams without a conversion. Layers of the two array textures:
//! `(slot * 6 + face) * 2 + layer`.
//!
//! The camera pass (`local_transmittance` in scene.wgsl) reads a light's visibility by
//! percentage-closer filtering with 16 taps on a rotated Vogel disc, each tap a direction
//! that finds its own face: one texel wide for a point light; for a sphere (radius `R`) or
//! a quad (the disc of its area, radius `sqrt(A / π)`), percentage-closer soft shadows
//! (Fernando 2005): a blocker search, then a filter as wide as the penumbra
//! `R (d_r - d_b) / (d_r d_b)` (radians, receiver `d_r` and mean blocker `d_b` from the
//! light).

use super::bounds::SceneBounds;
use super::culling::CullView;
use super::geometry::{DrawList, Geometry};
use super::layout::{
    D2, D2_ARRAY, DEPTH_FORMAT, SHADOW_COLOR_FORMAT, buffer_entry, texture_2d, view_entry,
};
use super::lights::{Globals, shadow_range};
use super::pipelines::ScenePipelines;
use super::projection::{CUBE_FACES, cube_face_matrix};
use super::sun::light_view_pass;
use crate::context::GpuContext;
use crate::error::GpuError;
use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

/// Array layers per light: six faces, two layers each.
const LAYERS_PER_LIGHT: u32 = 2 * CUBE_FACES.len() as u32;

/// The cubes of shadow maps of the shadowed local lights.
pub(super) struct LocalShadows {
    /// Depth (distance over range) and transmittance (rgb, card radius in a), one array
    /// layer per light, face and layer.
    textures: [wgpu::Texture; 2],
    /// The same as 2D-array views, for the camera pass.
    pub array_views: [wgpu::TextureView; 2],
    /// Side of each face, texels (0 when no light has a cube).
    pub size: u32,
}

impl LocalShadows {
    /// Empty maps for `lights` cubes of faces of side `size` (already clamped to the
    /// device); with no light, a 1-texel stand-in that the camera pass never reads.
    pub fn new(device: &wgpu::Device, size: u32, lights: usize) -> Self {
        let (side, layers) = if lights == 0 {
            (1, LAYERS_PER_LIGHT)
        } else {
            (size, LAYERS_PER_LIGHT * lights as u32)
        };
        let mk = |label: &str, format: wgpu::TextureFormat| {
            let usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            texture_2d(device, label, (side, side, layers), format, usage)
        };
        let textures = [
            mk("local shadow depth", DEPTH_FORMAT),
            mk("local shadow transmittance", SHADOW_COLOR_FORMAT),
        ];
        let array_views = textures.each_ref().map(|t| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(D2_ARRAY),
                ..Default::default()
            })
        });
        LocalShadows {
            textures,
            array_views,
            size: if lights == 0 { 0 } else { size },
        }
    }

    /// GPU memory of the maps, bytes.
    pub fn bytes(&self) -> u64 {
        let t = &self.textures[0];
        let texels = t.width() as u64 * t.height() as u64 * t.depth_or_array_layers() as u64;
        // Depth32Float and Rgba16Float.
        texels * (4 + 8)
    }

    /// Renders the cubes of `cubes` (slot, centre), each light in its own submission
    /// (the culling pass, when the device has one, thins leaves out as seen from the light
    /// at the faces' resolution), with `base` as the globals of every face but its matrix
    /// and centre; waits for validation.
    pub fn bake(
        &self,
        ctx: &GpuContext,
        cubes: &[(u32, Vec3)],
        bounds: &SceneBounds,
        base: Globals,
        lod_pixels: f32,
        scene: (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
    ) -> Result<(), GpuError> {
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        for &(slot, center) in cubes {
            let range = shadow_range(center, bounds);
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            if let Some(c) = &scene.1.culling {
                c.encode(
                    &ctx.queue,
                    &mut encoder,
                    &CullView {
                        view_proj: Mat4::IDENTITY,
                        position: center,
                        // A 90° face: the focal length is half its side.
                        focal_px: 0.5 * self.size as f32,
                        lod_pixels,
                        frustum: false,
                        ortho_px_per_m: None,
                    },
                    None,
                );
            }
            for face in 0..CUBE_FACES.len() {
                let mut g = base;
                g.light_view_proj = cube_face_matrix(face, center, range).to_cols_array_2d();
                g.cube = center.extend(range).to_array();
                let first = (slot * LAYERS_PER_LIGHT) + 2 * face as u32;
                self.encode_face(&ctx.device, &mut encoder, first, &g, scene);
            }
            ctx.queue.submit([encoder.finish()]);
        }
        match pollster::block_on(scope.pop()) {
            None => Ok(()),
            Some(e) => Err(GpuError::Validation {
                what: "baking the shadow maps of point, sphere and quad lights".into(),
                message: e.to_string(),
            }),
        }
    }

    /// Records the two layers of one face (array layers `first`, `first + 1`) with `g`.
    fn encode_face(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        first: u32,
        g: &Globals,
        (pipelines, geometry, materials): (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
    ) {
        let buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cube face"),
            contents: bytemuck::bytes_of(g),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let view = |t: &wgpu::Texture, layer: u32| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(D2),
                base_array_layer: first + layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        };
        let depth = [view(&self.textures[0], 0), view(&self.textures[0], 1)];
        let color = [view(&self.textures[1], 0), view(&self.textures[1], 1)];
        for layer in 0..2 {
            let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("cube face"),
                layout: &pipelines.shadow_layout,
                // Layer 1 reads nothing (it binds layer 2's depth only because the layout
                // wants a depth texture); layer 2 peels behind layer 1's depth.
                entries: &[buffer_entry(0, &buf), view_entry(1, &depth[1 - layer])],
            });
            let pipeline = if layer == 0 {
                &pipelines.cube_first
            } else {
                &pipelines.cube_peel
            };
            let mut pass = light_view_pass(
                encoder,
                "local light view",
                &color[layer],
                &depth[layer],
                None,
            );
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &bg, &[]);
            geometry.draw(&mut pass, materials, DrawList::Shadow);
        }
    }
}
