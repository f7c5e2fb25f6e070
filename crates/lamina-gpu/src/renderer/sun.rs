//! The sun's two-layer translucent shadow map, redrawn every frame (the sun may move):
//! depth and transmittance of the nearest occluder (layer 1) and of the next one behind
//! it (layer 2), seen from the sun (see the [`super`] docs). Also the light-view pass both
//! the sun and the sky-visibility bake ([`super::sky_visibility`]) render into.

use super::geometry::{DrawList, Geometry};
use super::layout::{DEPTH_FORMAT, SHADOW_COLOR_FORMAT, buffer_entry, texture_2d, view_entry};
use super::lights::Globals;
use super::pipelines::ScenePipelines;
use super::timing::{Pass, Timer};
use wgpu::util::DeviceExt;

/// The sun's light-view maps and the bind groups of its two passes.
pub(super) struct SunShadow {
    /// Side of the maps (texels).
    pub size: u32,
    /// Depth `d1`, depth `d2`, transmittance `c1`, transmittance `c2`.
    pub views: [wgpu::TextureView; 4],
    /// Group 0 of layer 1 (binds `d2` only because the layout wants a depth texture).
    first: wgpu::BindGroup,
    /// Group 0 of layer 2: peels behind `d1`.
    peel: wgpu::BindGroup,
}

impl SunShadow {
    /// Maps of side `size` (already clamped to the device), bound with `globals`.
    pub fn new(
        device: &wgpu::Device,
        size: u32,
        pipelines: &ScenePipelines,
        globals: &wgpu::Buffer,
    ) -> Self {
        let mk = |label: &str, format: wgpu::TextureFormat| {
            let usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            texture_2d(device, label, (size, size, 1), format, usage)
                .create_view(&wgpu::TextureViewDescriptor::default())
        };
        let views = [
            mk("shadow d1", DEPTH_FORMAT),
            mk("shadow d2", DEPTH_FORMAT),
            mk("shadow c1", SHADOW_COLOR_FORMAT),
            mk("shadow c2", SHADOW_COLOR_FORMAT),
        ];
        let bind = |d: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("shadow globals"),
                layout: &pipelines.shadow_layout,
                entries: &[buffer_entry(0, globals), view_entry(1, d)],
            })
        };
        // Layer 1 binds d2 only because the layout wants a depth texture; it reads none.
        let first = bind(&views[1]);
        let peel = bind(&views[0]);
        SunShadow {
            size,
            views,
            first,
            peel,
        }
    }

    /// Records both layers' passes; without a sun they only clear (depth 1, white).
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipelines: &ScenePipelines,
        geometry: &Geometry,
        materials: &[wgpu::BindGroup],
        has_sun: bool,
        mut timer: Option<&mut Timer>,
    ) {
        for (layer, (pipeline, bg, slot)) in [
            (&pipelines.shadow_first, &self.first, Pass::ShadowFirst),
            (&pipelines.shadow_peel, &self.peel, Pass::ShadowPeel),
        ]
        .into_iter()
        .enumerate()
        {
            let (color, depth) = (&self.views[2 + layer], &self.views[layer]);
            let writes = timer.as_deref_mut().and_then(|t| t.writes(slot));
            let mut pass = light_view_pass(encoder, "light view", color, depth, writes);
            if has_sun {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, bg, &[]);
                geometry.draw(&mut pass, materials, DrawList::Shadow);
            }
        }
    }
}

/// Begins a light-view pass into transmittance `color` (cleared to white: nothing
/// blocks) and `depth` (cleared to 1: nothing in front).
pub(super) fn light_view_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    color: &wgpu::TextureView,
    depth: &wgpu::TextureView,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::WHITE),
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: timestamps,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// One view of a light baked at load (a sky-visibility direction, a further sun's tile, a
/// cube face): globals `g` (its matrix) and the single-layer views of its two layers,
/// depth `[d1, d2]` and transmittance `[c1, c2]`, drawn by `pipelines` (layer 1, layer 2).
pub(super) struct BakedView<'a> {
    pub g: &'a Globals,
    pub depth: [wgpu::TextureView; 2],
    pub color: [wgpu::TextureView; 2],
    pub pipelines: (&'a wgpu::RenderPipeline, &'a wgpu::RenderPipeline),
}

/// Records both layers of `view` (every instance drawn, as the light views' list has it).
pub(super) fn encode_baked_view(
    device: &wgpu::Device,
    encoder: &mut wgpu::CommandEncoder,
    view: &BakedView<'_>,
    (scene, geometry, materials): (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
) {
    let buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("light view"),
        contents: bytemuck::bytes_of(view.g),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    for layer in 0..2 {
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("light view"),
            layout: &scene.shadow_layout,
            // Layer 1 reads nothing (it binds layer 2's depth only because the layout
            // wants a depth texture); layer 2 peels behind layer 1's depth.
            entries: &[buffer_entry(0, &buf), view_entry(1, &view.depth[1 - layer])],
        });
        let pipeline = if layer == 0 {
            view.pipelines.0
        } else {
            view.pipelines.1
        };
        let mut pass = light_view_pass(
            encoder,
            "light view",
            &view.color[layer],
            &view.depth[layer],
            None,
        );
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bg, &[]);
        geometry.draw(&mut pass, materials, DrawList::Shadow);
    }
}

/// The view of array layer `layer` of `t` as a single 2D texture (a render target).
pub(super) fn layer_view(t: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(super::layout::D2),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}
