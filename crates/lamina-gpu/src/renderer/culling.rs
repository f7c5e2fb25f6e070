//! The per-frame culling and level-of-detail pass on the GPU (`shaders/cull.wgsl`): one
//! compute dispatch, one workgroup per group of instances, that gives every instance the
//! fraction of its leaves kept ([`super::lod`]), writes the camera's draw list (instances
//! whose bounding sphere, grown by what LOD enlarges, meets the view frustum) and the
//! light views' (every instance drawn), and the indirect draw arguments of every mesh per
//! list and LOD bucket. Nothing comes back to the CPU: the passes draw from those
//! arguments ([`super::geometry::Geometry::draw`]).
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
/// Argument slots per mesh: the camera list's buckets, then the shadow list's.
const SLOTS: u64 = 2 * BUCKETS as u64;

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
    bind_group: wgpu::BindGroup,
    params: wgpu::Buffer,
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
            ],
        });
        let pipeline = ctx.validated("building the culling pipeline", || {
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("culling"),
                bind_group_layouts: &[Some(&layout)],
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
        let params = uniform_buffer(device, "culling view", std::mem::size_of::<Params>());
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("culling"),
            layout: &layout,
            entries: &[
                buffer_entry(0, &params),
                buffer_entry(1, &groups),
                buffer_entry(2, inputs.transforms),
                buffer_entry(3, &counts),
                buffer_entry(4, inputs.inst_lod),
                buffer_entry(5, inputs.lists),
                buffer_entry(6, &args),
            ],
        });
        Ok(Culling {
            pipeline,
            bind_group,
            bytes: groups.size() + counts.size() + args.size() + params.size(),
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
        let half = match list {
            DrawList::Camera => 0,
            DrawList::Shadow => BUCKETS as u64,
        };
        (&self.args, (mesh as u64 * SLOTS + half) * ARGS_BYTES)
    }

    /// Records the pass for `view` (its uniforms are written through `queue`, so record
    /// one culling pass per submission).
    pub fn encode(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        view: &CullView,
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
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("culling"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.dispatch_workgroups(per_row, self.groups.div_ceil(per_row), 1);
    }

    /// Triangles the last culling pass made the camera and the light views draw
    /// (reads the arguments back, waiting for the GPU: for tests and benchmarks).
    pub fn drawn_triangles(&self, ctx: &GpuContext) -> Result<[u64; 2], GpuError> {
        let raw = super::readback::read_buffer(ctx, &self.args)?;
        let words: &[u32] = bytemuck::cast_slice(&raw);
        let mut out = [0u64; 2];
        for (k, a) in words.chunks_exact(5).enumerate() {
            let list = (k as u64 % SLOTS) / BUCKETS as u64;
            out[list as usize] += a[0] as u64 / 3 * a[1] as u64;
        }
        Ok(out)
    }
}
