//! Upload of the scene's geometry: every mesh (world meshes, then each prototype's meshes
//! with the range of its instances) as an interleaved vertex buffer and an index buffer,
//! one shared buffer of instance transforms, and the draw calls of every pass.

use crate::error::GpuError;
use glam::{Affine3A, Vec3};
use lamina_scene::{Mesh, Scene};
use std::ops::Range;
use wgpu::util::DeviceExt;

/// Interleaved vertex: position (m), normal, uv.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    pos: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
}

/// Vertex attributes 0-2: position, normal, uv ([`Vertex`]).
const VERTEX_ATTRS: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2];
/// Instance attributes 3-6: the columns of the instance's affine transform.
const INSTANCE_ATTRS: [wgpu::VertexAttribute; 4] =
    wgpu::vertex_attr_array![3 => Float32x3, 4 => Float32x3, 5 => Float32x3, 6 => Float32x3];

/// The vertex buffer layouts of the scene shader: slot 0 per vertex, slot 1 per instance.
pub(super) fn vertex_layouts() -> [Option<wgpu::VertexBufferLayout<'static>>; 2] {
    [
        Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &VERTEX_ATTRS,
        }),
        Some(wgpu::VertexBufferLayout {
            array_stride: 48,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &INSTANCE_ATTRS,
        }),
    ]
}

/// One mesh on the GPU.
struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    material: usize,
    /// Range in the instance buffer (the identity at 0 for plain meshes).
    instances: Range<u32>,
}

/// The scene's meshes and instance transforms on the GPU, in draw order.
pub(super) struct Geometry {
    meshes: Vec<GpuMesh>,
    /// Affine transforms, 12 floats each (columns); index 0 is the identity.
    instances: wgpu::Buffer,
    /// Triangles drawn per pass, instances counted.
    pub triangles: u64,
}

impl Geometry {
    /// Checks and uploads the meshes of `scene` (errors name the mesh or instance).
    pub fn upload(device: &wgpu::Device, scene: &Scene) -> Result<Self, GpuError> {
        let limit = device.limits().max_buffer_size;
        let materials = scene.materials.len();
        let mut up = Uploader {
            device,
            limit,
            materials,
            triangles: 0,
            meshes: Vec::new(),
        };
        let mut instance_data: Vec<[f32; 12]> = vec![affine_cols(&Affine3A::IDENTITY)];
        for (i, m) in scene.meshes.iter().enumerate() {
            up.mesh(m, format!("mesh {i}"), 0..1)?;
        }
        for (p, proto) in scene.prototypes.iter().enumerate() {
            let start = instance_data.len() as u32;
            instance_data.extend(
                scene
                    .instances
                    .iter()
                    .filter(|inst| inst.prototype as usize == p)
                    .map(|inst| affine_cols(&inst.transform)),
            );
            let range = start..instance_data.len() as u32;
            for (k, m) in proto.meshes.iter().enumerate() {
                up.mesh(
                    m,
                    format!("prototype '{}' mesh {k}", proto.name),
                    range.clone(),
                )?;
            }
        }
        check_instances(scene)?;
        let instances = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("instances"),
            contents: bytemuck::cast_slice(&instance_data),
            usage: wgpu::BufferUsages::VERTEX,
        });
        Ok(Geometry {
            meshes: up.meshes,
            instances,
            triangles: up.triangles,
        })
    }

    /// Bytes of the vertex, index and instance buffers.
    pub fn bytes(&self) -> u64 {
        self.instances.size()
            + self
                .meshes
                .iter()
                .map(|m| m.vertices.size() + m.indices.size())
                .sum::<u64>()
    }

    /// Draws every mesh into `pass` (whose pipeline and group 0 are set), binding each
    /// mesh's material from `materials` as group 1.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>, materials: &[wgpu::BindGroup]) {
        pass.set_vertex_buffer(1, self.instances.slice(..));
        for m in &self.meshes {
            pass.set_bind_group(1, &materials[m.material], &[]);
            pass.set_vertex_buffer(0, m.vertices.slice(..));
            pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..m.index_count, 0, m.instances.clone());
        }
    }
}

/// Uploads meshes one by one, counting triangles.
struct Uploader<'a> {
    device: &'a wgpu::Device,
    /// Largest buffer the device allows (bytes).
    limit: u64,
    /// Materials in the scene.
    materials: usize,
    triangles: u64,
    meshes: Vec<GpuMesh>,
}

impl Uploader<'_> {
    /// Checks `m` (called `what` in errors) and uploads it, drawn for `instances`; empty
    /// meshes and meshes without instances are skipped.
    fn mesh(&mut self, m: &Mesh, what: String, instances: Range<u32>) -> Result<(), GpuError> {
        if m.indices.is_empty() || m.positions.is_empty() || instances.is_empty() {
            return Ok(());
        }
        check_mesh(m, &what, self.materials)?;
        let verts = vertices_of(m);
        let vbytes = (verts.len() * std::mem::size_of::<Vertex>()) as u64;
        if vbytes > self.limit {
            return Err(GpuError::BufferTooLarge {
                what: format!("{what}'s vertex buffer"),
                bytes: vbytes,
                limit: self.limit,
            });
        }
        self.triangles += m.indices.len() as u64 * (instances.end - instances.start) as u64;
        let device = self.device;
        self.meshes.push(GpuMesh {
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("vertices"),
                contents: bytemuck::cast_slice(&verts),
                usage: wgpu::BufferUsages::VERTEX,
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("indices"),
                contents: bytemuck::cast_slice(&m.indices),
                usage: wgpu::BufferUsages::INDEX,
            }),
            index_count: (m.indices.len() * 3) as u32,
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

/// The mesh's vertices; without per-vertex normals, area-weighted face normals.
fn vertices_of(m: &Mesh) -> Vec<Vertex> {
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
        .map(|i| Vertex {
            pos: m.positions[i].to_array(),
            normal: normals[i].to_array(),
            uv: m.uvs.get(i).map_or([0.0, 0.0], |u| u.to_array()),
        })
        .collect()
}

/// The transform's columns (three axes, then the translation), 12 floats.
fn affine_cols(t: &Affine3A) -> [f32; 12] {
    let m = t.matrix3;
    let c = [m.x_axis, m.y_axis, m.z_axis, t.translation];
    let mut out = [0.0; 12];
    for (k, v) in c.iter().enumerate() {
        out[3 * k..3 * k + 3].copy_from_slice(&v.to_array());
    }
    out
}
