//! The per-frame culling and level-of-detail pass on the GPU (`shaders/cull.wgsl`): one
//! compute dispatch, one workgroup per group of instances, that gives every instance the
//! fraction of its leaves kept ([`super::lod`]), writes the camera's draw list (instances
//! whose bounding sphere, grown by what LOD enlarges, meets the view frustum) and the
//! light views' (every instance drawn), and the indirect draw arguments of every mesh per
//! list and LOD bucket. Nothing comes back to the CPU: the passes draw from those
//! arguments ([`super::geometry::Geometry::draw`]).
//!
//! With occlusion culling ([`Phase`]), frames run it twice: before the camera pass, with
//! the camera list holding only the instances visible in the last frame; after the camera
//! pass's first part and its depth pyramid ([`super::hiz`]), to test every instance in view
//! against that depth and put those not hidden and not yet drawn in the late list, which
//! the camera pass's second part draws. Each phase has its own uniforms, so both record
//! into one submission.
//!
//! It needs indirect draws with a first instance (`INDIRECT_FIRST_INSTANCE`, which Vulkan
//! drivers have); without it the geometry is drawn directly, at full detail, unculled.

use super::geometry::DrawList;
use super::layout::{buffer_entry, uniform_buffer};
use super::lod::{self, BUCKETS};
use crate::context::GpuContext;
use crate::error::GpuError;
use glam::{Mat4, Vec3};

/// The culling shader.
pub const CULL_WGSL: &str = include_str!("../shaders/cull.wgsl");

/// Bytes of one `DrawIndexedIndirectArgs`.
const ARGS_BYTES: u64 = 20;
/// Argument slots per mesh: the camera list's buckets, the shadow list's, the late list's.
const SLOTS: u64 = 3 * BUCKETS as u64;

/// One group of instances as the culling shader reads it (`Group` in cull.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct GroupUniform {
    /// Object-space bounding sphere of its meshes: centre, radius (m).
    pub sphere: [f32; 4],
    /// Mean element area (m², object space; 0 = no LOD), 1 when instances are the
    /// elements, largest element radius (m), unused.
    pub shape: [f32; 4],
    /// First instance slot, instances, first mesh, meshes.
    pub range: [u32; 4],
}

/// The frame's view as the culling shader reads it (`Params` in cull.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    view_proj: [[f32; 4]; 4],
    cam: [f32; 4],
    lod: [f32; 4],
    counts: [u32; 4],
    occl: [f32; 4],
}

/// Which instances the camera list takes (see the module docs and cull.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Phase {
    /// Every instance in view; the late list empty (single images, light views).
    All,
    /// Occlusion culling, before the camera pass: those in view seen last frame.
    Seen,
    /// Occlusion culling, after the camera pass's first part: the late list, against its
    /// depth pyramid of `levels` levels over a `width x height` target.
    Late {
        width: u32,
        height: u32,
        levels: u32,
    },
}

/// What one frame culls and simplifies for.
#[derive(Clone, Copy, Debug)]
pub(super) struct CullView {
    /// World-to-clip of the camera.
    pub view_proj: Mat4,
    /// Camera position (m).
    pub position: Vec3,
    /// The camera's focal length in pixels of the target.
    pub focal_px: f32,
    /// Projected leaf area (px²) below which leaves thin out; 0 = full detail.
    pub lod_pixels: f32,
    /// Whether the camera list is frustum-culled.
    pub frustum: bool,
    /// For an orthographic view (a light's): pixels per metre, which then replaces
    /// `focal_px` over the distance.
    pub ortho_px_per_m: Option<f32>,
    /// Occlusion culling's phase.
    pub phase: Phase,
}

/// What [`Culling::new`] binds: the geometry's buffers.
pub(super) struct CullingInputs<'a> {
    pub groups: &'a [GroupUniform],
    pub transforms: &'a wgpu::Buffer,
    pub bucket_counts: &'a [u32],
    pub inst_lod: &'a wgpu::Buffer,
    pub lists: &'a wgpu::Buffer,
    /// Instance slots (the shadow list starts there in `lists`).
    pub slots: u32,
    pub meshes: usize,
}

/// The culling pass's pipeline, bindings and draw-argument buffer.
pub(super) struct Culling {
    pipeline: wgpu::ComputePipeline,
    /// Group 0 with the uniforms of phases `All`/`Seen` and of `Late`.
    bind_groups: [wgpu::BindGroup; 2],
    params: [wgpu::Buffer; 2],
    /// Layout of group 1, the depth pyramid ([`super::hiz::HiZ`] binds it).
    pub hiz_layout: wgpu::BindGroupLayout,
    /// Group 1 for phases without a pyramid: a 1-texel stand-in.
    no_hiz: wgpu::BindGroup,
    /// Per mesh, [`SLOTS`] `DrawIndexedIndirectArgs`.
    args: wgpu::Buffer,
    groups: u32,
    slots: u32,
    bytes: u64,
}

impl Culling {
    /// Whether `ctx`'s device can draw from the culling pass's arguments.
    pub fn supported(ctx: &GpuContext) -> bool {
        ctx.device
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
            && ctx
                .adapter
                .get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION)
    }

    /// Compiles the shader and binds `inputs`.
    pub fn new(ctx: &GpuContext, inputs: CullingInputs<'_>) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let module = ctx.compile_wgsl("cull.wgsl", &super::cull_wgsl())?;
        let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let mut uniform = super::layout::uniform_entry(0);
        uniform.visibility = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("culling"),
            entries: &[
                uniform,
                storage(1, true),
                storage(2, true),
                storage(3, true),
                storage(4, false),
                storage(5, false),
                storage(6, false),
                storage(7, false),
            ],
        });
        let hiz_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("depth pyramid"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Texture {
                    sample_type: super::layout::UNFILTERED,
                    view_dimension: super::layout::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let pipeline = ctx.validated("building the culling pipeline", || {
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("culling"),
                bind_group_layouts: &[Some(&layout), Some(&hiz_layout)],
                immediate_size: 0,
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("culling"),
                layout: Some(&pl),
                module: &module,
                entry_point: Some("cull"),
                compilation_options: Default::default(),
                cache: None,
            })
        })?;
        use wgpu::util::DeviceExt;
        // Storage bindings may not be empty.
        let padded = |v: &[u8]| -> Vec<u8> {
            if v.is_empty() {
                vec![0; 64]
            } else {
                v.to_vec()
            }
        };
        let groups = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("culling groups"),
            contents: &padded(bytemuck::cast_slice(inputs.groups)),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let counts = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("bucket index counts"),
            contents: &padded(bytemuck::cast_slice(inputs.bucket_counts)),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("draw arguments"),
            size: (inputs.meshes.max(1) as u64) * SLOTS * ARGS_BYTES,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        // Nothing was seen before the first frame.
        let visible = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("visible last frame"),
            size: inputs.slots.max(1) as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let params =
            [0, 1].map(|_| uniform_buffer(device, "culling view", std::mem::size_of::<Params>()));
        let bind_groups = params.each_ref().map(|params| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("culling"),
                layout: &layout,
                entries: &[
                    buffer_entry(0, params),
                    buffer_entry(1, &groups),
                    buffer_entry(2, inputs.transforms),
                    buffer_entry(3, &counts),
                    buffer_entry(4, inputs.inst_lod),
                    buffer_entry(5, inputs.lists),
                    buffer_entry(6, &args),
                    buffer_entry(7, &visible),
                ],
            })
        });
        let stand_in = super::layout::texture_2d(
            device,
            "no depth pyramid",
            (1, 1, 1),
            wgpu::TextureFormat::R32Float,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let no_hiz = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("no depth pyramid"),
            layout: &hiz_layout,
            entries: &[super::layout::view_entry(
                0,
                &stand_in.create_view(&Default::default()),
            )],
        });
        Ok(Culling {
            pipeline,
            bind_groups,
            hiz_layout,
            no_hiz,
            bytes: groups.size()
                + counts.size()
                + args.size()
                + 2 * params[0].size()
                + visible.size(),
            params,
            args,
            groups: inputs.groups.len() as u32,
            slots: inputs.slots,
        })
    }

    /// Bytes of the buffers this pass owns.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// The argument buffer and the offset of mesh `mesh`'s [`BUCKETS`] draws for `list`.
    pub fn args(&self, mesh: usize, list: DrawList) -> (&wgpu::Buffer, u64) {
        let part = match list {
            DrawList::Camera => 0,
            DrawList::Shadow => BUCKETS as u64,
            DrawList::Late => 2 * BUCKETS as u64,
        };
        (&self.args, (mesh as u64 * SLOTS + part) * ARGS_BYTES)
    }

    /// Records the pass for `view` (its uniforms are written through `queue`, so record
    /// one culling pass of phase `All` or `Seen` and one of `Late` at most per
    /// submission); `hiz` is the camera's depth pyramid for phase `Late`.
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        view: &CullView,
        hiz: Option<&wgpu::BindGroup>,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        if self.groups == 0 {
            return;
        }
        let per_row = self.groups.min(65_535);
        let params = Params {
            view_proj: view.view_proj.to_cols_array_2d(),
            cam: view.position.extend(view.focal_px).to_array(),
            lod: [
                view.lod_pixels.max(0.0),
                if view.frustum { 1.0 } else { 0.0 },
                lod::min_fraction(),
                view.ortho_px_per_m.unwrap_or(0.0).max(0.0),
            ],
            counts: [self.groups, self.slots, per_row, 0],
            occl: match view.phase {
                Phase::All => [0.0; 4],
                Phase::Seen => [1.0, 0.0, 0.0, 0.0],
                Phase::Late {
                    width,
                    height,
                    levels,
                } => [2.0, width as f32, height as f32, levels as f32],
            },
        };
        let k = usize::from(matches!(view.phase, Phase::Late { .. }));
        queue.write_buffer(&self.params[k], 0, bytemuck::bytes_of(&params));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("culling"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_groups[k], &[]);
        pass.set_bind_group(1, hiz.unwrap_or(&self.no_hiz), &[]);
        pass.dispatch_workgroups(per_row, self.groups.div_ceil(per_row), 1);
    }

    /// Triangles the last frame's culling passes made the camera (both of its lists) and
    /// the light views draw (reads the arguments back, waiting for the GPU: for tests and
    /// benchmarks).
    pub fn drawn_triangles(&self, ctx: &GpuContext) -> Result<[u64; 2], GpuError> {
        let raw = super::readback::read_buffer(ctx, &self.args)?;
        let words: &[u32] = bytemuck::cast_slice(&raw);
        let mut out = [0u64; 2];
        for (k, a) in words.chunks_exact(5).enumerate() {
            // Camera, shadow, late: the late list counts for the camera.
            let list = ((k as u64 % SLOTS) / BUCKETS as u64) % 2;
            out[list as usize] += a[0] as u64 / 3 * a[1] as u64;
        }
        Ok(out)
    }
}
