//! The camera pass: the per-frame globals buffer, the camera pass's group 0 (globals, the
//! sun's maps, the sky-visibility maps, the local lights' cubes), the HDR and depth targets
//! it draws into (made for the view's size, kept while the size holds), and the pass itself.

use super::geometry::{DrawList, Geometry};
use super::hiz::{HiZ, HiZPipelines};
use super::layout::{DEPTH_FORMAT, HDR_FORMAT, buffer_entry, texture_2d, view_entry};
use super::lights::Globals;
use super::local_shadows::LocalShadows;
use super::pipelines::ScenePipelines;
use super::sky_visibility::SkyVisibility;
use super::sun::SunShadow;
use glam::Vec3;

/// The camera's render targets at one size.
pub(super) struct Targets {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear radiance (W m⁻² sr⁻¹), RGBA16F, also read back and tone-mapped.
    pub hdr: wgpu::Texture,
    /// View of [`Targets::hdr`].
    pub hdr_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    /// The depth pyramid over the depth target, where occlusion culling can run.
    pub hiz: Option<HiZ>,
}

/// The camera pass's uniforms, bindings and targets.
pub(super) struct CameraPass {
    /// The [`Globals`] of the frame (also group 0 of the sun's passes).
    pub globals: wgpu::Buffer,
    /// Group 0 of the camera pass.
    bind_group: wgpu::BindGroup,
    /// The targets of the last frame's size; `None` before the first frame.
    pub targets: Option<Targets>,
}

/// The buffer every frame's [`Globals`] is written into.
pub(super) fn globals_buffer(device: &wgpu::Device) -> wgpu::Buffer {
    super::layout::uniform_buffer(device, "globals", std::mem::size_of::<Globals>())
}

impl CameraPass {
    /// Binds `globals` with the sun's, the sky's and the local lights' maps.
    pub fn new(
        device: &wgpu::Device,
        pipelines: &ScenePipelines,
        globals: wgpu::Buffer,
        (sun, sky, local): (&SunShadow, &SkyVisibility, &LocalShadows),
    ) -> Self {
        let (s, k, c) = (&sun.views, &sky.array_views, &local.array_views);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("main globals"),
            layout: &pipelines.camera_layout,
            entries: &[
                buffer_entry(0, &globals),
                view_entry(1, &s[0]),
                view_entry(2, &s[1]),
                view_entry(3, &s[2]),
                view_entry(4, &s[3]),
                buffer_entry(5, &sky.buffer),
                view_entry(6, &k[0]),
                view_entry(7, &k[1]),
                view_entry(8, &k[2]),
                view_entry(9, &k[3]),
                view_entry(10, &c[0]),
                view_entry(11, &c[1]),
            ],
        });
        CameraPass {
            globals,
            bind_group,
            targets: None,
        }
    }

    /// Makes the targets for `width x height` unless they already have that size, with a
    /// depth pyramid when `hiz` gives its pipelines and the culling pass's layout.
    pub fn ensure_targets(
        &mut self,
        device: &wgpu::Device,
        width: u32,
        height: u32,
        hiz: Option<(&HiZPipelines, &wgpu::BindGroupLayout)>,
    ) {
        if self
            .targets
            .as_ref()
            .is_some_and(|t| t.width == width && t.height == height)
        {
            return;
        }
        let hdr = texture_2d(
            device,
            "hdr",
            (width, height, 1),
            HDR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture_2d(
            device,
            "depth",
            (width, height, 1),
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let depth_view = depth.create_view(&Default::default());
        let hiz = hiz.map(|(p, layout)| HiZ::new(device, p, &depth_view, (width, height), layout));
        self.targets = Some(Targets {
            width,
            height,
            hdr_view: hdr.create_view(&Default::default()),
            hdr,
            depth_view,
            hiz,
        });
    }

    /// Records the camera pass over `list` into the current targets: the camera list
    /// cleared to `background` (linear radiance) and depth 1 first, the late list on top.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        background: Vec3,
        (pipelines, geometry, materials): (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
        list: DrawList,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let t = self.targets.as_ref().expect("targets were just made");
        let bg = background;
        let clear = list != DrawList::Late;
        let color_load = if clear {
            wgpu::LoadOp::Clear(wgpu::Color {
                r: bg.x as f64,
                g: bg.y as f64,
                b: bg.z as f64,
                a: 1.0,
            })
        } else {
            wgpu::LoadOp::Load
        };
        let depth_load = if clear {
            wgpu::LoadOp::Clear(1.0)
        } else {
            wgpu::LoadOp::Load
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("camera"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &t.hdr_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: color_load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &t.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: depth_load,
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        // Depth first, then each pixel shaded once, by the surface the depth holds (leaves
        // overlap many times over: shading each one cost most of a frame; on an H200 the
        // 1M-leaf tree's camera pass fell from 207 to 29 ms). Where two surfaces meet at
        // the same depth (crossing leaves) the last drawn now shows, not the first: 0.7 %
        // of the forest example's pixels, the same ones on lavapipe and on NVIDIA.
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_pipeline(&pipelines.camera_depth);
        geometry.draw(&mut pass, materials, list);
        pass.set_pipeline(&pipelines.camera);
        geometry.draw(&mut pass, materials, list);
    }
}
