//! Post-processing for windows and screenshots: the tone-map pass (exposure and operator
//! of the film, the same curves as lamina-image's PNG output; the sRGB target applies the
//! sRGB curve on store) with the frame-time overlay text composited in the top-left
//! corner.

use super::layout::{
    D2, UNFILTERED, buffer_entry, tex_entry, uniform_buffer, uniform_entry, view_entry,
};
use crate::context::GpuContext;
use crate::error::GpuError;
use lamina_scene::{Film, ToneMap};

/// Overlay text texture size (pixels).
pub const OVERLAY_SIZE: (u32, u32) = (1024, 24);

/// Uniforms of the post pass (see `Post` in post.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PostUniform {
    /// `x`: exposure scale `2^exposure`; `y`: operator (0 clamp, 1 ACES, 2 Reinhard).
    params: [f32; 4],
    /// The overlay's rectangle in target pixels (x, y, width, height); zero for none.
    rect: [f32; 4],
}

/// The tone-map pipeline for one target format.
struct PostPipeline {
    format: wgpu::TextureFormat,
    pipeline: wgpu::RenderPipeline,
}

/// The tone-map pass's shader, pipeline (made for the first target format asked for, and
/// remade when it changes), uniforms and overlay texture.
pub(super) struct PostProcess {
    layout: wgpu::BindGroupLayout,
    module: wgpu::ShaderModule,
    pipeline: Option<PostPipeline>,
    uniform: wgpu::Buffer,
    overlay_tex: wgpu::Texture,
    overlay_view: wgpu::TextureView,
}

impl PostProcess {
    /// The pass's resources; `module` is the compiled post.wgsl.
    pub fn new(device: &wgpu::Device, module: wgpu::ShaderModule) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("post"),
            entries: &[
                tex_entry(0, UNFILTERED, D2),
                uniform_entry(1),
                tex_entry(2, UNFILTERED, D2),
            ],
        });
        let uniform = uniform_buffer(device, "post", std::mem::size_of::<PostUniform>());
        let overlay_tex = super::layout::texture_2d(
            device,
            "overlay",
            (OVERLAY_SIZE.0, OVERLAY_SIZE.1, 1),
            wgpu::TextureFormat::R8Unorm,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        );
        let overlay_view = overlay_tex.create_view(&Default::default());
        PostProcess {
            layout,
            module,
            pipeline: None,
            uniform,
            overlay_tex,
            overlay_view,
        }
    }

    /// Makes the pipeline for `format` unless the current one has it.
    pub fn ensure_pipeline(
        &mut self,
        ctx: &GpuContext,
        format: wgpu::TextureFormat,
    ) -> Result<(), GpuError> {
        if self.pipeline.as_ref().is_some_and(|p| p.format == format) {
            return Ok(());
        }
        let pipeline = ctx.validated("building the tone-map pipeline", || {
            self.build_pipeline(&ctx.device, format)
        })?;
        self.pipeline = Some(PostPipeline { format, pipeline });
        Ok(())
    }

    fn build_pipeline(
        &self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
    ) -> wgpu::RenderPipeline {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("post"),
            bind_group_layouts: &[Some(&self.layout)],
            immediate_size: 0,
        });
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("tonemap"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &self.module,
                entry_point: Some("vs_full"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &self.module,
                entry_point: Some("fs_tonemap"),
                compilation_options: Default::default(),
                targets: &[Some(format.into())],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// Writes the uniforms for `film` and the overlay (R8, [`OVERLAY_SIZE`], 1 = text)
    /// when given.
    pub fn write_inputs(&self, ctx: &GpuContext, film: &Film, overlay: Option<&[u8]>) {
        let op = match film.tonemap {
            ToneMap::Clamp => 0.0,
            ToneMap::Aces => 1.0,
            ToneMap::Reinhard => 2.0,
        };
        let exposure = if film.exposure.is_finite() {
            2f32.powf(film.exposure)
        } else {
            1.0
        };
        let (ow, oh) = OVERLAY_SIZE;
        let rect = if overlay.is_some() {
            [8.0, 8.0, ow as f32, oh as f32]
        } else {
            [0.0; 4]
        };
        if let Some(data) = overlay {
            ctx.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &self.overlay_tex,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                data,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(ow),
                    rows_per_image: Some(oh),
                },
                wgpu::Extent3d {
                    width: ow,
                    height: oh,
                    depth_or_array_layers: 1,
                },
            );
        }
        let uniform = PostUniform {
            params: [exposure, op, 0.0, 0.0],
            rect,
        };
        ctx.queue
            .write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
    }

    /// Records the pass from `hdr` into `target` (after [`PostProcess::ensure_pipeline`]
    /// and [`PostProcess::write_inputs`]).
    pub fn encode(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        hdr: &wgpu::TextureView,
        target: &wgpu::TextureView,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("post"),
            layout: &self.layout,
            entries: &[
                view_entry(0, hdr),
                buffer_entry(1, &self.uniform),
                view_entry(2, &self.overlay_view),
            ],
        });
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("tonemap"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: timestamps,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let pipeline = &self.pipeline.as_ref().expect("made by ensure_pipeline");
        pass.set_pipeline(&pipeline.pipeline);
        pass.set_bind_group(0, &bg, &[]);
        pass.draw(0..3, 0..1);
    }
}
