//! Scene builders shared by the renderer's tests: cards, spheres, films, cameras, options,
//! the small canopy, and instanced / flattened twins of it.

use crate::RenderOptions;
use glam::{Affine3A, Quat, Vec2, Vec3};
use lamina_core::{
    Camera, ColorInput, Film, Instance, Integrator, Light, Material, Mesh, PixelFilter, Prototype,
    Scene, Sky, ToneMap,
};
use std::f32::consts::PI;

/// A `2·half` square card in the plane `z = z0`, front (counter-clockwise) facing `+z`,
/// UVs over `[0, 1]²` with `u` along `+x`.
pub(crate) fn card(half: f32, z0: f32, material: u32) -> Mesh {
    Mesh {
        positions: vec![
            Vec3::new(-half, -half, z0),
            Vec3::new(half, -half, z0),
            Vec3::new(half, half, z0),
            Vec3::new(-half, half, z0),
        ],
        normals: vec![],
        tangents: Vec::new(),
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
    }
}

/// A `w x h` film with `spp` samples, box filter, no exposure, clamping tone map.
pub(crate) fn film(w: u32, h: u32, spp: u32) -> Film {
    Film {
        width: w,
        height: h,
        spp,
        filter: PixelFilter::Box,
        exposure: 0.0,
        tonemap: ToneMap::Clamp,
        spectral: lamina_core::SpectralMode::Rgb,
    }
}

/// A pinhole camera on the `+z` axis at height `z`, looking at the origin, `+y` up.
pub(crate) fn camera_at(z: f32, fov_deg: f32) -> Camera {
    Camera {
        position: Vec3::new(0.0, 0.0, z),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        fov_deg,
        aperture_radius: 0.0,
        focus_distance: 1.0,
    }
}

/// An opaque Lambertian material of grey reflectance `r`.
pub(crate) fn diffuse(r: f32) -> Material {
    Material::Diffuse {
        name: "d".into(),
        reflectance: ColorInput::Constant(Vec3::splat(r)),
        alpha: None,
    }
}

/// A Lambertian reflector and transmitter, reflectance `r`, transmittance `t`.
pub(crate) fn diffuse_transmission(r: Vec3, t: Vec3) -> Material {
    Material::DiffuseTransmission {
        name: "dt".into(),
        reflectance: ColorInput::Constant(r),
        transmittance: ColorInput::Constant(t),
        alpha: None,
    }
}

/// Render options: `spp` samples on `threads` threads, seed 7.
pub(crate) fn opts(spp: u32, threads: usize) -> RenderOptions {
    RenderOptions {
        spp: Some(spp),
        threads: Some(threads),
        seed: 7,
        ..Default::default()
    }
}

/// A delta sun (zero diameter) toward `direction`, `irradiance` W m⁻² on all channels.
pub(crate) fn sun(direction: Vec3, irradiance: f32) -> Light {
    Light::Sun {
        direction,
        irradiance: Vec3::splat(irradiance),
        angular_diameter_deg: 0.0,
    }
}

/// Twelve crossing cards (two materials) under a sun, a quad, a sphere and a point light
/// and a constant sky, with a Gaussian filter: a little of everything.
pub(crate) fn small_canopy_scene() -> Scene {
    let mut meshes = Vec::new();
    for i in 0..12 {
        let mut m = card(0.3, 0.0, (i % 2) as u32);
        let a = i as f32 * 0.9;
        for p in &mut m.positions {
            let q = Vec3::new(p.x * a.cos(), p.y, p.x * a.sin() + p.y * 0.3);
            *p = q + Vec3::new(
                (i as f32 * 0.37).sin() * 0.6,
                (i as f32 * 0.61).cos() * 0.6,
                0.0,
            );
        }
        meshes.push(m);
    }
    Scene {
        radiometry: Default::default(),
        camera: camera_at(3.0, 50.0),
        film: Film {
            filter: PixelFilter::Gaussian {
                radius: 1.5,
                sigma: 0.5,
            },
            ..film(40, 30, 8)
        },
        integrator: Integrator::Path {
            max_depth: 6,
            rr_depth: 2,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![
            Light::Sun {
                direction: Vec3::new(0.3, 1.0, 0.5),
                irradiance: Vec3::splat(500.0),
                angular_diameter_deg: 0.53,
            },
            Light::Quad {
                corner: Vec3::new(-1.0, 1.5, -1.0),
                edge_u: Vec3::new(2.0, 0.0, 0.0),
                edge_v: Vec3::new(0.0, 0.0, 2.0),
                radiance: Vec3::splat(5.0),
                two_sided: false,
            },
            Light::Sphere {
                center: Vec3::new(1.0, -1.0, 1.0),
                radius: 0.2,
                radiance: Vec3::new(20.0, 10.0, 5.0),
            },
            Light::Point {
                position: Vec3::new(-1.0, 0.0, 1.5),
                intensity: Vec3::splat(3.0),
            },
        ],
        sky: Some(Sky::Constant(Vec3::new(0.2, 0.3, 0.5))),
        materials: vec![
            diffuse_transmission(Vec3::new(0.1, 0.3, 0.05), Vec3::new(0.1, 0.4, 0.05)),
            diffuse(0.6),
        ],
        meshes,
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// `mesh` seen from `z = 4` (24 x 24, 8 spp, path tracing) with materials 0 (diffuse 0.5)
/// and 1 (diffuse transmission 0.3 / 0.4).
pub(crate) fn sphere_scene(mesh: Mesh, lights: Vec<Light>, sky: Option<Sky>) -> Scene {
    Scene {
        radiometry: Default::default(),
        camera: camera_at(4.0, 40.0),
        film: film(24, 24, 8),
        integrator: Integrator::Path {
            max_depth: 4,
            rr_depth: 2,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights,
        sky,
        materials: vec![
            diffuse(0.5),
            diffuse_transmission(Vec3::splat(0.3), Vec3::splat(0.4)),
        ],
        meshes: vec![mesh],
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// A UV sphere of `stacks x slices` quads (triangle fans at the poles are degenerate and
/// dropped by the BVH build), wound counter-clockwise seen from outside. With `smooth` its
/// vertex normals are the analytic ones, `(p - center) / radius`; otherwise it has none.
pub(crate) fn uv_sphere(
    center: Vec3,
    radius: f32,
    stacks: u32,
    slices: u32,
    smooth: bool,
    material: u32,
) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=stacks {
        let th = PI * i as f32 / stacks as f32;
        for j in 0..=slices {
            let ph = 2.0 * PI * j as f32 / slices as f32;
            let n = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            positions.push(center + radius * n);
            normals.push(n);
        }
    }
    let at = |i: u32, j: u32| i * (slices + 1) + j;
    let mut indices = Vec::new();
    for i in 0..stacks {
        for j in 0..slices {
            for mut t in [
                [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
            ] {
                let p = t.map(|k| positions[k as usize]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                if n.dot(p[0] + p[1] + p[2] - 3.0 * center) < 0.0 {
                    t.swap(1, 2);
                }
                indices.push(t);
            }
        }
    }
    Mesh {
        tangents: Vec::new(),
        uvs: positions
            .iter()
            .enumerate()
            .map(|(k, _)| {
                let (i, j) = (k as u32 / (slices + 1), k as u32 % (slices + 1));
                Vec2::new(j as f32 / slices as f32, 1.0 - i as f32 / stacks as f32)
            })
            .collect(),
        positions,
        normals: if smooth { normals } else { Vec::new() },
        indices,
        material,
    }
}

/// `mesh` with every triangle given its own three vertices, with vertex normals equal to
/// the triangle's geometric normal (`Some`) or none.
pub(crate) fn faceted(mesh: &Mesh, with_normals: bool) -> Mesh {
    let mut out = Mesh {
        positions: Vec::new(),
        normals: Vec::new(),
        tangents: Vec::new(),
        uvs: Vec::new(),
        indices: Vec::new(),
        material: mesh.material,
    };
    for t in &mesh.indices {
        let p = t.map(|k| mesh.positions[k as usize]);
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let base = out.positions.len() as u32;
        for k in 0..3 {
            out.positions.push(p[k]);
            out.uvs.push(mesh.uvs[t[k] as usize]);
            if with_normals {
                out.normals.push(n);
            }
        }
        out.indices.push([base, base + 1, base + 2]);
    }
    out
}

/// `mesh` moved to world space by `m` the way scene loaders flatten transformed meshes:
/// positions transformed, winding reversed when `m` mirrors (front faces stay in front).
pub(crate) fn flatten(mesh: &Mesh, m: Affine3A) -> Mesh {
    let mut out = mesh.clone();
    for p in &mut out.positions {
        *p = m.transform_point3(*p);
    }
    if m.matrix3.determinant() < 0.0 {
        for t in &mut out.indices {
            t.swap(1, 2);
        }
    }
    out
}

/// The test placements: a rotation, a rotation with non-uniform scale, and a mirror.
pub(crate) fn test_transforms() -> Vec<Affine3A> {
    vec![
        Affine3A::from_rotation_translation(
            Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.3),
            Vec3::new(-0.9, 0.1, -0.5),
        ),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(1.6, 0.5, 0.8),
            Quat::from_rotation_z(0.4) * Quat::from_rotation_y(-1.1),
            Vec3::new(0.8, -0.3, 0.2),
        ),
        Affine3A::from_scale_rotation_translation(
            Vec3::new(-1.0, 1.0, 1.0),
            Quat::from_rotation_y(0.5),
            Vec3::new(0.1, 0.6, -0.8),
        ),
    ]
}

/// [`small_canopy_scene`] with its cards as one prototype placed by `transforms`, and the
/// same scene flattened into world-space meshes.
pub(crate) fn instanced_and_flat(transforms: &[Affine3A]) -> (Scene, Scene) {
    let base = small_canopy_scene();
    let mut inst = base.clone();
    inst.meshes = Vec::new();
    inst.prototypes = vec![Prototype {
        name: "cards".into(),
        meshes: base.meshes.clone(),
    }];
    inst.instances = transforms
        .iter()
        .map(|&transform| Instance {
            prototype: 0,
            transform,
        })
        .collect();
    // A ground card in world space, shared by both.
    let ground = {
        let mut g = card(3.0, 0.0, 1);
        for p in &mut g.positions {
            *p = Vec3::new(p.x, -1.2, p.y);
        }
        g.indices = vec![[0, 2, 1], [0, 3, 2]]; // facing +y
        g
    };
    inst.meshes.push(ground.clone());
    let mut flat = base;
    flat.meshes = transforms
        .iter()
        .flat_map(|&m| flat.meshes.iter().map(move |mesh| flatten(mesh, m)))
        .collect();
    flat.meshes.push(ground);
    (inst, flat)
}
