//! The renderer: uploads a [`Scene`] once, then draws frames. Per frame, three passes
//! (plus the optional tone-map pass for windows and screenshots):
//!
//! 1. **Light view, layer 1** (`fs_shadow_first`): the sun's orthographic view of every
//!    alpha-tested surface: depth `d1` of the nearest and its diffuse transmittance `c1`.
//! 2. **Light view, layer 2** (`fs_shadow_peel`): depth peeling: the nearest surface behind
//!    layer 1, `d2` and `c2`. Together a two-layer translucent shadow map: sunlight reaches
//!    a point unattenuated, through one leaf (`c1`), or through two (`c1 c2`), each leaf's
//!    share scaled by the form factor `a² / (a² + d²)` of its card (radius `a`) seen from
//!    `d` behind it, since a leaf passes light on diffusely.
//! 3. **Camera** (`fs_main`): every mesh and instance with the alpha test, shaded with the
//!    baked leaf model ([`crate::bake`]), the sun through the transmittance map, unshadowed
//!    point and extra directional lights, and the SH sky ([`crate::sky`]). Output: linear
//!    radiance in an RGBA16F target.
//!
//! Area lights (quads, spheres) become point lights at their centre with the same power
//! toward the scene (an approximation that holds away from the light). Only the first sun
//! casts shadows. Determinism: the same scene and view give the same image on the same
//! device and driver (no randomness, fixed draw order).

use crate::bake::{self, BakedMaterial, LUT_LAYERS, LUT_N, MaterialUniform, MipMap};
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::sky;
use glam::{Affine3A, Mat4, Vec3};
use lamina_image::Image;
use lamina_scene::{Camera, Light, Mesh, Scene, Sky};
use wgpu::util::DeviceExt;

/// The scene shader (light-view and camera passes).
pub const SCENE_WGSL: &str = include_str!("shaders/scene.wgsl");
/// The tone-map and overlay shader.
pub const POST_WGSL: &str = include_str!("shaders/post.wgsl");

const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Transmittance maps: rgb = diffuse transmittance of the occluder, a = its card radius (m).
const SHADOW_COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Overlay text texture size (pixels).
pub const OVERLAY_SIZE: (u32, u32) = (512, 24);
const MAX_LIGHTS: usize = 8;

/// Quality settings.
#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    /// Side of the sun's shadow and transmittance maps, in texels.
    pub shadow_map_size: u32,
    /// Supersampling factor per axis for [`Renderer::render_image`] (box-filtered down).
    pub supersample: u32,
    /// Directions (0-16) of the sky-visibility maps baked at load time: how much of the
    /// sky each surface sees, and through how many leaves. 0 leaves sky light unshadowed.
    pub sky_directions: u32,
    /// Side of each sky-visibility map, in texels.
    pub sky_map_size: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            shadow_map_size: 2048,
            supersample: 2,
            sky_directions: 16,
            sky_map_size: 512,
        }
    }
}

/// What changes from frame to frame: the camera, the sun and the image size.
#[derive(Clone, Copy, Debug)]
pub struct FrameView {
    /// The camera (horizontal field of view, as in the scene file).
    pub camera: Camera,
    /// Direction toward the shadowed sun; `None` keeps the scene's first sun.
    pub sun_dir: Option<Vec3>,
    /// Target width in pixels.
    pub width: u32,
    /// Target height in pixels.
    pub height: u32,
}

/// One light in the uniform block (see `Light` in scene.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuLight {
    pos: [f32; 4],
    color: [f32; 4],
}

/// Per-frame uniforms (see `Globals` in scene.wgsl for the meaning and units).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    light_view_proj: [[f32; 4]; 4],
    camera_pos: [f32; 4],
    sun_dir: [f32; 4],
    sun_irr: [f32; 4],
    shadow: [f32; 4],
    sky: [[f32; 4]; 9],
    lights: [GpuLight; MAX_LIGHTS],
    counts: [u32; 4],
}

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

/// `n` directions spread evenly over the sphere (a Fibonacci lattice, `+y` up), each
/// standing for `4 pi / n` sr of sky.
pub fn sphere_directions(n: usize) -> Vec<Vec3> {
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - (2 * i + 1) as f32 / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

/// World-to-clip matrix of the orthographic light camera looking along `-dir` at the
/// bounding sphere `(c, r)`: the sphere fills the map, depth 0..1 over its diameter.
fn light_matrix(dir: Vec3, c: Vec3, r: f32) -> Mat4 {
    let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
    orthographic(r, r, 3.0 * r) * look_at(c + dir * (2.0 * r), c, up)
}

/// Uniforms of the post pass (see `Post` in post.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PostUniform {
    params: [f32; 4],
    rect: [f32; 4],
}

struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
    material: usize,
    /// Range in the instance buffer (the identity at 0 for plain meshes).
    instances: std::ops::Range<u32>,
}

struct Targets {
    width: u32,
    height: u32,
    hdr: wgpu::Texture,
    hdr_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
}

struct PostPipeline {
    format: wgpu::TextureFormat,
    pipeline: wgpu::RenderPipeline,
}

/// A scene on the GPU, ready to draw frames.
pub struct Renderer {
    ctx: GpuContext,
    settings: RenderSettings,
    meshes: Vec<GpuMesh>,
    instance_buf: wgpu::Buffer,
    material_groups: Vec<wgpu::BindGroup>,
    globals_buf: wgpu::Buffer,
    shadow_first: wgpu::RenderPipeline,
    shadow_peel: wgpu::RenderPipeline,
    main: wgpu::RenderPipeline,
    shadow_bg_first: wgpu::BindGroup,
    shadow_bg_peel: wgpu::BindGroup,
    main_bg: wgpu::BindGroup,
    shadow_views: [wgpu::TextureView; 4],
    sky_textures: [wgpu::Texture; 4],
    sky_buf: wgpu::Buffer,
    bgl_shadow: wgpu::BindGroupLayout,
    targets: Option<Targets>,
    post_layout: wgpu::BindGroupLayout,
    post_module: wgpu::ShaderModule,
    post: Option<PostPipeline>,
    post_buf: wgpu::Buffer,
    overlay_tex: wgpu::Texture,
    overlay_view: wgpu::TextureView,
    /// Scene bounds: centre and radius (m).
    bounds: (Vec3, f32),
    /// The region the sun's and sky's maps cover (see [`caster_bounds`]).
    shadow_bounds: (Vec3, f32),
    base: Scene0,
    warnings: Vec<String>,
    triangles: u64,
}

/// The parts of the scene the frame loop needs (lights, sky, film).
#[derive(Clone, Debug)]
struct Scene0 {
    lights: Vec<Light>,
    sky: [Vec3; 9],
    background: Vec3,
    film: lamina_scene::Film,
    camera: Camera,
}

/// Interleaved vertex: position (m), normal, uv.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    pos: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
}

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

fn affine_cols(t: &Affine3A) -> [f32; 12] {
    let m = t.matrix3;
    let c = [m.x_axis, m.y_axis, m.z_axis, t.translation];
    let mut out = [0.0; 12];
    for (k, v) in c.iter().enumerate() {
        out[3 * k..3 * k + 3].copy_from_slice(&v.to_array());
    }
    out
}

/// Bounding sphere of the scene's geometry (instances included).
fn scene_bounds(scene: &Scene) -> (Vec3, f32) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut add = |p: Vec3| {
        if p.is_finite() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    };
    for m in &scene.meshes {
        m.positions.iter().for_each(|&p| add(p));
    }
    let proto_bounds: Vec<Option<(Vec3, Vec3)>> = scene
        .prototypes
        .iter()
        .map(|p| {
            let mut l = Vec3::splat(f32::INFINITY);
            let mut h = Vec3::splat(f32::NEG_INFINITY);
            for m in &p.meshes {
                for &q in &m.positions {
                    l = l.min(q);
                    h = h.max(q);
                }
            }
            (l.x <= h.x).then_some((l, h))
        })
        .collect();
    for inst in &scene.instances {
        if let Some(Some((l, h))) = proto_bounds.get(inst.prototype as usize) {
            for k in 0..8 {
                let c = Vec3::new(
                    if k & 1 == 0 { l.x } else { h.x },
                    if k & 2 == 0 { l.y } else { h.y },
                    if k & 4 == 0 { l.z } else { h.z },
                );
                add(inst.transform.transform_point3(c));
            }
        }
    }
    if lo.x > hi.x {
        return (Vec3::ZERO, 1.0);
    }
    let c = 0.5 * (lo + hi);
    (c, (0.5 * (hi - lo).length()).max(1e-3))
}

/// Right-handed view matrix: camera at `eye` looking at `center`, `-z` forward.
fn look_at(eye: Vec3, center: Vec3, up: Vec3) -> Mat4 {
    let f = (center - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    Mat4::from_cols(
        glam::Vec4::new(s.x, u.x, -f.x, 0.0),
        glam::Vec4::new(s.y, u.y, -f.y, 0.0),
        glam::Vec4::new(s.z, u.z, -f.z, 0.0),
        glam::Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// Right-handed perspective projection to wgpu's clip space (depth 0 at `near`, 1 at `far`).
fn perspective(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let fy = 1.0 / (0.5 * fov_y).tan();
    let r = far / (near - far);
    Mat4::from_cols(
        glam::Vec4::new(fy / aspect, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, fy, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, r, -1.0),
        glam::Vec4::new(0.0, 0.0, r * near, 0.0),
    )
}

/// Right-handed orthographic projection of the box `[-h, h]^2 x [near, far]` (depth 0..1).
fn orthographic(h: f32, near: f32, far: f32) -> Mat4 {
    let r = 1.0 / (near - far);
    Mat4::from_cols(
        glam::Vec4::new(1.0 / h, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, 1.0 / h, 0.0, 0.0),
        glam::Vec4::new(0.0, 0.0, r, 0.0),
        glam::Vec4::new(0.0, 0.0, near * r, 1.0),
    )
}

/// Bounding sphere of the *shadow casters' core*: per axis, the 0.5th to 99.5th percentile of
/// the vertex positions (instances by their transformed prototype corners, weighted by
/// vertex count). A large ground quad has four vertices, a plant thousands, so the sun's
/// and the sky's maps spend their texels on the plants instead of on the ground's extent.
/// Points outside the maps count as unshadowed.
fn caster_bounds(scene: &Scene) -> (Vec3, f32) {
    let mut pts: Vec<Vec3> = scene
        .meshes
        .iter()
        .flat_map(|m| m.positions.iter().copied())
        .filter(|p| p.is_finite())
        .collect();
    for inst in &scene.instances {
        if let Some(p) = scene.prototypes.get(inst.prototype as usize) {
            for m in &p.meshes {
                // Every 16th vertex is plenty for the percentiles.
                pts.extend(
                    m.positions
                        .iter()
                        .step_by(16)
                        .map(|&q| inst.transform.transform_point3(q)),
                );
            }
        }
    }
    if pts.len() < 16 {
        return scene_bounds(scene);
    }
    let n = pts.len();
    let (lo_i, hi_i) = (n / 200, n - 1 - n / 200);
    let mut lo = Vec3::ZERO;
    let mut hi = Vec3::ZERO;
    for axis in 0..3 {
        let mut v: Vec<f32> = pts.iter().map(|p| p[axis]).collect();
        lo[axis] = *v.select_nth_unstable_by(lo_i, f32::total_cmp).1;
        hi[axis] = *v.select_nth_unstable_by(hi_i, f32::total_cmp).1;
    }
    let c = 0.5 * (lo + hi);
    (c, (0.5 * (hi - lo).length()).max(1e-3))
}

/// World-to-clip matrix of a lamina camera for a `width x height` image (the camera's
/// field of view is horizontal; depth 0..1 between `near` and `far`).
pub fn camera_matrix(camera: &Camera, width: u32, height: u32, near: f32, far: f32) -> Mat4 {
    let aspect = width as f32 / height.max(1) as f32;
    let tan_x = (camera.fov_deg.to_radians() * 0.5).tan();
    let fov_y = 2.0 * (tan_x / aspect).atan();
    let view = look_at(camera.position, camera.look_at, camera.up);
    perspective(fov_y, aspect, near, far) * view
}

fn half_to_f32(h: u16) -> f32 {
    let s = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let e = ((h >> 10) & 0x1f) as i32;
    let m = (h & 0x3ff) as f32;
    match e {
        0 => s * m * 2f32.powi(-24),
        31 => {
            if m == 0.0 {
                s * f32::INFINITY
            } else {
                f32::NAN
            }
        }
        _ => s * (1.0 + m / 1024.0) * 2f32.powi(e - 15),
    }
}

fn f32_to_half(x: f32) -> u16 {
    let b = x.to_bits();
    let sign = ((b >> 16) & 0x8000) as u16;
    let e = ((b >> 23) & 0xff) as i32 - 127 + 15;
    let m = b & 0x7f_ffff;
    if x.is_nan() {
        return 0x7e00;
    }
    if e >= 31 {
        return sign | 0x7c00;
    }
    if e <= 0 {
        if e < -10 {
            return sign;
        }
        let m = (m | 0x80_0000) >> (1 - e);
        return sign | ((m + 0x1000) >> 13) as u16;
    }
    let v = ((e as u32) << 10) | (m >> 13);
    // Round to nearest (ties away), carrying into the exponent if needed.
    let v = v + ((m >> 12) & 1);
    sign | v as u16
}

fn tex_entry(
    binding: u32,
    sample: wgpu::TextureSampleType,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: sample,
            view_dimension: dim,
            multisampled: false,
        },
        count: None,
    }
}

fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

const FLOAT: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: true };
const UNFILTERED: wgpu::TextureSampleType = wgpu::TextureSampleType::Float { filterable: false };
const D2: wgpu::TextureViewDimension = wgpu::TextureViewDimension::D2;

fn upload_mips(
    ctx: &GpuContext,
    label: &str,
    m: &MipMap,
    format: wgpu::TextureFormat,
) -> wgpu::TextureView {
    let tex = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: m.width,
            height: m.height,
            depth_or_array_layers: 1,
        },
        mip_level_count: m.levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let (mut w, mut h) = (m.width, m.height);
    for (level, data) in m.levels.iter().enumerate() {
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: level as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(data),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * w),
                rows_per_image: Some(h),
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        (w, h) = ((w / 2).max(1), (h / 2).max(1));
    }
    tex.create_view(&wgpu::TextureViewDescriptor::default())
}

impl Renderer {
    /// Uploads `scene` (bakes its materials, see [`crate::bake`]) and builds the pipelines.
    pub fn new(
        ctx: &GpuContext,
        scene: &Scene,
        settings: RenderSettings,
    ) -> Result<Self, GpuError> {
        let device = &ctx.device;
        let scene_module = ctx.compile_wgsl("scene.wgsl", SCENE_WGSL)?;
        let post_module = ctx.compile_wgsl("post.wgsl", POST_WGSL)?;

        // --- Materials.
        let bgl_mat = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("material"),
            entries: &[
                tex_entry(0, FLOAT, D2),
                tex_entry(1, FLOAT, D2),
                tex_entry(2, FLOAT, D2),
                tex_entry(3, FLOAT, wgpu::TextureViewDimension::D2Array),
                sampler_entry(4),
                sampler_entry(5),
                uniform_entry(6),
                tex_entry(7, FLOAT, D2),
            ],
        });
        let s_map = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("maps"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let s_lut = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("lut"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        // Card radius per material: the mean area of two of its triangles, as a disc.
        let mut area = vec![(0.0f64, 0usize); scene.materials.len()];
        let mut add_area = |m: &Mesh, scale: f32| {
            if let Some(a) = area.get_mut(m.material as usize) {
                for t in &m.indices {
                    let p = t.map(|i| m.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO));
                    a.0 += (0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length() * scale) as f64;
                    a.1 += 1;
                }
            }
        };
        scene.meshes.iter().for_each(|m| add_area(m, 1.0));
        for inst in &scene.instances {
            if let Some(p) = scene.prototypes.get(inst.prototype as usize) {
                let s = inst.transform.matrix3.determinant().abs().powf(2.0 / 3.0);
                p.meshes.iter().for_each(|m| add_area(m, s));
            }
        }
        let mut warnings = Vec::new();
        let mut material_groups = Vec::new();
        for (mi, m) in scene.materials.iter().enumerate() {
            let mut b: BakedMaterial = bake::bake_material(m, ctx.max_texture_dim);
            let (sum, n) = area[mi];
            b.uniform.shape[0] = if n > 0 {
                (2.0 * sum / n as f64 / std::f64::consts::PI).sqrt() as f32
            } else {
                0.0
            };
            warnings.extend(b.warnings.iter().cloned());
            let group = ctx.validated(&format!("uploading material '{}'", b.name), || {
                let srgb = wgpu::TextureFormat::Rgba8UnormSrgb;
                let front = upload_mips(ctx, "front", &b.front, srgb);
                let back = upload_mips(ctx, "back", &b.back, srgb);
                let trans = upload_mips(ctx, "trans", &b.trans, srgb);
                // Tangent-space normals are stored linearly.
                let normal = upload_mips(ctx, "normal", &b.normal, wgpu::TextureFormat::Rgba8Unorm);
                let lut_half: Vec<u16> = b.lut.iter().flatten().map(|&x| f32_to_half(x)).collect();
                let lut = device.create_texture_with_data(
                    &ctx.queue,
                    &wgpu::TextureDescriptor {
                        label: Some("lut"),
                        size: wgpu::Extent3d {
                            width: LUT_N as u32,
                            height: LUT_N as u32,
                            depth_or_array_layers: LUT_LAYERS as u32,
                        },
                        mip_level_count: 1,
                        sample_count: 1,
                        dimension: wgpu::TextureDimension::D2,
                        format: wgpu::TextureFormat::Rgba16Float,
                        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                        view_formats: &[],
                    },
                    wgpu::util::TextureDataOrder::LayerMajor,
                    bytemuck::cast_slice(&lut_half),
                );
                let lut_view = lut.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2Array),
                    ..Default::default()
                });
                let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("material uniform"),
                    contents: bytemuck::bytes_of::<MaterialUniform>(&b.uniform),
                    usage: wgpu::BufferUsages::UNIFORM,
                });
                device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&b.name),
                    layout: &bgl_mat,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::TextureView(&front),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::TextureView(&back),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: wgpu::BindingResource::TextureView(&trans),
                        },
                        wgpu::BindGroupEntry {
                            binding: 3,
                            resource: wgpu::BindingResource::TextureView(&lut_view),
                        },
                        wgpu::BindGroupEntry {
                            binding: 4,
                            resource: wgpu::BindingResource::Sampler(&s_map),
                        },
                        wgpu::BindGroupEntry {
                            binding: 5,
                            resource: wgpu::BindingResource::Sampler(&s_lut),
                        },
                        wgpu::BindGroupEntry {
                            binding: 6,
                            resource: ubuf.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 7,
                            resource: wgpu::BindingResource::TextureView(&normal),
                        },
                    ],
                })
            })?;
            material_groups.push(group);
        }

        // --- Geometry.
        let limit = device.limits().max_buffer_size;
        let mut triangles = 0u64;
        let mut instance_data: Vec<[f32; 12]> = vec![affine_cols(&Affine3A::IDENTITY)];
        let mut meshes = Vec::new();
        let mut upload_mesh = |m: &Mesh,
                               what: String,
                               instances: std::ops::Range<u32>|
         -> Result<Option<GpuMesh>, GpuError> {
            if m.indices.is_empty() || m.positions.is_empty() || instances.is_empty() {
                return Ok(None);
            }
            if m.material as usize >= scene.materials.len() {
                return Err(GpuError::Scene(format!(
                    "{what} uses material {} but the scene has {}",
                    m.material,
                    scene.materials.len()
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
            let verts = vertices_of(m);
            let vbytes = (verts.len() * std::mem::size_of::<Vertex>()) as u64;
            if vbytes > limit {
                return Err(GpuError::BufferTooLarge {
                    what: format!("{what}'s vertex buffer"),
                    bytes: vbytes,
                    limit,
                });
            }
            triangles += m.indices.len() as u64 * (instances.end - instances.start) as u64;
            Ok(Some(GpuMesh {
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
            }))
        };
        for (i, m) in scene.meshes.iter().enumerate() {
            if let Some(g) = upload_mesh(m, format!("mesh {i}"), 0..1)? {
                meshes.push(g);
            }
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
                if let Some(g) = upload_mesh(
                    m,
                    format!("prototype '{}' mesh {k}", proto.name),
                    range.clone(),
                )? {
                    meshes.push(g);
                }
            }
        }
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
        let instance_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("instances"),
            contents: bytemuck::cast_slice(&instance_data),
            usage: wgpu::BufferUsages::VERTEX,
        });

        // --- Shadow maps.
        let size = settings.shadow_map_size.clamp(16, ctx.max_texture_dim);
        let mk = |label: &str, format: wgpu::TextureFormat| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d {
                        width: size,
                        height: size,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                        | wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                })
                .create_view(&wgpu::TextureViewDescriptor::default())
        };
        let shadow_views = [
            mk("shadow d1", DEPTH_FORMAT),
            mk("shadow d2", DEPTH_FORMAT),
            mk("shadow c1", SHADOW_COLOR_FORMAT),
            mk("shadow c2", SHADOW_COLOR_FORMAT),
        ];
        let globals_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let sky_size = settings.sky_map_size.clamp(16, ctx.max_texture_dim);
        let sky_layers = settings.sky_directions.clamp(1, MAX_SKY_DIRS as u32);
        let mk_array = |label: &str, format: wgpu::TextureFormat| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: sky_size,
                    height: sky_size,
                    depth_or_array_layers: sky_layers,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
        };
        let sky_textures = [
            mk_array("sky d1", DEPTH_FORMAT),
            mk_array("sky d2", DEPTH_FORMAT),
            mk_array("sky c1", SHADOW_COLOR_FORMAT),
            mk_array("sky c2", SHADOW_COLOR_FORMAT),
        ];
        let sky_array_views = sky_textures.each_ref().map(|t| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            })
        });
        let sky_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sky visibility"),
            size: std::mem::size_of::<SkyVis>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let depth_tex = wgpu::TextureSampleType::Depth;
        let d2a = wgpu::TextureViewDimension::D2Array;
        let bgl_shadow = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow globals"),
            entries: &[uniform_entry(0), tex_entry(1, depth_tex, D2)],
        });
        let bgl_main = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("main globals"),
            entries: &[
                uniform_entry(0),
                tex_entry(1, depth_tex, D2),
                tex_entry(2, depth_tex, D2),
                tex_entry(3, UNFILTERED, D2),
                tex_entry(4, UNFILTERED, D2),
                uniform_entry(5),
                tex_entry(6, depth_tex, d2a),
                tex_entry(7, depth_tex, d2a),
                tex_entry(8, UNFILTERED, d2a),
                tex_entry(9, UNFILTERED, d2a),
            ],
        });
        fn view_entry(binding: u32, v: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: wgpu::BindingResource::TextureView(v),
            }
        }
        let shadow_bg = |d: &wgpu::TextureView| {
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("shadow globals"),
                layout: &bgl_shadow,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: globals_buf.as_entire_binding(),
                    },
                    view_entry(1, d),
                ],
            })
        };
        // Layer 1 binds d2 only because the layout wants a depth texture; it reads none.
        let shadow_bg_first = shadow_bg(&shadow_views[1]);
        let shadow_bg_peel = shadow_bg(&shadow_views[0]);
        let main_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("main globals"),
            layout: &bgl_main,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: globals_buf.as_entire_binding(),
                },
                view_entry(1, &shadow_views[0]),
                view_entry(2, &shadow_views[1]),
                view_entry(3, &shadow_views[2]),
                view_entry(4, &shadow_views[3]),
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: sky_buf.as_entire_binding(),
                },
                view_entry(6, &sky_array_views[0]),
                view_entry(7, &sky_array_views[1]),
                view_entry(8, &sky_array_views[2]),
                view_entry(9, &sky_array_views[3]),
            ],
        });

        // --- Pipelines.
        let vertex_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2];
        let instance_attrs = wgpu::vertex_attr_array![3 => Float32x3, 4 => Float32x3, 5 => Float32x3, 6 => Float32x3];
        let buffers = [
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &vertex_attrs,
            }),
            Some(wgpu::VertexBufferLayout {
                array_stride: 48,
                step_mode: wgpu::VertexStepMode::Instance,
                attributes: &instance_attrs,
            }),
        ];
        let pipeline = |label: &str,
                        bgl0: &wgpu::BindGroupLayout,
                        vs: &str,
                        fs: &str,
                        color: wgpu::TextureFormat| {
            let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(bgl0), Some(&bgl_mat)],
                immediate_size: 0,
            });
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &scene_module,
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
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &scene_module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let (shadow_first, shadow_peel, main) =
            ctx.validated("building the render pipelines", || {
                (
                    pipeline(
                        "shadow layer 1",
                        &bgl_shadow,
                        "vs_shadow",
                        "fs_shadow_first",
                        SHADOW_COLOR_FORMAT,
                    ),
                    pipeline(
                        "shadow layer 2",
                        &bgl_shadow,
                        "vs_shadow",
                        "fs_shadow_peel",
                        SHADOW_COLOR_FORMAT,
                    ),
                    pipeline("camera", &bgl_main, "vs_main", "fs_main", HDR_FORMAT),
                )
            })?;

        // --- Post.
        let post_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("post"),
            entries: &[
                tex_entry(0, UNFILTERED, D2),
                uniform_entry(1),
                tex_entry(2, UNFILTERED, D2),
            ],
        });
        let post_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("post"),
            size: std::mem::size_of::<PostUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let overlay_tex = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("overlay"),
            size: wgpu::Extent3d {
                width: OVERLAY_SIZE.0,
                height: OVERLAY_SIZE.1,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let overlay_view = overlay_tex.create_view(&Default::default());

        // --- Lights and sky.
        let sky_sh = sky::sky_irradiance_sh(scene.sky.as_ref());
        let background = match &scene.sky {
            None => Vec3::ZERO,
            Some(Sky::Constant(c)) => *c,
            // The mean radiance: SH band 0 is E = pi * mean.
            Some(Sky::Image { .. }) => sky_sh[0] * 0.282_095 / std::f32::consts::PI,
        };
        let mut renderer = Renderer {
            ctx: ctx.clone(),
            settings,
            meshes,
            instance_buf,
            material_groups,
            globals_buf,
            shadow_first,
            shadow_peel,
            main,
            shadow_bg_first,
            shadow_bg_peel,
            main_bg,
            shadow_views,
            sky_textures,
            sky_buf,
            bgl_shadow,
            targets: None,
            post_layout,
            post_module,
            post: None,
            post_buf,
            overlay_tex,
            overlay_view,
            bounds: scene_bounds(scene),
            shadow_bounds: caster_bounds(scene),
            base: Scene0 {
                lights: scene.lights.clone(),
                sky: sky_sh,
                background,
                film: scene.film,
                camera: scene.camera,
            },
            warnings,
            triangles,
        };
        renderer.bake_sky_visibility()?;
        Ok(renderer)
    }

    /// Renders the sky-visibility maps (once: geometry and sky are static): for each of
    /// [`RenderSettings::sky_directions`] directions over the sphere, the same two-layer
    /// depth and transmittance maps as the sun's.
    fn bake_sky_visibility(&mut self) -> Result<(), GpuError> {
        let n = (self.settings.sky_directions as usize).min(MAX_SKY_DIRS);
        let dirs = sphere_directions(n);
        let (c, r) = self.shadow_bounds;
        let size = self.sky_textures[0].width();
        let mut vis = SkyVis {
            view_proj: [[[0.0; 4]; 4]; MAX_SKY_DIRS],
            dir: [[0.0; 4]; MAX_SKY_DIRS],
            params: [n as f32, size as f32, 2.0 * r / size as f32, 2.0 * r],
        };
        let device = self.ctx.device.clone();
        let mut encoder = device.create_command_encoder(&Default::default());
        let layer_view = |t: &wgpu::Texture, k: usize| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(D2),
                base_array_layer: k as u32,
                array_layer_count: Some(1),
                ..Default::default()
            })
        };
        for (k, d) in dirs.iter().enumerate() {
            let m = light_matrix(*d, c, r);
            vis.view_proj[k] = m.to_cols_array_2d();
            vis.dir[k] = d.extend(0.0).to_array();
            let mut g = self.globals(&FrameView {
                camera: self.base.camera,
                sun_dir: None,
                width: 1,
                height: 1,
            });
            g.light_view_proj = m.to_cols_array_2d();
            let buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("sky direction"),
                contents: bytemuck::bytes_of(&g),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let views = self.sky_textures.each_ref().map(|t| layer_view(t, k));
            for layer in 0..2 {
                let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("sky direction"),
                    layout: &self.bgl_shadow,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: buf.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            // Layer 1 reads nothing; layer 2 peels behind layer 1's depth.
                            resource: wgpu::BindingResource::TextureView(&views[1 - layer]),
                        },
                    ],
                });
                let pipeline = if layer == 0 {
                    &self.shadow_first
                } else {
                    &self.shadow_peel
                };
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("sky visibility"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &views[2 + layer],
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::WHITE),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: &views[layer],
                        depth_ops: Some(wgpu::Operations {
                            load: wgpu::LoadOp::Clear(1.0),
                            store: wgpu::StoreOp::Store,
                        }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &bg, &[]);
                self.draw_all(&mut pass);
            }
        }
        self.ctx
            .queue
            .write_buffer(&self.sky_buf, 0, bytemuck::bytes_of(&vis));
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        self.ctx.queue.submit([encoder.finish()]);
        match pollster::block_on(scope.pop()) {
            None => Ok(()),
            Some(e) => Err(GpuError::Validation {
                what: "baking the sky-visibility maps".into(),
                message: e.to_string(),
            }),
        }
    }

    /// Messages about the upload (downscaled maps); empty when all went as asked.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Triangles drawn per camera pass (instances counted).
    pub fn triangles(&self) -> u64 {
        self.triangles
    }

    /// Scene bounding sphere (centre, radius in m).
    pub fn bounds(&self) -> (Vec3, f32) {
        self.bounds
    }

    /// The scene's camera, film and first sun direction (toward the sun), for viewers.
    pub fn scene_view(&self) -> (Camera, lamina_scene::Film, Option<Vec3>) {
        let sun = self.base.lights.iter().find_map(|l| match l {
            Light::Sun { direction, .. } => Some(*direction),
            _ => None,
        });
        (self.base.camera, self.base.film, sun)
    }

    /// The GPU context.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    fn globals(&self, view: &FrameView) -> Globals {
        let (c, r) = self.bounds;
        let dist = (view.camera.position - c).length();
        let far = (dist + r) * 1.01;
        let near = (dist - r).max(far * 1e-4).max(1e-4);
        let view_proj = camera_matrix(&view.camera, view.width, view.height, near, far);
        let mut lights = [GpuLight::default(); MAX_LIGHTS];
        let mut n = 0usize;
        let mut sun: Option<(Vec3, Vec3)> = None;
        for l in &self.base.lights {
            let entry = match l {
                Light::Sun {
                    direction,
                    irradiance,
                    ..
                } => {
                    if sun.is_none() {
                        let d = view.sun_dir.unwrap_or(*direction).normalize_or(Vec3::Y);
                        sun = Some((d, *irradiance));
                        continue;
                    }
                    GpuLight {
                        pos: [direction.x, direction.y, direction.z, 0.0],
                        color: irradiance.extend(0.0).to_array(),
                    }
                }
                Light::Point {
                    position,
                    intensity,
                } => GpuLight {
                    pos: position.extend(1.0).to_array(),
                    color: intensity.extend(0.0).to_array(),
                },
                // A one-sided quad of radiance L and area A emits intensity L A cos toward
                // its normal; as a point light we use L A (the on-axis value).
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                    ..
                } => GpuLight {
                    pos: (*corner + 0.5 * (*edge_u + *edge_v)).extend(1.0).to_array(),
                    color: (*radiance * edge_u.cross(*edge_v).length())
                        .extend(0.0)
                        .to_array(),
                },
                // A sphere of radius R and radiance L has intensity L pi R^2 in every
                // direction.
                Light::Sphere {
                    center,
                    radius,
                    radiance,
                } => GpuLight {
                    pos: center.extend(1.0).to_array(),
                    color: (*radiance * std::f32::consts::PI * radius * radius)
                        .extend(0.0)
                        .to_array(),
                },
            };
            if n < MAX_LIGHTS {
                lights[n] = entry;
                n += 1;
            }
        }
        let size = self
            .settings
            .shadow_map_size
            .clamp(16, self.ctx.max_texture_dim);
        let (sc, sr) = self.shadow_bounds;
        let (sun_dir, sun_irr, light_view_proj) = match sun {
            Some((d, e)) => (d.extend(1.0), e.extend(0.0), light_matrix(d, sc, sr)),
            None => (Vec3::Y.extend(0.0), Vec3::ZERO.extend(0.0), Mat4::IDENTITY),
        };
        let mut sky = [[0.0; 4]; 9];
        for (s, v) in sky.iter_mut().zip(self.base.sky) {
            *s = v.extend(0.0).to_array();
        }
        Globals {
            view_proj: view_proj.to_cols_array_2d(),
            light_view_proj: light_view_proj.to_cols_array_2d(),
            camera_pos: view.camera.position.extend(1.0).to_array(),
            sun_dir: sun_dir.to_array(),
            sun_irr: sun_irr.to_array(),
            shadow: [size as f32, 2.0 * sr / size as f32, 2.0 * sr, 0.0],
            sky,
            lights,
            counts: [n as u32, 0, 0, 0],
        }
    }

    fn ensure_targets(&mut self, width: u32, height: u32) {
        if self
            .targets
            .as_ref()
            .is_some_and(|t| t.width == width && t.height == height)
        {
            return;
        }
        let device = &self.ctx.device;
        let mk = |label: &str, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let hdr = mk(
            "hdr",
            HDR_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = mk(
            "depth",
            DEPTH_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        self.targets = Some(Targets {
            width,
            height,
            hdr_view: hdr.create_view(&Default::default()),
            hdr,
            depth_view: depth.create_view(&Default::default()),
        });
    }

    fn draw_all<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>) {
        pass.set_vertex_buffer(1, self.instance_buf.slice(..));
        for m in &self.meshes {
            pass.set_bind_group(1, &self.material_groups[m.material], &[]);
            pass.set_vertex_buffer(0, m.vertices.slice(..));
            pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..m.index_count, 0, m.instances.clone());
        }
    }

    /// Records the three scene passes for `view` into `encoder`, rendering into the
    /// internal HDR target (resized to the view).
    pub fn encode_scene(&mut self, encoder: &mut wgpu::CommandEncoder, view: &FrameView) {
        self.ensure_targets(view.width, view.height);
        let globals = self.globals(view);
        self.ctx
            .queue
            .write_buffer(&self.globals_buf, 0, bytemuck::bytes_of(&globals));
        let white = wgpu::Operations {
            load: wgpu::LoadOp::Clear(wgpu::Color::WHITE),
            store: wgpu::StoreOp::Store,
        };
        let depth_ops = Some(wgpu::Operations {
            load: wgpu::LoadOp::Clear(1.0),
            store: wgpu::StoreOp::Store,
        });
        let has_sun = globals.sun_dir[3] > 0.5;
        for (layer, (pipeline, bg)) in [
            (&self.shadow_first, &self.shadow_bg_first),
            (&self.shadow_peel, &self.shadow_bg_peel),
        ]
        .into_iter()
        .enumerate()
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("light view"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &self.shadow_views[2 + layer],
                    depth_slice: None,
                    resolve_target: None,
                    ops: white,
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.shadow_views[layer],
                    depth_ops,
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if has_sun {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, bg, &[]);
                self.draw_all(&mut pass);
            }
        }
        let t = self.targets.as_ref().expect("targets were just made");
        let bg = self.base.background;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("camera"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &t.hdr_view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: bg.x as f64,
                        g: bg.y as f64,
                        b: bg.z as f64,
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &t.depth_view,
                depth_ops,
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.main);
        pass.set_bind_group(0, &self.main_bg, &[]);
        self.draw_all(&mut pass);
    }

    /// Renders the scene's own camera at the film size (supersampled, see
    /// [`RenderSettings::supersample`]) and reads back linear radiance.
    pub fn render_image(&mut self) -> Result<Image, GpuError> {
        let film = self.base.film;
        let view = FrameView {
            camera: self.base.camera,
            sun_dir: None,
            width: film.width,
            height: film.height,
        };
        self.render_view_image(&view)
    }

    /// Renders `view` (supersampled) and reads back linear radiance at `view`'s size.
    pub fn render_view_image(&mut self, view: &FrameView) -> Result<Image, GpuError> {
        let ss = self.settings.supersample.max(1);
        let max = self.ctx.max_texture_dim;
        let (w, h) = (view.width * ss, view.height * ss);
        if w > max || h > max {
            return Err(GpuError::Scene(format!(
                "the image ({w}x{h} with {ss}x supersampling) is larger than the GPU's texture \
                 limit of {max}; lower the film size"
            )));
        }
        let big = FrameView {
            width: w,
            height: h,
            ..*view
        };
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_scene(&mut encoder, &big);
        let hdr = &self.targets.as_ref().expect("made by encode_scene").hdr;
        let raw = read_texture(&self.ctx, encoder, hdr, w, h, 8)?;
        let mut pixels = vec![Vec3::ZERO; (view.width * view.height) as usize];
        let row = (w * 8) as usize;
        let norm = 1.0 / (ss * ss) as f32;
        for y in 0..view.height {
            for x in 0..view.width {
                let mut acc = Vec3::ZERO;
                for sy in 0..ss {
                    for sx in 0..ss {
                        let o = ((y * ss + sy) as usize) * row + ((x * ss + sx) as usize) * 8;
                        let c = |k: usize| {
                            half_to_f32(u16::from_le_bytes([raw[o + 2 * k], raw[o + 2 * k + 1]]))
                        };
                        acc += Vec3::new(c(0), c(1), c(2));
                    }
                }
                pixels[(y * view.width + x) as usize] = acc * norm;
            }
        }
        Ok(Image {
            width: view.width,
            height: view.height,
            pixels,
        })
    }

    /// Records the tone-map pass (exposure and operator of `film`, identical to the PNG
    /// output of the offline renderer) from the HDR target into `target` (an sRGB format
    /// so the store applies the sRGB curve), with `overlay` (R8, [`OVERLAY_SIZE`], 1 =
    /// text) in the top-left corner when given.
    pub fn encode_post(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        film: &lamina_scene::Film,
        overlay: Option<&[u8]>,
    ) -> Result<(), GpuError> {
        if self.post.as_ref().is_none_or(|p| p.format != format) {
            let ctx = self.ctx.clone();
            let pipeline = ctx.validated("building the tone-map pipeline", || {
                let layout = ctx
                    .device
                    .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: Some("post"),
                        bind_group_layouts: &[Some(&self.post_layout)],
                        immediate_size: 0,
                    });
                ctx.device
                    .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                        label: Some("tonemap"),
                        layout: Some(&layout),
                        vertex: wgpu::VertexState {
                            module: &self.post_module,
                            entry_point: Some("vs_full"),
                            compilation_options: Default::default(),
                            buffers: &[],
                        },
                        primitive: Default::default(),
                        depth_stencil: None,
                        multisample: Default::default(),
                        fragment: Some(wgpu::FragmentState {
                            module: &self.post_module,
                            entry_point: Some("fs_tonemap"),
                            compilation_options: Default::default(),
                            targets: &[Some(format.into())],
                        }),
                        multiview_mask: None,
                        cache: None,
                    })
            })?;
            self.post = Some(PostPipeline { format, pipeline });
        }
        let t = self.targets.as_ref().ok_or_else(|| GpuError::Validation {
            what: "tone mapping".into(),
            message: "no frame was rendered yet".into(),
        })?;
        let op = match film.tonemap {
            lamina_scene::ToneMap::Clamp => 0.0,
            lamina_scene::ToneMap::Aces => 1.0,
            lamina_scene::ToneMap::Reinhard => 2.0,
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
            self.ctx.queue.write_texture(
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
        self.ctx.queue.write_buffer(
            &self.post_buf,
            0,
            bytemuck::bytes_of(&PostUniform {
                params: [exposure, op, 0.0, 0.0],
                rect,
            }),
        );
        let bg = self
            .ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("post"),
                layout: &self.post_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&t.hdr_view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: self.post_buf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&self.overlay_view),
                    },
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
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.post.as_ref().expect("made above").pipeline);
        pass.set_bind_group(0, &bg, &[]);
        pass.draw(0..3, 0..1);
        Ok(())
    }

    /// Renders `view` at 1x, tone-maps it with `film` and the overlay, and returns sRGB
    /// RGBA8 rows (for window screenshots).
    pub fn render_screenshot(
        &mut self,
        view: &FrameView,
        film: &lamina_scene::Film,
        overlay: Option<&[u8]>,
    ) -> Result<Vec<u8>, GpuError> {
        let format = wgpu::TextureFormat::Rgba8UnormSrgb;
        let tex = self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("screenshot"),
            size: wgpu::Extent3d {
                width: view.width,
                height: view.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_scene(&mut encoder, view);
        self.encode_post(
            &mut encoder,
            &tex.create_view(&Default::default()),
            format,
            film,
            overlay,
        )?;
        read_texture(&self.ctx, encoder, &tex, view.width, view.height, 4)
    }

    /// Renders `view` without reading it back and waits for the GPU: one frame's work,
    /// for timing.
    pub fn render_and_wait(&mut self, view: &FrameView) -> Result<(), GpuError> {
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_scene(&mut encoder, view);
        self.ctx.queue.submit([encoder.finish()]);
        self.ctx
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        Ok(())
    }
}

/// Submits `encoder` plus a copy of `tex` (`width x height`, `bpp` bytes per texel) and
/// returns the tightly packed rows.
fn read_texture(
    ctx: &GpuContext,
    mut encoder: wgpu::CommandEncoder,
    tex: &wgpu::Texture,
    width: u32,
    height: u32,
    bpp: u32,
) -> Result<Vec<u8>, GpuError> {
    let row = width * bpp;
    let padded = row.div_ceil(256) * 256;
    let buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: (padded * height) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: tex,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buf,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    ctx.queue.submit([encoder.finish()]);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Validation {
            what: "rendering the frame".into(),
            message: e.to_string(),
        });
    }
    let (tx, rx) = std::sync::mpsc::channel();
    buf.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let data = buf
        .get_mapped_range(..)
        .map_err(|e| GpuError::Readback(format!("{e:?}")))?;
    let mut out = Vec::with_capacity((row * height) as usize);
    for y in 0..height as usize {
        out.extend_from_slice(&data[y * padded as usize..y * padded as usize + row as usize]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projections_map_near_and_far_to_0_and_1() {
        let p = perspective(1.0, 1.5, 0.1, 10.0);
        let z = |d: f32| {
            let c = p * glam::Vec4::new(0.0, 0.0, -d, 1.0);
            c.z / c.w
        };
        assert!(z(0.1).abs() < 1e-5 && (z(10.0) - 1.0).abs() < 1e-5);
        let o = orthographic(2.0, 1.0, 3.0);
        let c = o * glam::Vec4::new(2.0, -2.0, -3.0, 1.0);
        assert!(
            (c - glam::Vec4::new(1.0, -1.0, 1.0, 1.0))
                .abs()
                .max_element()
                < 1e-6
        );
        // The camera looks down -z at its target, +x to the right.
        let v = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y);
        assert!((v.transform_point3(Vec3::ZERO) - Vec3::new(0.0, 0.0, -5.0)).length() < 1e-6);
        assert!(v.transform_vector3(Vec3::X).x > 0.99);
    }

    #[test]
    fn half_floats_round_trip() {
        for x in [0.0f32, 1.0, 0.5, 0.3, 3.0, 1e-3, 65000.0, -2.5] {
            let y = half_to_f32(f32_to_half(x));
            assert!((x - y).abs() <= x.abs() * 1e-3 + 1e-7, "{x} -> {y}");
        }
    }
}
