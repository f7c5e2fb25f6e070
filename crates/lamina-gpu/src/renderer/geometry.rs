//! Upload of the scene's geometry and the draw calls of every pass.
//!
//! * **Groups.** Every world mesh is a group with one instance (the identity); every
//!   prototype with instances is a group with its instances. Each instance has a slot in
//!   one storage buffer of transforms, a group's slots contiguous.
//! * **Meshes.** One interleaved vertex buffer (position, normal, uv, and the level of
//!   detail's element centre and rank, [`super::lod`]) and one index buffer per mesh,
//!   elements of foliage meshes in rank order.
//! * **Draws.** Per frame, [`super::culling`] (on the GPU) picks each instance's leaves
//!   and writes three draw lists (camera: frustum-culled, and with occlusion culling those
//!   seen last frame; shadow: every instance; late: in view, not hidden, not drawn yet)
//!   and one indirect draw per mesh, list and LOD bucket; a pass then draws each mesh with one
//!   `multi_draw_indexed_indirect`. The vertex shader finds its instance through the list
//!   (`instance_index` = the draw's first instance + k). On a device without indirect first
//!   instances, every instance of a mesh is drawn directly, at full detail (the lists then
//!   hold the identity).

use super::culling::{Culling, CullingInputs, GroupUniform};
use super::layout::buffer_entry;
use super::lod::{self, BUCKETS, LodMesh};
use crate::context::GpuContext;
use crate::error::GpuError;
use glam::{Affine3A, Vec3};
use lamina_scene::{Mesh, Scene};
use std::ops::Range;
use wgpu::util::DeviceExt;

/// Interleaved vertex, 36 bytes: position (m, object space, f32), unit normal (snorm16,
/// w = 0), uv (f32), and the level of detail's (half floats): the offset from the vertex to
/// its element's centre (m) and the element's rank ([`LodMesh::lod`]). The offset keeps
/// half precision relative to a leaf's size, and is 0 where nothing is scaled.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    pos: [f32; 3],
    normal: [i16; 4],
    uv: [f32; 2],
    lod: [u16; 4],
}

/// Vertex attributes 0-3: position, normal, uv, LOD ([`Vertex`]).
const VERTEX_ATTRS: [wgpu::VertexAttribute; 4] = wgpu::vertex_attr_array![
    0 => Float32x3, 1 => Snorm16x4, 2 => Float32x2, 3 => Float16x4
];

/// The vertex buffer layout of the scene shader (instances come from storage buffers).
pub(super) fn vertex_layouts() -> [Option<wgpu::VertexBufferLayout<'static>>; 1] {
    [Some(wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRS,
    })]
}

/// Which instances a pass draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum DrawList {
    /// Those the camera sees (frustum-culled).
    Camera,
    /// Every instance (light views).
    Shadow,
    /// With occlusion culling, those in view that the depth pyramid of the camera pass's
    /// first part does not hide and that it did not draw (drawn in its second part).
    Late,
}

/// One mesh on the GPU.
struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    material: usize,
    /// Its group's instance slots.
    instances: Range<u32>,
}

/// The scene's meshes and instances on the GPU, in draw order.
pub(super) struct Geometry {
    meshes: Vec<GpuMesh>,
    /// Group 2 of every scene pipeline: transforms, per-instance LOD and the draw lists.
    pub layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    /// Buffers the per-frame culling pass reads and writes; `None` on devices without
    /// indirect first instances.
    pub culling: Option<Culling>,
    /// Bytes of every geometry buffer.
    bytes: u64,
    /// Triangles drawn per pass at full detail, instances counted.
    pub triangles: u64,
    /// Leaf elements (instances counted) that level of detail may thin out.
    pub lod_elements: u64,
}

/// A storage buffer entry (read-only in the vertex stage).
fn vertex_storage(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl Geometry {
    /// Checks and uploads the meshes of `scene` (errors name the mesh or instance).
    pub fn upload(ctx: &GpuContext, scene: &Scene) -> Result<Self, GpuError> {
        let device = &ctx.device;
        check_instances(scene)?;
        let limits = device.limits();
        let mut up = Uploader {
            device,
            limit: limits.max_buffer_size,
            scene,
            triangles: 0,
            lod_elements: 0,
            bytes: 0,
            meshes: Vec::new(),
            groups: Vec::new(),
            bucket_counts: Vec::new(),
            transforms: Vec::new(),
        };
        for (i, m) in scene.meshes.iter().enumerate() {
            up.group(&[(m, format!("mesh {i}"))], &[Affine3A::IDENTITY])?;
        }
        for (p, proto) in scene.prototypes.iter().enumerate() {
            let placed: Vec<Affine3A> = scene
                .instances
                .iter()
                .filter(|inst| inst.prototype as usize == p)
                .map(|inst| inst.transform)
                .collect();
            let meshes: Vec<(&Mesh, String)> = proto
                .meshes
                .iter()
                .enumerate()
                .map(|(k, m)| (m, format!("prototype '{}' mesh {k}", proto.name)))
                .collect();
            up.group(&meshes, &placed)?;
        }
        let slots = up.transforms.len().max(1) as u64;
        let storage_limit = limits.max_storage_buffer_binding_size;
        let instance_bytes = slots * 64;
        if instance_bytes > storage_limit {
            return Err(GpuError::BufferTooLarge {
                what: format!("the {slots} instance transforms"),
                bytes: instance_bytes,
                limit: storage_limit,
            });
        }
        if up.transforms.is_empty() {
            up.transforms.push([[0.0; 4]; 4]);
        }
        let storage = wgpu::BufferUsages::STORAGE;
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let transforms = init(
            "instance transforms",
            bytemuck::cast_slice(&up.transforms),
            storage,
        );
        // Until culling runs (or where it cannot): full detail, lists = every slot.
        let inst_lod = init(
            "instance lod",
            bytemuck::cast_slice(&vec![[1.0f32, 1.0]; slots as usize]),
            storage,
        );
        let identity: Vec<u32> = (0..3).flat_map(|_| 0..slots as u32).collect();
        let lists = init("draw lists", bytemuck::cast_slice(&identity), storage);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("instances"),
            entries: &[vertex_storage(0), vertex_storage(1), vertex_storage(2)],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("instances"),
            layout: &layout,
            entries: &[
                buffer_entry(0, &transforms),
                buffer_entry(1, &inst_lod),
                buffer_entry(2, &lists),
            ],
        });
        let mut bytes = up.bytes + transforms.size() + inst_lod.size() + lists.size();
        let culling = if Culling::supported(ctx) {
            let c = Culling::new(
                ctx,
                CullingInputs {
                    groups: &up.groups,
                    transforms: &transforms,
                    bucket_counts: &up.bucket_counts,
                    inst_lod: &inst_lod,
                    lists: &lists,
                    slots: slots as u32,
                    meshes: up.meshes.len(),
                },
            )?;
            bytes += c.bytes();
            Some(c)
        } else {
            None
        };
        Ok(Geometry {
            meshes: up.meshes,
            layout,
            bind_group,
            culling,
            bytes,
            triangles: up.triangles,
            lod_elements: up.lod_elements,
        })
    }

    /// Bytes of the vertex, index, instance, draw-list and draw-argument buffers.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Draws every mesh into `pass` (whose pipeline and group 0 are set), binding each
    /// mesh's material from `materials` as group 1, the instances of `list`.
    pub fn draw(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        materials: &[wgpu::BindGroup],
        list: DrawList,
    ) {
        pass.set_bind_group(2, &self.bind_group, &[]);
        for (k, m) in self.meshes.iter().enumerate() {
            pass.set_bind_group(1, &materials[m.material], &[]);
            pass.set_vertex_buffer(0, m.vertices.slice(..));
            pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint32);
            match &self.culling {
                Some(c) => {
                    let (buffer, offset) = c.args(k, list);
                    pass.multi_draw_indexed_indirect(buffer, offset, BUCKETS as u32);
                }
                None if list == DrawList::Late => {}
                None => pass.draw_indexed(0..m.index_count, 0, m.instances.clone()),
            }
        }
    }
}

/// Uploads groups of meshes one by one, counting triangles.
struct Uploader<'a> {
    device: &'a wgpu::Device,
    /// Largest buffer the device allows (bytes).
    limit: u64,
    scene: &'a Scene,
    triangles: u64,
    lod_elements: u64,
    bytes: u64,
    meshes: Vec<GpuMesh>,
    groups: Vec<GroupUniform>,
    /// Per mesh, [`BUCKETS`] index counts.
    bucket_counts: Vec<u32>,
    /// Instance transforms: columns, w unused.
    transforms: Vec<[[f32; 4]; 4]>,
}

impl Uploader<'_> {
    /// Checks and uploads `meshes` (each with its name for errors) drawn at `placed`;
    /// empty meshes are skipped, as is a group without instances.
    fn group(&mut self, meshes: &[(&Mesh, String)], placed: &[Affine3A]) -> Result<(), GpuError> {
        let meshes: Vec<&(&Mesh, String)> = meshes
            .iter()
            .filter(|(m, _)| !m.indices.is_empty() && !m.positions.is_empty())
            .collect();
        if meshes.is_empty() || placed.is_empty() {
            return Ok(());
        }
        let materials = &self.scene.materials;
        for (m, what) in &meshes {
            check_mesh(m, what, materials.len())?;
        }
        let sphere = bounding_sphere(meshes.iter().map(|(m, _)| *m));
        let foliage = |m: &Mesh| lod::is_foliage(&materials[m.material as usize]);
        let mut prepared: Vec<LodMesh> = meshes
            .iter()
            .map(|(m, _)| {
                if foliage(m) {
                    lod::prepare(m)
                } else {
                    lod::plain(m)
                }
            })
            .collect();
        let elements: u64 = prepared.iter().map(|l| l.elements as u64).sum();
        let instances = placed.len() as u64;
        // Area (m²) and radius (m) of one element, and whether instances are the elements.
        let (area, radius, whole) = if elements > 0 {
            let a: f64 = prepared.iter().map(|l| l.area as f64).sum();
            let r = prepared
                .iter()
                .map(|l| l.element_radius)
                .fold(0.0, f32::max);
            self.lod_elements += elements * instances;
            ((a / elements as f64) as f32, r, false)
        } else if placed.len() >= lod::MIN_ELEMENTS && meshes.iter().all(|(m, _)| foliage(m)) {
            // One small foliage piece placed many times: each instance is an element.
            prepared = meshes
                .iter()
                .map(|(m, _)| lod::whole(m, sphere.0))
                .collect();
            let a: f32 = meshes.iter().map(|(m, _)| mesh_area(m)).sum();
            self.lod_elements += instances;
            (a, sphere.1, true)
        } else {
            (0.0, 0.0, false)
        };
        let start = self.transforms.len() as u32;
        self.transforms.extend(placed.iter().map(affine_cols));
        let slots = start..self.transforms.len() as u32;
        self.groups.push(GroupUniform {
            sphere: sphere.0.extend(sphere.1).to_array(),
            shape: [area, if whole { 1.0 } else { 0.0 }, radius, 0.0],
            range: [
                slots.start,
                slots.end - slots.start,
                self.meshes.len() as u32,
                meshes.len() as u32,
            ],
        });
        for ((m, what), l) in meshes.iter().zip(prepared) {
            self.mesh(m, what, l, slots.clone())?;
        }
        Ok(())
    }

    /// Uploads one checked mesh, prepared as `l`, drawn for `instances`.
    fn mesh(
        &mut self,
        m: &Mesh,
        what: &str,
        l: LodMesh,
        instances: Range<u32>,
    ) -> Result<(), GpuError> {
        let verts = vertices_of(m, &l.lod);
        let vbytes = (verts.len() * std::mem::size_of::<Vertex>()) as u64;
        if vbytes > self.limit {
            return Err(GpuError::BufferTooLarge {
                what: format!("{what}'s vertex buffer"),
                bytes: vbytes,
                limit: self.limit,
            });
        }
        self.triangles += m.indices.len() as u64 * (instances.end - instances.start) as u64;
        self.bucket_counts.extend_from_slice(&l.bucket_counts);
        let device = self.device;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("vertices"),
            contents: bytemuck::cast_slice(&verts),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("indices"),
            contents: bytemuck::cast_slice(&l.indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        self.bytes += vertices.size() + indices.size();
        self.meshes.push(GpuMesh {
            vertices,
            indices,
            index_count: l.indices.len() as u32,
            material: m.material as usize,
            instances,
        });
        Ok(())
    }
}

/// A mesh's material and indices must exist.
fn check_mesh(m: &Mesh, what: &str, materials: usize) -> Result<(), GpuError> {
    if m.material as usize >= materials {
        return Err(GpuError::Scene(format!(
            "{what} uses material {} but the scene has {materials}",
            m.material,
        )));
    }
    if let Some(bad) = m
        .indices
        .iter()
        .flatten()
        .find(|&&i| i as usize >= m.positions.len())
    {
        return Err(GpuError::Scene(format!(
            "{what} has index {bad} but only {} vertices",
            m.positions.len()
        )));
    }
    Ok(())
}

/// Every instance's prototype must exist.
fn check_instances(scene: &Scene) -> Result<(), GpuError> {
    if let Some(bad) = scene
        .instances
        .iter()
        .find(|i| i.prototype as usize >= scene.prototypes.len())
    {
        return Err(GpuError::Scene(format!(
            "an instance uses prototype {} but the scene has {}",
            bad.prototype,
            scene.prototypes.len()
        )));
    }
    Ok(())
}

/// A sphere around every vertex of `meshes`: the box's centre, the farthest vertex.
fn bounding_sphere<'m>(meshes: impl Iterator<Item = &'m Mesh> + Clone) -> (Vec3, f32) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in meshes.clone().flat_map(|m| &m.positions) {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let c = 0.5 * (lo + hi);
    let r = meshes
        .flat_map(|m| &m.positions)
        .map(|p| p.distance(c))
        .fold(0.0, f32::max);
    (c, r)
}

/// Total triangle area of `m` (m²).
fn mesh_area(m: &Mesh) -> f32 {
    m.indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// The mesh's vertices with their LOD attributes; without per-vertex normals,
/// area-weighted face normals.
fn vertices_of(m: &Mesh, lod: &[[f32; 4]]) -> Vec<Vertex> {
    use super::half::f32_to_half;
    let snorm = |x: f32| (x.clamp(-1.0, 1.0) * 32767.0).round() as i16;
    let n = m.positions.len();
    let normals: Vec<Vec3> = if m.normals.len() == n {
        m.normals.clone()
    } else {
        // Area-weighted face normals (counter-clockwise = adaxial).
        let mut acc = vec![Vec3::ZERO; n];
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO));
            let f = (b - a).cross(c - a);
            for &i in t {
                if let Some(x) = acc.get_mut(i as usize) {
                    *x += f;
                }
            }
        }
        acc.iter().map(|v| v.normalize_or(Vec3::Z)).collect()
    };
    (0..n)
        .map(|i| {
            let [cx, cy, cz, rank] = lod[i];
            // Rank -1: never scaled, no centre needed (an offset of exactly 0).
            let offset = if rank == -1.0 {
                Vec3::ZERO
            } else {
                Vec3::new(cx, cy, cz) - m.positions[i]
            };
            let n = normals[i];
            Vertex {
                pos: m.positions[i].to_array(),
                normal: [snorm(n.x), snorm(n.y), snorm(n.z), 0],
                uv: m.uvs.get(i).map_or([0.0, 0.0], |u| u.to_array()),
                lod: [offset.x, offset.y, offset.z, rank].map(f32_to_half),
            }
        })
        .collect()
}

/// The transform's columns (three axes, then the translation), w unused.
fn affine_cols(t: &Affine3A) -> [[f32; 4]; 4] {
    let m = t.matrix3;
    [m.x_axis, m.y_axis, m.z_axis, t.translation].map(|v| Vec3::from(v).extend(0.0).to_array())
}
