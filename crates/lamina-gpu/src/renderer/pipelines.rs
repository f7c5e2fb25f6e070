//! The scene shader's six render pipelines (sun/sky light view layer 1 and layer 2, the
//! local lights' cube faces layer 1 and layer 2, the camera's depth pre-pass and its
//! shading pass) and the layouts of their group 0 (group 1 is the material,
//! [`super::materials`]; group 2 the instances, [`super::geometry`]).

use super::geometry::vertex_layouts;
use super::layout::{
    D2, D2_ARRAY, DEPTH, DEPTH_FORMAT, HDR_FORMAT, SHADOW_COLOR_FORMAT, UNFILTERED, tex_entry,
    uniform_entry,
};
use crate::context::GpuContext;
use crate::error::GpuError;

/// Pipelines and group-0 layouts of `scene.wgsl`.
pub(super) struct ScenePipelines {
    /// Group 0 of the light-view passes: the globals and the depth map to peel behind.
    pub shadow_layout: wgpu::BindGroupLayout,
    /// Group 0 of the camera pass: the globals, the sun's maps, the sky-visibility maps,
    /// the local lights' cubes.
    pub camera_layout: wgpu::BindGroupLayout,
    /// Light view, layer 1 (`fs_shadow_first`): nearest occluder.
    pub shadow_first: wgpu::RenderPipeline,
    /// Light view, layer 2 (`fs_shadow_peel`): the next occluder behind layer 1.
    pub shadow_peel: wgpu::RenderPipeline,
    /// A local light's cube face, layer 1 (`fs_cube_first`): depth is distance over range.
    pub cube_first: wgpu::RenderPipeline,
    /// A local light's cube face, layer 2 (`fs_cube_peel`).
    pub cube_peel: wgpu::RenderPipeline,
    /// The camera's depth pre-pass (`fs_depth`): depth only, the colour left alone.
    pub camera_depth: wgpu::RenderPipeline,
    /// The camera pass (`fs_main`) into the HDR target, where the pre-pass left the
    /// nearest depth (equal depth passes, no depth writes): one shading per pixel.
    pub camera: wgpu::RenderPipeline,
}

impl ScenePipelines {
    /// Builds the layouts and pipelines of `module` (the compiled scene shader), with
    /// `material` as group 1.
    pub fn new(
        ctx: &GpuContext,
        module: &wgpu::ShaderModule,
        material: &wgpu::BindGroupLayout,
        instances: &wgpu::BindGroupLayout,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow globals"),
            entries: &[uniform_entry(0), tex_entry(1, DEPTH, D2)],
        });
        let camera_layout = camera_layout(device);
        let make = |label: &str, group0: &wgpu::BindGroupLayout, vs, fs, color, depth| {
            pipeline(
                device,
                module,
                [group0, material, instances],
                (label, vs, fs),
                color,
                depth,
            )
        };
        let light_view = |label: &str, fs| {
            make(
                label,
                &shadow_layout,
                "vs_shadow",
                fs,
                SHADOW_COLOR_FORMAT,
                Depth::Nearest,
            )
        };
        let (shadow_first, shadow_peel, cube_first, cube_peel, camera_depth, camera) = ctx
            .validated("building the render pipelines", || {
                (
                    light_view("shadow layer 1", "fs_shadow_first"),
                    light_view("shadow layer 2", "fs_shadow_peel"),
                    light_view("cube face layer 1", "fs_cube_first"),
                    light_view("cube face layer 2", "fs_cube_peel"),
                    make(
                        "camera depth",
                        &camera_layout,
                        "vs_main",
                        "fs_depth",
                        HDR_FORMAT,
                        Depth::Only,
                    ),
                    make(
                        "camera",
                        &camera_layout,
                        "vs_main",
                        "fs_main",
                        HDR_FORMAT,
                        Depth::Equal,
                    ),
                )
            })?;
        Ok(ScenePipelines {
            shadow_layout,
            camera_layout,
            shadow_first,
            shadow_peel,
            cube_first,
            cube_peel,
            camera_depth,
            camera,
        })
    }
}

fn camera_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("main globals"),
        entries: &[
            uniform_entry(0),
            tex_entry(1, DEPTH, D2),
            tex_entry(2, DEPTH, D2),
            tex_entry(3, UNFILTERED, D2),
            tex_entry(4, UNFILTERED, D2),
            uniform_entry(5),
            tex_entry(6, DEPTH, D2_ARRAY),
            tex_entry(7, DEPTH, D2_ARRAY),
            tex_entry(8, UNFILTERED, D2_ARRAY),
            tex_entry(9, UNFILTERED, D2_ARRAY),
            tex_entry(10, DEPTH, D2_ARRAY),
            tex_entry(11, UNFILTERED, D2_ARRAY),
        ],
    })
}

/// How a pipeline uses depth.
#[derive(Clone, Copy, PartialEq)]
enum Depth {
    /// Nearest wins, depth and colour written.
    Nearest,
    /// Nearest wins, depth written, colour not (a depth pre-pass).
    Only,
    /// Only where the depth equals the stored one (after a pre-pass), depth not written.
    Equal,
}

/// One pipeline of the scene shader: entry points `vs`, `fs`, the depth test `depth`, no
/// culling (leaves are two-sided sheets), no blending, into `color`.
fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    [group0, group1, group2]: [&wgpu::BindGroupLayout; 3],
    (label, vs, fs): (&str, &str, &str),
    color: wgpu::TextureFormat,
    depth: Depth,
) -> wgpu::RenderPipeline {
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(group0), Some(group1), Some(group2)],
        immediate_size: 0,
    });
    let buffers = vertex_layouts();
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vs),
            compilation_options: Default::default(),
            buffers: &buffers,
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            front_face: wgpu::FrontFace::Ccw,
            // Leaves are two-sided sheets.
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(depth != Depth::Equal),
            depth_compare: Some(if depth == Depth::Equal {
                wgpu::CompareFunction::Equal
            } else {
                wgpu::CompareFunction::Less
            }),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format: color,
                blend: None,
                write_mask: if depth == Depth::Only {
                    wgpu::ColorWrites::empty()
                } else {
                    wgpu::ColorWrites::ALL
                },
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
